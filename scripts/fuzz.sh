#!/usr/bin/env bash
# Runs each libFuzzer harness for a bounded time. Usage: scripts/fuzz.sh BUILD_DIR [SECONDS]
# New inputs go to BUILD_DIR/corpus/<name>; the committed seeds in tests/fuzz/corpus/<name> are read only.
set -euo pipefail
build=${1:-build-fuzz}
secs=${2:-30}
shopt -s nullglob
for f in "$build"/fuzz_*; do
  name=$(basename "$f")
  seeds=tests/fuzz/corpus/${name#fuzz_}
  work=$build/corpus/${name#fuzz_}
  mkdir -p "$work" "$seeds"
  echo "== $name (${secs}s, seeds $seeds, new inputs in $work)"
  "$f" -max_total_time="$secs" "$work" "$seeds"
done
