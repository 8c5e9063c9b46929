"""What the render call saves when it calls the plane, its BSDF and the flash directly, and encodes in its own kernel
(#42): one view's call, per commit, in processes that alternate on one machine.

Arms are commits (``--arms``, e.g. the commit before, the direct calls, the direct calls with the in-kernel
encoding). Each arm gets a git worktree. Each round starts one child process per arm, in alternating order. The child
renders the same views with that commit's stage path, ``FlashScene(in_kernel=True).render_view_srgb8``, on one drjit
thread. The views are 256^2 from 256^2 base maps of the first presets of the registry. Half magnify (zoom 0.85:
1 subsample) and half minify (zoom 1.25: 2 x 2). The child times each view (process CPU, after a warm-up view of
each kind) and returns the views' codes' digest. Every arm must give the same digest.

    PYTHONPATH=. python3 experiments/direct_calls/probe_direct.py --arms 9d52ebf 19f8b7f 4710b4a
"""
from __future__ import annotations

import hashlib
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))
from harness import parser, write_results  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"
RES = 256


def child(n_views: int) -> None:
    """Run in a child process whose PYTHONPATH is the arm's tree: time its views, print JSON."""
    import time

    import numpy as np

    from svcore.mi_env import dr

    dr.set_thread_count(1)
    import materials
    from pipeline.render.scene import FlashScene
    from storage.views import ViewParams, texels_of

    presets = materials.presets()[:4]
    texels = [texels_of(p.generate(None, RES, 0)) for p in presets]
    views = {"magnifying": 0.85, "minifying": 1.25}
    scene = FlashScene(RES, 1, "point", "centre", in_kernel=True)
    digest = hashlib.sha256()
    ms = {}
    for kind, zoom in views.items():
        vs = [ViewParams(light_x=float(0.3 * np.cos(k)), light_y=float(0.3 * np.sin(k)), zoom=zoom, rotation=0.37 * k,
                         shift_u=0.05 * k, shift_v=0.03 * k, seed=k) for k in range(n_views)]
        scene.render_view_srgb8(texels[0], vs[0])  # warm-up (kernel from the cache)
        t = []
        for k, v in enumerate(vs):
            c0 = time.process_time()
            codes = scene.render_view_srgb8(texels[k % len(texels)], v)
            t.append(time.process_time() - c0)
            digest.update(codes.tobytes())
        ms[kind] = 1e3 * statistics.median(t)
    print(json.dumps({"ms_per_view": ms, "digest": digest.hexdigest()}))


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--arms", nargs="+", default=[], help="commits, in the order of the first round")
    ap.add_argument("--rounds", type=int, default=6)
    ap.add_argument("--views", type=int, default=24, help="views of each kind per child")
    ap.add_argument("--out", default=str(RESULTS / "probe_direct.json"))
    ap.add_argument("--child", action="store_true", help=argparse_hidden())
    a = ap.parse_args(argv)
    if a.child:
        return child(a.views)
    if len(a.arms) < 2:
        ap.error("--arms needs at least two commits")
    work = Path(tempfile.mkdtemp(prefix="probe_direct_"))
    trees = {}
    try:
        for c in a.arms:
            t = work / c
            subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(t), c], check=True,
                           capture_output=True)
            trees[c] = t
        rows = {c: [] for c in a.arms}
        digests = {c: set() for c in a.arms}
        for r in range(a.rounds):
            order = a.arms if r % 2 == 0 else a.arms[::-1]
            for c in order:
                out = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--child", "--views",
                                      str(a.views)], env={**os.environ, "PYTHONPATH": str(trees[c]), "SVGEN_NO_PROGRESS": "1"},
                                     capture_output=True, text=True, check=True, cwd=str(trees[c]))
                d = json.loads(out.stdout.strip().splitlines()[-1])
                rows[c].append(d["ms_per_view"])
                digests[c].add(d["digest"])
                print(r, c, d["ms_per_view"], flush=True)
        first = a.arms[0]
        result = {"experiment": "direct_calls.probe_direct", "res": RES, "drjit_threads": 1, "rounds": a.rounds,
                  "views_per_kind": a.views, "arms": a.arms,
                  "same_codes": len({x for s in digests.values() for x in s}) == 1,
                  "ms_per_view_rounds": rows,
                  "ms_per_view_median": {c: {k: statistics.median(x[k] for x in rows[c]) for k in rows[c][0]}
                                         for c in a.arms},
                  "lower_than_first_arm_in_rounds": {c: {k: sum(x[k] < y[k] for x, y in zip(rows[c], rows[first]))
                                                         for k in rows[c][0]} for c in a.arms[1:]}}
        write_results(a.out, result, a.note)
        print(json.dumps({k: v for k, v in result.items() if k != "ms_per_view_rounds"}, indent=1))
    finally:
        for t in trees.values():
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(t)], capture_output=True)


def argparse_hidden():
    import argparse

    return argparse.SUPPRESS


if __name__ == "__main__":
    main()
