"""``svtrain eval-reference``: a run evaluated on the reference renders store (``svgen reference``: real materials
rendered with the training views), the DVC stage ``eval_reference``.

Every view is evaluated (suite ``all``: training never saw the reference), with the paired bootstrap intervals
over materials (:func:`train.evaluate.paired`), into ``<out>/eval/`` (eval.json, eval.md, per_view.csv, eval.png);
``<out>/eval_metrics.json`` holds what `dvc metrics` compares. With params.yaml ``reference.sources`` empty (the
default) the reference stage wrote no store: one line says so and the metrics file is empty.
"""
from __future__ import annotations

import json
from pathlib import Path

from svcore.config import params_section
from svcore.errors import ConfigError

from .evaluate import run_eval

EVAL_DIR = "eval"


def run(checkpoint: str | Path, params_file: str | Path, store: str | Path, out_dir: str | Path,
        device: str = "cpu") -> dict | None:
    """Evaluate ``checkpoint`` on ``store`` in full when the params file lists reference sources.

    Returns:
        the eval result (:func:`train.evaluate.run_eval`), or None when ``reference.sources`` is empty (then
        ``<out>/eval_metrics.json`` is ``{}`` and ``<out>/eval/`` is empty).

    Raises:
        ConfigError: a bad ``reference`` section. StoreError: sources listed but no finished store at ``store``.
    """
    from . import dvc_metrics

    # the section as plain values: train reads no pipeline config class (tests/test_layout.py); `svgen reference`
    # validated the same section when it wrote the store
    section = params_section(params_file, "reference") if Path(params_file).exists() else {}
    sources = section.get("sources") or []
    if not isinstance(sources, list):
        raise ConfigError(f"reference.sources must be a list of folders, got {sources!r}")
    out = Path(out_dir)
    (out / EVAL_DIR).mkdir(parents=True, exist_ok=True)
    if not sources:
        dvc_metrics.write(out / dvc_metrics.EVAL_FILE, {})
        return None
    res = run_eval(checkpoint, out / EVAL_DIR, suite="all", store=str(store), device=device)
    metrics = dvc_metrics.eval_metrics(res)
    metrics["crop"] = float(section.get("crop", 1.0))
    dvc_metrics.write(out / dvc_metrics.EVAL_FILE, metrics)
    return res


def summary(res: dict | None) -> str:
    """One JSON line for stdout: the model's RMSE per column, or {} when nothing was evaluated."""
    from .evaluate import COLUMNS

    return json.dumps({} if res is None else {c: res["model"][c] for c in COLUMNS})
