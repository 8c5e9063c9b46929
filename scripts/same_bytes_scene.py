"""Same-bytes check for the scene/BRDF/pack refactor (issue #13 part 1): hash everything the refactor could move.

Run from the repository root, before and after a change, and compare the two JSON files:

    python3 scripts/same_bytes_scene.py scripts/same_bytes_scene_before.json
    python3 scripts/same_bytes_scene.py scripts/same_bytes_scene_after.json
    python3 scripts/same_bytes_scene.py --compare scripts/same_bytes_scene_{before,after}.json

It hashes (sha256 of the raw array bytes):
  * every array of a tiny variants store (``svgen sample``) and of two tiny renders stores (``svgen render``:
    point flash + centre sampler, the data default; sphere flash + independent sampler, which runs the
    plugin's sample/pdf through MIS), and their scene attributes;
  * the torch BRDF ``ggx_cos`` and flash renderer on fixed random inputs, and the gradient of the flash render;
  * the numpy reference (``design_brdf``, ``render_point_flash``) on fixed inputs;
  * the state dict of two tiny ``svtrain fit`` runs: one on the tiny renders store (the store crop path of
    the dataset), one on the in-memory synthetic source (its pack/unpack);
  * the catalogue's contact-sheet flash renders of four presets (expected to change when its private alpha
    floor goes: see scripts/contact_sheet_change.py).

The imports of project modules are resolved at run time (``_first``) so the same script runs on the code
before and after the modules moved.
"""
from __future__ import annotations

import hashlib
import importlib
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
ENV = {**os.environ, "PYTHONPATH": str(ROOT), "SVGEN_NO_PROGRESS": "1"}


def _h(a) -> str:
    a = np.ascontiguousarray(np.asarray(a))
    return f"{a.dtype}{list(a.shape)}:" + hashlib.sha256(a.tobytes()).hexdigest()[:24]


def _first(*names: str):
    """The first importable 'module:attr' of names (the home before or after the refactor)."""
    for name in names:
        mod, attr = name.split(":")
        try:
            return getattr(importlib.import_module(mod), attr)
        except (ImportError, AttributeError):
            continue
    raise ImportError(f"none of {names}")


def _run(*args: str) -> None:
    subprocess.run([sys.executable, "-c", args[0], *args[1:]], check=True, env=ENV, cwd=ROOT,
                   stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)


def _store_hashes(path: Path) -> dict:
    import zarr

    g = zarr.open_group(str(path), mode="r")
    out = {}
    for name, arr in sorted(g.arrays()):
        out[name] = _h(arr[...])
    scene = g.attrs.get("scene")
    if scene is not None:
        out["attrs.scene"] = json.dumps(scene, sort_keys=True)
    return out


def stores(tmp: Path) -> dict:
    cli = "from pipeline.cli import main; main()"
    _run(cli, "sample", str(tmp / "v.zarr"), "--config", "tiny", "--preset", "paint/glossy_red",
         "--preset", "wood/mahogany_veneer", "--preset", "metal/brushed_steel", "--per-preset", "2",
         "--workers", "0")
    _run(cli, "render", str(tmp / "v.zarr"), str(tmp / "r.zarr"), "--config", "tiny", "--res", "64", "--views",
         "3", "--chunk", "2", "--workers", "0")
    _run(cli, "render", str(tmp / "v.zarr"), str(tmp / "rs.zarr"), "--config", "tiny", "--res", "48", "--views",
         "2", "--chunk", "2", "--light", "sphere", "--sampler", "independent", "--spp", "4", "--workers", "0")
    return {"variants": _store_hashes(tmp / "v.zarr"), "renders_point_centre": _store_hashes(tmp / "r.zarr"),
            "renders_sphere_independent": _store_hashes(tmp / "rs.zarr")}


def torch_brdf() -> dict:
    import torch

    from train.brdf import ggx_cos
    from train.render import flash_render

    g = torch.Generator().manual_seed(13)
    maps = torch.rand(3, 10, 24, 24, generator=g)
    maps[:, 0:2] = maps[:, 0:2] * 2 - 1
    maps[:, 9:10] = maps[:, 9:10] ** 2  # reach the roughness floor
    wi = torch.randn(3, 3, 24, 24, generator=g)
    wo = torch.randn(3, 3, 24, 24, generator=g)
    wi[:, 2], wo[:, 2] = wi[:, 2].abs(), wo[:, 2].abs()
    light = torch.rand(3, 2, generator=g) - 0.5
    m = maps.clone().requires_grad_(True)
    img = flash_render(m, light, clip=False)
    img.sum().backward()
    return {"ggx_cos": _h(ggx_cos(maps, wi, wo).numpy()), "flash_render": _h(flash_render(maps, light).numpy()),
            "flash_render_grad": _h(m.grad.numpy())}


def numpy_reference() -> dict:
    from materials.maps import SVBRDF, normalize

    design_brdf = _first("materials.brdf_reference:design_brdf", "pipeline.render.reference:design_brdf")
    render_point_flash = _first("materials.brdf_reference:render_point_flash",
                                "pipeline.render.reference:render_point_flash")
    rng = np.random.default_rng(13)
    n = normalize(np.concatenate([0.4 * rng.standard_normal((32, 32, 2)), np.ones((32, 32, 1))], -1))
    maps = SVBRDF(normal=n, diffuse=rng.random((32, 32, 3), np.float32), specular=rng.random((32, 32, 3), np.float32),
                  roughness=rng.random((32, 32, 1), np.float32) ** 2)
    v = normalize(rng.standard_normal((64, 3)) * [1, 1, 0] + [0, 0, 1.5]).astype(np.float64)
    l = normalize(rng.standard_normal((64, 3)) * [1, 1, 0] + [0, 0, 1.5]).astype(np.float64)
    f = design_brdf(np.array([0.0, 0.0, 1.0]), v, l, rng.random((64, 3)), rng.random((64, 3)),
                    rng.random((64, 1)) ** 2)
    d = _first("materials.capture:CAMERA_DISTANCE", "train.render:CAMERA_DISTANCE")
    intensity = np.pi * d * d  # fixed inputs: written as the before-run wrote it (pi D^2 rounds differently)
    img, spread = render_point_flash(maps, (0.2, -0.3), intensity, d, subsamples=2, return_spread=True)
    return {"design_brdf": _h(f), "render_point_flash": _h(img), "render_point_flash_spread": _h(spread)}


def fits(tmp: Path) -> dict:
    import torch

    common = ["--iterations", "3", "--batch-size", "2", "--workers", "0", "--no-compile", "--seed", "5",
              "--set", "model.base_width=4", "--set", "model.max_width=8", "--set", "model.levels=3",
              "--set", "data.crop=32", "--set", "optim.checkpoint_every=100"]
    cli = "from train.cli import main; main()"
    _run(cli, "fit", "--store", str(tmp / "r.zarr"), "--out", str(tmp / "fit_store"), "--set", "data.holdout=0.34",
         *common)
    _run(cli, "fit", "--out", str(tmp / "fit_synth"), "--set", "data.synthetic_samples=8",
         "--set", "data.synthetic_size=40", "--set", "data.synthetic_materials=4", *common)
    out = {}
    for run in ("fit_store", "fit_synth"):
        sd = torch.load(tmp / run / "model.pt", weights_only=True)["model"]
        out[run] = {k: _h(v.numpy()) for k, v in sorted(sd.items())}
    return out


def contact_sheet_renders() -> dict:
    import materials
    from materials.catalog import flash_render

    names = ["paint/glossy_red", "wood/mahogany_veneer", "metal/brushed_steel", "plastic/glossy_blue"]
    out = {}
    for name in names:
        try:
            p = materials.get_preset(name)
        except Exception:  # noqa: BLE001  (a preset name that does not exist is skipped, the same before/after)
            continue
        out[name] = _h(flash_render(p.generate(None, 64, 0)))
    return out


def main(path: str) -> None:
    with tempfile.TemporaryDirectory(prefix="same_bytes_") as d:
        tmp = Path(d)
        result = {"stores": stores(tmp), "torch_brdf": torch_brdf(), "numpy_reference": numpy_reference(),
                  "fits": fits(tmp), "contact_sheet_flash_render": contact_sheet_renders()}
    result["git_head"] = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True,
                                        text=True).stdout.strip()
    Path(path).write_text(json.dumps(result, indent=1, sort_keys=True) + "\n")
    print(f"wrote {path}")


def compare(before: str, after: str) -> int:
    """Print every key whose hash differs; returns the count (git_head always differs)."""
    a, b = json.loads(Path(before).read_text()), json.loads(Path(after).read_text())
    diffs = []

    def walk(x, y, path):
        if isinstance(x, dict) and isinstance(y, dict):
            for k in sorted(set(x) | set(y)):
                walk(x.get(k), y.get(k), f"{path}/{k}")
        elif x != y:
            diffs.append(path)

    walk(a, b, "")
    print("\n".join(f"differs: {d}" for d in diffs) or "identical")
    return len(diffs)


if __name__ == "__main__":
    if len(sys.argv) == 4 and sys.argv[1] == "--compare":
        compare(sys.argv[2], sys.argv[3])
    else:
        main(sys.argv[1] if len(sys.argv) > 1 else "same_bytes_scene.json")
