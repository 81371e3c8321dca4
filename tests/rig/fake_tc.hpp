#pragma once
// A stand-in for `tc` ($RIG_TC) that keeps lo's qdiscs in the file $FAKE_TC_STATE (present = the
// rig's prio root stands: its netem and filter lines) and logs each call to $FAKE_TC_LOG; answers as
// tc does to the commands rig/src/network_delay.cpp gives, anything else is an error (exit 2).
// $FAKE_TC_NO_NETEM: a kernel without sch_netem. For tests of host.network_delay by netem: this CI
// kernel has none, and no test may shape the host's loopback under the others.
namespace sensor_rig::test {

inline constexpr const char* kFakeTc = R"(#!/bin/sh
echo "$*" >> "$FAKE_TC_LOG"
case "$*" in
  "qdisc show dev lo")
    if [ -e "$FAKE_TC_STATE" ]; then echo "qdisc prio 1: root refcnt 2 bands 3"; cat "$FAKE_TC_STATE";
    else echo "qdisc noqueue 0: root refcnt 2"; fi ;;
  "qdisc add dev lo root handle 1: prio bands 3 priomap 1 1 1 1 1 1 1 1 1 1 1 1 1 1 1 1")
    if [ -e "$FAKE_TC_STATE" ]; then echo "Error: Exclusivity flag on, cannot modify."; exit 2; fi
    : > "$FAKE_TC_STATE" ;;
  "qdisc add dev lo parent 1:3 handle 30: netem delay "*)
    [ -e "$FAKE_TC_STATE" ] || exit 2
    if [ -n "$FAKE_TC_NO_NETEM" ]; then echo "Error: Specified qdisc kind is unknown."; exit 2; fi
    echo "qdisc netem 30: parent 1:3 ${*#*netem }" >> "$FAKE_TC_STATE" ;;
  "filter add dev lo parent 1: protocol ip prio 1 u32 match ip protocol 17 0xff match ip dport "*" 0xffff flowid 1:3")
    [ -e "$FAKE_TC_STATE" ] || exit 2
    echo "filter dport ${*#*dport }" >> "$FAKE_TC_STATE" ;;
  "filter del dev lo parent 1: prio 1")
    [ -e "$FAKE_TC_STATE" ] || exit 2
    grep -v '^filter' "$FAKE_TC_STATE" > "$FAKE_TC_STATE.new"; mv "$FAKE_TC_STATE.new" "$FAKE_TC_STATE" ;;
  "qdisc del dev lo root handle 1:")
    if [ ! -e "$FAKE_TC_STATE" ]; then echo "Error: Cannot find specified qdisc on specified device."; exit 2; fi
    rm -f "$FAKE_TC_STATE" ;;
  *) echo "fake tc: unexpected: $*"; exit 2 ;;
esac
)";

}  // namespace sensor_rig::test
