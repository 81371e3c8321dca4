#!/usr/bin/env bash
# Soak (issue 13, "Long runs"): the whole mock rig (config/mock_rig.yaml: three LIDARs, seven cameras,
# drive-by-wire) for SECONDS with `rig monitor` beside it. Every 10 s it samples each process of the
# rig's tree (rig up and everything it started) and the monitor: resident memory (VmRSS) and open file
# descriptors. Reports per process the first-minute and final figures and the growth after the first
# minute (goal < 1 %), and per topic the samples received and lost (goal 0 lost).
# Usage: scripts/bench_soak.sh BUILD_DIR [SECONDS] [CONFIG]
# Environment: TRANSPORT=shm runs the rig and the monitor over shared memory (rig.dds.transport shm:
# rig up's own RouDi, which is then sampled too): a chunk a reader never releases exhausts RouDi's
# pools within minutes, and shows as lost samples.
set -euo pipefail
build=${1:-build-release}
secs=${2:-300}
config=${3:-config/mock_rig.yaml}
root=$(cd "$(dirname "$0")/.." && pwd)
out=$(mktemp -d)
domain=$((150 + $$ % 50))
conf="$root/config/.bench_soak_$$.yaml"
rig_pid=""
cleanup() {
  if [ -n "$rig_pid" ] && kill -0 "$rig_pid" 2>/dev/null; then kill -INT "$rig_pid"; sleep 3; kill -KILL "$rig_pid" 2>/dev/null || true; fi
  rm -f "$conf"
  rm -rf "$out"
}
trap cleanup EXIT
# Its own domain, so a soak beside other work on this host sees only its own rig.
transport=${TRANSPORT:-udp}
sed -e "s/^    domain: 0$/    domain: $domain/" -e "s|^    profile: cyclonedds/loopback.xml.*|&\n    transport: $transport|" \
  "$root/$config" >"$conf"
grep -q "domain: $domain" "$conf" || { echo "could not set the domain in $conf" >&2; exit 1; }
grep -q "transport: $transport" "$conf" || { echo "could not set the transport in $conf" >&2; exit 1; }
"$build/rig" up "$conf" --duration $((secs + 20)) 2>"$out/up.log" &
rig_pid=$!
sleep 8  # fakes, streams, DDS matched
"$build/rig" monitor --domain "$domain" --transport "$transport" --duration "$secs" --json --summary "$out/summary.json" \
  >/dev/null 2>"$out/monitor.log" &
mon_pid=$!
python3 - "$rig_pid" "$mon_pid" "$secs" "$out/summary.json" <<'PY'
import json, os, sys, time
rig, mon, secs, summary = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3]), sys.argv[4]
def ppid_of(p):
    s = open(f"/proc/{p}/stat").read()
    return int(s[s.rindex(")") + 2:].split()[1])
def tree(root):
    kids = {}
    for p in os.listdir("/proc"):
        if p.isdigit():
            try:
                kids.setdefault(ppid_of(p), []).append(int(p))
            except OSError:
                pass
    found, todo = [], [root]
    while todo:
        p = todo.pop(); found.append(p); todo += kids.get(p, [])
    return found
def probe(p):
    name, rss = "?", None
    for line in open(f"/proc/{p}/status"):
        if line.startswith("Name:"):
            name = line.split()[1]
        elif line.startswith("VmRSS:"):
            rss = int(line.split()[1])
    return name, rss, len(os.listdir(f"/proc/{p}/fd"))
samples = []  # (t, {pid: (name, rss_kB, fds)})
t0 = time.monotonic()
while time.monotonic() - t0 < secs - 2:
    snap = {}
    for p in tree(rig) + [mon]:
        try:
            name, rss, fds = probe(p)
            if rss is not None:
                snap[p] = (name, rss, fds)
        except OSError:
            pass
    samples.append((time.monotonic() - t0, snap))
    time.sleep(10)
base = next((s for s in samples if s[0] >= 60), samples[0])
last = samples[-1]
print(f"{len(samples)} samples over {last[0]:.0f} s; growth = final vs the first sample after 60 s")
print(f"{'process':22} {'pid':>7} | {'RSS@1min kB':>11} {'RSS end':>9} {'growth':>7} | {'fds@1min':>8} {'fds end':>7}")
total0 = total1 = 0
for p, (name, rss1, fd1) in sorted(last[1].items(), key=lambda kv: -kv[1][1]):
    if p not in base[1]:
        print(f"{name:22} {p:7d} | (started after the first minute: a restart?)")
        continue
    _, rss0, fd0 = base[1][p]
    total0 += rss0; total1 += rss1
    print(f"{name:22} {p:7d} | {rss0:11d} {rss1:9d} {100.0 * (rss1 - rss0) / rss0:6.2f}% | {fd0:8d} {fd1:7d}")
gone = [f"{base[1][p][0]}({p})" for p in base[1] if p not in last[1]]
if gone:
    print("processes gone before the end:", ", ".join(gone))
print(f"{'all':22} {'':7} | {total0:11d} {total1:9d} {100.0 * (total1 - total0) / max(total0, 1):6.2f}%")
deadline = time.monotonic() + 30
while not os.path.exists(summary) and time.monotonic() < deadline:
    time.sleep(0.5)
time.sleep(1)
rows = json.load(open(summary))
print(f"{'topic':44} {'received':>9} {'lost':>6}")
for r in rows:
    if "topic" in r:  # set and trigger rows have their own keys
        print(f"{r['topic']:44} {r.get('received', 0):9d} {r.get('lost', 0):6d}")
PY
wait "$mon_pid" || true
echo "rig up log: $(grep -ci 'error' "$out/up.log" || true) lines with 'error', $(grep -ci 'critical' "$out/up.log" || true) with 'critical'"
