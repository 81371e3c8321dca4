#!/bin/bash
# The fault campaign benchmark (issue 25, BENCHMARKS.md "Fault campaigns"): the whole mock rig under
# `rig chaos` for DURATION seconds at RATE faults a minute (plus one of every kind), then the cost of
# the truth records: `rig up` of the mock rig for 30 s with every mock writing its truth (RIG_CHAOS_DIR,
# an empty plan) and without, alternated PAIRS times, CPU (user+sys, the mocks included) and bytes.
#   scripts/bench_chaos.sh BUILD [DURATION=600] [RATE=30] [SEED=1] [PAIRS=2] [OUT=/tmp/rig-bench-chaos]
set -euo pipefail
BUILD=${1:?usage: bench_chaos.sh BUILD [DURATION] [RATE] [SEED] [PAIRS] [OUT]}
DURATION=${2:-600}
RATE=${3:-30}
SEED=${4:-1}
PAIRS=${5:-2}
OUT=${6:-/tmp/rig-bench-chaos}
cd "$(dirname "$0")/.."
RIG="$BUILD/rig"
rm -rf "$OUT"
mkdir -p "$OUT"
echo "== campaign: $DURATION s, $RATE faults/min, seed $SEED (load: $(cut -d' ' -f1-3 /proc/loadavg))"
start=$(date +%s)
set +e
"$RIG" chaos config/mock_rig.yaml --duration "$DURATION" --seed "$SEED" --rate "$RATE" --json --out "$OUT/campaign" \
  > "$OUT/verdict.json" 2> "$OUT/verdict.txt"
rc=$?
set -e
echo "rig chaos: exit $rc in $(( $(date +%s) - start )) s; truth $(du -sh "$OUT/campaign/truth" | cut -f1)"
grep -v '^chaos: [0-9w]' "$OUT/verdict.txt" | tail -60
echo "== truth records' cost: rig up config/mock_rig.yaml 30 s, truth off/on, $PAIRS pairs"
for i in $(seq "$PAIRS"); do
  for mode in off on; do
    d=$(mktemp -d /tmp/rig-truthcost-XXXXXX)
    mkdir -p "$d/truth"
    echo '{"fault_plan":1,"epoch_mono_ns":0}' > "$d/plan.jsonl"
    env_var=RIG_BENCH_TRUTH=off
    [ "$mode" = on ] && env_var="RIG_CHAOS_DIR=$d"
    /usr/bin/time -f "%U %S %M" -o "$d/time" env "$env_var" "$RIG" up config/mock_rig.yaml --duration 30 > /dev/null 2>&1
    read -r user sys rss < "$d/time"
    printf '%s  cpu %.2f s (user %s, sys %s)  truth %s bytes  load %s\n' "$mode" "$(awk -v u="$user" -v s="$sys" 'BEGIN{print u+s}')" "$user" "$sys" \
      "$(du -sb "$d/truth" | cut -f1)" "$(cut -d' ' -f1 /proc/loadavg)"
    rm -rf "$d"
  done
done
