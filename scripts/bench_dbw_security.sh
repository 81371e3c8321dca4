#!/usr/bin/env bash
# The latency cost of DDS Security on /vehicle/dbw/cmd (issue 13): `rig mock paravan` +
# `rig dbw bridge` + `rig dbw send` (100 Hz, enable held) in rounds alternating security off / on
# in one run; per round the bridge's own summary: command stamp -> its CAN frames written
# (latency_us p50/p99/max, the to_wire of rt/rig/stamps) and take -> written. Keys: a fresh
# `rig security init` in a temporary directory (removed at the end).
# Usage: scripts/bench_dbw_security.sh BUILD_DIR [SECONDS_PER_ROUND] [ROUNDS_PER_MODE]
# CMD_PROTECTION=none|sign|encrypt|sign-origin|encrypt-origin: `rig security init --cmd-protection`.
# SECURITY_DIR=DIR: use that `rig security init` directory instead of a fresh one.
set -euo pipefail
build=${1:-build-release}
secs=${2:-5}
rounds=${3:-2}
rig="$build/rig"
[ -x "$rig" ] || { echo "no $rig (build the rig target)" >&2; exit 2; }
out=$(mktemp -d)
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill -KILL "$p" 2>/dev/null || true; done
  rm -rf "$out"
}
trap cleanup EXIT
domain=$((120 + $$ % 50))
sec_dir=${SECURITY_DIR:-$out/sec}
[ -n "${SECURITY_DIR:-}" ] ||
  "$rig" security init "$sec_dir" --cmd-protection "${CMD_PROTECTION:-sign-origin}" \
    $([ "${CMD_PROTECTION:-}" = none ] && echo --no-unauthenticated) >/dev/null 2>&1  # none: only so (issue 28)
echo "load average: $(cut -d' ' -f1-3 /proc/loadavg)"
printf '%-9s %7s %9s %9s %9s %12s %12s\n' mode commands p50_us p99_us max_us take_p50_us take_p99_us
for ((r = 0; r < rounds; ++r)); do
  for mode in off on; do
    sec=()
    [ "$mode" = on ] && sec=(--security "$sec_dir")
    bus="$out/bus_${mode}_$r.sock"
    "$rig" mock paravan --transport "unix-listen:$bus" --duration $((secs + 4)) >"$out/mock.out" 2>&1 &
    pids+=($!)
    for _ in $(seq 100); do [ -S "$bus" ] && break; sleep 0.05; done
    "$rig" dbw bridge --transport "unix:$bus" --domain "$domain" --duration $((secs + 3)) "${sec[@]}" \
      >"$out/bridge.json" 2>"$out/bridge.err" &
    bridge=$!
    pids+=($bridge)
    sleep 1
    "$rig" dbw send --enable --steer 0.05 --throttle 0.2 --rate 100 --duration "$secs" --domain "$domain" \
      "${sec[@]}" >/dev/null 2>&1  # identities: dbw_bridge and dbw_command, the defaults
    wait "$bridge" || { echo "bridge failed:" >&2; cat "$out/bridge.err" >&2; exit 1; }
    wait
    python3 - "$out/bridge.json" "$mode" <<'PY'
import json, sys
s = json.loads(open(sys.argv[1]).read().strip().splitlines()[-1])
l, t = s["latency_us"], s["take_to_send_us"]
print(f'{sys.argv[2]:<9} {s["commands"]:7d} {l["p50"]:9.1f} {l["p99"]:9.1f} {l["max"]:9.1f} {t["p50"]:12.1f} {t["p99"]:12.1f}')
PY
  done
done
echo "load average: $(cut -d' ' -f1-3 /proc/loadavg)"
