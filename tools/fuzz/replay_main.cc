// The fuzz targets' seeds as a test: a main for a libFuzzer target (<module>/fuzz/*_fuzz.cc) built
// without libFuzzer (gcc, the sanitizer build: cmake/autonomsim.cmake's autonomsim_fuzzer). It
// feeds the target each seed once and fails as the target would under libFuzzer: a finding aborts,
// a sanitizer report stops the process. Mutating the seeds is tools/fuzz.sh's work.
//
//   TARGET SEEDS...   each SEEDS is a glob of files, one input per file, or a *.seeds file, one
//                     input per line (blank lines and lines starting with '#' skipped), as
//                     tools/fuzz.sh seeds the corpus.
#include <glob.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace {

bool EndsWith(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

void Feed(const std::string& input) {
  LLVMFuzzerTestOneInput(reinterpret_cast<const std::uint8_t*>(input.data()), input.size());
}

// The inputs of one SEEDS argument, fed to the target; how many, or -1 when there are none.
int ReplaySeeds(const std::string& seeds) {
  int fed = 0;
  if (EndsWith(seeds, ".seeds")) {
    std::ifstream in(seeds);
    for (std::string line; std::getline(in, line);) {
      if (line.empty() || line[0] == '#') continue;
      Feed(line);
      ++fed;
    }
    return fed > 0 ? fed : -1;
  }
  glob_t found{};
  if (glob(seeds.c_str(), 0, nullptr, &found) == 0) {
    for (std::size_t i = 0; i < found.gl_pathc; ++i) {
      std::ifstream in(found.gl_pathv[i], std::ios::binary);
      Feed(std::string(std::istreambuf_iterator<char>(in), {}));
      ++fed;
    }
  }
  globfree(&found);
  return fed > 0 ? fed : -1;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s SEEDS... (a glob of files, or a *.seeds file)\n", argv[0]);
    return 2;
  }
  int total = 0;
  for (int i = 1; i < argc; ++i) {
    const int fed = ReplaySeeds(argv[i]);
    if (fed < 0) {  // a seed set that matches nothing would make the test pass on nothing
      std::fprintf(stderr, "%s: no seeds in %s\n", argv[0], argv[i]);
      return 2;
    }
    total += fed;
  }
  std::printf("%s: %d seeds, no finding\n", argv[0], total);
  return 0;
}
