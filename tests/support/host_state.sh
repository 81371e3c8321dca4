#!/usr/bin/env bash
# The host as the suite may change it, before and after: ctest runs `snapshot` before every test
# (fixture setup) and `check` after the last (fixture cleanup). `check` fails naming every change
# left behind, then puts it back (so the next run starts clean).
#
#   host_state.sh snapshot FILE BUILD_DIR
#   host_state.sh check FILE BUILD_DIR
#
# What is compared: addresses on lo, network interfaces and namespaces, /dev/shm files, the rig's
# state folder (/run/sensor-rig: the loopback address registry), entries in /tmp, the socket-buffer
# sysctls, and processes still running from BUILD_DIR or the mocks' and RouDi's programs.
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
  # /tmp: what the suite writes outside its temporary folders. The snapshot's own file and the
  # tool's files are not the suite's.
  for f in /tmp/* /tmp/.[!.]*; do
    [[ -e "$f" ]] || continue
    case "${f#/tmp/}" in .X*-lock|.X11-unix|.ICE-unix|.font-unix|.XIM-unix|.Test-unix|bash_tool_*|bash_jobs*|systemd-private-*) continue ;; esac
    echo "tmp ${f#/tmp/}"
  done
  for s in net.core.rmem_max net.core.wmem_max net.core.rmem_default net.core.wmem_default; do
    echo "sysctl $s=$(sysctl -n "$s" 2>/dev/null)"
  done
  for p in /proc/[0-9]*; do
    exe=$(readlink "$p/exe" 2>/dev/null) || continue
    case "$exe" in
      "$build"/*|*/iox-roudi|*/arv-fake-gv-camera*) echo "process ${p#/proc/} $exe" ;;
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
