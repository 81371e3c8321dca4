#!/usr/bin/env bash
# Times one stage of `make test` (CI has 90 minutes on 2 cores: where do they go?).
#
#   stage.sh TIMES NAME -- COMMAND...   runs COMMAND, prints its wall time, appends a row to TIMES
#                                       (with the pass/fail counts when COMMAND ran ctest)
#   stage.sh TIMES --summary            the table of every stage, and one closing line with the
#                                       tests of every stage: "make test: P passed, F failed"
# The exit status is COMMAND's.
set -uo pipefail
times=${1:?usage: stage.sh TIMES NAME -- COMMAND... | stage.sh TIMES --summary}
shift

if [[ "${1:-}" == "--summary" ]]; then
  [[ -f "$times" ]] || { echo "stage.sh: no stage times in $times" >&2; exit 1; }
  echo
  echo "make test, stage by stage (wall time on $(nproc) cores):"
  awk -F'\t' '{ printf "  %-28s %6d s  %s\n", $1, $2, ($4 == "" ? "" : $4 " passed, " $5 " failed"); t += $2; p += $4; f += $5 }
              END { printf "  %-28s %6d s (%.1f min)\n", "total", t, t / 60; printf "make test: %d passed, %d failed\n", p, f }' "$times"
  exit 0
fi

name=${1:?stage name}
shift
[[ "${1:-}" == "--" ]] && shift
log=$(mktemp)
trap 'rm -f "$log"' EXIT
start=$(date +%s)
"$@" 2>&1 | tee "$log"
rc=${PIPESTATUS[0]}
seconds=$(( $(date +%s) - start ))
# ctest: "100% tests passed, 0 tests failed out of 95"
counts=$(sed -n 's/.*tests passed, \([0-9]*\) tests\{0,1\} failed out of \([0-9]*\).*/\2 \1/p' "$log" | tail -1)
passed="" failed=""
if [[ -n "$counts" ]]; then
  read -r total failed <<<"$counts"
  passed=$(( total - failed ))
fi
printf '%s\t%d\t%d\t%s\t%s\n' "$name" "$seconds" "$rc" "$passed" "$failed" >>"$times"
echo "== stage '$name': ${seconds} s, exit ${rc} =="
exit "$rc"
