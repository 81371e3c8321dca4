#!/usr/bin/env bash
# The mock rig (config/mock_rig.yaml) over each DDS transport, back to back: rig.dds.transport udp,
# then shm (rig up's own iox-roudi). Per transport: the whole rig's CPU (rig up + every process it
# started: LIDAR mocks, GigE fakes, dbw processes, RouDi; the monitor apart) as % of one core, and
# per topic the `dds` stage (DDS source timestamp -> monitor receive) p50/p99/max from a monitor
# that uses the same transport.
# Usage: scripts/bench_rig_transport.sh BUILD_DIR [SECONDS] [LEGS...]
# A leg is a transport (udp, shm), run once each in the order given; TRANSPORT+record also runs
# `rig record` (every topic, lz4, over that transport) beside the monitor for the whole window: the
# rig's `dds` stage with and without a recorder, side by side (e.g. udp udp+record udp udp+record).
# Environment: LIDARS_ONLY=1 runs the three LIDARs alone (no cameras, dbw, fusion, sync sets);
# PHASE_DEG=N phase-locks every synthetic LIDAR to N degrees (their scans complete together),
# PHASE_DEG=free lets them run free (each from whenever its mock starts);
# FUSION_RT=N sets fusion.realtime_priority N (before/after runs);
# DDS_RT=N sets rig.dds.realtime_priority N (0: off, for before/after runs); the monitor runs with
# --rt-priority at the config's rig.dds.realtime_priority.
set -euo pipefail
build=${1:-build-release}
secs=${2:-30}
shift $(( $# > 2 ? 2 : $# ))
legs=("${@:-udp}")
[ $# -eq 0 ] && legs=(udp shm)
root=$(cd "$(dirname "$0")/.." && pwd)
out=$(mktemp -d)
domain=$((150 + $$ % 50))
rig_pid=""
rec_pid=""
conf=""
cleanup() {
  [ -n "${rec_pid:-}" ] && kill -INT "$rec_pid" 2>/dev/null || true
  if [ -n "$rig_pid" ] && kill -0 "$rig_pid" 2>/dev/null; then kill -INT "$rig_pid"; sleep 3; kill -KILL "$rig_pid" 2>/dev/null || true; fi
  [ -n "$conf" ] && rm -f "$conf"
  rm -rf "$out"
}
trap cleanup EXIT
rec_pid=""
names=()
for i in "${!legs[@]}"; do
  leg=${legs[$i]}
  t=${leg%+record}
  name="${i}_${leg}"
  names+=("$name")
  # Relative paths in a rig config resolve against its directory: the generated one sits in config/.
  conf="$root/config/.bench_transport_$$.yaml"
  sed -e "s/^    domain: 0$/    domain: $domain/" -e "s|^    profile: cyclonedds/loopback.xml.*|&\n    transport: $t|" \
    "$root/config/mock_rig.yaml" >"$conf"
  grep -q "transport: $t" "$conf" || { echo "could not set the transport in $conf" >&2; exit 1; }
  if [ -n "${LIDARS_ONLY:-}" ] || [ -n "${DDS_RT:-}" ] || [ -n "${PHASE_DEG:-}" ] || [ -n "${FUSION_RT:-}" ]; then
    python3 - "$conf" "${LIDARS_ONLY:-}" "${DDS_RT:-}" "${PHASE_DEG:-}" "${FUSION_RT:-}" <<'PY'
import sys, yaml
path, lidars_only, rt, phase, fusion_rt = sys.argv[1:6]
c = yaml.safe_load(open(path))
if lidars_only:
    for k in ("cameras", "dbw", "sync_sets", "fusion"):
        c.pop(k, None)
if rt:
    c["rig"]["dds"]["realtime_priority"] = int(rt)
if fusion_rt and "fusion" in c:
    c["fusion"]["realtime_priority"] = int(fusion_rt)
for lidar in c.get("lidars", []):
    mock = lidar.get("mock", {})
    if phase == "free":
        mock.pop("phase_deg", None)
    elif phase and mock.get("kind") == "synthetic":
        mock["phase_deg"] = float(phase)
yaml.safe_dump(c, open(path, "w"), sort_keys=False)
PY
  fi
  # The monitor as a tuned subscriber of that rig: its thread and DDS threads at the rig's priority.
  mon_rt=(--rt-priority "$(python3 -c 'import sys, yaml; print(yaml.safe_load(open(sys.argv[1]))["rig"]["dds"].get("realtime_priority", 0))' "$conf")")
  "$build/rig" up "$conf" --duration $((secs + 14)) 2>"$out/up_$name.log" &
  rig_pid=$!
  sleep 8  # RouDi, fakes, streams, DDS matched
  if [ "$leg" != "$t" ]; then
    "$build/rig" record --domain "$domain" --transport "$t" --compression lz4 --duration "$secs" --out "$out/rec_$name.mcap" \
      >"$out/record_$name.json" 2>"$out/record_$name.log" &
    rec_pid=$!
  fi
  "$build/rig" monitor --domain "$domain" --transport "$t" "${mon_rt[@]}" --duration "$secs" --json --summary "$out/summary_$name.json" \
    >/dev/null 2>"$out/monitor_$name.log" &
  mon_pid=$!
  python3 - "$rig_pid" "$mon_pid" "$secs" "$out/cpu_$name.json" "${rec_pid:-0}" <<'PY'
import json, os, sys, time
rig, mon, secs, dst, rec = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3]), sys.argv[4], int(sys.argv[5])
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
    for p in tree(rig) + [mon] + ([rec] if rec else []):
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
procs = [{"pid": p, "comm": c, "cpu_pct": 100.0 * (t - p0[p][1]) / hz / dt, "monitor": p == mon, "recorder": p == rec}
         for p, (c, t) in p1.items() if p in p0]
json.dump({"seconds": dt, "procs": procs}, open(dst, "w"))
PY
  wait "$mon_pid" || true
  if [ -n "$rec_pid" ]; then wait "$rec_pid" || echo "rig record ($name) exited with $?: $(tail -2 "$out/record_$name.log")" >&2; rec_pid=""; fi
  wait "$rig_pid" || echo "rig up ($name) exited with $?; its log: $out/up_$name.log" >&2
  rig_pid=""
  grep -E "shm:|error" "$out/up_$name.log" | sed "s/^/  [$name] /" >&2 || true
done
python3 - "$out" "$secs" "${names[@]}" <<'PY'
import json, sys
out, secs, ts = sys.argv[1], float(sys.argv[2]), sys.argv[3:]
rows = {t: {r["topic"]: r for r in json.load(open(f"{out}/summary_{t}.json")) if "topic" in r} for t in ts}
cpu = {t: json.load(open(f"{out}/cpu_{t}.json")) for t in ts}
print(f"mock rig, {secs:.0f} s per leg; dds stage = source timestamp -> monitor receive (ms)")
hdr = "".join(f" | {t + ' p50':>16} {'p99':>7} {'max':>7} {'recv':>5} {'lost':>4}" for t in ts)
print(f"{'topic':46}{hdr}")
for topic in sorted(set().union(*[set(r) for r in rows.values()])):
    line = f"{topic:46}"
    for t in ts:
        r = rows[t].get(topic)
        if r is None:
            line += f" | {'-':>16} {'-':>7} {'-':>7} {'-':>5} {'-':>4}"
            continue
        d = r["latency_ms"].get("dds", {})
        line += f" | {d.get('p50', float('nan')):16.3f} {d.get('p99', float('nan')):7.3f} {d.get('max', float('nan')):7.3f} {r['received']:5d} {r['lost']:4d}"
    print(line)
for t in ts:
    procs = cpu[t]["procs"]
    whole = sum(p["cpu_pct"] for p in procs if not p["monitor"] and not p.get("recorder"))
    by = {}
    for p in procs:
        if not p["monitor"] and not p.get("recorder"):
            by[p["comm"]] = by.get(p["comm"], 0.0) + p["cpu_pct"]
    mon = sum(p["cpu_pct"] for p in procs if p["monitor"])
    rec = sum(p["cpu_pct"] for p in procs if p.get("recorder"))
    extra = ""
    try:
        r = [json.loads(l) for l in open(f"{out}/record_{t}.json") if l.startswith("{")][-1]
        d = r.get("drops", {})
        extra = f"; recorder {rec:.1f} %, {r.get('written', 0)} of {r.get('received', 0)} written, drops {sum(d.values())}"
    except (OSError, IndexError, ValueError):
        pass
    print(f"{t}: whole rig {whole:.1f} % of one core (" + ", ".join(f"{k} {v:.1f}" for k, v in sorted(by.items(), key=lambda kv: -kv[1]) if v >= 0.3)
          + f"); monitor {mon:.1f} %" + extra)
PY
