#!/usr/bin/env bash
# The comparison report's browser test (tests/test_report_browser.py) opens the page in
# headless Chromium, driven by playwright; playwright's own browser download cannot reach its
# host, so the test uses Debian's `chromium` package. Install it when missing (as root, or
# with sudo), after `apt-get update` (a fresh machine's package lists may be empty).
# Idempotent: does nothing when /usr/bin/chromium is there. When it cannot be installed (no
# root, no apt, no network) it says so and exits 0: that one test is then skipped, with the
# reason, and everything else still runs.
set -uo pipefail

CHROMIUM=${LABCUT_CHROMIUM:-/usr/bin/chromium}
if [ -x "$CHROMIUM" ]; then
  echo "chromium found ($CHROMIUM): the report's browser test can run."
  exit 0
fi

skip() {
  echo "warning: $1; tests/test_report_browser.py will be skipped." >&2
  echo "         Install it with: sudo apt-get update && sudo apt-get install -y chromium" >&2
  exit 0
}

command -v apt-get >/dev/null 2>&1 || skip "chromium is missing and apt-get is not available"
if [ "$(id -u)" -eq 0 ]; then
  SUDO=""
elif command -v sudo >/dev/null 2>&1 && sudo -n true 2>/dev/null; then
  SUDO="sudo -n"
else
  skip "chromium is missing and installing it needs root"
fi

echo "chromium not found; installing Debian's chromium (for the report's browser test) ..."
export DEBIAN_FRONTEND=noninteractive
log=$(mktemp)
if ! $SUDO apt-get update -qq >"$log" 2>&1 || ! $SUDO apt-get install -y -qq chromium >>"$log" 2>&1; then
  tail -n 5 "$log" >&2
  rm -f "$log"
  skip "apt-get could not install chromium"
fi
rm -f "$log"
[ -x "$CHROMIUM" ] || skip "chromium was installed but $CHROMIUM is missing"
echo "chromium installed."
