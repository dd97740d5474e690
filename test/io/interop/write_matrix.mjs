// MCAP files from a writer that is not ours (@mcap/core's McapWriter), covering what the
// specification allows: every writer option toggled on its own and every pair of options
// toggled together, each with metadata and an attachment, plus files without messages, without
// metadata, and with chunks cut small. Next to each FILE.mcap, FILE.json says what was written
// (messages per topic, metadata records, the options), for mcap_matrix_test to check against.
// Usage: node write_matrix.mjs OUT_DIR
import { mkdir, writeFile } from "node:fs/promises";
import { join } from "node:path";
import { McapWriter } from "@mcap/core";

const OPTIONS = ["useStatistics", "useSummaryOffsets", "useChunks", "repeatSchemas", "repeatChannels",
                 "useAttachmentIndex", "useMetadataIndex", "useMessageIndex", "useChunkIndex"];
// The writer's defaults (all on): a variant turns options off.
const DEFAULTS = Object.fromEntries(OPTIONS.map((o) => [o, true]));

class BufferWritable {
  #chunks = [];
  #size = 0n;
  position() { return this.#size; }
  async write(data) { this.#chunks.push(data.slice()); this.#size += BigInt(data.byteLength); }
  bytes() { return Buffer.concat(this.#chunks); }
}

async function writeVariant(dir, name, off, { messages = 120, metadata = true, attachment = true, chunkSize } = {}) {
  const options = { ...DEFAULTS };
  for (const o of off) options[o] = false;
  const writable = new BufferWritable();
  const writer = new McapWriter({ writable, ...options, ...(chunkSize ? { chunkSize } : {}) });
  await writer.start({ profile: "", library: "mcap-matrix" });
  const encoder = new TextEncoder();
  const imuSchema = await writer.registerSchema({ name: "test::Imu", encoding: "jsonschema", data: encoder.encode("{}") });
  const scanSchema = await writer.registerSchema({ name: "test::Scan", encoding: "jsonschema", data: encoder.encode("{}") });
  const channels = [
    { topic: "imu", id: await writer.registerChannel({ topic: "imu", schemaId: imuSchema, messageEncoding: "json", metadata: new Map() }) },
    { topic: "lidar/scan", id: await writer.registerChannel({ topic: "lidar/scan", schemaId: scanSchema, messageEncoding: "json", metadata: new Map() }) },
    { topic: "raw", id: await writer.registerChannel({ topic: "raw", schemaId: 0, messageEncoding: "octets", metadata: new Map([["k", "v"]]) }) },
  ];
  const counts = {};
  for (let i = 0; i < messages; i++) {
    const c = channels[i % 10 === 0 ? 1 : i % 7 === 0 ? 2 : 0];
    const t = 1_000_000_000n + BigInt(i) * 5_000_000n;
    await writer.addMessage({ channelId: c.id, sequence: i, logTime: t, publishTime: t,
                              data: encoder.encode(JSON.stringify({ i, pad: "x".repeat(i % 50) })) });
    counts[c.topic] = (counts[c.topic] ?? 0) + 1;
    if (metadata && i === Math.floor(messages / 2)) {
      await writer.addMetadata({ name: "calibration", metadata: new Map([["a", "1"], ["b", String(i)]]) });
    }
  }
  if (metadata) await writer.addMetadata({ name: "run", metadata: new Map([["end", "yes"]]) });
  if (attachment) {
    await writer.addAttachment({ name: "notes.txt", logTime: 1_000_000_000n, createTime: 1_000_000_000n,
                                 mediaType: "text/plain", data: encoder.encode("hello") });
  }
  await writer.end();
  const metadataCount = metadata ? (messages > 0 ? 2 : 1) : 0;
  await writeFile(join(dir, `${name}.mcap`), writable.bytes());
  await writeFile(join(dir, `${name}.json`), JSON.stringify({ options, messages: counts, metadata: metadataCount }));
}

const dir = process.argv[2];
if (!dir) throw new Error("usage: node write_matrix.mjs OUT_DIR");
await mkdir(dir, { recursive: true });
let n = 0;
await writeVariant(dir, "all_on", []); n++;
for (const o of OPTIONS) { await writeVariant(dir, `off_${o}`, [o]); n++; }
for (let i = 0; i < OPTIONS.length; i++) {
  for (let j = i + 1; j < OPTIONS.length; j++) { await writeVariant(dir, `off_${OPTIONS[i]}_${OPTIONS[j]}`, [OPTIONS[i], OPTIONS[j]]); n++; }
}
await writeVariant(dir, "all_off", OPTIONS); n++;
await writeVariant(dir, "empty", [], { messages: 0, metadata: false, attachment: false }); n++;
await writeVariant(dir, "empty_with_metadata", [], { messages: 0 }); n++;
await writeVariant(dir, "empty_without_chunks", ["useChunks"], { messages: 0, metadata: false, attachment: false }); n++;
await writeVariant(dir, "no_metadata", [], { metadata: false, attachment: false }); n++;
await writeVariant(dir, "small_chunks", [], { chunkSize: 256 }); n++;
await writeVariant(dir, "small_chunks_no_indexes", ["useChunkIndex", "useMessageIndex", "useMetadataIndex"], { chunkSize: 256 }); n++;
console.log(`${n} MCAP files written to ${dir}`);
