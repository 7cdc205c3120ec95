// The tests' own MCAP reader, written from the specification independently of the writer (no
// code shared with it): a file's records by offset, the fields of the records the writer writes,
// chunks decompressed with libzstd, CRC-32 from zlib. It checks nothing itself beyond bounds (a
// record that runs past its bytes throws); the tests compare what it finds with the spec.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace autonomsim::mcap::testing {

inline constexpr std::uint8_t kMcapMagic[] = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};

std::vector<std::uint8_t> ReadBytes(const std::filesystem::path& file);
std::uint32_t Crc32(std::span<const std::uint8_t> bytes);
// A zstd frame decompressed; throws unless it gives exactly `size` bytes.
std::vector<std::uint8_t> ZstdDecompress(std::span<const std::uint8_t> frame, std::uint64_t size);

// Little-endian fields read in order; std::out_of_range past the end.
class FieldReader {
 public:
  explicit FieldReader(std::span<const std::uint8_t> bytes) : bytes_(bytes) {}
  std::uint8_t U8();
  std::uint16_t U16();
  std::uint32_t U32();
  std::uint64_t U64();
  std::string String();
  std::map<std::string, std::string> StringMap();
  std::map<std::uint16_t, std::uint64_t> U16U64Map();
  std::span<const std::uint8_t> Take(std::uint64_t size);
  std::span<const std::uint8_t> Rest() { return Take(bytes_.size() - position_); }
  bool AtEnd() const { return position_ == bytes_.size(); }

 private:
  std::span<const std::uint8_t> bytes_;
  std::size_t position_{0};
};

struct Record {
  std::uint8_t opcode;
  std::uint64_t offset;  // of the opcode, from the start of the bytes parsed
  std::uint64_t length;  // the whole record: opcode, length, content
  std::span<const std::uint8_t> content;
};
// The records of `bytes` (a sequence of opcode, uint64 length, content), offsets from `base`.
std::vector<Record> ParseRecords(std::span<const std::uint8_t> bytes, std::uint64_t base = 0);

// A whole file: the magic at both ends checked, the records between them.
struct McapFile {
  std::vector<std::uint8_t> bytes;
  std::vector<Record> records;  // Header ... Footer
  explicit McapFile(const std::filesystem::path& file);
  const Record& At(std::uint64_t offset) const;  // the record starting there, or throws
};

struct ChunkFields {
  std::uint64_t message_start_time, message_end_time, uncompressed_size;
  std::uint32_t uncompressed_crc;
  std::string compression;
  std::span<const std::uint8_t> records;
  std::vector<std::uint8_t> Uncompressed() const;  // `records` decompressed
};
ChunkFields ParseChunk(const Record& record);

struct ChunkIndexFields {
  std::uint64_t message_start_time, message_end_time, chunk_start_offset, chunk_length;
  std::map<std::uint16_t, std::uint64_t> message_index_offsets;
  std::uint64_t message_index_length;
  std::string compression;
  std::uint64_t compressed_size, uncompressed_size;
};
ChunkIndexFields ParseChunkIndex(const Record& record);

struct MessageFields {
  std::uint16_t channel_id;
  std::uint32_t sequence;
  std::uint64_t log_time, publish_time;
  std::vector<std::uint8_t> data;
  bool operator==(const MessageFields&) const = default;
};
MessageFields ParseMessage(const Record& record);

struct MessageIndexFields {
  std::uint16_t channel_id;
  std::vector<std::pair<std::uint64_t, std::uint64_t>> entries;  // log_time, offset
};
MessageIndexFields ParseMessageIndex(const Record& record);

struct StatisticsFields {
  std::uint64_t message_count;
  std::uint16_t schema_count;
  std::uint32_t channel_count, attachment_count, metadata_count, chunk_count;
  std::uint64_t message_start_time, message_end_time;
  std::map<std::uint16_t, std::uint64_t> channel_message_counts;
};
StatisticsFields ParseStatistics(const Record& record);

struct FooterFields {
  std::uint64_t summary_start, summary_offset_start;
  std::uint32_t summary_crc;
};
FooterFields ParseFooter(const Record& record);

// A record as a streaming reader meets it: the data section in order, each chunk's records in
// place of the chunk (copied out of the decompressed chunk).
struct StreamedRecord {
  std::uint8_t opcode;
  bool in_chunk;
  std::vector<std::uint8_t> content;
  Record AsRecord() const { return {opcode, 0, 1 + 8 + content.size(), content}; }
};
// The data section's records (after the Header, up to and including DataEnd), chunks expanded.
std::vector<StreamedRecord> StreamDataSection(const McapFile& file);

}  // namespace autonomsim::mcap::testing
