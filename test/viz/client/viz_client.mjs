// A Foxglove WebSocket client built on Foxglove's client library (@foxglove/ws-protocol) and the
// `ws` WebSocket, for the fuse-viz test: it connects, subscribes to every advertised channel, and
// decodes each message with the schema its channel advertised (JSON Schema, checked by Ajv, and
// against Foxglove's own definition of that schema from @foxglove/schemas; the fields the schema
// marks base64 are decoded as bytes). Each message becomes one JSON line in OUT:
//   {"topic", "schema", "t", "log_time_ns", "frame_id", ...what the test compares}
// Point clouds are read through their PackedElementFields. On SIGTERM it checks that every
// frame_id it saw is reachable in the transform tree built from the FrameTransforms channels,
// writes a "summary" line and exits 0, or 1 when any message failed to decode.
//
//   node viz_client.mjs ws://127.0.0.1:PORT OUT
import fs from "node:fs";
import wsProtocol from "@foxglove/ws-protocol"; // CommonJS: its names are on the default export
const { FoxgloveClient } = wsProtocol;
import WebSocket from "ws";
import Ajv2020 from "ajv/dist/2020.js";
import { base64Paths, decodeBytes, rootOf } from "./foxglove_json.mjs";
import foxgloveSchemas from "@foxglove/schemas/jsonschema.js";

const [url, outPath] = process.argv.slice(2);
if (!url || !outPath) {
  console.error("usage: node viz_client.mjs URL OUT");
  process.exit(2);
}
const out = fs.openSync(outPath, "w");
const emit = (obj) => fs.writeSync(out, JSON.stringify(obj) + "\n");
const ajv = new Ajv2020({ strict: false, allErrors: true });
const bySubscription = new Map(); // subscription id -> { channel, validate, base64Paths }
const parents = new Map();        // child frame -> parent frame
const frames = new Set();         // every frame_id a message named
const counts = {};
let errors = 0;

function fail(message) {
  errors += 1;
  emit({ kind: "error", message });
  console.error(message);
}

function timeOf(stamp) {
  return stamp.sec + stamp.nsec * 1e-9;
}

// foxglove.NumericType -> reader of one value at a byte offset (little-endian).
const readers = {
  1: (b, o) => b.readUInt8(o), 2: (b, o) => b.readInt8(o), 3: (b, o) => b.readUInt16LE(o),
  4: (b, o) => b.readInt16LE(o), 5: (b, o) => b.readUInt32LE(o), 6: (b, o) => b.readInt32LE(o),
  7: (b, o) => b.readFloatLE(o), 8: (b, o) => b.readDoubleLE(o),
};

function summarisePointCloud(msg) {
  const field = (name) => msg.fields.find((f) => f.name === name);
  const [fx, fy, fz] = ["x", "y", "z"].map(field);
  if (!fx || !fy || !fz) throw new Error("point cloud without x, y and z fields");
  const n = msg.point_stride > 0 ? Math.floor(msg.data.length / msg.point_stride) : 0;
  if (n * msg.point_stride !== msg.data.length) throw new Error("data is not a whole number of points");
  let sx = 0, sy = 0, sz = 0;
  const first = [], last = [];
  for (let i = 0; i < n; ++i) {
    const base = i * msg.point_stride;
    const p = [fx, fy, fz].map((f) => readers[f.type](msg.data, base + f.offset));
    sx += p[0]; sy += p[1]; sz += p[2];
    if (i === 0) first.push(...p);
    if (i === n - 1) last.push(...p);
  }
  return { points: n, sum: [sx, sy, sz], first, last };
}

function handle(channel, msg) {
  const s = { topic: channel.topic, schema: channel.schemaName };
  switch (channel.schemaName) {
    case "foxglove.PointCloud":
      Object.assign(s, { t: timeOf(msg.timestamp), frame_id: msg.frame_id }, summarisePointCloud(msg));
      frames.add(msg.frame_id);
      break;
    case "foxglove.PoseInFrame":
      Object.assign(s, { t: timeOf(msg.timestamp), frame_id: msg.frame_id, position: msg.pose.position,
                         orientation: msg.pose.orientation });
      frames.add(msg.frame_id);
      break;
    case "foxglove.PosesInFrame":
      Object.assign(s, { t: timeOf(msg.timestamp), frame_id: msg.frame_id, poses: msg.poses.length,
                         last: msg.poses.length ? msg.poses[msg.poses.length - 1].position : null });
      frames.add(msg.frame_id);
      break;
    case "foxglove.FrameTransforms":
      s.transforms = msg.transforms.map((tf) => {
        parents.set(tf.child_frame_id, tf.parent_frame_id);
        return { t: timeOf(tf.timestamp), parent: tf.parent_frame_id, child: tf.child_frame_id,
                 translation: tf.translation, rotation: tf.rotation };
      });
      break;
    case "fuse.Health":
      Object.assign(s, { service: msg.service, state: msg.state });
      break;
    default:
      throw new Error(`no decoder for schema ${channel.schemaName}`);
  }
  return s;
}

const client = new FoxgloveClient({ ws: new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]) });
client.on("error", (e) => fail(`connection error: ${e?.message ?? e}`));
client.on("serverInfo", (info) => emit({ kind: "serverInfo", name: info.name, capabilities: info.capabilities }));
client.on("advertise", (channels) => {
  for (const channel of channels) {
    if (channel.encoding !== "json" || channel.schemaEncoding !== "jsonschema") {
      fail(`channel ${channel.topic}: encoding ${channel.encoding}/${channel.schemaEncoding} is not what this client decodes`);
      continue;
    }
    let schema;
    try {
      schema = JSON.parse(channel.schema);
    } catch (e) {
      fail(`channel ${channel.topic}: its schema is not JSON: ${e.message}`);
      continue;
    }
    const validate = ajv.compile(schema);
    // Foxglove's own definition of the schema (@foxglove/schemas), by name: what its 3D panel reads.
    const name = channel.schemaName.startsWith("foxglove.") ? channel.schemaName.slice("foxglove.".length) : null;
    if (name && !foxgloveSchemas[name]) fail(`${channel.schemaName} is not one of Foxglove's schemas`);
    const official = name && foxgloveSchemas[name] ? ajv.compile(foxgloveSchemas[name]) : null;
    const id = client.subscribe(channel.id);
    bySubscription.set(id, { channel, validate, official, paths: base64Paths(schema) });
    emit({ kind: "channel", topic: channel.topic, schema: channel.schemaName, id: channel.id });
  }
});
client.on("message", ({ subscriptionId, timestamp, data }) => {
  const sub = bySubscription.get(subscriptionId);
  if (!sub) return fail(`message for unknown subscription ${subscriptionId}`);
  const topic = sub.channel.topic;
  counts[topic] = (counts[topic] ?? 0) + 1;
  let msg;
  try {
    msg = JSON.parse(new TextDecoder().decode(new Uint8Array(data.buffer, data.byteOffset, data.byteLength)));
  } catch (e) {
    return fail(`${topic}: not JSON: ${e.message}`);
  }
  if (!sub.validate(msg)) return fail(`${topic}: does not match its schema: ${ajv.errorsText(sub.validate.errors)}`);
  if (sub.official && !sub.official(msg)) {
    return fail(`${topic}: not a ${sub.channel.schemaName} by @foxglove/schemas: ${ajv.errorsText(sub.official.errors)}`);
  }
  try {
    for (const path of sub.paths) msg = decodeBytes(msg, path);
    const line = handle(sub.channel, msg);
    line.log_time_ns = timestamp.toString();
    emit(line);
  } catch (e) {
    fail(`${topic}: ${e.message}`);
  }
});

process.on("SIGTERM", () => {
  // Every frame a message named must reach the root of the one tree the transforms make.
  const all = new Set([...frames, ...parents.keys(), ...parents.values()]);
  const roots = new Set([...all].map((f) => rootOf(parents, f)));
  const unreachable = [...all].filter((f) => rootOf(parents, f) !== [...roots][0]);
  if (roots.size !== 1) fail(`the transforms make ${roots.size} trees (${[...roots].join(", ")}), not one`);
  emit({ kind: "summary", counts, frames: [...all], roots: [...roots], unreachable, errors });
  fs.closeSync(out);
  process.exit(errors > 0 ? 1 : 0);
});
