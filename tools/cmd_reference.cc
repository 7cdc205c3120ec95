// `autonomsim reference`: the scenario reference (docs/scenarios.md), generated from the loader's
// Describe: every key with its type, unit, default and meaning; the obstacle; the default track's
// start poses, routes, lanes and intersections; each fault and expectation kind.
#include <fmt/format.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "sim/scenario/reference.h"
#include "tools/cli_common.h"

namespace autonomsim::cli {
namespace {

// The line the generated page carries, by which a file is known to be one this command wrote.
constexpr std::string_view kGeneratedMark = "Generated from the loader's Describe";

int ReferenceCommand(const std::optional<std::string>& out, bool force) {
  const std::string text = sim::ScenarioReferenceMarkdown() + "\n";
  if (!out) {
    fmt::print("{}", text);
    return kExitOk;
  }
  namespace fs = std::filesystem;
  if (fs::exists(*out) && !force) {
    std::ifstream in(*out, std::ios::binary);
    std::stringstream existing;
    existing << in.rdbuf();
    if (!fs::is_regular_file(*out) || existing.str().find(kGeneratedMark) == std::string::npos) {
      fmt::print(stderr,
                 "error: --out {}: exists and is not a reference this command wrote; "
                 "choose another file or add --force\n",
                 *out);
      return kExitUnusableInput;
    }
  }
  std::ofstream file(*out, std::ios::binary | std::ios::trunc);
  file << text;
  file.close();
  if (!file) {
    fmt::print(stderr, "error: --out {}: cannot write\n", *out);
    return kExitUnusableInput;
  }
  fmt::print(stderr, "wrote {}\n", *out);
  return kExitOk;
}

}  // namespace

Command AddReferenceCommand(CLI::App& parent) {
  struct Options {
    std::optional<std::string> out;
    bool force{false};
  };
  auto o = std::make_shared<Options>();
  CLI::App* reference = parent.add_subcommand(
      "reference",
      "Print the scenario reference (every key with its type, allowed names, unit, default and "
      "meaning; obstacles; the default track's start poses, routes, lanes and intersections; "
      "what each fault and expectation kind does and its keys), as docs/scenarios.md has it");
  reference
      ->add_option("--out", o->out,
                   "Write it to FILE instead of standard output (refuses a file it did not write)")
      ->type_name("FILE");
  reference->add_flag("--force", o->force, "Replace --out even if this command did not write it");
  return {reference, [o] { return ReferenceCommand(o->out, o->force); }};
}

}  // namespace autonomsim::cli
