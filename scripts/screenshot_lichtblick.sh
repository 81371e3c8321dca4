#!/usr/bin/env bash
# A screenshot of Lichtblick showing the mock rig live through `rig view` (docs/viewing.md).
#
#   scripts/screenshot_lichtblick.sh LICHTBLICK_WEB_BUILD [OUT.png]
#
# LICHTBLICK_WEB_BUILD: the output of Lichtblick's `yarn web:build:prod` (its web/.webpack directory).
# Built from a git checkout with LFS content: a `git archive` without it has pointer files instead of
# the fonts (styles/assets/*.woff2), and the app stops at start-up on "NetworkError" loading them.
# Needs: build/rig, python3, node + npm (for puppeteer-core), chromium (CHROMIUM, default
# /usr/bin/chromium). Starts a static web server, `rig up config/mock_rig.yaml`, `rig view`, headless
# Chromium; stops all of them on exit, `rig up` with SIGTERM so it removes what it set up (loopback
# addresses, shared memory).
set -euo pipefail
web=$(realpath "${1:?usage: $0 LICHTBLICK_WEB_BUILD [OUT.png]}")
out=${2:+$(realpath -m "$2")}
cd "$(dirname "$0")/.."
root=$PWD out=${out:-$PWD/docs/img/lichtblick-mock-rig.png}
http_port=${HTTP_PORT:-8080} ws_port=${WS_PORT:-8765}
[[ -f $web/index.html ]] || { echo "no index.html in $web" >&2; exit 1; }

pids=()
tmp=$(mktemp -d)
cleanup() {
  # Reverse order, the viewer server before the rig. SIGTERM, not SIGINT: background jobs of a
  # non-interactive shell ignore SIGINT (python's http.server does); `rig up` stops cleanly on both.
  for ((i = ${#pids[@]} - 1; i >= 0; i--)); do
    kill -TERM "${pids[i]}" 2>/dev/null || true
    wait "${pids[i]}" 2>/dev/null || true
  done
  rm -rf "$tmp"
}
trap cleanup EXIT
trap 'exit 130' INT TERM # -> cleanup via EXIT

# puppeteer-core drives the system Chromium (no browser download); installed into a temp dir.
(cd "$tmp" && npm init -y >/dev/null && PUPPETEER_SKIP_DOWNLOAD=1 npm install --silent puppeteer-core >/dev/null)

# The web app is static files; the browser connects from it to ws://127.0.0.1:$ws_port itself.
python3 -m http.server "$http_port" --bind 127.0.0.1 -d "$web" >"$tmp/http.log" 2>&1 & pids+=($!)
build/rig up config/mock_rig.yaml >"$tmp/up.log" 2>&1 & pids+=($!)
sleep 10 # drivers, mock devices and fusion up and publishing
build/rig view --port "$ws_port" >"$tmp/view.log" 2>&1 & pids+=($!)
sleep 2

mkdir -p "$(dirname "$out")"
(cd "$tmp" && node "$root/scripts/screenshot_lichtblick.mjs" "$out" "http://127.0.0.1:$http_port/" "ws://127.0.0.1:$ws_port")
