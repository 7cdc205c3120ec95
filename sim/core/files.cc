#include "sim/core/files.h"

#include <unistd.h>

#include <fstream>
#include <stdexcept>

namespace autonomsim::sim {

namespace fs = std::filesystem;

void WriteFile(const fs::path& file, const std::string& content) {
  std::ofstream out(file, std::ios::binary);
  out << content;
  out.close();
  if (!out) throw std::runtime_error("cannot write " + file.string());
}

void WriteFileAtomically(const fs::path& file, const std::string& content) {
  const fs::path tmp = file.string() + ".tmp-" + std::to_string(::getpid());
  try {
    WriteFile(tmp, content);
    fs::rename(tmp, file);
  } catch (...) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw;
  }
}

void WriteFolderAtomically(const fs::path& target_dir,
                           const std::function<void(const fs::path& partial)>& fill) {
  const fs::path target = fs::absolute(target_dir).lexically_normal();
  const std::string suffix = std::to_string(::getpid());
  const fs::path partial = target.string() + ".partial-" + suffix;
  fs::create_directories(target.parent_path());
  fs::remove_all(partial);
  fs::create_directory(partial);
  try {
    fill(partial);
    if (fs::exists(target)) {
      const fs::path old = target.string() + ".old-" + suffix;
      fs::rename(target, old);
      fs::rename(partial, target);
      fs::remove_all(old);
    } else {
      fs::rename(partial, target);
    }
  } catch (...) {
    std::error_code ignored;
    fs::remove_all(partial, ignored);
    throw;
  }
}

}  // namespace autonomsim::sim
