"""The torch BRDF and flash renderer: finite values/gradients at every edge, conventions, agreement."""
from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from train.brdf import ggx_cos
from materials.brdf_reference import design_brdf
from materials.capture import CAMERA_DISTANCE, FLASH_INTENSITY
from train.render import flash_render, plane_points

# Edge values on purpose: 0/1 albedo, roughness 0, grazing/horizon/below-surface directions.
unit = st.sampled_from([0.0, 1e-7, 1e-3, 0.5, 1.0 - 1e-7, 1.0])
coord = st.sampled_from([-1.0, -0.5, -1e-6, 0.0, 1e-6, 0.3, 1.0])


def _vec(x, y, z):
    return torch.tensor([x, y, z], dtype=torch.float32).reshape(1, 3, 1, 1)


@settings(max_examples=300, deadline=None)
@given(nx=coord, ny=coord, nz=coord, lx=coord, ly=coord, lz=coord, vx=coord, vy=coord, vz=coord,
       d=unit, s=unit, r=unit)
def test_values_and_gradients_finite_at_edges(nx, ny, nz, lx, ly, lz, vx, vy, vz, d, s, r):
    maps = torch.tensor([nx, ny, nz, d, d, d, s, s, s, r], dtype=torch.float32).reshape(1, 10, 1, 1)
    maps.requires_grad_(True)
    wi = _vec(lx, ly, lz).requires_grad_(True)
    wo = _vec(vx, vy, vz).requires_grad_(True)
    out = ggx_cos(maps, wi, wo)
    assert torch.isfinite(out).all() and (out >= 0).all()
    torch.log(out + 0.01).sum().backward()
    for t in (maps, wi, wo):
        assert torch.isfinite(t.grad).all(), (t.grad, maps, wi, wo)


def test_light_below_surface_is_black():
    maps = torch.tensor([0, 0, 1, .5, .5, .5, .04, .04, .04, .5], dtype=torch.float32).reshape(1, 10, 1, 1)
    assert ggx_cos(maps, _vec(0.3, 0, -1), _vec(0, 0, 1)).abs().max() == 0


def test_matches_design_formula_at_a_generic_point():
    """ggx_cos equals the reference (materials.brdf_reference, float64) at a point where nothing is clamped."""
    n = np.array([0.2, -0.1, 1.0]); n /= np.linalg.norm(n)
    l = np.array([0.4, 0.3, 1.0]); l /= np.linalg.norm(l)
    v = np.array([-0.2, 0.1, 1.0]); v /= np.linalg.norm(v)
    d, s, r = np.array([0.6, 0.3, 0.1]), np.array([0.04, 0.05, 0.9]), 0.4
    nl = n @ l
    f = design_brdf(n, v, l, d, s, np.array([r]))
    maps = torch.tensor([*n, *d, *s, r], dtype=torch.float32).reshape(1, 10, 1, 1)
    got = ggx_cos(maps, torch.tensor(l, dtype=torch.float32).reshape(1, 3, 1, 1),
                  torch.tensor(v, dtype=torch.float32).reshape(1, 3, 1, 1))
    np.testing.assert_allclose(got.flatten().numpy(), f * nl, rtol=1e-5)


def test_pixel_centres_and_orientation():
    p = plane_points(4, 2)
    assert p.shape == (1, 3, 4, 2)
    np.testing.assert_allclose(p[0, :, 0, 0].numpy(), [-0.5, 0.75, 0.0])  # row 0 = top (y up), col 0 = left
    np.testing.assert_allclose(p[0, :, 3, 1].numpy(), [0.5, -0.75, 0.0])


def test_flash_render_white_lambertian_centre_and_falloff():
    h = w = 64
    maps = torch.zeros(1, 10, h, w)
    maps[:, 2] = 1.0
    maps[:, 3:6] = 1.0
    maps[:, 9] = 1.0
    img = flash_render(maps, torch.zeros(2), clip=False)
    # I = pi D^2: irradiance pi at the centre, so a white Lambertian (s = 0) renders ~1 there
    x = 1.0 / w
    expect = FLASH_INTENSITY / math.pi * CAMERA_DISTANCE / (CAMERA_DISTANCE ** 2 + 2 * x * x) ** 1.5
    assert img[0, 0, h // 2, w // 2].item() == pytest.approx(expect, rel=2e-2)  # rough part of r=1 adds a little
    assert img[0, 0, 0, 0] < 0.7 * img[0, 0, h // 2, w // 2]  # inverse-square and cosine fall-off to corners


def test_flash_render_light_offset_moves_highlight_up_right():
    maps = torch.zeros(1, 10, 65, 65)
    maps[:, 2] = 1.0
    maps[:, 6:9] = 1.0
    maps[:, 9] = 0.1
    img = flash_render(maps, torch.tensor([0.6, 0.6]), clip=False)[0, 0]
    i, j = np.unravel_index(int(img.argmax()), img.shape)
    # mirror point halfway between camera and light: (0.3, 0.3) -> right of centre, above centre (row < 32)
    assert j > 32 and i < 32
    assert -1 + (j + 0.5) * 2 / 65 == pytest.approx(0.3, abs=0.04)
    assert 1 - (i + 0.5) * 2 / 65 == pytest.approx(0.3, abs=0.04)
