// A streaming writer of MCAP files (https://mcap.dev/spec, major version 0), written from the
// specification. What it writes:
//
//   magic, Header (profile, library)
//   per chunk: Chunk (zstd or uncompressed) holding the Schema and Channel records each message
//     needs before its first message, then the messages; right after it one MessageIndex per
//     channel that has messages in it (ascending channel id)
//   Metadata records, where AddMetadata was called (between chunks: never inside one)
//   Schema and Channel records that no message used (so that a streaming reader sees them too)
//   DataEnd (CRC-32 of every byte before it, magic included)
//   summary: every Schema, every Channel, Statistics, a ChunkIndex per chunk, a MetadataIndex per
//     Metadata record; grouped by opcode, one SummaryOffset per group
//   Footer (summary_start, summary_offset_start, CRC-32 from summary_start to the end of
//     summary_offset_start), magic
//
// Streaming: a chunk's records collect in memory until they reach chunk_size_bytes; then the chunk
// and its message indexes go to the file. What stays in memory for the summary grows with the
// chunks (one ChunkIndex record each, ~80 bytes + 10 per channel) and the schemas, channels and
// metadata, never with the messages.
//
// Deterministic: the same calls give a byte-identical file. Nothing reads a clock; zstd
// compresses single-threaded with the same parameters every time; ids count up in call order.
//
// Errors: a file that cannot be created or written is a std::runtime_error naming it and the OS's
// reason; a call that breaks the contract (an unknown id, a call after Close) is a
// std::invalid_argument or std::logic_error. After an I/O error the file is incomplete and the
// writer refuses further messages.
//
// CRC-32 is zlib's crc32 (the ISO-HDLC polynomial MCAP names). Not thread-safe: one thread writes.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace autonomsim::mcap {

struct WriterOptions {
  std::string profile{"ros2"};  // the Header's profile ("ros2": cdr messages, ros2msg schemas)
  std::string library{"autonomsim"};  // the Header's library
  // A chunk is closed once its uncompressed records reach this many bytes. Larger chunks compress
  // better and index coarser (a reader seeking to a time decompresses a whole chunk); memory holds
  // about one chunk, uncompressed and compressed.
  std::uint64_t chunk_size_bytes{1 << 20};
  bool compress{true};  // chunks compressed with zstd ("zstd"); false: uncompressed ("")
  int zstd_level{3};    // 1 (fastest) to 19 (smallest); 3 is zstd's own default
};

class Writer {
 public:
  // Creates or truncates `path` (the caller checks that it may) and writes the magic and Header.
  // std::runtime_error naming the path and the OS's reason if it cannot.
  explicit Writer(const std::filesystem::path& path, WriterOptions options = {});
  ~Writer();  // Close()s if Close() was not called; errors swallowed (call Close() to see them)
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  // A schema (e.g. name "std_msgs/msg/String", encoding "ros2msg", data the .msg text with its
  // dependencies); ids count from 1. Written into the data section before the first message of a
  // channel that uses it, and into the summary.
  std::uint16_t AddSchema(std::string_view name, std::string_view encoding, std::string_view data);
  // A channel: `schema_id` one AddSchema returned, or 0 for none; ids count from 1. (The ros2
  // profile wants metadata "offered_qos_profiles".) std::invalid_argument for an unknown schema.
  std::uint16_t AddChannel(std::uint16_t schema_id, std::string_view topic,
                           std::string_view message_encoding,
                           const std::map<std::string, std::string>& metadata = {});
  // A message on `channel_id`. Its sequence number is the writer's count of messages on that
  // channel, from 1. Log times may come in any order (the chunk and file start/end are minimum
  // and maximum). std::invalid_argument for an unknown channel.
  void Write(std::uint16_t channel_id, std::uint64_t log_time_ns, std::uint64_t publish_time_ns,
             std::span<const std::uint8_t> data);
  // A Metadata record (name and key/value pairs: the scenario, the seed, versions). Written to the
  // file at once, between chunks; indexed in the summary.
  void AddMetadata(std::string_view name, const std::map<std::string, std::string>& entries);
  // Writes the last chunk and the rest of the file (see the opening comment) and closes it.
  // std::runtime_error naming the file on an I/O error. A second call does nothing.
  void Close();

  struct Counts {
    std::uint64_t messages{0};
    std::uint64_t chunks{0};              // chunks written so far
    std::uint64_t uncompressed_bytes{0};  // the written chunks' records, uncompressed
    std::uint64_t bytes_written{0};       // the file's size so far (all of it once closed)
  };
  Counts counts() const;
  const std::filesystem::path& path() const { return path_; }

 private:
  struct Output;
  struct Chunk;
  struct ChannelInfo {
    std::uint16_t schema_id{0};
    std::vector<std::uint8_t> record;  // its Channel record, written once in each section
    bool in_data_section{false};
    std::uint32_t sequence{0};  // the last message's
    std::uint64_t message_count{0};
  };
  struct SchemaInfo {
    std::vector<std::uint8_t> record;
    bool in_data_section{false};
  };

  void RequireOpen(const char* call) const;
  void WriteDefinitions(ChannelInfo& channel);
  void CloseChunk();
  void WriteMessageIndexes(std::uint64_t* length);
  void WriteUnusedDefinitions();
  std::vector<std::uint8_t> Summary(std::uint64_t summary_start) const;
  void AppendStatistics(std::vector<std::uint8_t>* out) const;

  std::filesystem::path path_;
  WriterOptions options_;
  std::unique_ptr<Output> out_;
  std::unique_ptr<Chunk> chunk_;
  std::vector<SchemaInfo> schemas_;             // [id - 1]
  std::vector<ChannelInfo> channels_;           // [id - 1]
  std::vector<std::uint8_t> chunk_indexes_;     // the summary's ChunkIndex records, in order
  std::vector<std::uint8_t> metadata_indexes_;  // the summary's MetadataIndex records
  std::uint32_t metadata_count_{0};
  Counts counts_;
  std::uint64_t message_start_time_{0};
  std::uint64_t message_end_time_{0};
  bool closed_{false};
};

}  // namespace autonomsim::mcap
