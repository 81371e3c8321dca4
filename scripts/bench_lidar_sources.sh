#!/usr/bin/env bash
# Three synthetic LIDARs at full rate into the LIDAR sources, UDP socket then AF_PACKET ring, back to
# back in one run. Network: a receiver namespace with a bridge (the PU's sensor NIC behind a switch,
# 10.213.1.1) and one namespace per sensor (10.213.1.2-4) on its own veth port, MTU 1500, so the
# Ouster's datagrams arrive as IPv4 fragments as from a real sensor. Senders: `rig lidar replay
# --synthetic` (normal priority: a shared host) for SECONDS; receiver: bench_lidar_sources (one
# receive thread per sensor, no decoding) from 1 s before the first packet to 2 s after the last,
# so received + lost = sent. Per source and sensor: rates, lost datagrams, the source's own drop
# counters (UDP: SO_RXQ_OVFL; ring: PACKET_STATISTICS drops/freezes, reassembly drops), the receive
# thread's CPU (% of one core over the window, µs per datagram), the delivery delay (handed over -
# kernel stamp, p50/p99/max); per source the host's system and
# softirq share (of all cores) and the load average.
# Needs root (namespaces, AF_PACKET).
# Usage: scripts/bench_lidar_sources.sh BUILD_DIR [SECONDS_PER_SOURCE] [SOURCES...]
#   BUILD_DIR holds rig and bench_lidar_sources (configure with -DRIG_BENCH=ON); default 60 s, udp packet.
#   RETIRE_MS=N: the ring's block retire timeout (default 4 ms; the ring's delivery delay vs CPU).
set -euo pipefail
build=${1:-build-release}
secs=${2:-60}
shift $(( $# > 2 ? 2 : $# ))
sources=("$@")
[ ${#sources[@]} -eq 0 ] && sources=(udp packet)
for exe in rig bench_lidar_sources; do
  [ -x "$build/$exe" ] || { echo "$build/$exe missing (cmake -DRIG_BENCH=ON, build rig and bench_lidar_sources)" >&2; exit 2; }
done
tag=$$
rx=rigbRx_$tag
out=$(mktemp -d)
# name model port extra-args: a Velodyne VLP-32C (dual returns), an Ouster OS-1-128 at 1024x20
# (~25 kB datagrams: 17 fragments each), a Hesai Pandar40P.
# LIDARS=heavy: two OS-1-128 at 1024x20 and the Pandar40P instead (~70 MB/s: the issue's
# "2 x OS-128-class + 1 x Pandar40P-class" example; the first Ouster sends to port 2368).
sensors=("vlp32c VLP-32C 2368 --return dual" "os128 OS 7502 --beams 128 --lidar-mode 1024x20" "pandar40p Pandar40P 2370")
[ "${LIDARS:-}" = heavy ] && sensors=("os128a OS 2368 --beams 128 --lidar-mode 1024x20" "os128b OS 7502 --beams 128 --lidar-mode 1024x20" "pandar40p Pandar40P 2370")
cleanup() {
  for p in $(jobs -p); do kill "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
  ip netns del "$rx" 2>/dev/null || true
  for i in 1 2 3; do ip netns del "rigbTx${i}_$tag" 2>/dev/null || true; done
  rm -rf "$out"
}
trap cleanup EXIT
ip netns add "$rx"
ip -n "$rx" link add br0 type bridge
ip -n "$rx" addr add 10.213.1.1/24 dev br0
ip -n "$rx" link set br0 up
ip -n "$rx" link set lo up
for i in 1 2 3; do
  tx=rigbTx${i}_$tag
  ip netns add "$tx"
  ip link add "vbp$i$tag" netns "$rx" type veth peer name "vbs$i$tag" netns "$tx"
  ip -n "$rx" link set "vbp$i$tag" master br0 mtu 1500 up
  ip -n "$tx" addr add "10.213.1.$((i + 1))/24" dev "vbs$i$tag"
  ip -n "$tx" link set "vbs$i$tag" mtu 1500 up
  ip -n "$tx" link set lo up
done
ip -n "$rx" link set br0 mtu 1500

for src in "${sources[@]}"; do
  ip netns exec "$rx" "$build/bench_lidar_sources" --source="$src" --interface=br0 ${RETIRE_MS:+--retire-ms=$RETIRE_MS} --ports=2368,7502,2370 \
    --sensors=10.213.1.2,10.213.1.3,10.213.1.4 --seconds=$((secs + 3)) >"$out/recv_$src.json" &
  bench=$!
  sleep 1
  pids=()
  i=0
  for s in "${sensors[@]}"; do
    i=$((i + 1))
    read -r name model port extra <<<"$s"
    # shellcheck disable=SC2086
    ip netns exec "rigbTx${i}_$tag" "$build/rig" lidar replay --synthetic "$model" $extra --to "10.213.1.1:$port" \
      --rt-priority 0 --duration "$secs" --json >"$out/sent_${src}_$name.json" 2>"$out/sent_${src}_$name.log" &
    pids+=($!)
  done
  for p in "${pids[@]}"; do wait "$p" || true; done
  wait "$bench"
  port_names=$(for s in "${sensors[@]}"; do read -r n _ p _ <<<"$s"; printf '%s:%s ' "$p" "$n"; done)
  python3 - "$src" "$out" $port_names <<'PY'
import json, sys
src, out = sys.argv[1], sys.argv[2]
rows = [json.loads(l) for l in open(f"{out}/recv_{src}.json") if l.strip()]
names = {int(a.split(":")[0]): a.split(":")[1] for a in sys.argv[3:]}
for r in rows:
    if r.get("summary"):
        print(f"{src:6} all       process_cpu {r['process_cpu_pct']:5.2f} % of a core  host system {r['host_system_pct']:5.2f} %"
              f"  softirq {r['host_softirq_pct']:5.2f} % (of all cores)  loadavg {r['loadavg']}")
        continue
    name = names.get(r["port"], str(r["port"]))
    try:
        sent = json.loads(open(f"{out}/sent_{src}_{name}.json").read().strip().splitlines()[-1])
    except (OSError, ValueError, IndexError):
        sent = {}
    n = sent.get("sent_data", 0)
    rate = n / sent["elapsed_s"] if sent.get("elapsed_s") else 0.0
    r["sent"] = n
    r["sender_late"] = sent.get("late")
    print(f"{src:6} {name:9} sent {n:7} ({rate:6.0f}/s, late {sent.get('late', '?')})  received {r['packets']:7}"
          f"  lost {n - r['packets']:5}  drops {r['drops']}  freezes {r['freeze_q']}  reasm_drops {r['reassembly_dropped']}"
          f"  reassembled {r['reassembled']}  {r['mbytes_per_s']:6.2f} MB/s  cpu {r['cpu_pct']:5.2f} %"
          f"  {r['cpu_us_per_packet']:5.2f} us/pkt  delay p50/p99/max {r['delay_us_p50']:.0f}/{r['delay_us_p99']:.0f}/{r['delay_us_max']:.0f} us")
print(json.dumps({"source": src, "rows": rows}))
PY
done
