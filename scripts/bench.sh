#!/usr/bin/env bash
# Runs every benchmark in an optimized build dir. Usage: scripts/bench.sh BUILD_DIR
set -euo pipefail
build=${1:-build-release}
shopt -s nullglob
for b in "$build"/bench_*; do
  [ -x "$b" ] || continue
  echo "== $(basename "$b")"
  "$b"
done
