// Writes ROS 1 and rosbag2 test bags with known synthetic contents through independent
// serialisers, and expected.json with what fuse-import must produce from each (field by field):
//   - message bytes: @foxglove/rosmsg-serialization (ROS 1) and @foxglove/rosmsg2-serialization
//     (CDR), from definitions parsed by @foxglove/rosmsg;
//   - rosbag2 MCAP storage: @mcap/core's McapWriter; rosbag2 sqlite3 storage: sql.js (SQLite);
//   - ROS 1 bag containers: no maintained npm package writes them (@foxglove/rosbag only reads),
//     so this script writes the records itself from the ROS wiki "Bags/Format/2.0", compresses
//     chunks with lz4js (LZ4 frame) and compressjs (bzip2), and then reads every bag back with
//     @foxglove/rosbag's reader to make sure the container is what the spec says.
// Usage: node write_test_bags.mjs OUT_DIR
import fs from "node:fs";
import path from "node:path";

import { parse } from "@foxglove/rosmsg";
import { MessageWriter as Ros1Writer } from "@foxglove/rosmsg-serialization";
import { MessageWriter as Cdr2Writer } from "@foxglove/rosmsg2-serialization";
import { McapWriter } from "@mcap/core";
import { Bag } from "@foxglove/rosbag";
import { FileReader } from "@foxglove/rosbag/node.js";
import lz4 from "lz4js";
import compressjs from "compressjs";
import initSqlJs from "sql.js";

const out = process.argv[2];
if (!out) {
  console.error("usage: node write_test_bags.mjs OUT_DIR");
  process.exit(2);
}
fs.mkdirSync(out, { recursive: true });

// ---- Message definitions (ROS 1 and ROS 2 .msg text, dependencies after "MSG:" separators) ----
const SEP = "\n================================================================================\n";
const ros1Header = "MSG: std_msgs/Header\nuint32 seq\ntime stamp\nstring frame_id";
const ros2Header = "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id" + SEP +
  "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec";
const vec3 = "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z";
const quat = "MSG: geometry_msgs/Quaternion\nfloat64 x\nfloat64 y\nfloat64 z\nfloat64 w";
const imuBody = "std_msgs/Header header\ngeometry_msgs/Quaternion orientation\nfloat64[9] orientation_covariance\n" +
  "geometry_msgs/Vector3 angular_velocity\nfloat64[9] angular_velocity_covariance\n" +
  "geometry_msgs/Vector3 linear_acceleration\nfloat64[9] linear_acceleration_covariance";
const cloudBody = "std_msgs/Header header\nuint32 height\nuint32 width\nsensor_msgs/PointField[] fields\n" +
  "bool is_bigendian\nuint32 point_step\nuint32 row_step\nuint8[] data\nbool is_dense";
const pointField = "MSG: sensor_msgs/PointField\nuint8 INT8=1\nuint8 UINT8=2\nuint8 INT16=3\nuint8 UINT16=4\n" +
  "uint8 INT32=5\nuint8 UINT32=6\nuint8 FLOAT32=7\nuint8 FLOAT64=8\nstring name\nuint32 offset\nuint8 datatype\nuint32 count";
const livoxBody = (pkg) => `std_msgs/Header header\nuint64 timebase\nuint32 point_num\nuint8 lidar_id\nuint8[3] rsvd\n${pkg}/CustomPoint[] points`;
const livoxPoint = (pkg) => `MSG: ${pkg}/CustomPoint\nuint32 offset_time\nfloat32 x\nfloat32 y\nfloat32 z\nuint8 reflectivity\nuint8 tag\nuint8 line`;

const DEFS = {
  ros1: {
    "sensor_msgs/Imu": [imuBody, ros1Header, quat, vec3].join(SEP),
    "sensor_msgs/PointCloud2": [cloudBody, ros1Header, pointField].join(SEP),
    "livox_ros_driver/CustomMsg": [livoxBody("livox_ros_driver"), ros1Header, livoxPoint("livox_ros_driver")].join(SEP),
    "std_msgs/String": "string data",
  },
  ros2: {
    "sensor_msgs/msg/Imu": [imuBody, ros2Header, quat, vec3].join(SEP),
    "sensor_msgs/msg/PointCloud2": [cloudBody, ros2Header, pointField].join(SEP),
    "livox_ros_driver2/msg/CustomMsg": [livoxBody("livox_ros_driver2"), ros2Header, livoxPoint("livox_ros_driver2")].join(SEP),
    "std_msgs/msg/String": "string data",
  },
};
// md5sums as rosbag records them (not checked by the reader; std_msgs/String's is the real one).
const MD5 = { "sensor_msgs/Imu": "6a62c6daae103f4ff57a132d6f95cec2", "sensor_msgs/PointCloud2": "1158d486dd51d683ce2f1be655c3c181",
  "livox_ros_driver/CustomMsg": "e4d6829bdfe657cb6c21a746c86b21a6", "std_msgs/String": "992ce8a1687cec8c8bd883ec73ca41d1" };

const writers = {};
function serialize(flavor, type, msg) {
  const key = flavor + type;
  if (!writers[key]) {
    const defs = parse(DEFS[flavor][type], { ros2: flavor === "ros2" });
    writers[key] = flavor === "ros2" ? new Cdr2Writer(defs) : new Ros1Writer(defs);
  }
  return writers[key].writeMessage(msg);
}

// ---- Known contents ----
const T0 = 1700000000n * 1000000000n;  // ns
const IMU_N = 400, IMU_DT = 5000000n;   // 200 Hz, 2 s
const SCANS = 20, SCAN_DT = 100000000n; // 10 Hz
const POINTS = 240;                      // per scan
const G = 9.80665;
const sec = (ns) => Number(ns / 1000000000n) + Number(ns % 1000000000n) * 1e-9;
const f32 = Math.fround;

function imuValues(i) {
  return { gyro: [0.01 * Math.sin(i / 10), 0.02, -0.01 * i / IMU_N], accel: [0.1, -0.2, 9.81 + 0.001 * i] };
}
function stampOf(ns, flavor) {
  const s = Number(ns / 1000000000n), n = Number(ns % 1000000000n);
  return flavor === "ros2" ? { sec: s, nanosec: n } : { sec: s, nsec: n };
}
function header(ns, frame, flavor) {
  return flavor === "ros2" ? { stamp: stampOf(ns, flavor), frame_id: frame } : { seq: 0, stamp: stampOf(ns, flavor), frame_id: frame };
}
function imuMessage(i, flavor, inG) {
  const v = imuValues(i);
  const a = inG ? v.accel.map((x) => x / G) : v.accel;
  return {
    header: header(T0 + BigInt(i) * IMU_DT, "imu_link", flavor),
    orientation: { x: 0, y: 0, z: 0, w: 1 },
    orientation_covariance: new Array(9).fill(0),
    angular_velocity: { x: v.gyro[0], y: v.gyro[1], z: v.gyro[2] },
    angular_velocity_covariance: new Array(9).fill(0),
    linear_acceleration: { x: a[0], y: a[1], z: a[2] },
    linear_acceleration_covariance: new Array(9).fill(0),
  };
}
/// Point j of scan k: its offset in ns from the scan start, coordinates, intensity, ring.
function point(k, j) {
  const bad = j % 97 === 5 ? "nan" : j % 101 === 7 ? "zero" : null;
  return {
    offset_ns: j * 400000 + 1234,  // 0.4 ms apart
    x: bad === "zero" ? 0 : bad === "nan" ? NaN : 5 + Math.cos(j + k),
    y: bad === "zero" ? 0 : Math.sin(j),
    z: bad === "zero" ? 0 : 0.01 * j - 1,
    intensity: (j * 7) % 256,
    ring: j % 32,
    bad,
  };
}
const scanStart = (k) => T0 + 2500000n + BigInt(k) * SCAN_DT;  // 2.5 ms after an IMU sample

// PointCloud2 in each per-point time convention; the header stamp follows the driver.
const CONVENTIONS = {
  t: { type: 6, size: 4, stamp: (k) => scanStart(k), value: (k, p) => p.offset_ns },  // Ouster: ns since stamp
  time: { type: 7, size: 4, stamp: (k) => scanStart(k) + SCAN_DT,                      // Velodyne: s rel. to stamp (end)
    value: (k, p) => f32((p.offset_ns - Number(SCAN_DT)) * 1e-9) },
  timestamp: { type: 8, size: 8, stamp: (k) => scanStart(k), value: (k, p) => sec(scanStart(k)) + p.offset_ns * 1e-9 }, // Hesai
  offset_time: { type: 6, size: 4, stamp: (k) => scanStart(k), value: (k, p) => p.offset_ns },  // Livox driver2 cloud
};

function cloudMessage(k, conv, flavor) {
  const c = CONVENTIONS[conv];
  // x y z intensity (float32), ring (uint16), time field; point_step 32 with padding.
  const fields = [["x", 0, 7], ["y", 4, 7], ["z", 8, 7], ["intensity", 12, 7], ["ring", 16, 4], [conv, 24, c.type]];
  const step = 32;
  const data = new Uint8Array(step * POINTS);
  const dv = new DataView(data.buffer);
  for (let j = 0; j < POINTS; ++j) {
    const p = point(k, j), b = j * step;
    dv.setFloat32(b, p.x, true); dv.setFloat32(b + 4, p.y, true); dv.setFloat32(b + 8, p.z, true);
    dv.setFloat32(b + 12, p.intensity, true); dv.setUint16(b + 16, p.ring, true);
    const v = c.value(k, p);
    if (c.type === 6) dv.setUint32(b + 24, v, true); else if (c.type === 7) dv.setFloat32(b + 24, v, true); else dv.setFloat64(b + 24, v, true);
  }
  return {
    header: header(c.stamp(k), "lidar", flavor), height: 1, width: POINTS,
    fields: fields.map(([name, offset, datatype]) => ({ name, offset, datatype, count: 1 })),
    is_bigendian: false, point_step: step, row_step: step * POINTS, data, is_dense: false,
  };
}
function livoxMessage(k, flavor) {
  const points = [];
  for (let j = 0; j < POINTS; ++j) {
    const p = point(k, j);
    points.push({ offset_time: p.offset_ns, x: p.x, y: p.y, z: p.z, reflectivity: p.intensity, tag: 0x10, line: p.ring % 4 });
  }
  return { header: header(scanStart(k), "livox_frame", flavor), timebase: scanStart(k), point_num: POINTS, lidar_id: 0,
    rsvd: new Uint8Array(3), points };
}

/// What fuse-import must write for scan k: kept points (NaN and origin dropped), times.
function expectedScan(k, conv) {
  const kept = [];
  const offs = [];
  const stampS = conv ? sec(CONVENTIONS[conv].stamp(k)) : sec(scanStart(k));
  for (let j = 0; j < POINTS; ++j) {
    const p = point(k, j);
    if (p.bad) continue;
    let off;  // seconds from the header stamp (or timebase), as the file holds it
    if (!conv || conv === "t" || conv === "offset_time") off = p.offset_ns * 1e-9;
    else if (conv === "time") off = CONVENTIONS.time.value(k, p);
    else off = CONVENTIONS.timestamp.value(k, p) - stampS;
    offs.push(off);
    kept.push([f32(p.x), f32(p.y), f32(p.z), p.intensity, conv ? p.ring : p.ring % 4]);
  }
  const lo = Math.min(...offs), hi = Math.max(...offs);
  return { t_start: stampS + lo, t_end: stampS + hi, points: kept.map((q, i) => [...q, offs[i] - lo]) };
}

// ---- ROS 1 bag container (Bags/Format/2.0), written by this script ----
class Bytes {
  constructor() { this.parts = []; this.length = 0; }
  push(u8) { this.parts.push(u8); this.length += u8.length; }
  u32(v) { const b = new Uint8Array(4); new DataView(b.buffer).setUint32(0, v, true); this.push(b); }
  concat() { const o = new Uint8Array(this.length); let p = 0; for (const x of this.parts) { o.set(x, p); p += x.length; } return o; }
}
const enc = new TextEncoder();
function fieldsBytes(fields) {  // [name, Uint8Array value]
  const b = new Bytes();
  for (const [name, value] of fields) { const n = enc.encode(name + "="); b.u32(n.length + value.length); b.push(n); b.push(value); }
  return b.concat();
}
const u8 = (v) => Uint8Array.of(v);
const u32 = (v) => { const b = new Uint8Array(4); new DataView(b.buffer).setUint32(0, v, true); return b; };
const u64 = (v) => { const b = new Uint8Array(8); new DataView(b.buffer).setBigUint64(0, BigInt(v), true); return b; };
const rtime = (ns) => { const b = new Uint8Array(8); const d = new DataView(b.buffer);
  d.setUint32(0, Number(ns / 1000000000n), true); d.setUint32(4, Number(ns % 1000000000n), true); return b; };
function record(b, headerFields, data) { const h = fieldsBytes(headerFields); b.u32(h.length); b.push(h); b.u32(data.length); b.push(data); }

function writeRos1Bag(file, connections, messages, compression, perChunk) {
  // connections: [{id, topic, type}], messages: [{conn, time (ns BigInt), data}] sorted by time.
  const connRecord = (b, c) => record(b, [["op", u8(7)], ["conn", u32(c.id)], ["topic", enc.encode(c.topic)]],
    fieldsBytes([["topic", enc.encode(c.topic)], ["type", enc.encode(c.type)], ["md5sum", enc.encode(MD5[c.type] ?? "*")],
      ["message_definition", enc.encode(DEFS.ros1[c.type])]]));
  const body = new Bytes();
  const infos = [];
  const headerSize = 4096;
  let pos = 13 + headerSize;
  for (let i = 0; i < messages.length; i += perChunk) {
    const inner = new Bytes();
    const index = new Map();
    const seen = new Set();
    const slice = messages.slice(i, i + perChunk);
    for (const m of slice) {
      if (!seen.has(m.conn)) { seen.add(m.conn); connRecord(inner, connections.find((c) => c.id === m.conn)); }
      if (!index.has(m.conn)) index.set(m.conn, []);
      index.get(m.conn).push([m.time, inner.length]);
      record(inner, [["op", u8(2)], ["conn", u32(m.conn)], ["time", rtime(m.time)]], m.data);
    }
    const raw = inner.concat();
    let packed = raw;
    if (compression === "lz4") packed = Uint8Array.from(lz4.compress(raw));
    if (compression === "bz2") packed = Uint8Array.from(compressjs.Bzip2.compressFile(Array.from(raw)));
    const chunk = new Bytes();
    record(chunk, [["op", u8(5)], ["compression", enc.encode(compression)], ["size", u32(raw.length)]], packed);
    for (const [conn, entries] of index) {
      const d = new Bytes();
      for (const [t, off] of entries) { d.push(rtime(t)); d.u32(off); }
      record(chunk, [["op", u8(4)], ["ver", u32(1)], ["conn", u32(conn)], ["count", u32(entries.length)]], d.concat());
    }
    const times = slice.map((m) => m.time);
    infos.push({ pos, start: times.reduce((a, b) => (b < a ? b : a)), end: times.reduce((a, b) => (b > a ? b : a)),
      counts: [...index].map(([c, e]) => [c, e.length]) });
    const bytes = chunk.concat();
    body.push(bytes);
    pos += bytes.length;
  }
  const indexPos = pos;
  for (const c of connections) connRecord(body, c);
  for (const info of infos) {
    const d = new Bytes();
    for (const [c, n] of info.counts) { d.u32(c); d.u32(n); }
    record(body, [["op", u8(6)], ["ver", u32(1)], ["chunk_pos", u64(info.pos)], ["start_time", rtime(info.start)],
      ["end_time", rtime(info.end)], ["count", u32(info.counts.length)]], d.concat());
  }
  const head = new Bytes();
  head.push(enc.encode("#ROSBAG V2.0\n"));
  const hf = fieldsBytes([["op", u8(3)], ["index_pos", u64(indexPos)], ["conn_count", u32(connections.length)],
    ["chunk_count", u32(infos.length)]]);
  head.u32(hf.length); head.push(hf);
  const pad = headerSize - 8 - hf.length;
  head.u32(pad); head.push(new Uint8Array(pad).fill(0x20));
  head.push(body.concat());
  fs.writeFileSync(file, head.concat());
}

async function checkRos1Bag(file, expectedCount) {
  const reader = new FileReader(file);
  // parse: false — the deliberately cut LiDAR message would not parse; the container must read.
  const bag = new Bag(reader, {
    parse: false,
    decompress: {
      lz4: (buffer, size) => Uint8Array.from(lz4.decompress(buffer, size)),
      bz2: (buffer) => Uint8Array.from(compressjs.Bzip2.decompressFile(Array.from(buffer))),
    },
  });
  await bag.open();
  let n = 0;
  for await (const m of bag.messageIterator()) {
    if (!(m.data instanceof Uint8Array) || m.data.length === 0) throw new Error(`${file}: empty message data`);
    ++n;
  }
  await reader.close?.();
  if (n !== expectedCount) throw new Error(`${file}: @foxglove/rosbag reads ${n} messages, expected ${expectedCount}`);
}

// ---- rosbag2 storages ----
function metadataYaml(storage, files, topics, count, startNs, endNs) {
  const t = topics.map((x) => `  - topic_metadata:\n      name: ${x.name}\n      type: ${x.type}\n      serialization_format: cdr\n` +
    `      offered_qos_profiles: ''\n    message_count: ${x.count}`).join("\n");
  return `rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: ${storage}\n` +
    `  duration:\n    nanoseconds: ${endNs - startNs}\n  starting_time:\n    nanoseconds_since_epoch: ${startNs}\n` +
    `  message_count: ${count}\n  topics_with_message_count:\n${t}\n  compression_format: ''\n  compression_mode: ''\n` +
    `  relative_file_paths:\n${files.map((f) => "    - " + f).join("\n")}\n`;
}

async function writeMcap(file, topics, messages) {
  const chunks = [];
  let position = 0n;
  const writable = { position: () => position, write: async (buf) => { chunks.push(Buffer.from(buf)); position += BigInt(buf.byteLength); } };
  const w = new McapWriter({ writable, chunkSize: 64 * 1024 });
  await w.start({ profile: "ros2", library: "fuse interop test (@mcap/core)" });
  const channel = {};
  for (const t of topics) {
    const schemaId = await w.registerSchema({ name: t.type, encoding: "ros2msg", data: enc.encode(DEFS.ros2[t.type]) });
    channel[t.name] = await w.registerChannel({ topic: t.name, schemaId, messageEncoding: "cdr", metadata: new Map() });
  }
  let seq = 0;
  for (const m of messages) {
    await w.addMessage({ channelId: channel[m.topic], sequence: seq++, logTime: m.time, publishTime: m.time, data: m.data });
  }
  await w.end();
  fs.writeFileSync(file, Buffer.concat(chunks));
}

async function writeSqlite(file, topics, messages) {
  const SQL = await initSqlJs();
  const db = new SQL.Database();
  db.run("CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL, serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL);");
  db.run("CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, timestamp INTEGER NOT NULL, data BLOB NOT NULL);");
  const ids = {};
  topics.forEach((t, i) => { ids[t.name] = i + 1; db.run("INSERT INTO topics VALUES (?, ?, ?, 'cdr', '')", [i + 1, t.name, t.type]); });
  const ins = db.prepare("INSERT INTO messages(topic_id, timestamp, data) VALUES (?, ?, ?)");
  for (const m of messages) ins.run([ids[m.topic], m.time.toString(), m.data]);
  ins.free();
  // timestamps were bound as text to keep all 19 digits; store them as integers.
  db.run("UPDATE messages SET timestamp = CAST(timestamp AS INTEGER)");
  fs.writeFileSync(file, Buffer.from(db.export()));
  db.close();
}

// ---- The cases ----
// Each: a bag, the fuse-import arguments, and the expected recording.
const cases = [
  { name: "ros1_ouster_t", kind: "ros1", compression: "none", conv: "t" },
  { name: "ros1_velodyne_time_bz2", kind: "ros1", compression: "bz2", conv: "time" },
  { name: "ros1_livox_custom_lz4_g", kind: "ros1", compression: "lz4", conv: null, inG: true },
  { name: "rosbag2_mcap_hesai_timestamp", kind: "mcap", conv: "timestamp" },
  { name: "rosbag2_sqlite_livox2_offset_time", kind: "sqlite3", conv: "offset_time" },
  { name: "rosbag2_sqlite_livox2_custom", kind: "sqlite3", conv: null },
];

const expected = { cases: [] };
for (const c of cases) {
  const flavor = c.kind === "ros1" ? "ros1" : "ros2";
  const imuType = flavor === "ros1" ? "sensor_msgs/Imu" : "sensor_msgs/msg/Imu";
  const lidarType = c.conv ? (flavor === "ros1" ? "sensor_msgs/PointCloud2" : "sensor_msgs/msg/PointCloud2")
    : (flavor === "ros1" ? "livox_ros_driver/CustomMsg" : "livox_ros_driver2/msg/CustomMsg");
  const noteType = flavor === "ros1" ? "std_msgs/String" : "std_msgs/msg/String";
  const msgs = [];
  for (let i = 0; i < IMU_N; ++i) {
    const t = T0 + BigInt(i) * IMU_DT;
    msgs.push({ topic: "/imu", time: t + 200000n, data: serialize(flavor, imuType, imuMessage(i, flavor, c.inG)) });
  }
  for (let k = 0; k < SCANS; ++k) {
    const m = c.conv ? cloudMessage(k, c.conv, flavor) : livoxMessage(k, flavor);
    const data = serialize(flavor, lidarType, m);
    msgs.push({ topic: "/lidar", time: scanStart(k) + SCAN_DT + 5000000n, data });
    msgs.push({ topic: "/note", time: scanStart(k), data: serialize(flavor, noteType, { data: `scan ${k}` }) });
  }
  // One malformed LiDAR message (cut short) at the end: skipped and counted by fuse-import.
  const last = c.conv ? cloudMessage(SCANS, c.conv, flavor) : livoxMessage(SCANS, flavor);
  const cut = serialize(flavor, lidarType, last);
  msgs.push({ topic: "/lidar", time: scanStart(SCANS) + SCAN_DT + 5000000n, data: cut.slice(0, cut.length - 40) });
  msgs.sort((a, b) => (a.time < b.time ? -1 : a.time > b.time ? 1 : 0));

  const topics = [{ name: "/imu", type: imuType }, { name: "/lidar", type: lidarType }, { name: "/note", type: noteType }];
  for (const t of topics) t.count = msgs.filter((m) => m.topic === t.name).length;
  let input;
  if (c.kind === "ros1") {
    input = path.join(out, c.name + ".bag");
    const conns = topics.map((t, i) => ({ id: i, topic: t.name, type: t.type }));
    const byName = Object.fromEntries(conns.map((x) => [x.topic, x.id]));
    writeRos1Bag(input, conns, msgs.map((m) => ({ conn: byName[m.topic], time: m.time, data: m.data })), c.compression, 150);
    await checkRos1Bag(input, msgs.length);
  } else {
    input = path.join(out, c.name);
    fs.rmSync(input, { recursive: true, force: true });
    fs.mkdirSync(input);
    const file = c.name + (c.kind === "mcap" ? ".mcap" : ".db3");
    if (c.kind === "mcap") await writeMcap(path.join(input, file), topics, msgs);
    else await writeSqlite(path.join(input, file), topics, msgs);
    fs.writeFileSync(path.join(input, "metadata.yaml"),
      metadataYaml(c.kind, [file], topics, msgs.length, msgs[0].time, msgs[msgs.length - 1].time));
  }

  const imu = [];
  for (let i = 0; i < IMU_N; ++i) {
    const v = imuValues(i);
    // In g, the file holds accel / g; fuse-import multiplies by g again.
    const a = c.inG ? v.accel.map((x) => (x / G) * G) : v.accel;
    imu.push([sec(T0 + BigInt(i) * IMU_DT), ...v.gyro, ...a]);
  }
  const scans = [];
  for (let k = 0; k < SCANS; ++k) scans.push(expectedScan(k, c.conv));
  const args = ["--input", input];
  if (c.inG) args.push("--imu-accel-unit", "g");
  // One case also stores the LiDAR-IMU extrinsic (a 90 degree yaw and an offset).
  const extrinsic = c.name === "ros1_ouster_t" ? [0.05, -0.02, 0.1, 0, 0, Math.SQRT1_2, Math.SQRT1_2] : null;
  if (extrinsic) args.push("--extrinsic", extrinsic.join(","));
  expected.cases.push({ name: c.name, args, imu, scans, extrinsic, malformed_lidar: 1, other_topic_messages: SCANS });
  console.log(`${c.name}: ${msgs.length} messages -> ${input}`);
}
fs.writeFileSync(path.join(out, "expected.json"), JSON.stringify(expected));
