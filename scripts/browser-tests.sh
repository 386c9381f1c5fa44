#!/usr/bin/env bash
# The console's end-to-end browser test (tests/browser/console.test.mjs): Debian's chromium
# driven by playwright-core from npm (no browser download), against `omnikin robot --sim` and
# `omnikin console` built by cargo. Installs chromium with apt and the npm packages with
# `npm ci` (package-lock.json) when they are missing; the whole run is bounded by
# BROWSER_TEST_TIMEOUT seconds (default 600).
#
# BROWSER_SKIP_UNAVAILABLE=1 skips loudly (exit 0) when chromium, node/npm or the npm registry
# cannot be had. SCREENSHOT_DIR=docs/figures keeps the page's screenshots (console*.png).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)

skip() {
  if [ "${BROWSER_SKIP_UNAVAILABLE:-0}" = 1 ]; then
    echo "SKIPPED browser tests: $*" >&2
    exit 0
  fi
  echo "browser tests: $*" >&2
  exit 1
}

CHROMIUM=${CHROMIUM:-/usr/bin/chromium}
need=()
[ -x "$CHROMIUM" ] || need+=(chromium)
command -v node >/dev/null 2>&1 || need+=(nodejs)
command -v npm >/dev/null 2>&1 || need+=(npm)
if [ ${#need[@]} -gt 0 ] && command -v apt-get >/dev/null 2>&1; then
  sudo=""
  [ "$(id -u)" -ne 0 ] && command -v sudo >/dev/null && sudo="sudo -n"
  echo "installing ${need[*]} with apt-get" >&2
  ($sudo apt-get update -qq && DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq \
    "${need[@]}") >/dev/null 2>&1 || true
fi
[ -x "$CHROMIUM" ] || skip "no chromium at $CHROMIUM (apt-get install chromium)"
command -v node >/dev/null 2>&1 || skip "node not found (apt-get install nodejs)"
command -v npm >/dev/null 2>&1 || skip "npm not found (apt-get install npm)"
node -e 'process.exit(Number(process.versions.node.split(".")[0]) < 18 ? 1 : 0)' || skip "node $(node --version) is older than 18"

# playwright-core only: its install step downloads no browser (PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD
# makes sure of it).
export PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD=1
(cd tests/browser && npm ci --no-audit --no-fund --loglevel=error) \
  || skip "npm ci failed in tests/browser (no npm registry?)"
cargo build -p omnikin-cli --locked --quiet
export OMNIKIN_BIN="$root/target/debug/omnikin" CHROMIUM
[ -n "${SCREENSHOT_DIR:-}" ] && export SCREENSHOT_DIR="$(cd "$SCREENSHOT_DIR" && pwd)"
cd tests/browser
timeout --kill-after=10 "${BROWSER_TEST_TIMEOUT:-600}" \
  node --test --test-concurrency=1 --test-timeout=240000 console.test.mjs
