"""Where a view's render CPU goes: the Mitsuba call taken apart, the view transform and the encoding (#24).

#24 aims at 0.010 CPU-s per 256² view end to end; the render stage measures about three times that on this
machine (``paper_scale.json``). This probe measures, on one drjit thread, the floor that the stage's own calls
set before any store I/O, and what each part of the ``mi.render`` call of the capture scene costs, by rendering
the same scene with integrators that stop early (registered here, used nowhere else):

* ``camera``: camera rays and the film only (the integrator returns the ray's direction);
* ``+ intersect``: adds the scene's ray intersection (``scene.ray_intersect``: Embree on the LLVM variants);
* ``+ light``: adds the flash's direction sample (no shadow ray);
* ``direct``: the stage's integrator before #42 (Mitsuba's ``direct``, a shadow ray and the svgen_ggx BSDF);
* ``shape intersect``: the stage's integrator since #42 (``svgen_plane_flash``, pipeline/render/integrator.py):
  what ``direct`` computes for this scene with the plane intersected by Mitsuba's own rectangle code
  (``shape.ray_intersect_preliminary``) instead of Embree and no shadow ray (a single plane lit from its front
  cannot shadow itself). Not bit-identical to ``direct``: its agreement is measured over views of the library
  (float pixels that differ, 8-bit codes that differ per million).

Beside them: ``transform_planes`` (the view's texture transform) at 1 and 2 subsamples per axis (2 when the view
minifies: zoom above base/res, about half the views at the default zoom range) and the drjit 8-bit encoding.

    python3 experiments/render_floor/probe_render_floor.py    # -> experiments/render_floor/results/render_floor.json

CPU is ``time.process_time`` of this process, median of ``--rounds`` rounds of ``--calls`` calls, the items
interleaved within each round.
"""
from __future__ import annotations

import sys
from pathlib import Path
import statistics
import time

import numpy as np

# harness.py (and freshness.py) stay in benchmarks/; this finished experiment imports them from there
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from harness import parser, write_results  # noqa: E402

#: this experiment's frozen results (experiments/render_floor/results/)
RESULTS = Path(__file__).resolve().parent / "results"

#: integrators of the probe, in order: name -> what it adds
STEPS = {"camera": "camera rays and film", "intersect": "+ scene.ray_intersect (Embree)",
         "light": "+ the flash's direction sample", "direct": "Mitsuba's direct with svgen_ggx (the stage's until #42)",
         "shape_intersect": "direct's result via the rectangle's own intersection, no shadow ray (the stage's "
                            "svgen_plane_flash since #42)"}


def register_probe_integrators():
    """Register the probe's integrators (``svgen_probe_<step>``); returns the mitsuba module."""
    from svcore.mi_env import mi

    class Partial(mi.SamplingIntegrator):
        """camera / intersect / light: the render call stopped after that step."""

        def __init__(self, props):
            mi.SamplingIntegrator.__init__(self, props)
            self.step = props.get("step", "camera")

        def sample(self, scene, sampler, ray, medium=None, active=True):
            if self.step == "camera":
                return mi.Spectrum(ray.d.z), mi.Bool(True), []
            si = scene.ray_intersect(ray, active)
            if self.step == "intersect":
                return mi.Spectrum(si.uv.x), si.is_valid(), []
            ds, em = scene.sample_emitter_direction(si, sampler.next_2d(active), False, active)
            return mi.Spectrum(em), si.is_valid(), []

        def aov_names(self):
            return []

        def to_string(self):
            return f"Partial[{self.step}]"

    mi.register_integrator("svgen_probe_partial", lambda p: Partial(p))
    return mi


def probe_scene(res: int, step: str):
    """A FlashScene (point light, centre sampler, 1 spp) whose integrator is the probe's ``step``."""
    from pipeline.render.scene import FlashScene, scene_dict

    mi = register_probe_integrators()
    scene = FlashScene(res, 1, "point", "centre")  # shape_intersect: the stage's own integrator since #42
    if step != "shape_intersect":
        d = scene_dict(res, 1, "point", "centre")
        d["integrator"] = ({"type": "direct", "emitter_samples": 1, "bsdf_samples": 0} if step == "direct"
                           else {"type": "svgen_probe_partial", "step": step})
        scene.scene = mi.load_dict(d)
        scene.params = mi.traverse(scene.scene)
    return scene


def agreement(res: int, views: int, presets: int = 15) -> dict:
    """``shape_intersect`` against ``direct`` on views of evenly spaced presets of the library."""
    import materials
    from storage.views import texels_of, transform_planes

    from pipeline.render.views import draw_views

    direct, shape = probe_scene(res, "direct"), probe_scene(res, "shape_intersect")
    names = materials.presets()
    pick = np.linspace(0, len(names) - 1, presets).round().astype(int)
    same, rel, codes, n_codes, n_views = 0, 0.0, 0, 0, 0
    for i in pick:
        base = texels_of(names[i].generate(None, res, int(i)))
        for v in draw_views(0, int(i), max(1, views // presets)):
            planes = transform_planes(base, res, v, res)
            a = direct.render_planes(planes, (v.light_x, v.light_y), v.seed, clip=False)
            b = shape.render_planes(planes, (v.light_x, v.light_y), v.seed, clip=False)
            same += int(np.array_equal(a, b))
            rel = max(rel, float((np.abs(a - b) / np.maximum(np.abs(a), 1e-3)).max()))
            ca = direct.render_planes_srgb8(planes, (v.light_x, v.light_y), v.seed)
            cb = shape.render_planes_srgb8(planes, (v.light_x, v.light_y), v.seed)
            codes += int((ca != cb).sum())
            n_codes += ca.size
            n_views += 1
    return {"views": n_views, "views_bit_identical": same, "max_relative_difference": rel,
            "codes_differing_per_million": round(1e6 * codes / n_codes, 3), "codes": n_codes}


def _interleaved_cpu_ms(items: dict, calls: int, rounds: int) -> dict:
    """Median CPU ms per call of each ``name -> f``: every round times each item in turn (``calls`` calls), so
    that the drifts of a shared VM (the same call varies by up to 1.7x between seconds here) fall on every item
    alike."""
    for f in items.values():
        f()  # compile / warm
    per = {k: [] for k in items}
    for _ in range(rounds):
        for k, f in items.items():
            t = time.process_time()
            for _ in range(calls):
                f()
            per[k].append((time.process_time() - t) / calls * 1e3)
    return {k: round(statistics.median(v), 3) for k, v in per.items()}


def measure(res: int, calls: int, rounds: int) -> dict:
    """CPU ms per call of each step, the transform at 1 and 2 subsamples and the encoding, at ``res``²."""
    import materials
    from svcore.mi_env import dr, mi
    from storage.srgb8 import DrjitEncoder
    from storage.views import ViewParams, supersampling, texels_of, transform_planes

    base = texels_of(materials.presets()[0].generate(None, res, 0))
    views = {ss: ViewParams(light_x=0.3, light_y=-0.2, zoom=z, rotation=0.7, shift_u=0.25, shift_v=0.6, seed=5)
             for ss, z in ((1, 0.85), (2, 1.2))}
    assert all(supersampling(v, res, res) == ss for ss, v in views.items())
    planes = transform_planes(base, res, views[1], res)
    scenes = {step: probe_scene(res, step) for step in STEPS}
    enc = DrjitEncoder()
    flat = mi.Float(scenes["camera"].render_planes(planes, (0.3, -0.2), 5, clip=False).ravel())

    def render(scene):
        return lambda: scene.render_planes(planes, (0.3, -0.2), 5, clip=False)

    def transform(v):  # synchronised: the kernel's time is the call's, not the next call's
        return lambda: (transform_planes(base, res, v, res), dr.sync_thread())

    items = {**{f"render_{k}": render(s) for k, s in scenes.items()},
             **{f"transform_ss{ss}": transform(v) for ss, v in views.items()}, "encode": lambda: enc(flat)}
    ms = _interleaved_cpu_ms(items, calls, rounds)
    r = {k: ms[f"render_{k}"] for k in STEPS}
    t = {f"ss{ss}": ms[f"transform_ss{ss}"] for ss in views}
    out = {"render_ms": r, "transform_ms": t, "encode_ms": ms["encode"]}
    out["parts_ms"] = {"camera_and_film": r["camera"], "intersect": round(r["intersect"] - r["camera"], 3),
                       "light_sample": round(r["light"] - r["intersect"], 3),
                       "shadow_ray_bsdf_and_rest": round(r["direct"] - r["light"], 3)}
    out["floor_ms_per_view"] = round(r["shape_intersect"] + (t["ss1"] + t["ss2"]) / 2 + out["encode_ms"], 3)
    out["floor_note"] = ("the stage's render (shape_intersect since #42) + the mean of the two transforms (about half "
                         "the views minify) + encoding: "
                         "the stage's calls per view before decoding inputs and writing the store")
    return out


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--res", type=int, nargs="+", default=[256, 288])
    ap.add_argument("--calls", type=int, default=10)
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--agreement-views", type=int, default=45)
    ap.add_argument("--out", default=str(RESULTS / "render_floor.json"))
    a = ap.parse_args(argv)
    from svcore.mi_env import dr

    dr.set_thread_count(1)
    results = {}
    for res in a.res:
        results[str(res)] = measure(res, a.calls, a.rounds)
        results[str(res)]["agreement_shape_intersect"] = agreement(res, a.agreement_views)
        m = results[str(res)]
        print(f"{res}²: render {m['render_ms']}, transform {m['transform_ms']}, encode {m['encode_ms']} ms; floor "
              f"{m['floor_ms_per_view']} ms/view; shape_intersect: {m['agreement_shape_intersect']}", flush=True)
    write_results(a.out, {"benchmark": "render_floor", "drjit_threads": 1, "steps": STEPS, "calls": a.calls,
                          "rounds": a.rounds, "aim_ms_per_view": 10.0, "results": results}, a.note)


if __name__ == "__main__":
    main()
