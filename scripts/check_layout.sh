#!/usr/bin/env bash
# The floors of the house (docs/architecture.md): includes and CMake links only run downward.
#   common -> msgs/dds, timesync, lidar, camera, dbw -> drivers -> rig -> bench
# Checks: (1) every #include "sensor_rig/<floor>/..." of a folder names its own floor or a lower one;
# (2) only dds/ includes Cyclone (dds/dds.h, dds/ddsrt, dds/ddsi); (3) with a build dir, CMake's
# link graph (its --graphviz output) has no library of a lower floor linking one of a higher floor.
# Exit 1 with one line per violation.
set -uo pipefail
src=${1:-.}
build=${2:-}
cd "$src" || exit 2

# The floor of each folder, and which floors it may include.
declare -A allowed=(
  [common]="common"
  [msgs]="common msgs"
  [record]="common record"
  [view]="common view"
  [dds]="common msgs dds"
  [timesync]="common timesync"
  [lidar]="common lidar"
  [camera]="common camera"
  [dbw]="common dbw"
  [drivers]="common msgs dds timesync lidar camera dbw drivers"
  [rig]="common msgs record view dds timesync lidar camera dbw drivers"
  [bench]="common msgs record view dds timesync lidar camera dbw drivers bench"
)
fail=0
for folder in "${!allowed[@]}"; do
  [ -d "$folder" ] || continue
  while IFS= read -r line; do
    file=${line%%:*}
    # Bash's own matching, no process per line: the check ran ~55 s forking sed and grep.
    [[ $line =~ \#include\ \"sensor_rig/([a-z_]+)/ ]] || continue
    inc=${BASH_REMATCH[1]}
    # `msgs` headers are generated (dds only, checked below); tests are not floors.
    if [[ " ${allowed[$folder]} " != *" $inc "* ]]; then
      echo "layout: $file includes sensor_rig/$inc/ (a $folder file may include: ${allowed[$folder]})"
      fail=1
    fi
  done < <(grep -rnE '#include "sensor_rig/[a-z_]+/' "$folder" --include='*.cpp' --include='*.hpp' --include='*.h')
done

# Cyclone's own headers: dds/ only (loans, waitsets and the zero-copy take included).
while IFS= read -r line; do
  echo "layout: ${line%%:*} includes Cyclone (only dds/ may): ${line#*:}"
  fail=1
done < <(grep -rnE '#include [<"](dds/dds\.h|dds/ddsrt|dds/ddsi|dds/ddsc)' --include='*.cpp' --include='*.hpp' --include='*.h' \
           common msgs record view timesync lidar camera dbw drivers rig bench 2>/dev/null | grep -v "^dds/")

# The link graph: a library's folder floor must be >= the floor of everything it links.
if [ -n "$build" ] && command -v cmake >/dev/null; then
  declare -A floor=([common]=1 [msgs]=2 [record]=3 [view]=3 [dds]=3 [timesync]=3 [lidar]=3 [camera]=3 [dbw]=3 [drivers]=4 [rig]=5 [bench]=6)
  graph_dir=$(mktemp -d)
  trap 'rm -rf "$graph_dir"' EXIT
  if cmake --graphviz="$graph_dir/g.dot" "$build" >/dev/null 2>&1; then
    # Map target name -> source folder from the build tree's CMakeFiles/<target>.dir location.
    declare -A home
    while IFS= read -r d; do
      t=${d##*/}
      t=${t%.dir}
      rel=${d#"$build"/}
      home[$t]=${rel%%/*}
      [ "${home[$t]}" = rig_cmd ] && home[$t]=rig
    done < <(find "$build" -path '*/CMakeFiles/*.dir' -type d -not -path '*/tests/*' 2>/dev/null)
    # Node ids -> names, then edges.
    declare -A name
    while IFS= read -r l; do
      [[ $l =~ ^\ *\"([^\"]+)\".*label\ =\ \"([^\"]+)\" ]] || continue
      name[${BASH_REMATCH[1]}]=${BASH_REMATCH[2]}
    done < <(grep -E '^ *"node[0-9]+" \[' "$graph_dir/g.dot")
    while IFS= read -r l; do
      [[ $l =~ ^\ *\"([^\"]+)\"\ -\>\ \"([^\"]+)\" ]] || continue
      a=${BASH_REMATCH[1]}
      b=${BASH_REMATCH[2]}
      ta=${name[$a]:-}; tb=${name[$b]:-}
      fa=${home[$ta]:-}; fb=${home[$tb]:-}
      [ -n "$fa" ] && [ -n "$fb" ] || continue
      [ -n "${floor[$fa]:-}" ] && [ -n "${floor[$fb]:-}" ] || continue
      # The rig executable composes every command, bench's `rig perf` included (bench plugs it in).
      [ "$ta" = "rig" ] && continue
      # Downward only; on the areas' floor (dds, timesync, lidar, camera, dbw) none links another.
      if [ "${floor[$fa]}" -lt "${floor[$fb]}" ] || { [ "${floor[$fa]}" -eq "${floor[$fb]}" ] && [ "$fa" != "$fb" ]; }; then
        echo "layout: target $ta ($fa/) links $tb ($fb/): links run downward only"
        fail=1
      fi
    done < <(grep -E '^ *"node[0-9]+" -> "node[0-9]+"' "$graph_dir/g.dot")
  else
    echo "layout: cmake --graphviz failed on $build (link graph not checked)"
    fail=1
  fi
fi
[ $fail -eq 0 ] && echo "layout: ok (includes and links run downward; Cyclone only in dds/)"
exit $fail
