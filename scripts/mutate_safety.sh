#!/usr/bin/env bash
# Mutation testing of dbw/safety (opendbc practice): plants one small change at a time (a flipped
# comparison, a dropped check, a changed constant) in a private copy of dbw/safety, rebuilds only the
# safety test against it and runs the typed suite. A mutant is killed when the suite fails (or
# crashes). The checkout is never touched. Prints one line per mutant and the score; exit 1 if any
# mutant survives, 2 if the setup is wrong (a mutant's text no longer occurs exactly once in the
# sources: every mutant is checked before anything is built; the unmutated suite does not build or
# pass).
# Usage: scripts/mutate_safety.sh [--only REGEX] [SOURCE_DIR]   (5-9 minutes on 2 shared cores)
#   --only REGEX   only the mutants whose line (file|text|replacement) matches REGEX (grep -E)
set -euo pipefail
usage() { sed -n '2,/^set -euo/p' "$0" | sed '$d; s/^# \{0,1\}//'; }
only=''
while [ $# -gt 0 ]; do
  case $1 in
    -h|--help) usage; exit 0 ;;
    --only) [ $# -ge 2 ] || { usage >&2; exit 2; }; only=$2; shift 2 ;;
    -*) usage >&2; exit 2 ;;
    *) break ;;
  esac
done
src=$(cd "${1:-$(dirname "$0")/..}" && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cxx=${CXX:-c++}
flags=(-O1 -std=c++20 -w -I"$work/include" -I"$src/common/include" -I"$src/tests/support" -DGTEST_HAS_PTHREAD=1)
gtest=(/usr/lib/x86_64-linux-gnu/libgtest.a /usr/lib/x86_64-linux-gnu/libgtest_main.a -pthread)
# The sources of test_dbw_safety (tests/dbw/CMakeLists.txt): the typed suite, split by section.
tests=(test_safety_engage.cpp test_safety_limits.cpp test_safety_time.cpp test_safety_writers.cpp
       test_safety_measured.cpp test_safety_e2e_shutdown.cpp test_safety_config.cpp)
for t in "${tests[@]}"; do
  [ -f "$src/tests/dbw/$t" ] || { echo "no tests/dbw/$t: update this script's list of test files" >&2; exit 2; }
done

# file | exact text (must occur once) | replacement   -- one mutant per line
mutants=$(cat <<'LIST'
src/safety_core.cpp|if (!cmd.enable) disengage(Reason::kEnableReleased, now);|if (false) disengage(Reason::kEnableReleased, now);
src/safety_core.cpp|if (w.used && cmd.seq <= w.last_seq)|if (w.used && cmd.seq < w.last_seq)
src/safety_core.cpp|age > cfg_.command_timeout_ns \|\| age < -cfg_.max_future_ns|age > cfg_.command_timeout_ns
src/safety_core.cpp|age > cfg_.command_timeout_ns \|\| age < -cfg_.max_future_ns|age > 2 * cfg_.command_timeout_ns \|\| age < -cfg_.max_future_ns
src/safety_core.cpp|if (w.used && cmd.stamp <= w.last_stamp)|if (w.used && cmd.stamp < w.last_stamp)
src/safety_core.cpp|std::min(cmd.stamp - w.last_stamp, now - w.last_rx + cfg_.rate_rx_slack_ns)|std::max(cmd.stamp - w.last_stamp, now - w.last_rx + cfg_.rate_rx_slack_ns)
src/safety_core.cpp|if (state_ == State::kEngaged && w.id != owner_)|if (false && w.id != owner_)
src/safety_core.cpp|state_ == State::kDisengaged && cmd.enable && w.armed;|state_ == State::kDisengaged && cmd.enable;
src/safety_core.cpp|measured.steering_angle = measured_steering_;|measured.steering_angle = 0.0;
src/safety_core.cpp|    w.armed = false;  // a rejected command cannot be half of an enable edge|
src/safety_core.cpp|  disarm_all();  // every writer must show false then true again|
src/safety_core.cpp|  w.armed = false;  // an edge is used once, engaged or refused|
src/safety_core.cpp|e2e_level_ = std::min(e2e_level_ + 1, e2e_level_max(cfg_));|e2e_level_ = e2e_level_ + 1;
src/safety_core.cpp|if (e2e_level_ > cfg_.e2e_tolerance) disengage(Reason::kE2eErrors, now);|if (e2e_level_ >= cfg_.e2e_tolerance) disengage(Reason::kE2eErrors, now);
src/safety_core.cpp|if (e2e_level_ > 0) --e2e_level_;|if (e2e_level_ > 1) --e2e_level_;
src/safety_core.cpp|if (now - last_cmd_rx_ > cfg_.command_timeout_ns) {|if (now - last_cmd_rx_ > cfg_.command_timeout_ns + cfg_.max_future_ns) {
src/safety_core.cpp|    } else if (!ecu_fresh(now)) {|    } else if (false) {
src/safety_core.cpp|  stopping_ = true;|
src/safety_core.cpp|  if (bus_off_) return Reason::kBusOff;|
src/safety_core.cpp|  if (!ecu_fresh(now)) return Reason::kEcuTimeout;|
src/safety_core.cpp|  if (ecu_.override) return Reason::kDriverOverride;|
src/safety_core.cpp|  if (ecu_.fault) return Reason::kEcuFault;|
src/safety_core.cpp|  if (!ecu_.ready) return Reason::kEcuNotReady;|
src/safety_core.cpp|  if (e2e_level_ > cfg_.e2e_tolerance) return Reason::kE2eErrors;|
src/safety_core.cpp|  if (st.override) {|  if (false) {
src/safety_core.cpp|  } else if (!st.ready) {|  } else if (false) {
src/safety_core.cpp|if (std::isfinite(steering_angle)) measured_steering_ = steering_angle;|measured_steering_ = steering_angle;
src/safety_core.cpp|if (n_events_ == events_.size()) {|if (n_events_ == 2 * events_.size()) {
src/safety_core.cpp|(oldest == nullptr \|\| w.last_rx < oldest->last_rx)|(oldest == nullptr \|\| w.last_rx > oldest->last_rx)
src/safety_core.cpp|  if (bus_off) disengage(Reason::kBusOff, now);|
src/limits.cpp|if (v < lim.min \|\| v > lim.max) {|if (v > lim.max) {
src/limits.cpp|r.add({axis, false, lim.action == LimitAction::kReject, false, want, c});|r.add({axis, false, false, false, want, c});
src/limits.cpp|r.add({axis, true, lim.action == LimitAction::kReject, false, want, c});|r.add({axis, true, false, false, want, c});
src/limits.cpp|if (std::fabs(v) > lat) {|if (std::fabs(v) > 2 * lat) {
src/limits.cpp|return std::atan(v.max_lateral_accel * v.wheelbase_m / v2);|return std::atan(v.max_lateral_accel / v2);
src/limits.cpp|req.brake > limits_.brake_throttle_cutoff && v > 0.0|req.brake > 1.0 && v > 0.0
src/limits.cpp|const double step = lim.max_rate * std::max(dt_s, 0.0);|const double step = lim.max_rate * std::fabs(dt_s);
src/limits.cpp|if (have_prev_ && lim.max_rate > 0.0) {|if (lim.max_rate > 0.0) {
src/limits.cpp|if (!std::isfinite(want)) {|if (std::isnan(want)) {
include/sensor_rig/dbw/safety/safety_core.hpp|Nanos max_future_ns = 20'000'000;|Nanos max_future_ns = 200'000'000;
include/sensor_rig/dbw/safety/safety_core.hpp|Nanos command_timeout_ns = 100'000'000;|Nanos command_timeout_ns = 150'000'000;
include/sensor_rig/dbw/safety/safety_core.hpp|return 2 * c.e2e_tolerance + 1;|return c.e2e_tolerance;
include/sensor_rig/dbw/safety/limits.hpp|    2.5,|    25.0,
LIST
)

fresh_copy() {
  rm -rf "$work/include" "$work/src"
  cp -r "$src/dbw/safety/include" "$work/include"
  cp -r "$src/dbw/safety/src" "$work/src"
}
# "file<US>from<US>to" of a mutant line: fields are split on unescaped '|'; '\|' stands for a literal '|'.
fields() { printf '%s\n' "$1" | sed 's/\\|/\x1e/g; s/|/\x1f/g; s/\x1e/|/g'; }
# Applies `from` -> `to` to $work/$file; exit 1 unless `from` occurs exactly once.
apply() {
  python3 - "$work/$1" "$2" "$3" <<'PY'
import sys
path, old, new = sys.argv[1:]
text = open(path).read()
if text.count(old) != 1:
    sys.exit(1)
open(path, "w").write(text.replace(old, new))
PY
}
objects=("${tests[@]/#/$work/}"); objects=("${objects[@]/%/.o}")
build() {  # $1: rebuild the test objects too (a header changed)
  if [ "$1" = 1 ] || [ ! -f "$work/objects.ok" ]; then
    rm -f "$work/objects.ok"
    # Two at a time: the test files are independent.
    printf '%s\n' "${tests[@]}" | xargs -P "${JOBS:-2}" -I{} \
      "$cxx" "${flags[@]}" -c "$src/tests/dbw/{}" -o "$work/{}.o" || return 1
    touch "$work/objects.ok"
  fi
  "$cxx" "${flags[@]}" "${objects[@]}" "$work/src/limits.cpp" "$work/src/safety_core.cpp" "${gtest[@]}" -o "$work/test" || return 1
}
selected=()
while IFS= read -r line; do
  [ -n "$line" ] || continue
  [ -z "$only" ] || grep -qE -- "$only" <<<"$line" || continue
  selected+=("$line")
done <<< "$mutants"
[ ${#selected[@]} -gt 0 ] || { echo "no mutant matches --only '$only'" >&2; exit 2; }

# Every mutant must apply to the sources as they are now, before anything is built.
stale=0
for line in "${selected[@]}"; do
  IFS=$'\x1f' read -r file from to < <(fields "$line")
  fresh_copy
  apply "$file" "$from" "$to" || { echo "mutant not applicable (text must occur once in dbw/safety/$file): $line" >&2; stale=1; }
done
[ "$stale" = 0 ] || exit 2

fresh_copy
build 1 || { echo "the unmutated safety test does not build" >&2; exit 2; }
"$work/test" --gtest_brief=1 >/dev/null || { echo "the unmutated safety suite fails" >&2; exit 2; }

total=0 killed=0 survived=()
for line in "${selected[@]}"; do
  IFS=$'\x1f' read -r file from to < <(fields "$line")
  fresh_copy
  apply "$file" "$from" "$to"
  total=$((total + 1))
  header=0; [[ $file == include/* ]] && header=1
  if ! build "$header" 2>/dev/null; then
    verdict="killed (does not build)"; killed=$((killed + 1))
  elif ! timeout 60 "$work/test" --gtest_brief=1 >/dev/null 2>&1; then
    verdict="killed"; killed=$((killed + 1))
  else
    verdict="SURVIVED"; survived+=("$line")
  fi
  printf '%-24s %s: %s -> %s\n' "$verdict" "$file" "$from" "${to:-<removed>}"
  [ "$header" = 1 ] && rm -f "$work/objects.ok"  # the next mutant needs the unmutated header again
done

echo "mutation score: $killed/$total killed"
[ ${#survived[@]} -eq 0 ]
