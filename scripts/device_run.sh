#!/usr/bin/env bash
# The prepared GPU run (docs/GPU.md): install the wheels carried in .device/wheels (scripts/device_wheels.py made
# them here) into /tmp/site, then scripts/device_run.py with this script's arguments (its --help lists them).
# On the lent GPU machine:  bash scripts/device_run.sh        (writes $OUT/device_run.json, the log, the model)
# Tests run it at a tiny size with SVGEN_DEVICE_WHEELS pointing nowhere, on this machine's own packages.
set -uo pipefail
cd "$(dirname "$0")/.."
wheels=${SVGEN_DEVICE_WHEELS-.device/wheels}
if compgen -G "$wheels/*.whl" > /dev/null; then
  python3 -c "import lzma" || { echo "device_run: this Python cannot read LZMA: the carried wheels need it" >&2; exit 3; }
  python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site \
    "$wheels"/*.whl || { echo "device_run: installing the carried wheels failed" >&2; exit 3; }
  export PYTHONPATH=/tmp/site${PYTHONPATH:+:$PYTHONPATH}
fi
export PYTHONPATH=$PWD${PYTHONPATH:+:$PYTHONPATH} PYTHONUNBUFFERED=1 SVGEN_NO_PROGRESS=1
exec python3 scripts/device_run.py "$@"
