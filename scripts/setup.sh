#!/usr/bin/env bash
# Set up svgen on a fresh Debian 12 machine (Python 3.11): the system libLLVM for drjit,
# the CPU build of torch, then the project (editable) with its test extras.
# Idempotent: a second run installs nothing new.
set -euo pipefail
cd "$(dirname "$0")/.."

have_llvm() { ls /usr/lib/llvm-1[6-9]/lib/libLLVM*.so* /usr/lib/llvm-2[0-9]/lib/libLLVM*.so* >/dev/null 2>&1; }
# headless Chromium: tests/test_gallery.py opens `svgen gallery`'s page in it (the tests skip without it)
have_chromium() { command -v chromium >/dev/null 2>&1 || command -v chromium-browser >/dev/null 2>&1; }
if ! have_llvm || ! have_chromium; then
  if command -v apt-get >/dev/null 2>&1; then
    SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
    $SUDO apt-get update -qq
    have_llvm || DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq libllvm19
    have_chromium || DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq chromium
  elif ! have_llvm; then
    echo "svgen setup: install libLLVM >= 16 (e.g. libllvm19) with your package manager" >&2; exit 1
  else
    echo "svgen setup: no chromium (optional: the gallery's browser test skips without it)" >&2
  fi
fi

PY=${PYTHON:-python3}
# torch first and pinned: an unpinned torch pulls a multi-GB CUDA build.
$PY -m pip install -q --disable-pip-version-check "torch==2.13.0"
$PY -m pip install -q --disable-pip-version-check -e ".[dev]"
$PY - <<'PY'
from svcore.mi_env import load_mitsuba
mi = load_mitsuba()
print("svgen setup: ok, mitsuba", mi.__version__, "variant", mi.variant())
PY
