"""What a data stage's process costs before its first sample: fresh `svgen` processes on tiny inputs, per checkout.

Each command runs in a fresh Python process (as `dvc repro`, a shell or a dask worker starts one) on inputs so small
that the process's start (imports, config, store open) is most of it. Several checkouts can be measured in the same
run, their repetitions interleaved (this VM's speed drifts by minutes): e.g. the parent commit in a git worktree
against this checkout.

    git worktree add /tmp/before HEAD~1
    python3 benchmarks/bench_cli_start.py --checkout before=/tmp/before --checkout after=. --reps 5 \\
        -> benchmarks/results/cli_start.json

Figures: per checkout and command, the median wall seconds and CPU seconds (user + system of the process) over the
repetitions; ``import_colour`` is `python3 -c "import colour"` alone (colour-science's package import).
"""
from __future__ import annotations

import os
import statistics
import sys
import tempfile
from pathlib import Path

from harness import RESULTS, SVGEN, parser, run_child, write_results

#: name -> svgen arguments ({d}: the repetition's scratch folder; variants.zarr there is made first by "sample")
COMMANDS = {
    "sample": ["sample", "{d}/v.zarr", "--per-preset", "1", "--size", "64", "--class", "wood", "--workers", "0"],
    "blend": ["blend", "{d}/v.zarr", "{d}/b.zarr", "--count", "4", "--workers", "0"],
    "render": ["render", "{d}/v.zarr", "{d}/r.zarr", "--views", "1", "--res", "64", "--workers", "0"],
    "stress": ["stress", "{d}/s.zarr", "--per-category", "1", "--size", "64", "--category", "glossy_saturated",
               "--workers", "0"],
}


def run_once(checkout: Path, argv: list[str]) -> tuple[float, float]:
    """(wall s, CPU s) of one fresh process running ``argv`` with ``checkout``'s modules."""
    m = run_child(argv, {**os.environ, "PYTHONPATH": str(checkout), "SVGEN_NO_PROGRESS": "1"}, cwd=checkout)
    return m["wall_s"], m["cpu_s"]


def main() -> None:
    p = parser(__doc__)
    p.add_argument("--checkout", action="append", default=[], metavar="LABEL=PATH",
                   help="a checkout to measure (repeatable; default: this one as 'now')")
    p.add_argument("--reps", type=int, default=5)
    p.add_argument("--out", default=str(RESULTS / "cli_start.json"))
    a = p.parse_args()
    checkouts = dict(c.split("=", 1) for c in a.checkout) or {"now": "."}
    checkouts = {k: Path(v).resolve() for k, v in checkouts.items()}
    samples: dict[str, dict[str, list[tuple[float, float]]]] = {k: {} for k in checkouts}
    for rep in range(a.reps):
        for label, where in checkouts.items():  # interleaved: each repetition measures every checkout in turn
            with tempfile.TemporaryDirectory() as d:
                for name, args in COMMANDS.items():
                    argv = SVGEN + [x.format(d=d) for x in args]
                    samples[label].setdefault(name, []).append(run_once(where, argv))
                samples[label].setdefault("import_colour", []).append(
                    run_once(where, [sys.executable, "-c", "import colour"]))
        print(f"rep {rep + 1}/{a.reps}", file=sys.stderr)
    result = {"benchmark": "cli_start", "reps": a.reps, "commands": {k: " ".join(v) for k, v in COMMANDS.items()},
              "checkouts": {}}
    for label, by_cmd in samples.items():
        result["checkouts"][label] = {
            name: {"wall_s": round(statistics.median(w for w, _ in s), 3),
                   "cpu_s": round(statistics.median(c for _, c in s), 3)} for name, s in by_cmd.items()}
    for name in COMMANDS:
        print(name, {label: result["checkouts"][label][name] for label in checkouts}, file=sys.stderr)
    write_results(a.out, result, note=a.note, code=("pipeline", "materials", "storage", "svcore"))


if __name__ == "__main__":
    main()
