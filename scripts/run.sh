#!/usr/bin/env bash
# The README's "main job": set up (idempotent), then run the whole pipeline with DVC on the small default
# configuration of params.yaml: sample -> blend -> render -> fit -> eval, the stress suite and the charts.
# Extra arguments go to `dvc repro` (e.g. a stage name, or --force).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
dvc repro "$@"
echo
echo "== held-out evaluation (runs/eval/eval.md)"; cat runs/eval/eval.md
echo "== stress suite (runs/eval_stress/eval.md)"; cat runs/eval_stress/eval.md
echo "charts: runs/charts/  metrics: dvc metrics show  plots: dvc plots show"
