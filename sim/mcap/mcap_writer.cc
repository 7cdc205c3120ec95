#include "sim/mcap/mcap_writer.h"

#include <zlib.h>
#include <zstd.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <limits>
#include <new>
#include <stdexcept>
#include <string>
#include <utility>

namespace autonomsim::mcap {
namespace {

static_assert(std::endian::native == std::endian::little,
              "mcap::Writer copies integers as they are in memory: MCAP is little-endian");

constexpr std::uint8_t kMagic[] = {0x89, 'M', 'C', 'A', 'P', 0x30, '\r', '\n'};

// Record opcodes (spec, "Records").
enum Opcode : std::uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kMessageIndex = 0x07,
  kChunkIndex = 0x08,
  kStatistics = 0x0B,
  kMetadata = 0x0C,
  kMetadataIndex = 0x0D,
  kSummaryOffset = 0x0E,
  kDataEnd = 0x0F,
};

constexpr std::size_t kRecordPrefix = 1 + 8;  // opcode, uint64 content length
constexpr std::size_t kFileBuffer = 1 << 20;  // stdio's buffer: one write(2) per MiB
constexpr std::uint64_t kMaxChunkReserve = 64 << 20;
constexpr std::size_t kMessageFields = 2 + 4 + 8 + 8;  // channel_id, sequence, log and publish time

// Appends `value` little-endian.
template <typename T>
void Put(std::vector<std::uint8_t>* out, T value) {
  const std::size_t at = out->size();
  out->resize(at + sizeof(T));
  std::memcpy(out->data() + at, &value, sizeof(T));
}

// Stores `value` little-endian at `at` (room made already); returns the byte after it.
template <typename T>
std::uint8_t* Store(std::uint8_t* at, T value) {
  std::memcpy(at, &value, sizeof(T));
  return at + sizeof(T);
}

void PutRaw(std::vector<std::uint8_t>* out, std::span<const std::uint8_t> bytes) {
  out->insert(out->end(), bytes.begin(), bytes.end());
}

// A uint32 length, as String, Bytes with a uint32 prefix, Array and Map use; std::length_error
// beyond it.
std::uint32_t Length32(std::size_t size) {
  if (size > std::numeric_limits<std::uint32_t>::max()) {
    throw std::length_error("mcap::Writer: a field longer than 4 GiB");
  }
  return static_cast<std::uint32_t>(size);
}

// String (and the uint32 length-prefixed Bytes of a Schema's data): length, bytes.
void PutString(std::vector<std::uint8_t>* out, std::string_view text) {
  Put(out, Length32(text.size()));
  out->insert(out->end(), text.begin(), text.end());
}

// Opens a record: its opcode and a length to patch; returns where the length is.
std::size_t BeginRecord(std::vector<std::uint8_t>* out, Opcode opcode) {
  out->push_back(opcode);
  Put<std::uint64_t>(out, 0);
  return out->size() - 8;
}

void PatchLength(std::vector<std::uint8_t>* out, std::size_t length_at, std::uint64_t length) {
  std::memcpy(out->data() + length_at, &length, sizeof length);
}

// Closes the record BeginRecord opened: its content length is what follows the length field.
void EndRecord(std::vector<std::uint8_t>* out, std::size_t length_at) {
  PatchLength(out, length_at, out->size() - length_at - 8);
}

// Map<string, string>: the entries' byte length, then key, value, ... in the map's (sorted) order.
void PutStringMap(std::vector<std::uint8_t>* out, const std::map<std::string, std::string>& map) {
  const std::size_t length_at = out->size();
  Put<std::uint32_t>(out, 0);
  for (const auto& [key, value] : map) {
    PutString(out, key);
    PutString(out, value);
  }
  const std::uint32_t length = Length32(out->size() - length_at - 4);
  std::memcpy(out->data() + length_at, &length, sizeof length);
}

std::uint32_t Crc32(std::uint32_t crc, std::span<const std::uint8_t> bytes) {
  return static_cast<std::uint32_t>(crc32_z(crc, bytes.data(), bytes.size()));
}

}  // namespace

// Types of Writer::Chunk's members (not in the anonymous namespace: Chunk is not in it).
namespace detail {
struct MessageIndexEntry {
  std::uint64_t log_time;
  std::uint64_t offset;  // of the Message record in the uncompressed chunk records
};

struct ZstdContextFree {
  void operator()(ZSTD_CCtx* context) const { ZSTD_freeCCtx(context); }
};
}  // namespace detail
using detail::MessageIndexEntry;

// The file: its stdio stream, the bytes written so far and their running CRC-32.
struct Writer::Output {
  std::filesystem::path path;
  std::vector<char> buffer = std::vector<char>(kFileBuffer);
  std::FILE* file{nullptr};
  std::uint64_t position{0};  // bytes written: the offset of the next record
  std::uint32_t crc{0};       // CRC-32 of those bytes (the data section's until DataEnd)
  bool failed{false};

  explicit Output(std::filesystem::path file_path) : path(std::move(file_path)) {
    file = std::fopen(path.c_str(), "wb");
    if (file == nullptr) Fail("create");
    std::setvbuf(file, buffer.data(), _IOFBF, buffer.size());
  }
  ~Output() {
    if (file != nullptr) std::fclose(file);
  }
  Output(const Output&) = delete;
  Output& operator=(const Output&) = delete;

  void Write(std::span<const std::uint8_t> bytes) {
    if (bytes.empty()) return;
    if (std::fwrite(bytes.data(), 1, bytes.size(), file) != bytes.size()) Fail("write");
    crc = Crc32(crc, bytes);
    position += bytes.size();
  }
  // Flushes and closes the file.
  void Finish() {
    std::FILE* closing = std::exchange(file, nullptr);
    const bool flushed = std::fflush(closing) == 0;
    const int flush_errno = errno;
    if (std::fclose(closing) != 0 || !flushed) {
      if (!flushed) errno = flush_errno;
      Fail("write");
    }
  }
  [[noreturn]] void Fail(const char* what) {
    const int error = errno;
    failed = true;
    throw std::runtime_error("mcap::Writer: cannot " + std::string(what) + " " + path.string() +
                             ": " + std::strerror(error));
  }
};

// The open chunk: its uncompressed records and what its MessageIndex and ChunkIndex records need;
// the compressor and buffers, reused from chunk to chunk.
struct Writer::Chunk {
  std::vector<std::uint8_t> records;
  std::vector<std::uint8_t> compressed;
  std::vector<std::uint8_t> scratch;  // a record being built (chunk prefix, message index)
  std::unique_ptr<ZSTD_CCtx, detail::ZstdContextFree> zstd;
  std::uint64_t start_time{0};
  std::uint64_t end_time{0};
  bool has_messages{false};
  std::vector<std::vector<MessageIndexEntry>> index;  // [channel id - 1]
  std::vector<std::uint16_t> channels;                // the channels with messages in this chunk

  explicit Chunk(const WriterOptions& options) {
    // A chunk closes once past chunk_size_bytes: room for that and a message beyond it, within
    // reason (a larger one grows as a vector does).
    records.reserve(std::min<std::uint64_t>(options.chunk_size_bytes + options.chunk_size_bytes / 8,
                                            kMaxChunkReserve));
    if (!options.compress) return;
    zstd.reset(ZSTD_createCCtx());
    if (!zstd) throw std::bad_alloc();
    const std::size_t set =
        ZSTD_CCtx_setParameter(zstd.get(), ZSTD_c_compressionLevel, options.zstd_level);
    if (ZSTD_isError(set)) {
      throw std::invalid_argument("mcap::WriterOptions: zstd_level " +
                                  std::to_string(options.zstd_level) + ": " +
                                  ZSTD_getErrorName(set));
    }
  }

  void AddMessage(std::uint16_t channel_id, std::uint64_t log_time, std::uint64_t offset) {
    if (index.size() < channel_id) index.resize(channel_id);
    std::vector<MessageIndexEntry>& entries = index[channel_id - 1];
    if (entries.empty()) channels.push_back(channel_id);
    entries.push_back({log_time, offset});
    start_time = has_messages ? std::min(start_time, log_time) : log_time;
    end_time = has_messages ? std::max(end_time, log_time) : log_time;
    has_messages = true;
  }

  // The records compressed with zstd (one frame, its content size in the frame header).
  std::span<const std::uint8_t> Compress() {
    compressed.resize(ZSTD_compressBound(records.size()));
    const std::size_t size = ZSTD_compress2(zstd.get(), compressed.data(), compressed.size(),
                                            records.data(), records.size());
    if (ZSTD_isError(size)) {
      throw std::runtime_error(std::string("mcap::Writer: zstd: ") + ZSTD_getErrorName(size));
    }
    return {compressed.data(), size};
  }

  void Clear() {
    records.clear();
    for (std::uint16_t channel_id : channels) index[channel_id - 1].clear();
    channels.clear();
    has_messages = false;
    start_time = end_time = 0;
  }
};

Writer::Writer(const std::filesystem::path& path, WriterOptions options)
    : path_(path),
      options_(std::move(options)),
      out_(std::make_unique<Output>(path)),
      chunk_(std::make_unique<Chunk>(options_)) {
  std::vector<std::uint8_t> head(std::begin(kMagic), std::end(kMagic));
  const std::size_t length_at = BeginRecord(&head, kHeader);
  PutString(&head, options_.profile);
  PutString(&head, options_.library);
  EndRecord(&head, length_at);
  out_->Write(head);
}

Writer::~Writer() {
  if (closed_) return;
  try {
    Close();
  } catch (...) {  // NOLINT(bugprone-empty-catch): documented; Close() reports errors
  }
}

void Writer::RequireOpen(const char* call) const {
  if (closed_) throw std::logic_error(std::string("mcap::Writer::") + call + " after Close");
  if (out_->failed) {
    throw std::runtime_error(std::string("mcap::Writer::") + call + ": an earlier write to " +
                             path_.string() + " failed");
  }
}

std::uint16_t Writer::AddSchema(std::string_view name, std::string_view encoding,
                                std::string_view data) {
  RequireOpen("AddSchema");
  if (schemas_.size() >= std::numeric_limits<std::uint16_t>::max()) {
    throw std::length_error("mcap::Writer::AddSchema: 65535 schemas already");
  }
  const auto id = static_cast<std::uint16_t>(schemas_.size() + 1);
  SchemaInfo& schema = schemas_.emplace_back();
  const std::size_t length_at = BeginRecord(&schema.record, kSchema);
  Put(&schema.record, id);
  PutString(&schema.record, name);
  PutString(&schema.record, encoding);
  PutString(&schema.record, data);
  EndRecord(&schema.record, length_at);
  return id;
}

std::uint16_t Writer::AddChannel(std::uint16_t schema_id, std::string_view topic,
                                 std::string_view message_encoding,
                                 const std::map<std::string, std::string>& metadata) {
  RequireOpen("AddChannel");
  if (schema_id > schemas_.size()) {
    throw std::invalid_argument("mcap::Writer::AddChannel: no schema " + std::to_string(schema_id) +
                                " for topic " + std::string(topic));
  }
  if (channels_.size() >= std::numeric_limits<std::uint16_t>::max()) {
    throw std::length_error("mcap::Writer::AddChannel: 65535 channels already");
  }
  const auto id = static_cast<std::uint16_t>(channels_.size() + 1);
  ChannelInfo& channel = channels_.emplace_back();
  channel.schema_id = schema_id;
  const std::size_t length_at = BeginRecord(&channel.record, kChannel);
  Put(&channel.record, id);
  Put(&channel.record, schema_id);
  PutString(&channel.record, topic);
  PutString(&channel.record, message_encoding);
  PutStringMap(&channel.record, metadata);
  EndRecord(&channel.record, length_at);
  return id;
}

// The channel's Schema (unless written already) and Channel records, into the open chunk.
void Writer::WriteDefinitions(ChannelInfo& channel) {
  if (channel.schema_id != 0) {
    SchemaInfo& schema = schemas_[channel.schema_id - 1];
    if (!schema.in_data_section) PutRaw(&chunk_->records, schema.record);
    schema.in_data_section = true;
  }
  PutRaw(&chunk_->records, channel.record);
  channel.in_data_section = true;
}

void Writer::Write(std::uint16_t channel_id, std::uint64_t log_time_ns,
                   std::uint64_t publish_time_ns, std::span<const std::uint8_t> data) {
  RequireOpen("Write");
  if (channel_id == 0 || channel_id > channels_.size()) {
    throw std::invalid_argument("mcap::Writer::Write: no channel " + std::to_string(channel_id));
  }
  ChannelInfo& channel = channels_[channel_id - 1];
  if (!channel.in_data_section) WriteDefinitions(channel);
  ++channel.sequence;
  ++channel.message_count;

  // The Message record, its fixed part copied in one go.
  std::vector<std::uint8_t>& records = chunk_->records;
  const std::uint64_t offset = records.size();
  const std::uint64_t length = kMessageFields + data.size();
  records.resize(offset + kRecordPrefix + kMessageFields);
  std::uint8_t* at = records.data() + offset;
  at = Store(at, kMessage);
  at = Store(at, length);
  at = Store(at, channel_id);
  at = Store(at, channel.sequence);
  at = Store(at, log_time_ns);
  Store(at, publish_time_ns);
  PutRaw(&records, data);

  chunk_->AddMessage(channel_id, log_time_ns, offset);
  message_start_time_ =
      counts_.messages == 0 ? log_time_ns : std::min(message_start_time_, log_time_ns);
  message_end_time_ = std::max(message_end_time_, log_time_ns);
  ++counts_.messages;
  if (records.size() >= options_.chunk_size_bytes) CloseChunk();
}

void Writer::AddMetadata(std::string_view name, const std::map<std::string, std::string>& entries) {
  RequireOpen("AddMetadata");
  std::vector<std::uint8_t>& record = chunk_->scratch;
  record.clear();
  const std::size_t length_at = BeginRecord(&record, kMetadata);
  PutString(&record, name);
  PutStringMap(&record, entries);
  EndRecord(&record, length_at);
  const std::uint64_t offset = out_->position;
  out_->Write(record);

  const std::size_t index_at = BeginRecord(&metadata_indexes_, kMetadataIndex);
  Put(&metadata_indexes_, offset);
  Put<std::uint64_t>(&metadata_indexes_, record.size());
  PutString(&metadata_indexes_, name);
  EndRecord(&metadata_indexes_, index_at);
  ++metadata_count_;
}

// Writes the open chunk (if it holds anything) and its message indexes, and keeps its ChunkIndex.
void Writer::CloseChunk() {
  Chunk& chunk = *chunk_;
  if (chunk.records.empty()) return;
  const std::uint32_t crc = Crc32(0, chunk.records);
  const std::span<const std::uint8_t> stored =
      options_.compress ? chunk.Compress() : std::span<const std::uint8_t>(chunk.records);
  const std::string_view compression = options_.compress ? "zstd" : "";

  std::vector<std::uint8_t>& prefix = chunk.scratch;  // the Chunk record up to its records
  prefix.clear();
  const std::size_t length_at = BeginRecord(&prefix, kChunk);
  Put(&prefix, chunk.start_time);
  Put(&prefix, chunk.end_time);
  Put<std::uint64_t>(&prefix, chunk.records.size());
  Put(&prefix, crc);
  PutString(&prefix, compression);
  Put<std::uint64_t>(&prefix, stored.size());
  PatchLength(&prefix, length_at, prefix.size() - length_at - 8 + stored.size());
  const std::uint64_t chunk_start = out_->position;
  out_->Write(prefix);
  out_->Write(stored);
  const std::uint64_t chunk_length = out_->position - chunk_start;

  const std::size_t index_at = BeginRecord(&chunk_indexes_, kChunkIndex);
  Put(&chunk_indexes_, chunk.start_time);
  Put(&chunk_indexes_, chunk.end_time);
  Put(&chunk_indexes_, chunk_start);
  Put(&chunk_indexes_, chunk_length);
  std::uint64_t message_index_length = 0;
  WriteMessageIndexes(&message_index_length);  // appends message_index_offsets
  Put(&chunk_indexes_, message_index_length);
  PutString(&chunk_indexes_, compression);
  Put<std::uint64_t>(&chunk_indexes_, stored.size());
  Put<std::uint64_t>(&chunk_indexes_, chunk.records.size());
  EndRecord(&chunk_indexes_, index_at);

  ++counts_.chunks;
  counts_.uncompressed_bytes += chunk.records.size();
  chunk.Clear();
}

// Writes the open chunk's MessageIndex records (ascending channel id) and appends their offsets,
// the ChunkIndex's message_index_offsets, to chunk_indexes_; `length` is set to their bytes.
void Writer::WriteMessageIndexes(std::uint64_t* length) {
  Chunk& chunk = *chunk_;
  std::sort(chunk.channels.begin(), chunk.channels.end());
  Put(&chunk_indexes_, Length32(chunk.channels.size() * (2 + 8)));
  const std::uint64_t start = out_->position;
  for (std::uint16_t channel_id : chunk.channels) {
    const std::vector<MessageIndexEntry>& entries = chunk.index[channel_id - 1];
    std::vector<std::uint8_t>& record = chunk.scratch;
    record.clear();
    const std::size_t length_at = BeginRecord(&record, kMessageIndex);
    Put(&record, channel_id);
    Put(&record, Length32(entries.size() * sizeof(MessageIndexEntry)));
    for (const MessageIndexEntry& entry : entries) {
      Put(&record, entry.log_time);
      Put(&record, entry.offset);
    }
    EndRecord(&record, length_at);
    Put(&chunk_indexes_, channel_id);
    Put(&chunk_indexes_, out_->position);
    out_->Write(record);
  }
  *length = out_->position - start;
}

// Schemas and channels no message brought into a chunk: top-level records in the data section.
void Writer::WriteUnusedDefinitions() {
  for (SchemaInfo& schema : schemas_) {
    if (!schema.in_data_section) out_->Write(schema.record);
    schema.in_data_section = true;
  }
  for (ChannelInfo& channel : channels_) {
    if (!channel.in_data_section) out_->Write(channel.record);
    channel.in_data_section = true;
  }
}

void Writer::AppendStatistics(std::vector<std::uint8_t>* out) const {
  const std::size_t length_at = BeginRecord(out, kStatistics);
  Put(out, counts_.messages);
  Put(out, static_cast<std::uint16_t>(schemas_.size()));
  Put(out, static_cast<std::uint32_t>(channels_.size()));
  Put<std::uint32_t>(out, 0);  // attachments
  Put(out, metadata_count_);
  Put(out, static_cast<std::uint32_t>(counts_.chunks));
  Put(out, message_start_time_);
  Put(out, message_end_time_);
  Put(out, Length32(channels_.size() * (2 + 8)));  // channel_message_counts, every channel
  for (std::size_t i = 0; i < channels_.size(); ++i) {
    Put(out, static_cast<std::uint16_t>(i + 1));
    Put(out, channels_[i].message_count);
  }
  EndRecord(out, length_at);
}

// Everything after DataEnd: the summary, one SummaryOffset per group, the Footer with the summary
// CRC, the closing magic.
std::vector<std::uint8_t> Writer::Summary(std::uint64_t summary_start) const {
  std::size_t size = chunk_indexes_.size() + metadata_indexes_.size() + 256 + 10 * channels_.size();
  for (const SchemaInfo& schema : schemas_) size += schema.record.size();
  for (const ChannelInfo& channel : channels_) size += channel.record.size();
  std::vector<std::uint8_t> tail;
  tail.reserve(size);  // about the final size: the summary offsets and footer are under 256 bytes
  struct Group {
    Opcode opcode;
    std::uint64_t start, length;
  };
  std::vector<Group> groups;
  auto group = [&](Opcode opcode, auto append) {
    const std::size_t before = tail.size();
    append();
    if (tail.size() > before) {
      groups.push_back({opcode, summary_start + before, tail.size() - before});
    }
  };
  group(kSchema, [&] {
    for (const SchemaInfo& schema : schemas_) PutRaw(&tail, schema.record);
  });
  group(kChannel, [&] {
    for (const ChannelInfo& c : channels_) PutRaw(&tail, c.record);
  });
  group(kStatistics, [&] { AppendStatistics(&tail); });
  group(kChunkIndex, [&] { PutRaw(&tail, chunk_indexes_); });
  group(kMetadataIndex, [&] { PutRaw(&tail, metadata_indexes_); });

  const std::uint64_t summary_offset_start = summary_start + tail.size();
  for (const Group& g : groups) {
    const std::size_t length_at = BeginRecord(&tail, kSummaryOffset);
    tail.push_back(g.opcode);
    Put(&tail, g.start);
    Put(&tail, g.length);
    EndRecord(&tail, length_at);
  }
  const std::size_t length_at = BeginRecord(&tail, kFooter);
  Put(&tail, summary_start);
  Put(&tail, summary_offset_start);
  PatchLength(&tail, length_at, 8 + 8 + 4);
  Put(&tail, Crc32(0, tail));  // from summary_start through summary_offset_start
  tail.insert(tail.end(), std::begin(kMagic), std::end(kMagic));
  return tail;
}

void Writer::Close() {
  if (closed_) return;
  closed_ = true;  // whatever happens next, the destructor does not try again
  if (out_->failed) {
    throw std::runtime_error("mcap::Writer::Close: an earlier write to " + path_.string() +
                             " failed; the file is incomplete");
  }
  CloseChunk();
  WriteUnusedDefinitions();
  std::vector<std::uint8_t> data_end;
  const std::size_t length_at = BeginRecord(&data_end, kDataEnd);
  Put(&data_end, out_->crc);  // CRC-32 of every byte before this record
  EndRecord(&data_end, length_at);
  out_->Write(data_end);
  const std::uint64_t summary_start = out_->position;
  out_->Write(Summary(summary_start));
  out_->Finish();
}

Writer::Counts Writer::counts() const {
  Counts counts = counts_;
  counts.bytes_written = out_->position;
  return counts;
}

}  // namespace autonomsim::mcap
