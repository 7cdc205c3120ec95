#include "sim/mcap/tests/mcap_file.h"

#include <zlib.h>
#include <zstd.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <iterator>
#include <stdexcept>

namespace autonomsim::mcap::testing {

std::vector<std::uint8_t> ReadBytes(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + file.string());
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::uint32_t Crc32(std::span<const std::uint8_t> bytes) {
  return static_cast<std::uint32_t>(crc32_z(0, bytes.data(), bytes.size()));
}

std::vector<std::uint8_t> ZstdDecompress(std::span<const std::uint8_t> frame, std::uint64_t size) {
  std::vector<std::uint8_t> out(size + 1);  // one byte more: a frame that gives more shows
  const std::size_t got = ZSTD_decompress(out.data(), out.size(), frame.data(), frame.size());
  if (ZSTD_isError(got)) throw std::runtime_error(ZSTD_getErrorName(got));
  if (got != size) throw std::runtime_error("zstd frame of " + std::to_string(got) + " bytes");
  out.resize(size);
  return out;
}

std::span<const std::uint8_t> FieldReader::Take(std::uint64_t size) {
  if (size > bytes_.size() - position_) throw std::out_of_range("field past the record's end");
  const std::span<const std::uint8_t> field = bytes_.subspan(position_, size);
  position_ += size;
  return field;
}

std::uint8_t FieldReader::U8() { return Take(1)[0]; }

std::uint16_t FieldReader::U16() {
  const auto b = Take(2);
  return static_cast<std::uint16_t>(b[0] | b[1] << 8);
}

std::uint32_t FieldReader::U32() {
  const auto b = Take(4);
  std::uint32_t value = 0;
  for (int i = 3; i >= 0; --i) value = value << 8 | b[i];
  return value;
}

std::uint64_t FieldReader::U64() {
  const std::uint64_t low = U32();
  return low | static_cast<std::uint64_t>(U32()) << 32;
}

std::string FieldReader::String() {
  const auto bytes = Take(U32());
  return {bytes.begin(), bytes.end()};
}

std::map<std::string, std::string> FieldReader::StringMap() {
  FieldReader entries(Take(U32()));
  std::map<std::string, std::string> map;
  while (!entries.AtEnd()) {
    std::string key = entries.String();
    map[key] = entries.String();
  }
  return map;
}

std::map<std::uint16_t, std::uint64_t> FieldReader::U16U64Map() {
  FieldReader entries(Take(U32()));
  std::map<std::uint16_t, std::uint64_t> map;
  while (!entries.AtEnd()) {
    const std::uint16_t key = entries.U16();
    map[key] = entries.U64();
  }
  return map;
}

std::vector<Record> ParseRecords(std::span<const std::uint8_t> bytes, std::uint64_t base) {
  std::vector<Record> records;
  FieldReader reader(bytes);
  std::uint64_t offset = base;
  while (!reader.AtEnd()) {
    const std::uint8_t opcode = reader.U8();
    const std::uint64_t length = reader.U64();
    records.push_back({opcode, offset, 1 + 8 + length, reader.Take(length)});
    offset += 1 + 8 + length;
  }
  return records;
}

McapFile::McapFile(const std::filesystem::path& file) : bytes(ReadBytes(file)) {
  const std::size_t magic = sizeof kMcapMagic;
  if (bytes.size() < 2 * magic || !std::equal(kMcapMagic, kMcapMagic + magic, bytes.begin()) ||
      !std::equal(kMcapMagic, kMcapMagic + magic, bytes.end() - magic)) {
    throw std::runtime_error(file.string() + ": no MCAP magic at both ends");
  }
  records = ParseRecords(std::span(bytes).subspan(magic, bytes.size() - 2 * magic), magic);
}

const Record& McapFile::At(std::uint64_t offset) const {
  for (const Record& record : records) {
    if (record.offset == offset) return record;
  }
  throw std::runtime_error("no record at offset " + std::to_string(offset));
}

std::vector<std::uint8_t> ChunkFields::Uncompressed() const {
  if (compression == "zstd") return ZstdDecompress(records, uncompressed_size);
  if (compression.empty()) return {records.begin(), records.end()};
  throw std::runtime_error("compression " + compression);
}

ChunkFields ParseChunk(const Record& record) {
  FieldReader r(record.content);
  ChunkFields chunk{r.U64(), r.U64(), r.U64(), r.U32(), "", {}};
  chunk.compression = r.String();
  chunk.records = r.Take(r.U64());
  return chunk;
}

ChunkIndexFields ParseChunkIndex(const Record& record) {
  FieldReader r(record.content);
  ChunkIndexFields index{};
  index.message_start_time = r.U64();
  index.message_end_time = r.U64();
  index.chunk_start_offset = r.U64();
  index.chunk_length = r.U64();
  index.message_index_offsets = r.U16U64Map();
  index.message_index_length = r.U64();
  index.compression = r.String();
  index.compressed_size = r.U64();
  index.uncompressed_size = r.U64();
  return index;
}

MessageFields ParseMessage(const Record& record) {
  FieldReader r(record.content);
  MessageFields message{};
  message.channel_id = r.U16();
  message.sequence = r.U32();
  message.log_time = r.U64();
  message.publish_time = r.U64();
  const auto data = r.Rest();
  message.data.assign(data.begin(), data.end());
  return message;
}

MessageIndexFields ParseMessageIndex(const Record& record) {
  FieldReader r(record.content);
  MessageIndexFields index{r.U16(), {}};
  FieldReader entries(r.Take(r.U32()));
  while (!entries.AtEnd()) {
    const std::uint64_t log_time = entries.U64();
    index.entries.emplace_back(log_time, entries.U64());
  }
  return index;
}

StatisticsFields ParseStatistics(const Record& record) {
  FieldReader r(record.content);
  StatisticsFields stats{};
  stats.message_count = r.U64();
  stats.schema_count = r.U16();
  stats.channel_count = r.U32();
  stats.attachment_count = r.U32();
  stats.metadata_count = r.U32();
  stats.chunk_count = r.U32();
  stats.message_start_time = r.U64();
  stats.message_end_time = r.U64();
  stats.channel_message_counts = r.U16U64Map();
  return stats;
}

FooterFields ParseFooter(const Record& record) {
  FieldReader r(record.content);
  FooterFields footer{};
  footer.summary_start = r.U64();
  footer.summary_offset_start = r.U64();
  footer.summary_crc = r.U32();
  return footer;
}

std::vector<StreamedRecord> StreamDataSection(const McapFile& file) {
  std::vector<StreamedRecord> out;
  for (std::size_t i = 1; i < file.records.size(); ++i) {  // after the Header
    const Record& record = file.records[i];
    if (record.opcode == 0x06) {
      const std::vector<std::uint8_t> records = ParseChunk(record).Uncompressed();
      for (const Record& inner : ParseRecords(records)) {
        out.push_back({inner.opcode, true, {inner.content.begin(), inner.content.end()}});
      }
    } else {
      out.push_back({record.opcode, false, {record.content.begin(), record.content.end()}});
    }
    if (record.opcode == 0x0F) break;  // DataEnd
  }
  return out;
}

}  // namespace autonomsim::mcap::testing
