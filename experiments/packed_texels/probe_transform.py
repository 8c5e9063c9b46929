"""The view transform alone, before and after the packed texels, on one drjit thread (#42).

Each arm runs in its own process with its own tree on ``PYTHONPATH`` (the code before from a git worktree of
``--before``; after: this checkout): ``--svbrdfs`` library variants at ``--res`` (generated the same way in both),
10 drawn views each, every view's ``transform_planes`` timed (CPU) after one untimed pass that compiles the kernels.
Before, the transform reads the maps as 10 planes (``planes_of``); after, as packed texels (``texels_of``). The
arms alternate for ``--rounds`` rounds; the outputs of the first round are compared bit for bit.

    python3 experiments/packed_texels/probe_transform.py --before 25e5d83   # -> results/probe_transform.json
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]


def worker(res: int, svbrdfs: int, out: str) -> None:
    """In the arm's process: time every view's transform; write the ms per view and the first view planes."""
    import time

    import materials
    from svcore.mi_env import use_variant

    use_variant("llvm_ad_rgb")
    from svcore.mi_env import dr
    from pipeline.render.views import R_MAX, R_MIN, draw_views
    import storage.views as V

    dr.set_thread_count(1)
    pack = getattr(V, "texels_of", V.planes_of)
    presets = materials.presets()[:: max(1, len(materials.presets()) // svbrdfs)][:svbrdfs]
    jobs = [(pack(p.generate(None, res, i)), draw_views(0, i, 10, (R_MIN, R_MAX), (0.7, 1.4)))
            for i, p in enumerate(presets)]
    outs, t = [], 0.0
    for timed in (False, True):
        for base, views in jobs:
            for v in views:
                a = time.process_time()
                planes = V.transform_planes(base, res, v, res)
                dr.eval(planes)
                dr.sync_thread()
                t += (time.process_time() - a) if timed else 0.0
                if timed:
                    outs.append(np.stack([np.asarray(p) for p in planes]))
    np.savez(out, planes=np.stack(outs), ms=1000 * t / len(outs), packed=pack is not V.planes_of)


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--before", required=True)
    ap.add_argument("--res", type=int, default=288)
    ap.add_argument("--svbrdfs", type=int, default=8)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--note", default="")
    ap.add_argument("--out", default=str(Path(__file__).parent / "results" / "probe_transform.json"))
    a = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="probe_transform_") as tmp:
        old = Path(tmp) / "before"
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(old), a.before], check=True,
                       capture_output=True)
        try:
            ms, first = {"before": [], "after": []}, {}
            for r in range(a.rounds):
                for arm in ("before", "after") if r % 2 == 0 else ("after", "before"):
                    tree = old if arm == "before" else ROOT
                    f = Path(tmp) / f"{arm}_{r}.npz"
                    code = (f"import sys; sys.path.insert(0, {str(Path(__file__).parent)!r}); import probe_transform as P; "
                            f"P.worker({a.res}, {a.svbrdfs}, {str(f)!r})")
                    subprocess.run([sys.executable, "-c", code], check=True, cwd=str(tree),
                                   env={**os.environ, "PYTHONPATH": str(tree)})
                    z = np.load(f)
                    ms[arm].append(round(float(z["ms"]), 3))
                    first.setdefault(arm, (z["planes"], bool(z["packed"])))
                    print(arm, r, ms[arm][-1], flush=True)
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(old)], capture_output=True)
    same = bool(np.array_equal(first["before"][0], first["after"][0]))
    res = {"experiment": "packed_texels.probe_transform", "before": a.before, "res": a.res, "svbrdfs": a.svbrdfs,
           "views": 10 * a.svbrdfs, "drjit_threads": 1, "ms_per_view": ms,
           "median_ms_per_view": {k: statistics.median(v) for k, v in ms.items()},
           "packed": {k: v[1] for k, v in first.items()}, "same_floats": same, "note": a.note,
           "command": "python3 experiments/packed_texels/probe_transform.py " + " ".join(argv or sys.argv[1:])}
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps(res, indent=1) + "\n")
    print(json.dumps({k: res[k] for k in ("median_ms_per_view", "packed", "same_floats")}))
    return res


if __name__ == "__main__":
    main()
