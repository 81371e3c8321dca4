#!/usr/bin/env bash
# Runs each libFuzzer harness, one at a time, bounded by time and/or by the number of inputs.
# Usage: scripts/fuzz.sh BUILD_DIR [SECONDS] [RUNS] [HARNESS_REGEX]
#   SECONDS: -max_total_time (0 = no time bound); RUNS: -runs (0 = no run bound); at least one bound.
# New inputs go to BUILD_DIR/corpus/<name>, crash/leak/timeout inputs to BUILD_DIR/artifacts/<name>/;
# the committed seeds in tests/fuzz/corpus/<name> are read only. After each harness one line:
# inputs run, wall time, exec/s, coverage (cov/ft), new corpus entries, crash artifacts, peak RSS;
# the log of each run is BUILD_DIR/fuzz_logs/<name>.log. Exit 1 when any harness found something.
# Runs add up: each appends its inputs to BUILD_DIR/fuzz_logs/<name>.history, and the line gives the
# total over the runs that kept BUILD_DIR/corpus/<name> (a slow harness reaches 10 M over several
# sittings). A run stopped with SIGINT to the fuzzer (libFuzzer exit 72) counts what it ran.
set -euo pipefail
build=${1:-build-fuzz}
secs=${2:-30}
runs=${3:-0}
only=${4:-.}
if [[ $secs == 0 && $runs == 0 ]]; then
  echo "fuzz.sh: SECONDS and RUNS are both 0: a run would never end" >&2
  exit 2
fi
shopt -s nullglob
mkdir -p "$build/fuzz_logs"
failed=0
summary=()
for f in "$build"/fuzz_*; do
  [[ -x $f && -f $f ]] || continue
  name=$(basename "$f")
  [[ $name =~ $only ]] || continue
  seeds=tests/fuzz/corpus/${name#fuzz_}
  work=$build/corpus/${name#fuzz_}
  artifacts=$build/artifacts/${name#fuzz_}/
  log=$build/fuzz_logs/${name#fuzz_}.log
  mkdir -p "$work" "$seeds" "$artifacts"
  before=$(find "$work" -type f | wc -l)
  # Slow units (libFuzzer's slow-unit-*, over 10 s) are counted apart: a fuzzer that was stopped
  # (SIGSTOP while something is measured) or starved writes them too; replay one alone to tell.
  found_before=$(find "$artifacts" -type f ! -name 'slow-unit-*' | wc -l)
  slow_before=$(find "$artifacts" -type f -name 'slow-unit-*' | wc -l)
  bounds=()
  [[ $secs != 0 ]] && bounds+=(-max_total_time="$secs")
  [[ $runs != 0 ]] && bounds+=(-runs="$runs")
  echo "== $name (${bounds[*]}, seeds $seeds, new inputs in $work, log $log)"
  start=$(date +%s)
  rc=0
  # CPU seconds beside wall time: on a shared host a niced fuzzer's exec/s says more about the load.
  timer=()
  [[ -x /usr/bin/time ]] && timer=(/usr/bin/time -o "$log.cpu" -f '%U %S')
  rm -f "$log.cpu"
  "${timer[@]}" "$f" "${bounds[@]}" -print_final_stats=1 -artifact_prefix="$artifacts" "$work" "$seeds" >"$log" 2>&1 || rc=$?
  wall=$(($(date +%s) - start))
  stat() { sed -n "s/^stat::$1: *//p" "$log" | tail -1; }
  # The last status line (#N DONE/pulse/NEW ... cov: C ft: F ...) has the final coverage.
  cov=$(grep -Eo 'cov: [0-9]+ ft: [0-9]+' "$log" | tail -1 | tr -d ':' || true)
  crashes=$(($(find "$artifacts" -type f ! -name 'slow-unit-*' | wc -l) - found_before))
  slow=$(($(find "$artifacts" -type f -name 'slow-unit-*' | wc -l) - slow_before))
  added=$(($(find "$work" -type f | wc -l) - before))
  cpu=$(awk 'END { printf "%.0f", $1 + $2 }' "$log.cpu" 2>/dev/null || echo '?')
  line="$name: runs $(stat number_of_executed_units) in ${wall}s (CPU ${cpu}s), $(stat average_exec_per_sec) exec/s,"
  line+=" ${cov:-cov ?}, new corpus entries $added, crashes/leaks/timeouts $crashes, slow units $slow,"
  line+=" peak RSS $(stat peak_rss_mb) MB, exit $rc"
  [[ $rc == 72 ]] && line+=" (interrupted)"
  history=$build/fuzz_logs/${name#fuzz_}.history
  echo "$(date -u +%FT%TZ) runs=$(stat number_of_executed_units) wall=${wall}s exit=$rc crashes=$crashes" >>"$history"
  total=$(sed -n 's/.* runs=\([0-9]*\) .*/\1/p' "$history" | awk '{ s += $1 } END { print s + 0 }')
  line+="; $total inputs over $(wc -l <"$history") run(s) with this corpus"
  echo "$line"
  summary+=("$line")
  if [[ ($rc != 0 && $rc != 72) || $crashes != 0 ]]; then
    failed=1
    grep -E '^(==[0-9]+==ERROR|SUMMARY|artifact_prefix|Test unit written)' "$log" || tail -20 "$log"
  fi
done
echo "== summary"
printf '%s\n' "${summary[@]}"
exit $failed
