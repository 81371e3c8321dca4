#!/usr/bin/env bash
# Scan latency with three LIDARs at once: the mock rig (three synthetic sensors at real packet
# timing -> three drivers) and the monitor in separate processes. Reports per LIDAR: process (kernel
# receive of the scan's last packet -> DDS write called), write (-> write returned: on the wire),
# to_wire (the two together, per scan: the goal's "last packet -> PointCloud2 on the wire"), dds.
# Usage: scripts/bench_scan_latency.sh BUILD_DIR [SECONDS]
set -euo pipefail
build=${1:-build-release}
secs=${2:-30}
out=$(mktemp -d)
"$build/rig" up config/mock_rig.yaml --duration $((secs + 6)) 2>"$out/up.log" &
rig_pid=$!
sleep 2
"$build/rig" monitor --duration "$secs" --json --summary "$out/summary.json" >/dev/null
wait "$rig_pid" || true
python3 - "$out/summary.json" <<'PY'
import json, sys
rows = json.load(open(sys.argv[1]))
print(f"{'topic':30} {'scans':>6} {'lost':>5} | {'process p50':>11} {'p99':>7} | {'write p50':>9} {'p99':>7} | "
      f"{'to_wire p50':>11} {'p99':>7} {'max':>7} | {'dds p50':>8} {'p99':>7}")
for r in rows:
    l = r.get("latency_ms", {})
    if "to_wire" not in l:
        continue  # topics without per-sample source stamps (drive-by-wire): not a scan path
    g = lambda s, k: l.get(s, {}).get(k, float('nan'))
    print(f"{r['topic']:30} {r['received']:6d} {r['lost']:5d} | {g('process','p50'):11.3f} {g('process','p99'):7.3f} | "
          f"{g('write','p50'):9.3f} {g('write','p99'):7.3f} | {g('to_wire','p50'):11.3f} {g('to_wire','p99'):7.3f} "
          f"{g('to_wire','max'):7.3f} | {g('dds','p50'):8.3f} {g('dds','p99'):7.3f}")
PY
rm -rf "$out"
