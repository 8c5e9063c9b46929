"""Is a figure still the code's? The code digest a results file records, and the change a re-measurement makes.

**Code digest.** Every results file written through :mod:`harness` records ``code_digest``: a sha256 per piece of
code the measurement ran, keyed by its path relative to the repository:

* the benchmark script itself (``benchmarks/bench_x.py``) and the other benchmark modules it imported
  (``benchmarks/ablation_effects.py``), one digest per file;
* each project package it imported (``pipeline/``, ``storage/``, ...: a top-level folder with ``__init__.py``),
  one digest per package over all its files.

Why per top-level package and not one digest of the whole tree: one digest would call every figure stale after
any edit (a training change would flag the material benchmark), and a digest per module would need the import
graph of every run, worker processes included. A package is what a benchmark exercises as a whole, and what it
imports is what ran (``sys.modules`` when the results are written). The harness itself (and this module) is left
out: it writes the figures, it does not make them, and including it would flag every file at once; so are the
chart builders (``benchmarks/charts/``), which draw them. A script whose
work runs in a subprocess (``svgen ...``) names the packages that subprocess runs (``write_results(code=...)``).

``python3 benchmarks/stale.py`` recomputes each recorded digest on the checkout: a results file is *stale* when
one differs, *fresh* when all match and *unknown* when it records none (written before digests were recorded).

**Regressions.** When a script writes a results file that already exists, every numeric figure of both (nested
keys joined with ".") is compared with its previous value; the direction in which a figure is better comes from
its name (:func:`direction`) and a change for the worse above :data:`REGRESSION` (20 %) is a regression. The
comparison is printed and recorded in the new file (``changes``).
"""
from __future__ import annotations

import hashlib
import re
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable

#: repository root (the folder holding benchmarks/).
ROOT = Path(__file__).resolve().parents[1]
#: benchmark modules that write figures without making them: not part of any measured code.
NOT_MEASURED = frozenset({"harness", "freshness"})
#: top-level folders with an ``__init__.py`` that are not project code a benchmark measures.
NOT_PACKAGES = frozenset({"tests", "benchmarks", "scripts"})
#: a figure changed for the worse by more than this fraction of its previous value is a regression.
REGRESSION = 0.20
#: keys of a results file that are not figures (never compared).
META = frozenset({"machine", "command", "note", "code_digest", "changes", "versions", "threads"})

# -- code digest ----------------------------------------------------------------------------------------------


def file_digest(path: Path) -> str | None:
    """sha256 (hex) of a file's bytes; None when it does not exist."""
    return hashlib.sha256(path.read_bytes()).hexdigest() if path.is_file() else None


def package_digest(folder: Path) -> str | None:
    """sha256 (hex) of every file of a package folder (relative path and bytes, in path order; bytecode caches
    left out); None when the folder does not exist."""
    if not folder.is_dir():
        return None
    h = hashlib.sha256()
    for f in sorted(folder.rglob("*")):
        if f.is_file() and "__pycache__" not in f.parts and f.suffix != ".pyc":
            h.update(str(f.relative_to(folder)).encode() + b"\0" + f.read_bytes() + b"\0")
    return h.hexdigest()


def digest_of(key: str, root: Path = ROOT) -> str | None:
    """The digest of one recorded key on the checkout at ``root``: ``pkg/`` a package, else a file."""
    return package_digest(root / key) if key.endswith("/") else file_digest(root / key)


def _is_package(folder: Path) -> bool:
    return (folder / "__init__.py").is_file()


def measured_code(root: Path = ROOT, script: str | Path | None = None, code: Iterable[str] = (),
                  modules: dict[str, Any] | None = None) -> dict[str, str]:
    """The code a measurement ran: path relative to ``root`` -> sha256 (the module docstring says what counts).

    Args:
        root: the repository root the keys are relative to.
        script: the benchmark script (default: the command's script, ``sys.argv[0]``, when it lies under ``root``).
        code: further project packages (``"pipeline"``) or files relative to ``root`` the measurement ran in
            another process.
        modules: the imported modules (default ``sys.modules``).

    Returns:
        key -> digest, keys sorted: ``benchmarks/x.py`` for files, ``pkg/`` for packages. A project package is
        digested where it was imported from (the measured code, which may be another checkout).
    """
    modules = sys.modules if modules is None else modules
    out: dict[str, str] = {}
    if script is None:
        script = sys.argv[0] if sys.argv and sys.argv[0] else None
    if script is not None:
        p = Path(script).resolve()
        if p.is_relative_to(root):
            out[str(p.relative_to(root))] = file_digest(p)
    bench = root / "benchmarks"
    for name, mod in list(modules.items()):
        f = getattr(mod, "__file__", None)
        if not f:
            continue
        p = Path(f).resolve()
        if "." not in name and p.parent == bench.resolve() and name not in NOT_MEASURED:
            out[str(p.relative_to(root))] = file_digest(p)
        elif "." not in name and p.name == "__init__.py" and name not in NOT_PACKAGES and _is_package(root / name):
            out[f"{name}/"] = package_digest(p.parent)  # a project package, where it was imported from
    for c in code:
        key = f"{c.rstrip('/')}/" if _is_package(root / c.rstrip("/")) else c
        out[key] = digest_of(key, root)
    return {k: out[k] for k in sorted(out) if out[k] is not None}


def changed_code(recorded: dict[str, str], root: Path = ROOT, cache: dict | None = None) -> list[str]:
    """The keys of a recorded code digest whose code differs on the checkout at ``root`` (or is gone).

    ``cache`` (key -> digest at ``root``), when given, keeps the digests computed for the next call: a survey of
    many files digests each package once."""
    cache = {} if cache is None else cache
    for k in recorded:
        if k not in cache:
            cache[k] = digest_of(k, root)
    return [k for k, v in sorted(recorded.items()) if cache[k] != v]


def recorded_digests(results: dict) -> dict[str, dict[str, str]]:
    """Every code digest a results file records: ``""`` -> the file's own, ``entry`` -> that of an entry
    written by ``update_results`` (files several scripts share)."""
    out = {}
    if isinstance(results.get("code_digest"), dict):
        out[""] = results["code_digest"]
    for k, v in results.items():
        if isinstance(v, dict) and isinstance(v.get("code_digest"), dict):
            out[k] = v["code_digest"]
    return out


@dataclass
class Freshness:
    """The state of one results file: ``"fresh"``, ``"stale"`` or ``"unknown"`` (no digest recorded), and for a
    stale one the changed code (``entry: key``, or the key alone for the file's own digest)."""

    state: str
    changed: list[str]


def freshness(results: dict, root: Path = ROOT, cache: dict | None = None) -> Freshness:
    """Whether the code a results file measured is still the code at ``root`` (``cache``: :func:`changed_code`)."""
    digests = recorded_digests(results)
    if not digests:
        return Freshness("unknown", [])
    changed = [f"{entry}: {k}" if entry else k for entry, rec in digests.items()
               for k in changed_code(rec, root, cache)]
    return Freshness("stale" if changed else "fresh", changed)

# -- regressions ----------------------------------------------------------------------------------------------


#: name tokens of a time unit: "per" followed by one makes a rate (higher is better: variants_per_s).
TIME_UNITS = frozenset({"s", "sec", "second", "seconds", "ms", "min", "minute", "h", "hour", "step"})
#: name tokens of a cost (lower is better): time, memory, disk, error.
COST = frozenset({"s", "sec", "seconds", "ms", "us", "min", "minutes", "h", "hours", "wall", "cpu", "time",
                  "latency", "bytes", "kb", "mb", "gb", "kib", "mib", "gib", "rss", "memory", "disk", "loss",
                  "error", "err", "rmse", "mse", "mae", "l1", "l2"})
#: name tokens of a benefit (higher is better) when the name has no cost token.
BENEFIT = frozenset({"speedup", "throughput", "fps", "psnr", "ssim", "accuracy", "rate"})


def direction(name: str) -> int:
    """+1 when a higher value of the figure ``name`` is better, -1 when lower is better, 0 when the name does not
    say (the change is shown, never flagged).

    The rule, on the name's tokens (split at "_" and "."): "per" followed by a time unit is a rate, higher is
    better (``variants_per_s``, ``it_per_s``); else a cost token (a time, a size, an error: ``wall_s``,
    ``cpu_s_per_view``, ``bytes_per_view``, ``peak_rss_mb``, ``rmse``) means lower is better; else a benefit token
    (``speedup``, ``psnr``) means higher is better.
    """
    tokens = [t for t in re.split(r"[_.]", name.lower()) if t]
    if any(t == "per" and n in TIME_UNITS for t, n in zip(tokens, tokens[1:])):
        return 1
    if any(t in COST for t in tokens):
        return -1
    if any(t in BENEFIT for t in tokens):
        return 1
    return 0


def figures(results: Any, prefix: str = "") -> dict[str, float]:
    """The numeric figures of a results file: dotted key -> value (booleans, lists and :data:`META` keys left
    out)."""
    out: dict[str, float] = {}
    if isinstance(results, dict):
        for k, v in results.items():
            if k in META:
                continue
            key = f"{prefix}{k}"
            if isinstance(v, dict):
                out.update(figures(v, key + "."))
            elif isinstance(v, (int, float)) and not isinstance(v, bool):
                out[key] = float(v)
    return out


@dataclass
class Change:
    """One figure measured again: its previous and new value, the relative change, the better direction
    (:func:`direction`) and whether it is a regression (worse by more than :data:`REGRESSION`)."""

    figure: str
    before: float
    after: float
    change: float | None
    direction: int
    regression: bool

    def line(self) -> str:
        pct = "n/a" if self.change is None else f"{100 * self.change:+.1f} %"
        flag = "  REGRESSION" if self.regression else ""
        return f"{self.figure}: {self.before:.6g} -> {self.after:.6g} ({pct}){flag}"


def compare(previous: dict, now: dict, threshold: float = REGRESSION) -> list[Change]:
    """The figures of ``now`` that ``previous`` also has and that changed, with the regressions flagged."""
    old, new = figures(previous), figures(now)
    out = []
    for k in sorted(set(old) & set(new)):
        a, b = old[k], new[k]
        if a == b:
            continue
        rel = (b - a) / abs(a) if a != 0 else None
        d = direction(k)
        worse = rel is not None and d != 0 and -d * rel > threshold
        out.append(Change(k, a, b, rel, d, worse))
    return out


def changes_record(changes: list[Change]) -> dict:
    """The ``changes`` key of a results file: the figures whose better direction is known, before and after."""
    return {"threshold": REGRESSION,
            "regressions": [c.figure for c in changes if c.regression],
            "figures": {c.figure: {"before": c.before, "after": c.after,
                                   "change": None if c.change is None else round(c.change, 4),
                                   "higher_is_better": c.direction > 0}
                        for c in changes if c.direction != 0}}
