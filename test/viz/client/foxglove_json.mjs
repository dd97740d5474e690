// The JSON encoding of Foxglove's schemas, as both checks read it: the string fields a JSON
// Schema marks `contentEncoding: base64` are the schema's bytes fields, decoded to Buffers.

/// Paths (property names, "[]" for array items) of the base64 string fields of `schema`.
export function base64Paths(schema, path = []) {
  if (!schema || typeof schema !== "object") return [];
  if (schema.type === "string" && schema.contentEncoding === "base64") return [path];
  if (schema.type === "object" && schema.properties) {
    return Object.entries(schema.properties).flatMap(([k, v]) => base64Paths(v, [...path, k]));
  }
  if (schema.type === "array" && schema.items) return base64Paths(schema.items, [...path, "[]"]);
  return [];
}

/// `value` with the field at `path` decoded from base64 into a Buffer.
export function decodeBytes(value, path) {
  if (path.length === 0) return Buffer.from(value, "base64");
  const [head, ...rest] = path;
  if (head === "[]") return value.map((v) => decodeBytes(v, rest));
  return { ...value, [head]: decodeBytes(value[head], rest) };
}

/// The root a frame reaches through `parents` (child -> parent, from FrameTransforms); a cycle
/// ends at the frame where it closes.
export function rootOf(parents, frame) {
  const seen = new Set();
  while (parents.has(frame) && !seen.has(frame)) {
    seen.add(frame);
    frame = parents.get(frame);
  }
  return frame;
}
