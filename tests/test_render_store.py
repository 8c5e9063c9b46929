"""`svgen render` and the renders store: reader contents, alignment of stored images with recomputed maps,
8-bit sRGB encoding, worker-count invariance, bad inputs."""
from __future__ import annotations

import numpy as np
import pytest
import zarr

from conftest import tree_digest
from pipeline.config import RenderConfig, SampleConfig
from storage.srgb8 import _thresholds, decode_srgb8, encode_srgb8, encode_srgb8_reference
from pipeline.render.scene import FlashScene
from pipeline.render.stage import run_render
from storage.renders_store import RendersReader
from pipeline.sample import run_sample
from storage.store import StoreWriter, write_chunk
from storage.svbrdf_store import encode_maps, map_specs
from svcore.config import build

PRESETS = ("paint/glossy_red", "metal/aluminium_plate")
RENDER = ("--config-preset", "tiny", "--chunk", "1")


@pytest.fixture(scope="module")
def variants(tmp_path_factory):
    """4 variants (2 presets x 2) of 64^2 maps, written in-process."""
    out = tmp_path_factory.mktemp("render_in") / "variants.zarr"
    run_sample(out, build(SampleConfig, "tiny", presets=PRESETS, per_preset=2), workers=0)
    return out


@pytest.fixture(scope="module")
def renders(variants, tmp_path_factory):
    """Its renders store, in-process (2 views per SVBRDF at 64^2: the tiny config)."""
    out = tmp_path_factory.mktemp("render_out") / "renders.zarr"
    run_render(variants, out, build(RenderConfig, "tiny", chunk=1), workers=0)
    return out


def test_reader_serves_every_view(renders):
    r = RendersReader(renders)
    assert len(r) == 8 and r.res == 64
    for i in range(len(r)):
        img = r.image(i)
        assert img.shape == (64, 64, 3) and img.dtype == np.float32 and 0 <= img.min() and img.max() <= 1
        assert img.mean() > 0.02
        m = r.maps(i).validate()
        assert m.normal.shape == (64, 64, 3)
        src = r.source(i)
        assert src["svbrdf"] == i // 2 and src["input_index"] == i // 2 and src["input_kind"] == "variants"
        assert src["render_seed"] == r.view_params(i).seed
    assert len({r.view_params(i).seed for i in range(len(r))}) == 8
    with pytest.raises(IndexError):
        r.image(8)


def test_attributes_describe_the_store(renders):
    a = dict(zarr.open_group(renders, mode="r").attrs)
    assert a["svgen"]["kind"] == "renders" and a["svgen"]["complete"]
    assert a["svgen"]["arrays"]["image"]["encoding"].startswith("sRGB")
    assert a["scene"]["light_model"] == "point" and a["scene"]["fov_deg"] == 50.0
    assert {"mitsuba", "drjit", "zarr"} <= set(a["svgen"]["versions"])
    assert a["config"]["views"] == 2 and a["view_distribution"]["zoom"] == [0.7, 1.4]


def test_a_zoom_range_is_recorded_and_rendered_and_the_default_left_out(variants, renders, tmp_path):
    """``render.zoom``: the default range is not in the recorded config (a store made before the key had the same
    bytes); another range is recorded, drives every view's zoom, and the reader's maps follow it (the stored image
    is the render of the recomputed maps, bit for bit)."""
    assert "zoom" not in zarr.open_group(renders, mode="r").attrs["config"]
    out = tmp_path / "zoomed.zarr"
    run_render(variants, out, build(RenderConfig, "tiny", chunk=1, zoom=(1.5, 1.5)), workers=0)
    a = dict(zarr.open_group(out, mode="r").attrs)
    assert a["config"]["zoom"] == [1.5, 1.5] and a["view_distribution"]["zoom"] == [1.5, 1.5]
    r = RendersReader(out)
    assert {r.view_params(i).zoom for i in range(len(r))} == {1.5}
    scene = FlashScene(r.res, a["config"]["spp"], a["config"]["light"], a["config"]["sampler"])
    v = r.view_params(1)
    assert np.array_equal(encode_srgb8(scene.render_maps(r.maps(1), v)), np.asarray(r.group["image"][0, 1]))
    assert not np.array_equal(np.asarray(r.group["image"][0, 1]),
                              np.asarray(zarr.open_group(renders, mode="r")["image"][0, 1]))


def test_stored_images_line_up_with_the_recomputed_maps(renders):
    """Rendering reader.maps(i) under reader.view_params(i) gives back the stored image bit for bit: the maps
    the reader recomputes are exactly the textures the render used."""
    r = RendersReader(renders)
    cfg = r.attrs["config"]
    scene = FlashScene(r.res, cfg["spp"], cfg["light"], cfg["sampler"])
    for i in (0, 3, 6):
        v = r.view_params(i)
        again = encode_srgb8(scene.render_maps(r.maps(i), v))
        stored = np.asarray(r.group["image"][i // 2, i % 2])
        assert np.array_equal(again, stored)


def test_worker_count_does_not_change_a_byte(variants, renders, tmp_path):
    out = tmp_path / "r2.zarr"
    run_render(variants, out, build(RenderConfig, "tiny", chunk=1), workers=2)
    assert tree_digest(out) == tree_digest(renders)


def test_srgb8_matches_colour_science():
    """Fast table encoding == round(255 * colour.cctf_encoding(x)); at exact code boundaries (within 1 float32
    ulp of a threshold) the float64 reference may round either way, so those values are excluded."""
    rng = np.random.default_rng(0)
    x = np.concatenate([rng.random(200_000) ** 3, np.linspace(0, 1, 100_001), [0.0, 1.0]]).astype(np.float32)
    t = _thresholds()
    near = np.abs(x[:, None] - t[None, :]).min(1) <= np.spacing(np.float32(1.0))
    fast, ref = encode_srgb8(x), encode_srgb8_reference(x)
    assert np.array_equal(fast[~near], ref[~near]) and (~near).sum() > 290_000
    assert np.abs(fast.astype(int) - ref.astype(int)).max() <= 1
    # round trip: within half a code step (the largest linear step, 254 -> 255, is 0.0089)
    assert np.abs(decode_srgb8(fast) - np.clip(x, 0, 1)).max() < 0.00446


def test_drjit_encoder_gives_numpys_codes():
    """The render's drjit encoder (:class:`storage.srgb8.DrjitEncoder`), on one array and channel by channel inside a
    kernel, gives :func:`encode_srgb8`'s codes exactly: the same bucket rule, on every threshold, the float32
    neighbours of every threshold, and values outside [0, 1] (clipped). Channels come back side by side."""
    from storage.srgb8 import DrjitEncoder

    from svcore.mi_env import mi

    t = _thresholds()
    x = np.concatenate([t, np.nextafter(t, np.float32(0)), np.nextafter(t, np.float32(2)), [-1.0, 0.0, 1.0, 2.5],
                        np.random.default_rng(1).random(3_000) ** 2]).astype(np.float32)
    want = encode_srgb8(x)
    enc = DrjitEncoder()
    np.testing.assert_array_equal(enc(mi.Float(x)), want)
    k = len(x) // 3
    rgb = x[: 3 * k].reshape(k, 3)
    got = enc.channels([mi.Float(rgb[:, c]) * 1.0 for c in range(3)])  # traced channels, as a render's
    assert got.shape == (k, 3) and got.dtype == np.uint8
    np.testing.assert_array_equal(got, want[: 3 * k].reshape(k, 3))


def _bad_variants(path, normal_z: float):
    """A variants-kind store whose normals have z = normal_z (z <= 0 breaks DESIGN.md)."""
    n = 2
    with StoreWriter(path, "variants", n, 1, {**map_specs(16), **_extra_specs()}, {"test": "bad"}) as w:
        for c in range(n):
            nm = np.zeros((16, 16, 3), np.float32)
            nm[..., 0] = np.sqrt(1 - normal_z**2)
            nm[..., 2] = normal_z
            m = {k: v[None] for k, v in encode_maps(_svbrdf(nm)).items()}
            write_chunk(w.partial, c, c, {**m, "seed": np.array([c], np.uint64), "preset": np.array([[0, -1]], np.int32)})
        w.finalize()


def _extra_specs():
    from storage.store import ArraySpec

    return {"seed": ArraySpec((), "uint64"), "preset": ArraySpec((2,), "int32")}


def _svbrdf(normal):
    from materials.maps import SVBRDF

    h = normal.shape[0]
    return SVBRDF(normal=normal, diffuse=np.full((h, h, 3), 0.5, np.float32),
                  specular=np.full((h, h, 3), 0.04, np.float32), roughness=np.full((h, h, 1), 0.5, np.float32))


@pytest.mark.parametrize(("args", "message"), [
    (("{renders}", "{tmp}/o.zarr"), "is a renders store, expected a variants or blends or stress store"),
    (("{tmp}/nothing.zarr", "{tmp}/o.zarr"), "no store at"),
    (("{variants}", "{renders}"), "already exists"),
    (("{variants}", "{tmp}/o.zarr", "--views", "0"), "render.views must be >= 1"),
    (("{variants}", "{tmp}/o.zarr", "--res", "8"), "render.res must be >= 16"),
    (("{variants}", "{tmp}/o.zarr", "--sampler", "centre", "--spp", "2"), "needs a square spp"),
    (("{variants}", "{tmp}/o.zarr", "--light", "laser"), "Invalid value for '--light'"),
    (("{variants}", "{tmp}/o.zarr", "--bogus"), "No such option"),
    # an unreachable --scheduler-address: tests/test_bad_input.py (each case waits out the 10 s connect timeout)
    (("{bad}", "{tmp}/o.zarr", "--workers", "0"), "normals with z <= 0"),
])
def test_bad_input_gives_one_line_and_nonzero_exit(args, message, variants, renders, tmp_path, svgen_cli):
    bad = tmp_path / "bad.zarr"
    _bad_variants(bad, -0.2)
    before = tree_digest(renders)
    fmt = {"renders": renders, "variants": variants, "tmp": tmp_path, "bad": bad}
    code, msg = svgen_cli("render", *[a.format(**fmt) for a in args], *RENDER)
    assert code != 0
    assert message in msg, msg
    assert len(msg.strip().splitlines()) == 1, msg
    assert "Traceback" not in msg
    assert not (tmp_path / "o.zarr").exists()
    assert tree_digest(renders) == before  # nothing overwritten


def test_crop_window_equals_cropping_the_full_view(renders):
    """The training loader's window transform gives exactly the pixels of the full image and maps."""
    r = RendersReader(renders)
    for i in range(len(r)):
        img, m = r.crop(i, 5, 17, 32)
        full_i, full_m = r.image(i), r.maps(i)
        assert np.array_equal(img, full_i[5:37, 17:49])
        for k in ("normal", "diffuse", "specular", "roughness"):
            assert np.array_equal(getattr(m, k), getattr(full_m, k)[5:37, 17:49]), k
