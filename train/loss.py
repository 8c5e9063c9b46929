"""The rendering loss of DESIGN.md / paper §4.3: 3 diffuse + 6 specular configurations per sample.

Configurations are drawn afresh for every sample at every step from a ``torch.Generator`` owned by
the trainer (its state goes into checkpoints, so a resumed run draws the same ones), all at once:
no Python loop over samples or configurations.

A configuration is a light and a viewer in homogeneous form ``(x, y, z, w)``: ``w = 0`` is a
distant direction, ``w = 1`` a position; the vector towards it from plane point p is ``xyz - w·p``.
Renderings follow the original code: ``R = π · f · max(N·L, 0) / max(l_z, 0.001)`` with no distance
falloff; the division by the light's elevation undoes the cosine weighting of the sampled lights, so
a flat surface looks the same under every light elevation.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import torch

from .brdf import ggx_cos
from .render import plane_points

N_DIFFUSE, N_SPECULAR = 3, 6
#: r1 range of the cosine-hemisphere sampler (original code: keeps directions off the horizon and
#: off the exact zenith).
R1_LOW, R1_HIGH = 0.001, 0.95
#: log-distance of the specular configurations' light and viewer: exp(N(0.5, 0.75)).
DIST_MU, DIST_SIGMA = 0.5, 0.75
LOG_EPS = 0.01


@dataclass
class LossConfigs:
    """Lights and viewers for one batch.

    Attributes:
        light: (B, K, 4) homogeneous light (xyz, w).
        view: (B, K, 4) homogeneous viewer (xyz, w).
    """

    light: torch.Tensor
    view: torch.Tensor

    def rows(self, lo: int, hi: int) -> "LossConfigs":
        """The configurations of samples lo..hi-1 (a data-parallel rank's share of the global batch's draw)."""
        return LossConfigs(self.light[lo:hi], self.view[lo:hi])


def cosine_hemisphere(shape: tuple[int, ...], gen: torch.Generator | None = None,
                      r1_low: float = R1_LOW, r1_high: float = R1_HIGH) -> torch.Tensor:
    """Directions from the cosine-weighted upper hemisphere (z = sqrt(1 - r1), r1 ~ U(r1_low, r1_high)).

    Returns:
        (*shape, 3) unit vectors with z > 0.
    """
    r1 = torch.rand(shape, generator=gen) * (r1_high - r1_low) + r1_low
    phi = 2.0 * math.pi * torch.rand(shape, generator=gen)
    r = torch.sqrt(r1)
    return torch.stack([r * torch.cos(phi), r * torch.sin(phi), torch.sqrt(1.0 - r1)], -1)


def sample_configs(batch: int, gen: torch.Generator | None = None, n_diffuse: int = N_DIFFUSE,
                   n_specular: int = N_SPECULAR) -> LossConfigs:
    """Draw ``n_diffuse`` + ``n_specular`` configurations for each of ``batch`` samples.

    Diffuse: light and view independent cosine-hemisphere directions, both distant.
    Specular: v from the cosine hemisphere, l = (-vx, -vy, vz); positions v·exp(N(.5,.75)) and
    l·exp(N(.5,.75)) (independent draws), both shifted by the same (U(-1,1), U(-1,1), 0).

    Returns:
        configs with K = n_diffuse + n_specular, diffuse ones first.
    """
    dl = cosine_hemisphere((batch, n_diffuse), gen)
    dv = cosine_hemisphere((batch, n_diffuse), gen)
    sv = cosine_hemisphere((batch, n_specular), gen)
    sl = sv * torch.tensor([-1.0, -1.0, 1.0])
    dist = torch.exp(torch.randn((batch, n_specular, 2), generator=gen) * DIST_SIGMA + DIST_MU)
    shift = torch.zeros(batch, n_specular, 3)
    shift[..., :2] = torch.rand((batch, n_specular, 2), generator=gen) * 2.0 - 1.0
    sv_pos = sv * dist[..., :1] + shift
    sl_pos = sl * dist[..., 1:] + shift
    zeros = torch.zeros(batch, n_diffuse, 1)
    ones = torch.ones(batch, n_specular, 1)
    light = torch.cat([torch.cat([dl, zeros], -1), torch.cat([sl_pos, ones], -1)], 1)
    view = torch.cat([torch.cat([dv, zeros], -1), torch.cat([sv_pos, ones], -1)], 1)
    return LossConfigs(light, view)


def render_configs(maps: torch.Tensor, cfg: LossConfigs) -> torch.Tensor:
    """Render packed maps under every configuration.

    Args:
        maps: (B, 10, H, W) packed maps.
        cfg: configurations with light/view (B, K, 4).

    Returns:
        (B, K, 3, H, W) renderings (>= 0, unclipped).
    """
    b, _, h, w = maps.shape
    p = plane_points(h, w, maps.device, maps.dtype)[:, None]  # (1, 1, 3, H, W)
    light = cfg.light.to(maps)[..., None, None]  # (B, K, 4, 1, 1)
    view = cfg.view.to(maps)[..., None, None]
    wi = light[:, :, :3] - light[:, :, 3:] * p
    wo = view[:, :, :3] - view[:, :, 3:] * p
    lz = wi[:, :, 2:3] * torch.rsqrt((wi * wi).sum(2, keepdim=True) + 1e-16)
    return math.pi * ggx_cos(maps[:, None], wi, wo, dim=2) / lz.clamp(min=0.001)


def log_l1(a: torch.Tensor, b: torch.Tensor, eps: float = LOG_EPS) -> torch.Tensor:
    """mean |log(a + eps) - log(b + eps)| (a, b >= 0)."""
    return (torch.log(a + eps) - torch.log(b + eps)).abs().mean()


def rendering_loss(pred: torch.Tensor, target: torch.Tensor, gen: torch.Generator | None = None,
                   cfg: LossConfigs | None = None, render=render_configs) -> torch.Tensor:
    """The rendering loss of one batch.

    Args:
        pred: (B, 10, H, W) predicted packed maps (differentiable).
        target: (B, 10, H, W) ground-truth packed maps.
        gen: generator drawing the configurations (ignored when ``cfg`` is given).
        cfg: fixed configurations (tests, evaluation).
        render: the renderer (``render_configs`` or a compiled version of it).

    Returns:
        scalar loss.
    """
    if cfg is None:
        cfg = sample_configs(pred.shape[0], gen)
    # fp32 island (train/device.py): the log of radiances near 0 and GGX at the roughness floor need float32, so
    # a bf16/fp16 prediction from an autocast network is upcast and autocast is off for the renderings and the log.
    with torch.autocast(pred.device.type, enabled=False):
        pred, target = pred.float(), target.float()
        with torch.no_grad():
            r_gt = render(target, cfg)
        return log_l1(render(pred, cfg), r_gt)


def make_loss(compile: bool = False):
    """``loss(pred, target, gen)``; with ``compile`` the renderer is fused by torch.compile.

    Only the renderer is compiled: drawing the configurations stays eager, so the generator state
    (and thus resumed runs) is identical with or without compilation.
    """
    render = torch.compile(render_configs, dynamic=False) if compile else render_configs

    def loss(pred: torch.Tensor, target: torch.Tensor, gen: torch.Generator | None,
             cfg: LossConfigs | None = None) -> torch.Tensor:
        return rendering_loss(pred, target, gen, cfg, render=render)

    return loss
