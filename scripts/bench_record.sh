#!/usr/bin/env bash
# `rig record` on the whole mock rig (config/mock_rig.yaml on a domain of its own) for each chunk
# compression, then `rig play` of one recording at several rates (BENCHMARKS.md, "Recording").
# Usage: scripts/bench_record.sh [SECONDS] [OUT_DIR]   (run under flock /tmp/rig-rt.lock: it starts
# the mock rig, whose ports and addresses are fixed). Prints one line per run. CAMERAS=1920x1200 sets
# every camera to that size (the issue's full-size rig); PLAY=0 skips the `rig play` runs; REC_RT=N
# runs the recorder at SCHED_FIFO N (--rt-priority); COMPRESSIONS="lz4" records with those only
# (default: none lz4 zstd); RIG=PATH runs that `rig` (its tools beside it) instead of build/rig.
set -euo pipefail
secs=${1:-30}
out=${2:-$(mktemp -d /tmp/rig-bench-record-XXXXXX)}
src=$(cd "$(dirname "$0")/.." && pwd)
rig=${RIG:-$src/build/rig}
read -r -a compressions <<< "${COMPRESSIONS:-none lz4 zstd}"
domain=57
cfg=$out/mock_rig.yaml
# The mock rig on domain $domain; its relative paths made absolute for the copy.
sed -e "s|domain: 0|domain: $domain|" -e "s|profile: cyclonedds/|profile: $src/config/cyclonedds/|" \
    -e "s|protocol: dbw/|protocol: $src/config/dbw/|" "$src/config/mock_rig.yaml" > "$cfg"
if [ -n "${CAMERAS:-}" ]; then
  sed -i -e "s|^    width: [0-9]*|    width: ${CAMERAS%x*}|" -e "s|^    height: [0-9]*|    height: ${CAMERAS#*x}|" "$cfg"
fi
profile=$src/config/cyclonedds/loopback.xml
"$rig" up "$cfg" --duration $((secs * ${#compressions[@]} + 40)) > "$out/rig.log" 2>&1 &
rig_pid=$!
trap 'kill $rig_pid 2>/dev/null; wait $rig_pid 2>/dev/null || true' EXIT
sleep 8  # the rig's processes up, cameras streaming
for c in "${compressions[@]}"; do
  /usr/bin/time -f "%e %U %S" -o "$out/time_$c" "$rig" record --out "$out/rec_$c.mcap" --domain $domain \
    --dds-profile "$profile" --compression $c --duration "$secs" --no-progress --rt-priority "${REC_RT:-0}" > "$out/summary_$c.json" 2> "$out/err_$c"
  read -r wall user sys < "$out/time_$c"
  python3 - "$out/summary_$c.json" "$c" "$wall" "$user" "$sys" <<'PY'
import json, sys
s = json.loads(open(sys.argv[1]).read().strip().splitlines()[-1])
c, wall, user, sysc = sys.argv[2], float(sys.argv[3]), float(sys.argv[4]), float(sys.argv[5])
mb_in = s["bytes_received"] / s["seconds"] / 1e6
mb_out = s["file_bytes"] / s["seconds"] / 1e6
cpu = (user + sysc) / wall * 100
d = s["drops"]
print(f"record {c:4}: {s['seconds']:.1f} s, {len(s['topics'])} topics, {s['received']} msgs, {mb_in:.1f} MB/s in, "
      f"{mb_out:.1f} MB/s to disk (ratio {mb_in / mb_out if mb_out else 0:.2f}), recorder CPU {cpu:.0f} % of a core "
      f"({cpu / mb_in * 100 if mb_in else 0:.0f} % per 100 MB/s), writer compress {s['writer_ms']['compress']:.0f} ms "
      f"write {s['writer_ms']['write']:.0f} ms, drops {d}")
PY
done
# The rig stopped: `rig play` alone on the host, into a domain without subscribers (the DDS writes
# still serialize every sample); lateness = when the timed thread woke minus the message's due time.
kill $rig_pid 2>/dev/null || true; wait $rig_pid 2>/dev/null || true
[ "${PLAY:-1}" = 0 ] && exit 0
sleep 3
bench_play() {  # rate rt-priority
  "$rig" play "$out/rec_lz4.mcap" --domain $((domain + 1)) --dds-profile "$profile" --delay 0.5 --rate "$1" \
    --rt-priority "$2" > "$out/play_$1_$2.json" 2> "$out/play_err_$1_$2" || true
  python3 -c "import json,sys; s=json.loads(open(sys.argv[1]).read().strip().splitlines()[-1]); l=s['late_ms']; print(f'play rate {sys.argv[2]} rt {sys.argv[3]}: {s[\"played\"]} msgs, late p50 {l[\"p50\"]:.3f} ms, p99 {l[\"p99\"]:.3f} ms, max {l[\"max\"]:.2f} ms')" "$out/play_$1_$2.json" "$1" "$2"
}
bench_play 1 0
for rate in 1 2 5 10; do bench_play $rate 30; done
echo "files in $out"
