"""Torch renderings of packed maps: the flash capture scene of DESIGN.md and the loss configurations.

Plane coordinates: pixel (i, j) of an (H, W) map has its centre at
``x = -1 + (j + 0.5) * 2 / W``, ``y = 1 - (i + 0.5) * 2 / H``, ``z = 0`` (row 0 = image top, y up),
on the 2×2 material plane that fills the image exactly. Camera distance and flash intensity: ``materials.capture``.
"""
from __future__ import annotations

import torch

from materials.capture import CAMERA_DISTANCE, FLASH_INTENSITY

from .brdf import ggx_cos


def plane_points(h: int, w: int, device=None, dtype=torch.float32) -> torch.Tensor:
    """Pixel-centre positions on the material plane.

    Returns:
        (1, 3, H, W) points (x right, y up, z = 0).
    """
    x = -1.0 + (torch.arange(w, device=device, dtype=dtype) + 0.5) * 2.0 / w
    y = 1.0 - (torch.arange(h, device=device, dtype=dtype) + 0.5) * 2.0 / h
    yy, xx = torch.meshgrid(y, x, indexing="ij")
    return torch.stack([xx, yy, torch.zeros_like(xx)])[None]


def flash_render(maps: torch.Tensor, light_offset: torch.Tensor, intensity: float = FLASH_INTENSITY,
                 clip: bool = True) -> torch.Tensor:
    """Render the capture scene: pinhole camera at (0, 0, D), point light at (ox, oy, D).

    Radiance = f · max(N·L, 0) · I / d², d the light–point distance; the camera sees every pixel
    centre of the plane (perspective maps the 2×2 plane exactly onto the image).

    Args:
        maps: (B, 10, H, W) packed maps.
        light_offset: (B, 2) light offset from the camera centre in the plane z = D (or (2,)).
        intensity: flash radiant intensity.
        clip: clip to [0, 1] like the LDR data renders (off for HDR analysis).

    Returns:
        (B, 3, H, W) linear image, row 0 = image top.
    """
    b, _, h, w = maps.shape
    p = plane_points(h, w, maps.device, maps.dtype)
    off = torch.as_tensor(light_offset, dtype=maps.dtype, device=maps.device).reshape(-1, 2).expand(b, 2)
    light = torch.cat([off, torch.full((b, 1), CAMERA_DISTANCE, dtype=maps.dtype, device=maps.device)], 1)
    cam = torch.tensor([0.0, 0.0, CAMERA_DISTANCE], dtype=maps.dtype, device=maps.device)
    wi = light[:, :, None, None] - p
    wo = cam[None, :, None, None] - p
    d2 = (wi * wi).sum(1, keepdim=True)
    out = ggx_cos(maps, wi, wo) * (intensity / d2)
    return out.clamp(0.0, 1.0) if clip else out
