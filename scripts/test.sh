#!/usr/bin/env bash
# The README's test command: set up (idempotent), then run the whole suite on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
export SVGEN_NO_PROGRESS=1
python3 -m pytest -n 2 --dist loadgroup -q tests "$@"
