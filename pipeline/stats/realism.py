"""Realism statistics of one material: what `svgen stats --reference` compares between a store and real materials.

Every function takes one material's maps (linear, [0, 1]; normals unit tangent-space vectors, DESIGN.md) and
returns numbers; :mod:`pipeline.stats.profile` gathers them over a store, :mod:`pipeline.stats.compare`
turns two gatherings into distances. docs/REALISM.md says what each measures and why it matters to flash capture.

* pixel values (:func:`pixel_samples`): diffuse luminance Y, diffuse chroma C*ab (CIELAB, D65), specular F0
  luminance, roughness and normal tilt arccos(n_z) in degrees, on a fixed grid of ``GRID``² pixels spread over
  each material whatever its size, so every material weighs the same in a store's pooled distribution;
* normal relief by scale (:func:`octave_shares`): the share of slope power in octaves of cycles per map;
* spatial variation (:func:`variation`): coefficient of variation std / mean of each map within the material;
* cross-map correlation (:func:`correlations`): Pearson's r over the material's pixels of roughness and specular
  Y, diffuse Y and roughness, normal relief (slope magnitude) and diffuse Y.
"""
from __future__ import annotations

import numpy as np

#: Rec. 709 luminance weights of linear RGB.
LUMA = np.array([0.2126, 0.7152, 0.0722], np.float64)
#: pixels per side of the grid :func:`pixel_samples` reads from every material.
GRID = 64
#: octave bins of radial frequency in cycles per map: [1, 2), [2, 4), ..., [64, 128] (the last one closed).
OCTAVES: tuple[tuple[int, int], ...] = tuple((2 ** i, 2 ** (i + 1)) for i in range(7))
#: below this standard deviation a map counts as constant (16-bit storage quantises to 1.5e-5).
FLAT = 1e-4
#: the mean a coefficient of variation divides by is at least this (a black diffuse map has no defined CV).
CV_MEAN_FLOOR = 1e-3
PIXEL_STATS = ("diffuse_luminance", "diffuse_chroma", "specular_f0", "roughness", "normal_tilt_deg")
VARIATION_STATS = ("cv_diffuse", "cv_specular", "cv_roughness", "cv_relief")
CORRELATION_STATS = ("r_roughness_specular", "r_diffuse_roughness", "r_relief_diffuse")


def slopes(normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Surface slopes of a normal map: dh/dx = -n_x / n_z, dh/dy = -n_y / n_z (the inverse of
    normalize(-dh/dx, -dh/dy, 1)).

    Args:
        normal: (H, W, 3) unit normals, z > 0.

    Returns:
        Two (H, W) float64 arrays (n_z clamped at 1e-3: a normal at the horizon has no finite slope).
    """
    nz = np.maximum(normal[..., 2].astype(np.float64), 1e-3)
    return -normal[..., 0] / nz, -normal[..., 1] / nz


def relief(normal: np.ndarray) -> np.ndarray:
    """Slope magnitude |grad h| = tan(tilt) of every pixel: (H, W) float64."""
    dx, dy = slopes(normal)
    return np.hypot(dx, dy)


def octave_shares(normal: np.ndarray) -> np.ndarray:
    """Share of the slope field's power in each octave of :data:`OCTAVES`.

    Frequencies are counted in cycles per map at the map's own size (a 256² map resolves up to 128 cycles, a 64²
    one up to 32, so compare stores at the same size; the reference is imported at 256²). The power of both
    slope components |FFT(dh/dx)|² + |FFT(dh/dy)|² is binned by radial frequency sqrt(fx² + fy²); the mean slope
    (0 cycles) and frequencies above 128 (the corners of a 256² spectrum, everything beyond at 512²) are left out,
    so the shares of the octaves sum to 1 (all 0 for a flat map).

    Args:
        normal: (N, N, 3) unit normals.

    Returns:
        (7,) float64 shares, octave k holding [2^k, 2^(k+1)) cycles per map.
    """
    n = normal.shape[0]
    if normal.shape[1] != n:
        raise ValueError(f"octave shares need a square map, got {normal.shape[:2]}")
    dx, dy = slopes(normal)
    power = np.abs(np.fft.fft2(dx)) ** 2 + np.abs(np.fft.fft2(dy)) ** 2
    f = np.fft.fftfreq(n) * n  # cycles per map
    r = np.hypot(f[:, None], f[None, :])
    out = np.array([power[(r >= lo) & ((r < hi) if hi < OCTAVES[-1][1] else (r <= hi))].sum()
                    for lo, hi in OCTAVES])
    total = out.sum()
    # a flat map's spectrum is rounding noise: call it no relief rather than normalise noise into shares
    return out / total if total > 1e-12 * n ** 4 else np.zeros(len(OCTAVES))


def chroma(rgb: np.ndarray) -> np.ndarray:
    """CIELAB chroma C*ab = sqrt(a*² + b*²) of linear sRGB colours (D65): 0 for greys, ~100 for vivid colours.

    Args:
        rgb: (..., 3) linear RGB.

    Returns:
        (...) float64.
    """
    import colour

    space = colour.RGB_COLOURSPACES["sRGB"]
    lab = colour.XYZ_to_Lab(colour.RGB_to_XYZ(np.asarray(rgb, np.float64), space, apply_cctf_decoding=False),
                            space.whitepoint)
    return np.hypot(lab[..., 1], lab[..., 2])


def pixel_samples(diffuse, specular, roughness, normal) -> dict[str, np.ndarray]:
    """The values of :data:`PIXEL_STATS` on a ``GRID``² grid of pixels spread evenly over the map (all when N <= GRID).

    Args:
        diffuse, specular: (N, N, 3); roughness: (N, N, 1) or (N, N); normal: (N, N, 3).

    Returns:
        name -> (min(N, GRID)²,) float64.
    """
    n = diffuse.shape[0]
    g = min(n, GRID)
    rows = np.arange(g) * n // g  # evenly spread over the whole map (every 4th pixel at 256²)
    pick = np.ix_(rows, rows)
    d = np.asarray(diffuse, np.float64)[pick].reshape(-1, 3)
    nz = np.asarray(normal, np.float64)[pick][..., 2].reshape(-1)
    return {"diffuse_luminance": d @ LUMA, "diffuse_chroma": chroma(d),
            "specular_f0": np.asarray(specular, np.float64)[pick].reshape(-1, 3) @ LUMA,
            "roughness": np.asarray(roughness, np.float64)[pick].reshape(-1),
            "normal_tilt_deg": np.degrees(np.arccos(np.clip(nz, -1, 1)))}


def cv(x: np.ndarray) -> float:
    """Coefficient of variation std / mean over all values (0 for a constant map; the mean floored at
    :data:`CV_MEAN_FLOOR`)."""
    x = np.asarray(x, np.float64)
    s = float(x.std())
    return 0.0 if s < FLAT else s / max(float(x.mean()), CV_MEAN_FLOOR)


def pearson(a: np.ndarray, b: np.ndarray) -> float:
    """Pearson's r of two maps over their pixels; 0 when either is constant (no linear relation to measure)."""
    a, b = np.asarray(a, np.float64).ravel(), np.asarray(b, np.float64).ravel()
    if a.std() < FLAT or b.std() < FLAT:
        return 0.0
    return float(np.corrcoef(a, b)[0, 1])


def variation(diffuse, specular, roughness, normal) -> dict[str, float]:
    """:data:`VARIATION_STATS`: CV of diffuse Y, specular Y, roughness and slope magnitude within the material."""
    return {"cv_diffuse": cv(np.asarray(diffuse) @ LUMA), "cv_specular": cv(np.asarray(specular) @ LUMA),
            "cv_roughness": cv(roughness), "cv_relief": cv(relief(normal))}


def correlations(diffuse, specular, roughness, normal) -> dict[str, float]:
    """:data:`CORRELATION_STATS`: Pearson's r over the material's pixels (see :func:`pearson`)."""
    dy, sy = np.asarray(diffuse) @ LUMA, np.asarray(specular) @ LUMA
    r = np.asarray(roughness).reshape(dy.shape)
    return {"r_roughness_specular": pearson(r, sy), "r_diffuse_roughness": pearson(dy, r),
            "r_relief_diffuse": pearson(relief(normal), dy)}
