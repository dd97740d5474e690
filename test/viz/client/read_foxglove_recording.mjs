// Reads the Foxglove channels of FUSE recordings (fuse-sim's recording.mcap, fuse-record's files)
// with the reference MCAP reader (@mcap/core) and only the schemas embedded in the file: every
// message of every JSON channel is validated against its channel's JSON Schema (Ajv), and against
// Foxglove's own definition of that schema (@foxglove/schemas), and the fields the schema marks
// base64 are decoded. Prints one JSON summary per file and checks:
//   - every channel the 3D panel needs is there (/tf, /tf_static, /fuse/scan, and /fuse/pose);
//   - each point cloud's data is a whole number of points, its frame reachable in the one
//     transform tree the FrameTransforms make (root "world");
//   - --pair A=B: channels A and B carry as many messages (e.g. /fuse/scan=lidar/scan);
//   - --truth FILE: every /fuse/pose is the TUM row of that time (1e-6 m);
//   - --map-points N: the last /fuse/map holds N points.
// Exit code 0 when every check passed, 1 otherwise.
//   node read_foxglove_recording.mjs FILE.mcap [--pair A=B]... [--truth TUM] [--map-points N]
import { open, readFile } from "node:fs/promises";
import { McapIndexedReader } from "@mcap/core";
import { FileHandleReadable } from "@mcap/nodejs";
import { loadDecompressHandlers } from "@mcap/support";
import Ajv2020 from "ajv/dist/2020.js";
import { base64Paths, decodeBytes, rootOf } from "./foxglove_json.mjs";
import foxgloveSchemas from "@foxglove/schemas/jsonschema.js";

const args = process.argv.slice(2);
const file = args.shift();
const pairs = [];
let truthPath = null;
let mapPoints = null;
while (args.length) {
  const a = args.shift();
  if (a === "--pair") pairs.push(args.shift().split("="));
  else if (a === "--truth") truthPath = args.shift();
  else if (a === "--map-points") mapPoints = Number(args.shift());
  else {
    console.error(`unknown argument ${a}`);
    process.exit(2);
  }
}
let failures = 0;
function check(ok, what) {
  if (!ok) {
    failures += 1;
    console.error(`check failed: ${what}`);
  }
}

const truth = new Map(); // round(t * 1e6) -> [x, y, z]
if (truthPath) {
  for (const line of (await readFile(truthPath, "utf8")).split("\n")) {
    if (!line || line.startsWith("#")) continue;
    const v = line.trim().split(/\s+/).map(Number);
    truth.set(Math.round(v[0] * 1e6), v.slice(1, 4));
  }
}

const ajv = new Ajv2020({ strict: false, allErrors: true });
const handle = await open(file, "r");
const reader = await McapIndexedReader.Initialize({
  readable: new FileHandleReadable(handle),
  decompressHandlers: await loadDecompressHandlers(),
});
const counts = {};
const json = new Map(); // channel id -> { topic, validate, paths }
for (const channel of reader.channelsById.values()) {
  counts[channel.topic] = Number(reader.statistics?.channelMessageCounts.get(channel.id) ?? 0n);
  if (channel.messageEncoding !== "json") continue;
  const schema = reader.schemasById.get(channel.schemaId);
  check(schema?.encoding === "jsonschema", `${channel.topic}: schema encoding jsonschema`);
  const parsed = JSON.parse(new TextDecoder().decode(schema.data));
  // Foxglove's own definition of the schema (@foxglove/schemas), by name: what its 3D panel reads.
  const official = schema.name.startsWith("foxglove.") ? foxgloveSchemas[schema.name.slice("foxglove.".length)] : null;
  if (schema.name.startsWith("foxglove.")) check(official !== undefined, `${schema.name} is one of Foxglove's schemas`);
  json.set(channel.id, { topic: channel.topic, name: schema.name, validate: ajv.compile(parsed), paths: base64Paths(parsed),
                         official: official ? ajv.compile(official) : null });
}
for (const topic of ["/tf", "/tf_static", "/fuse/scan"]) check(topic in counts, `channel ${topic} present`);

const parents = new Map();
const frames = new Set();
let lastMap = null, posesChecked = 0, invalid = 0, clouds = 0;
const schemas = {};
for await (const message of reader.readMessages({ topics: [...json.values()].map((c) => c.topic) })) {
  const c = json.get(message.channelId);
  let msg = JSON.parse(new TextDecoder().decode(message.data));
  if (!c.validate(msg)) {
    if (invalid++ < 5) console.error(`${c.topic}: ${ajv.errorsText(c.validate.errors)}`);
    continue;
  }
  if (c.official && !c.official(msg)) {
    if (invalid++ < 5) console.error(`${c.topic}: not a ${c.name} by @foxglove/schemas: ${ajv.errorsText(c.official.errors)}`);
    continue;
  }
  for (const path of c.paths) msg = decodeBytes(msg, path);
  schemas[c.topic] = c.name;
  if (c.name === "foxglove.FrameTransforms") {
    for (const tf of msg.transforms) parents.set(tf.child_frame_id, tf.parent_frame_id);
  } else if ("frame_id" in msg) {
    frames.add(msg.frame_id);
  }
  if (c.name === "foxglove.PointCloud") {
    clouds += 1;
    const n = msg.data.length / msg.point_stride;
    check(Number.isInteger(n), `${c.topic}: whole points`);
    if (c.topic === "/fuse/map") lastMap = n;
  }
  if (c.topic === "/fuse/pose" && truth.size) {
    const t = msg.timestamp.sec + msg.timestamp.nsec * 1e-9;
    const row = truth.get(Math.round(t * 1e6));
    check(row !== undefined, `/fuse/pose at t=${t} has a truth row`);
    if (row) {
      const p = msg.pose.position;
      check(Math.hypot(p.x - row[0], p.y - row[1], p.z - row[2]) < 1e-6, `/fuse/pose at t=${t} is the truth`);
      posesChecked += 1;
    }
  }
}
await handle.close();
check(invalid === 0, `${invalid} messages do not match their schema`);
const all = new Set([...frames, ...parents.keys(), ...parents.values()]);
const roots = [...new Set([...all].map((f) => rootOf(parents, f)))];
check(roots.length === 1 && roots[0] === "world", `one transform tree rooted at world (roots: ${roots})`);
for (const [a, b] of pairs) check(counts[a] === counts[b] && counts[a] > 0, `${a} (${counts[a]}) and ${b} (${counts[b]}) pair up`);
if (truthPath) check(posesChecked > 0 && posesChecked === counts["/fuse/pose"], `every /fuse/pose checked against the truth (${posesChecked})`);
if (mapPoints !== null) check(lastMap === mapPoints, `last /fuse/map has ${lastMap} points, expected ${mapPoints}`);
console.log(JSON.stringify({ file, counts, schemas, frames: [...all], roots, clouds, posesChecked, lastMap, failures }));
process.exit(failures ? 1 : 0);
