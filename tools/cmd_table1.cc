// `autonomsim table1`: the paper's Table I test setup (camera driver at 30 fps, one processing
// component, a rate probe) for all eight configurations on the platform model, beside the paper's
// ranges, each row's processes beside the lab's sheet's; and the whole unit in software. Exit 0
// only when every cell is in the paper's range.
#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <fstream>

#include "sim/core/config.h"
#include "sim/platform/table1.h"
#include "sim/scenario/scenario.h"
#include "tools/cli_common.h"

namespace autonomsim::cli {
namespace {

bool WriteText(const std::filesystem::path& file, const std::string& text) {
  std::ofstream out(file, std::ios::binary);
  out << text;
  out.close();
  if (!out) fmt::print(stderr, "error: cannot write {}\n", file.string());
  return static_cast<bool>(out);
}

int Table1Command(const std::string& profile_file, const std::optional<std::string>& json_file,
                  const std::optional<std::string>& trace_dir,
                  const std::vector<std::string>& overrides, double duration_s, double warmup_s) {
  sim::PlatformProfile profile;
  sim::Table1Options options;
  try {
    profile = sim::LoadPlatformProfile(sim::ResolveShippedFile(profile_file), overrides);
    if (!(warmup_s >= 0.0) || !(duration_s > warmup_s)) {
      throw sim::ConfigError(
          fmt::format("--duration ({} s) must exceed --warmup ({} s) >= 0", duration_s, warmup_s));
    }
    options.duration = FromSeconds(duration_s);
    options.warmup = FromSeconds(warmup_s);
    options.trace = trace_dir.has_value();
  } catch (const sim::ConfigError& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return kExitUnusableInput;
  } catch (const std::invalid_argument& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return kExitUnusableInput;
  }
  std::vector<sim::Table1Result> rows;
  std::vector<sim::WholeUnitResult> whole;
  try {
    rows = sim::RunTable1(profile, options);
    whole.push_back(sim::RunWholeUnit(profile, options, sim::Transport::kZeroCopy));
    whole.push_back(sim::RunWholeUnit(profile, options, sim::Transport::kDds));
  } catch (const sim::ConfigError& e) {
    fmt::print(stderr, "error: {}: {}\n", profile_file, e.what());
    return kExitUnusableInput;
  }
  fmt::print("{}", sim::Table1Text(rows, whole, profile.name, options));
  if (json_file && !WriteText(*json_file, sim::Table1Json(rows, whole).dump(2) + "\n")) {
    return kExitUnusableInput;
  }
  if (trace_dir) {
    std::error_code error;
    std::filesystem::create_directories(*trace_dir, error);
    for (const sim::WholeUnitResult& w : whole) {
      const std::filesystem::path base =
          std::filesystem::path(*trace_dir) / ("whole_unit_" + w.transport);
      if (!WriteText(base.string() + ".trace.json", w.trace_json) ||
          !WriteText(base.string() + ".nodes.csv", w.nodes_csv)) {
        return kExitUnusableInput;
      }
    }
    fmt::print("traces: {}/whole_unit_{{zero_copy,dds}}.trace.json (open in ui.perfetto.dev)\n",
               *trace_dir);
  }
  const bool all_in =
      std::all_of(rows.begin(), rows.end(), [](const sim::Table1Result& r) { return r.all_in(); });
  return all_in ? kExitOk : kExitExpectationFailed;
}

}  // namespace

Command AddTable1Command(CLI::App& parent) {
  struct Options {
    std::string profile{"scenarios/platforms/zcu104.yaml"};
    std::optional<std::string> json;
    std::optional<std::string> trace;
    std::vector<std::string> overrides;
    double duration_s{12.0};
    double warmup_s{2.0};
  };
  auto o = std::make_shared<Options>();
  CLI::App* table1 = parent.add_subcommand(
      "table1",
      "Reproduce the paper's Table I on the platform model (8 configurations) and run the whole "
      "unit in software; exit 0 only when every cell is in the paper's range");
  table1->add_option("--profile", o->profile, kProfileHelp)
      ->type_name("FILE")
      ->capture_default_str();
  table1->add_option("--json", o->json, "Also write the results as JSON")->type_name("FILE");
  table1
      ->add_option("--trace", o->trace,
                   "Write the whole-unit runs' trace.json (Perfetto) and nodes.csv into DIR")
      ->type_name("DIR");
  table1
      ->add_option("--set", o->overrides,
                   "Override a profile field, e.g. --set dds.write.copies=3 (repeatable)")
      ->type_name("KEY=VALUE");
  table1->add_option("--duration", o->duration_s, "Simulated seconds per configuration")
      ->type_name("S")
      ->capture_default_str();
  table1->add_option("--warmup", o->warmup_s, "Seconds not measured at the start")
      ->type_name("S")
      ->capture_default_str();
  return {table1, [o] {
            return Table1Command(o->profile, o->json, o->trace, o->overrides, o->duration_s,
                                 o->warmup_s);
          }};
}

}  // namespace autonomsim::cli
