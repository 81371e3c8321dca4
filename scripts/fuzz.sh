#!/usr/bin/env bash
# Runs each libFuzzer harness for a bounded time. Usage: scripts/fuzz.sh BUILD_DIR [SECONDS]
set -euo pipefail
build=${1:-build-fuzz}
secs=${2:-30}
shopt -s nullglob
for f in "$build"/fuzz_*; do
  name=$(basename "$f")
  corpus=tests/fuzz/corpus/${name#fuzz_}
  mkdir -p "$corpus"
  echo "== $name (${secs}s, corpus $corpus)"
  "$f" -max_total_time="$secs" "$corpus"
done
