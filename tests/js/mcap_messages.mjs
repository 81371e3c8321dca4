// Every message of an MCAP file as @mcap/core reads it, for comparing two files message by message:
//   node mcap_messages.mjs FILE indexed   McapIndexedReader (summary, chunk indexes, message indexes)
//   node mcap_messages.mjs FILE stream    McapStreamReader over the bytes, chunk CRCs checked; on a
//                                         damaged file it yields what precedes the damage, then stops
// Prints one JSON object: {"reader", "messages": [{"topic","sequence","log_time","publish_time",
// "size","fnv"}] (fnv: FNV-1a of the message's bytes), "count", "per_topic", "statistics" (indexed),
// "stopped" (stream: why it stopped, "" at a complete end)}. Exit 1 and {"error"} when a reader refuses.
import { McapStreamReader } from "@mcap/core";
import { decompressHandlers, indexedReader, openFile } from "./mcap_open.mjs";

function fnv1a(bytes) {
  let h = 0x811c9dc5;
  for (let i = 0; i < bytes.length; i++) h = Math.imul(h ^ bytes[i], 0x01000193) >>> 0;
  return h >>> 0;
}

async function main() {
  const [file, mode] = process.argv.slice(2);
  const { handle, size } = await openFile(file);
  const messages = [];
  const perTopic = {};
  const add = (topic, m) => {
    perTopic[topic] = (perTopic[topic] ?? 0) + 1;
    messages.push({ topic, sequence: m.sequence, log_time: String(m.logTime), publish_time: String(m.publishTime),
                    size: m.data.length, fnv: fnv1a(m.data) });
  };
  const out = { reader: mode };
  if (mode === "indexed") {
    const reader = await indexedReader(handle, size);
    for await (const m of reader.readMessages()) add(reader.channelsById.get(m.channelId).topic, m);
    const s = reader.statistics;
    out.statistics = s ? { message_count: String(s.messageCount), chunk_count: s.chunkCount,
                           channel_count: s.channelCount, message_start: String(s.messageStartTime),
                           message_end: String(s.messageEndTime) } : null;
    out.chunk_indexes = reader.chunkIndexes.length;
  } else {
    const all = new Uint8Array(size);
    await handle.read(all, 0, size, 0);
    const stream = new McapStreamReader({ decompressHandlers, validateCrcs: true });
    stream.append(all);
    const channels = new Map();
    out.stopped = "";
    try {
      for (let rec; (rec = stream.nextRecord()); ) {
        if (rec.type === "Channel") channels.set(rec.id, rec.topic);
        if (rec.type === "Message") add(channels.get(rec.channelId), rec);
      }
      if (!stream.done()) out.stopped = "the data ends before the file's end (cut)";
    } catch (e) {
      out.stopped = String(e && e.message ? e.message : e);
    }
  }
  await handle.close();
  out.count = messages.length;
  out.per_topic = perTopic;
  out.messages = messages;
  console.log(JSON.stringify(out));
}

main().catch((e) => {
  console.log(JSON.stringify({ error: String(e && e.message ? e.message : e) }));
  process.exit(1);
});
