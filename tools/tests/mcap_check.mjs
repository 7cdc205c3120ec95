#!/usr/bin/env node
// An MCAP file read by an implementation independent of ours: Foxglove's @mcap/core (the
// TypeScript reader Foxglove Studio uses), both ways a reader can go, and every channel's first
// and last message decoded with @foxglove/rosmsg + @foxglove/rosmsg2-serialization (the ros2msg
// schema, CDR messages). Test-only; the packages come from `npm ci` at the repository root
// (package.json; tools/install_deps.sh runs it).
//
//   node tools/tests/mcap_check.mjs FILE   prints a JSON summary, exit 0; or a message, exit 1
//
// What it checks:
// - the indexed reader (McapIndexedReader over the file): footer, summary and its CRC, schemas,
//   channels, statistics, chunk indexes; every message found through the index, CRCs validated;
// - the streaming reader (McapStreamReader, chunk CRCs validated): every record from the first
//   byte to the last, the chunks themselves, and the data section CRC (DataEnd) recomputed here;
// - the two agree: the same messages (channel, sequence, times, bytes) in the same log-time order,
//   the chunk indexes describe the chunks as streamed (compression and sizes, in file order), the
//   statistics count the messages seen (in all, per channel, first and last log time) and the
//   chunks, schemas and channels there are.
// The summary: per topic {schema, encoding, count, bytes, first, last, trailing_bytes}, where first
// and last are decoded messages (typed arrays and long arrays shortened to their length and first
// values, bigints as numbers) and trailing_bytes says whether a decode left bytes unread (a schema
// that does not match its messages); totals; metadata records by name.
//
// Importable: checkMcap(path) returns the same object (a Promise), or throws.
import { createReadStream } from "node:fs";
import { open } from "node:fs/promises";
import { pathToFileURL } from "node:url";

import { McapIndexedReader, McapStreamReader } from "@mcap/core";
import { loadDecompressHandlers } from "@mcap/support";
import rosmsg from "@foxglove/rosmsg";
import rosmsg2 from "@foxglove/rosmsg2-serialization";

const ARRAY_HEAD = 8; // values an array keeps in the summary, its length beside them

// @mcap/core's IReadable over a file handle: the indexed reader reads what it needs by offset.
class FileHandleReadable {
  constructor(handle, size) {
    this.handle = handle;
    this.fileSize = size;
  }
  async size() {
    return BigInt(this.fileSize);
  }
  async read(offset, length) {
    const buffer = new Uint8Array(Number(length));
    const { bytesRead } = await this.handle.read(buffer, 0, buffer.length, Number(offset));
    if (bytesRead !== buffer.length) {
      throw new Error(`short read: ${bytesRead} of ${length} bytes at ${offset}`);
    }
    return buffer;
  }
}

// CRC-32 (ISO-HDLC, as zlib and MCAP), to recompute the data section's.
const CRC_TABLE = (() => {
  const table = new Uint32Array(256);
  for (let n = 0; n < 256; n++) {
    let c = n;
    for (let k = 0; k < 8; k++) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
    table[n] = c >>> 0;
  }
  return table;
})();
function crc32Update(crc, bytes) {
  let c = ~crc >>> 0;
  for (let i = 0; i < bytes.length; i++) c = CRC_TABLE[(c ^ bytes[i]) & 0xff] ^ (c >>> 8);
  return ~c >>> 0;
}

function fail(message) {
  throw new Error(message);
}

// The indexed reader's view: summary records and every message through the chunk indexes.
async function readIndexed(path, decompressHandlers) {
  const handle = await open(path, "r");
  try {
    const { size } = await handle.stat();
    const reader = await McapIndexedReader.Initialize({
      readable: new FileHandleReadable(handle, size),
      decompressHandlers,
    });
    const messages = [];
    for await (const message of reader.readMessages({ validateCrcs: true })) messages.push(message);
    const metadata = {};
    for await (const record of reader.readMetadata()) {
      metadata[record.name] = Object.fromEntries(record.metadata);
    }
    return { reader, messages, metadata, size };
  } finally {
    await handle.close();
  }
}

// The streaming reader's view: every record in file order; the data section's CRC on the way.
async function readStreamed(path, decompressHandlers, dataEndOffset) {
  const reader = new McapStreamReader({ includeChunks: true, decompressHandlers, validateCrcs: true });
  const seen = { records: [], messages: [], chunks: [], crc: 0 };
  let offset = 0;
  for await (const piece of createReadStream(path, { highWaterMark: 1 << 20 })) {
    const bytes = new Uint8Array(piece.buffer, piece.byteOffset, piece.byteLength);
    const before = Math.max(0, Math.min(bytes.length, Number(dataEndOffset) - offset));
    seen.crc = crc32Update(seen.crc, bytes.subarray(0, before));
    offset += bytes.length;
    reader.append(bytes);
    for (let record; (record = reader.nextRecord()); ) {
      seen.records.push(record.type);
      if (record.type === "Message") seen.messages.push(record);
      if (record.type === "Chunk") seen.chunks.push(record);
      if (record.type === "DataEnd") seen.dataSectionCrc = record.dataSectionCrc;
    }
  }
  if (!reader.done()) fail("the stream ended before the footer and closing magic");
  return seen;
}

function sameMessage(a, b) {
  return (
    a.channelId === b.channelId &&
    a.sequence === b.sequence &&
    a.logTime === b.logTime &&
    a.publishTime === b.publishTime &&
    Buffer.compare(Buffer.from(a.data), Buffer.from(b.data)) === 0
  );
}

function byLogTime(a, b) {
  return a.logTime < b.logTime ? -1 : a.logTime > b.logTime ? 1 : 0;
}

function checkMessagesAgree(indexed, streamed) {
  if (indexed.length !== streamed.length) {
    fail(`the index finds ${indexed.length} messages, the stream ${streamed.length}`);
  }
  // stable sort: equal log times keep file order, as the indexed reader returns them
  const ordered = [...streamed].sort(byLogTime);
  for (let i = 0; i < ordered.length; i++) {
    if (!sameMessage(indexed[i], ordered[i])) {
      fail(`message ${i} by log time differs between the index and the stream ` +
           `(channel ${indexed[i].channelId} seq ${indexed[i].sequence} vs ` +
           `channel ${ordered[i].channelId} seq ${ordered[i].sequence})`);
    }
  }
}

function checkChunks(reader, streamed) {
  const indexes = [...reader.chunkIndexes].sort((a, b) =>
    a.chunkStartOffset < b.chunkStartOffset ? -1 : 1);
  if (indexes.length !== streamed.chunks.length) {
    fail(`${indexes.length} chunk indexes for ${streamed.chunks.length} chunks`);
  }
  indexes.forEach((index, i) => {
    const chunk = streamed.chunks[i];
    if (index.compression !== chunk.compression ||
        index.uncompressedSize !== chunk.uncompressedSize ||
        index.compressedSize !== BigInt(chunk.records.byteLength) ||
        index.messageStartTime !== chunk.messageStartTime ||
        index.messageEndTime !== chunk.messageEndTime) {
      fail(`chunk index ${i} (at ${index.chunkStartOffset}) does not describe chunk ${i}`);
    }
    if (chunk.uncompressedCrc === 0) fail(`chunk ${i} has no CRC`);
  });
}

function checkStatistics(reader, streamed) {
  const stats = reader.statistics ?? fail("no Statistics record in the summary");
  const counts = new Map();
  for (const m of streamed.messages) counts.set(m.channelId, (counts.get(m.channelId) ?? 0n) + 1n);
  const times = streamed.messages.map((m) => m.logTime);
  const min = times.length ? times.reduce((a, b) => (b < a ? b : a)) : 0n;
  const max = times.length ? times.reduce((a, b) => (b > a ? b : a)) : 0n;
  const expect = (what, got, want) => {
    if (got !== want) fail(`statistics: ${what} is ${got}, the file has ${want}`);
  };
  expect("message_count", stats.messageCount, BigInt(streamed.messages.length));
  expect("chunk_count", stats.chunkCount, streamed.chunks.length);
  expect("channel_count", stats.channelCount, reader.channelsById.size);
  expect("schema_count", stats.schemaCount, reader.schemasById.size);
  expect("message_start_time", stats.messageStartTime, min);
  expect("message_end_time", stats.messageEndTime, max);
  for (const [id, count] of stats.channelMessageCounts) {
    expect(`channel ${id}'s count`, count, counts.get(id) ?? 0n);
  }
  for (const id of counts.keys()) {
    if (!stats.channelMessageCounts.has(id)) fail(`statistics: no count for channel ${id}`);
  }
}

// A decoded value made small and JSON-friendly.
function summarize(value) {
  if (typeof value === "bigint") return Number(value);
  if (ArrayBuffer.isView(value) || Array.isArray(value)) {
    const items = Array.from(value.length > ARRAY_HEAD ? value.slice(0, ARRAY_HEAD) : value);
    const head = items.map(summarize);
    return value.length > ARRAY_HEAD || ArrayBuffer.isView(value)
      ? { length: value.length, head }
      : head;
  }
  if (value !== null && typeof value === "object") {
    return Object.fromEntries(Object.entries(value).map(([k, v]) => [k, summarize(v)]));
  }
  return value;
}

// Per topic: the schema, count, bytes, and the first and last messages decoded.
function describeTopics(reader, messages) {
  const topics = {};
  const decoders = new Map();
  for (const channel of reader.channelsById.values()) {
    const schema = reader.schemasById.get(channel.schemaId);
    const onChannel = messages.filter((m) => m.channelId === channel.id);
    const entry = {
      schema: schema?.name ?? "",
      encoding: channel.messageEncoding,
      count: onChannel.length,
      bytes: onChannel.reduce((sum, m) => sum + m.data.byteLength, 0),
      trailing_bytes: false,
    };
    const decodable = schema?.encoding === "ros2msg" && channel.messageEncoding === "cdr";
    if (decodable && onChannel.length > 0) {
      if (!decoders.has(schema.id)) {
        const text = new TextDecoder().decode(schema.data);
        decoders.set(schema.id, new rosmsg2.MessageReader(rosmsg.parse(text, { ros2: true })));
      }
      const decoder = decoders.get(schema.id);
      const decode = (m) => {
        const value = summarize(decoder.readMessage(m.data));
        entry.trailing_bytes ||= decoder.lastReadHadTrailingBytes();
        return value;
      };
      entry.first = decode(onChannel[0]);
      entry.last = decode(onChannel[onChannel.length - 1]);
    }
    if (topics[channel.topic]) fail(`two channels on topic ${channel.topic}`);
    topics[channel.topic] = entry;
  }
  return topics;
}

export async function checkMcap(path) {
  const decompressHandlers = await loadDecompressHandlers();
  const { reader, messages, metadata, size } = await readIndexed(path, decompressHandlers);
  const streamed = await readStreamed(path, decompressHandlers, reader.dataEndOffset);
  if (streamed.dataSectionCrc !== undefined && streamed.dataSectionCrc !== 0 &&
      streamed.dataSectionCrc !== streamed.crc) {
    fail(`data section CRC ${streamed.dataSectionCrc}, the bytes give ${streamed.crc}`);
  }
  checkMessagesAgree(messages, streamed.messages);
  checkChunks(reader, streamed);
  checkStatistics(reader, streamed);
  return {
    file: path,
    profile: reader.header.profile,
    library: reader.header.library,
    topics: describeTopics(reader, streamed.messages),
    totals: {
      messages: messages.length,
      chunks: reader.chunkIndexes.length,
      channels: reader.channelsById.size,
      schemas: reader.schemasById.size,
      compression: [...new Set(reader.chunkIndexes.map((c) => c.compression))],
      file_bytes: size,
      data_section_crc: streamed.dataSectionCrc ?? 0,
    },
    metadata,
  };
}

async function main(args) {
  if (args.length !== 1) {
    process.stderr.write("usage: node tools/tests/mcap_check.mjs FILE.mcap\n");
    return 2;
  }
  try {
    process.stdout.write(JSON.stringify(await checkMcap(args[0]), null, 2) + "\n");
    return 0;
  } catch (error) {
    process.stderr.write(`mcap_check: ${args[0]}: ${error.message}\n`);
    return 1;
  }
}

if (process.argv[1] && import.meta.url === pathToFileURL(process.argv[1]).href) {
  process.exitCode = await main(process.argv.slice(2));
}
