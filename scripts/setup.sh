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
  liblz4-dev libzstd-dev        # MCAP chunk compression (rig record / play)
  libboost-dev                 # Boost.Beast/Asio, header-only: rig view's WebSocket server (view/)
  iproute2                     # tc: rig chaos host.network_delay by netem on lo (kernels with sch_netem)
)

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
# The tests' independent clients (tests/js: @mcap/core, @foxglove/ws-protocol, ...) from the npm
# registry, pinned by tests/js/package-lock.json, with the machine's Node.js.
install_js_clients() {
  local dir
  dir="$(cd "$(dirname "$0")/.." && pwd)/tests/js"
  if ! command -v npm >/dev/null 2>&1; then
    echo "setup: npm not found: the tests that read MCAP files and the Foxglove server with npm clients will fail (install Node.js >= 18)" >&2
    return 0
  fi
  if cmp -s "$dir/package-lock.json" "$dir/node_modules/.rig-installed-lock.json" 2>/dev/null; then
    return 0
  fi
  echo "setup: installing the npm test clients in tests/js"
  (cd "$dir" && npm ci --no-audit --no-fund --loglevel=error && cp package-lock.json node_modules/.rig-installed-lock.json)
}

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#PACKAGES[@]} Debian packages present"
  install_js_clients
  exit 0
fi

echo "setup: installing ${missing[*]}"
SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
install_js_clients
