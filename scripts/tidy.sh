#!/usr/bin/env bash
# `make tidy`: clang-tidy (.clang-tidy at the root, found above each source) over the project's
# sources in BUILD_DIR's compile_commands.json; prints every finding once, then counts. Exit 0:
# the findings are a report. BUILD_DIR must have been built (generated IDL headers).
# Usage: scripts/tidy.sh BUILD_DIR [PATH_REGEX]   PATH_REGEX: sources to check, relative to the
# source root, e.g. 'lidar/(velodyne|ouster)/' (default: every area and the tests).
set -euo pipefail
build=${1:-build}
only=${2:-}
[ -f "$build/compile_commands.json" ] || { echo "tidy: no $build/compile_commands.json (configure and build it first)" >&2; exit 2; }
src=$(sed -n 's/^CMAKE_HOME_DIRECTORY:INTERNAL=//p' "$build/CMakeCache.txt")
regex="^${src}/${only:-(bench|camera|common|dbw|dds|drivers|lidar|rig|tests|timesync)/}"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
python3 - "$build/compile_commands.json" "$regex" >"$out/files" <<'PY'
import json, re, sys
seen = set()
for e in json.load(open(sys.argv[1])):
    f = e["file"]
    if re.search(sys.argv[2], f) and f not in seen:
        seen.add(f)
        print(f)
PY
echo "tidy: $(wc -l <"$out/files") sources under $src" >&2
# One clang-tidy per source, JOBS at a time; each writes its own file (no interleaving).
xargs -a "$out/files" -P "${JOBS:-$(nproc)}" -I{} sh -c \
  'clang-tidy -p "$1" --quiet "$2" >"$3/$(echo "$2" | tr / _).log" 2>/dev/null || true' _ "$build" {} "$out"
# One line per finding (a header is seen from many translation units).
cat "$out"/*.log | grep -E '^/.*:[0-9]+:[0-9]+: (warning|error):' | sort -u >"$out/findings" || true
cat "$out/findings"
echo "tidy: $(wc -l <"$out/findings") findings in $(cut -d: -f1 "$out/findings" | sort -u | wc -l) files"
grep -oE '\[[a-z0-9.,-]+\]$' "$out/findings" | sort | uniq -c | sort -rn || true
