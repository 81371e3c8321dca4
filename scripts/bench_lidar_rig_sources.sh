#!/usr/bin/env bash
# The running LIDAR nodes with each data source: `rig up` with three synthetic LIDARs at full rate
# (VLP-32C dual, Ouster OS 1024x20, Pandar40P; mocks on loopback) and `source: udp`, then
# `source: packet` (interface lo). Per source: the CPU of the rig up process (the three driver
# threads receiving, decoding and publishing, and DDS; the mock senders are its children and not
# counted) over the middle SECONDS, the load average, and each driver's stop summary (scans,
# packets, drops). No subscriber. Needs root for the packet ring (CAP_NET_RAW).
# Usage: scripts/bench_lidar_rig_sources.sh BUILD_DIR [SECONDS]   (default 50)
set -euo pipefail
build=${1:-build-release}
secs=${2:-50}
[ -x "$build/rig" ] || { echo "$build/rig missing" >&2; exit 2; }
out=$(mktemp -d)
pid=""
cleanup() {
  if [ -n "$pid" ] && kill -0 "$pid" 2>/dev/null; then kill -INT "$pid"; sleep 3; kill -KILL "$pid" 2>/dev/null || true; fi
  rm -rf "$out"
}
trap cleanup EXIT
domain=$((180 + $$ % 50))
base=$((24000 + ($$ % 100) * 10))
hz=$(getconf CLK_TCK)
for src in udp packet; do
  extra=""
  [ "$src" = packet ] && extra=$'\n    source: packet\n    interface: lo\n    sensor_address: 127.0.0.1'
  cat >"$out/rig_$src.yaml" <<EOF
rig:
  name: lidar_sources_$src
  dds:
    domain: $domain
lidars:
  - name: vlp32c
    model: VLP-32C
    port: $((base + 1))
    returns: dual$extra
    mock: {kind: synthetic}
  - name: os1
    model: OS
    port: $((base + 2))$extra
    mock: {kind: synthetic, rpm: 1200}
  - name: pandar
    model: Pandar40P
    port: $((base + 3))$extra
    mock: {kind: synthetic}
EOF
  "$build/rig" up "$out/rig_$src.yaml" --duration $((secs + 15)) >"$out/up_$src.log" 2>&1 &
  pid=$!
  sleep 8  # drivers up, mocks streaming
  read -r u0 s0 < <(awk '{print $14, $15}' "/proc/$pid/stat")
  t0=$(date +%s.%N)
  l0=$(cut -d' ' -f1-3 /proc/loadavg)
  sleep "$secs"
  read -r u1 s1 < <(awk '{print $14, $15}' "/proc/$pid/stat")
  t1=$(date +%s.%N)
  l1=$(cut -d' ' -f1-3 /proc/loadavg)
  python3 -c "print('$src: rig up %.1f %% of one core over %.0f s (load %s -> %s)' % \
    (100.0 * (($u1 + $s1) - ($u0 + $s0)) / $hz / ($t1 - $t0), $t1 - $t0, '$l0', '$l1'))"
  wait "$pid" || true
  pid=""
  grep -E "lidar: (vlp32c|os1|pandar): scans" "$out/up_$src.log" | sed 's/^\[[^]]*\] info  lidar: /  /'
done
