"""Tileable structured patterns: cells (Worley), tiles/bricks, wood rings, weaves, scratches.

Like :mod:`materials.noise`, everything lives on the unit torus in texture space
(u right, v down, period 1) with counts that are integers, so patterns wrap
exactly. All random draws are per feature (cell, tile, scratch), never per
pixel, so the same seed gives the same layout at every map size.
"""
from __future__ import annotations

import numpy as np

from .noise import F32, Tex, blur


def worley(tex: Tex, n: int, jitter: float = 0.9, aspect: float = 1.0, enabled: bool = True):
    """Cellular noise on a jittered grid of ``n`` x ``round(n * aspect)`` cells, wrap-around.

    Args:
        tex: the canvas.
        n: cells across u (>= 1).
        jitter: 0 = regular grid, 1 = fully random point within each cell.
        aspect: rows per column count ratio (cells stretched when != 1).
        enabled: False skips the work (a material whose parameters switch the layer off) and returns
            f1 = f2 = 1, cell 0; the layer's seed is still drawn so later layers keep their seeds.

    Returns:
        f1, f2: (H, W) float32 distances to the nearest / second nearest point, in cell widths.
        cell: (H, W) int32 id of the nearest point's cell (0 .. nx*ny-1).
        rnd: (nx*ny,) float32 uniform random value per cell (for per-cell colour).
    """
    nx = max(1, int(round(n)))
    ny = max(1, int(round(n * aspect)))
    g = tex.sub()
    if not enabled:
        one = np.ones((tex.size, tex.size), F32)
        return one, one.copy(), np.zeros((tex.size, tex.size), np.int32), np.zeros(nx * ny, F32)
    jx = (0.5 + jitter * (g.random((ny, nx), dtype=F32) - 0.5)).astype(F32)
    jy = (0.5 + jitter * (g.random((ny, nx), dtype=F32) - 0.5)).astype(F32)
    rnd = g.random(nx * ny, dtype=F32)
    # a random whole-grid offset: Voronoi edges crowd near the grid lines of a jittered grid, and the
    # wrap seam must not sit on one more often than any interior line of pixels does
    off_x, off_y = g.random(2)
    # cell grid padded by one cell on every side with wrapped copies: neighbour lookups become flat
    # `take`s at a constant offset from each pixel's own cell (much faster than 2-D fancy indexing)
    pad = lambda a: np.pad(a, 1, mode="wrap").ravel()  # noqa: E731
    jxp, jyp = pad(jx), pad(jy)
    idp = pad(np.arange(nx * ny, dtype=np.int32).reshape(ny, nx))
    t = (np.arange(tex.size, dtype=F32) + 0.5) / tex.size
    xs, ys = t * nx + F32(off_x), t * ny + F32(off_y)
    cx, cy = np.floor(xs).astype(np.int32), np.floor(ys).astype(np.int32)
    fx = (xs - cx)[None, :]  # position inside the cell, separable in rows and columns
    fy = (ys - cy)[:, None]
    cx[cx >= nx] -= nx  # offset coordinates run past the last cell: wrap to the first
    cy[cy >= ny] -= ny
    base = (cy[:, None] + 1) * (nx + 2) + (cx[None, :] + 1)
    f1 = np.full(base.shape, 1e9, F32)
    f2 = np.full(base.shape, 1e9, F32)
    cell = np.zeros(base.shape, np.int32)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            k = base + (dy * (nx + 2) + dx)
            ddx = np.take(jxp, k) + F32(dx) - fx
            ddy = np.take(jyp, k) + F32(dy) - fy
            d = ddx * ddx + ddy * ddy  # squared; sqrt once at the end
            closer = d < f1
            np.minimum(f2, np.where(closer, f1, d), out=f2)
            np.copyto(cell, np.take(idp, k), where=closer)
            np.minimum(f1, d, out=f1)
    f1, f2 = np.sqrt(f1), np.sqrt(f2)
    return f1, f2, cell, rnd


def tiles(tex: Tex, nx: int, ny: int, stagger: float = 0.0, gap: float = 0.01, bevel: float = 0.01):
    """A grid of tiles or bricks separated by grout.

    Args:
        tex: the canvas.
        nx, ny: tiles across u and v. With ``stagger`` > 0, ``ny`` is rounded up to an even
            number so that the staggered rows wrap.
        stagger: horizontal offset of odd rows, in tile widths (0.5 = running bond).
        gap: grout width in texture widths.
        bevel: width of the rounded tile edge in texture widths.

    Returns:
        dict with (H, W) float32 ``height`` (1 on tiles, 0 in grout), ``mortar`` (1 in grout),
        ``fx``, ``fy`` (position inside the tile, 0..1), ``edge`` (distance to the tile edge in
        texture widths), int32 ``id`` (0 .. nx*ny-1), and ``nx``, ``ny`` actually used.
    """
    nx = max(1, int(round(nx)))
    ny = max(1, int(round(ny)))
    if stagger > 0 and ny % 2:
        ny += 1
    # grid shifted by half a tile so that the wrap seam crosses tiles, not a grout line: a grout line
    # sampled exactly on a pixel boundary would be a (harmless but measurable) special place
    y = tex.v * ny + 0.5
    row = np.floor(y).astype(np.int32)
    x = tex.u * nx + 0.5 + stagger * (row % 2)
    col = np.floor(x).astype(np.int32) % nx
    fx = (x - np.floor(x)).astype(F32)
    fy = (y - row).astype(F32)
    edge = np.minimum(np.minimum(fx, 1 - fx) / nx, np.minimum(fy, 1 - fy) / ny).astype(F32)
    t = np.clip((edge - gap / 2) / max(bevel, 1e-6), 0, 1)
    height = (t * (2 - t)).astype(F32)  # rounded (quadratic) bevel
    mortar = (edge < gap / 2).astype(F32)
    return {"height": height, "mortar": mortar, "fx": fx, "fy": fy, "edge": edge,
            "id": (row % ny) * nx + col, "nx": nx, "ny": ny}


def rings(tex: Tex, n_rings: float, distort: float, scale: float = 0.5, angle_tilt: float = 0.0):
    """Wood growth rings seen on a plank: stripes along v, phase warped by noise.

    Args:
        n_rings: rings across the texture width (rounded to an integer to tile).
        distort: ring waviness in ring widths.
        scale: size of the waviness in texture widths.
        angle_tilt: ring phase drift per texture height, in rings (rounded to tile; cathedral-like
            arches come from the noise).

    Returns:
        phase: (H, W) float32 ring phase in [0, 1) (0 = start of early wood).
    """
    n = max(1, int(round(n_rings)))
    w1, w2 = tex.fbm2(scale, beta=3.5, aniso=3.0, angle=np.pi / 2)
    p = tex.u * n + distort * (w1 + 0.3 * w2) + int(round(angle_tilt)) * tex.v
    return (p - np.floor(p)).astype(F32)


def weave(tex: Tex, threads: int, pattern: str = "plain", gap: float = 0.15, twill: int = 2):
    """Woven threads: warp along v, weft along u.

    Args:
        threads: threads across the texture (rounded up to a whole number of weave repeats).
        pattern: "plain" (1 over 1) or "twill" (``twill`` over 1, shifted by one per row) or "satin".
        gap: fraction of a thread cell left open between threads.
        twill: float length of twill/satin floats.

    Returns:
        height: (H, W) float32 thread height in [0, 1].
        warp_on_top: (H, W) bool, True where the warp thread is visible.
        along: (H, W) float32 coordinate along the visible thread, 0..1 within a cell (for fibres).
    """
    n = max(1, int(round(threads)))
    k = 2 if pattern == "plain" else twill + 1
    n = -(-n // k) * k  # a whole number of repeats across the texture, so the weave wraps
    # threads narrower than ~4 px alias (2 px per thread can sample the same phase everywhere):
    # supersample and box-filter down
    ss = min(4, -(-4 * n // tex.size))
    m = tex.size * ss
    t = (np.arange(m, dtype=F32) + 0.5) / m
    # a quarter thread off, so the seam is not on a thread boundary (see tiles) and, at 2 px per
    # thread, the two pixels of a thread see different halves of its profile
    x = t[None, :] * n + 0.25
    y = t[:, None] * n + 0.25
    i = np.floor(x).astype(np.int32)
    j = np.floor(y).astype(np.int32)
    fx = np.broadcast_to(x - i, (m, m))
    fy = np.broadcast_to(y - j, (m, m))
    if pattern == "plain":
        top = (i + j) % 2 == 0
    elif pattern == "satin":
        top = ((i * 2 + j) % k) != 0  # warp-faced, floats offset by 2
    else:
        top = ((i + j) % k) != 0
    half = 0.5 * (1 - gap)
    # cross-section profile of a round thread across its width, arched along its length
    pw = np.sqrt(np.clip(1 - ((fx - 0.5) / half) ** 2, 0, 1))  # warp across x
    pf = np.sqrt(np.clip(1 - ((fy - 0.5) / half) ** 2, 0, 1))  # weft across y
    archw = 0.6 + 0.4 * np.sin(np.pi * fy)
    archf = 0.6 + 0.4 * np.sin(np.pi * fx)
    hw = pw * archw
    hf = pf * archf
    height = np.where(top, np.maximum(hw, 0.5 * hf), np.maximum(hf, 0.5 * hw)).astype(F32)
    warp_vis = np.where(top, hw >= 0.5 * hf, hw > hf)
    along = np.where(warp_vis, fy, fx).astype(F32)
    if ss > 1:
        box = lambda a: a.reshape(tex.size, ss, tex.size, ss).mean((1, 3))  # noqa: E731
        height, along = box(height).astype(F32), box(along).astype(F32)
        warp_vis = box(warp_vis.astype(F32)) >= 0.5
    return height, warp_vis, along


def scratches(tex: Tex, count: int, length: float, angle: float, spread: float, width: float = 0.0):
    """Thin random line segments splatted with wrap-around.

    Args:
        count: number of scratches.
        length: mean length in texture widths.
        angle: mean direction in radians (from +u towards +v).
        spread: std of the direction in radians.
        width: extra blur in texture widths (0: about one pixel).

    Returns:
        (H, W) float32 scratch intensity in [0, 1].
    """
    n = tex.size
    g = tex.sub()
    count = int(round(count))
    c = g.random((count, 2))
    a = angle + spread * g.standard_normal(count)
    ln = length * (0.3 + 1.4 * g.random(count))
    depth = 0.4 + 0.6 * g.random(count)
    img = np.zeros(n * n, np.float64)
    if count:
        m = int(np.ceil(ln.max() * n * 1.5)) + 2  # samples per scratch: denser than pixels
        t = np.linspace(-0.5, 0.5, m)
        px = (c[:, 0:1] + np.outer(ln * np.cos(a), t)) * n
        py = (c[:, 1:2] + np.outer(ln * np.sin(a), t)) * n
        keep = np.abs(t)[None, :] <= (ln / ln.max())[:, None] * 0.5
        ix = np.floor(px).astype(np.int64) % n
        iy = np.floor(py).astype(np.int64) % n
        w = np.broadcast_to(depth[:, None], px.shape)
        img = np.bincount((iy * n + ix)[keep], weights=w[keep], minlength=n * n)
        img *= 1.0 / 1.5  # ~1.5 samples per pixel crossed
    img = img.reshape(n, n).astype(F32)
    sig = max(width, 0.6 / n)
    img = blur(img, sig)
    # a blurred one-pixel line peaks at 1 / (sqrt(2 pi) sigma_px): undo that so depth ~ intensity
    return np.clip(img * F32(np.sqrt(2 * np.pi) * sig * n), 0, 1).astype(F32)
