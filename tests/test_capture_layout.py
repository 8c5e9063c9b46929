"""One home for the capture scene and the packed map layout (issue #13): the layout round-trips through every
representation (numpy packed, plugin planes, torch slices), and no module restates the scene's numbers."""
from __future__ import annotations

import ast
from pathlib import Path

import numpy as np

from materials import capture
from materials.maps import CHANNEL_NAMES, MAP_CHANNELS, MAP_SLICES, N_CHANNELS, SVBRDF, pack_maps, unpack_maps

ROOT = Path(__file__).resolve().parents[1]


def _maps(rng, h=5, w=7) -> SVBRDF:
    """Distinct values in every channel, so any swapped or shifted channel shows."""
    return SVBRDF(normal=rng.random((h, w, 3), np.float32), diffuse=rng.random((h, w, 3), np.float32),
                  specular=rng.random((h, w, 3), np.float32), roughness=rng.random((h, w, 1), np.float32))


def test_layout_is_the_map_order():
    assert N_CHANNELS == sum(MAP_CHANNELS.values()) == len(CHANNEL_NAMES) == 10
    assert [(k, s.stop - s.start) for k, s in MAP_SLICES.items()] == list(MAP_CHANNELS.items())
    assert MAP_SLICES["normal"].start == 0 and MAP_SLICES["roughness"].stop == N_CHANNELS


def test_pack_unpack_round_trip_numpy():
    m = _maps(np.random.default_rng(0))
    packed = pack_maps(m)
    assert packed.shape == (5, 7, 10) and packed.dtype == np.float32
    back = unpack_maps(packed)
    for k in MAP_CHANNELS:
        np.testing.assert_array_equal(getattr(back, k), getattr(m, k))
        assert getattr(back, k).flags.c_contiguous
    back.normal[...] = -1  # copies: the packed array is not changed through the maps
    assert (packed[..., MAP_SLICES["normal"]] >= 0).all()


def test_plugin_planes_and_torch_slices_read_the_same_channels():
    """The Mitsuba planes (pack -> planes -> maps) and the torch renderer's slices address the same maps."""
    import torch

    from storage.views import planes_of, svbrdf_of
    from train.brdf import DIFFUSE, NORMAL, ROUGHNESS, SPECULAR

    m = _maps(np.random.default_rng(1), 6, 6)
    back = svbrdf_of(planes_of(m), 6)
    for k in MAP_CHANNELS:
        np.testing.assert_array_equal(getattr(back, k), getattr(m, k))
    t = torch.from_numpy(pack_maps(m)).permute(2, 0, 1)[None]  # (1, 10, H, W), the training layout
    for k, sl in (("normal", NORMAL), ("diffuse", DIFFUSE), ("specular", SPECULAR), ("roughness", ROUGHNESS)):
        np.testing.assert_array_equal(t[0, sl].permute(1, 2, 0).numpy(), getattr(m, k))


def test_scene_constants():
    assert capture.CAMERA_DISTANCE == 1.0 / np.tan(np.radians(25.0))  # DESIGN.md: FOV 50 degrees, 2x2 plane
    assert capture.FLASH_INTENSITY == np.pi * capture.CAMERA_DISTANCE**2
    assert capture.ALPHA_MIN == 1e-4 and capture.ROUGHNESS_MIN**2 == capture.ALPHA_MIN


def _restated(path: Path) -> list[str]:
    """Numbers of the capture scene written out again in a module: the Fresnel constants, or a tan/radians of
    the half field of view (the camera distance)."""
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Constant) and node.value in (capture.FRESNEL_SG_A, capture.FRESNEL_SG_B):
            found.append(f"{path.relative_to(ROOT)}:{node.lineno}: Fresnel constant {node.value}")
        if (isinstance(node, ast.Call) and getattr(node.func, "attr", getattr(node.func, "id", "")) == "radians"
                and any(isinstance(a, ast.Constant) and a.value == capture.FOV_DEG / 2 for a in node.args)):
            found.append(f"{path.relative_to(ROOT)}:{node.lineno}: camera half field of view")
    return found


def test_no_module_restates_the_scene():
    """materials.capture is the only home of these numbers in the code (tests may restate them to check it)."""
    home = ROOT / "materials" / "capture.py"
    found = [f for pkg in ("materials", "pipeline", "train", "benchmarks", "scripts")
             for p in sorted((ROOT / pkg).rglob("*.py")) if p != home for f in _restated(p)]
    assert not found, found
