#!/usr/bin/env bash
# Dr.Jit 1.5's LLVM backend aborts ("LLVM ERROR: Cannot select ... fmaximum") on
# libLLVM 14, 15 and 16, Debian 12's defaults. Install Debian's libllvm19 when no
# libLLVM >= 17 is present. Idempotent: does nothing when a good one is there.
set -euo pipefail

best=0
for f in /usr/lib/x86_64-linux-gnu/libLLVM*.so* /usr/lib/aarch64-linux-gnu/libLLVM*.so* \
         /usr/lib/libLLVM*.so* /usr/local/lib/libLLVM*.so* ${DRJIT_LIBLLVM_PATH:-}; do
  [ -e "$f" ] || continue
  v=$(basename "$f" | sed -nE 's/^libLLVM(-|\.so\.)?([0-9]+).*/\2/p')
  [ -n "$v" ] && [ "$v" -gt "$best" ] && best=$v
done

if [ "$best" -ge 17 ]; then
  echo "libLLVM $best found: Dr.Jit's LLVM backend can run."
  exit 0
fi

echo "No libLLVM >= 17 found (newest: ${best}); installing Debian's libllvm19 ..."
if [ "$(id -u)" -eq 0 ]; then
  SUDO=""
elif command -v sudo >/dev/null 2>&1 && sudo -n true 2>/dev/null; then
  SUDO="sudo -n"
else
  echo "error: need root to install libllvm19: run 'sudo apt-get update && sudo apt-get install -y libllvm19'" >&2
  exit 1
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq libllvm19 >/dev/null
echo "libllvm19 installed."
