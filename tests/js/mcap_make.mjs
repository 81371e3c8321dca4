// Writes an MCAP file in the `ros2` profile with @mcap/core's McapWriter (chunked, lz4 via lz4js),
// the messages encoded by @foxglove/rosmsg2-serialization from schema texts written here, as a
// ROS 2 tool other than the rig would: /made/compressed (sensor_msgs/msg/CompressedImage, QoS
// metadata in the names form of newer rosbag2) and /made/unknown (std_msgs/msg/String, a type the
// rig does not know). Prints what it wrote as JSON. Usage: node mcap_make.mjs FILE [N]
import { open } from "node:fs/promises";
import { McapWriter } from "@mcap/core";
import { parse } from "@foxglove/rosmsg";
import { MessageWriter } from "@foxglove/rosmsg2-serialization";
import lz4 from "lz4js";

const SEP = "\n" + "=".repeat(80) + "\n";
const compressedSchema =
  "std_msgs/Header header\nstring format\nuint8[] data\n" +
  SEP + "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n" +
  SEP + "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n";
const stringSchema = "string data\n";

function fnv1a(bytes) {
  let h = 0x811c9dc5;
  for (let i = 0; i < bytes.length; i++) {
    h ^= bytes[i];
    h = Math.imul(h, 0x01000193) >>> 0;
  }
  return h >>> 0;
}

const file = process.argv[2];
const n = Number(process.argv[3] ?? 20);
const handle = await open(file, "w");
let pos = 0n;
const writable = {
  position: () => pos,
  write: async (buf) => {
    await handle.write(buf);
    pos += BigInt(buf.byteLength);
  },
};
const writer = new McapWriter({
  writable,
  chunkSize: 4096,
  compressChunk: (data) => ({ compression: "lz4", compressedData: lz4.compress(data) }),
});
await writer.start({ profile: "ros2", library: "tests/js/mcap_make.mjs" });
const enc = new TextEncoder();
const compressedId = await writer.registerSchema({ name: "sensor_msgs/msg/CompressedImage", encoding: "ros2msg",
                                                   data: enc.encode(compressedSchema) });
const stringId = await writer.registerSchema({ name: "std_msgs/msg/String", encoding: "ros2msg", data: enc.encode(stringSchema) });
const qos = "- history: keep_last\n  depth: 5\n  reliability: best_effort\n  durability: volatile\n";
const chCompressed = await writer.registerChannel({ schemaId: compressedId, topic: "/made/compressed", messageEncoding: "cdr",
                                                    metadata: new Map([["offered_qos_profiles", qos]]) });
const chString = await writer.registerChannel({ schemaId: stringId, topic: "/made/unknown", messageEncoding: "cdr",
                                                metadata: new Map() });
const compressedWriter = new MessageWriter(parse(compressedSchema, { ros2: true }));
const stringWriter = new MessageWriter(parse(stringSchema, { ros2: true }));
const written = [];
const t0 = 1_700_000_000_000_000_000n;
for (let i = 0; i < n; i++) {
  const data = new Uint8Array(300 + i * 11);
  for (let k = 0; k < data.length; k++) data[k] = (k * 5 + i) & 0xff;
  const msg = { header: { stamp: { sec: 1_700_000_000 + i, nanosec: 1000 * i }, frame_id: "made" }, format: "jpeg", data };
  const logTime = t0 + BigInt(i) * 20_000_000n;  // 50 Hz
  await writer.addMessage({ channelId: chCompressed, sequence: i, logTime, publishTime: logTime,
                            data: compressedWriter.writeMessage(msg) });
  await writer.addMessage({ channelId: chString, sequence: i, logTime: logTime + 1n, publishTime: logTime + 1n,
                            data: stringWriter.writeMessage({ data: "hello " + i }) });
  written.push({ stamp_sec: 1_700_000_000 + i, nanosec: 1000 * i, len: data.length, fnv: fnv1a(data) });
}
await writer.end();
await handle.close();
console.log(JSON.stringify({ written }));
