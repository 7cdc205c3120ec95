// The writer's files read back with the tests' own reader (mcap_file.h) and checked against the
// specification (mcap.dev/spec): magic, the CRCs recomputed, indexes followed to what they index,
// statistics counted, determinism, chunking, and the errors. tools/tests/mcap_check.mjs reads the
// files with Foxglove's libraries besides (Mcap.node_reader).
#include "sim/mcap/mcap_writer.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "sim/mcap/tests/mcap_file.h"

namespace autonomsim::mcap {
namespace {

namespace fs = std::filesystem;
using testing::ChunkFields;
using testing::McapFile;
using testing::MessageFields;
using testing::Record;

constexpr std::uint8_t kOpHeader = 0x01, kOpFooter = 0x02, kOpSchema = 0x03, kOpChannel = 0x04,
                       kOpMessage = 0x05, kOpChunk = 0x06, kOpMessageIndex = 0x07,
                       kOpChunkIndex = 0x08, kOpStatistics = 0x0B, kOpMetadata = 0x0C,
                       kOpMetadataIndex = 0x0D, kOpSummaryOffset = 0x0E, kOpDataEnd = 0x0F;

class McapWriterTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("autonomsim_mcap_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // A file of `count` messages alternating between two channels (the second with every third
  // message), data of varying length, log times 1000 + 10 i ns, publish times one less.
  // Returns what it wrote, with the sequence numbers the writer should have given.
  std::vector<MessageFields> WriteSample(const fs::path& file, WriterOptions options, int count) {
    Writer writer(file, options);
    const std::uint16_t text = writer.AddSchema("std_msgs/msg/String", "ros2msg", "string data");
    const std::uint16_t a = writer.AddChannel(text, "/a", "cdr", {{"offered_qos_profiles", ""}});
    const std::uint16_t b = writer.AddChannel(text, "/b", "cdr");
    std::vector<MessageFields> written;
    std::map<std::uint16_t, std::uint32_t> sequence;
    for (int i = 0; i < count; ++i) {
      const std::uint16_t channel = i % 3 == 2 ? b : a;
      const std::uint64_t log_time = 1000 + 10 * static_cast<std::uint64_t>(i);
      std::vector<std::uint8_t> data(static_cast<std::size_t>(20 + i % 50));
      for (std::size_t k = 0; k < data.size(); ++k) data[k] = static_cast<std::uint8_t>(i + k);
      writer.Write(channel, log_time, log_time - 1, data);
      written.push_back({channel, ++sequence[channel], log_time, log_time - 1, data});
    }
    writer.AddMetadata("run", {{"seed", "7"}, {"scenario", "lab"}});
    writer.Close();
    return written;
  }

  fs::path dir_;
};

std::vector<const Record*> WithOpcode(const McapFile& file, std::uint8_t opcode) {
  std::vector<const Record*> found;
  for (const Record& record : file.records) {
    if (record.opcode == opcode) found.push_back(&record);
  }
  return found;
}

TEST_F(McapWriterTest, TheFileHasMagicAtBothEndsAHeaderFirstAndAFooterLast) {
  const fs::path file = dir_ / "a.mcap";
  WriteSample(file, {.profile = "ros2", .library = "autonomsim test"}, 10);
  const McapFile mcap(file);  // throws without the magic at both ends
  ASSERT_GE(mcap.records.size(), 3U);
  EXPECT_EQ(mcap.records.front().opcode, kOpHeader);
  EXPECT_EQ(mcap.records.front().offset, 8U);
  testing::FieldReader header(mcap.records.front().content);
  EXPECT_EQ(header.String(), "ros2");
  EXPECT_EQ(header.String(), "autonomsim test");
  EXPECT_TRUE(header.AtEnd());
  EXPECT_EQ(mcap.records.back().opcode, kOpFooter);
  EXPECT_EQ(mcap.records.back().length, 1U + 8 + 20);
}

TEST_F(McapWriterTest, TheFootersSummaryCrcAndDataEndsCrcRecompute) {
  const fs::path file = dir_ / "a.mcap";
  WriteSample(file, {}, 100);
  const McapFile mcap(file);
  const Record& footer_record = mcap.records.back();
  const testing::FooterFields footer = testing::ParseFooter(footer_record);
  // the summary starts right after DataEnd
  const auto data_end = WithOpcode(mcap, kOpDataEnd);
  ASSERT_EQ(data_end.size(), 1U);
  EXPECT_EQ(footer.summary_start, data_end[0]->offset + data_end[0]->length);
  EXPECT_EQ(mcap.At(footer.summary_offset_start).opcode, kOpSummaryOffset);
  // summary CRC: summary_start up to and including the footer's summary_offset_start
  const std::uint64_t crc_end = footer_record.offset + 1 + 8 + 8 + 8;
  EXPECT_EQ(
      footer.summary_crc,
      testing::Crc32(
          std::span(mcap.bytes).subspan(footer.summary_start, crc_end - footer.summary_start)));
  // data section CRC: every byte before the DataEnd record, the opening magic included
  testing::FieldReader data_end_fields(data_end[0]->content);
  EXPECT_EQ(data_end_fields.U32(),
            testing::Crc32(std::span(mcap.bytes).first(data_end[0]->offset)));
}

TEST_F(McapWriterTest, TheSummaryIsGroupedByOpcodeAndEachGroupHasItsOffset) {
  const fs::path file = dir_ / "a.mcap";
  WriteSample(file, {.chunk_size_bytes = 1000}, 100);
  const McapFile mcap(file);
  const testing::FooterFields footer = testing::ParseFooter(mcap.records.back());
  std::vector<std::uint8_t> order;  // the summary's opcodes, one per group
  std::map<std::uint8_t, std::pair<std::uint64_t, std::uint64_t>> groups;  // start, length
  for (const Record& record : mcap.records) {
    if (record.offset < footer.summary_start || record.offset >= footer.summary_offset_start) {
      continue;
    }
    if (order.empty() || order.back() != record.opcode) {
      ASSERT_EQ(groups.count(record.opcode), 0U) << "opcode " << int{record.opcode} << " twice";
      order.push_back(record.opcode);
      groups[record.opcode] = {record.offset, 0};
    }
    groups[record.opcode].second += record.length;
  }
  EXPECT_EQ(order, (std::vector<std::uint8_t>{kOpSchema, kOpChannel, kOpStatistics, kOpChunkIndex,
                                              kOpMetadataIndex}));
  std::size_t offsets = 0;
  for (const Record* record : WithOpcode(mcap, kOpSummaryOffset)) {
    testing::FieldReader r(record->content);
    const std::uint8_t opcode = r.U8();
    const std::uint64_t start = r.U64();
    EXPECT_EQ(std::make_pair(start, r.U64()), groups.at(opcode)) << "opcode " << int{opcode};
    ++offsets;
  }
  EXPECT_EQ(offsets, groups.size());
}

TEST_F(McapWriterTest, EveryChunksCrcMatchesItsDecompressedRecords) {
  for (bool compress : {true, false}) {
    const fs::path file = dir_ / "a.mcap";
    WriteSample(file, {.chunk_size_bytes = 2000, .compress = compress}, 300);
    const McapFile mcap(file);
    const auto chunks = WithOpcode(mcap, kOpChunk);
    ASSERT_GT(chunks.size(), 5U);
    for (const Record* record : chunks) {
      const ChunkFields chunk = testing::ParseChunk(*record);
      EXPECT_EQ(chunk.compression, compress ? "zstd" : "");
      const std::vector<std::uint8_t> records = chunk.Uncompressed();  // checks the size
      EXPECT_EQ(chunk.uncompressed_crc, testing::Crc32(records));
      if (compress) {
        EXPECT_LT(chunk.records.size(), records.size());
      }
    }
  }
}

// Each chunk index against its chunk, and each message index entry against the message it points
// at: together they must list every message written, once.
TEST_F(McapWriterTest, TheIndexesPointAtTheChunksAndListEveryMessage) {
  const fs::path file = dir_ / "a.mcap";
  const std::vector<MessageFields> written = WriteSample(file, {.chunk_size_bytes = 1500}, 400);
  const McapFile mcap(file);
  std::vector<MessageFields> indexed;
  for (const Record* index_record : WithOpcode(mcap, kOpChunkIndex)) {
    const testing::ChunkIndexFields index = testing::ParseChunkIndex(*index_record);
    const Record& chunk_record = mcap.At(index.chunk_start_offset);
    ASSERT_EQ(chunk_record.opcode, kOpChunk);
    EXPECT_EQ(chunk_record.length, index.chunk_length);
    const ChunkFields chunk = testing::ParseChunk(chunk_record);
    EXPECT_EQ(index.message_start_time, chunk.message_start_time);
    EXPECT_EQ(index.message_end_time, chunk.message_end_time);
    EXPECT_EQ(index.compressed_size, chunk.records.size());
    EXPECT_EQ(index.uncompressed_size, chunk.uncompressed_size);
    EXPECT_EQ(index.compression, chunk.compression);
    const std::vector<std::uint8_t> records = chunk.Uncompressed();
    // the message indexes follow the chunk directly, one per channel
    std::uint64_t at = index.chunk_start_offset + index.chunk_length;
    for (const auto& [channel_id, offset] : index.message_index_offsets) {
      EXPECT_EQ(offset, at);
      const Record& index_of_channel = mcap.At(offset);
      ASSERT_EQ(index_of_channel.opcode, kOpMessageIndex);
      at += index_of_channel.length;
      const testing::MessageIndexFields entries = testing::ParseMessageIndex(index_of_channel);
      EXPECT_EQ(entries.channel_id, channel_id);
      for (const auto& [log_time, message_offset] : entries.entries) {
        const auto in_chunk = testing::ParseRecords(std::span(records).subspan(message_offset));
        ASSERT_EQ(in_chunk.front().opcode, kOpMessage);
        indexed.push_back(testing::ParseMessage(in_chunk.front()));
        EXPECT_EQ(indexed.back().channel_id, channel_id);
        EXPECT_EQ(indexed.back().log_time, log_time);
        EXPECT_GE(log_time, index.message_start_time);
        EXPECT_LE(log_time, index.message_end_time);
      }
    }
    EXPECT_EQ(at - index.chunk_start_offset - index.chunk_length, index.message_index_length);
  }
  auto by_time = [](const MessageFields& x, const MessageFields& y) {
    return x.log_time < y.log_time;
  };
  std::sort(indexed.begin(), indexed.end(), by_time);
  EXPECT_EQ(indexed, written);
}

TEST_F(McapWriterTest, StreamedInOrderEverySchemaAndChannelComesBeforeItsMessages) {
  const fs::path file = dir_ / "a.mcap";
  const std::vector<MessageFields> written = WriteSample(file, {.chunk_size_bytes = 1000}, 200);
  const McapFile mcap(file);
  std::set<std::uint16_t> schemas, channels;
  std::vector<MessageFields> streamed;
  for (const testing::StreamedRecord& streamed_record : testing::StreamDataSection(mcap)) {
    const Record record = streamed_record.AsRecord();
    testing::FieldReader r(record.content);
    if (record.opcode == kOpSchema) schemas.insert(r.U16());
    if (record.opcode == kOpChannel) {
      const std::uint16_t id = r.U16();
      EXPECT_TRUE(schemas.count(r.U16())) << "channel " << id << " before its schema";
      channels.insert(id);
    }
    if (record.opcode == kOpMessage) {
      EXPECT_TRUE(streamed_record.in_chunk);
      streamed.push_back(testing::ParseMessage(record));
      EXPECT_TRUE(channels.count(streamed.back().channel_id)) << "a message before its channel";
    }
  }
  EXPECT_EQ(streamed, written);  // sequence numbers per channel from 1, in order
  EXPECT_EQ(schemas, (std::set<std::uint16_t>{1}));
  EXPECT_EQ(channels, (std::set<std::uint16_t>{1, 2}));
}

TEST_F(McapWriterTest, StatisticsCountTheMessagesOfEachChannel) {
  const fs::path file = dir_ / "a.mcap";
  const std::vector<MessageFields> written = WriteSample(file, {.chunk_size_bytes = 1000}, 200);
  const McapFile mcap(file);
  const auto statistics = WithOpcode(mcap, kOpStatistics);
  ASSERT_EQ(statistics.size(), 1U);
  const testing::StatisticsFields stats = testing::ParseStatistics(*statistics[0]);
  std::map<std::uint16_t, std::uint64_t> per_channel;
  for (const MessageFields& message : written) ++per_channel[message.channel_id];
  EXPECT_EQ(stats.message_count, written.size());
  EXPECT_EQ(stats.channel_message_counts, per_channel);
  EXPECT_EQ(stats.schema_count, 1U);
  EXPECT_EQ(stats.channel_count, 2U);
  EXPECT_EQ(stats.attachment_count, 0U);
  EXPECT_EQ(stats.metadata_count, 1U);
  EXPECT_EQ(stats.chunk_count, WithOpcode(mcap, kOpChunk).size());
  EXPECT_EQ(stats.message_start_time, written.front().log_time);
  EXPECT_EQ(stats.message_end_time, written.back().log_time);
}

TEST_F(McapWriterTest, TheMetadataIndexPointsAtTheMetadataRecord) {
  const fs::path file = dir_ / "a.mcap";
  WriteSample(file, {}, 5);
  const McapFile mcap(file);
  const auto indexes = WithOpcode(mcap, kOpMetadataIndex);
  ASSERT_EQ(indexes.size(), 1U);
  testing::FieldReader index(indexes[0]->content);
  const std::uint64_t offset = index.U64();
  const std::uint64_t length = index.U64();
  EXPECT_EQ(index.String(), "run");
  const Record& metadata = mcap.At(offset);
  ASSERT_EQ(metadata.opcode, kOpMetadata);
  EXPECT_EQ(metadata.length, length);
  testing::FieldReader fields(metadata.content);
  EXPECT_EQ(fields.String(), "run");
  EXPECT_EQ(fields.StringMap(),
            (std::map<std::string, std::string>{{"seed", "7"}, {"scenario", "lab"}}));
}

TEST_F(McapWriterTest, TheSameCallsGiveTheSameBytes) {
  WriteSample(dir_ / "1.mcap", {.chunk_size_bytes = 3000}, 500);
  WriteSample(dir_ / "2.mcap", {.chunk_size_bytes = 3000}, 500);
  EXPECT_EQ(testing::ReadBytes(dir_ / "1.mcap"), testing::ReadBytes(dir_ / "2.mcap"));
}

// Each message record here is 9 + 22 + 100 bytes: with 1000 bytes per chunk, the chunk closes at
// the message that takes its records to 1000 or more.
TEST_F(McapWriterTest, AChunkClosesOnceItsRecordsReachTheChunkSize) {
  const fs::path file = dir_ / "a.mcap";
  {
    Writer writer(file, {.chunk_size_bytes = 1000});
    const std::uint16_t channel = writer.AddChannel(0, "/raw", "application/octet-stream");
    const std::vector<std::uint8_t> data(100, 0x5A);
    for (int i = 0; i < 25; ++i) writer.Write(channel, i, i, data);
    EXPECT_EQ(writer.counts().messages, 25U);
    EXPECT_EQ(writer.counts().chunks, 3U);  // two full, the third still open
    writer.Close();
    EXPECT_EQ(writer.counts().chunks, 4U);
    EXPECT_EQ(writer.counts().bytes_written, fs::file_size(file));
  }
  const McapFile mcap(file);
  std::vector<std::uint64_t> sizes;
  for (const Record* record : WithOpcode(mcap, kOpChunk)) {
    sizes.push_back(testing::ParseChunk(*record).uncompressed_size);
  }
  const std::uint64_t message = 9 + 22 + 100, channel = 9 + 2 + 2 + (4 + 4) + (4 + 24) + 4;
  EXPECT_EQ(sizes,
            (std::vector<std::uint64_t>{channel + 8 * message, 8 * message, 8 * message, message}));
}

TEST_F(McapWriterTest, ZeroMessagesStillGiveAValidFile) {
  const fs::path empty = dir_ / "empty.mcap", unused = dir_ / "unused.mcap";
  Writer(empty).Close();
  {
    Writer writer(unused, {});
    const std::uint16_t schema = writer.AddSchema("std_msgs/msg/String", "ros2msg", "string data");
    writer.AddChannel(schema, "/never", "cdr");
  }  // closed by the destructor
  for (const fs::path& file : {empty, unused}) {
    const McapFile mcap(file);
    EXPECT_TRUE(WithOpcode(mcap, kOpChunk).empty());
    EXPECT_TRUE(WithOpcode(mcap, kOpChunkIndex).empty());
    const auto statistics = WithOpcode(mcap, kOpStatistics);
    ASSERT_EQ(statistics.size(), 1U);
    const testing::StatisticsFields stats = testing::ParseStatistics(*statistics[0]);
    EXPECT_EQ(stats.message_count, 0U);
    EXPECT_EQ(stats.message_start_time, 0U);
    const testing::FooterFields footer = testing::ParseFooter(mcap.records.back());
    EXPECT_EQ(mcap.At(footer.summary_start).opcode, file == empty ? kOpStatistics : kOpSchema);
  }
  // the unused schema and channel are in the data section (top level) and in the summary
  const McapFile mcap(unused);
  EXPECT_EQ(WithOpcode(mcap, kOpSchema).size(), 2U);
  EXPECT_EQ(WithOpcode(mcap, kOpChannel).size(), 2U);
  EXPECT_EQ(mcap.records[1].opcode, kOpSchema);
  EXPECT_EQ(mcap.records[2].opcode, kOpChannel);
  EXPECT_EQ(mcap.records[3].opcode, kOpDataEnd);
}

TEST_F(McapWriterTest, AFileThatCannotBeCreatedIsAnErrorNamingIt) {
  const fs::path file = dir_ / "no such folder" / "a.mcap";
  try {
    Writer writer(file);
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
  }
}

// /dev/full takes the open and fails every write (ENOSPC): the buffered bytes fail at Close.
TEST_F(McapWriterTest, CloseReportsAWriteErrorNamingTheFile) {
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "no /dev/full here";
  Writer writer("/dev/full");
  writer.AddChannel(0, "/raw", "application/octet-stream");
  writer.Write(1, 1, 1, std::vector<std::uint8_t>(10));
  try {
    writer.Close();
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/dev/full"), std::string::npos) << e.what();
  }
  EXPECT_THROW(writer.Write(1, 2, 2, {}), std::logic_error);
  writer.Close();  // a second Close does nothing
}

TEST_F(McapWriterTest, UnknownIdsAreErrors) {
  Writer writer(dir_ / "a.mcap");
  EXPECT_THROW(writer.AddChannel(1, "/a", "cdr"), std::invalid_argument);  // no schema 1 yet
  const std::uint16_t channel = writer.AddChannel(0, "/a", "cdr");
  EXPECT_EQ(channel, 1U);
  EXPECT_THROW(writer.Write(0, 0, 0, {}), std::invalid_argument);
  EXPECT_THROW(writer.Write(2, 0, 0, {}), std::invalid_argument);
  writer.Close();
  EXPECT_THROW(writer.AddSchema("x", "ros2msg", ""), std::logic_error);
}

}  // namespace
}  // namespace autonomsim::mcap
