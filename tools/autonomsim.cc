// autonomsim: the command-line front end. One file per subcommand (tools/cmd_*.cc); what they
// share is in tools/cli_common.h.
#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "tools/cli_common.h"

int main(int argc, char** argv) {
  using namespace autonomsim::cli;
  CLI::App app{
      "autonomsim: closed-loop simulator of the AutonomROS model-car fleet.\n"
      "Exit codes: 0 all expectations held, 1 an expectation failed, 2 unusable input (or output\n"
      "that could not be written), 130 run, check or sweep stopped by Ctrl-C (what was "
      "half-written is removed)."};
  app.set_version_flag("--version", std::string("autonomsim ") + AUTONOMSIM_VERSION);
  app.require_subcommand(1);
  const std::vector<Command> commands = {
      AddRunCommand(app),    AddCheckCommand(app),     AddValidateCommand(app),
      AddTable1Command(app), AddTransportCommand(app), AddRenderCommand(app),
      AddSweepCommand(app),  AddReportCommand(app),    AddReferenceCommand(app),
      AddExportCommand(app), AddVideoForwarder(app)};

  return ParseAndRun(app, argc, argv, commands);
}
