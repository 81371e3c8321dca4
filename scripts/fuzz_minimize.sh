#!/usr/bin/env bash
# Minimizes each harness's corpus into the committed seeds: the named seeds (the harness's corpus
# generator wrote them) stay; the committed found inputs (40-hex names) and the working
# BUILD_DIR/corpus/<name> (what scripts/fuzz.sh found) are merged after them with libFuzzer
# -merge=1 (an input is kept only for coverage no earlier one has). The result replaces
# tests/fuzz/corpus/<name> only if every kept input replays clean. One line per harness: inputs
# and kB before/after, replay seconds.
# The CI replays the committed corpora under ASan: keep a replay to ~1-2 s (the line says).
# Usage: scripts/fuzz_minimize.sh BUILD_DIR NAME...   (BUILD_DIR: a -DRIG_FUZZ=ON build; NAME: the
# harness fuzz_<NAME>, e.g. position candump). Then review and commit tests/fuzz/corpus/<NAME>.
set -euo pipefail
build=${1:?usage: scripts/fuzz_minimize.sh BUILD_DIR NAME...}
shift
[[ $# -gt 0 ]] || { echo "fuzz_minimize.sh: name the harnesses (e.g. position candump)" >&2; exit 2; }
status=0
files() { find "$1" -type f | wc -l; }
kbytes() { du -sk --apparent-size "$1" | cut -f1; }
mkdir -p "$build/fuzz_logs"
for n in "$@"; do
  f=$build/fuzz_$n
  name=fuzz_$n
  if [[ ! -x $f ]]; then
    echo "$name: no harness $f"
    status=1; continue
  fi
  seeds=tests/fuzz/corpus/$n
  work=$build/corpus/$n
  mkdir -p "$seeds" "$work"
  out=$(mktemp -d "$build/merge_$n.XXXXXX")
  found=$(mktemp -d "$build/found_$n.XXXXXX")
  log=$build/fuzz_logs/$n.merge.log
  for s in "$seeds"/*; do
    [[ -f $s ]] || continue
    if [[ $(basename "$s") =~ ^[0-9a-f]{40}$ ]]; then cp "$s" "$found"/; else cp "$s" "$out"/; fi
  done
  merged=0
  "$f" -merge=1 "$out" "$found" "$work" >"$log" 2>&1 || merged=$?
  rm -rf "$found"
  if [[ $merged != 0 ]]; then
    echo "$name: merge failed (log $log)"
    rm -rf "$out"; status=1; continue
  fi
  # Replay every kept input once (-runs=0 with a directory runs its files and stops).
  start=$(date +%s.%N)
  if ! "$f" -runs=0 "$out" >"$log.replay" 2>&1; then
    echo "$name: the merged corpus does not replay clean (log $log.replay); committed seeds unchanged"
    rm -rf "$out"; status=1; continue
  fi
  replay=$(awk -v s="$start" -v e="$(date +%s.%N)" 'BEGIN { printf "%.1f", e - s }')
  line="$name: $(files "$seeds") committed + $(files "$work") working inputs ($(kbytes "$seeds") + $(kbytes "$work") kB)"
  find "$seeds" -type f -delete
  cp "$out"/* "$seeds"/ 2>/dev/null || true
  rm -rf "$out"
  echo "$line -> $(files "$seeds") inputs, $(kbytes "$seeds") kB, replay ${replay}s"
done
exit $status
