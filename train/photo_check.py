"""Is a photo like the flash photos the network was trained on? Simple image statistics and a warning flag.

The network saw renders of a flat sample lit by a flash beside the camera, exposed so that the sample is neither
black nor clipped: a bright lobe of light near the middle falling off towards the borders. A photo far from that
still gets maps (``svtrain predict`` never refuses one for it), but ``prediction.json`` says why they may be wrong.
Three statistics of the linear network input (after the centre crop and resize) decide it:

- ``mean_luminance``: Rec. 709 luminance averaged over the image (very dark below :data:`DARK_MEAN`);
- ``clipped_fraction``: the share of pixels with a channel at or above :data:`CLIP_LEVEL` (saturated highlights
  above :data:`CLIPPED_MAX`);
- ``flash_contrast``: the brightest of a 4x4 grid of block means over their median (no flash lobe below
  :data:`FLASH_CONTRAST_MIN`: evenly lit, as under ambient light).

The thresholds sit outside what the default training store's views show (``svtrain bundle`` counts how many of
them a threshold flags and writes it into the model card), so the flag marks photos unlike every training view,
not merely unusual ones.
"""
from __future__ import annotations

import numpy as np
import torch

#: Rec. 709 / sRGB luminance weights of linear RGB.
LUMA = (0.2126, 0.7152, 0.0722)
#: mean linear luminance below this: very dark (about sRGB 25/255 over the whole image).
DARK_MEAN = 0.01
#: a channel at or above this linear value counts as clipped.
CLIP_LEVEL = 0.99
#: more than this share of clipped pixels: saturated highlights (above what the default store's views show).
CLIPPED_MAX = 0.25
#: block-mean max / median below this: no flash lobe (evenly lit).
FLASH_CONTRAST_MIN = 1.10
#: grid of blocks for ``flash_contrast`` (coarse: texture averages out, the flash lobe does not).
GRID = 4


def photo_stats(image: torch.Tensor) -> dict[str, float]:
    """The statistics of one linear photo.

    Args:
        image: (3, H, W) linear RGB in [0, 1] (the network input), H and W multiples of :data:`GRID`.

    Returns:
        ``mean_luminance``, ``clipped_fraction``, ``flash_contrast`` (see the module docstring).
    """
    x = image.detach().float().cpu()
    y = (torch.tensor(LUMA)[:, None, None] * x).sum(0)
    clipped = (x >= CLIP_LEVEL).any(0).float().mean()
    h, w = y.shape
    blocks = y[: h - h % GRID, : w - w % GRID].reshape(GRID, h // GRID, GRID, w // GRID).mean((1, 3)).flatten()
    med = float(blocks.median())
    contrast = float(blocks.max()) / med if med > 0 else float("inf")
    return {"mean_luminance": float(y.mean()), "clipped_fraction": float(clipped), "flash_contrast": contrast}


def photo_warnings(stats: dict[str, float]) -> list[str]:
    """The reasons a photo is far from the training distribution (empty: none)."""
    out = []
    if stats["mean_luminance"] < DARK_MEAN:
        out.append(f"very dark: mean linear luminance {stats['mean_luminance']:.4f} < {DARK_MEAN}")
    if stats["clipped_fraction"] > CLIPPED_MAX:
        out.append(f"saturated highlights: {100 * stats['clipped_fraction']:.1f} % of the pixels clipped "
                   f"(> {100 * CLIPPED_MAX:.0f} %)")
    if stats["flash_contrast"] < FLASH_CONTRAST_MIN:
        out.append(f"no flash lobe: brightest/median block {stats['flash_contrast']:.2f} < {FLASH_CONTRAST_MIN} "
                   "(evenly lit, as without a flash)")
    return out


def check(image: torch.Tensor) -> dict:
    """``{"stats", "warnings", "out_of_distribution"}`` of one linear photo (3, H, W), for prediction.json."""
    stats = {k: round(v, 5) for k, v in photo_stats(image).items()}
    warnings = photo_warnings(stats)
    return {"stats": stats, "warnings": warnings, "out_of_distribution": bool(warnings)}


def flag_rates(images: np.ndarray | torch.Tensor) -> dict[str, float]:
    """The share of images each rule flags (the model card's check that the thresholds spare the training data).

    Args:
        images: (N, 3, H, W) linear photos.
    """
    rules = {"very dark": 0, "saturated highlights": 0, "no flash lobe": 0}
    n = len(images)
    for img in images:
        for w in photo_warnings(photo_stats(torch.as_tensor(img))):
            rules[w.split(":")[0]] += 1
    return {k: v / n if n else 0.0 for k, v in rules.items()}
