"""Where each data stage spends its time: sample, blend and render profiled in one process (cProfile).

Each stage runs in-process (``workers=0``: no dask worker processes, so that the profile sees every call) on a small
count at the paper presets' resolution (288²): ``--variants`` variants (the first base materials, one variant
each), ``--blends`` blends of them, and ``--views`` views of ``--render`` SVBRDFs. The top ``--top`` functions by
their own time (tottime) and by cumulative time go into ``experiments/stage_profiles/results/profiles.json``
under ``--label`` (e.g. ``before`` and ``after`` a speed change), beside each stage's wall seconds and per-item
rate, so that a change's effect on the profile is kept with the figures (issue #24: "profiles before and after").

    python3 experiments/stage_profiles/profile_stages.py --label before
"""
from __future__ import annotations

import cProfile
import io
import pstats
import shutil
import sys
import tempfile
import time
from pathlib import Path

# harness.py (and freshness.py) stay in benchmarks/; this finished experiment imports them from there
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from harness import ROOT, parser, update_results  # noqa: E402

#: this experiment's frozen results (experiments/stage_profiles/results/)
RESULTS = Path(__file__).resolve().parent / "results"


def _top(prof: cProfile.Profile, key: str, n: int) -> list[dict]:
    """The n heaviest functions by ``key`` ("tottime" or "cumulative") as rows without machine paths."""
    st = pstats.Stats(prof, stream=io.StringIO())
    rows = []
    for (file, line, fn), (_, ncalls, tt, ct, _) in st.stats.items():  # noqa: B007
        short = file.split("site-packages/", 1)[1] if "site-packages/" in file else \
            str(Path(file).relative_to(ROOT)) if file.startswith(str(ROOT)) else Path(file).name
        rows.append({"function": f"{short}:{line}({fn})", "calls": ncalls, "tottime_s": round(tt, 4),
                     "cumtime_s": round(ct, 4)})
    rows.sort(key=lambda r: -r["tottime_s" if key == "tottime" else "cumtime_s"])
    return rows[:n]


def _profiled(fn, top: int) -> dict:
    prof = cProfile.Profile()
    t0 = time.perf_counter()
    prof.enable()
    fn()
    prof.disable()
    wall = time.perf_counter() - t0
    return {"wall_s": round(wall, 3), "top_tottime": _top(prof, "tottime", top),
            "top_cumulative": _top(prof, "cumulative", top)}


def main(argv=None) -> int:
    ap = parser(__doc__)
    ap.add_argument("--label", default="now", help="key of this profile in profiles.json (e.g. before, after)")
    ap.add_argument("--variants", type=int, default=40, help="variants sampled (one per base material)")
    ap.add_argument("--blends", type=int, default=200, help="blends of those variants")
    ap.add_argument("--render", type=int, default=20, help="SVBRDFs rendered (the first variants)")
    ap.add_argument("--views", type=int, default=10, help="views per rendered SVBRDF")
    ap.add_argument("--size", type=int, default=288, help="map and render side (the paper presets: 288)")
    ap.add_argument("--top", type=int, default=15, help="functions kept per table")
    ap.add_argument("--out", default=str(RESULTS / "profiles.json"))
    a = ap.parse_args(argv)
    from materials import presets
    from pipeline.blend import run_blend
    from pipeline.config import BlendConfig, RenderConfig, SampleConfig
    from pipeline.render.stage import run_render
    from pipeline.sample import run_sample
    from svcore.config import build

    names = tuple(sorted(p.name for p in presets()))[:a.variants]
    tmp = Path(tempfile.mkdtemp(prefix="profile_stages_"))
    try:
        v, b, r, rv = (tmp / f"{k}.zarr" for k in ("v", "b", "r", "rv"))
        res = {"sample": _profiled(lambda: run_sample(v, build(SampleConfig, "default", presets=names, per_preset=1,
                                                                size=a.size), workers=0), a.top)}
        res["sample"]["variants_per_s"] = round(len(names) / res["sample"]["wall_s"], 2)
        res["blend"] = _profiled(lambda: run_blend(v, b, build(BlendConfig, "default", count=a.blends),
                                                   workers=0), a.top)
        res["blend"]["blends_per_s"] = round(a.blends / res["blend"]["wall_s"], 2)
        # the render input: the first --render variants as their own store (sampled, not timed)
        run_sample(rv, build(SampleConfig, "default", presets=names[:a.render], per_preset=1, size=a.size),
                   workers=0)
        res["render"] = _profiled(lambda: run_render(rv, r, build(RenderConfig, "default", views=a.views,
                                                                  res=a.size), workers=0), a.top)
        n_views = min(a.render, len(names)) * a.views
        res["render"]["views"] = n_views
        res["render"]["s_per_view"] = round(res["render"]["wall_s"] / n_views, 5)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    block = {"counts": {"variants": len(names), "blends": a.blends, "render_svbrdfs": a.render, "views": a.views,
                        "size": a.size}, "stages": res}
    update_results(a.out, a.label, block, a.note)
    for k, st in res.items():
        print(f"{k}: {st['wall_s']:.1f} s; top by own time:")
        for row in st["top_tottime"][:6]:
            print(f"   {row['tottime_s']:8.3f} s  {row['calls']:>8}  {row['function']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
