#!/usr/bin/env bash
# Phase error of the LIDAR-triggered camera in the mock rig (issue 12; goal p99 <= 1 ms): runs
# `rig up config/mock_rig.yaml` (three synthetic LIDARs, seven cameras, drive-by-wire) for SECONDS
# and reads, from the camera's summary line when the rig stops, |exposure start - actual crossing
# of the front LIDAR's sweep| p50/p99 (last 1024 triggers) and max, with the trigger counts, and
# the load average around the run. Usage: scripts/bench_lidar_trigger.sh BUILD_DIR [SECONDS] [CAMERA]
set -euo pipefail
build=${1:-build}
secs=${2:-60}
camera=${3:-corner_front_left}
root=$(cd "$(dirname "$0")/.." && pwd)
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
echo "load before: $(cut -d' ' -f1-3 /proc/loadavg)"
"$build/rig" up "$root/config/mock_rig.yaml" --duration "$secs" 2>"$out/up.log" >/dev/null || true
echo "load after:  $(cut -d' ' -f1-3 /proc/loadavg)"
line=$(grep -E "${camera}: frames=" "$out/up.log" | tail -1 || true)
if [[ -z "$line" || "$line" != *phase_error_p99_ms* ]]; then
  echo "no trigger summary for camera $camera in the rig's log:" >&2
  tail -20 "$out/up.log" >&2
  exit 1
fi
echo "camera $camera (${secs} s): ${line#*${camera}: }"
