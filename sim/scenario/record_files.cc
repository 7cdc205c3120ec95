#include "sim/scenario/record_files.h"

#include <cerrno>
#include <stdexcept>
#include <string>
#include <vector>

#include "sim/core/files.h"
#include "sim/core/hash.h"

namespace autonomsim::sim {
namespace {

namespace fs = std::filesystem;

std::ofstream OpenForWriting(const fs::path& file) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  if (!out) ThrowCannotWrite(file);
  return out;
}

std::ifstream OpenForReading(const fs::path& file) {
  RequireRegularFile(file);
  std::ifstream in(file, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + file.string());
  return in;
}

void Write(std::ofstream& out, const std::string& text, const fs::path& file) {
  errno = 0;  // the reason a failure gives is this write's
  out << text;
  if (!out) ThrowCannotWrite(file);
}

// Calls `visit` with each non-empty line of `file` (without its newline), after its header line if
// it has one (`header`, without its newline: the first line must be it); a line `visit` cannot
// take (std::invalid_argument) is an error at file:line. Returns the lines visited.
int ForEachLine(const fs::path& file, const std::string* header,
                const std::function<void(const std::string&)>& visit) {
  std::ifstream in = OpenForReading(file);
  std::string line;
  int number = 0;
  if (header != nullptr) {
    if (!std::getline(in, line)) {
      throw std::runtime_error(file.string() + ": empty, not even its header");
    }
    number = 1;
    if (line != *header) {
      throw std::runtime_error(file.string() + ":1: not the header a run writes: expected '" +
                               *header + "', got '" + line + "'");
    }
  }
  int visited = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.empty()) continue;
    try {
      visit(line);
      ++visited;
    } catch (const std::invalid_argument& e) {
      throw std::runtime_error(file.string() + ":" + std::to_string(number) +
                               ": not a line a run wrote: " + e.what());
    }
  }
  if (in.bad()) throw std::runtime_error("cannot read " + file.string());
  return visited;
}

void HashFile(const fs::path& file, Sha256* hash) {
  std::ifstream in = OpenForReading(file);
  std::vector<char> buffer(1 << 20);
  while (in) {
    in.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    hash->Update(std::string_view(buffer.data(), static_cast<std::size_t>(in.gcount())));
  }
  if (in.bad()) throw std::runtime_error("cannot read " + file.string());
}

}  // namespace

RecordFiles::RecordFiles(const fs::path& folder)
    : trajectory_file_(folder / "trajectory.csv"),
      events_file_(folder / "events.jsonl"),
      trace_file_(folder / "trace.json"),
      trajectory_(OpenForWriting(trajectory_file_)),
      events_(OpenForWriting(events_file_)) {
  Write(trajectory_, TrajectoryCsvHeader(), trajectory_file_);
}

void RecordFiles::Append(const TrajectorySample& sample) {
  Write(trajectory_, TrajectoryCsvLine(sample), trajectory_file_);
}

void RecordFiles::Append(const Event& event) { Write(events_, EventJsonLine(event), events_file_); }

void RecordFiles::RequireClosed() const {
  if (!closed_) throw std::logic_error("RecordFiles read before Close: " + events_file_.string());
}

std::ostream* RecordFiles::OpenTrace() {
  if (closed_)
    throw std::logic_error("RecordFiles::OpenTrace after Close: " + trace_file_.string());
  if (!trace_.is_open()) trace_ = OpenForWriting(trace_file_);
  return &trace_;
}

void RecordFiles::Close() {
  if (closed_) return;
  closed_ = true;
  for (auto [out, file] : {std::pair{&trajectory_, &trajectory_file_},
                           {&events_, &events_file_},
                           {&trace_, &trace_file_}}) {
    if (out == &trace_ && !trace_.is_open()) continue;
    out->close();
    if (!*out) ThrowCannotWrite(*file);
  }
}

void ReadTrajectoryCsv(const fs::path& file,
                       const std::function<void(const TrajectorySample&)>& visit) {
  std::string header = TrajectoryCsvHeader();
  header.pop_back();  // its newline
  const int rows = ForEachLine(
      file, &header, [&](const std::string& line) { visit(ParseTrajectoryCsvLine(line)); });
  if (rows == 0) {
    throw std::runtime_error(file.string() +
                             ": no rows after the header (a run writes every car's at t = 0)");
  }
}

void ReadEventsJsonl(const fs::path& file, const std::function<void(const Event&)>& visit) {
  ForEachLine(file, nullptr, [&](const std::string& line) { visit(ParseEventJsonLine(line)); });
}

void RecordFiles::ForEachSample(const std::function<void(const TrajectorySample&)>& visit) const {
  RequireClosed();
  ReadTrajectoryCsv(trajectory_file_, visit);
}

void RecordFiles::ForEachEvent(const std::function<void(const Event&)>& visit) const {
  RequireClosed();
  ReadEventsJsonl(events_file_, visit);
}

void RecordFiles::HashText(Sha256* hash) const {
  RequireClosed();
  HashFile(trajectory_file_, hash);
  HashFile(events_file_, hash);
}

}  // namespace autonomsim::sim
