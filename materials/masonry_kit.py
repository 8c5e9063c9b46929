"""Building blocks shared by the masonry-like classes (bricks, roofing, concrete, rock): physical clamps, rounded
stones on a cell pattern, bevelled block profiles and mid-scale relief bands.

Relief in these classes is built from *bands* (:func:`materials.noise.band_relief`) with a stated RMS slope, so the
slope power sits where the material has its structure (joints, stones, undulation: 4-32 cycles per texture width,
periods of 8-64 px at 256²) and the fine grain stays a minority (issue #22: the network does not learn relief at
periods <= 8 px).
"""
from __future__ import annotations

import numpy as np

from .compose import finish
from .maps import SVBRDF
from .noise import F32, Tex, band_relief, smoothstep
from .patterns import worley


def physical_finish(phys: dict, height: np.ndarray, diffuse, specular, roughness) -> SVBRDF:
    """:func:`materials.compose.finish` with diffuse, F0 and roughness held inside a class's ``PHYSICAL`` ranges.

    Args:
        phys: ``{"diffuse": (lo, hi), "specular": (lo, hi), "roughness": (lo, hi)}`` (linear albedo, F0 per channel).
        height: (H, W) height in texture widths.
        diffuse, specular: (H, W, 3) or (3,) or scalar, linear.
        roughness: (H, W) or scalar.
    """
    d = np.clip(np.asarray(diffuse, F32), *phys["diffuse"])
    s = np.clip(np.asarray(specular, F32), *phys["specular"])
    r = np.clip(np.asarray(roughness, F32), *phys["roughness"])
    return finish(height, 1.0, d, s, r)


def bevel_profile(edge: np.ndarray, gap: float, bevel: float) -> np.ndarray:
    """Height profile of a block from its distance to the block edge: 0 in the joint, a smooth (C1) shoulder of
    width ``bevel`` and 1 on the face. A smooth shoulder keeps the joint's slope power at the joint's scale rather
    than in the one-pixel kink of a hard edge.

    Args:
        edge: (H, W) distance to the block edge in texture widths (``patterns.tiles(...)["edge"]``).
        gap, bevel: joint width and shoulder width in texture widths.

    Returns:
        (H, W) float32 in [0, 1].
    """
    return smoothstep(gap / 2, gap / 2 + max(bevel, 1e-6), edge)


def stones(tex: Tex, n: float, jitter: float, gap: float, enabled: bool = True, aspect: float = 1.0) -> dict:
    """Rounded stones on a Voronoi (cell) pattern: pebbles, gravel, cobbles.

    Args:
        tex: the canvas.
        n: stones across the texture (rounded; >= 1).
        jitter: 0 a regular grid of stones, 1 fully random centres.
        gap: joint between stones, in cell widths (distance between the nearest two cell centres' bisector).
        enabled: False skips the work and returns no stones (seeds still drawn, see :func:`patterns.worley`).
        aspect: cell rows per column ratio.

    Returns:
        dict of (H, W) float32 ``mask`` (1 on a stone), ``dome`` (0 at the stone's edge, 1 at its middle),
        int32 ``id`` and (n_cells,) float32 ``rnd`` per-stone uniform values, ``n`` the stone count used.
    """
    f1, f2, cid, rnd = worley(tex, max(1, int(round(n))), jitter, aspect=aspect, enabled=enabled)
    if not enabled:
        z = np.zeros_like(f1)
        return {"mask": z, "dome": z, "id": cid, "rnd": rnd, "n": max(1, int(round(n)))}
    d = (f2 - f1) * F32(0.5)  # ~distance to the cell edge (the bisector), cell widths
    mask = smoothstep(gap / 2, gap / 2 + 0.06, d)
    x = np.clip((d - gap / 2) * F32(1 / 0.35), 0, 1)
    dome = (x * (2 - x)).astype(F32)  # a parabolic cap: finite slope at the rim (a sqrt rim is a one-pixel cliff)
    return {"mask": mask, "dome": dome * mask, "id": cid, "rnd": rnd, "n": max(1, int(round(n)))}


def relief_band(tex: Tex, cycles: float, slope_rms: float) -> np.ndarray:
    """A mid-scale relief layer: height (H, W) in texture widths with its power in one octave around ``cycles``
    per texture width and RMS slope ``slope_rms`` (always draws one seed, so zero slope keeps later layers)."""
    seed = tex.seed()
    if slope_rms <= 0:
        return np.zeros((tex.size, tex.size), F32)
    return band_relief(tex.size, seed, cycles, slope_rms)


def courses(tex: Tex, nx: float, ny: float, stagger: float) -> dict:
    """Blocks laid in courses (bricks, roof tiles): ``nx`` blocks across, ``ny`` courses down, odd courses offset by
    ``stagger`` blocks.

    Unlike :func:`materials.patterns.tiles` the offset is split between even (-stagger/2) and odd (+stagger/2)
    courses, each from half a block, so no course has a vertical joint on the wrap seam: with a running bond and a
    few blocks across, a joint on the seam in every other course makes the seam column statistically special.

    Returns:
        dict of (H, W) float32 ``fx``, ``fy`` (position in the block, 0..1), ``edge`` (distance to the block
        edge, texture widths), int32 ``row``, ``id`` (row * nx + column), and the ``nx``, ``ny`` used (``ny`` even
        when staggered, so the offset courses wrap).
    """
    nx = max(1, int(round(nx)))
    ny = max(1, int(round(ny)))
    if stagger > 0 and ny % 2:
        ny += 1
    y = tex.v * ny + 0.5  # half a course shifted: the seam crosses blocks, not a bed joint
    row = np.floor(y).astype(np.int32)
    fy = (y - row).astype(F32)
    x = tex.u * nx + 0.5 + stagger * (row % 2 - 0.5)
    col = np.floor(x).astype(np.int32)
    fx = (x - col).astype(F32)
    col %= nx
    row %= ny
    edge = np.minimum(np.minimum(fx, 1 - fx) / nx, np.minimum(fy, 1 - fy) / ny).astype(F32)
    return {"fx": fx, "fy": fy, "edge": edge, "row": row, "id": row * nx + col, "nx": nx, "ny": ny}
