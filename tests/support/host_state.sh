#!/usr/bin/env bash
# The host as the suite may change it, before and after: ctest runs `snapshot` before every test
# (fixture setup) and `check` after the last (fixture cleanup). `check` fails naming every change
# left behind, then puts it back (so the next run starts clean).
#
#   host_state.sh snapshot FILE BUILD_DIR
#   host_state.sh check FILE BUILD_DIR
#
# What is compared: addresses on lo, network interfaces and namespaces, /dev/shm files, the rig's
# state folder (/run/sensor-rig: the loopback address registry), the rig's and its peers' entries in
# /tmp, the socket-buffer sysctls, and orphaned processes of BUILD_DIR, RouDi or the GigE fakes.
set -uo pipefail
mode=${1:-} file=${2:-} build=${3:-}
if [[ -z "$mode" || -z "$file" || -z "$build" ]]; then
  echo "usage: host_state.sh snapshot|check FILE BUILD_DIR" >&2
  exit 2
fi
build=$(cd "$build" && pwd -P)

state() {
  ip -o addr show dev lo 2>/dev/null | awk '{print "lo-address " $4}'
  ip -o link show 2>/dev/null | awk -F': ' '{sub(/@.*/, "", $2); print "interface " $2}'
  ip netns list 2>/dev/null | awk '{print "netns " $1}'
  for f in /dev/shm/* /dev/shm/.[!.]*; do [[ -e "$f" ]] && echo "shm ${f#/dev/shm/}"; done
  [[ -e /run/sensor-rig ]] && find /run/sensor-rig -mindepth 0 | sed 's/^/state /'
  # /tmp: what the rig, its mocks, RouDi and the DDS peers name there (temporary folders of the
  # tests, GenICam files, iceoryx and Fast DDS locks). Only those names: other programs (a compiler
  # beside the suite) keep their own files there, which are neither reported nor touched.
  # Not /tmp/rig-*.lock: developers' flock(1) files (one build, one real-time test, one commit at a
  # time on a shared machine) come and go beside a run; removing one a process holds lets a second in.
  for f in /tmp/rig* /tmp/iox* /tmp/roudi* /tmp/iceoryx* /tmp/fastrtps* /tmp/fastdds* /tmp/arv* /tmp/sensor-rig*; do
    [[ -e "$f" && "$f" != /tmp/rig-*.lock ]] && echo "tmp ${f#/tmp/}"
  done
  for s in net.core.rmem_max net.core.wmem_max net.core.rmem_default net.core.wmem_default; do
    echo "sysctl $s=$(sysctl -n "$s" 2>/dev/null)"
  done
  # Processes a test left: orphans (parent gone, adopted by init) running the build's programs,
  # RouDi or a GigE fake. A rig someone runs beside the suite has a parent and is not the suite's.
  for p in /proc/[0-9]*; do
    exe=$(readlink "$p/exe" 2>/dev/null) || continue
    case "$exe" in
      "$build"/*|*/iox-roudi|*/arv-fake-gv-camera*)
        ppid=$(awk '{print $4}' "$p/stat" 2>/dev/null)
        [[ "$ppid" == 1 ]] && echo "process ${p#/proc/} $exe" ;;
    esac
  done
}

case "$mode" in
  snapshot)
    state | sort -u >"$file"
    echo "host state before the suite: $(wc -l <"$file") entries in $file"
    ;;
  check)
    [[ -f "$file" ]] || { echo "no snapshot $file (the fixture's setup did not run)" >&2; exit 1; }
    left=$(comm -13 "$file" <(state | sort -u))
    gone=$(comm -23 "$file" <(state | sort -u) | grep -v '^process ' || true)
    if [[ -z "$left" && -z "$gone" ]]; then
      echo "host left as it was: $(wc -l <"$file") entries compared"
      exit 0
    fi
    [[ -n "$left" ]] && { echo "left behind by the suite:"; echo "$left" | sed 's/^/  /'; }
    [[ -n "$gone" ]] && { echo "removed by the suite:"; echo "$gone" | sed 's/^/  /'; }
    # Put back what can be: the suite's processes, addresses, namespaces, shm files and state.
    while read -r kind what rest; do
      case "$kind" in
        process) kill -9 "$what" 2>/dev/null ;;
        lo-address) ip addr del "$what" dev lo 2>/dev/null ;;
        netns) ip netns del "$what" 2>/dev/null ;;
        shm) rm -f "/dev/shm/$what" ;;
        state) rm -rf /run/sensor-rig ;;
        tmp) rm -rf "/tmp/$what" ;;
      esac
    done <<<"$left"
    echo "(restored what it could; run again to see what remains)"
    exit 1
    ;;
  *)
    echo "usage: host_state.sh snapshot|check FILE BUILD_DIR" >&2
    exit 2
    ;;
esac
