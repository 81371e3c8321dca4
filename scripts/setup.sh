#!/usr/bin/env bash
# Installs the Debian packages sensor-rig needs. Idempotent and fast when everything is present.
set -euo pipefail

PACKAGES=(
  build-essential cmake pkg-config git
  cyclonedds-dev cyclonedds-tools libcycloneddsidl0
  iceoryx libiceoryx-posh-dev libiceoryx-hoofs-dev libiceoryx-binding-c-dev
  libpcap-dev libyaml-cpp-dev libcli11-dev nlohmann-json3-dev libssl-dev
  libpcl-dev                   # the fused LIDAR cloud (drivers/fusion): PCL 1.13 common + filters
  libaravis-dev aravis-tools libusb-1.0-0-dev libturbojpeg0-dev
  libgtest-dev libgmock-dev googletest libbenchmark-dev
  libfastrtps-dev              # Fast DDS 2.9 (rmw_fastrtps' DDS): the foreign subscriber of tests/interop
  clang libclang-rt-14-dev clang-tidy
  lld                          # the linker of every build (CMake option RIG_LLD): 3-4x faster links
  python3
)

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#PACKAGES[@]} Debian packages present"
  exit 0
fi

echo "setup: installing ${missing[*]}"
SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
