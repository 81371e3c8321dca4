#!/usr/bin/env bash
# Ouster decode per packet, ours against ouster-sdk's own batching + XYZ, on the same packets, in
# one run (issue 11). Ours: bench_lidar_ouster (its ns_per_packet: header checks, scan
# completeness, XYZ + intensity + ring + time per point). Peer: bench/peers/ouster (FrameBatcher
# into a LidarFrame, XYZLut of each completed frame: what an ouster-sdk user does), built here
# against an ouster-sdk checkout (1.0.1 tested; only the ouster_core sources it needs). Both
# single-threaded on core $RIG_BENCH_CPU (default 1), alternating, ROUNDS rounds; thread CPU time.
# Streams: the shared OS-1-32-G capture (LEGACY, 64 packets; $RIG_TEST_DATA) and synthetic
# OS-2-128 RNG19_RFL8_SIG16_NIR16 packets (the shared OS-2-128 metadata). First checks that both
# give the same points: count and every point within 1 mm.
# Usage: scripts/bench_ouster_peer.sh BUILD_DIR OUSTER_SDK_DIR [ROUNDS] [SECONDS] [BEFORE_BENCH]
#   BUILD_DIR: a configured Release build of this project (bench_lidar_ouster is built in it);
#   BEFORE_BENCH: optionally another bench_lidar_ouster binary (e.g. of an older commit) to add.
#   The peer is built in $OUSTER_PEER_BUILD (default BUILD_DIR/ouster-peer; ~20 min the first time).
set -euo pipefail
build=${1:?usage: $0 BUILD_DIR OUSTER_SDK_DIR [ROUNDS] [SECONDS] [BEFORE_BENCH]}
sdk=${2:?usage: $0 BUILD_DIR OUSTER_SDK_DIR [ROUNDS] [SECONDS] [BEFORE_BENCH]}
rounds=${3:-5}
secs=${4:-2}
before=${5:-}
cpu=${RIG_BENCH_CPU:-1}
here=$(cd "$(dirname "$0")/.." && pwd)
export RIG_TEST_DATA=${RIG_TEST_DATA:-$here/../shared/data}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

cmake --build "$build" --target bench_lidar_ouster -j2 >/dev/null
peer_build=${OUSTER_PEER_BUILD:-$build/ouster-peer}
cmake -S "$here/bench/peers/ouster" -B "$peer_build" -DOUSTER_SDK_DIR="$(cd "$sdk" && pwd)" \
  -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$peer_build" -j2 >/dev/null
ours="$build/bench_lidar_ouster"
peer="$peer_build/ouster_peer_bench"

# The packets, metadata and our first scan of each stream.
RIG_BENCH_OUSTER_EXPORT="$out" "$ours" --benchmark_list_tests=true >/dev/null
streams=(OS-1-32-G_LEGACY_capture OS-2-128_RNG19_RFL8_SIG16_NIR16_synthetic)
filters=('decode/OS-1-32-G/LEGACY/capture/' 'decode/OS-2-128/RNG19_RFL8_SIG16_NIR16/synthetic/')
for s in "${streams[@]}"; do
  if [[ ! -f "$out/$s.packets" ]]; then
    echo "$s: not exported (data under $RIG_TEST_DATA/lidar/ouster missing?)" >&2
    exit 1
  fi
  echo "== $s: same points?"
  "$peer" "$out/$s.packets" "$out/$s.json" --seconds 0 --compare "$out/$s.ours.xyz" | grep '^compare'
done

echo "== load before: $(cut -d' ' -f1-3 /proc/loadavg)"
for ((r = 1; r <= rounds; r++)); do
  for i in "${!streams[@]}"; do
    s=${streams[$i]}
    for bin in "$ours" ${before:+"$before"}; do
      tag=ours; [[ "$bin" == "$before" ]] && tag=before
      taskset -c "$cpu" "$bin" --benchmark_filter="${filters[$i]}" --benchmark_min_time="$secs" \
        --benchmark_format=json 2>/dev/null |
        python3 -c 'import json,sys
for b in json.load(sys.stdin)["benchmarks"]:
    print(sys.argv[1], sys.argv[2], sys.argv[2] + ":" + b["name"].rsplit("/", 1)[1], "%.3f" % (b["ns_per_packet"] / 1000))' \
          "$s" "$tag" >>"$out/results"
    done
    for variant in "" --float; do
      line=$(taskset -c "$cpu" "$peer" "$out/$s.packets" "$out/$s.json" --seconds "$secs" $variant)
      name=$(awk '{print $2}' <<<"$line")
      us=$(grep -o 'us_per_packet=[0-9.]*' <<<"$line" | head -1 | cut -d= -f2)
      echo "$s peer peer:$name $us" >>"$out/results"
    done
  done
done
echo "== load after: $(cut -d' ' -f1-3 /proc/loadavg)"

# Per stream and contender: median over the rounds (and min..max), and the peer's time over ours.
python3 - "$out/results" "$rounds" <<'PY'
import statistics, sys
rows = {}
for line in open(sys.argv[1]):
    stream, _, name, us = line.split()
    rows.setdefault(stream, {}).setdefault(name, []).append(float(us))
for stream, named in rows.items():
    print(f"\n{stream} (us/packet, thread CPU, median of {sys.argv[2]} rounds [min..max])")
    peer = statistics.median(named.get("peer:XYZLut(double)", [float("nan")]))
    for name, v in named.items():
        m = statistics.median(v)
        print(f"  {name:42s} {m:8.3f}  [{min(v):.3f}..{max(v):.3f}]  peer(double)/this = {peer / m:5.2f}x")
PY
