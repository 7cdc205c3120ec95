// autonomsim-video: `autonomsim video`, in a binary of its own. OpenCV's video writer (videoio)
// loads FFmpeg and GStreamer, some 150 shared libraries and 17 MB of memory at start: linked into
// `autonomsim`, every run paid for them. `autonomsim video ARGS` runs this helper, found beside
// it, as `autonomsim-video video ARGS` (AddVideoForwarder below).
#include <fmt/format.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <filesystem>
#include <string>
#include <vector>

#include "tools/cli_common.h"

int main(int argc, char** argv) {
  using namespace autonomsim::cli;
  CLI::App app{"autonomsim video: the top-down replay of a finished run as a video", "autonomsim"};
  app.require_subcommand(1);
  const Command video = AddVideoCommand(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? kExitOk : kExitUnusableInput;
  }
  try {
    return video.run();
  } catch (const std::exception& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return kExitUnusableInput;
  }
}
