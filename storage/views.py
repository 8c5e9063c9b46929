"""A view of a renders store: its parameters, and the transform that gives its aligned maps.

A view is a flash photograph of the material plane under a light offset and a texture transform (zoom,
rotation, shift); the renders store keeps one row of :class:`ViewParams` per view (``view`` array). The maps
that go with the view are the base maps under the same transform, normals rotated into screen space:
:func:`transform_planes` computes them. The renderer (:mod:`pipeline.render.scene`) uses exactly those maps as
its textures (one texel per film pixel, nearest lookup), and the store's reader
(:class:`storage.renders_store.RendersReader`, what the training loader crops) recomputes them with the same
function, so they line up with the render pixel for pixel by construction. The transform runs as one drjit
kernel (numpy fancy-index gathers took ~40 ms per 256^2 view, the whole view budget); mitsuba and drjit come from
:mod:`svcore.mi_env` (libLLVM located first), loaded when this module is imported.

This module is the part of a view that the store defines and both the renderer and the loader need; how views are
drawn (the view distribution) is the renderer's, :mod:`pipeline.render.views`.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from materials.capture import NORMAL_Z_MIN
from materials.maps import N_CHANNELS, SVBRDF, pack_maps, unpack_maps

from svcore.mi_env import dr, mi

#: field order of :meth:`ViewParams.as_array` (the per-view row stored in a renders store).
VIEW_FIELDS = ("light_x", "light_y", "zoom", "rotation", "shift_u", "shift_v", "seed")
#: units of each field (the store's ``view`` array records them): world units are those of the capture scene, whose
#: material plane spans [-1, 1]^2 and whose camera looks down from z = D (materials/capture.py).
VIEW_UNITS = {"light_x": "world unit (material plane spans [-1, 1])", "light_y": "world unit (material plane spans "
              "[-1, 1])", "zoom": "base-map tiles per picture width", "rotation": "radian",
              "shift_u": "tile", "shift_v": "tile", "seed": "1"}
VIEW_LONG_NAMES = {"light_x": "flash offset from the camera along image x (right), in the plane z = D",
                   "light_y": "flash offset from the camera along image y (up), in the plane z = D",
                   "zoom": "texture zoom: tiles of the base map across the picture width",
                   "rotation": "counter-clockwise rotation of the material on screen",
                   "shift_u": "texture offset along u (right)", "shift_v": "texture offset along v (up)",
                   "seed": "sampler seed of mi.render (integer < 2^31, exact in float64)"}


@dataclass(frozen=True)
class ViewParams:
    """One view.

    Attributes:
        light_x, light_y: flash offset from the camera in the camera plane (world units; plane half-size 1).
        zoom: base-map tiles across the picture width.
        rotation: counter-clockwise rotation of the material on screen, radians.
        shift_u, shift_v: texture offset in tiles (u right, v up).
        seed: sampler seed for ``mi.render`` (< 2**31).
    """

    light_x: float = 0.0
    light_y: float = 0.3
    zoom: float = 1.0
    rotation: float = 0.0
    shift_u: float = 0.0
    shift_v: float = 0.0
    seed: int = 0

    def as_array(self) -> np.ndarray:
        """(7,) float64 in :data:`VIEW_FIELDS` order (seed < 2**31 is exact in float64)."""
        return np.array([getattr(self, f) for f in VIEW_FIELDS], np.float64)

    @classmethod
    def from_array(cls, a) -> "ViewParams":
        vals = dict(zip(VIEW_FIELDS, (float(x) for x in a)))
        vals["seed"] = int(vals["seed"])
        return cls(**vals)

    def as_dict(self) -> dict:
        return asdict(self)


def supersampling(view: ViewParams, res: int, base: int) -> int:
    """Subsamples per axis: ceil(base texels per output pixel), at least 1 (a box prefilter when minifying)."""
    return max(1, math.ceil(view.zoom * base / res - 1e-9))


#: floats per texel of :class:`BaseTexels`: the 10 channels and 6 of padding, 64 bytes: a texel is one cache line of an
#: aligned buffer, so its three 4-float packets never straddle two lines, as half of 48-byte texels did (#42; the same
#: floats, faster when minifying: experiments/direct_calls)
TEXEL_STRIDE = 16


@dataclass(frozen=True)
class BaseTexels:
    """Base maps packed texel by texel for :func:`transform_planes`: ``buf`` holds each texel's 10 channels (and 6
    zeros: :data:`TEXEL_STRIDE`) side by side, so a bilinear corner is 3 packet gathers of 4 floats from one cache
    line, where 10 separate planes cost 10 scattered loads (#42; the same floats, faster: experiments/packed_texels).

    Attributes:
        buf: mi.Float of width base * base * TEXEL_STRIDE, texels row-major with numpy row 0 = image top.
        base: side length of the square base maps.
    """

    buf: object
    base: int

    @classmethod
    def of_packed(cls, packed: np.ndarray) -> "BaseTexels":
        """From (B, B, 10) maps in the packed layout (:func:`materials.maps.pack_maps`)."""
        b = packed.shape[0]
        t = np.zeros((b * b, TEXEL_STRIDE), np.float32)
        t[:, :N_CHANNELS] = packed.reshape(-1, N_CHANNELS)
        return cls(mi.Float(t.ravel()), b)

    @classmethod
    def of_planes(cls, planes: list, base: int) -> "BaseTexels":
        """From 10 channel planes (mi.Float or numpy, base * base each; :func:`planes_of`)."""
        return cls.of_packed(np.stack([np.asarray(p, np.float32) for p in planes], axis=-1).reshape(base, base, -1))


def texels_of(m: SVBRDF) -> BaseTexels:
    """numpy SVBRDF (B, B, C) -> :class:`BaseTexels` (what :func:`transform_planes` reads fastest)."""
    return BaseTexels.of_packed(pack_maps(m))


def transform_planes(base_planes: "BaseTexels | list", base: int, view: ViewParams, res: int,
                     window: tuple[int, int, int] | None = None) -> list:
    """Transform base maps (the BSDF's channel planes) into a view, in one drjit kernel.

    Per output pixel: ss x ss subsamples (see :func:`supersampling`), each a bilinear, periodically wrapped
    lookup of the base maps at ``texture = zoom * R(-rotation) picture + shift`` (so the material appears
    rotated by +rotation on screen), averaged; then the normal's xy is rotated by ``rotation`` and renormalised
    (the gradient of a rotated height field rotates with it; zoom scales the surface itself, so slopes do not
    change), the other maps are clipped to [0, 1]. View values enter as opaque variables: one compiled kernel
    serves every view of a given (res, base, ss); the subsample loop is unrolled in Python, so the average
    needs no reduction kernel.

    Args:
        base_planes: the base maps as :class:`BaseTexels` (:func:`texels_of`), or as 10 mi.Float of width
            base * base (:func:`planes_of` planes), packed here first (the same result, slower).
        base: side length of the square base maps.
        view: the view.
        res: output side length.
        window: optional (row0, col0, size): only that square of the res x res picture (training crops); the
            offsets are opaque, so every crop position shares one kernel.

    Returns:
        10 evaluated mi.Float of width res * res (or size * size), numpy row 0 = image top.
    """
    texels = base_planes if isinstance(base_planes, BaseTexels) else BaseTexels.of_planes(base_planes, base)
    if texels.base != base:
        raise ValueError(f"the base texels are {texels.base}^2, not {base}^2")
    if window is None:
        pix = dr.arange(mi.UInt32, res * res)
        row = pix // res
        col = pix - row * res
    else:
        r0w, c0w, size = window
        pix = dr.arange(mi.UInt32, size * size)
        row = pix // size
        col = pix - row * size + dr.opaque(mi.UInt32, c0w)
        row = row + dr.opaque(mi.UInt32, r0w)
    out = view_texel(texels, view_inputs(view), supersampling(view, res, base), res, row, col)
    dr.eval(*out)
    return out


def view_inputs(view: ViewParams) -> tuple:
    """The view's transform as opaque kernel inputs (cos, sin of the rotation, zoom, shift_u, shift_v): one compiled
    kernel serves every view of a given (res, base, ss)."""
    return tuple(dr.opaque(mi.Float, v) for v in (math.cos(view.rotation), math.sin(view.rotation), view.zoom,
                                                  view.shift_u, view.shift_v))


def view_texel(texels: BaseTexels, inputs: tuple, ss: int, res: int, row, col, active=True) -> list:
    """The view's maps at output pixels (row, col) of a res x res picture: :func:`transform_planes`'s arithmetic,
    which the renderer's BSDF also runs inside its own kernel for its pixel (:class:`pipeline.render.bsdf.ViewGGXBSDF`):
    one function, so the two give the same floats.

    Args:
        texels: the base maps.
        inputs: :func:`view_inputs` of the view.
        ss: subsamples per axis (:func:`supersampling`).
        res: output side length.
        row, col: mi.UInt32 output pixel indices (numpy row 0 = image top).
        active: lanes to gather for (the others get 0).

    Returns:
        10 mi.Float (lazy): normal xyz (rotated, renormalised), then diffuse, specular and roughness clipped to [0, 1].
    """
    base = texels.base
    packets = -(-N_CHANNELS // 4)  # the packets that hold channels (a texel's stride may pad past them)
    stride = TEXEL_STRIDE // 4
    packet_t = mi.Array4f  # 4 floats gathered at once, in the variant's own array type (llvm or cuda)
    c, s, zoom, su, sv = inputs
    acc = [mi.Float(0.0) for _ in range(N_CHANNELS)]
    for i in range(ss):
        for j in range(ss):
            # picture coordinates in picture widths, origin at the centre, x right, y up
            x = (mi.Float(col) + (j + 0.5) / ss) / res - 0.5
            y = 0.5 - (mi.Float(row) + (i + 0.5) / ss) / res
            tu = zoom * (c * x + s * y) + su
            tv = zoom * (-s * x + c * y) + sv
            # texel centres at integers; the identity view (zoom 1, no rotation/shift, res == base) hits them
            cols = tu * base - 0.5 + base / 2
            rows = -tv * base - 0.5 + base / 2
            cols = cols - base * dr.floor(cols / base)  # wrap into [0, base)
            rows = rows - base * dr.floor(rows / base)
            c0f = dr.floor(cols)
            r0f = dr.floor(rows)
            fc = cols - c0f
            fr = rows - r0f
            c0 = mi.UInt32(dr.clip(mi.Int32(c0f), 0, base - 1))  # clip: float rounding can give exactly `base`
            r0 = mi.UInt32(dr.clip(mi.Int32(r0f), 0, base - 1))
            c1 = dr.select(c0 + 1 == base, 0, c0 + 1)
            r1 = dr.select(r0 + 1 == base, 0, r0 + 1)
            corners = ((r0 * base + c0, (1 - fr) * (1 - fc)), (r0 * base + c1, (1 - fr) * fc),
                       (r1 * base + c0, fr * (1 - fc)), (r1 * base + c1, fr * fc))
            for idx, w in corners:
                # the corner's channels in packets of 4 (channel k is component k % 4 of packet k // 4); each
                # channel's sum keeps the order of one gather per plane: the same floats
                texel = [g[q] for p in range(packets)
                         for g in (dr.gather(packet_t, texels.buf, idx * stride + p, active),) for q in range(4)]
                for k in range(N_CHANNELS):
                    acc[k] = dr.fma(texel[k], w, acc[k])
    if ss > 1:
        acc = [a * (1.0 / (ss * ss)) for a in acc]
    n = dr.normalize(mi.Vector3f(c * acc[0] - s * acc[1], s * acc[0] + c * acc[1],
                                 dr.maximum(acc[2], NORMAL_Z_MIN)))
    return [n.x, n.y, n.z] + [dr.clip(a, 0.0, 1.0) for a in acc[3:]]


def to_planes(packed: np.ndarray) -> np.ndarray:
    """The channel planes of packed maps (the layout the renderer's BSDF and :func:`transform_planes` read).

    Args:
        packed: (H, W, 10) maps in the packed layout (:func:`materials.maps.pack_maps`).

    Returns:
        (10, H * W) float32 planes in ``materials.maps.CHANNEL_NAMES`` order, texels row-major with numpy row 0 =
        image top.
    """
    return np.ascontiguousarray(packed.reshape(-1, N_CHANNELS).T)


def planes_of(m: SVBRDF) -> list:
    """numpy SVBRDF (H, W, C) -> 10 mi.Float channel planes."""
    return [mi.Float(p) for p in to_planes(pack_maps(m))]


def svbrdf_of(planes: list, res: int) -> SVBRDF:
    """10 channel planes (mi.Float or numpy, res*res each) -> numpy SVBRDF of (res, res, C) float32 maps."""
    return unpack_maps(np.stack([np.asarray(p, np.float32) for p in planes], axis=-1).reshape(res, res, N_CHANNELS))


def transform_maps(base: SVBRDF, view: ViewParams, res: int) -> SVBRDF:
    """Base maps under a view's transform (numpy in, numpy out); see :func:`transform_planes`.

    Args:
        base: (B, B, C) square tileable maps.
        view: the view.
        res: output side length.

    Returns:
        SVBRDF with (res, res, C) float32 maps in screen space (numpy row 0 = image top), exactly the textures
        the renderer uses for this view.
    """
    b = base.normal.shape[0]
    if base.normal.shape[:2] != (b, b):
        raise ValueError(f"base maps must be square, got {base.normal.shape[:2]}")
    return svbrdf_of(transform_planes(texels_of(base), b, view, res), res)
