// A run's MCAP recording against the run's own files, read with Foxglove's libraries (@mcap/core,
// @foxglove/rosmsg2-serialization), independent of the writer: `node tools/tests/
// mcap_run_check.mjs RUN_DIR FILE.mcap`. Checks, besides mcap_check.mjs's structure, CRCs and
// indexes:
//   - every channel's first and last message decode, with no bytes left over;
//   - /carN/ground_truth/pose and the map→carN/ground_truth transforms on /carN/tf equal
//     trajectory.csv's rows (stamp, x, y, yaw) within float precision, one message per row;
//   - the stack's map→odom→base_link (/carN/tf_static, /carN/tf) lies within the summary's
//     max_localization_error_m of the ground truth at its stamp (+ how far the car moves in one
//     trajectory sample);
//   - an image (when recorded) has its size, encoding and data length, and is not blank;
//   - the lane points have the lab's layout (valid, 30 points);
//   - /carN/cpu_load's mean over the run is summary.json's cpu_percent for the board;
//   - the file's metadata carries the run's result_sha256.
// A car whose ground truth and TF were left out (--mcap-topics) is said so and skipped.
// Prints a line per check; exits 1 on the first failure.
import { readFileSync } from "node:fs";
import { open } from "node:fs/promises";
import { McapIndexedReader } from "@mcap/core";
import { loadDecompressHandlers } from "@mcap/support";
import { parse } from "@foxglove/rosmsg";
import { MessageReader } from "@foxglove/rosmsg2-serialization";
import { checkMcap } from "./mcap_check.mjs";

const [runDir, file] = process.argv.slice(2);
if (!runDir || !file) {
  process.stderr.write("usage: node tools/tests/mcap_run_check.mjs RUN_DIR FILE.mcap\n");
  process.exit(2);
}
const fail = (message) => {
  process.stderr.write(`mcap_run_check: ${message}\n`);
  process.exit(1);
};
const ok = (message) => process.stdout.write(`ok: ${message}\n`);

const structure = await checkMcap(file);
ok(`structure, CRCs and indexes (${structure.totals.messages} messages, ` +
   `${structure.totals.chunks} chunks, ${structure.totals.channels} channels)`);
for (const [topic, entry] of Object.entries(structure.topics)) {
  if (entry.count === 0) fail(`${topic}: a channel without messages`);
  if (entry.first === undefined || entry.last === undefined) fail(`${topic}: not decoded`);
  if (entry.trailing_bytes) fail(`${topic}: bytes left after decoding (schema and CDR disagree)`);
}
ok(`every channel's first and last message decode (${Object.keys(structure.topics).length})`);

const summary = JSON.parse(readFileSync(`${runDir}/summary.json`, "utf8"));
if (structure.metadata.autonomsim?.result_sha256 !== summary.result_sha256) {
  fail(`metadata result_sha256 ${structure.metadata.autonomsim?.result_sha256} is not the ` +
       `run's ${summary.result_sha256}`);
}
ok("metadata carries the run's result_sha256");

// trajectory.csv per car: [t_s, x, y, yaw]
const rows = new Map();
const lines = readFileSync(`${runDir}/trajectory.csv`, "utf8").trim().split("\n").slice(1);
for (const line of lines) {
  const f = line.split(",").map(Number);
  if (!rows.has(f[1])) rows.set(f[1], []);
  rows.get(f[1]).push({ t: f[0], x: f[2], y: f[3], yaw: f[4] });
}

// every message, decoded, per topic (the test's runs are short)
const handle = await open(file, "r");
const reader = await McapIndexedReader.Initialize({
  readable: {
    size: async () => BigInt((await handle.stat()).size),
    read: async (offset, length) => {
      const buffer = new Uint8Array(Number(length));
      await handle.read(buffer, 0, Number(length), Number(offset));
      return buffer;
    },
  },
  decompressHandlers: await loadDecompressHandlers(),
});
const decoders = new Map();
for (const [id, schema] of reader.schemasById) {
  decoders.set(id, new MessageReader(parse(new TextDecoder().decode(schema.data), { ros2: true })));
}
const byTopic = new Map();
for await (const m of reader.readMessages()) {
  const channel = reader.channelsById.get(m.channelId);
  if (!byTopic.has(channel.topic)) byTopic.set(channel.topic, []);
  byTopic.get(channel.topic).push(decoders.get(channel.schemaId).readMessage(m.data));
}
await handle.close();

const seconds = (stamp) => stamp.sec + stamp.nanosec * 1e-9;
const yawOf = (q) => 2 * Math.atan2(q.z, q.w);
const wrap = (a) => Math.atan2(Math.sin(a), Math.cos(a));
const close = (a, b, tolerance) => Math.abs(a - b) <= tolerance;
const kFloat = 1e-9;  // m, rad, s: float64 through sin/cos and back

function samePose(what, got, want) {
  if (!close(got.t, want.t, kFloat) || !close(got.x, want.x, kFloat) ||
      !close(got.y, want.y, kFloat) || !close(wrap(got.yaw - want.yaw), 0, kFloat)) {
    fail(`${what}: ${JSON.stringify(got)} is not trajectory.csv's ${JSON.stringify(want)}`);
  }
}

for (const [car, expected] of rows) {
  if (!byTopic.has(`/car${car}/ground_truth/pose`) && !byTopic.has(`/car${car}/tf`)) {
    ok(`car ${car}: its poses are not in the file (not recorded)`);
    continue;
  }
  const poses = byTopic.get(`/car${car}/ground_truth/pose`) ?? [];
  if (poses.length !== expected.length) {
    fail(`/car${car}/ground_truth/pose: ${poses.length} messages for ${expected.length} rows`);
  }
  poses.forEach((p, i) => samePose(`/car${car}/ground_truth/pose[${i}]`, {
    t: seconds(p.header.stamp), x: p.pose.position.x, y: p.pose.position.y,
    yaw: yawOf(p.pose.orientation),
  }, expected[i]));
  const tf = (byTopic.get(`/car${car}/tf`) ?? []).flatMap((m) => m.transforms);
  const truth = tf.filter((t) => t.child_frame_id === `car${car}/ground_truth`);
  if (truth.length !== expected.length) {
    fail(`/car${car}/tf: ${truth.length} ground-truth transforms for ${expected.length} rows`);
  }
  truth.forEach((t, i) => samePose(`/car${car}/tf ground truth [${i}]`, {
    t: seconds(t.header.stamp), x: t.transform.translation.x, y: t.transform.translation.y,
    yaw: yawOf(t.transform.rotation),
  }, expected[i]));
  ok(`car ${car}: ${expected.length} ground-truth poses and transforms equal trajectory.csv`);
  checkEstimate(car, tf, expected);
}

// map→odom (static) ∘ odom→base_link (the EKF) against the ground truth at the stamp.
function checkEstimate(car, tf, expected) {
  const estimates = tf.filter((t) => t.child_frame_id === `car${car}/base_link`);
  if (estimates.length === 0) return;  // a car without the stack
  const statics = (byTopic.get(`/car${car}/tf_static`) ?? []).flatMap((m) => m.transforms);
  const mapOdom = statics.find((t) => t.child_frame_id === `car${car}/odom`);
  if (!mapOdom) fail(`/car${car}/tf_static: no map→car${car}/odom`);
  const bound = summary.cars.find((c) => c.id === car)?.stack?.max_localization_error_m;
  if (bound === undefined) fail(`summary.json: no max_localization_error_m for car ${car}`);
  const o = mapOdom.transform.translation;
  const oyaw = yawOf(mapOdom.transform.rotation);
  let worst = 0;
  for (const e of estimates) {
    const p = e.transform.translation;
    const x = o.x + Math.cos(oyaw) * p.x - Math.sin(oyaw) * p.y;
    const y = o.y + Math.sin(oyaw) * p.x + Math.cos(oyaw) * p.y;
    const t = seconds(e.header.stamp);
    const i = Math.max(1, expected.findIndex((r) => r.t >= t));
    const [a, b] = [expected[i - 1], expected[Math.min(i, expected.length - 1)]];
    const error = Math.min(Math.hypot(x - a.x, y - a.y), Math.hypot(x - b.x, y - b.y));
    const step = Math.hypot(b.x - a.x, b.y - a.y);
    if (error > bound + step + 1e-6) {
      fail(`car ${car}: estimate at ${t} s is ${error} m from the ground truth, beyond the ` +
           `summary's ${bound} m (+ ${step} m between samples)`);
    }
    worst = Math.max(worst, error);
  }
  ok(`car ${car}: ${estimates.length} EKF transforms within ${bound.toFixed(3)} m of the ground ` +
     `truth (worst ${worst.toFixed(3)} m)`);
}

// The board's load over the run: the mean of its samples (equal intervals from the first sample
// to the end) is summary.json's cpu_percent for the board, measured over the same span.
for (const [topic, messages] of byTopic) {
  const board = /^\/(car\d+)\/cpu_load$/.exec(topic)?.[1];
  const whole = summary.platform?.[board]?.cpu_percent;
  if (!board || whole === undefined) continue;
  const mean = messages.reduce((sum, m) => sum + m.data, 0) / messages.length;
  if (Math.abs(mean - whole) > 1e-6 * Math.max(1, whole)) {
    fail(`${topic}: mean ${mean} % is not summary.json's cpu_percent ${whole} %`);
  }
  ok(`${topic}: ${messages.length} samples, mean ${mean.toFixed(3)} % = summary.json's`);
}

for (const [topic, messages] of byTopic) {
  if (!/\/(image|depth\/image_raw)$/.test(topic)) continue;
  const image = messages[Math.floor(messages.length / 2)];
  if (image.format !== undefined) {  // CompressedImage
    const png = [0x89, 0x50, 0x4e, 0x47];
    if (!png.every((b, i) => image.data[i] === b)) fail(`${topic}: not a PNG`);
    ok(`${topic}: ${messages.length} PNG images`);
    continue;
  }
  if (image.data.length !== image.step * image.height) fail(`${topic}: data is not step x height`);
  if (image.data.every((b) => b === image.data[0])) fail(`${topic}: a blank image`);
  ok(`${topic}: ${messages.length} images ${image.width}x${image.height} ${image.encoding}`);
}

for (const [topic, messages] of byTopic) {
  if (!topic.endsWith("/lane_detector/central_line/point_cloud")) continue;
  for (const m of messages) {
    if (typeof m.valid !== "bigint" || m.points.length !== 30) fail(`${topic}: not LanePoints`);
  }
  const valid = messages.filter((m) => m.valid !== 0n).length;
  ok(`${topic}: ${messages.length} LanePoints, ${valid} valid`);
}
