// `autonomsim report` as a user sees it: the file it writes, what it refuses to overwrite, and the
// page in a real browser (Debian's chromium, headless): it loads from a temporary folder with no
// error and no network request, and after seeking the time slider the cars are drawn where
// trajectory.csv has them.
#include "sim/results/report.h"

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "sim/scenario/run_record.h"
#include "tools/tests/cli_testing.h"
#include "vehicle/tests/gl_available.h"

namespace autonomsim {
namespace {

namespace fs = std::filesystem;
using testing::Cli;
using ::testing::HasSubstr;
using testing::Read;
using testing::Result;
using testing::Shell;

// The run the tests share: the default scenario cut to 15 s, with an expectation it fails (a
// lateral error bound tighter than the cars hold), so the report has a failure and snapshots.
Result MakeSharedRun(const fs::path& folder, const std::string& more = "") {
  return Cli(
      "run scenarios/lab_two_cars.yaml -q --set duration_s=15 "
      "--set 'expect=[{max_lateral_error: {max_m: 0.05}}, {no_collision: {}}]' --out " +
      folder.string() + more);
}

// Under ctest this test makes the shared run once, in the folder AUTONOMSIM_REPORT_RUN names (the
// ctest fixture report_run, tools/CMakeLists.txt), and each ReportTest process copies it instead
// of running the scenario again. A process started by hand runs it itself.
TEST(ReportRun, MakeTheSharedRun) {
  const char* folder = std::getenv("AUTONOMSIM_REPORT_RUN");
  if (folder == nullptr) GTEST_SKIP() << "ctest's fixture (AUTONOMSIM_REPORT_RUN is not set)";
  const Result r = MakeSharedRun(folder, " --force");  // a folder of the build's, made by a run
  EXPECT_EQ(r.exit_code, 1) << r.output;               // its expectation fails, on purpose
  EXPECT_TRUE(fs::exists(fs::path(folder) / "summary.json")) << r.output;
}

class ReportTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    // one folder per process: ctest runs these tests in parallel processes, each writing beside
    // its copy of the run
    root_ = new fs::path(fs::path(::testing::TempDir()) /
                         ("autonomsim_report_" + std::to_string(::getpid())));
    fs::remove_all(*root_);
    run_dir_ = new fs::path(*root_ / "run");
    const char* shared = std::getenv("AUTONOMSIM_REPORT_RUN");
    if (shared != nullptr && fs::exists(fs::path(shared) / "summary.json")) {
      fs::create_directories(*root_);
      fs::copy(shared, *run_dir_, fs::copy_options::recursive);
      run_output_ = new std::string("a copy of " + std::string(shared));
    } else {
      run_output_ = new std::string(MakeSharedRun(*run_dir_).output);
    }
  }
  static void TearDownTestSuite() {
    fs::remove_all(*root_);
    delete root_;
    delete run_dir_;
    delete run_output_;
  }
  static fs::path* root_;
  static fs::path* run_dir_;
  static std::string* run_output_;
};
fs::path* ReportTest::root_ = nullptr;
fs::path* ReportTest::run_dir_ = nullptr;
std::string* ReportTest::run_output_ = nullptr;

TEST_F(ReportTest, WritesOneSelfContainedFileBesideTheRun) {
  ASSERT_TRUE(fs::exists(*run_dir_ / "summary.json")) << *run_output_;
  const Result r = Cli("report " + run_dir_->string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const fs::path file = *run_dir_ / "report.html";
  EXPECT_THAT(r.output, HasSubstr("report: " + fs::absolute(file).lexically_normal().string()));
  const std::string html = Read(file);
  EXPECT_THAT(html.substr(0, 4096), HasSubstr(sim::kReportSignature));
  // nothing it would fetch: no address outside the page (uPlot's and our code name none)
  for (const char* fetch : {"src=\"http", "href=\"http", "url(http", "@import"}) {
    EXPECT_EQ(html.find(fetch), std::string::npos) << fetch;
  }
  EXPECT_THAT(html, HasSubstr("default-src 'none'"));  // the page may load nothing at all
  EXPECT_LT(fs::file_size(file), 5u * 1000 * 1000);
}

TEST_F(ReportTest, ReplacesOnlyItsOwnReports) {
  const fs::path elsewhere = *root_ / "notes.html";
  testing::Shell("echo '<p>my notes</p>' > " + elsewhere.string());
  const Result refused = Cli("report " + run_dir_->string() + " --out " + elsewhere.string());
  EXPECT_EQ(refused.exit_code, 2);
  EXPECT_THAT(refused.output, HasSubstr("--force"));
  EXPECT_EQ(Read(elsewhere), "<p>my notes</p>\n");
  EXPECT_EQ(
      Cli("report " + run_dir_->string() + " --out " + elsewhere.string() + " --force").exit_code,
      0);
  // now it is a report: replaced without --force
  EXPECT_EQ(Cli("report " + run_dir_->string() + " --out " + elsewhere.string()).exit_code, 0);
  const Result not_a_run = Cli("report " + elsewhere.parent_path().string());
  EXPECT_EQ(not_a_run.exit_code, 2);
  EXPECT_THAT(not_a_run.output, HasSubstr("not a finished run"));
}

// Issue 33, item 4: report and video drew 13 kinds of damaged run folders without a word (an empty
// trajectory, a wrong header, NaN coordinates, an unknown car, ...). Each is refused, exit 2, at
// the file and line, saying what is wrong.
TEST_F(ReportTest, ADamagedRunFolderIsRefusedAtItsFileAndLine) {
  ASSERT_TRUE(fs::exists(*run_dir_ / "summary.json")) << *run_output_;
  struct Damage {
    std::string name, edit, says;
  };
  const std::vector<Damage> damages = {
      {"empty", ": > trajectory.csv", "trajectory.csv: empty, not even its header"},
      {"header_only", "head -1 trajectory.csv > x && mv x trajectory.csv",
       "trajectory.csv: no rows after the header"},
      {"wrong_header", "sed -i 1s/t_s/time/ trajectory.csv",
       "trajectory.csv:1: not the header a run writes"},
      {"nan", "sed -i '5s/^\\([^,]*\\),\\([^,]*\\),[^,]*,/\\1,\\2,nan,/' trajectory.csv",
       "trajectory.csv:5: not a line a run wrote: column 3 (x_m) is 'nan'"},
      {"unknown_car", "sed -i '5s/^\\([^,]*\\),[^,]*,/\\1,7,/' trajectory.csv",
       "trajectory.csv:5: not a line a run wrote: car 7 is not in the run's scenario (cars 0, 1)"},
      {"backwards", "sed -i '5s/^[^,]*,/0.001,/' trajectory.csv",
       "trajectory.csv:5: not a line a run wrote: t_s 0.001 is before the row above"},
      {"far_off", "sed -i '5s/^\\([^,]*\\),\\([^,]*\\),[^,]*,/\\1,\\2,1e300,/' trajectory.csv",
       "far off the track's floor"},
      {"event_car", "sed -i '1s/\"car\":[0-9]/\"car\":8/' events.jsonl",
       "events.jsonl:1: not a line a run wrote: car 8 is not in the run's scenario"},
      {"no_trajectory", "rm trajectory.csv", "trajectory.csv: no such file"},
  };
  for (const Damage& d : damages) {
    const fs::path copy = *root_ / ("damaged_" + d.name);
    fs::remove_all(copy);
    fs::copy(*run_dir_, copy, fs::copy_options::recursive);
    ASSERT_EQ(Shell("cd " + copy.string() + " && " + d.edit).exit_code, 0) << d.name;
    for (const auto& [command, out] : {std::pair{"report ", "out.html"}, {"video ", "out.mp4"}}) {
      const Result r =
          Cli(command + copy.string() + " --out " + (*root_ / out).string() + " --force");
      EXPECT_EQ(r.exit_code, 2) << d.name << ": " << command << r.output;
      EXPECT_THAT(r.output, HasSubstr(d.says)) << d.name << ": " << command;
    }
  }
}

TEST_F(ReportTest, TheDataCarryTheFailureAndItsCameraSnapshot) {
  const sim::FinishedRun run = sim::ReadFinishedRun(*run_dir_);
  const nlohmann::json data = sim::ReportData(run);
  ASSERT_EQ(data["expectations"].size(), 2u);
  const nlohmann::json& lateral = data["expectations"][0];
  EXPECT_FALSE(lateral["passed"].get<bool>());
  ASSERT_TRUE(lateral.contains("at_s"));
  ASSERT_EQ(data["snapshots"].size(), 1u);
  const nlohmann::json& snapshot = data["snapshots"][0];
  EXPECT_EQ(snapshot["car"], lateral["car"]);
  EXPECT_LE(snapshot["t"].get<double>(), lateral["at_s"].get<double>());
  EXPECT_GT(snapshot["t"].get<double>(), lateral["at_s"].get<double>() - 0.051);  // its sample
  EXPECT_THAT(snapshot["color"].get<std::string>(),
              ::testing::StartsWith("data:image/jpeg;base64,"));
  EXPECT_THAT(snapshot["lane"].get<std::string>(), HasSubstr("lane detection:"));
  // every sample of every car, in order
  std::size_t samples = 0;
  for (const auto& [car, columns] : data["trajectory"].items()) samples += columns["t"].size();
  EXPECT_EQ(samples, run.record.trajectory.size());
  EXPECT_EQ(data["events"].size(), run.record.events.size());
  EXPECT_TRUE(data["boards"]["car0"].contains("e2e_max_ms"));
  // the 3D views: at the snapshot and at the end, or the reason there are none
  if (vehicle::testing::GlUnavailableReason().empty()) {
    EXPECT_THAT(snapshot["chase"].get<std::string>(), ::testing::StartsWith("data:image/jpeg"));
    EXPECT_THAT(snapshot["overview"].get<std::string>(), ::testing::StartsWith("data:image/jpeg"));
    EXPECT_THAT(data["scene"]["overview"].get<std::string>(),
                ::testing::StartsWith("data:image/jpeg"));
    EXPECT_DOUBLE_EQ(data["scene"]["t"].get<double>(), 15.0);
  } else {
    EXPECT_THAT(data["scene"]["note"].get<std::string>(), HasSubstr("no OpenGL ES context"));
  }
}

TEST_F(ReportTest, ACheckWithReportsNamesThemInItsOutputAndItsJunit) {
  const fs::path out = *root_ / "check";
  const fs::path junit = *root_ / "check.xml";
  const Result r = Cli("check scenarios/lab_two_cars_oracle.yaml --report --out " + out.string() +
                       " --junit " + junit.string() +
                       " --set duration_s=20 --set 'expect=[{max_lateral_error: {max_m: 0.001}}]'");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  const fs::path report = out / "lab_two_cars_oracle" / "report.html";
  EXPECT_TRUE(fs::exists(report));
  // the failed check says where its report is, and how to open it at the failure
  EXPECT_THAT(r.output, HasSubstr("report: " + report.string()));
  EXPECT_THAT(r.output, HasSubstr(".html#t="));
  EXPECT_THAT(Read(junit), HasSubstr("<property name=\"report\" value=\"" + report.string()));
  // Issue 34: the JUnit failure carries what stdout prints (time, car, report link), and the link
  // opens the report at or after the failure, never before it (15.212 s was linked as 15.21).
  const nlohmann::json failure =
      nlohmann::json::parse(Read(out / "lab_two_cars_oracle" / "summary.json"))["expectations"][0];
  const double at_s = failure["at_s"].get<double>();
  const std::string xml = Read(junit);
  EXPECT_THAT(xml, HasSubstr(fmt::format("<failure message=\"{}\">at t = {:.3f} s, car {}: ",
                                         sim::XmlEscape(failure["detail"].get<std::string>()), at_s,
                                         failure["car"].get<int>())));
  const std::size_t link = xml.find("report: file://");
  ASSERT_NE(link, std::string::npos) << xml;
  const std::size_t t_at = xml.find("#t=", link);
  ASSERT_NE(t_at, std::string::npos);
  const double link_s = std::stod(xml.substr(t_at + 3));
  EXPECT_GE(link_s, at_s);
  EXPECT_LT(link_s, at_s + 0.0011);
  const std::size_t printed = r.output.find(".html#t=");
  ASSERT_NE(printed, std::string::npos);
  EXPECT_GE(std::stod(r.output.substr(printed + 8)), at_s);
  const Result no_out = Cli("check scenarios/lab_two_cars_oracle.yaml --report");
  EXPECT_EQ(no_out.exit_code, 2);
  EXPECT_THAT(no_out.output, HasSubstr("--out"));
}

TEST_F(ReportTest, TheVideoHasOneFramePerInstantAndReadsBack) {
  const fs::path video = *root_ / "replay.mp4";
  const Result r = Cli("video " + run_dir_->string() + " --out " + video.string() +
                       " --fps 10 --speed 2 --to 10 --cameras 0 -q");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("51 frames"));  // 0, 0.2, ..., 10 s
  cv::VideoCapture capture(video.string());
  ASSERT_TRUE(capture.isOpened());
  EXPECT_NEAR(capture.get(cv::CAP_PROP_FPS), 10.0, 1e-6);
  int frames = 0;
  cv::Mat frame;
  while (capture.read(frame)) ++frames;
  EXPECT_EQ(frames, 51);
  // the run's own folder may be replaced by a video; a file elsewhere only with --force
  EXPECT_EQ(
      Cli("video " + run_dir_->string() + " --out " + video.string() + " --to 1 -q").exit_code, 2);
  EXPECT_EQ(
      Cli("video " + run_dir_->string() + " --out " + (*run_dir_ / "v.mp4").string() + " --to 1 -q")
          .exit_code,
      0);
  const Result no_board = Cli("video " + run_dir_->string() + " --out " +
                              (*root_ / "x.mp4").string() + " --cameras 7 -q");
  EXPECT_EQ(no_board.exit_code, 2);
  EXPECT_THAT(no_board.output, HasSubstr("no car 7 with a board"));
  EXPECT_FALSE(fs::exists(*root_ / "x.mp4"));
}

TEST_F(ReportTest, TheVideoShowsTheRunIn3DFromBehindACarAndFromAbove) {
  AUTONOMSIM_REQUIRE_GL();
  const fs::path plain = *root_ / "plain.mp4", views = *root_ / "views.mp4";
  ASSERT_EQ(
      Cli("video " + run_dir_->string() + " --out " + plain.string() + " --to 1 -q").exit_code, 0);
  const Result r = Cli("video " + run_dir_->string() + " --out " + views.string() +
                       " --to 1 --chase 1 --overview -q");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  cv::VideoCapture with(views.string()), without(plain.string());
  cv::Mat frame, plain_frame;
  ASSERT_TRUE(with.read(frame));
  ASSERT_TRUE(without.read(plain_frame));
  // a panel to the right of the top-down figure: the chase view above the overview
  ASSERT_EQ(frame.cols, plain_frame.cols + 500);
  const cv::Mat panel = frame(cv::Rect(plain_frame.cols, 0, 500, frame.rows));
  const cv::Scalar mean = cv::mean(panel);
  EXPECT_GT(mean[0] + mean[1] + mean[2], 30.0);  // drawn, not the background alone
  int frames = 1;
  while (with.read(frame)) ++frames;
  EXPECT_EQ(frames, 21);  // 0, 0.05, ..., 1 s
  const Result no_car = Cli("video " + run_dir_->string() + " --out " +
                            (*root_ / "y.mp4").string() + " --chase 7 -q");
  EXPECT_EQ(no_car.exit_code, 2);
  EXPECT_THAT(no_car.output, HasSubstr("--chase 7: the run has no car 7"));
  EXPECT_FALSE(fs::exists(*root_ / "y.mp4"));
}

TEST_F(ReportTest, RenderWritesACameraDatasetWithLabelsFromEitherBackend) {
  AUTONOMSIM_REQUIRE_GL();
  const fs::path ray_cast = *root_ / "render_raycast", gl = *root_ / "render_gl";
  const std::string common = "render scenarios/lab_two_cars.yaml --car 0 --at 4,8.5 --labels ";
  ASSERT_EQ(Cli(common + "--out " + ray_cast.string()).exit_code, 0);
  const Result r = Cli(common + "--backend gl --out " + gl.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("rendered (gl, with labels)"));
  for (const char* instant : {"t_0004.000", "t_0008.500"}) {
    const nlohmann::json legend = nlohmann::json::parse(Read(gl / instant / "labels.json"));
    EXPECT_EQ(legend["classes"][1], "floor");
    EXPECT_EQ(legend["instances"][0]["car"], 1);
    for (const char* file :
         {"color_camera/color.png", "color_camera/labels.png", "color_camera/instances.png",
          "color_camera/camera_info.json", "depth_camera/depth.png",
          "depth_camera/depth_preview.png", "depth_camera/labels.png"}) {
      EXPECT_TRUE(fs::exists(gl / instant / file)) << instant << "/" << file;
      EXPECT_TRUE(fs::exists(ray_cast / instant / file)) << instant << "/" << file;
    }
    // the same files; the images agree but for edges, the labels are the same ground truth
    const cv::Mat a = cv::imread((gl / instant / "color_camera/color.png").string());
    const cv::Mat b = cv::imread((ray_cast / instant / "color_camera/color.png").string());
    cv::Mat differ;
    cv::compare(a.reshape(1), b.reshape(1), differ, cv::CMP_NE);
    EXPECT_LT(cv::countNonZero(differ), a.total() / 100) << instant;
    const cv::Mat la =
        cv::imread((gl / instant / "color_camera/labels.png").string(), cv::IMREAD_UNCHANGED);
    const cv::Mat lb =
        cv::imread((ray_cast / instant / "color_camera/labels.png").string(), cv::IMREAD_UNCHANGED);
    EXPECT_EQ(cv::norm(la, lb, cv::NORM_INF), 0.0) << instant;
    const cv::Mat da =
        cv::imread((gl / instant / "depth_camera/depth.png").string(), cv::IMREAD_UNCHANGED);
    const cv::Mat db =
        cv::imread((ray_cast / instant / "depth_camera/depth.png").string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(da.type(), CV_16UC1);
    EXPECT_LE(cv::norm(da, db, cv::NORM_INF), 1.0) << instant;
  }
  const Result bad =
      Cli("render scenarios/lab_two_cars.yaml --car 0 --at 1 --backend vulkan --out " +
          (*root_ / "bad").string());
  EXPECT_EQ(bad.exit_code, 2);
}

TEST_F(ReportTest, ALongRunsTrajectoryIsThinnedToKeepThePageSmall) {
  sim::FinishedRun run = sim::ReadFinishedRun(*run_dir_);
  const std::vector<sim::TrajectorySample> once = run.record.trajectory;
  ASSERT_FALSE(once.empty());
  // the same samples again and again, later each time: a run of over 60000 samples
  for (int copy = 1; run.record.trajectory.size() <= 60000; ++copy) {
    for (sim::TrajectorySample s : once) {
      s.t += copy * (once.back().t + FromSeconds(0.05));
      run.record.trajectory.push_back(s);
    }
  }
  const nlohmann::json data = sim::ReportData(run);
  EXPECT_EQ(data["meta"]["trajectory_stride"], 2);
  std::size_t kept = 0;
  for (const auto& [car, columns] : data["trajectory"].items()) {
    kept += columns["t"].size();
    double last_t = 0.0;  // each car's last sample is kept
    for (const sim::TrajectorySample& s : run.record.trajectory) {
      if (std::to_string(s.car) == car) last_t = ToSeconds(s.t);
    }
    EXPECT_NEAR(columns["t"].back().get<double>(), last_t, 1e-3) << "car " << car;
  }
  EXPECT_LT(kept, run.record.trajectory.size() * 6 / 10);
}

// trajectory.csv: car -> t (ms) -> (x, y)
std::map<int, std::map<long, std::pair<double, double>>> Trajectory(const fs::path& file) {
  std::map<int, std::map<long, std::pair<double, double>>> out;
  std::istringstream in(Read(file));
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    const sim::TrajectorySample s = sim::ParseTrajectoryCsvLine(line);
    out[s.car][std::lround(ToSeconds(s.t) * 1000.0)] = {s.x_m, s.y_m};
  }
  return out;
}

TEST_F(ReportTest, InChromiumTheSliderDrawsTheCarsWhereTheTrajectoryHasThem) {
  const Result which = Shell("command -v chromium");
  ASSERT_EQ(which.exit_code, 0)
      << "chromium is not installed: tools/install_deps.sh installs it (Debian's chromium)";
  // the report alone in a fresh folder: nothing beside it to lean on
  const fs::path folder = *root_ / "browser";
  fs::remove_all(folder);
  fs::create_directories(folder / "profile");
  const fs::path page = folder / "replay.html";
  ASSERT_EQ(Cli("report " + run_dir_->string() + " --out " + page.string()).exit_code, 0);

  // ten instants, sampled ones (the slider's step is the 0.05 s sample period)
  const std::vector<double> instants{0.0, 1.5, 3.05, 4.0, 5.35, 7.2, 8.9, 10.5, 12.55, 14.95};
  std::string probe;
  for (double t : instants) probe += (probe.empty() ? "" : ",") + std::to_string(t);
  // the script waits, on the wall clock, for the page to write its probe (see its docstring)
  const Result browser = Shell(
      "/usr/bin/python3 tools/tests/chromium_probe.py --timeout 90 "
      "--user-data-dir " +
      (folder / "profile").string() + " 'file://" + page.string() + "#probe=" + probe + "'");
  const std::size_t json_begin = browser.output.find("{\"probe\"");
  ASSERT_NE(json_begin, std::string::npos) << browser.output;
  const nlohmann::json opened = nlohmann::json::parse(browser.output.substr(json_begin));
  EXPECT_TRUE(opened["exceptions"].empty()) << opened["exceptions"];
  EXPECT_TRUE(opened["console"].empty()) << opened["console"];  // console errors, CSP refusals
  ASSERT_EQ(browser.exit_code, 0) << "the page wrote no probe: " << opened.dump(1);
  const nlohmann::json result = nlohmann::json::parse(opened["probe"].get<std::string>());

  EXPECT_TRUE(result["errors"].empty()) << result["errors"];
  EXPECT_TRUE(result["resources"].empty()) << "network requests: " << result["resources"];
  for (int width : result["images"]) EXPECT_GT(width, 0) << "an image did not decode";
  ::testing::Test::RecordProperty("load_ms", std::to_string(result["load_ms"].get<double>()));
  std::printf("report ready in %.0f ms in headless chromium\n", result["load_ms"].get<double>());

  const auto trajectory = Trajectory(*run_dir_ / "trajectory.csv");
  ASSERT_EQ(result["samples"].size(), instants.size());
  for (const nlohmann::json& sample : result["samples"]) {
    const long t_ms = std::lround(sample["t"].get<double>() * 1000.0);
    for (const nlohmann::json& car : sample["cars"]) {
      const auto& [x, y] = trajectory.at(car["car"].get<int>()).at(t_ms);
      SCOPED_TRACE("car " + car["car"].dump() + " at t = " + sample["t"].dump() + " s");
      ASSERT_GT(car["pixels"].get<int>(), 200) << "the car is not drawn";
      EXPECT_NEAR(car["drawn_x_m"].get<double>(), x, 0.01);
      EXPECT_NEAR(car["drawn_y_m"].get<double>(), y, 0.01);
    }
  }
}

}  // namespace
}  // namespace autonomsim
