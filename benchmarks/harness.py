"""What every benchmark script shares: paths, timing, machine information and the results writer.

Scripts run as ``python3 benchmarks/<script>.py`` from anywhere. They import the project as the installed package
(``scripts/setup.sh`` installs it in editable mode; a worktree sets ``PYTHONPATH``), exactly as users and the
tests do, and no script edits ``sys.path``: Python puts ``benchmarks/`` first on the path of the script it runs,
which is how ``import harness`` and imports between benchmark scripts resolve. Which code was measured is
recorded in every results file (:func:`machine_info`: the package's folder and git commit), so a result
measured on another checkout than the one it is written into shows it, with a digest of that code
(``code_digest``, :mod:`freshness`): ``python3 benchmarks/stale.py`` lists the results whose code changed since.
Writing over an existing results file prints each figure's change against its previous value and flags a
regression above 20 % (:func:`freshness.compare`).

Nothing here imports torch, drjit or mitsuba: drjit must be imported after ``svcore.mi_env`` has found libLLVM,
and library versions come from the installed distributions' metadata instead.
"""
from __future__ import annotations

import argparse
import csv
import hashlib
import importlib.util
import json
import os
import platform
import re
import resource
import shlex
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from importlib import metadata
from pathlib import Path
from typing import Any, Callable, Iterable, NamedTuple

import freshness

#: repository root (the folder holding benchmarks/).
ROOT = Path(__file__).resolve().parents[1]
#: where results files are committed.
RESULTS = ROOT / "benchmarks" / "results"
#: where the README's charts are written.
IMG = ROOT / "docs" / "img"
#: the distributions whose versions every results file records.
LIBRARIES = ("numpy", "torch", "mitsuba", "drjit", "zarr", "numcodecs", "dask", "distributed", "matplotlib")


class Timing(NamedTuple):
    """The result of the last call and the median CPU (all threads of this process) and wall seconds."""

    result: Any
    cpu_s: float
    wall_s: float


def timed(f: Callable[[], Any], reps: int = 1) -> Timing:
    """Call ``f`` ``reps`` times; median CPU and wall seconds per call (the medians resist a shared machine)."""
    cpu, wall, out = [], [], None
    for _ in range(max(1, reps)):
        c, w = time.process_time(), time.perf_counter()
        out = f()
        cpu.append(time.process_time() - c)
        wall.append(time.perf_counter() - w)
    return Timing(out, float(statistics.median(cpu)), float(statistics.median(wall)))


#: ``svgen`` as a fresh process of this interpreter (the project importable through its PYTHONPATH).
SVGEN = [sys.executable, "-c", "from pipeline.cli import main; main()"]


def _tree_rss(pid: int) -> int:
    """Resident bytes of a process and all its descendants (0 once it is gone)."""
    import psutil

    try:
        p = psutil.Process(pid)
        procs = [p, *p.children(recursive=True)]
    except psutil.Error:
        return 0
    total = 0
    for q in procs:
        try:
            total += q.memory_info().rss
        except psutil.Error:
            pass
    return total


def run_child(argv: list[str], env: dict | None = None, cwd=None, peak_rss: bool = False) -> dict:
    """Run ``argv`` as a child process (output captured) and measure it; a failing command exits with the tail
    of its stderr.

    Returns:
        wall_s; user_s, sys_s and cpu_s (their sum) of the child and of the processes it reaped (its dask workers:
        the calling script must run nothing else meanwhile); with ``peak_rss``, peak_rss_bytes: the resident
        memory of its whole process tree, sampled every 0.2 s. Unrounded.
    """
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.Popen(argv, cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    peak, stop = [0], threading.Event()

    def poll():
        while not stop.is_set():
            peak[0] = max(peak[0], _tree_rss(proc.pid))
            stop.wait(0.2)

    sampler = threading.Thread(target=poll, daemon=True)
    if peak_rss:
        sampler.start()
    _, err = proc.communicate()
    wall = time.perf_counter() - t0
    stop.set()
    if peak_rss:
        sampler.join()
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"{shlex.join(map(str, argv))} failed (exit {proc.returncode}) in {cwd or '.'}:\n"
                         f"{err.strip()[-2000:]}")
    user, system = after.ru_utime - before.ru_utime, after.ru_stime - before.ru_stime
    out = {"wall_s": wall, "user_s": user, "sys_s": system, "cpu_s": user + system}
    return {**out, "peak_rss_bytes": peak[0]} if peak_rss else out


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor()


def _version(dist: str) -> str | None:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return None


def _code() -> dict:
    """Where the imported project lives and its git commit (``dirty`` when the tree has uncommitted changes)."""
    spec = importlib.util.find_spec("pipeline")
    where = Path(spec.origin).resolve().parents[1] if spec and spec.origin else None
    # the path relative to this repository ("." when the measured code is this checkout): results files hold no
    # absolute paths (they would leak one machine's layout and mean nothing elsewhere)
    out: dict[str, Any] = {"path": _relative(str(where)) if where else None, "commit": None, "dirty": None}
    if where is not None:
        try:
            git = ["git", "-C", str(where)]
            out["commit"] = subprocess.run(git + ["rev-parse", "HEAD"], capture_output=True, text=True,
                                           check=True, timeout=10).stdout.strip()
            out["dirty"] = bool(subprocess.run(git + ["status", "--porcelain", "--untracked-files=no"],
                                               capture_output=True, text=True, timeout=10).stdout.strip())
        except (OSError, subprocess.SubprocessError):
            pass
    return out


def machine_info() -> dict:
    """The machine and software a result was measured on; the same keys in every results file.

    Keys: platform, machine (architecture), cpu (model), cpus, python, versions (:data:`LIBRARIES`, None when
    not installed), threads (torch / drjit pools, None when the script has not imported them), loadavg_1min (at
    the time of the call: other work on the machine slows the figures down), code (the measured checkout).
    """
    torch, dr = sys.modules.get("torch"), sys.modules.get("drjit")
    return {
        "platform": platform.platform(), "machine": platform.machine(), "cpu": _cpu_model(),
        "cpus": os.cpu_count(), "python": platform.python_version(),
        "versions": {lib: _version(lib) for lib in LIBRARIES},
        "threads": {"torch": torch.get_num_threads() if torch else None,
                    "drjit": dr.thread_count() if dr else None},
        "loadavg_1min": round(os.getloadavg()[0], 2),
        "code": _code(),
    }


def parser(doc: str | None, note: bool = True) -> argparse.ArgumentParser:
    """An argument parser described by the first line of the script's docstring, with ``--note`` for scripts
    that write results (:func:`write_results`)."""
    ap = argparse.ArgumentParser(description=(doc or "").strip().split("\n")[0])
    if note:
        ap.add_argument("--note", default=None,
                        help="a note stored in the results (e.g. 'shared machine: rerun quietly before quoting')")
    return ap


def command() -> str:
    """The command line that ran this script, as a user would type it from the repository root."""
    script = Path(sys.argv[0]).resolve()
    try:
        script = script.relative_to(ROOT)
    except ValueError:
        pass
    return shlex.join(["python3", str(script), *sys.argv[1:]])


#: an absolute path inside a string: a "/" that does not follow a word, a dot, a colon or another slash (so not
#: "s/view", "./x" or "s3://bucket/key"), then at least two path components.
ABSOLUTE_PATH = re.compile(r"(?<![\w.~:/-])/[\w.+@-]+(?:/[\w.+@-]+)+")


def _relative(path: str, root: Path = ROOT) -> str:
    """``path`` relative to the repository ``root``; a temporary file as ``$TMPDIR/...``; else relative to
    ``root`` with ``..`` (never absolute)."""
    p = Path(path)
    tmp = Path(tempfile.gettempdir())
    if p.is_relative_to(root):
        return str(p.relative_to(root))
    if p.is_relative_to(tmp):
        return str("$TMPDIR" / p.relative_to(tmp))
    return os.path.relpath(p, root)


def repo_relative(obj: Any, root: Path = ROOT) -> Any:
    """``obj`` (JSON-able) with every absolute path inside its strings made relative (:func:`_relative`)."""
    if isinstance(obj, str):
        return ABSOLUTE_PATH.sub(lambda m: _relative(m.group(0), root), obj)
    if isinstance(obj, dict):
        return {k: repo_relative(v, root) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [repo_relative(v, root) for v in obj]
    return obj


def _with_history(entry: dict, previous: dict | None, code: Iterable[str], label: str) -> dict:
    """``entry`` with its ``code_digest`` (:func:`freshness.measured_code`) and, when the same results were
    measured before, its ``changes`` against them; the changes are printed (stderr), regressions flagged."""
    entry.setdefault("code_digest", freshness.measured_code(ROOT, code=code))
    if previous:
        changes = freshness.compare(previous, entry)
        entry["changes"] = freshness.changes_record(changes)
        for c in changes:
            print(f"{label}: {c.line()}", file=sys.stderr)
        if entry["changes"]["regressions"]:
            print(f"{label}: {len(entry['changes']['regressions'])} figure(s) regressed by more than "
                  f"{freshness.REGRESSION:.0%}: {', '.join(entry['changes']['regressions'])}", file=sys.stderr)
    return entry


def _previous(path: Path) -> dict:
    try:
        return json.loads(path.read_text()) if path.exists() else {}
    except (OSError, ValueError):
        return {}


def write_results(path: str | os.PathLike, result: dict, note: str | None = None, code: Iterable[str] = ()) -> Path:
    """Write a results JSON: ``result`` plus ``command``, ``machine`` (:func:`machine_info`), ``note``,
    ``code_digest`` (the code measured: the script, the benchmark modules and project packages it imported, and
    ``code``: packages a subprocess ran, e.g. ``("pipeline", "storage")``) and, when ``path`` held results
    before, ``changes`` (every figure against its previous value; regressions above 20 % flagged and printed).

    Keys the result already has win (a script may record its own command). Parent folders are created. Absolute
    paths (a store, an output folder, the measured checkout) are written relative to the repository
    (:func:`repo_relative`).

    Returns:
        The path written.
    """
    path = Path(path)
    out = {**result}
    out.setdefault("command", command())
    out.setdefault("machine", machine_info())
    if note is not None:
        out["note"] = note
    out = _with_history(out, _previous(path), code, _relative(str(path.resolve())))
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(repo_relative(out), indent=1) + "\n")
    return path


def update_results(path: str | os.PathLike, key: str, result: dict, note: str | None = None,
                   code: Iterable[str] = ()) -> Path:
    """Set ``key`` of a results JSON that several scripts share (read-modify-write: other keys are kept).

    ``result`` gets ``command``, ``machine`` (with the measured checkout's path relative to the repository, so
    the file holds no absolute path), ``note``, ``code_digest`` and ``changes`` (against the previous value of
    ``key``) like :func:`write_results`; keys it already has win.

    Returns:
        The path written.
    """
    path = Path(path)
    data = _previous(path)
    entry = {**result}
    entry.setdefault("command", command())
    if "machine" not in entry:
        entry["machine"] = machine_info()
        where = entry["machine"]["code"].get("path")
        if where is not None:
            entry["machine"]["code"]["path"] = os.path.relpath(where, ROOT)
    if note is not None:
        entry["note"] = note
    previous = data.get(key) if isinstance(data.get(key), dict) else None
    data[key] = _with_history(entry, previous, code, f"{_relative(str(path.resolve()))} {key}")
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, indent=1) + "\n")
    return path


def write_csv(path: str | os.PathLike, rows: Iterable[dict], columns: list[str] | None = None) -> Path:
    """Write dict rows as CSV with a header (``columns``, default the first row's keys, in order)."""
    rows = list(rows)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=columns or list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    return path


def tree_digest(path: str | os.PathLike) -> dict[str, str]:
    """relative file path -> sha256 of every file under ``path`` (byte-identity of stores)."""
    root = Path(path)
    return {str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(root.rglob("*")) if p.is_file()}


def pyplot():
    """matplotlib's pyplot on the file-only Agg backend (benchmarks and DVC stages have no display)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig, path: str | os.PathLike, dpi: float | None = None) -> Path:
    """Lay out, write (parent folders created) and close a matplotlib figure; returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    pyplot().close(fig)
    return path
