// Mcap.node_reader: a file of ROS 2 messages written by mcap::Writer and CdrWriter, read back by
// Foxglove's TypeScript libraries (tools/tests/mcap_check.mjs), and what they decode compared
// with what was written. Two channels with real ROS 2 definitions (std_msgs/msg/String and
// geometry_msgs/msg/TransformStamped with its dependencies, concatenated as rosbag2 stores them),
// enough messages for several chunks.
//
//   mcap_node_check REPO_ROOT OUT_DIR
//
// Exit 0: the reader agrees; 1: it does not (each difference printed) or it failed; 77 (ctest's
// skip) when node or the repository's node_modules are missing, unless CI=true, where that is a
// failure: tools/install_deps.sh installs both.
#include <sys/wait.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "sim/mcap/cdr.h"
#include "sim/mcap/mcap_writer.h"

namespace {

namespace fs = std::filesystem;
using autonomsim::mcap::CdrWriter;
using Json = nlohmann::json;

constexpr int kSkip = 77;
constexpr int kMessages = 400;  // per channel; ~ 30 kB of records, 4 kB chunks

constexpr const char* kStringDefinition = "# A string message\nstring data\n";

// geometry_msgs/msg/TransformStamped as rosbag2 records its definition (ros2msg): the type's .msg,
// then each dependency after a line of 80 '=' and "MSG: package/Type".
std::string TransformStampedDefinition() {
  const std::string rule = std::string(80, '=') + "\n";
  return "std_msgs/Header header\n"
         "string child_frame_id # the frame id of the child frame\n"
         "Transform transform\n" +
         rule + "MSG: std_msgs/Header\n" +
         "builtin_interfaces/Time stamp\n"
         "string frame_id\n" +
         rule + "MSG: builtin_interfaces/Time\n" +
         "int32 sec\n"
         "uint32 nanosec\n" +
         rule + "MSG: geometry_msgs/Transform\n" +
         "Vector3 translation\n"
         "Quaternion rotation\n" +
         rule + "MSG: geometry_msgs/Vector3\n" +
         "float64 x\n"
         "float64 y\n"
         "float64 z\n" +
         rule + "MSG: geometry_msgs/Quaternion\n" +
         "float64 x 0\n"
         "float64 y 0\n"
         "float64 z 0\n"
         "float64 w 1\n";
}

struct Transform {
  std::int32_t sec;
  std::uint32_t nanosec;
  std::string frame_id, child_frame_id;
  double translation[3];
  double rotation[4];
};

// The i-th message of each channel. Values exact in binary, so that JSON gives them back exactly.
std::string TextAt(int i) { return "hello " + std::to_string(i); }
Transform TransformAt(int i) {
  return {i / 10,
          static_cast<std::uint32_t>(100'000'000 * (i % 10)),
          "map",
          i % 2 == 0 ? "base_link" : "car1/base_link",
          {0.25 * i, -0.5 * i, 1.0},
          {0.0, 0.0, 0.5, 0.75}};
}

void EncodeTransform(const Transform& t, CdrWriter* cdr) {
  cdr->I32(t.sec);
  cdr->U32(t.nanosec);
  cdr->String(t.frame_id);
  cdr->String(t.child_frame_id);
  for (double v : t.translation) cdr->F64(v);
  for (double v : t.rotation) cdr->F64(v);
}

autonomsim::mcap::Writer::Counts WriteFile(const fs::path& file) {
  autonomsim::mcap::Writer writer(file, {.chunk_size_bytes = 4096});
  const std::map<std::string, std::string> qos{{"offered_qos_profiles", ""}};
  const std::uint16_t text =
      writer.AddChannel(writer.AddSchema("std_msgs/msg/String", "ros2msg", kStringDefinition),
                        "/chatter", "cdr", qos);
  const std::uint16_t tf =
      writer.AddChannel(writer.AddSchema("geometry_msgs/msg/TransformStamped", "ros2msg",
                                         TransformStampedDefinition()),
                        "/transform", "cdr", qos);
  writer.AddMetadata("run", {{"scenario", "node_reader"}, {"seed", "42"}});
  CdrWriter cdr;
  for (int i = 0; i < kMessages; ++i) {
    const std::uint64_t t_ns = 1'000'000'000ULL + 10'000'000ULL * static_cast<std::uint64_t>(i);
    cdr.Reset();
    cdr.String(TextAt(i));
    writer.Write(text, t_ns, t_ns, cdr.data());
    cdr.Reset();
    EncodeTransform(TransformAt(i), &cdr);
    writer.Write(tf, t_ns + 1, t_ns, cdr.data());
  }
  writer.Close();
  return writer.counts();
}

// Runs `command`, returns its stdout and sets `status` to its exit status (-1 if it did not exit).
std::string Run(const std::string& command, int* status) {
  std::string out;
  std::FILE* pipe = ::popen(command.c_str(), "r");
  if (pipe == nullptr) {
    *status = -1;
    return out;
  }
  char buffer[4096];
  for (std::size_t n; (n = std::fread(buffer, 1, sizeof buffer, pipe)) > 0;) out.append(buffer, n);
  const int wait_status = ::pclose(pipe);
  *status = WIFEXITED(wait_status) ? WEXITSTATUS(wait_status) : -1;
  return out;
}

std::string Quoted(const fs::path& path) {
  std::string quoted = "'";
  for (char c : path.string()) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

// What keeps the check from running (no node, no node_modules), or "".
std::string MissingReader(const fs::path& root) {
  int status = 0;
  Run("node --version >/dev/null 2>&1", &status);
  if (status != 0) return "node is not installed";
  if (!fs::exists(root / "node_modules/@mcap/core/package.json") ||
      !fs::exists(root / "node_modules/@foxglove/rosmsg2-serialization/package.json")) {
    return "the test readers are not installed (" + (root / "node_modules").string() + ")";
  }
  return "";
}

// Collects differences between what the reader says and what is expected.
class Differences {
 public:
  template <typename T>
  void Expect(const Json& summary, const Json::json_pointer& where, const T& expected) {
    if (!summary.contains(where)) {
      lines_.push_back(where.to_string() + ": missing");
    } else if (summary.at(where) != Json(expected)) {
      lines_.push_back(where.to_string() + ": " + summary.at(where).dump() + ", expected " +
                       Json(expected).dump());
    }
  }
  const std::vector<std::string>& lines() const { return lines_; }

 private:
  std::vector<std::string> lines_;
};

void ExpectTransform(const Json& summary, const std::string& which, const Transform& t,
                     Differences* d) {
  const std::string at = "/topics/~1transform/" + which;
  d->Expect(summary, Json::json_pointer(at + "/header/stamp/sec"), t.sec);
  d->Expect(summary, Json::json_pointer(at + "/header/stamp/nanosec"), t.nanosec);
  d->Expect(summary, Json::json_pointer(at + "/header/frame_id"), t.frame_id);
  d->Expect(summary, Json::json_pointer(at + "/child_frame_id"), t.child_frame_id);
  const char* axes[] = {"x", "y", "z", "w"};
  for (int k = 0; k < 3; ++k) {
    d->Expect(summary, Json::json_pointer(at + "/transform/translation/" + axes[k]),
              t.translation[k]);
  }
  for (int k = 0; k < 4; ++k) {
    d->Expect(summary, Json::json_pointer(at + "/transform/rotation/" + axes[k]), t.rotation[k]);
  }
}

std::vector<std::string> Compare(const Json& summary,
                                 const autonomsim::mcap::Writer::Counts& counts) {
  Differences d;
  using P = Json::json_pointer;
  d.Expect(summary, P("/profile"), "ros2");
  d.Expect(summary, P("/totals/messages"), counts.messages);
  d.Expect(summary, P("/totals/chunks"), counts.chunks);
  d.Expect(summary, P("/totals/compression"), std::vector<std::string>{"zstd"});
  d.Expect(summary, P("/metadata/run/seed"), "42");
  for (const std::string topic : {"/topics/~1chatter", "/topics/~1transform"}) {
    d.Expect(summary, P(topic + "/count"), kMessages);
    d.Expect(summary, P(topic + "/trailing_bytes"), false);
  }
  d.Expect(summary, P("/topics/~1chatter/schema"), "std_msgs/msg/String");
  d.Expect(summary, P("/topics/~1chatter/first/data"), TextAt(0));
  d.Expect(summary, P("/topics/~1chatter/last/data"), TextAt(kMessages - 1));
  d.Expect(summary, P("/topics/~1transform/schema"), "geometry_msgs/msg/TransformStamped");
  ExpectTransform(summary, "first", TransformAt(0), &d);
  ExpectTransform(summary, "last", TransformAt(kMessages - 1), &d);
  return d.lines();
}

int Check(const fs::path& root, const fs::path& out_dir) {
  if (const std::string missing = MissingReader(root); !missing.empty()) {
    const char* ci = std::getenv("CI");
    const bool required = ci != nullptr && std::string(ci) == "true";
    std::cerr << "Mcap.node_reader: " << missing << ": run tools/install_deps.sh"
              << (required ? " (CI=true: a failure)" : " (skipped)") << "\n";
    return required ? 1 : kSkip;
  }
  fs::create_directories(out_dir);
  const fs::path file = out_dir / "node_reader.mcap";
  const autonomsim::mcap::Writer::Counts counts = WriteFile(file);
  if (counts.chunks < 3) {
    std::cerr << "Mcap.node_reader: only " << counts.chunks << " chunks; the test wants several\n";
    return 1;
  }
  int status = 0;
  const std::string out =
      Run("node " + Quoted(root / "tools/tests/mcap_check.mjs") + " " + Quoted(file), &status);
  if (status != 0) {
    std::cerr << "Mcap.node_reader: mcap_check.mjs failed (exit " << status << ")\n" << out;
    return 1;
  }
  const Json summary = Json::parse(out);
  const std::vector<std::string> differences = Compare(summary, counts);
  for (const std::string& line : differences) std::cerr << "Mcap.node_reader: " << line << "\n";
  if (!differences.empty()) std::cerr << out;
  std::cout << "Mcap.node_reader: " << counts.messages << " messages in " << counts.chunks
            << " chunks read back by @mcap/core; " << differences.size() << " differences\n";
  return differences.empty() ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: mcap_node_check REPO_ROOT OUT_DIR\n";
    return 2;
  }
  try {
    return Check(argv[1], argv[2]);
  } catch (const std::exception& e) {
    std::cerr << "Mcap.node_reader: " << e.what() << "\n";
    return 1;
  }
}
