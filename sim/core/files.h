// Files written so that nothing half-written ever looks complete (ARCHITECTURE: results are
// written to a temporary name and renamed when complete).
#pragma once

#include <filesystem>
#include <functional>
#include <string>

namespace autonomsim::sim {

// Writes `content` to `file`; throws std::runtime_error naming the file on failure.
void WriteFile(const std::filesystem::path& file, const std::string& content);

// Writes `content` to `file` through a sibling "<file>.tmp-<pid>" renamed over it, so a reader
// sees the previous file or the new one, never half of one (one writer per file at a time in a
// process). On failure the temporary is removed and the error (a std::runtime_error naming the
// file) propagates.
void WriteFileAtomically(const std::filesystem::path& file, const std::string& content);

// Creates `target` by letting `fill` write into a sibling "<target>.partial-<pid>" folder and
// renaming it to `target` when `fill` returns; a previous `target` is replaced only then. If
// `fill` throws, the partial folder is removed and the exception propagates.
void WriteFolderAtomically(const std::filesystem::path& target,
                           const std::function<void(const std::filesystem::path& partial)>& fill);

}  // namespace autonomsim::sim
