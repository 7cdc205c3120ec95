// `autonomsim report RUN_DIR`: one self-contained HTML file that replays a finished run in the
// browser, opened from disk with no network: the track to scale with its zone boxes and obstacles,
// the cars over time (time slider, play/pause, speed, trails), each intersection coloured by who
// holds it and who is queued, the events on a timeline (a click seeks there), time plots synced to
// the slider (speed, lateral error, commands, CPU load and end-to-end latency of each board), the
// expectations with their verdicts (each failure links to its instant), and for a car with a board
// its camera images with the lane detection drawn in at each failing instant.
//
// The page is built from sim/results/report/ (report.html, report.css, report.js and the vendored
// uPlot, a 50 KB MIT-licensed time-series plotting library), embedded in the program at build
// time; the run's data travels inside the page as one JSON block (ReportData).
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

#include "sim/results/finished_run.h"

namespace autonomsim::sim {

struct ReportOptions {
  int max_snapshots{6};  // camera snapshots: at most this many failing instants
};

// The page's data: {meta, floor, track, obstacles, cars, trajectory, events, expectations,
// boards, snapshots}; the keys are the page's (report.js) and documented there.
nlohmann::json ReportData(const FinishedRun& run, const ReportOptions& options = {});

// The page: the template with its styles, scripts and `data` inlined.
std::string ReportHtml(const nlohmann::json& data);

// For pages built from a template with their data inlined (this report, a sweep's index.html):
// `json` as text that may stand inside a <script> element ("</" written "<\/"), and the one
// occurrence of `placeholder` in `page` replaced (std::logic_error when it has none).
std::string JsonForScript(const nlohmann::json& json);
// Text as XML and HTML take it in content and in quoted attributes (& < > " ' escaped); JUnit
// files use it too.
std::string XmlEscape(std::string_view text);
void ReplacePlaceholder(std::string& page, std::string_view placeholder, std::string_view with);

// What every report carries in its first bytes, so that an earlier report may be replaced
// (CheckOutputFile) and nothing else is.
inline constexpr const char* kReportSignature =
    "<meta name=\"generator\" content=\"autonomsim report\">";

// The report file of a run folder when no --out is given.
inline constexpr const char* kReportFileName = "report.html";

// Reads the run in `run_dir` and writes its report to `out` (empty: RUN_DIR/report.html),
// atomically. ConfigError for a folder that is not a finished run and for an `out` that
// CheckOutputFile refuses (a file this program did not write, unless `force`). Returns the path
// written.
std::filesystem::path WriteReport(const std::filesystem::path& run_dir,
                                  const std::filesystem::path& out = {}, bool force = false,
                                  const ReportOptions& options = {});

}  // namespace autonomsim::sim
