#!/usr/bin/env bash
# The fused LIDAR cloud with the three mock LIDARs (config/mock_rig.yaml's lidars and fusion, no
# cameras or drive-by-wire): last input scan on the wire -> fused cloud on the wire (the monitor's
# to_wire of /sensors/lidar/fused/points: its stamps' last_rx is the last input scan's written time),
# p50/p99/max, and the CPU of the `rig up` process (drivers + fusion; the mock sensors are other
# processes), side by side in one run: fusion off; on (the mock rig's SCHED_FIFO 19 thread); on with
# a normal-priority thread; on with a 0.2 m voxel filter; on with one LIDAR stopped (the right one's
# mock not started: every sweep lacks it), where `total` (acquisition -> fused cloud received) shows
# whether sweeps wait for it. BEFORE_RIG=/path/to/rig (an older build) adds "on" and "stopped" runs
# of that binary, interleaved with this build's.
# Usage: [BEFORE_RIG=RIG] scripts/bench_fusion.sh BUILD_DIR [SECONDS]   (DDS domain $RIG_BENCH_DOMAIN, default 42; ports +10000)
set -euo pipefail
build=${1:-build-release}
secs=${2:-20}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
here=$(cd "$(dirname "$0")/.." && pwd)
domain=${RIG_BENCH_DOMAIN:-42}

# rig:, lidars: and fusion: of the mock rig, with fusion's enable and voxel_leaf as given.
make_config() {  # NAME ENABLE LEAF PRIORITY [STOPPED_LIDAR]
  python3 - "$here/config/mock_rig.yaml" "$out/$1.yaml" "$2" "$3" "$here/config" "$4" "$domain" "${5:-}" <<'PY'
import re, sys
src, dst, enable, leaf, confdir, prio, domain, stopped = sys.argv[1:]
keep, section, lidar = [], None, None
for line in open(src):
    m = re.match(r"^([a-z_]+):", line)
    if m:
        section = m.group(1)
    m = re.match(r"^  - name: (\S+)", line)
    if m:
        lidar = m.group(1)
    if section == "lidars" and lidar == stopped:
        line = re.sub(r"^    mock: \{.*\}", "    mock: {kind: none}", line)
    if section in ("rig", "lidars", "fusion"):
        line = re.sub(r"^  enable: \w+", "  enable: " + enable, line)
        line = re.sub(r"^  voxel_leaf: [0-9.]+", "  voxel_leaf: " + leaf, line)
        line = re.sub(r"^  realtime_priority: [0-9]+", "  realtime_priority: " + prio, line)
        line = line.replace("profile: cyclonedds/", "profile: " + confdir + "/cyclonedds/")
        # Clear of another rig on this machine: its own DDS domain and sensor ports.
        line = re.sub(r"^    domain: \d+", "    domain: " + domain, line)
        line = re.sub(r"^(    (?:port|position_port|imu_port): )(\d+)", lambda m: m.group(1) + str(int(m.group(2)) + 10000), line)
        keep.append(line)
open(dst, "w").write("".join(keep))
PY
}

cpu_ticks() { awk '{print $14 + $15}' "/proc/$1/stat"; }

run() {  # NAME [RIG]
  "${2:-$build/rig}" up "$out/${1%_before}.yaml" --duration $((secs + 6)) 2>"$out/$1.log" &
  local pid=$!
  sleep 3
  local t0 c0
  t0=$(date +%s.%N); c0=$(cpu_ticks "$pid")
  "$build/rig" monitor --domain "$domain" --duration "$secs" --json --summary "$out/$1.json" >/dev/null
  local c1 t1
  c1=$(cpu_ticks "$pid"); t1=$(date +%s.%N)
  wait "$pid" || true
  python3 -c "import sys; print(f'{(int(sys.argv[2]) - int(sys.argv[1])) / $(getconf CLK_TCK) / ($t1 - $t0) * 100:.1f}')" "$c0" "$c1" >"$out/$1.cpu"
}

make_config off false 0 19
make_config on true 0 19
make_config normal true 0 0
make_config voxel true 0.2 19
make_config stopped true 0 19 right
runs="off on normal voxel stopped"
[ -n "${BEFORE_RIG:-}" ] && runs="off on_before on normal voxel stopped_before stopped"
echo "load average before: $(cut -d' ' -f1-3 /proc/loadavg)"
for n in $runs; do
  case $n in *_before) run "$n" "$BEFORE_RIG" ;; *) run "$n" ;; esac
done
echo "load average after:  $(cut -d' ' -f1-3 /proc/loadavg)"
python3 - "$out" $runs <<'PY'
import json, sys, os
out = sys.argv[1]
print(f"{'run':14} {'rig up CPU %':>12} | {'fused sweeps':>12} {'lost':>5} {'points/sweep':>14} | {'to_wire p50':>11} {'p99':>7} {'max':>7} ms | {'dds p50':>8} | {'total p50':>9} {'p99':>7} ms")
for n in sys.argv[2:]:
    cpu = open(os.path.join(out, n + ".cpu")).read().strip()
    rows = [r for r in json.load(open(os.path.join(out, n + ".json"))) if r.get("topic") == "/sensors/lidar/fused/points"]
    if not rows:
        print(f"{n:14} {cpu:>12} | no fused cloud")
        continue
    r = rows[0]; l = r["latency_ms"]
    g = lambda s, k: l.get(s, {}).get(k, float('nan'))
    print(f"{n:14} {cpu:>12} | {r['received']:12d} {r['lost']:5d} {r.get('size_bytes', 0) // 24:14d} | {g('to_wire','p50'):11.3f} "
          f"{g('to_wire','p99'):7.3f} {g('to_wire','max'):7.3f}    | {g('dds','p50'):8.3f} | {g('total','p50'):9.3f} {g('total','p99'):7.3f}")
PY
