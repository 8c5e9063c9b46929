"""The realism chart (docs/img/chart_realism.png) redrawn from benchmarks/results/realism.json alone (key
"statistics", written by bench_realism.py): histograms of every statistic, svgen's library beside the reference,
the octave shares of slope power and every distance as a multiple of the reference's noise floor.

Usage: python3 benchmarks/charts/realism.py [realism.json] [out.png]
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

if not __package__:  # run as a file (python3 benchmarks/charts/...): harness.py is one folder up
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from harness import IMG, RESULTS  # noqa: E402

DEFAULT_JSON = RESULTS / "realism.json"
DEFAULT_PNG = IMG / "chart_realism.png"


def plot(json_path: str | Path = DEFAULT_JSON, png_path: str | Path = DEFAULT_PNG) -> Path | None:
    """Draw the chart from the JSON's "statistics" report; None when the file holds none (run the benchmark)."""
    from pipeline.stats.realism_chart import chart

    data = json.loads(Path(json_path).read_text())
    if "statistics" not in data:
        return None
    return chart(data["statistics"]["report"], png_path)


if __name__ == "__main__":
    made = plot(*sys.argv[1:3])
    print(made or "no 'statistics' in the results: run benchmarks/bench_realism.py first")
