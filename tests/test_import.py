"""`svgen import`: fixture folders written here (ambientCG, MatSynth, specular workflow, 16-bit PNG, EXR, 2018
strips), the round trip with `svgen export --format deschaintre`, worker-count invariance and resume."""
from __future__ import annotations

import json

import numpy as np
import pytest

from import_fixtures import ambientcg, bumpy_normals, exr, height_field, matsynth, png8, png16, unit
from pipeline.config import ImportConfig
from pipeline.importer.job import run_import
from storage.svbrdf_store import SVBRDFStore
from svcore.config import build
from svcore.image_io import srgb_decode
from conftest import dump_maps, tree_digest

Q8 = 1 / 255  # one 8-bit step
Q16 = 1 / 65535


def imp(src, out, workers=0, **kw):
    srcs = tuple(map(str, src)) if isinstance(src, (list, tuple)) else (str(src),)
    return run_import(out, build(ImportConfig, sources=srcs, **kw), workers=workers)


def by_name(path):
    st = SVBRDFStore(path)
    recs = {m["name"]: (i, m) for i, m in enumerate(st.attrs["materials"])}
    return st, recs


def test_ambientcg_gl_and_dx_give_the_same_normals(tmp_path, rng):
    n = bumpy_normals(64, rng)
    dx = n * np.array([1, -1, 1], np.float32)
    ambientcg(tmp_path / "src", "GL", 64, np.random.default_rng(1), {"GL": n})
    ambientcg(tmp_path / "src", "DX", 64, np.random.default_rng(1), {"DX": dx})
    ambientcg(tmp_path / "src", "Both", 64, np.random.default_rng(1), {"GL": n, "DX": dx})
    imp(tmp_path / "src", tmp_path / "a.zarr", size=32)
    st, recs = by_name(tmp_path / "a.zarr")
    gl, dxm, both = (st.maps(recs[k][0]).normal for k in ("GL", "DX", "Both"))
    # the DX file differs from the GL file only by the flipped green; after decoding both are the same vectors
    # up to 8-bit quantisation of the files (normals move by < 2 steps of (n+1)/2, i.e. < 4/255)
    assert np.abs(gl - dxm).max() < 4 * Q8, dump_maps(st.maps(recs["DX"][0]), "dx")
    assert np.abs(gl - both).max() < 1e-6
    assert recs["DX"][1]["normal"] == {"from": "normal map", "convention": "directx", "decided_by": "file name"}
    assert "Both_2K-PNG_NormalDX.png" in recs["Both"][1]["ignored"]
    assert "Both_2K-PNG_AmbientOcclusion.png" in recs["Both"][1]["ignored"]
    # against the analytic normals, area-averaged 64 -> 32
    ref = unit(n.reshape(32, 2, 32, 2, 3).mean((1, 3)))
    assert np.abs(gl - ref).max() < 4 * Q8
    # forcing directx on the folder with both picks the DX file: still the same normals
    imp(tmp_path / "src", tmp_path / "b.zarr", size=32, normal_convention="directx")
    st2, recs2 = by_name(tmp_path / "b.zarr")
    assert recs2["Both"][1]["files"]["normal"].endswith("NormalDX.png")
    assert np.abs(st2.maps(recs2["Both"][0]).normal - gl).max() < 4 * Q8


def test_bumpy_normals_fixture_draws_from_its_rng():
    """The fixture's rng is live (issue #28): two draws give two different normal maps, one seed the same map."""
    a, b = bumpy_normals(16, np.random.default_rng(1)), bumpy_normals(16, np.random.default_rng(2))
    assert np.abs(a - b).max() > 0.1
    np.testing.assert_array_equal(a, bumpy_normals(16, np.random.default_rng(1)))
    np.testing.assert_allclose(np.linalg.norm(a, axis=-1), 1, atol=1e-6)


def test_matsynth_metallic_and_height(tmp_path, rng):
    s = 64
    base = rng.random((s, s, 3)) * 0.9 + 0.05
    metal = np.zeros((s, s))
    metal[:, s // 2:] = 1.0
    h, grad = height_field(s)
    matsynth(tmp_path / "src", "steel", s, base, metal, h, {"category": "metal", "license": "CC-BY-4.0"})
    strength = 0.2
    imp(tmp_path / "src", tmp_path / "m.zarr", size=s, height_strength=strength)
    st, recs = by_name(tmp_path / "m.zarr")
    i, rec = recs["steel"]
    m = st.maps(i)
    lin = srgb_decode(np.round(base * 65535) / 65535)
    # metallic = 1: no diffuse, F0 = linear base colour; metallic = 0: diffuse = base colour, F0 = 0.04
    assert np.abs(m.diffuse[:, s // 2:]).max() <= Q16
    assert np.abs(m.specular[:, s // 2:] - lin[:, s // 2:]).max() < 2 * Q16
    assert np.abs(m.diffuse[:, :s // 2] - lin[:, :s // 2]).max() < 2 * Q16
    assert np.abs(m.specular[:, :s // 2] - 0.04).max() < 2 * Q16
    # height-derived normals agree with the analytic surface z = strength * h: n ~ (-s dh/du, -s dh/dv, 1);
    # central differences over 1/64 of the period err by (2 pi / 64)^2 / 6 = 1.6 % of the slope (max slope 0.31)
    c = (np.arange(s) + 0.5) / s
    u, v = np.meshgrid(c, 1 - c)
    gu, gv = grad(u, v)
    ref = unit(np.stack([-strength * gu, -strength * gv, np.ones_like(gu)], -1))
    err = np.abs(m.normal - ref).max()
    assert err < 0.01, (err, dump_maps(m, "matsynth"))
    assert rec["normal"] == {"from": "height", "height_strength": strength}
    assert rec["category"] == "metal" and rec["licence"] == "CC-BY-4.0"
    assert rec["preset"] == "metal/steel" and rec["workflow"] == "metallic"
    assert rec["maps"]["basecolor"]["bits"] == 16 and "sRGB" in rec["maps"]["basecolor"]["space"]
    assert rec["maps"]["height"]["space"].startswith("data")


def test_fractional_metallic_follows_the_documented_blend(tmp_path, rng):
    """docs/IMPORT.md's metallic/roughness conversion at fractional metalness: d = b (1 - m), s = 0.04 (1 - m) + b m,
    at eight metalness values in [0, 1] (8-bit codes, decoded exactly as code / 255), one per 8-pixel band."""
    s = 64
    codes = np.array([0, 32, 64, 96, 128, 160, 224, 255])
    metal = np.repeat(codes / 255, s // len(codes))[None, :].repeat(s, 0)
    base = rng.random((s, s, 3)) * 0.9 + 0.05
    matsynth(tmp_path / "src", "alloy", s, base, metal, height_field(s)[0])
    imp(tmp_path / "src", tmp_path / "m.zarr", size=s)
    st, recs = by_name(tmp_path / "m.zarr")
    got = st.maps(recs["alloy"][0])
    b, m = srgb_decode(np.round(base * 65535) / 65535), metal[..., None]
    # the expected maps in float64 from the formula; stored as 16-bit codes: within one code plus rounding
    np.testing.assert_allclose(got.diffuse, b * (1 - m), rtol=0, atol=2 * Q16)
    np.testing.assert_allclose(got.specular, 0.04 * (1 - m) + b * m, rtol=0, atol=2 * Q16)


def test_normal_convention_from_height_agreement(tmp_path):
    s = 64
    h, grad = height_field(s)
    c = (np.arange(s) + 0.5) / s
    u, v = np.meshgrid(c, 1 - c)
    gu, gv = grad(u, v)
    n = unit(np.stack([-0.2 * gu, -0.2 * gv, np.ones_like(gu)], -1))
    for name, flip in (("plain_gl", 1), ("plain_dx", -1)):
        d = tmp_path / "src" / name
        d.mkdir(parents=True)
        png8(d / "albedo.png", np.full((s, s, 3), 0.5))
        png8(d / "normal.png", (n * np.array([1, flip, 1]) + 1) / 2)
        png16(d / "height.png", h)
    imp(tmp_path / "src", tmp_path / "o.zarr", size=s)
    st, recs = by_name(tmp_path / "o.zarr")
    assert recs["plain_gl"][1]["normal"]["convention"] == "opengl"
    assert recs["plain_dx"][1]["normal"]["convention"] == "directx"
    assert recs["plain_dx"][1]["normal"]["decided_by"] == "height gradient agreement"
    assert np.abs(st.maps(recs["plain_gl"][0]).normal - st.maps(recs["plain_dx"][0]).normal).max() < 4 * Q8


def test_specular_workflow_and_glossiness(tmp_path, rng):
    s = 32
    d = tmp_path / "src" / "leather"
    d.mkdir(parents=True)
    diff, spec, gloss = rng.random((s, s, 3)), rng.random((s, s, 3)) * 0.3, rng.random((s, s))
    png8(d / "leather_diffuse.png", diff)
    png8(d / "leather_specular.png", spec)
    png8(d / "leather_glossiness.png", gloss)
    png8(d / "leather_basecolor.png", rng.random((s, s, 3)))  # MatSynth ships both: the specular pair wins
    _, mats = imp(tmp_path / "src", tmp_path / "o.zarr", size=s)
    st, recs = by_name(tmp_path / "o.zarr")
    m = st.maps(0)
    assert np.abs(m.diffuse - srgb_decode(np.round(diff * 255) / 255)).max() < 2 * Q16
    assert np.abs(m.specular - srgb_decode(np.round(spec * 255) / 255)).max() < 2 * Q16
    assert np.abs(m.roughness[..., 0] - (1 - np.round(gloss * 255) / 255)).max() < 2 * Q16
    rec = recs["leather"][1]
    assert rec["workflow"] == "specular" and rec["roughness_from"] == "1 - glossiness"
    assert rec["files"]["basecolor"] == "leather_diffuse.png" and "leather_basecolor.png" in rec["ignored"]
    assert any("flat normals" in w for w in rec["warnings"])


def test_exr_and_16bit_inputs(tmp_path, rng):
    s = 32
    d = tmp_path / "src" / "tile"
    d.mkdir(parents=True)
    base = rng.random((s, s, 3)).astype(np.float32)
    rough = rng.random((s, s)).astype(np.float32) * 1.2  # > 1 in places: clipped and recorded
    exr(d / "tile_BaseColor.exr", base)
    exr(d / "tile_Roughness.exr", rough, "Y")
    n = bumpy_normals(s, rng)
    exr(d / "tile_Normal.exr", n[..., :2], "RG")  # two channels: z reconstructed
    st_path, _ = imp(tmp_path / "src", tmp_path / "o.zarr", size=s)
    st, recs = by_name(st_path)
    m = st.maps(0)
    assert np.abs(m.diffuse - base).max() < Q16  # EXR is linear: no transfer function
    assert np.abs(m.roughness[..., 0] - np.clip(rough, 0, 1)).max() < Q16
    assert np.abs(m.normal - n).max() < 1e-3
    rec = recs["tile"][1]
    assert rec["maps"]["basecolor"]["space"] == "linear (float file)"
    assert rec["maps"]["roughness"]["clipped_fraction"] == pytest.approx(float((rough > 1).mean()))


def strip_of(image, maps_n, diff, rough, spec):
    return np.concatenate([image, (maps_n + 1) / 2, diff, np.repeat(rough[..., None], 3, -1), spec], axis=1)


def test_deschaintre_strip_variants_and_renders(tmp_path, rng):
    from storage.renders_store import RendersReader

    t = 32
    img, diff, spec = rng.random((t, t, 3)), rng.random((t, t, 3)), rng.random((t, t, 3)) * 0.5
    rough, n = rng.random((t, t)), bumpy_normals(t, rng)
    (tmp_path / "strips").mkdir()
    png8(tmp_path / "strips" / "0001;sample.png", strip_of(img, n, diff, rough, spec))
    path, mats = imp(tmp_path / "strips", tmp_path / "v.zarr", size=t)
    assert mats[0]["layout"] == "deschaintre"
    m = SVBRDFStore(path).maps(0)
    for got, want in ((m.diffuse, diff), (m.specular, spec), (m.roughness[..., 0], rough)):
        assert np.abs(got - want).max() <= 0.5 * Q8 + Q16  # linear as stored: only the file's 8-bit rounding
    assert np.abs(m.normal - n).max() < 2 * Q8
    path, _ = imp(tmp_path / "strips", tmp_path / "r.zarr", size=t, as_kind="renders")
    r = RendersReader(path)
    assert len(r) == 1 and r.res == t
    # the photo tile as the view's image: 8-bit linear codes re-stored as 8-bit sRGB codes; sRGB steps are at most
    # 1.3 % of linear range near 1, so the round trip is within 0.5 of such a step
    assert np.abs(r.image(0) - np.round(img * 255) / 255).max() < 0.007
    assert np.abs(r.maps(0).diffuse - m.diffuse).max() < 1e-6  # identity view transform
    assert np.abs(r.maps(0).normal - m.normal).max() < 1e-4


def test_roundtrip_with_export(tmp_path):
    from pipeline.config import SampleConfig
    from pipeline.export import export
    from pipeline.render.stage import RenderConfig, run_render
    from storage.renders_store import RendersReader
    from pipeline.sample import run_sample

    run_sample(tmp_path / "v.zarr", build(SampleConfig, "tiny", presets=("paint/glossy_red", "wood/oak_planks"),
                                          per_preset=1), workers=0)
    run_render(tmp_path / "v.zarr", tmp_path / "r.zarr", build(RenderConfig, "tiny", views=2), workers=0)
    export(tmp_path / "r.zarr", tmp_path / "strips", "deschaintre")
    path, mats = imp(tmp_path / "strips", tmp_path / "back.zarr", size=64, layout="deschaintre")
    r, back = RendersReader(tmp_path / "r.zarr"), SVBRDFStore(path)
    names = [m["name"] for m in mats]
    for i in range(len(r)):
        want, got = r.maps(i), back.maps(names.index(f"{i:07d}"))
        for k in ("diffuse", "specular", "roughness"):
            err = np.abs(getattr(got, k) - getattr(want, k)).max()
            assert err <= 0.5 * Q8 + Q16, (k, err, dump_maps(got, "roundtrip"))
        # normals: each (n+1)/2 component rounded to 8 bits, then renormalised
        assert np.abs(got.normal - want.normal).max() < 2 * Q8
    path, _ = imp(tmp_path / "strips", tmp_path / "back_r.zarr", size=64, as_kind="renders")
    rr = RendersReader(path)
    assert np.abs(rr.image(names.index("0000001")) - r.image(1)).max() < 0.007


def test_same_bytes_for_any_worker_count_and_resume(tmp_path, rng, monkeypatch):
    from pipeline.importer import job

    for k in range(5):
        ambientcg(tmp_path / "src", f"M{k}", 32, np.random.default_rng(k), {"GL": bumpy_normals(32, rng)})
    a, _ = imp(tmp_path / "src", tmp_path / "w0.zarr", size=16, chunk=2)
    b, _ = imp(tmp_path / "src", tmp_path / "w2.zarr", workers=2, size=16, chunk=2)
    # the output's own name is not part of the bytes (sources are resolved): compare the two trees
    assert tree_digest(a) == tree_digest(b)
    # a run killed after its first chunk resumes and gives the same bytes
    real = job._chunk_task

    def dies_after_first(c, threads, **kw):
        if c == 1:
            raise KeyboardInterrupt
        return real(c, threads, **kw)

    # the store names the code of its task's module (storage.local, code_of): the stand-in is the same stage's task
    dies_after_first.__module__ = real.__module__
    monkeypatch.setattr(job, "_chunk_task", dies_after_first)
    with pytest.raises(KeyboardInterrupt):
        imp(tmp_path / "src", tmp_path / "k.zarr", size=16, chunk=2)
    assert (tmp_path / "k.zarr.partial").exists() and not (tmp_path / "k.zarr").exists()
    monkeypatch.setattr(job, "_chunk_task", real)
    c, _ = imp(tmp_path / "src", tmp_path / "k.zarr", size=16, chunk=2)
    assert tree_digest(c) == tree_digest(a)
    assert json.loads((tmp_path / "k.zarr" / "zarr.json").read_text())["attributes"]["materials"][0]["name"] == "M0"


def test_mixed_sizes_upscale_and_input_space(tmp_path, svgen_cli, rng):
    from storage.renders_store import RendersReader

    d = tmp_path / "src" / "mixed"
    d.mkdir(parents=True)
    base = rng.random((32, 32, 3))
    png8(d / "color.png", np.kron(base, np.ones((2, 2, 1))))  # 64^2 colour, 32^2 roughness: same surface
    png8(d / "rough.png", np.full((32, 32), 0.3))
    code, out = svgen_cli("import", tmp_path / "src", tmp_path / "a.zarr", "--size", 64, "--workers", 0)
    assert code == 2 and "--allow-upscale" in out
    code, out = svgen_cli("import", tmp_path / "src", tmp_path / "a.zarr", "--size", 64, "--workers", 0,
                          "--allow-upscale")
    assert code == 0, out
    m = SVBRDFStore(tmp_path / "a.zarr").maps(0)
    assert np.abs(m.roughness - 0.3).max() < 0.5 * Q8 + Q16  # a constant stays constant when enlarged
    code, out = svgen_cli("import", tmp_path / "src", tmp_path / "b.zarr", "--size", 32, "--workers", 0)
    assert code == 0, out
    m = SVBRDFStore(tmp_path / "b.zarr").maps(0)
    assert np.abs(m.diffuse - srgb_decode(np.round(base * 255) / 255)).max() < 2 * Q16  # 2x2 blocks averaged back
    # --input-space srgb decodes the strip's photo; linear keeps it
    (tmp_path / "strips").mkdir()
    t = 16
    img = rng.random((t, t, 3))
    n = np.zeros((t, t, 3))
    n[..., 2] = 1
    png8(tmp_path / "strips" / "s.png", strip_of(img, n, img, img[..., 0], img * 0.1))
    for space, want in (("linear", np.round(img * 255) / 255), ("srgb", srgb_decode(np.round(img * 255) / 255))):
        out_p = tmp_path / f"r_{space}.zarr"
        code, out = svgen_cli("import", tmp_path / "strips", out_p, "--as", "renders", "--size", t,
                              "--input-space", space, "--workers", 0)
        assert code == 0, out
        assert np.abs(RendersReader(out_p).image(0) - want).max() < 0.007
        assert RendersReader(out_p).attrs["config"]["input_space"] == space


@pytest.mark.parametrize("src", [96, 128])
def test_resampling_is_an_area_average_and_keeps_tiling(src, rng):
    from pipeline.importer.resample import resize

    a = rng.random((src, src, 2)).astype(np.float32)
    out = resize(a, 64)
    # the exact area average of the piecewise-constant source, by another route: repeat pixels until the factor is
    # an integer, then block means (Pillow's BOX filter weighs whole pixels and is 1.6 % off on a sine at 96 -> 64)
    rep = 2 if src % 64 else 1
    big = np.repeat(np.repeat(a.astype(np.float64), rep, 0), rep, 1)
    f = big.shape[0] // 64
    want = big.reshape(64, f, 64, f, 2).mean((1, 3))
    assert np.abs(out - want).max() < 1e-5
    # tileable: rolling the source by one output footprint rolls the output by one pixel, seam included
    step = src * rep // 64 // rep if src % 64 == 0 else 3  # 96 -> 64: 3 source pixels = 2 output pixels
    shift = 1 if src % 64 == 0 else 2
    rolled = resize(np.roll(a, (step, -step), (0, 1)), 64)
    assert np.abs(rolled - np.roll(out, (shift, -shift), (0, 1))).max() < 1e-5


def _blocks(s: int, k: int) -> np.ndarray:
    """(s, s) roughness of k x k blocks, each its own 8-bit code: where each output pixel came from is readable."""
    idx = (np.arange(s) * k // s)
    return ((idx[:, None] * k + idx[None, :]) * 3 + 10).astype(np.float64) / 255


def test_crop_window_gives_the_source_pixels_it_covers(tmp_path, rng):
    """Physical scale: import.crop keeps the centre window of the source (crop_centre moves it), a stated physical
    size with capture_cm decides the fraction per material, and the store records both."""
    s = 64
    rough = _blocks(s, 8)
    for name, meta in (("Plain", None), ("Sized", {"physical_size_cm": 200})):
        d = tmp_path / "src" / name
        d.mkdir(parents=True)
        png8(d / "color.png", rng.random((s, s, 3)))
        png8(d / "roughness.png", rough)
        if meta:
            (d / "metadata.json").write_text(json.dumps(meta))
    imp(tmp_path / "src", tmp_path / "c.zarr", size=32, crop=0.5)  # window 32 px = size: the pixels as they are
    st, recs = by_name(tmp_path / "c.zarr")
    i, rec = recs["Plain"]
    got = st.maps(i).roughness[..., 0]
    assert np.abs(got - rough[16:48, 16:48]).max() < 1e-6
    assert rec["crop"] == {"fraction": 0.5, "centre": [0.5, 0.5], "decided_by": "import.crop", "window_pixels": 32}
    assert rec["tileable"] is False
    assert st.attrs["import"]["crop"] == {"fraction": 0.5, "centre": [0.5, 0.5], "capture_cm": None}
    # a window off centre: (x, y) = (0.25, 0.75) of the square, i.e. columns 0..32, rows 32..64
    imp(tmp_path / "src", tmp_path / "o.zarr", size=32, crop=0.5, crop_centre=(0.25, 0.75))
    st, recs = by_name(tmp_path / "o.zarr")
    assert np.abs(st.maps(recs["Plain"][0]).roughness[..., 0] - rough[32:64, 0:32]).max() < 1e-6
    # 50 cm of a tile stated as 200 cm wide: a quarter-width window (16 px, enlarged to 32 by --allow-upscale);
    # the material without a stated size keeps import.crop (1: the whole tile, averaged 2x2)
    imp(tmp_path / "src", tmp_path / "p.zarr", size=32, capture_cm=50, allow_upscale=True)
    st, recs = by_name(tmp_path / "p.zarr")
    i, rec = recs["Sized"]
    assert rec["crop"]["fraction"] == 0.25 and "physical_size_cm 200" in rec["crop"]["decided_by"]
    from pipeline.importer.resample import resize

    codes = np.round(rough * 255).astype(np.uint8)[24:40, 24:40, None]
    assert np.abs(st.maps(i).roughness[..., 0] - resize(codes, 32)[..., 0] / 255).max() < 1e-5
    i, rec = recs["Plain"]
    assert rec["crop"]["fraction"] == 1.0
    want = rough.reshape(32, 2, 32, 2).mean((1, 3))
    assert np.abs(st.maps(i).roughness[..., 0] - want).max() < 1e-6
