#!/usr/bin/env bash
# Raw LIDAR channels (issue 29): the cost to the LIDAR driver thread of /sensors/lidar/NAME/packets.
# One synthetic VLP-32C through its driver (`rig up`); for ROUNDS rounds, interleaved, SECONDS each:
# nobody records / `rig record` of the points only (the raw writer exists, no reader: the path every
# rig runs) / `rig record --raw`. Per run: the driver thread's CPU (from /proc, % of a core) and the
# recorder's summary of the raw channel. Usage: scripts/bench_raw_channels.sh [SECONDS] [ROUNDS]
# (under flock /tmp/rig-rt.lock: a real-rate mock).
set -euo pipefail
secs=${1:-20}
rounds=${2:-3}
src=$(cd "$(dirname "$0")/.." && pwd)
rig=$src/build/rig
out=$(mktemp -d /tmp/rig-bench-raw-XXXXXX)
domain=58
profile=$src/config/cyclonedds/loopback.xml
cat > "$out/rig.yaml" <<YAML
rig:
  name: bench-raw
  dds: {domain: $domain, profile: $profile}
lidars:
  - name: rawbench
    model: VLP-32C
    port: 23681
    position_port: 23682
    time_source: sensor
    mock: {kind: synthetic, rpm: 600}
YAML
"$rig" up "$out/rig.yaml" --duration $((secs * rounds * 3 + 60)) > "$out/rig.log" 2>&1 &
rig_pid=$!
trap 'kill $rig_pid 2>/dev/null; wait $rig_pid 2>/dev/null || true; rm -rf "$out"' EXIT
sleep 5
# The driver thread: threads carry no names of their own (Cyclone's do), so the busiest thread named
# like the process ("rig") over 3 s; with one LIDAR and no subscriber that is the LIDAR's.
busiest() {
  for t in /proc/$rig_pid/task/*; do
    [ "$(cat "$t/comm")" = rig ] && echo "${t##*/} $(awk '{print $14 + $15}' "$t/stat")"
  done
}
busiest > "$out/a"; sleep 3; busiest > "$out/b"
tid=$(join "$out/a" "$out/b" | awk '{ d = $3 - $2; if (d > best) { best = d; t = $1 } } END { print t }')
[ -n "$tid" ] || { echo "no busy rig thread in rig up ($rig_pid)"; cat "$out/rig.log"; exit 1; }
ticks() { awk '{print $14 + $15}' "/proc/$rig_pid/task/$tid/stat"; }
hz=$(getconf CLK_TCK)
for r in $(seq "$rounds"); do
  for mode in off points raw; do
    t0=$(ticks)
    case $mode in
      off) sleep "$secs" ;;
      points) "$rig" record /sensors/lidar/rawbench/points --out "$out/p.mcap" --domain $domain --dds-profile "$profile" \
                --duration "$secs" --no-progress > "$out/s.json" 2>/dev/null ;;
      raw) "$rig" record /sensors/lidar/rawbench/points --raw --out "$out/r.mcap" --domain $domain --dds-profile "$profile" \
             --duration "$secs" --no-progress > "$out/s.json" 2>/dev/null ;;
    esac
    t1=$(ticks)
    extra=""
    if [ "$mode" = raw ]; then extra=$(python3 -c "import json,sys; s=json.loads(open('$out/s.json').read().strip().splitlines()[-1]); t=s['topics'].get('/sensors/lidar/rawbench/packets',{}); print(f\"raw messages {t.get('written',0)}, queue_full {t.get('queue_full',0)}, dds_lost {t.get('dds_lost',0)}\")"); fi
    rm -f "$out"/*.mcap
    awk -v a="$t0" -v b="$t1" -v hz="$hz" -v s="$secs" -v m="$mode" -v r="$r" -v e="$extra" \
      'BEGIN { printf "round %d %-6s driver thread %.2f %% of a core %s\n", r, m, (b - a) / hz / s * 100, e }'
  done
done
