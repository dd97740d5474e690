// Interoperability check: opens FUSE recordings with the reference MCAP readers (@mcap/core,
// streaming and indexed) and decodes one message of every channel with @foxglove/omgidl-
// serialization, using only the schema embedded in the file. Exit code 0 = every check passed.
// A directory argument stands for every .mcap file in it (fuse-record's numbered files).
// Usage: node read_recording.mjs RECORDING.mcap|DIR [...]
import { readFile, open, readdir, stat } from "node:fs/promises";
import { join } from "node:path";
import { crc32 } from "@foxglove/crc";
import { McapIndexedReader, McapStreamReader } from "@mcap/core";
import { FileHandleReadable } from "@mcap/nodejs";
import { loadDecompressHandlers } from "@mcap/support";
import { parseIDL } from "@foxglove/omgidl-parser";
import { MessageReader } from "@foxglove/omgidl-serialization";

const NS_PER_S = 1e9;
// A sample's own time (double seconds) and its log time (integer ns) agree to rounding.
const TIME_TOLERANCE_S = 1e-6;

function check(ok, what) {
  if (!ok) throw new Error(`check failed: ${what}`);
}

const isFiniteNumber = (v) => typeof v === "number" && Number.isFinite(v);

// Whole-file pass with the streaming reader, validating chunk CRCs, counting messages.
function streamCheck(bytes, decompressHandlers) {
  const reader = new McapStreamReader({ decompressHandlers, validateCrcs: true });
  reader.append(bytes);
  let messages = 0;
  let statistics;
  for (let record; (record = reader.nextRecord()); ) {
    if (record.type === "Message") messages++;
    if (record.type === "Statistics") statistics = record;
  }
  check(reader.done(), "stream reader consumed the whole file");
  check(statistics !== undefined, "file has a Statistics record");
  check(BigInt(messages) === statistics.messageCount,
        `stream reader counted ${messages} messages, Statistics says ${statistics.messageCount}`);
  return messages;
}

// Data-section CRC: CRC-32 of every byte before the DataEnd record, magic included.
function checkDataSectionCrc(bytes, indexed) {
  const crc = indexed.dataSectionCrc;
  if (crc === undefined) return "not recorded";
  const computed = crc32(bytes.subarray(0, Number(indexed.dataEndOffset)));
  check(computed === crc, `data section CRC ${computed} != recorded ${crc}`);
  return "ok";
}

function checkImu(msg, logTime) {
  check(isFiniteNumber(msg.t), "imu.t is a finite number");
  check(Math.abs(msg.t - Number(logTime) / NS_PER_S) < TIME_TOLERANCE_S, `imu.t ${msg.t} matches log time ${logTime}`);
  for (const field of ["gyro", "accel"]) {
    const v = msg[field];
    check([v.x, v.y, v.z].length === 3 && [v.x, v.y, v.z].every(isFiniteNumber), `imu.${field} has 3 finite components`);
  }
  check(typeof msg.frame === "string" && msg.frame.length > 0, "imu.frame is a non-empty string");
  check(Math.abs(Math.hypot(msg.accel.x, msg.accel.y, msg.accel.z) - 9.8) < 5, "imu.accel magnitude near gravity");
}

function checkScan(msg, logTime) {
  check(Math.abs(msg.end_time - Number(logTime) / NS_PER_S) < TIME_TOLERANCE_S, `scan.end_time matches log time`);
  check(msg.end_time >= msg.start_time, "scan.end_time >= start_time");
  check(Array.isArray(msg.points) && msg.points.length > 0, "scan has points");
  const p = msg.points[0];
  check([p.x, p.y, p.z, p.intensity, p.time_offset].every(isFiniteNumber), "first point has finite fields");
  check(Number.isInteger(p.ring), "first point ring is an integer");
  const last = msg.points[msg.points.length - 1];
  check(last.time_offset >= 0 && last.time_offset <= msg.end_time - msg.start_time + TIME_TOLERANCE_S, "last point time offset inside the scan");
}

async function checkFile(path, decompressHandlers) {
  const bytes = new Uint8Array(await readFile(path));
  const streamed = streamCheck(bytes, decompressHandlers);

  const handle = await open(path, "r");
  try {
    const reader = await McapIndexedReader.Initialize({ readable: new FileHandleReadable(handle), decompressHandlers });
    const dataCrc = checkDataSectionCrc(bytes, reader);
    const topics = [...reader.channelsById.values()].map((c) => c.topic).sort();
    check(topics.includes("imu") && topics.includes("lidar/scan"), `channels imu and lidar/scan present (found ${topics})`);
    for (const channel of reader.channelsById.values()) {
      // A channel may be declared with no message in this file (a recorder's rotated file).
      if (reader.statistics && (reader.statistics.channelMessageCounts.get(channel.id) ?? 0n) === 0n) {
        console.log(`${path}: ${channel.topic} has no messages in this file`);
        continue;
      }
      const schema = reader.schemasById.get(channel.schemaId);
      check(schema !== undefined, `channel ${channel.topic} has a schema`);
      if (channel.messageEncoding === "json") {
        // A Foxglove view channel beside the data: JSON with a JSON Schema (test/viz checks them whole).
        check(schema.encoding === "jsonschema", `${channel.topic}: json messages with a jsonschema schema`);
        JSON.parse(new TextDecoder().decode(schema.data));
        for await (const message of reader.readMessages({ topics: [channel.topic] })) {
          const msg = JSON.parse(new TextDecoder().decode(message.data));
          check(typeof msg === "object" && msg !== null, `${channel.topic}: a JSON object`);
          break;
        }
        console.log(`${path}: ${channel.topic} (${schema.name}, json) decoded`);
        continue;
      }
      check(schema.encoding === "omgidl" && channel.messageEncoding === "cdr", `${channel.topic}: omgidl schema, cdr messages`);
      const definitions = parseIDL(new TextDecoder().decode(schema.data));
      const decoder = new MessageReader(schema.name, definitions);
      let decoded = 0;
      for await (const message of reader.readMessages({ topics: [channel.topic] })) {
        const msg = decoder.readMessage(message.data);
        if (channel.topic === "imu") checkImu(msg, message.logTime);
        if (channel.topic === "lidar/scan") checkScan(msg, message.logTime);
        decoded++;
        break; // one message per channel
      }
      check(decoded === 1, `one message decoded on ${channel.topic}`);
      console.log(`${path}: ${channel.topic} (${schema.name}) decoded`);
    }
    let calibration = "absent";
    for await (const metadata of reader.readMetadata({ name: "fuse.calibration" })) {
      for (const key of ["tx", "ty", "tz", "qx", "qy", "qz", "qw"]) {
        check(isFiniteNumber(Number(metadata.metadata.get(key))), `calibration key ${key} is a number`);
      }
      calibration = "ok";
    }
    console.log(`${path}: ${streamed} messages, ${reader.chunkIndexes.length} chunks, ` +
                `compression ${reader.chunkIndexes[0]?.compression || "none"}, data CRC ${dataCrc}, calibration ${calibration}`);
  } finally {
    await handle.close();
  }
}

const files = [];
for (const arg of process.argv.slice(2)) {
  if ((await stat(arg)).isDirectory()) {
    const inside = (await readdir(arg)).filter((n) => n.endsWith(".mcap")).sort();
    check(inside.length > 0, `directory ${arg} holds .mcap files`);
    files.push(...inside.map((n) => join(arg, n)));
  } else {
    files.push(arg);
  }
}
if (files.length === 0) {
  console.error("usage: node read_recording.mjs RECORDING.mcap|DIR [...]");
  process.exit(2);
}
const decompressHandlers = await loadDecompressHandlers();
for (const file of files) await checkFile(file, decompressHandlers);
console.log("all checks passed");
