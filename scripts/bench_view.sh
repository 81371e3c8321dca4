#!/usr/bin/env bash
# `rig view` on the whole mock rig (config/mock_rig.yaml): its CPU with 0, 1, 2 and 4 connected
# Foxglove clients, and the latency sample -> client. The clients are tests/js/view_client.mjs
# (@foxglove/ws-protocol on Node.js, decoding every message with the advertised schema), each
# subscribed to what a typical Foxglove layout shows (LIDAR clouds, the fused cloud, a camera,
# /diagnostics) plus /rig/stamps, whose publish_ns (the DDS source timestamp the driver wrote) gives
# the latency: client receive time - publish_ns ("source"), and client receive time - rig view's
# receive timestamp in the message ("server": take, queue, WebSocket, Node.js decode).
# CPU: rig view's own (user + system, /proc/PID/stat) over each phase, as % of one core.
# Usage: [TOPICS=T1,T2] scripts/bench_view.sh BUILD_DIR [SECONDS_PER_PHASE] [CLIENT_COUNTS...]
set -euo pipefail
build=${1:-build}
secs=${2:-20}
shift $(( $# > 2 ? 2 : $# ))
counts=("${@:-0}")
[ $# -eq 0 ] && counts=(0 1 2 4)
root=$(cd "$(dirname "$0")/.." && pwd)
out=$(mktemp -d)
domain=$((150 + $$ % 50))
port=$((20000 + $$ % 20000))
# TOPICS: what each client subscribes (comma-separated); default the three LIDARs, the fused cloud,
# a camera and /diagnostics (~85 MB/s per client).
topics=${TOPICS:-/sensors/lidar/front/points,/sensors/lidar/left/points,/sensors/lidar/right/points,/sensors/lidar/fused/points,/sensors/camera/front_narrow/image_raw,/diagnostics}
conf="$root/config/.bench_view_$$.yaml"
rig_pid=""
view_pid=""
cleanup() {
  for p in $view_pid $rig_pid; do
    if kill -0 "$p" 2>/dev/null; then kill -INT "$p"; sleep 3; kill -KILL "$p" 2>/dev/null || true; fi
  done
  rm -f "$conf"
  rm -rf "$out"
}
trap cleanup EXIT
sed -e "s/^    domain: 0$/    domain: $domain/" "$root/config/mock_rig.yaml" >"$conf"
grep -q "domain: $domain" "$conf" || { echo "could not set the domain in $conf" >&2; exit 1; }
total=$(( 30 + ${#counts[@]} * (secs + 10) ))
"$build/rig" up "$conf" --duration "$total" 2>"$out/up.log" &
rig_pid=$!
sleep 12
"$build/rig" view --domain "$domain" --port "$port" --stats-interval 0 >"$out/view.jsonl" 2>"$out/view.log" &
view_pid=$!
sleep 5
ticks() { awk '{print $14 + $15}' "/proc/$view_pid/stat"; }
hz=$(getconf CLK_TCK)
printf '%-8s %-10s %-12s %-34s %-30s\n' clients "CPU %" "per client" "source latency ms p50/p99 (n)" "server hop ms p50/p99"
for n in "${counts[@]}"; do
  pids=()
  for i in $(seq 1 "$n"); do
    node "$root/tests/js/view_client.mjs" --url "ws://127.0.0.1:$port" --wait-topics "$topics" --subscribe "$topics" \
      --stamps --duration "$secs" --timeout $((secs + 60)) >"$out/client_${n}_$i.jsonl" 2>&1 &
    pids+=($!)
  done
  sleep 3  # connected and subscribed
  t0=$(ticks)
  sleep "$secs"
  t1=$(ticks)
  for p in "${pids[@]}"; do wait "$p" || true; done
  cpu=$(python3 -c "print(f'{100.0 * ($t1 - $t0) / $hz / $secs:.1f}')")
  echo "$n $cpu" >>"$out/cpu.txt"
  python3 - "$out" "$n" "$cpu" <<'PY'
import glob, json, sys
out, n, cpu = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
base = None
for line in open(f"{out}/cpu.txt"):
    k, c = line.split()
    if int(k) == 0:
        base = float(c)
src, hop = [], []
counts = {}
for f in glob.glob(f"{out}/client_{n}_*.jsonl"):
    summary = [json.loads(l) for l in open(f) if l.startswith('{"event":"summary"')]
    if not summary:
        print(f"  {f}: no summary", file=sys.stderr)
        continue
    for topic, t in summary[-1]["topics"].items():
        counts[topic] = counts.get(topic, 0) + t["count"]
        lat = t["latency_ms"]
        if lat["source"]: src.append((lat["source"]["p50"], lat["source"]["p99"], lat["source"]["n"], topic))
        if lat["server"]: hop.append((lat["server"]["p50"], lat["server"]["p99"]))
per = f"{(cpu - base) / n:.1f}" if base is not None and n > 0 else "-"
def agg(xs):
    if not xs: return "-"
    return f"{max(x[0] for x in xs):.2f}/{max(x[1] for x in xs):.2f} ({sum(x[2] for x in xs) if len(xs[0]) > 2 else ''})"
print(f"{n:<8} {cpu:<10} {per:<12} {agg(src):<34} {agg([(a, b, 0) for a, b in hop]):<30}")
for s in sorted(src, key=lambda x: x[3]):
    print(f"           {s[3]}: source p50 {s[0]:.2f} p99 {s[1]:.2f} ms (n={s[2]})")
if counts:
    print("           messages per topic over the clients:", json.dumps(counts))
PY
done
kill -INT "$view_pid"
wait "$view_pid" || true
view_pid=""
tail -1 "$out/view.jsonl" | python3 -c 'import json,sys; j=json.loads(sys.stdin.read()); print("rig view at the end: published", j["published"], "dropped", j["dropped"], "dds_lost", j["dds"]["dds_lost"], "readers_opened", j["dds"]["readers_opened"])'
