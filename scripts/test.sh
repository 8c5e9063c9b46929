#!/usr/bin/env bash
# The README's test command: set up (idempotent), then run the whole suite on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
export SVGEN_NO_PROGRESS=1
# the whole run within 75 minutes (CI allows 90): a hang outside any test (a worker that never exits) then ends
# with the output so far and a non-zero exit instead of no output at all; each test has its own limit (pyproject)
timeout --kill-after=60 4500 python3 -m pytest -n 2 --dist loadgroup -q tests "$@"
