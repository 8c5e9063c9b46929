"""The torch loss renderer (train/render.py) and the Mitsuba data renderer (FlashScene) render the same picture.

Issue #4: "for the same SVBRDF and light, the torch render of the capture scene and the Mitsuba render differ
by <= 1 % relative RMSE". Here, for real presets of the materials library (glossy metal, rough diffuse, glossy
plastic, dark leather, clipped brushed steel, bumpy stone) in an identity view and a rotated + zoomed + shifted
view (maps from :func:`storage.views.transform_maps`, exactly what the data stage renders with):

    rel RMSE = sqrt(mean((torch - mitsuba)^2)) / sqrt(mean(mitsuba^2))

over all pixels and channels of the clipped LDR images (the data), Mitsuba taken as the reference.

What "the same picture" means depends on how Mitsuba samples the pixel:

* ``centre`` sampler, 1 spp (the data stage's default, chosen by bench_render_quality): Mitsuba shades the pixel
  centre, as torch does. Nothing is random, so only float32 arithmetic differs (Mitsuba builds the half vector,
  torch derives N.H and V.H from N.L, N.V, L.V). Measured <= 1.1e-4 (glossy highlights, where D is most
  sensitive to the direction). Asserted: the 1 % contract, and 1e-3 as a float32 bound that catches any real
  formula or convention change well below the contract (a 2 % intensity error or a flipped row order fails by
  10x or more: see the negative controls).
* ``centre`` sampler, 16 spp: the 4 x 4 grid centres of each pixel; torch renders the same points when the maps
  are repeated 4 x 4 (nearest lookup, as Mitsuba's texture) and averaged before clipping (Mitsuba clips the
  film). Deterministic again: same bounds.
* ``independent`` sampler, 1024 spp (the box-filtered pixel integral, Monte Carlo): against torch supersampled
  8 x 8. Pixel noise falls as 1/sqrt(spp): measured 0.28 % for polished gold (0.63 % at 256 spp, 1.3 % at 64),
  so 1024 spp is "enough spp" for the 1 % contract with a 3x margin; the seeds are fixed, so it cannot flake.

Why not compare torch's pixel centres with a converged box-filtered Mitsuba render: for glossy presets
(r ~ 0.02: a highlight narrower than a pixel at 64 px) the pixel integral differs from the pixel-centre value
by up to ~3 % relative RMSE. That is the film's filter, not a renderer disagreement; it shrinks with resolution
(benchmarks/bench_agreement.py measures it) and the data stage does not integrate the pixel anyway.

Known convention difference (inside the contract): a shading normal facing away from the camera (n.v <= 0;
needs a tilt > ~65 deg) is black in Mitsuba and lit with clamped cosines in torch (the paper's original code).
Real maps reach it rarely: ground/beach_sand in bench_agreement's 256^2 view has 13 such pixels, 0.14 %
relative RMSE. tests/test_stability.py states the two conventions.

On failure the two images and the difference image are written as PNG into a fresh temp dir, named in the
message.
"""
from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import pytest
import torch
import torch.nn.functional as F

from materials import get_preset
from materials.capture import FLASH_INTENSITY
from materials.maps import pack_maps
from pipeline.render.scene import FlashScene
from storage.views import ViewParams, transform_maps
from train.render import flash_render

RES = 64
#: the contract of issue #4.
CONTRACT = 0.01
#: deterministic comparisons (same sample points): float32 round-off only, measured <= 1.1e-4.
FLOAT32_BOUND = 1e-3
MATERIALS = [
    "metal/polished_gold",      # glossy metal: r 0.02-0.36, F0 ~0.66, highlights clip
    "ground/beach_sand",        # rough diffuse: r 0.17-1, bumpy normals (n_z >= 0.7)
    "plastic/glossy_blue",      # glossy dielectric
    "leather/black_smooth",     # very dark albedo: the highlight is all there is
    "metal/brushed_steel",      # 12 % of the pixels clip
    "stone/cobblestones",       # strong normal map
]
VIEWS = {
    "identity": ViewParams(light_x=0.2, light_y=0.3, seed=1),
    "rotated_zoomed": ViewParams(light_x=-0.4, light_y=-0.1, zoom=1.3, rotation=2.0, shift_u=0.3, shift_v=0.6,
                                 seed=2),
}


@pytest.fixture(scope="module")
def scenes():
    """Mitsuba scenes, loaded once per sampler setting (kernel compiled once each)."""
    return {key: FlashScene(RES, spp, "point", sampler) for key, (sampler, spp) in
            {"centre1": ("centre", 1), "centre16": ("centre", 16), "indep1024": ("independent", 1024)}.items()}


@pytest.fixture(scope="module")
def view_maps():
    """(material, view) -> the view's screen-space maps (RES^2), as the data stage computes them."""
    out = {}
    for name in MATERIALS:
        base = get_preset(name).generate(None, RES, 0)
        for vname, view in VIEWS.items():
            out[name, vname] = transform_maps(base, view, RES)
    return out


def torch_render(maps, view: ViewParams, k: int = 1, intensity: float = FLASH_INTENSITY) -> np.ndarray:
    """train.render.flash_render of numpy maps; k > 1 averages the k x k sub-pixel grid centres before clipping.

    Args:
        maps: SVBRDF with (H, W, C) maps.
        view: light offset source.
        k: sub-pixel grid per axis (the maps are repeated k x k: the nearest lookup of Mitsuba's texture).
        intensity: flash intensity (negative controls change it).

    Returns:
        (H, W, 3) float32 clipped linear image, row 0 = image top.
    """
    x = torch.from_numpy(pack_maps(maps)).permute(2, 0, 1)[None]
    if k > 1:
        x = x.repeat_interleave(k, 2).repeat_interleave(k, 3)
    with torch.no_grad():
        img = flash_render(x, torch.tensor([view.light_x, view.light_y]), intensity=intensity, clip=False)
        img = F.avg_pool2d(img, k) if k > 1 else img
    return img.clamp(0.0, 1.0)[0].permute(1, 2, 0).numpy()


def rel_rmse(img: np.ndarray, ref: np.ndarray) -> float:
    """RMSE(img - ref) / RMS(ref) over all pixels and channels."""
    return float(np.sqrt(np.mean((img.astype(np.float64) - ref) ** 2) / np.mean(ref.astype(np.float64) ** 2)))


def dump_pngs(tag: str, mitsuba: np.ndarray, torch_img: np.ndarray) -> str:
    """Write mitsuba.png, torch.png (sRGB-encoded for viewing) and diff.png (|difference| scaled to its max)."""
    from PIL import Image

    d = Path(tempfile.mkdtemp(prefix=f"svgen-agreement-{tag.replace('/', '_')}-"))

    def srgb8(a):
        a = np.clip(a, 0.0, 1.0)
        enc = np.where(a <= 0.0031308, 12.92 * a, 1.055 * np.power(a, 1 / 2.4) - 0.055)
        return (enc * 255 + 0.5).astype(np.uint8)

    Image.fromarray(srgb8(mitsuba)).save(d / "mitsuba.png")
    Image.fromarray(srgb8(torch_img)).save(d / "torch.png")
    diff = np.abs(torch_img - mitsuba)
    Image.fromarray((diff / max(float(diff.max()), 1e-12) * 255 + 0.5).astype(np.uint8)).save(d / "diff.png")
    np.savez(d / "images.npz", mitsuba=mitsuba, torch=torch_img)
    return str(d)


def check(tag: str, mitsuba: np.ndarray, torch_img: np.ndarray, bound: float) -> float:
    err = rel_rmse(torch_img, mitsuba)
    if not err <= bound:
        path = dump_pngs(tag, mitsuba, torch_img)
        pytest.fail(f"{tag}: torch vs Mitsuba relative RMSE {err:.3e} > {bound:.0e}; images in {path}")
    return err


@pytest.mark.parametrize("vname", list(VIEWS))
@pytest.mark.parametrize("material", MATERIALS)
def test_pixel_centres_agree(material, vname, scenes, view_maps):
    """The data stage's setting (centre sampler, 1 spp) against torch: contract 1 %, float32 bound 1e-3."""
    maps, view = view_maps[material, vname], VIEWS[vname]
    mi_img = scenes["centre1"].render_maps(maps, view)
    check(f"{material}-{vname}-centre1", mi_img, torch_render(maps, view), min(CONTRACT, FLOAT32_BOUND))


@pytest.mark.parametrize("vname", list(VIEWS))
@pytest.mark.parametrize("material", MATERIALS)
def test_subpixel_grid_agrees(material, vname, scenes, view_maps):
    """Centre sampler at 16 spp (4 x 4 grid centres, one film average, then clip) against torch at 4 x 4."""
    maps, view = view_maps[material, vname], VIEWS[vname]
    mi_img = scenes["centre16"].render_maps(maps, view)
    check(f"{material}-{vname}-centre16", mi_img, torch_render(maps, view, k=4), min(CONTRACT, FLOAT32_BOUND))


@pytest.mark.parametrize("vname", list(VIEWS))
@pytest.mark.parametrize("material", MATERIALS)
def test_converged_random_sampling_agrees(material, vname, scenes, view_maps):
    """Independent sampler, 1024 spp (Monte Carlo pixel integral) against torch's 8 x 8 sub-pixel average."""
    maps, view = view_maps[material, vname], VIEWS[vname]
    mi_img = scenes["indep1024"].render_maps(maps, view)
    check(f"{material}-{vname}-indep1024", mi_img, torch_render(maps, view, k=8), CONTRACT)


@pytest.mark.parametrize("mutation", ["intensity_2pct", "rows_flipped", "light_y_mirrored", "roughness_5pct"])
def test_negative_controls_fail_the_bound(mutation, scenes, view_maps):
    """The comparison has power: plausible convention bugs exceed the deterministic bound by >= 10x.

    A 2 % intensity error also exceeds the 1 % contract; a 5 % roughness error on a glossy preset, a flipped row
    order (the DESIGN.md "row 0 lands at the bottom" trap) or a mirrored light all exceed it by far.
    """
    name, vname = "plastic/glossy_blue", "rotated_zoomed"
    maps, view = view_maps[name, vname], VIEWS[vname]
    mi_img = scenes["centre1"].render_maps(maps, view)
    if mutation == "intensity_2pct":
        img = torch_render(maps, view, intensity=FLASH_INTENSITY * 1.02)
        floor = CONTRACT
    elif mutation == "rows_flipped":
        img = torch_render(maps, view)[::-1]  # the picture upside down
        floor = CONTRACT
    elif mutation == "light_y_mirrored":
        img = torch_render(maps, ViewParams(light_x=view.light_x, light_y=-view.light_y))
        floor = CONTRACT
    else:
        rough = maps.__class__(normal=maps.normal, diffuse=maps.diffuse, specular=maps.specular,
                               roughness=maps.roughness * 1.05)
        img = torch_render(rough, view)
        floor = 10 * FLOAT32_BOUND
    assert rel_rmse(img, mi_img) > floor


def test_failure_dump_writes_pngs():
    """The failure path works: three PNGs that decode to the right shapes."""
    from PIL import Image

    a = np.random.default_rng(0).random((8, 8, 3)).astype(np.float32)
    d = Path(dump_pngs("selftest", a, a * 0.5))
    for name in ("mitsuba.png", "torch.png", "diff.png"):
        assert np.asarray(Image.open(d / name)).shape == (8, 8, 3)
