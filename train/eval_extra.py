"""``svtrain eval-extra``: evaluate a run on every renders store listed in params.yaml ``eval.extra_stores`` (e.g.
the 2018 test strips imported with ``svgen import --layout deschaintre --as renders``), the DVC stage ``eval_extra``.

Each store is evaluated in full (suite ``all``, at most ``eval.limit`` views) into ``<out>/stores/<name>/`` (with
``stores.json``: name -> path); ``<out>/eval_metrics.json`` holds the model's RMSE per column per store, what
`dvc metrics` and `dvc exp show` compare. An empty list writes an empty metrics file and evaluates nothing.
"""
from __future__ import annotations

import json
from pathlib import Path

from svcore.config import read_yaml
from svcore.errors import ConfigError

from .evaluate import COLUMNS, run_eval

SECTION, KEY = "eval", "extra_stores"


def extra_stores(params_file: str | Path) -> list[str]:
    """The store paths listed under ``eval.extra_stores`` (none when the key is absent)."""
    sec = read_yaml(params_file).get(SECTION) or {}
    stores = sec.get(KEY) or []
    if not isinstance(stores, list) or not all(isinstance(s, str) and s for s in stores):
        raise ConfigError(f"{params_file}: {SECTION}.{KEY} must be a list of renders store paths, got {stores!r}")
    return stores


def limit_of(params_file: str | Path) -> int | None:
    """``eval.limit``: views per store (None when absent), bounded like ``svtrain eval --limit`` (at least 1)."""
    limit = (read_yaml(params_file).get(SECTION) or {}).get("limit")
    if limit is not None and (type(limit) is not int or limit < 1):
        raise ConfigError(f"{params_file}: {SECTION}.limit must be an integer >= 1 (or null), got {limit!r}")
    return limit


def names_of(stores: list[str]) -> list[str]:
    """One folder name per store: its file name without ``.zarr`` (numbered where two would collide)."""
    names = []
    for s in stores:
        base = Path(s.rstrip("/")).name.removesuffix(".zarr") or "store"
        name, k = base, 1
        while name in names:
            k += 1
            name = f"{base}_{k}"
        names.append(name)
    return names


def run(checkpoint: str | Path, params_file: str | Path, out_dir: str | Path, device: str = "cpu") -> dict:
    """Evaluate ``checkpoint`` on every extra store; returns {name: {column: model RMSE}} (also eval_metrics.json)."""
    from . import dvc_metrics

    stores, limit = extra_stores(params_file), limit_of(params_file)
    out = Path(out_dir)
    (out / "stores").mkdir(parents=True, exist_ok=True)
    table = {}
    for name, store in zip(names_of(stores), stores):
        res = run_eval(checkpoint, out / "stores" / name, suite="all", store=store, limit=limit, device=device)
        table[name] = {c: res["model"][c] for c in COLUMNS}
    (out / "stores" / "stores.json").write_text(json.dumps(dict(zip(names_of(stores), stores)), indent=2) + "\n")
    dvc_metrics.write(out / dvc_metrics.EVAL_FILE, table)
    return table
