"""Rendering loss: zero for identical maps, grows with perturbation; configuration statistics."""
from __future__ import annotations

import numpy as np
import pytest
import torch
from scipy import stats

from train.loss import R1_HIGH, R1_LOW, cosine_hemisphere, rendering_loss, sample_configs
from train.synthetic import SyntheticSource


@pytest.fixture(scope="module")
def maps():
    src = SyntheticSource(4, 64, 4, seed=3)
    return torch.stack([torch.from_numpy(src.packed(i)).permute(2, 0, 1) for i in range(4)])


def test_zero_for_identical_maps(maps):
    g = torch.Generator().manual_seed(0)
    assert rendering_loss(maps, maps.clone(), g).item() == 0.0


def test_grows_with_perturbation(maps):
    noise = torch.randn(maps.shape, generator=torch.Generator().manual_seed(1))
    losses = []
    for eps in (0.01, 0.05, 0.2):
        pert = maps.clone()
        pert[:, 3:10] = (pert[:, 3:10] + eps * noise[:, 3:10]).clamp(0, 1)
        pert[:, 0:2] = pert[:, 0:2] + eps * noise[:, 0:2]
        cfg = sample_configs(len(maps), torch.Generator().manual_seed(2))  # same configs for every eps
        losses.append(rendering_loss(pert, maps, cfg=cfg).item())
    assert 0 < losses[0] < losses[1] < losses[2]


def test_gradient_flows_to_every_map(maps):
    pred = maps.clone().requires_grad_(True)
    with torch.no_grad():
        pred[:, 3:6] *= 0.8
        pred[:, 9] = 0.3
    rendering_loss(pred, maps, torch.Generator().manual_seed(0)).backward()
    g = pred.grad.abs().mean((0, 2, 3))
    assert torch.isfinite(pred.grad).all()
    assert (g[[0, 1, 3, 4, 5, 6, 7, 8, 9]] > 0).all()


def test_configs_fresh_per_sample_and_step():
    g = torch.Generator().manual_seed(0)
    a, b = sample_configs(8, g), sample_configs(8, g)
    assert a.light.shape == (8, 9, 4)
    assert not torch.equal(a.light, b.light)
    assert not torch.allclose(a.light[0], a.light[1])


def test_diffuse_directions_are_cosine_weighted():
    cfg = sample_configs(20000, torch.Generator().manual_seed(0))
    for t in (cfg.light, cfg.view):
        d = t[:, :3]
        assert (d[..., 3] == 0).all()  # distant
        np.testing.assert_allclose(d[..., :3].norm(dim=-1).numpy(), 1, atol=1e-5)
        # cosine-weighted hemisphere <=> sin^2(theta) = 1 - cos^2 uniform on [r1_low, r1_high]
        s2 = 1 - d[..., 2].flatten().double().numpy() ** 2
        p = stats.kstest(s2, stats.uniform(loc=R1_LOW, scale=R1_HIGH - R1_LOW).cdf).pvalue
        assert p > 1e-3
        # azimuth uniform
        phi = torch.atan2(d[..., 1], d[..., 0]).flatten().numpy()
        hist, _ = np.histogram(phi, bins=12, range=(-np.pi, np.pi))
        assert stats.chisquare(hist).pvalue > 1e-3
    # light and view independent
    assert abs(np.corrcoef(cfg.light[:, :3, 2].flatten(), cfg.view[:, :3, 2].flatten())[0, 1]) < 0.03


def test_uniform_cos_would_fail_the_ks_test():
    # the statistic above can fail: a uniform-in-cos sampler is rejected
    z = np.random.default_rng(0).uniform(np.sqrt(1 - R1_HIGH), np.sqrt(1 - R1_LOW), 60000)
    assert stats.kstest(1 - z ** 2, stats.uniform(loc=R1_LOW, scale=R1_HIGH - R1_LOW).cdf).pvalue < 1e-6


def test_specular_configs_mirror_geometry():
    cfg = sample_configs(20000, torch.Generator().manual_seed(1))
    l, v = cfg.light[:, 3:], cfg.view[:, 3:]
    assert (l[..., 3] == 1).all() and (v[..., 3] == 1).all()
    ld, vd = l[..., :3], v[..., :3]
    dl, dv = ld[..., 2], vd[..., 2]
    assert (dl > 0).all() and (dv > 0).all()
    # l = l_dir·a + s, v = v_dir·b + s with l_dir = (-vx, -vy, vz) and s on the plane: the shared shift is
    # where the light-view segment is cut in the ratio of the heights, (l_xy·v_z + v_xy·l_z) / (l_z + v_z)
    s = (ld[..., :2] * dv[..., None] + vd[..., :2] * dl[..., None]) / (dl + dv)[..., None]
    assert s.abs().max() <= 1.0 + 1e-5
    hist, _ = np.histogram(s[..., 0].flatten().numpy(), bins=10, range=(-1, 1))
    assert stats.chisquare(hist).pvalue > 1e-3
    # distances: log(|pos - s|) ~ N(0.5, 0.75)
    s3 = torch.cat([s, torch.zeros_like(s[..., :1])], -1)
    for pos in (ld, vd):
        logd = torch.log((pos - s3).norm(dim=-1)).flatten().double().numpy()
        assert stats.kstest(logd, stats.norm(0.5, 0.75).cdf).pvalue > 1e-3
    # directions mirror: (l - s)/|l - s| == ((-1,-1,1) * (v - s)/|v - s|)
    lu = (ld - s3) / (ld - s3).norm(dim=-1, keepdim=True)
    vu = (vd - s3) / (vd - s3).norm(dim=-1, keepdim=True)
    np.testing.assert_allclose(lu.numpy(), (vu * torch.tensor([-1.0, -1.0, 1.0])).numpy(), atol=1e-4)


def test_sample_configs_draws_the_papers_configs_and_nothing_else():
    # the paper's draws in their order, and nothing more drawn (the next step's draws are the paper's too)
    g0, g1 = torch.Generator().manual_seed(5), torch.Generator().manual_seed(5)
    # the paper's draws, in their order (sample_configs' docstring): 3 + 3 + 6 directions, distances, shifts
    dl, dv, sv = (cosine_hemisphere((64, k), g0) for k in (3, 3, 6))
    torch.randn((64, 6, 2), generator=g0), torch.rand((64, 6, 2), generator=g0)
    b = sample_configs(64, g1)
    assert torch.equal(b.light[:, :3, :3], dl) and torch.equal(b.view[:, :3, :3], dv)
    assert torch.equal(g0.get_state(), g1.get_state())  # nothing else drawn: the next step's draws are unchanged
