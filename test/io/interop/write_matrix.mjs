// MCAP files from a writer that is not ours (@mcap/core's McapWriter), covering what the
// specification allows: every writer option toggled on its own and every pair of options
// toggled together, each with metadata and an attachment, plus files without messages, without
// metadata, and with chunks cut small. Chunk compression is one more dimension: zstd
// (@foxglove/wasm-zstd) and lz4 each with every option on, each with every other option off on
// its own (so every pair "compression + option off" exists), with small chunks, with
// incompressible payloads, and without messages.
// lz4 frames come from lz4js, because @foxglove/wasm-lz4 (what @mcap/support reads lz4 with) can
// only decompress; every compressed chunk is decoded back through the reference decoder
// (@foxglove/wasm-lz4 / @foxglove/wasm-zstd) before it is written, so the files only hold frames
// the reference readers accept.
// Next to each FILE.mcap, FILE.json says what was written (messages per topic, metadata records,
// the options with the chunk compression, how many chunks were compressed), for
// mcap_matrix_test to check against.
// Usage: node write_matrix.mjs OUT_DIR
import { mkdir, writeFile } from "node:fs/promises";
import { join } from "node:path";
import { McapWriter } from "@mcap/core";
import lz4Decompress from "@foxglove/wasm-lz4";
import * as zstd from "@foxglove/wasm-zstd";
import lz4js from "lz4js";

const OPTIONS = ["useStatistics", "useSummaryOffsets", "useChunks", "repeatSchemas", "repeatChannels",
                 "useAttachmentIndex", "useMetadataIndex", "useMessageIndex", "useChunkIndex"];
// The writer's defaults (all on): a variant turns options off.
const DEFAULTS = Object.fromEntries(OPTIONS.map((o) => [o, true]));
const COMPRESSIONS = ["zstd", "lz4"];

class BufferWritable {
  #chunks = [];
  #size = 0n;
  position() { return this.#size; }
  async write(data) { this.#chunks.push(data.slice()); this.#size += BigInt(data.byteLength); }
  bytes() { return Buffer.concat(this.#chunks); }
}

function sameBytes(a, b) {
  return a.byteLength === b.byteLength && Buffer.compare(Buffer.from(a.buffer, a.byteOffset, a.byteLength),
                                                         Buffer.from(b.buffer, b.byteOffset, b.byteLength)) === 0;
}

// LZ4 frame block headers after the 7-byte frame header lz4js writes (magic, FLG, BD, HC; no
// content size): true when one of the blocks is stored uncompressed (high bit of its size).
function lz4HasStoredBlock(frame) {
  const view = new DataView(frame.buffer, frame.byteOffset, frame.byteLength);
  for (let pos = 7; pos + 4 <= frame.byteLength;) {
    const size = view.getUint32(pos, true);
    if (size === 0) return false;  // end mark
    if (size & 0x80000000) return true;
    pos += 4 + size;
  }
  return false;
}

// McapWriter's compressChunk for `compression`, checking each frame with the reference decoder.
// `stats` counts the chunks compressed and the lz4 frames holding a stored block.
function chunkCompressor(compression, stats) {
  return (data) => {
    const compressedData = compression === "zstd" ? zstd.compress(data, 3) : lz4js.compress(data);
    const decoded = compression === "zstd" ? zstd.decompress(compressedData, data.byteLength)
                                           : lz4Decompress(compressedData, data.byteLength);
    if (!sameBytes(decoded, data)) {
      throw new Error(`${compression} chunk of ${data.byteLength} bytes does not round-trip through the reference decoder`);
    }
    stats.chunks++;
    if (compression === "lz4" && lz4HasStoredBlock(compressedData)) stats.storedBlocks++;
    return { compression, compressedData };
  };
}

// Deterministic pseudo-random bytes (xorshift32), for payloads no compressor can shrink.
function noise(seed, n) {
  let x = (seed * 2654435761) >>> 0 || 1;
  const out = new Uint8Array(n);
  for (let k = 0; k < n; k++) {
    x ^= x << 13; x >>>= 0; x ^= x >>> 17; x ^= x << 5; x >>>= 0;
    out[k] = x & 0xff;
  }
  return out;
}

async function writeVariant(dir, name, off, { messages = 120, metadata = true, attachment = true, chunkSize,
                                              compression = "", incompressible = false } = {}) {
  const options = { ...DEFAULTS };
  for (const o of off) options[o] = false;
  const stats = { chunks: 0, storedBlocks: 0 };
  const writable = new BufferWritable();
  const writer = new McapWriter({ writable, ...options, ...(chunkSize ? { chunkSize } : {}),
                                  ...(compression ? { compressChunk: chunkCompressor(compression, stats) } : {}) });
  await writer.start({ profile: "", library: "mcap-matrix" });
  const encoder = new TextEncoder();
  const imuSchema = await writer.registerSchema({ name: "test::Imu", encoding: "jsonschema", data: encoder.encode("{}") });
  const scanSchema = await writer.registerSchema({ name: "test::Scan", encoding: "jsonschema", data: encoder.encode("{}") });
  // Incompressible payloads are raw octets on every channel (no schema, nothing to decode).
  const channel = (topic, schemaId, metadata = new Map()) =>
    writer.registerChannel({ topic, schemaId: incompressible ? 0 : schemaId,
                             messageEncoding: incompressible || schemaId === 0 ? "octets" : "json", metadata });
  const channels = [
    { topic: "imu", id: await channel("imu", imuSchema) },
    { topic: "lidar/scan", id: await channel("lidar/scan", scanSchema) },
    { topic: "raw", id: await channel("raw", 0, new Map([["k", "v"]])) },
  ];
  const counts = {};
  for (let i = 0; i < messages; i++) {
    const c = channels[i % 10 === 0 ? 1 : i % 7 === 0 ? 2 : 0];
    const t = 1_000_000_000n + BigInt(i) * 5_000_000n;
    const data = incompressible ? noise(i + 1, 200 + 37 * (i % 11))
                                : encoder.encode(JSON.stringify({ i, pad: "x".repeat(i % 50) }));
    // Incompressible: a publish time unlike the log time too (an equal one is a match lz4 can use).
    const publishTime = incompressible ? new DataView(noise(100_000 + i, 8).buffer).getBigUint64(0, true) : t;
    await writer.addMessage({ channelId: c.id, sequence: i, logTime: t, publishTime, data });
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
  if (incompressible && compression === "lz4" && stats.storedBlocks === 0) {
    throw new Error(`${name}: no lz4 chunk holds a stored (uncompressed) block`);
  }
  const metadataCount = metadata ? (messages > 0 ? 2 : 1) : 0;
  await writeFile(join(dir, `${name}.mcap`), writable.bytes());
  await writeFile(join(dir, `${name}.json`), JSON.stringify({ options: { ...options, compression }, messages: counts,
                                                              metadata: metadataCount, compressedChunks: stats.chunks }));
}

const dir = process.argv[2];
if (!dir) throw new Error("usage: node write_matrix.mjs OUT_DIR");
await Promise.all([zstd.isLoaded, lz4Decompress.isLoaded]);
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
for (const compression of COMPRESSIONS) {
  await writeVariant(dir, `${compression}_all_on`, [], { compression }); n++;
  for (const o of OPTIONS) { await writeVariant(dir, `${compression}_off_${o}`, [o], { compression }); n++; }
  await writeVariant(dir, `${compression}_small_chunks`, [], { compression, chunkSize: 256 }); n++;
  // Random payloads, one message per chunk (chunkSize 1): lz4 chunks with stored blocks.
  await writeVariant(dir, `${compression}_incompressible`, [], { compression, chunkSize: 1, incompressible: true }); n++;
  // McapWriter writes no Chunk without messages, so this file has none: the reader must not need one.
  await writeVariant(dir, `${compression}_empty`, [], { compression, messages: 0, metadata: false, attachment: false }); n++;
}
console.log(`${n} MCAP files written to ${dir}`);
