// A Foxglove WebSocket client written by others (@foxglove/ws-protocol's FoxgloveClient over `ws`),
// decoding with the schemas the server advertises (@foxglove/rosmsg + rosmsg2-serialization): what
// the C++ tests use to check `rig view` from the outside. One JSON line per event on stdout:
//   {"event":"serverInfo",...} {"event":"advertise","channels":[...]} {"event":"unadvertise",...}
//   {"event":"status","level":L,"message":"..."} {"event":"message","topic":..,"summary":{..},..}
//   {"event":"summary","topics":{TOPIC:{count,latency_ms:{...}}},"statuses":[...],...} (last line)
// Byte arrays are summarised as {"len":N,"fnv1a":H} (32-bit FNV-1a, as the tests compute it).
//
// Options:
//   --url ws://127.0.0.1:8765      server
//   --subscribe T1,T2 | --subscribe-all   what to subscribe (each once advertised)
//   --wait-topics T1,T2            exit 3 unless these are advertised within --timeout
//   --count N                      stop once every subscribed topic has N messages
//   --duration S                   stop after S seconds (from the first subscription)
//   --timeout S                    give up (exit 3) after S seconds (default 60)
//   --stall-after N                stop reading the socket after N messages (a client that hangs)
//   --bad-input                    send malformed and unsupported requests first, expect a status
//                                  error for each (listed in the summary)
//   --print-messages               one "message" line per message (else only the summary)
//   --stamps                       also subscribe /rig/stamps: latency from the DDS source timestamp
import { performance } from "node:perf_hooks";
import * as rosmsg from "@foxglove/rosmsg";
import * as ser from "@foxglove/rosmsg2-serialization";
import * as wsp from "@foxglove/ws-protocol";
import WebSocket from "ws";

const FoxgloveClient = wsp.FoxgloveClient ?? wsp.default?.FoxgloveClient;

function parseArgs(argv) {
  const o = { url: "ws://127.0.0.1:8765", subscribe: [], all: false, wait: [], count: 0, duration: 0,
              timeout: 60, stallAfter: 0, badInput: false, print: false, stamps: false };
  for (let i = 2; i < argv.length; i++) {
    const a = argv[i];
    const next = () => argv[++i];
    if (a === "--url") o.url = next();
    else if (a === "--subscribe") o.subscribe = next().split(",").filter(Boolean);
    else if (a === "--subscribe-all") o.all = true;
    else if (a === "--wait-topics") o.wait = next().split(",").filter(Boolean);
    else if (a === "--count") o.count = Number(next());
    else if (a === "--duration") o.duration = Number(next());
    else if (a === "--timeout") o.timeout = Number(next());
    else if (a === "--stall-after") o.stallAfter = Number(next());
    else if (a === "--bad-input") o.badInput = true;
    else if (a === "--print-messages") o.print = true;
    else if (a === "--stamps") o.stamps = true;
    else { console.error(`view_client: unknown option ${a}`); process.exit(2); }
  }
  return o;
}

const opts = parseArgs(process.argv);
const out = (obj) => process.stdout.write(JSON.stringify(obj, (k, v) => (typeof v === "bigint" ? v.toString() : v)) + "\n");
// Wall clock (CLOCK_REALTIME) with sub-millisecond resolution, as the server's timestamps.
const nowNs = () => (performance.timeOrigin + performance.now()) * 1e6;

function fnv1a(bytes) {
  let h = 0x811c9dc5;
  for (let i = 0; i < bytes.length; i++) h = Math.imul(h ^ bytes[i], 0x01000193);
  return h >>> 0;
}

// The decoded message with byte arrays reduced to length and checksum, big arrays cut.
function summarise(v) {
  if (ArrayBuffer.isView(v)) return { len: v.length, fnv1a: fnv1a(new Uint8Array(v.buffer, v.byteOffset, v.byteLength)) };
  if (Array.isArray(v)) return v.slice(0, 64).map(summarise);
  if (v !== null && typeof v === "object") {
    const r = {};
    for (const [k, x] of Object.entries(v)) r[k] = summarise(x);
    return r;
  }
  return v;
}
// Exact (BigInt): ns since 1970 exceed a double's 53 bits; printed as a decimal string.
const stampNs = (m) => (m?.header?.stamp ? BigInt(m.header.stamp.sec) * 1000000000n + BigInt(m.header.stamp.nanosec) : undefined);

function percentiles(xs) {
  if (xs.length === 0) return null;
  const s = [...xs].sort((a, b) => a - b);
  const at = (p) => s[Math.min(s.length - 1, Math.floor(p * s.length))];
  return { n: s.length, p50: at(0.5), p99: at(0.99), max: s[s.length - 1] };
}

const channels = new Map();   // channel id -> {topic, reader, ...}
const subs = new Map();       // subscription id -> channel id
const subscribedTopics = new Set();
const perTopic = new Map();   // topic -> {count, lat_stamp:[], lat_server:[], lat_source:[], bytes}
const statuses = [];
const stampsByKey = new Map(); // topic|stamp -> publish_ns (from /rig/stamps)
const pendingSource = new Map(); // topic|stamp -> client receive ns (sample came before its stamps)
let firstSubscribeAt = 0;
let stalled = false;
let received = 0;
let exitCode = 0;

const ws = new WebSocket(opts.url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
const client = new FoxgloveClient({ ws });

function topicState(t) {
  if (!perTopic.has(t)) perTopic.set(t, { count: 0, bytes: 0, lat_stamp: [], lat_server: [], lat_source: [] });
  return perTopic.get(t);
}

function wanted(topic) {
  if (opts.all) return true;
  if (opts.stamps && topic === "/rig/stamps") return true;
  return opts.subscribe.includes(topic);
}

client.on("serverInfo", (info) => out({ event: "serverInfo", ...info }));
client.on("status", (s) => { statuses.push({ level: s.level, message: s.message }); out({ event: "status", level: s.level, message: s.message }); });
let opened = false;
client.on("error", (e) => {
  out({ event: "error", message: String(e?.message ?? e) });
  if (!opened) exitCode = 5;  // never connected
});
client.on("advertise", (list) => {
  out({ event: "advertise", channels: list.map((c) => ({ id: c.id, topic: c.topic, encoding: c.encoding,
        schemaName: c.schemaName, schemaEncoding: c.schemaEncoding, schemaBytes: c.schema.length })) });
  for (const c of list) {
    let reader = null;
    let decodeError = null;
    try {
      if (c.encoding !== "cdr" || c.schemaEncoding !== "ros2msg") throw new Error(`encoding ${c.encoding}/${c.schemaEncoding}`);
      reader = new ser.MessageReader(rosmsg.parse(c.schema, { ros2: true }));
    } catch (e) {
      decodeError = String(e?.message ?? e);
      out({ event: "schema_error", topic: c.topic, message: decodeError });
    }
    channels.set(c.id, { ...c, reader, decodeError });
    if (wanted(c.topic) && !subscribedTopics.has(c.topic)) {
      subscribedTopics.add(c.topic);
      subs.set(client.subscribe(c.id), c.id);
      if (firstSubscribeAt === 0) firstSubscribeAt = Date.now();
      topicState(c.topic);
    }
  }
});
// `time` messages (capability `time`): how many, and the last against this host's clock.
let timeCount = 0;
let lastTime = null;
let timeBackwards = 0;
client.on("time", ({ timestamp }) => {
  if (lastTime !== null && timestamp < lastTime) timeBackwards++;
  lastTime = timestamp;
  timeCount++;
});
client.on("unadvertise", (ids) => {
  out({ event: "unadvertise", channelIds: ids, topics: ids.map((i) => channels.get(i)?.topic) });
  for (const i of ids) {
    const c = channels.get(i);
    if (c) subscribedTopics.delete(c.topic);
    channels.delete(i);
  }
});

function onSourceStamp(m) {
  const key = `${m.topic}|${stampNs(m)}`;
  const publish = Number(m.publish_ns);
  const seen = pendingSource.get(key);
  if (seen !== undefined) {
    pendingSource.delete(key);
    if (perTopic.has(m.topic) && publish > 0) perTopic.get(m.topic).lat_source.push((seen - publish) / 1e6);
  } else {
    stampsByKey.set(key, publish);
    if (stampsByKey.size > 10000) stampsByKey.delete(stampsByKey.keys().next().value);
  }
}

client.on("message", ({ subscriptionId, timestamp, data }) => {
  const at = nowNs();
  const c = channels.get(subs.get(subscriptionId));
  if (!c) { out({ event: "error", message: `message for unknown subscription ${subscriptionId}` }); return; }
  const bytes = new Uint8Array(data.buffer, data.byteOffset, data.byteLength);
  let msg;
  try {
    msg = c.reader.readMessage(bytes);
  } catch (e) {
    out({ event: "decode_error", topic: c.topic, message: String(e?.message ?? e), bytes: bytes.length });
    exitCode = 4;
    return;
  }
  if (c.topic === "/rig/stamps" && opts.stamps) { onSourceStamp(msg); if (!opts.subscribe.includes(c.topic) && !opts.all) return; }
  const st = topicState(c.topic);
  st.count++;
  st.bytes += bytes.length;
  received++;
  const stamp = stampNs(msg);
  if (stamp !== undefined) st.lat_stamp.push((at - Number(stamp)) / 1e6);
  st.lat_server.push((at - Number(timestamp)) / 1e6);
  if (opts.stamps && stamp !== undefined) {
    const key = `${c.topic}|${stamp}`;
    const publish = stampsByKey.get(key);
    if (publish !== undefined) { stampsByKey.delete(key); if (publish > 0) st.lat_source.push((at - publish) / 1e6); }
    else pendingSource.set(key, at);
  }
  if (opts.print)
    out({ event: "message", topic: c.topic, receive_ns: timestamp, client_ns: Math.round(at), bytes: bytes.length,
          stamp_ns: stamp, summary: summarise(msg) });
  if (opts.stallAfter > 0 && received >= opts.stallAfter && !stalled) {
    stalled = true;
    ws._socket.pause();  // stop reading: the kernel buffers fill, the server's writes stall
    out({ event: "stalled", after: received });
  }
  maybeDone();
});

function sendBadInput() {
  // Each gets one status error, and the connection stays open.
  const bad = [
    "this is not json",
    "[1,2,3]",
    JSON.stringify({ noop: 1 }),
    JSON.stringify({ op: "frobnicate" }),
    JSON.stringify({ op: "subscribe", subscriptions: [{ id: 900001, channelId: 4000000 }] }),
    JSON.stringify({ op: "subscribe", subscriptions: "all" }),
    JSON.stringify({ op: "unsubscribe", subscriptionIds: [777777] }),
    JSON.stringify({ op: "getParameters", parameterNames: [] }),
  ];
  for (const b of bad) ws.send(b);
  ws.send(Buffer.from([0x01, 0, 0, 0, 0, 1, 2, 3]));  // client message data without clientPublish
  out({ event: "bad_input_sent", count: bad.length + 1 });
}

let finished = false;
function done() {
  if (finished) return;
  finished = true;
  const topics = {};
  for (const [t, s] of perTopic)
    topics[t] = { count: s.count, bytes: s.bytes, latency_ms: { stamp: percentiles(s.lat_stamp),
                  server: percentiles(s.lat_server), source: percentiles(s.lat_source) } };
  const time = { count: timeCount, backwards: timeBackwards,
                 last_minus_now_ms: lastTime === null ? null : (Number(lastTime) - nowNs()) / 1e6 };
  out({ event: "summary", topics, statuses, advertised: [...channels.values()].map((c) => c.topic), stalled, time });
  client.close();
  setTimeout(() => process.exit(exitCode), 50);
}

function maybeDone() {
  if (opts.count > 0 && !stalled) {
    const need = opts.all ? [...subscribedTopics] : opts.subscribe;
    if (need.length > 0 && need.every((t) => (perTopic.get(t)?.count ?? 0) >= opts.count)) done();
  }
}

ws.on("open", () => {
  opened = true;
  out({ event: "open" });
  if (opts.badInput) sendBadInput();
});
ws.on("close", (code) => { out({ event: "close", code }); if (!stalled) done(); });

const t0 = Date.now();
const timer = setInterval(() => {
  if (opts.wait.length > 0) {
    const have = new Set([...channels.values()].map((c) => c.topic));
    if (!opts.wait.every((t) => have.has(t)) && Date.now() - t0 > opts.timeout * 1000) {
      out({ event: "timeout", waiting_for: opts.wait.filter((t) => !have.has(t)) });
      exitCode = 3;
      done();
    }
  }
  if (opts.duration > 0 && firstSubscribeAt > 0 && Date.now() - firstSubscribeAt >= opts.duration * 1000) done();
  else if (opts.duration > 0 && opts.badInput && Date.now() - t0 >= opts.duration * 1000) done();
  else if (Date.now() - t0 > opts.timeout * 1000) { out({ event: "timeout" }); exitCode = 3; done(); }
}, 50);
