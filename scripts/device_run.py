"""The prepared GPU run (issue #44, docs/GPU.md): render, compare, train and evaluate, one JSON and the models.

    python3 scripts/device_run.py --out OUT [--variant cuda_ad_rgb] [--device cuda] [--per-preset 3] ...

scripts/device_run.sh starts it on a bare GPU machine after installing the carried wheels. Steps, each a real
``svgen``/``svtrain`` command line in a subprocess, timed, and written to ``OUT/device_run.json`` as soon as it
ends (a run cut short still leaves what it measured; a failed step is recorded with its error and the run goes on
where it can):

1. ``env``: Python, torch, the GPU, whether a libLLVM >= 16 is there (drjit's CPU backend).
2. ``sample``: a variants store, ``--per-preset`` of each of svgen's presets (3: 546 SVBRDFs) at ``--size``.
3. ``render``: a warm-up render of one preset's SVBRDFs (Mitsuba compiles and caches its kernels), then the timed
   render of the whole store in ``--variant``, ``--views-per-launch`` views per Mitsuba call (10: all of an
   SVBRDF's); views per second over the command's wall clock.
4. ``compare``: the first ``--compare`` SVBRDFs' views rendered again in llvm_ad_rgb from the store's own maps
   and config, against the stored ones; where there is no libLLVM, against the llvm views carried in
   ``--llvm-views`` (scripts/device_wheels.py made them) of the SVBRDFs whose maps match.
5. ``fit_compact``, ``fit_paper``: ``svtrain fit`` of each preset in ``--precision`` on the store for at most
   ``--compact-s``/``--paper-s`` seconds from the loss log's first row (constant learning rate, the paper's, so
   that stopping by the clock cuts no schedule short): the run is stopped with SIGINT, which checkpoints; its it/s
   is steps over its own training clock (timing.json).
6. ``eval_*``: ``svtrain eval`` of each model on its own training views (``--suite train``: does it fit what it
   saw? #39's criterion), on the held-out views (each ``--eval-limit``) and, when ``--reference``
   names an imported materials store, on its render in ``--variant`` (the real-material reference).

Without a libLLVM, drjit has only its CUDA backend: the training loader's crop transform (storage.views)
then runs in cuda_ad_rgb in the main process (``data.workers`` 0), which the JSON records.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SVGEN = [sys.executable, "-c", "import sys; from pipeline.cli import main; sys.argv[0] = 'svgen'; main()"]
SVTRAIN = [sys.executable, "-c", "import sys; from train.cli import main; sys.argv[0] = 'svtrain'; main()"]
#: what the run writes under --out (a test checks them): the JSON, the compact model, the log
RESULT, COMPACT_MODEL, LOG = "device_run.json", "compact_model.pt", "device_run.log"

COMPARE = """
import json, sys
sys.path.insert(0, "scripts")
from device_run import diff_row
import numpy as np, zarr
from svcore.mi_env import use_variant
use_variant("llvm_ad_rgb")
from materials.maps import MAP_NAMES
from pipeline.config import RenderConfig
from pipeline.render.stage import render_svbrdf, scene_for
from storage.svbrdf_store import decode_maps
g = zarr.open_group(sys.argv[1], mode="r")
c = {k: v for k, v in g.attrs["config"].items() if k in RenderConfig.model_fields}
cfg = RenderConfig(**{**c, "variant": "llvm_ad_rgb"})
scene = scene_for(cfg)
rows = []
for s in range(min(int(sys.argv[2]), g["image"].shape[0])):
    maps = decode_maps({k: g[k][s] for k in MAP_NAMES})
    llvm, _ = render_svbrdf(scene, maps, s, cfg)
    rows.append(diff_row(s, llvm, g["image"][s]))
print(json.dumps(rows))
"""


def diff_row(s: int, llvm, other) -> dict:
    """How the views of SVBRDF ``s`` in another variant (uint8 codes) differ from llvm_ad_rgb's."""
    import numpy as np

    d = np.abs(np.asarray(llvm).astype(np.int16) - np.asarray(other).astype(np.int16))
    return {"svbrdf": s, "views": int(d.shape[0]), "max_abs_code": int(d.max()), "mean_abs_code": float(d.mean()),
            "share_equal": float((d == 0).mean()), "share_within_1": float((d <= 1).mean())}


def maps_digest(group, s: int) -> str:
    """sha256 of SVBRDF ``s``'s stored base maps in a renders store: which SVBRDF carried views are of."""
    import hashlib

    import numpy as np

    from materials.maps import MAP_NAMES

    h = hashlib.sha256()
    for k in MAP_NAMES:
        h.update(np.ascontiguousarray(group[k][s]).tobytes())
    return h.hexdigest()


#: the render settings two stores' views must share to be compared
SAME = ("views", "res", "spp", "light", "sampler", "seed")


def write_llvm_views(renders: Path, count: int, path: Path) -> Path:
    """Save the first ``count`` SVBRDFs' views of an llvm_ad_rgb renders store, with their maps' digests and the
    render settings: the comparison a machine without libLLVM makes (:func:`compare_carried`)."""
    import numpy as np
    import zarr

    g = zarr.open_group(str(renders), mode="r")
    k = min(count, g["image"].shape[0])
    cfg = {key: g.attrs["config"].get(key) for key in SAME}
    np.savez_compressed(path, images=g["image"][:k], digests=np.array([maps_digest(g, s) for s in range(k)]),
                        config=np.array(json.dumps(cfg)))
    return path


def compare_carried(renders: Path, path: Path) -> dict:
    """The views of ``renders`` against carried llvm_ad_rgb views of the same SVBRDFs (same maps, same settings)."""
    import numpy as np
    import zarr

    g = zarr.open_group(str(renders), mode="r")
    z = np.load(path)
    cfg = json.loads(str(z["config"]))
    if {key: g.attrs["config"].get(key) for key in SAME} != cfg:
        return {"ok": False, "skipped": f"the carried llvm views were rendered with {cfg}"}
    rows = [diff_row(s, z["images"][s], g["image"][s]) for s, digest in enumerate(z["digests"])
            if s < g["image"].shape[0] and maps_digest(g, s) == str(digest)]
    if not rows:
        return {"ok": False, "skipped": "the carried llvm views are of other SVBRDFs (their maps differ)"}
    return {"ok": True, "rows": rows, "against": str(path)}


class Run:
    """The JSON of the run, written after every step, and the log every command's output goes to."""

    def __init__(self, out: Path, args: argparse.Namespace):
        self.out = out
        out.mkdir(parents=True, exist_ok=True)
        self.log = open(out / LOG, "a")
        self.data: dict = {"args": vars(args), "steps": {}}
        self.save()

    def save(self) -> None:
        tmp = self.out / (RESULT + ".part")
        tmp.write_text(json.dumps(self.data, indent=1, default=str) + "\n")
        tmp.replace(self.out / RESULT)

    def step(self, name: str, value: dict) -> dict:
        self.data["steps"][name] = value
        self.save()
        print(f"== {name}: {json.dumps(value, default=str)[:400]}", flush=True)
        return value

    def command(self, cmd: list[str], env: dict | None = None, stop_after: float | None = None,
                started: Path | None = None) -> dict:
        """Run ``cmd`` (its output to the log); with ``stop_after``, SIGINT it that many seconds after the file
        ``started`` has a row below its header (fit's loss.csv: the first ``optim.log_every`` steps are done), so
        start-up and the first steps' compilation are not counted."""
        shown = " ".join(cmd[3:] if cmd[:3] in (SVGEN, SVTRAIN) else cmd)
        name = "svgen" if cmd[:3] == SVGEN else "svtrain" if cmd[:3] == SVTRAIN else ""
        self.log.write(f"\n$ {name} {shown}\n")
        self.log.flush()
        t0 = time.perf_counter()
        # SIGINT back to its default in the child: a process that inherits it ignored (a background job of a
        # non-interactive shell, or a test worker some earlier code left so) starts Python with no KeyboardInterrupt,
        # so the clock's Ctrl-C would not stop the fit and it was killed, without its model, 120 s later
        p = subprocess.Popen(cmd, stdout=self.log, stderr=subprocess.STDOUT, cwd=ROOT,
                             env={**os.environ, "SVGEN_NO_PROGRESS": "1", **(env or {})},
                             preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
        stopped, t_started = False, None
        while p.poll() is None:
            time.sleep(0.2)
            if stop_after is None:
                continue
            if t_started is None and (started is None or _rows(started) > 1):
                t_started = time.perf_counter()
            if t_started is not None and time.perf_counter() - t_started >= stop_after:
                p.send_signal(signal.SIGINT)  # fit checkpoints on Ctrl-C
                stopped = True
                try:
                    p.wait(timeout=120)
                except subprocess.TimeoutExpired:
                    p.kill()
                    p.wait()
        wall = time.perf_counter() - t0
        self.log.flush()
        ok = p.returncode == 0 or (stopped and p.returncode in (1, 2, 130, -signal.SIGINT))
        return {"cmd": f"{name} {shown}", "rc": p.returncode, "ok": ok, "stopped_by_clock": stopped, "wall_s": wall}


def _rows(path: Path) -> int:
    try:
        return len(path.read_text().splitlines())
    except OSError:
        return 0


def _env_info() -> dict:
    info = {"python": platform.python_version(), "machine": platform.machine()}
    try:
        import torch

        info.update(torch=torch.__version__, cuda=torch.cuda.is_available(),
                    gpu=torch.cuda.get_device_name(0) if torch.cuda.is_available() else None)
    except Exception as e:  # noqa: BLE001 (recorded, not fatal)
        info["torch_error"] = str(e)
    from svcore.llvm import find_llvm

    info["libllvm"] = find_llvm()
    for mod in ("mitsuba", "drjit", "zarr", "dask"):
        try:
            info[mod] = __import__(mod).__version__
        except Exception as e:  # noqa: BLE001
            info[mod] = f"missing: {e}"
    return info


def _fit(run: Run, name: str, preset: str, store: Path, work: Path, a, loader: dict, extra: list[str]) -> Path | None:
    """``svtrain fit`` of ``preset`` for at most its seconds; returns the model file (model.pt or checkpoint.pt)."""
    out = work / name
    cmd = SVTRAIN + ["fit", "--config-preset", preset, "--store", str(store), "--out", str(out), "--no-resume",
                     "--device", a.device, "--precision", a.precision, "--batch-size", str(a.batch),
                     "--iterations", str(a.iterations), "--no-compile", "--workers", str(loader["workers"]),
                     "--set", "optim.schedule=constant", "--set", "optim.checkpoint_every=1000000000",
                     "--set", "optim.checkpoint_minutes=0", *extra]
    seconds = a.compact_s if preset == "compact" else a.paper_s
    r = run.command(cmd, env=loader["env"], stop_after=seconds, started=out / "loss.csv")
    timing = _read_json(out / "timing.json")
    steps = (timing.get("checkpoint") or {}).get("step")
    wall = timing.get("train_wall_s")
    r.update(steps=steps, train_wall_s=wall, it_per_s=(steps / wall) if steps and wall else None,
             samples_per_s=(steps * a.batch / wall) if steps and wall else None, limit_s=seconds,
             metrics=_read_json(out / "metrics.json"))
    model = out / "model.pt" if (out / "model.pt").exists() else out / "checkpoint.pt"
    r["model"] = str(model) if model.exists() else None
    if model.exists():
        r["model_bytes"] = model.stat().st_size
    run.step(name, r)
    return model if model.exists() else None


def _eval(run: Run, name: str, model: Path, work: Path, a, loader: dict, store: Path | None = None,
          suite: str | None = None) -> None:
    out = work / name
    cmd = SVTRAIN + ["eval", "--checkpoint", str(model), "--out", str(out), "--device", a.device,
                     "--limit", str(a.eval_limit)] + (["--store", str(store)] if store else []) + (
                         ["--suite", suite] if suite else [])
    r = run.command(cmd, env=loader["env"])
    r["metrics"] = _read_json(out / "eval_metrics.json")
    run.step(name, r)


def _read_json(path: Path) -> dict:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return {}


def _model_file(src: Path, dst: Path) -> dict:
    """The trained weights of a run's model.pt/checkpoint.pt, saved as ``dst`` (config, weights, step)."""
    import torch

    state = torch.load(src, map_location="cpu", weights_only=False)
    torch.save({"config": state.get("config"), "model": state.get("model"), "step": state.get("step")}, dst)
    return {"file": dst.name, "bytes": dst.stat().st_size, "step": state.get("step")}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=os.environ.get("OUT"), help="where the JSON, log and model go ($OUT)")
    ap.add_argument("--work", default="/tmp/svgen_device", help="stores and runs (not brought back)")
    ap.add_argument("--variant", default="cuda_ad_rgb", choices=("cuda_ad_rgb", "llvm_ad_rgb"))
    ap.add_argument("--device", default="cuda", help="svtrain's device")
    ap.add_argument("--precision", default="bf16", choices=("fp32", "bf16", "fp16"))
    ap.add_argument("--per-preset", type=int, default=3, help="SVBRDFs per preset (182 presets: 3 -> 546)")
    ap.add_argument("--preset", action="append", default=[], help="only these presets (repeatable; tests)")
    ap.add_argument("--size", type=int, default=256, help="map side of the sampled SVBRDFs")
    ap.add_argument("--views", type=int, default=10)
    ap.add_argument("--res", type=int, default=256)
    ap.add_argument("--views-per-launch", type=int, default=10,
                    help="svgen render --views-per-launch: a GPU's per-call cost shared by an SVBRDF's views")
    ap.add_argument("--render-workers", type=int, default=1, help="svgen render --workers (1: one GPU process)")
    ap.add_argument("--sample-workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--compare", type=int, default=3, help="SVBRDFs re-rendered in llvm_ad_rgb and compared")
    ap.add_argument("--batch", type=int, default=8)
    ap.add_argument("--iterations", type=int, default=1_000_000, help="fit's iterations (the clock stops it first)")
    ap.add_argument("--compact-s", type=float, default=120.0, help="seconds of the compact fit's training loop")
    ap.add_argument("--paper-s", type=float, default=180.0, help="seconds of the paper fit's training loop")
    ap.add_argument("--compact-set", action="append", default=[], help="svtrain fit --set for compact (tests)")
    ap.add_argument("--paper-set", action="append", default=[], help="svtrain fit --set for paper (tests)")
    ap.add_argument("--eval-limit", type=int, default=200, help="held-out views evaluated")
    ap.add_argument("--reference", default=str(ROOT / ".device" / "reference" / "materials.zarr"),
                    help="an imported materials store (svgen import), rendered and evaluated on; skipped if missing")
    ap.add_argument("--llvm-views", default=str(ROOT / ".device" / "reference" / "llvm_views.npz"),
                    help="llvm views made here (scripts/device_wheels.py), compared where there is no libLLVM")
    ap.add_argument("--loader-workers", type=int, default=4, help="svtrain's data.workers where drjit has LLVM")
    a = ap.parse_args(argv)
    if not a.out:
        ap.error("give --out (or set OUT)")
    out, work = Path(a.out), Path(a.work)
    if work.exists():
        shutil.rmtree(work)
    work.mkdir(parents=True)
    run = Run(out, a)
    t_start = time.perf_counter()
    env = run.step("env", _env_info())
    # drjit's CPU backend needs a libLLVM: without one, the training loader's transform runs in CUDA, in-process
    llvm = bool(env.get("libllvm"))
    loader = {"workers": a.loader_workers, "env": {}} if llvm or a.variant == "llvm_ad_rgb" else \
        {"workers": 0, "env": {"SVGEN_MI_VARIANT": a.variant}}
    run.data["loader"] = loader
    progress: dict = {}

    variants = work / "variants.zarr"
    presets = [x for p in a.preset for x in ("--preset", p)]
    r = run.command(SVGEN + ["sample", str(variants), "--per-preset", str(a.per_preset), "--size", str(a.size),
                             "--workers", str(a.sample_workers), *presets], env=progress)
    run.step("sample", r)
    if not r["ok"]:
        return 1
    n = _store_n(variants)

    render = ["--views", str(a.views), "--res", str(a.res), "--variant", a.variant, "--workers", str(a.render_workers),
              "--views-per-launch", str(a.views_per_launch)]
    warm = work / "warm.zarr"
    first = a.preset[:1] or ["paint/glossy_red"]
    run.command(SVGEN + ["sample", str(work / "warm_in.zarr"), "--per-preset", "1", "--size", str(a.size),
                         "--preset", first[0], "--workers", str(min(1, a.sample_workers))], env=progress)
    w = run.step("render_warmup", run.command(SVGEN + ["render", str(work / "warm_in.zarr"), str(warm), *render],
                                              env=progress))
    renders = work / "renders.zarr"
    r = run.command(SVGEN + ["render", str(variants), str(renders), *render], env=progress)
    r.update(svbrdfs=n, views=n * a.views, views_per_s=n * a.views / r["wall_s"] if r["ok"] else None)
    # the warm-up (one SVBRDF's views) costs about the command's fixed part (start-up, imports, cluster): the rate
    # of the rest estimates the renderer's own
    if r["ok"] and w["ok"] and r["wall_s"] > w["wall_s"]:
        r["views_per_s_less_warmup"] = (n - 1) * a.views / (r["wall_s"] - w["wall_s"])
    if r["ok"]:
        import zarr

        g = zarr.open_group(str(renders), mode="r")
        r["store_variant"] = g.attrs["scene"]["mitsuba_variant"]
        r["views_per_launch"] = g.attrs["config"].get("views_per_launch", 1)
    run.step("render", r)
    if not r["ok"]:
        return 1

    if a.compare and (llvm or a.variant == "llvm_ad_rgb"):
        t0 = time.perf_counter()
        p = subprocess.run([sys.executable, "-c", COMPARE, str(renders), str(a.compare)], capture_output=True,
                           text=True, cwd=ROOT)
        rows = json.loads(p.stdout.strip().splitlines()[-1]) if p.returncode == 0 else None
        run.step("compare", {"ok": p.returncode == 0, "rows": rows, "wall_s": time.perf_counter() - t0,
                             "error": p.stderr[-2000:] if p.returncode else None})
    elif a.compare and Path(a.llvm_views).is_file():
        run.step("compare", compare_carried(renders, Path(a.llvm_views)))
    else:
        run.step("compare", {"ok": False, "skipped": "no libLLVM >= 16 here (llvm_ad_rgb cannot render) and no "
                             f"carried llvm views at {a.llvm_views}"})

    ref_renders = None
    if Path(a.reference).is_dir():
        ref_renders = work / "reference_renders.zarr"
        r = run.command(SVGEN + ["render", a.reference, str(ref_renders), *render], env=progress)
        run.step("reference_render", r)
        ref_renders = ref_renders if r["ok"] else None
    else:
        run.step("reference_render", {"ok": False, "skipped": f"no reference store at {a.reference}"})

    for preset, extra in (("compact", a.compact_set), ("paper", a.paper_set)):
        model = _fit(run, f"fit_{preset}", preset, renders, work, a, loader,
                     [x for kv in extra for x in ("--set", kv)])
        if model is None:
            continue
        # its own training views first: a model that cannot fit them cannot show what it learnt (#39)
        _eval(run, f"eval_{preset}_train", model, work, a, loader, suite="train")
        _eval(run, f"eval_{preset}_heldout", model, work, a, loader)
        if ref_renders is not None:
            _eval(run, f"eval_{preset}_reference", model, work, a, loader, ref_renders)
        if preset == "compact":
            run.data["compact_model"] = _model_file(model, out / COMPACT_MODEL)
        else:  # 62 M parameters: 247 MB in float32, over what a device call brings back; its digest is recorded
            import hashlib

            run.data["paper_model"] = {"bytes": model.stat().st_size,
                                       "sha256": hashlib.sha256(model.read_bytes()).hexdigest()}
    run.data["total_s"] = time.perf_counter() - t_start
    run.save()
    return 0


def _store_n(path: Path) -> int:
    import zarr

    return int(zarr.open_group(str(path), mode="r").attrs["svgen"]["n"])


if __name__ == "__main__":
    sys.exit(main())
