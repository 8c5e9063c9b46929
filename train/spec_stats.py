"""Two statistics of a specular map that tell a copy of the photo from a plausible specular, without ground truth.

A network that cannot separate the maps repeats the photo's texture in the specular map (#39: on real flash photos
the bundled model's specular copied wood grain and prints). Two symptoms show it on the predicted maps alone:

- **specular–diffuse correlation**: the Pearson correlation over a map's pixels of the specular map's luminance with
  the diffuse map's luminance. A copy scores 1 (or -1 for an inverted copy); an independent specular, e.g. the near
  constant one of a dielectric, near 0.
- **specular chroma**: per pixel, the standard deviation of R, G, B (over the three values, not n-1) divided by their
  mean; averaged over the map's pixels. A grey specular (dielectrics: F0 the same in R, G and B) scores 0; a copy of
  a coloured diffuse map scores the diffuse map's own chroma (the ratio ignores brightness, so a scaled copy too).
  Per pixel rather than of the map's mean colour: a print in several colours copied into the specular averages to
  a grey mean colour, but each of its pixels is coloured. Bounded by sqrt(2) (one channel lit, two at 0).

Luminance is Rec. 709's (``LUMA``) on the linear RGB maps. The statistics are computed in float64.

Compare them with the same statistics of real materials' ground truth (``svtrain eval`` reports both) rather than
with 0: metals have coloured specular that follows their albedo texture.
"""
from __future__ import annotations

import numpy as np
import torch

from .brdf import DIFFUSE, SPECULAR

#: Rec. 709 / sRGB luminance weights of linear R, G, B.
LUMA = (0.2126, 0.7152, 0.0722)
#: a map whose luminance varies less than this (standard deviation, linear units) is constant: its correlation is
#: undefined, and reported as 0 (no texture shared). 1e-6 is ~1/4000 of one 8-bit step, far above float32 rounding
#: of a constant map (~1e-8) and below any variation a map can show.
CONST_STD = 1e-6
#: floor of a pixel's RGB mean in the chroma (a black pixel has chroma 0, not 0/0).
CHROMA_EPS = 1e-6
CORRELATION, CHROMA = "spec_diffuse_corr", "spec_chroma"
STATS = (CORRELATION, CHROMA)


def luminance(rgb: torch.Tensor) -> torch.Tensor:
    """Rec. 709 luminance of linear RGB maps: (B, 3, H, W) -> (B, H, W) float64."""
    w = torch.tensor(LUMA, dtype=torch.float64, device=rgb.device)
    return (rgb.double() * w[None, :, None, None]).sum(1)


def correlation(specular: torch.Tensor, diffuse: torch.Tensor) -> torch.Tensor:
    """Pearson correlation over pixels of the two maps' luminances.

    Args:
        specular, diffuse: (B, 3, H, W) linear RGB maps.

    Returns:
        (B,) float64 in [-1, 1]; 0 where either luminance's standard deviation is below :data:`CONST_STD`.
    """
    a, b = luminance(specular).flatten(1), luminance(diffuse).flatten(1)
    a, b = a - a.mean(1, keepdim=True), b - b.mean(1, keepdim=True)
    sa, sb = a.pow(2).mean(1).sqrt(), b.pow(2).mean(1).sqrt()
    defined = (sa >= CONST_STD) & (sb >= CONST_STD)
    r = (a * b).mean(1) / torch.where(defined, sa * sb, torch.ones_like(sa))
    return torch.where(defined, r.clamp(-1.0, 1.0), torch.zeros_like(r))


def chroma(rgb: torch.Tensor) -> torch.Tensor:
    """Per-pixel RGB standard deviation / RGB mean, averaged over pixels.

    Args:
        rgb: (B, 3, H, W) linear RGB map (values >= 0).

    Returns:
        (B,) float64 in [0, sqrt(2)]: 0 for a grey map.
    """
    x = rgb.double()
    return (x.std(1, unbiased=False) / x.mean(1).clamp(min=CHROMA_EPS)).mean((1, 2))


def spec_stats(maps: torch.Tensor) -> dict[str, np.ndarray]:
    """Both statistics of packed maps.

    Args:
        maps: (B, 10, H, W) packed maps (train/brdf.py layout).

    Returns:
        {:data:`CORRELATION`: (B,), :data:`CHROMA`: (B,)} float64 arrays.
    """
    spec = maps[:, SPECULAR]
    return {CORRELATION: correlation(spec, maps[:, DIFFUSE]).cpu().numpy(), CHROMA: chroma(spec).cpu().numpy()}


def quartiles(values) -> dict[str, float]:
    """{"q25", "median", "q75"} of a 1-D sequence of per-view values (numpy's linear interpolation)."""
    q = np.quantile(np.asarray(values, np.float64), [0.25, 0.5, 0.75])
    return {"q25": float(q[0]), "median": float(q[1]), "q75": float(q[2])}
