#!/usr/bin/env bash
# Seven cameras at 1920x1200 BayerRG8 10 Hz from the fakes beside the mock rig's three LIDARs and
# drive-by-wire (config/mock_rig.yaml with its cameras replaced), for a bounded time. Reports per
# camera topic: frames received / expected, lost (monitor) and source drops (incomplete frames),
# frame complete -> on the wire (to_wire: written - complete) p50/p99/max; CPU per thread of
# `rig up` (capture threads cam:<name>, Aravis threads), of each GigE fake process, of the whole
# process tree (LIDAR mocks, dbw, fakes) and of the monitor, as % of one core.
# Usage: scripts/bench_cameras.sh BUILD_DIR [SECONDS] [gige|aravis-inprocess] [WIDTH HEIGHT]
# RIG_DOMAIN=N: DDS domain of the run (default 0); another rig on the same domain would mix its
# camera topics into this run's counts. CAMERA_QOS='{depth: 2}': each camera's qos (default: the
# node's, keep-last 2 since issue 10's loss runs).
set -euo pipefail
build=${1:-build-release}
secs=${2:-60}
kind=${3:-aravis-inprocess}
width=${4:-1920}
height=${5:-1200}
root=$(cd "$(dirname "$0")/.." && pwd)
out=$(mktemp -d)
# Relative paths in a rig config resolve against its directory: the generated one sits in config/.
conf="$root/config/.bench_cameras_$$.yaml"
rig_pid=""
cleanup() {
  if [ -n "$rig_pid" ] && kill -0 "$rig_pid" 2>/dev/null; then kill -INT "$rig_pid"; sleep 2; kill -KILL "$rig_pid" 2>/dev/null || true; fi
  rm -f "$conf"
  rm -rf "$out"
}
trap cleanup EXIT
domain=${RIG_DOMAIN:-0}
python3 - "$root/config/mock_rig.yaml" "$conf" "$kind" "$width" "$height" "$domain" "${CAMERA_QOS:-}" <<'PY'
import re, sys
src, dst, kind, w, h, domain, qos = sys.argv[1:8]
text = open(src).read()
head = text[: text.index("\ncameras:")]
head = re.sub(r"(?m)^(\s+domain:) \d+", rf"\1 {domain}", head, count=1)
names = ["front_narrow", "corner_front_left", "corner_front_right", "corner_rear_left", "corner_rear_right",
         "stereo_left", "stereo_right"]
cams = ["", "cameras:"]
for i, n in enumerate(names):
    device = f"127.0.0.{2 + i}" if kind == "gige" else n
    cams += [f"  - name: {n}", "    backend: aravis", f"    device: {device}", "    pixel_format: BayerRG8",
             f"    width: {w}", f"    height: {h}", "    frame_rate: 10", f"    mock: {{kind: {kind}}}"]
    if qos:
        cams.append(f"    qos: {qos}")
open(dst, "w").write(head + "\n".join(cams) + "\n")
PY
"$build/rig" up "$conf" --duration $((secs + 12)) 2>"$out/up.log" &
rig_pid=$!
sleep 6  # fakes started, streams open, DDS matched
topics=()
for n in front_narrow corner_front_left corner_front_right corner_rear_left corner_rear_right stereo_left stereo_right; do
  topics+=("/sensors/camera/$n/image_raw")
done
"$build/rig" monitor "${topics[@]}" --domain "$domain" --duration "$secs" --json --summary "$out/summary.json" >/dev/null &
mon_pid=$!
# CPU sampling over the monitor's window (after its 1 s warm-up).
python3 - "$rig_pid" "$mon_pid" "$secs" "$out/cpu.json" <<'PY'
import json, os, sys, time
rig, mon, secs, dst = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3]), sys.argv[4]
hz = os.sysconf("SC_CLK_TCK")
def stat(path):
    s = open(path).read()
    comm = s[s.index("(") + 1 : s.rindex(")")]
    f = s[s.rindex(")") + 2 :].split()
    return comm, int(f[1]), int(f[11]) + int(f[12])  # comm, ppid, utime+stime
def tree(root):
    kids = {}
    for p in os.listdir("/proc"):
        if p.isdigit():
            try:
                _, ppid, _ = stat(f"/proc/{p}/stat")
                kids.setdefault(ppid, []).append(int(p))
            except OSError:
                pass
    out, todo = [], [root]
    while todo:
        p = todo.pop()
        out.append(p)
        todo += kids.get(p, [])
    return out
def sample():
    procs, threads = {}, {}
    for p in tree(rig) + [mon]:
        try:
            comm, _, t = stat(f"/proc/{p}/stat")
            procs[p] = (comm, t)
            if p == rig:
                for tid in os.listdir(f"/proc/{p}/task"):
                    tc, _, tt = stat(f"/proc/{p}/task/{tid}/stat")
                    threads[int(tid)] = (tc, tt)
        except OSError:
            pass
    return time.monotonic(), procs, threads
time.sleep(1.0)
t0, p0, th0 = sample()
time.sleep(max(1.0, secs - 6.0))
t1, p1, th1 = sample()
dt = t1 - t0
pct = lambda a, b: 100.0 * (b - a) / hz / dt
by_thread = {}
for tid, (comm, t) in th1.items():
    if tid in th0:
        by_thread[comm] = by_thread.get(comm, 0.0) + pct(th0[tid][1], t)
procs = []
for p, (comm, t) in p1.items():
    if p in p0:
        procs.append({"pid": p, "comm": comm, "cpu_pct": pct(p0[p][1], t), "monitor": p == mon, "rig_up": p == rig})
json.dump({"seconds": dt, "threads": by_thread, "procs": procs, "monitor_pid": mon,
           "monitor_seen": [mon in p0, mon in p1]}, open(dst, "w"))
PY
wait "$mon_pid" || true
wait "$rig_pid" || true
rig_pid=""
python3 - "$out/summary.json" "$out/cpu.json" "$secs" "$kind" "$width" "$height" <<'PY'
import json, sys
rows = json.load(open(sys.argv[1])); cpu = json.load(open(sys.argv[2]))
secs, kind, w, h = float(sys.argv[3]), sys.argv[4], sys.argv[5], sys.argv[6]
print(f"seven cameras {w}x{h} BayerRG8 10 Hz, mock kind {kind}, {secs:.0f} s (CPU over {cpu['seconds']:.0f} s)")
print(f"{'topic':42} {'recv':>5} {'expect':>6} {'lost':>5} {'drops':>5} | {'to_wire p50':>11} {'p99':>7} {'max':>7} | {'dds p50':>7} {'p99':>7}")
tot_recv = tot_lost = 0
for r in rows:
    l = r["latency_ms"]; g = lambda s, k: l.get(s, {}).get(k, float("nan"))
    tot_recv += r["received"]; tot_lost += r["lost"]
    print(f"{r['topic']:42} {r['received']:5d} {int(10 * r.get('duration_s', secs)):6d} {r['lost']:5d} {r.get('source_drops', 0):5d} | "
          f"{g('to_wire','p50'):11.3f} {g('to_wire','p99'):7.3f} {g('to_wire','max'):7.3f} | {g('dds','p50'):7.3f} {g('dds','p99'):7.3f}")
print(f"total received {tot_recv}, lost {tot_lost}")
# Where the frames that did not arrive went (rig monitor's drops by stage: the camera node's
# counters from /diagnostics, then the monitor's own accounting).
stages = [k for r in rows for k in r.get("drops_by_stage", {})]
stages = list(dict.fromkeys(stages))
if stages:
    print("drops by stage: " + " ".join(stages))
    totals = {k: 0 for k in stages}
    for r in rows:
        d = r.get("drops_by_stage", {})
        for k in stages: totals[k] += d.get(k, 0)
        print(f"  {r['topic']:42} " + " ".join(f"{d.get(k, 0)}" for k in stages))
    print("  total: " + ", ".join(f"{k} {v}" for k, v in totals.items()))
th = cpu["threads"]
cam = {k: v for k, v in th.items() if k.startswith("cam:")}
print("CPU % of one core, rig up threads:", ", ".join(f"{k} {v:.1f}" for k, v in sorted(th.items(), key=lambda kv: -kv[1]) if v >= 0.5))
if cam:
    print(f"capture threads: mean {sum(cam.values()) / len(cam):.1f} %, max {max(cam.values()):.1f} %")
up = [p for p in cpu["procs"] if p["rig_up"]]
fakes = [p for p in cpu["procs"] if p["comm"].startswith("arv-fake")]
others = [p for p in cpu["procs"] if not p["rig_up"] and not p["monitor"] and not p["comm"].startswith("arv-fake")]
mon = [p for p in cpu["procs"] if p["monitor"]]
if up:
    print(f"rig up process (drivers + in-process fakes): {up[0]['cpu_pct']:.1f} %  = {up[0]['cpu_pct'] / 7:.1f} % per camera if the cameras dominate")
if fakes:
    print(f"GigE fake processes: " + ", ".join(f"{p['cpu_pct']:.1f}" for p in fakes) + f" (mean {sum(p['cpu_pct'] for p in fakes) / len(fakes):.1f} %)")
print("other mock processes: " + ", ".join(f"{p['comm']} {p['cpu_pct']:.1f}" for p in others))
whole = sum(p["cpu_pct"] for p in cpu["procs"] if not p["monitor"])
print(f"whole rig (rig up tree, without the monitor): {whole:.1f} % of one core")
PY
