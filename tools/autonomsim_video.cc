// autonomsim-video: `autonomsim video`, in a binary of its own. OpenCV's video writer (videoio)
// loads FFmpeg and GStreamer, some 150 shared libraries and 17 MB of memory at start: linked into
// `autonomsim`, every run paid for them. `autonomsim video ARGS` runs this helper, found beside
// it, as `autonomsim-video video ARGS` (AddVideoForwarder below).
#include <CLI/CLI.hpp>

#include "tools/cli_common.h"

int main(int argc, char** argv) {
  using namespace autonomsim::cli;
  CLI::App app{"autonomsim video: the top-down replay of a finished run as a video", "autonomsim"};
  app.require_subcommand(1);
  return ParseAndRun(app, argc, argv, {AddVideoCommand(app)});
}
