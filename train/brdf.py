"""The DESIGN.md Cook–Torrance/GGX BRDF in torch: batched, differentiable, finite at every edge.

Maps travel as one packed tensor (B, 10, H, W) in the packed layout of ``materials.maps`` (``MAP_SLICES``):
normal 0:3, diffuse 3:6, specular 6:9, roughness 9:10 (perceptual r, alpha = r**2). The scene constants and
floors come from ``materials.capture``; the numpy statement of the model is ``materials.brdf_reference``.

The geometry term is evaluated in its "visibility" form
``G / (4 NL NV) = G1'(NL) G1'(NV) / 4`` with ``G1'(x) = 1 / (x (1 - k) + k)``: algebraically the
same as DESIGN.md for NL, NV > 0, but it never divides by NL·NV, so grazing light/view and normals
at the horizon stay finite (this is also how the paper's original code evaluates it).
"""
from __future__ import annotations

import math

import torch

from materials.capture import FRESNEL_SG_A, FRESNEL_SG_B, NORMAL_Z_MIN, ROUGHNESS_MIN
from materials.maps import MAP_SLICES

#: channel slices of the packed map tensor.
NORMAL, DIFFUSE, SPECULAR, ROUGHNESS = (MAP_SLICES[k] for k in ("normal", "diffuse", "specular", "roughness"))
#: floor of vector norms before normalising (zero vectors give a finite, zero-gradient result).
NORM_EPS = 1e-8


def normalize(v: torch.Tensor, dim: int = 1) -> torch.Tensor:
    """Unit vectors along ``dim``; a zero vector maps to zero instead of NaN.

    Args:
        v: (..., 3, ...) vectors.
        dim: the vector axis.
    """
    # sum of squares + eps under the sqrt keeps the gradient finite at v = 0 (plain norm() is NaN there).
    return v * torch.rsqrt((v * v).sum(dim=dim, keepdim=True) + NORM_EPS * NORM_EPS)


def dot(a: torch.Tensor, b: torch.Tensor, dim: int = 1) -> torch.Tensor:
    """Dot product along ``dim`` keeping it as a size-1 axis."""
    return (a * b).sum(dim=dim, keepdim=True)


def ggx_cos(maps: torch.Tensor, wi: torch.Tensor, wo: torch.Tensor, dim: int = 1) -> torch.Tensor:
    """BRDF times the clamped cosine, f(wi, wo) · max(N·L, 0).

    Args:
        maps: (..., 10, H, W) packed maps with the channel axis at ``dim`` (normals need not be unit;
            they are normalised here).
        wi: (..., 3, H, W) directions towards the light (any length; broadcastable to maps).
        wo: (..., 3, H, W) directions towards the viewer (any length; broadcastable).
        dim: channel axis (1 for (B, C, H, W), 2 for (B, K, C, H, W)).

    Returns:
        (..., 3, H, W) reflected radiance per unit irradiance at normal incidence, >= 0, finite.
    """
    if maps.dtype in (torch.float16, torch.bfloat16):  # fp32 guard (train/device.py): a2 ~ 1e-8 at the floor
        maps, wi, wo = maps.float(), wi.float(), wo.float()
    sl = lambda s: maps.narrow(dim, s.start, s.stop - s.start)  # noqa: E731
    n = sl(NORMAL)
    # Same floor on n_z as the Mitsuba plugin: a normal at/below the horizon becomes a grazing one.
    n = normalize(torch.cat([n.narrow(dim, 0, 2), n.narrow(dim, 2, 1).clamp(min=NORMAL_Z_MIN)], dim), dim)
    d = sl(DIFFUSE).clamp(0.0, 1.0)
    s = sl(SPECULAR).clamp(0.0, 1.0)
    r = sl(ROUGHNESS).clamp(ROUGHNESS_MIN, 1.0)
    alpha = r * r
    a2 = alpha * alpha
    k = alpha * 0.5

    # N·H and V·H follow from N·L, N·V and L·V (|l + v| = sqrt(2 + 2 L·V)), without normalising h;
    # only D's 1 - N·H^2 needs the half vector itself (see q below).
    il = torch.rsqrt(dot(wi, wi, dim) + NORM_EPS * NORM_EPS)
    iv = torch.rsqrt(dot(wo, wo, dim) + NORM_EPS * NORM_EPS)
    nl_raw = dot(n, wi, dim) * il
    nv_raw = dot(n, wo, dim) * iv
    lv = dot(wi, wo, dim) * (il * iv)
    # l = -v has no half vector; the floor makes N·H = V·H = 0 there (the term is zero anyway).
    ih = torch.rsqrt((2.0 + 2.0 * lv).clamp(min=1e-12))
    nh = ((nl_raw + nv_raw) * ih).clamp(0.0, 1.0)
    vh = ((1.0 + lv) * ih).clamp(0.0, 1.0)
    nl = nl_raw.clamp(min=0.0)
    nv = nv_raw.clamp(min=0.0)

    # q = NH^2 (a2 - 1) + 1 = NH^2 a2 + (1 - NH^2), with 1 - NH^2 = |n x h|^2 from the tangential part of the
    # (unnormalised) half vector: the literal form cancels in float32 (1 - NH^2 has absolute error ~1e-7, and
    # a2 - 1 rounds to -1 for a2 < 6e-8), which gave D wrong by 1e8 at the r = 0.01 floor and by ~45 % relative
    # RMSE around the peak at r = 0.05 (tests/test_stability.py). The same form as the Mitsuba plugin's _ggx_d.
    # q lies in [a2, 1] for nh in [0, 1]; the clamp only guards rounding and the degenerate l = -v.
    hu = wi * il + wo * iv
    cx = n.narrow(dim, 1, 1) * hu.narrow(dim, 2, 1) - n.narrow(dim, 2, 1) * hu.narrow(dim, 1, 1)
    cy = n.narrow(dim, 2, 1) * hu.narrow(dim, 0, 1) - n.narrow(dim, 0, 1) * hu.narrow(dim, 2, 1)
    cz = n.narrow(dim, 0, 1) * hu.narrow(dim, 1, 1) - n.narrow(dim, 1, 1) * hu.narrow(dim, 0, 1)
    sin2 = (cx * cx + cy * cy + cz * cz) * (ih * ih)
    q = torch.maximum(nh * nh * a2 + sin2, a2).clamp(max=1.0)
    D = a2 / (math.pi * q * q)
    vis = 0.25 / ((nl * (1.0 - k) + k) * (nv * (1.0 - k) + k))
    fc = torch.exp2((-FRESNEL_SG_A * vh - FRESNEL_SG_B) * vh)
    spec = D * vis * nl  # scalar per pixel: D G / (4 NL NV) · NL
    # f·NL = d(1-s)/pi·NL + spec·(s + (1-s)·fc), grouped so only three ops run on 3 channels.
    return (1.0 - s) * (d * (nl / math.pi) + spec * fc) + s * spec
