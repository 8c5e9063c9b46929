#!/usr/bin/env bash
# Where the render stage's CPU goes, kernel included: perf samples every CPU for SECONDS while
# `svgen render VARIANTS BLENDS OUT --config-preset paper --workers 2` runs (after a 12 s start), then the shares by
# shared object and by symbol go to results/perf_<label>.txt (#42).
#   bash experiments/chunk_buffers/perf_profile.sh ../ps2/variants.zarr ../ps2/blends.zarr after [SECONDS]
set -euo pipefail
cd "$(dirname "$0")/../.."
V=$1; B=$2; LABEL=$3; SECONDS_=${4:-15}
W=$(mktemp -d)
trap 'rm -rf "$W"' EXIT
SVGEN_NO_PROGRESS=1 PYTHONPATH=$PWD python3 -c "import sys; from pipeline.cli import main; sys.argv[0]='svgen'; main()" \
    render "$V" "$B" "$W/r.zarr" --config-preset paper --workers 2 > /dev/null 2>&1 &
sleep 12
perf record -a -g -o "$W/perf.data" -- sleep "$SECONDS_" 2> /dev/null
wait
OUT=experiments/chunk_buffers/results/perf_$LABEL.txt
{ echo "# perf record -a over ${SECONDS_} s of the render stage (2 workers, paper preset); shares of all samples"
  perf report -i "$W/perf.data" --no-children --sort dso --stdio -g none 2> /dev/null | grep '%' | head -12
  echo "# by symbol"
  perf report -i "$W/perf.data" --no-children --sort sym --stdio -g none 2> /dev/null | grep '%' | head -25
} > "$OUT"
cat "$OUT"
