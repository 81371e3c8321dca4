#!/usr/bin/env bash
# `make bench`: every micro-benchmark (build/bench_*) and the end-to-end scan latency benchmark.
# Usage: scripts/bench.sh BUILD_DIR
set -euo pipefail
build=${1:-build-release}
export RIG_TEST_DATA=${RIG_TEST_DATA:-$(cd "$(dirname "$0")/.." && pwd)/../shared/data}
shopt -s nullglob
for b in "$build"/bench_*; do
  [ -x "$b" ] || continue
  # A receiver, not a Google Benchmark: scripts/bench_lidar_sources.sh drives it (sender, ports).
  [ "$(basename "$b")" = bench_lidar_sources ] && continue
  echo "== $(basename "$b")"
  "$b" --benchmark_min_time=0.5
done
echo "== scan latency, three LIDARs (30 s)"
scripts/bench_scan_latency.sh "$build" 30
echo "== dds stage (write called -> monitor receive) per topic, three LIDARs + cameras, udp then shm (30 s each)"
scripts/bench_rig_transport.sh "$build" 30
echo "== seven cameras 1920x1200 beside the LIDARs, in-process fakes then GigE fakes (60 s each; scripts/bench_cameras.sh)"
scripts/bench_cameras.sh "$build" 60 aravis-inprocess
scripts/bench_cameras.sh "$build" 60 gige
