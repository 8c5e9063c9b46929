"""The small, flat metrics files that `dvc metrics show` compares across runs (``fit_metrics.json``,
``eval_metrics.json``).

Why separate files: ``metrics.json`` and ``eval.json`` are artefacts holding everything a run knows (booleans,
device names, machine-dependent it/s, bootstrap intervals, per-group baselines: 418 columns under
`dvc metrics show`); a metric is a number worth comparing between experiments. These files keep only such
numbers, at most one level deep, so the table stays readable: the training loss and size, the held-out table
(model and baselines, every column), and the model's re-render error per stress group.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

#: the held-out table's columns (the re-render error, then one per map): what evaluation measures and what
#: DVC compares; defined here, the lower module, so the evaluation imports it and nothing imports back.
COLUMNS = ("rerender", "normal", "diffuse", "roughness", "specular")
FIT_FILE = "fit_metrics.json"
EVAL_FILE = "eval_metrics.json"

#: metrics.json keys kept for DVC (numbers that say how training went, not how fast this machine was).
FIT_KEYS = ("step", "loss_first", "loss_final", "parameters", "train_samples", "test_samples")
METHODS = ("model", "input_as_diffuse", "dataset_mean")


def _number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def fit_metrics(metrics: dict) -> dict[str, float]:
    """The :data:`FIT_KEYS` of a fit's metrics dict that are numbers (``loss_final`` is None after 0 steps)."""
    return {k: metrics[k] for k in FIT_KEYS if _number(metrics.get(k))}


def eval_metrics(res: dict) -> dict:
    """One-group suites: {method: {column: RMSE}} of the model and the baselines, and ``samples``; several groups
    (stress): {group: the model's re-render RMSE}, and ``samples`` (their total)."""
    if "groups" in res:
        groups = res["groups"]
        return {**{g: r["model"]["rerender"] for g, r in groups.items()},
                "samples": sum(int(r["samples"]) for r in groups.values())}
    return {**{m: {c: res[m][c] for c in COLUMNS} for m in METHODS}, "samples": int(res["samples"])}


def write(path: Path, values: dict) -> Path:
    """Write ``values`` as indented JSON to ``path``."""
    path.write_text(json.dumps(values, indent=2) + "\n")
    return path
