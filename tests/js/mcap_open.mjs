// What the tests' MCAP readers share: @mcap/core's indexed reader on a file, with the chunk
// compressions the rig writes (zstd, lz4), and a ros2msg/CDR decoder per channel from the schemas in
// the file (@foxglove/rosmsg + @foxglove/rosmsg2-serialization), so nothing of the rig's own reader
// is in the way.
import { open } from "node:fs/promises";
import { McapIndexedReader } from "@mcap/core";
import { parse } from "@foxglove/rosmsg";
import { MessageReader } from "@foxglove/rosmsg2-serialization";
import { decompress as zstdDecompress } from "fzstd";
import lz4 from "lz4js";

export const decompressHandlers = {
  zstd: (buf, size) => zstdDecompress(buf, new Uint8Array(Number(size))),
  lz4: (buf, size) => {
    const out = lz4.decompress(buf, Number(size));
    return out.length === Number(size) ? out : out.subarray(0, Number(size));
  },
};

// The file opened and its size; the caller closes `handle`.
export async function openFile(file) {
  const handle = await open(file, "r");
  return { handle, size: (await handle.stat()).size };
}

// @mcap/core's indexed reader over an open file.
export async function indexedReader(handle, size) {
  const readable = {
    size: async () => BigInt(size),
    read: async (offset, length) => {
      const buf = new Uint8Array(Number(length));
      await handle.read(buf, 0, Number(length), Number(offset));
      return buf;
    },
  };
  return McapIndexedReader.Initialize({ readable, decompressHandlers });
}

// channel id -> {reader, schema, topic} for every channel of ros2msg schema and cdr encoding.
export function ros2Decoders(reader) {
  const decoders = new Map();
  for (const [id, ch] of reader.channelsById) {
    const schema = reader.schemasById.get(ch.schemaId);
    if (schema && schema.encoding === "ros2msg" && ch.messageEncoding === "cdr")
      decoders.set(id, { reader: new MessageReader(parse(new TextDecoder().decode(schema.data), { ros2: true })),
                         schema: schema.name, topic: ch.topic });
  }
  return decoders;
}
