// Reads an MCAP file with readers written by others (@mcap/core's indexed and streaming readers,
// @foxglove/rosmsg + @foxglove/rosmsg2-serialization to decode every message with the schemas in
// the file) and prints one JSON object: per channel its schema, encoding, QoS metadata and count,
// and per message what a test compares with what the publishers sent (stamps, sizes, FNV-1a of
// payloads). Usage: node mcap_dump.mjs FILE   (exit 1 and {"error": ...} when a reader refuses it)
import { McapStreamReader } from "@mcap/core";
import { decompressHandlers, indexedReader, openFile, ros2Decoders } from "./mcap_open.mjs";

function fnv1a(bytes) {
  let h = 0x811c9dc5;
  for (let i = 0; i < bytes.length; i++) {
    h ^= bytes[i];
    h = Math.imul(h, 0x01000193) >>> 0;
  }
  return h >>> 0;
}

const stampNs = (h) => (h && h.stamp ? BigInt(h.stamp.sec) * 1000000000n + BigInt(h.stamp.nanosec) : null);

function summarize(schemaName, m) {
  const s = { stamp_ns: m.header ? String(stampNs(m.header)) : undefined, frame_id: m.header?.frame_id };
  switch (schemaName) {
    case "sensor_msgs/msg/PointCloud2":
      return { ...s, width: m.width, height: m.height, point_step: m.point_step, fields: m.fields.map((f) => f.name),
               data_len: m.data.length, data_fnv: fnv1a(m.data) };
    case "sensor_msgs/msg/Image":
      return { ...s, width: m.width, height: m.height, encoding: m.encoding, step: m.step, data_len: m.data.length,
               data_fnv: fnv1a(m.data) };
    case "sensor_msgs/msg/CompressedImage":
      return { ...s, format: m.format, data_len: m.data.length, data_fnv: fnv1a(m.data) };
    case "sensor_msgs/msg/CameraInfo":
      return { ...s, width: m.width, height: m.height, distortion_model: m.distortion_model, k: Array.from(m.k) };
    case "diagnostic_msgs/msg/DiagnosticArray":
      return { ...s, status: m.status.map((x) => ({ name: x.name, level: x.level, values: x.values.length })) };
    case "sensor_rig_msgs/msg/LidarPackets": {
      // The raw channel: each datagram's addresses and size, and one FNV-1a over the batch's payloads.
      let h = 0x811c9dc5;
      for (const p of m.packets)
        for (let i = 0; i < p.data.length; i++) h = Math.imul(h ^ p.data[i], 0x01000193) >>> 0;
      return { ...s, model: m.model, data_port: m.data_port, data_fnv: h >>> 0,
               packets: m.packets.map((p) => ({ stamp_ns: String(BigInt(p.stamp.sec) * 1000000000n + BigInt(p.stamp.nanosec)),
                                               src_address: p.src_address, src_port: p.src_port, dst_port: p.dst_port,
                                               size: p.data.length })) };
    }
    case "sensor_rig_msgs/msg/CanFrame":
      return { ...s, id: m.id, is_extended: m.is_extended, is_rtr: m.is_rtr, is_error: m.is_error, is_fd: m.is_fd,
               data: Array.from(m.data) };
    case "sensor_rig_msgs/msg/VehicleState":
      return { ...s, speed: m.speed, wheels: [m.wheel_speed_fl, m.wheel_speed_fr, m.wheel_speed_rl, m.wheel_speed_rr],
               steering_angle: m.steering_angle, yaw_rate: m.yaw_rate, gear: m.gear };
    case "sensor_rig_msgs/msg/SourceStamps":
      return { ...s, stamps_topic: m.topic, seq: String(m.seq), publish_ns: String(m.publish_ns) };
    default:
      return s;
  }
}

async function main() {
  const file = process.argv[2];
  const { handle, size } = await openFile(file);
  const reader = await indexedReader(handle, size);
  const decoders = ros2Decoders(reader);
  const channels = {};
  for (const [, ch] of reader.channelsById) {
    const schema = reader.schemasById.get(ch.schemaId);
    channels[ch.topic] = { schema: schema?.name, schema_encoding: schema?.encoding, message_encoding: ch.messageEncoding,
                           metadata: Object.fromEntries(ch.metadata), count: 0 };
  }
  const messages = [];
  let undecodable = 0;
  for await (const msg of reader.readMessages()) {
    const d = decoders.get(msg.channelId);
    const topic = reader.channelsById.get(msg.channelId).topic;
    channels[topic].count++;
    if (!d) {
      undecodable++;
      continue;
    }
    const decoded = d.reader.readMessage(msg.data);
    messages.push({ topic, log_time: String(msg.logTime), publish_time: String(msg.publishTime), sequence: msg.sequence,
                    ...summarize(d.schema, decoded) });
  }
  // The streaming reader over the whole file, chunk CRCs checked.
  const stream = new McapStreamReader({ decompressHandlers, validateCrcs: true });
  const all = new Uint8Array(size);
  await handle.read(all, 0, size, 0);
  stream.append(all);
  let streamed = 0;
  let streamEnd = false;
  for (let rec; (rec = stream.nextRecord()); ) {
    if (rec.type === "Message") streamed++;
    if (rec.type === "Footer") streamEnd = true;
  }
  await handle.close();
  const stats = reader.statistics;
  console.log(JSON.stringify({
    profile: reader.header.profile,
    library: reader.header.library,
    chunks: reader.chunkIndexes.length,
    statistics: stats ? { message_count: String(stats.messageCount), channel_count: stats.channelCount,
                          chunk_count: stats.chunkCount } : null,
    channels, messages, undecodable, streamed, stream_complete: streamEnd && stream.done(),
  }));
}

main().catch((e) => {
  console.log(JSON.stringify({ error: String(e && e.message ? e.message : e) }));
  process.exit(1);
});
