#!/usr/bin/env bash
# Issue 28: what write protection of rt/vehicle/*, rt/sensors/*, rt/rig/* costs on the running
# mock rig. The mock rig's LIDARs, fusion and drive-by-wire processes (no cameras: their fakes
# bind fixed loopback addresses another rig on this host may hold; LIDAR ports moved likewise),
# back to back per mode:
#   plain   no DDS Security (what the mock rig ships)
#   cmd     dbw.security only: the command topic signed (sign-origin), every other node ordinary
#   access  + every node authenticated as rig_node (RIG_DDS_SECURITY), `--protect-writes access`
#   sign    + `--protect-writes sign` (every rig topic's submessages signed)
# Per mode: the whole rig's CPU (rig up and every process it started, the monitor apart) as % of
# one core, and per topic the `dds` stage p50/p99/max from a monitor (authenticated in access and
# sign, as a consumer of signed topics must be).
# Usage: scripts/bench_rig_security.sh BUILD_DIR [SECONDS] [MODES...]
set -euo pipefail
build=${1:-build}
secs=${2:-20}
shift $(( $# > 2 ? 2 : $# ))
modes=("${@:-plain}")
[ $# -eq 0 ] && modes=(plain cmd access sign)
root=$(cd "$(dirname "$0")/.." && pwd)
rig="$(cd "$build" && pwd)/rig"
out=$(mktemp -d)
domain=$((180 + $$ % 20))
rig_pid=""
conf="$root/config/.bench_security_$$.yaml"
cleanup() {
  if [ -n "$rig_pid" ] && kill -0 "$rig_pid" 2>/dev/null; then kill -INT "$rig_pid"; sleep 3; kill -KILL "$rig_pid" 2>/dev/null || true; fi
  rm -f "$conf"
  [ -n "${KEEP_OUT:-}" ] && echo "kept $out" >&2 || rm -rf "$out"
}
trap cleanup EXIT
for m in "${modes[@]}"; do
  sec="$out/sec_$m"
  env_sec=()
  case $m in
    plain) ;;
    cmd) "$rig" security init "$sec" >/dev/null 2>&1 ;;
    access|sign) "$rig" security init "$sec" --protect-writes "$m" >/dev/null 2>&1; env_sec=("RIG_DDS_SECURITY=$sec:rig_node") ;;
    *) echo "unknown mode $m" >&2; exit 2 ;;
  esac
  python3 - "$root/config/mock_rig.yaml" "$conf" "$domain" "$out/bus_$m.sock" "$([ "$m" = plain ] || echo "$sec")" \
    "$((10000 + $$ % 400 * 10))" <<'PY'
import sys, yaml
src, dst, domain, bus, sec, port_offset = sys.argv[1:7]
c = yaml.safe_load(open(src))
c["rig"]["dds"]["domain"] = int(domain)
for k in ("cameras", "sync_sets"):
    c.pop(k, None)
for lidar in c["lidars"]:  # clear of another rig's LIDAR ports on this host
    for key in ("port", "position_port", "imu_port"):
        if key in lidar:
            lidar[key] += int(port_offset)
c["dbw"]["bus"] = bus
if sec:
    c["dbw"]["security"] = {"dir": sec}
yaml.safe_dump(c, open(dst, "w"), sort_keys=False)
PY
  env "${env_sec[@]}" "$rig" up "$conf" --duration $((secs + 14)) 2>"$out/up_$m.log" &
  rig_pid=$!
  sleep 8
  env "${env_sec[@]}" "$rig" monitor --domain "$domain" --rt-priority 15 --duration "$secs" --json \
    --summary "$out/summary_$m.json" >"$out/monitor_$m.jsonl" 2>"$out/monitor_$m.log" &
  mon_pid=$!
  python3 - "$rig_pid" "$mon_pid" "$secs" "$out/cpu_$m.json" <<'PY'
import json, os, sys, time
rig, mon, secs, dst = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3]), sys.argv[4]
hz = os.sysconf("SC_CLK_TCK")
def stat(path):
    s = open(path).read()
    f = s[s.rindex(")") + 2 :].split()
    return s[s.index("(") + 1 : s.rindex(")")], int(f[1]), int(f[11]) + int(f[12])
def tree(root):
    kids = {}
    for p in os.listdir("/proc"):
        if p.isdigit():
            try:
                kids.setdefault(stat(f"/proc/{p}/stat")[1], []).append(int(p))
            except OSError:
                pass
    out, todo = [], [root]
    while todo:
        p = todo.pop(); out.append(p); todo += kids.get(p, [])
    return out
def sample():
    procs = {}
    for p in tree(rig) + [mon]:
        try:
            comm, _, t = stat(f"/proc/{p}/stat"); procs[p] = (comm, t)
        except OSError:
            pass
    return time.monotonic(), procs
time.sleep(1.0)
t0, p0 = sample()
time.sleep(max(1.0, secs - 4.0))
t1, p1 = sample()
dt = t1 - t0
procs = [{"pid": p, "comm": c, "cpu_pct": 100.0 * (t - p0[p][1]) / hz / dt, "monitor": p == mon}
         for p, (c, t) in p1.items() if p in p0]
json.dump({"seconds": dt, "procs": procs}, open(dst, "w"))
PY
  wait "$mon_pid" || echo "monitor ($m) exited with $?: $(tail -3 "$out/monitor_$m.log")" >&2
  wait "$rig_pid" || { echo "rig up ($m) exited with $?:" >&2; grep -iE "error|refused|denied" "$out/up_$m.log" | head -5 >&2; }
  grep -q "driver start failed" "$out/up_$m.log" && { grep "driver start failed" "$out/up_$m.log" >&2; exit 1; }
  rig_pid=""
done
python3 - "$out" "$secs" "${modes[@]}" <<'PY'
import json, sys
out, secs, ms = sys.argv[1], float(sys.argv[2]), sys.argv[3:]
rows = {m: {r["topic"]: r for r in json.load(open(f"{out}/summary_{m}.json")) if "topic" in r} for m in ms}
cpu = {m: json.load(open(f"{out}/cpu_{m}.json")) for m in ms}
print(f"mock rig without cameras, {secs:.0f} s per mode; dds stage = source timestamp -> monitor receive (ms)")
print(f"{'topic':34}" + "".join(f" | {m + ' p50':>10} {'p99':>6} {'max':>6} {'recv':>5}" for m in ms))
for topic in sorted(set().union(*[set(r) for r in rows.values()])):
    line = f"{topic:34}"
    for m in ms:
        r = rows[m].get(topic)
        d = r["latency_ms"].get("dds", {}) if r else {}
        line += (f" | {d.get('p50', float('nan')):10.3f} {d.get('p99', float('nan')):6.2f} {d.get('max', float('nan')):6.2f} {r['received']:5d}"
                 if r else f" | {'-':>10} {'-':>6} {'-':>6} {'-':>5}")
    print(line)
for m in ms:
    procs = cpu[m]["procs"]
    whole = sum(p["cpu_pct"] for p in procs if not p["monitor"])
    by = {}
    for p in procs:
        if not p["monitor"]:
            by[p["comm"]] = by.get(p["comm"], 0.0) + p["cpu_pct"]
    mon = sum(p["cpu_pct"] for p in procs if p["monitor"])
    print(f"{m}: whole rig {whole:.1f} % of one core (" + ", ".join(f"{k} {v:.1f}" for k, v in sorted(by.items(), key=lambda kv: -kv[1]) if v >= 0.3)
          + f"); monitor {mon:.1f} %")
PY
