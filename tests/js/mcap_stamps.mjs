// The stamps of every message of an MCAP file, as @mcap/core's indexed reader has them, decoded by
// @foxglove/rosmsg2-serialization with the schemas in the file: for counting messages against
// another account (rig monitor's), where mcap_dump.mjs's checksum of every payload is not needed.
//   node mcap_stamps.mjs FILE
// Prints one JSON object: {"channels": {TOPIC: {schema, count}}, "messages": [{"topic", "log_time",
// "publish_time", "stamp_ns" (header stamp, when the message has a header), and for
// sensor_rig_msgs/msg/SourceStamps "stamps_topic", "publish_ns"}], "undecodable"}; times are decimal
// strings (ns). Exit 1 and {"error"} when the reader refuses the file.
import { indexedReader, openFile, ros2Decoders } from "./mcap_open.mjs";

const stampNs = (h) => (h && h.stamp ? String(BigInt(h.stamp.sec) * 1000000000n + BigInt(h.stamp.nanosec)) : undefined);

async function main() {
  const { handle, size } = await openFile(process.argv[2]);
  const reader = await indexedReader(handle, size);
  const decoders = ros2Decoders(reader);
  const channels = {};
  for (const [, ch] of reader.channelsById)
    channels[ch.topic] = { schema: reader.schemasById.get(ch.schemaId)?.name, count: 0 };
  const messages = [];
  let undecodable = 0;
  for await (const msg of reader.readMessages()) {
    const d = decoders.get(msg.channelId);
    const topic = reader.channelsById.get(msg.channelId).topic;
    channels[topic].count++;
    const m = { topic, log_time: String(msg.logTime), publish_time: String(msg.publishTime) };
    if (!d) {
      undecodable++;
    } else {
      const decoded = d.reader.readMessage(msg.data);
      m.stamp_ns = stampNs(decoded.header);
      if (d.schema === "sensor_rig_msgs/msg/SourceStamps") {
        m.stamps_topic = decoded.topic;
        m.publish_ns = String(decoded.publish_ns);
      }
    }
    messages.push(m);
  }
  await handle.close();
  console.log(JSON.stringify({ channels, messages, undecodable }));
}

main().catch((e) => {
  console.log(JSON.stringify({ error: String(e && e.message ? e.message : e) }));
  process.exit(1);
});
