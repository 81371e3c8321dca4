#!/usr/bin/env bash
# `make tidy`: clang-tidy (.clang-tidy at the root, found above each source) over the project's
# sources in BUILD_DIR's compile_commands.json; prints every finding once, then counts. Exit 0:
# the findings are a report. BUILD_DIR must have been built (generated IDL headers).
# Usage: scripts/tidy.sh BUILD_DIR [PATH_REGEX]   PATH_REGEX: sources to check, relative to the
# source root, e.g. 'lidar/(velodyne|ouster)/' (default: every area and the tests).
set -euo pipefail
build=${1:-build}
only=${2:-}
src=$(sed -n 's/^CMAKE_HOME_DIRECTORY:INTERNAL=//p' "$build/CMakeCache.txt")
[ -f "$build/compile_commands.json" ] || { echo "tidy: no $build/compile_commands.json (configure and build it first)" >&2; exit 2; }
files="^${src}/${only:-(bench|camera|dbw|drivers|lidar|msgs|tests|timesync)/}"
out=$(mktemp)
trap 'rm -f "$out"' EXIT
run-clang-tidy -p "$build" -j "${JOBS:-$(nproc)}" -quiet "$files" >"$out" 2>/dev/null || true
# One line per finding (headers are seen from many translation units).
grep -E '^/.*:[0-9]+:[0-9]+: (warning|error):' "$out" | sort -u | tee "$out.findings" || true
n=$(wc -l <"$out.findings")
echo "tidy: $n findings in $(cut -d: -f1 "$out.findings" | sort -u | wc -l) files"
grep -oE '\[[a-z0-9.,-]+\]$' "$out.findings" | sort | uniq -c | sort -rn || true
rm -f "$out.findings"
