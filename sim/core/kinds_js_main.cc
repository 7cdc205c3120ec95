// Build-time generator of the replay report's kind table (kinds.js): the JavaScript constants
// EVENT and FAULT with every kind's name, from the one C++ table (sim/core/vocabulary.h), so the
// page and the program cannot disagree. Usage: autonomsim_kinds_js OUT.js
#include <cctype>
#include <fstream>
#include <iostream>
#include <string>

#include "sim/core/vocabulary.h"

namespace {

template <class E>
std::string Constants(const char* name) {
  std::string out = "const " + std::string(name) + " = Object.freeze({\n";
  for (const auto& [value, kind] : autonomsim::NameTable<E>::kEntries) {
    std::string key(kind);
    for (char& c : key) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    out += "  " + key + ": \"" + std::string(kind) + "\",\n";
  }
  return out + "});\n";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: autonomsim_kinds_js OUT.js\n";
    return 2;
  }
  const std::string text =
      "// Generated from sim/core/vocabulary.h by sim/core/kinds_js_main.cc at build time; do not "
      "edit.\n" +
      Constants<autonomsim::sim::EventKind>("EVENT") +
      Constants<autonomsim::sim::FaultKind>("FAULT");
  const std::string tmp = std::string(argv[1]) + ".tmp";
  std::ofstream out(tmp, std::ios::binary);
  out << text;
  out.close();
  if (!out || std::rename(tmp.c_str(), argv[1]) != 0) {
    std::cerr << "autonomsim_kinds_js: cannot write " << argv[1] << "\n";
    return 1;
  }
  return 0;
}
