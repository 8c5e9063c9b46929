"""Stability where the methods fail (issue #5): the two BRDF implementations at every edge of their domain.

The matrix: roughness {0, 1e-4, 0.01, 1} (and in between), light and view near grazing and below the plane,
normals near the horizon and invalid (zero vector, z <= 0), diffuse and specular albedo at 0 and 1. For each
(n, l, v, maps) tuple:

* the Mitsuba plugin (``svgen_ggx.eval``, evaluated directly on a few thousand lanes per call: one texel per
  lane, ``si.uv`` at the texel centre) gives finite values >= 0, and finite pdfs;
* the torch BRDF (``train.brdf.ggx_cos``) gives finite values >= 0 and finite gradients w.r.t. all ten map
  channels and both directions;
* where the result is defined, both equal the DESIGN.md formula in float64 (``materials.brdf_reference``) on
  the same float32 inputs with the same floors, within the float32 conditioning of the lobe (below).

Shared floors (the "same clamping floors"): normal z is raised to 1e-4 and the normal renormalised (a zero
vector or one at/below the horizon becomes a grazing or upright normal: both renderers), alpha >= 1e-4
(r >= 0.01). "Defined" means: with that normal n', n'.l > 0, n'.v > 0, l_z > 0 and v_z > 0 (lit from the
front, seen from the front), each by a margin of 1e-5 so float32 rounding cannot put the two renderers on
different sides of a boundary. Outside, the conventions differ on purpose and are asserted as such: Mitsuba
returns exactly 0 (a plane is not lit or seen from behind, a back-facing shading normal is black), while the
torch loss renderer follows the paper's original code (clamped cosines, no back-facing mask, so a predicted
normal that faces away from a grazing loss view still gets a gradient); in the flash scene of the data both
directions are always above the plane.

Tolerance where defined: |x - ref| <= 2e-4 |ref| + C u / alpha |spec| + 1e-7, u = 6e-8 (float32), spec the
specular part of ref (the diffuse term has no D, so its conditioning terms do not apply to it). The first
term is float32 arithmetic (measured <= 3e-5 away from the peak); the second is the conditioning of D near its
peak: a direction rounded by u moves 1 - N.H^2 by ~u alpha, which changes D by ~u / alpha relative (r = 0:
alpha = 1e-4 gives ~1e-3 per ulp). C = 200 covers the few ulps of both the inputs' normalisation and the
renderers' own arithmetic. Measured: the edge matrix max relative error 3.8e-6 (Mitsuba) / 2.7e-6 (torch);
around the peaks 1.4e-3 / 1.1e-3 at r <= 0.01, i.e. <= 12 u / alpha. A third term, COND_H u / ((1 + l.v) alpha),
covers torch's half vector where light and viewer are grazing and nearly opposite (found by hypothesis in CI: 0.1 %
off at 1 + l.v = 3e-6); the hypothesis test is derandomized so that CI draws the same examples every run.

Finding (fixed in train/brdf.py): torch evaluated D's denominator as NH^2 (a^2 - 1) + 1, which cancels in
float32: at the shared floor (a^2 = 1e-8 < float32 epsilon) the peak came out 1e8 too large (1.3e11 instead of
1.3e3 for a black r = 0 surface lit and seen head-on), and around the peak the relative RMSE against float64
was 45 % at r = 0.05, 6 % at r = 0.1. Now 1 - NH^2 = |n x h|^2 as in the plugin: <= 0.2 % RMSE at r = 0.
test_edge_matrix, test_peaks_at_the_roughness_floor and test_random_edges_agree fail on the old code.
"""
from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
import torch
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from materials.brdf_reference import design_brdf, render_point_flash
from materials.capture import ALPHA_MIN, CAMERA_DISTANCE, FLASH_INTENSITY, NORMAL_Z_MIN
from materials.maps import N_CHANNELS, SVBRDF, pack_maps, unpack_maps
from pipeline.render import bsdf as B
from train.brdf import ggx_cos
from train.loss import rendering_loss, sample_configs
from train.render import flash_render

mi, dr = B.mi, B.dr

LANES = 4096
MARGIN = 1e-5
U32 = 2.0 ** -24  # float32 unit roundoff
RTOL = 2e-4
COND = 200.0
ATOL = 1e-7
#: torch derives N·H and V·H from l·v without normalising the half vector; 1 + l·v then carries an absolute
#: float32 error of a few u, so the half vector's direction is off by ~u / (1 + l·v), and D (as for COND) turns a
#: direction error e into ~e / alpha relative: large only where l -> -v (light and viewer grazing and opposite,
#: which neither the flash scene nor the loss's configurations produce).
COND_H = 8.0

ROUGH_EDGES = [0.0, 1e-4, 0.01, 1.0]
ALBEDO_EDGES = [0.0, 1.0]


class MitsubaBRDF:
    """The svgen_ggx plugin as a vectorised function of per-lane (n, l, v, d, s, r), LANES lanes per call."""

    def __init__(self):
        self.bsdf = mi.load_dict({"type": B.PLUGIN_NAME, "width": LANES, "height": 1})
        self.params = mi.traverse(self.bsdf)
        self.ctx = mi.BSDFContext()

    def _chunk(self, n, l, v, d, s, r):
        m = n.shape[0]

        def pad(a, fill):
            return np.concatenate([a, np.broadcast_to(np.asarray(fill, a.dtype), (LANES - m,) + a.shape[1:])])

        planes = B.to_planes(pack_maps(SVBRDF(normal=pad(n, [0, 0, 1]), diffuse=pad(d, 0.5), specular=pad(s, 0.04),
                                              roughness=pad(r, 0.5))))
        for name, plane in zip(B.CHANNELS, planes):
            self.params["tex_" + name] = mi.Float(plane)
        self.params.update()
        vv, ll = pad(v, [0, 0, 1]), pad(l, [0, 0, 1])
        si = dr.zeros(mi.SurfaceInteraction3f, LANES)
        si.wi = mi.Vector3f(vv[:, 0], vv[:, 1], vv[:, 2])  # Mitsuba's wi: towards the viewer
        si.uv = mi.Point2f((np.arange(LANES) + 0.5) / LANES, np.full(LANES, 0.5))  # texel centre of lane i
        wo = mi.Vector3f(ll[:, 0], ll[:, 1], ll[:, 2])  # towards the light
        value, pdf = self.bsdf.eval_pdf(self.ctx, si, wo)
        return np.array(value).T[:m].astype(np.float64), np.array(pdf)[:m].astype(np.float64)

    def __call__(self, n, l, v, d, s, r):
        """f(v, l) * max(n.l, 0) per lane, (M, 3) float64 of float32 results; and the pdf, (M,)."""
        out = [self._chunk(*(a[i:i + LANES] for a in (n, l, v, d, s, r))) for i in range(0, n.shape[0], LANES)]
        return np.concatenate([o[0] for o in out]), np.concatenate([o[1] for o in out])


@pytest.fixture(scope="module")
def mitsuba_brdf():
    return MitsubaBRDF()


def torch_brdf(n, l, v, d, s, r):
    """train.brdf.ggx_cos per lane with gradients w.r.t. the maps and both directions.

    Returns:
        value (M, 3) float64, and the gradients of sum(log(value + 0.01)) (the loss's shape) w.r.t. the maps
        (M, 10), l (M, 3) and v (M, 3).
    """
    maps = torch.tensor(np.concatenate([n, d, s, r], 1).T[None, :, :, None], requires_grad=True)
    wi = torch.tensor(l.T[None, :, :, None], requires_grad=True)
    wo = torch.tensor(v.T[None, :, :, None], requires_grad=True)
    out = ggx_cos(maps, wi, wo)
    torch.log(out + 0.01).sum().backward()
    grads = [t.grad[0, :, :, 0].T.numpy() for t in (maps, wi, wo)]
    return (out.detach()[0, :, :, 0].T.numpy().astype(np.float64), *grads)


def shared_normal(n: np.ndarray) -> np.ndarray:
    """The normal both renderers shade with: z raised to NORMAL_Z_MIN, renormalised (float64)."""
    m = np.concatenate([n[:, :2], np.maximum(n[:, 2:], NORMAL_Z_MIN)], 1).astype(np.float64)
    return m / np.linalg.norm(m, axis=1, keepdims=True)


def unit(a: np.ndarray) -> np.ndarray:
    """Unit rows in float64, then rounded to float32 (the renderers' input); zero rows stay zero."""
    a = np.asarray(a, np.float64)
    norm = np.linalg.norm(a, axis=1, keepdims=True)
    return np.where(norm > 0, a / np.where(norm > 0, norm, 1), 0).astype(np.float32)


def classify(n, l, v):
    """Masks (defined, undefined) over lanes; lanes within MARGIN of a boundary are in neither."""
    ns = shared_normal(n)
    l64, v64 = l.astype(np.float64), v.astype(np.float64)
    cos = np.stack([np.sum(ns * l64, 1), np.sum(ns * v64, 1), l64[:, 2], v64[:, 2]], 1)
    return (cos > MARGIN).all(1), (cos < -MARGIN).any(1)


def reference(n, l, v, d, s, r):
    """DESIGN.md in float64 on the float32 inputs and shared floors: f * n'.l (meaningful where defined)."""
    ns = shared_normal(n)
    l64, v64 = l.astype(np.float64), v.astype(np.float64)
    nl = np.sum(ns * l64, 1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):  # l = -v (no half vector) is never a defined lane
        return design_brdf(ns, v64, l64, d.astype(np.float64), s.astype(np.float64), r.astype(np.float64)) * nl


def tolerance(ref: np.ndarray, spec: np.ndarray, r: np.ndarray, l: np.ndarray, v: np.ndarray) -> np.ndarray:
    """RTOL on the whole value; the conditioning terms (COND, COND_H: D's sensitivity near its peak) only on the
    specular part ``spec`` (the reference with zero diffuse albedo): the diffuse term d (1 - s) / pi has no D in it,
    and scaling it by u / alpha would let a 12 % diffuse error pass at r <= 0.01."""
    alpha = np.maximum(r.astype(np.float64) ** 2, ALPHA_MIN)
    opp = np.maximum(1.0 + np.sum(l.astype(np.float64) * v.astype(np.float64), 1, keepdims=True), 1e-12)
    return RTOL * np.abs(ref) + (COND * U32 / alpha + COND_H * U32 / (opp * alpha)) * np.abs(spec) + ATOL


def check_lanes(mitsuba_brdf, n, l, v, d, s, r, label: str = "") -> dict:
    """Run both renderers on the lanes and assert finiteness, gradients and agreement; returns statistics."""
    n, l, v, d, s, r = (np.ascontiguousarray(a, np.float32) for a in (n, l, v, d, s, r))
    mv, mp = mitsuba_brdf(n, l, v, d, s, r)
    tv, g_maps, g_l, g_v = torch_brdf(n, l, v, d, s, r)
    where = lambda mask: np.nonzero(~mask.reshape(len(n), -1).all(1))[0][:5]  # noqa: E731
    ctx = lambda idx: [(n[i], l[i], v[i], d[i], s[i], r[i]) for i in idx]  # noqa: E731
    assert np.isfinite(mv).all() and (mv >= 0).all(), f"{label} mitsuba value {ctx(where(np.isfinite(mv) & (mv >= 0)))}"
    assert np.isfinite(mp).all() and (mp >= 0).all(), f"{label} mitsuba pdf {ctx(where(np.isfinite(mp) & (mp >= 0)))}"
    assert np.isfinite(tv).all() and (tv >= 0).all(), f"{label} torch value {ctx(where(np.isfinite(tv) & (tv >= 0)))}"
    for name, g in (("maps", g_maps), ("l", g_l), ("v", g_v)):
        assert np.isfinite(g).all(), f"{label} torch d/d{name} not finite at {ctx(where(np.isfinite(g)))}"

    defined, undefined = classify(n, l, v)
    assert (mv[undefined] == 0).all(), f"{label} mitsuba nonzero outside the domain {ctx(where(mv[undefined] == 0))}"
    ref = reference(n, l, v, d, s, r)
    tol = tolerance(ref, reference(n, l, v, np.zeros_like(d), s, r), r, l, v)
    stats = {"lanes": len(n), "defined": int(defined.sum()), "undefined": int(undefined.sum())}
    for name, x in (("mitsuba", mv), ("torch", tv)):
        bad = defined[:, None] & ~(np.abs(x - ref) <= tol)
        if bad.any():
            i = np.nonzero(bad.any(1))[0]
            worst = i[np.argmax((np.abs(x - ref) / tol)[i].max(1))]
            pytest.fail(f"{label} {name} disagrees with DESIGN.md on {len(i)} defined lanes; worst: n={n[worst]} "
                        f"l={l[worst]} v={v[worst]} d={d[worst]} s={s[worst]} r={r[worst]}: {name} {x[worst]}, "
                        f"float64 {ref[worst]}, mitsuba {mv[worst]}, torch {tv[worst]}")
        alpha = np.maximum(r[:, 0].astype(np.float64) ** 2, ALPHA_MIN)
        rel = np.abs(x - ref).max(1) / np.maximum(np.abs(ref).max(1), 1e-30)
        stats[name + "_max_rel"] = float(rel[defined].max()) if defined.any() else 0.0
        stats[name + "_max_rel_over_u_alpha"] = float((rel * alpha / U32)[defined].max()) if defined.any() else 0.0
    return stats


# ---------------------------------------------------------------------------------------------------------------
# the matrix, deterministically: every combination of the edge values

def _dirs(thetas_deg, phis=(0.3, 2.5)):
    return [[math.sin(math.radians(t)) * math.cos(p), math.sin(math.radians(t)) * math.sin(p),
             math.cos(math.radians(t))] for t in thetas_deg for p in phis]


EDGE_NORMALS = [
    [0, 0, 1],             # flat
    [0.3, -0.2, 0.93],     # generic tilt
    [1, 0, 1e-3],          # near the horizon
    [1, 0, 1e-7],          # at the horizon in float32 terms (raised to the floor)
    [0, 0, 0],             # invalid: zero vector
    [0.5, 0.2, -0.5],      # invalid: z < 0
    [0, 0, -1],            # invalid: pointing down
    [0.2, 0.1, 0.5],       # not unit length
]
# straight up, generic, near grazing (to 1e-5 rad), exactly grazing, just below and below the plane
EDGE_THETAS = [0.0, 30.0, 60.0, 89.9, 89.999, 89.99999, 90.0, 90.01, 120.0]


def edge_matrix():
    dirs = _dirs(EDGE_THETAS)
    rows = list(itertools.product(ROUGH_EDGES, EDGE_NORMALS, dirs, dirs, ALBEDO_EDGES, ALBEDO_EDGES))
    n = np.array([x[1] for x in rows], np.float32)
    l = unit([x[2] for x in rows])
    v = unit([x[3] for x in rows])
    d = np.repeat(np.array([[x[4]] for x in rows], np.float32), 3, 1)
    s = np.repeat(np.array([[x[5]] for x in rows], np.float32), 3, 1)
    r = np.array([[x[0]] for x in rows], np.float32)
    return n, l, v, d, s, r


def test_edge_matrix(mitsuba_brdf):
    """All 4 x 8 x 18 x 18 x 2 x 2 combinations: finite everywhere, equal to DESIGN.md where defined."""
    stats = check_lanes(mitsuba_brdf, *edge_matrix(), label="matrix")
    assert stats["defined"] > 5000 and stats["undefined"] > 5000  # both regimes are exercised
    print(stats)


def test_peaks_at_the_roughness_floor(mitsuba_brdf):
    """Light at (and within a few alpha of) the mirror direction, where D peaks at 1/(pi alpha^2) = 3e7 for
    r <= 0.01: the case that was 1e8 off in torch. Also the exact peak's value, against the closed form."""
    rng = np.random.default_rng(0)
    m = 2000
    rough = np.array(ROUGH_EDGES + [0.02, 0.05, 0.1, 0.3], np.float32)
    r = rough[rng.integers(0, len(rough), m)][:, None]
    n = unit(np.concatenate([0.3 * rng.standard_normal((m, 2)), np.ones((m, 1))], 1))
    v = unit(np.concatenate([0.3 * rng.standard_normal((m, 2)), np.ones((m, 1))], 1))
    mirror = 2 * np.sum(n * v, 1, keepdims=True) * n - v
    alpha = np.maximum(r.astype(np.float64) ** 2, ALPHA_MIN)
    l = unit(mirror + alpha * rng.standard_normal((m, 3)) * rng.choice([0, 0.3, 1, 3], (m, 1)))
    d = rng.choice([0.0, 0.5, 1.0], (m, 3)).astype(np.float32)
    s = rng.choice([0.0, 0.04, 1.0], (m, 3)).astype(np.float32)
    stats = check_lanes(mitsuba_brdf, n, l, v, d, s, r, label="peaks")
    assert stats["defined"] > 0.9 * m
    print(stats)

    # head-on at r = 0: D = 1/(pi 1e-8), G's visibility 1/4, F = s = 1 -> f cos = 1 / (4 pi 1e-8)
    up = np.array([[0, 0, 1]], np.float32)
    one = np.ones((1, 3), np.float32)
    tv = torch_brdf(up, up, up, 0 * one, one, np.zeros((1, 1), np.float32))[0]
    mv = mitsuba_brdf(up, up, up, 0 * one, one, np.zeros((1, 1), np.float32))[0]
    expect = 1.0 / (4 * math.pi * 1e-8)
    np.testing.assert_allclose(tv, expect, rtol=1e-5)
    np.testing.assert_allclose(mv, expect, rtol=1e-5)


# ---------------------------------------------------------------------------------------------------------------
# hypothesis: random tuples biased to the edges

_edge_unit = st.sampled_from([0.0, 1e-7, 1e-3, 0.5, 1.0 - 1e-7, 1.0])
unit_value = st.one_of(_edge_unit, st.floats(0.0, 1.0, width=32))
roughness = st.one_of(st.sampled_from(ROUGH_EDGES), st.floats(0.0, 1.0, width=32))
_elev = st.one_of(st.sampled_from([0.0, 1e-7, 1e-5, 1e-3, 0.01, -1e-5, -0.3, 1.0]), st.floats(-1.0, 1.0))
_azim = st.floats(0.0, 2 * math.pi)


@st.composite
def direction(draw):
    """A unit direction by elevation sine z and azimuth: grazing (z ~ 0), below (z < 0) and above."""
    z = draw(_elev)
    phi = draw(_azim)
    rxy = math.sqrt(max(1.0 - z * z, 0.0))
    return [rxy * math.cos(phi), rxy * math.sin(phi), z]


normal = st.one_of(
    st.sampled_from(EDGE_NORMALS),
    st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1)).map(list),  # any length, any side
    direction(),
)


@st.composite
def lane(draw):
    n = draw(normal)
    v = draw(direction())
    if draw(st.booleans()):  # near the mirror of v about the (floored) normal: the specular peak
        ns = shared_normal(np.array([n], np.float64))[0]
        l = list(2 * np.dot(ns, v) * ns - np.asarray(v) + draw(st.floats(-1e-3, 1e-3)))
    else:
        l = draw(direction())
    rgb = st.one_of(unit_value.map(lambda x: [x] * 3), st.tuples(unit_value, unit_value, unit_value).map(list))
    return n, l, v, draw(rgb), draw(rgb), [draw(roughness)]


# derandomize: CI runs the same 60 examples every time (a random draw once failed CI on a tolerance gap, now
# covered by COND_H and pinned in test_near_opposite_grazing_directions). derandomize overrides --hypothesis-seed:
# to explore new draws, set derandomize=False (and max_examples higher) locally and pass --hypothesis-seed=N.
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow], derandomize=True)
@given(lanes=st.lists(lane(), min_size=1, max_size=48))
def test_random_edges_agree(mitsuba_brdf, lanes):
    n, l, v, d, s, r = (np.array([x[i] for x in lanes], np.float64) for i in range(6))
    check_lanes(mitsuba_brdf, n.astype(np.float32), unit(l), unit(v), d.astype(np.float32),
                s.astype(np.float32), r.astype(np.float32), label="hypothesis")


def test_near_opposite_grazing_directions(mitsuba_brdf):
    """A lane hypothesis found: light and viewer both grazing and almost opposite (1 + l·v = 3e-6). Torch is
    0.1 % off float64 there (half-vector conditioning, COND_H), Mitsuba (normalised l + v) is exact; both finite."""
    n = np.array([[0.0, 0.0, 1.0]], np.float32)
    l = unit([[-9.99998689e-01, 5.29124518e-04, 1.52965286e-03]])
    v = unit([[0.9999995, 0.0, 0.001]])
    zero = np.zeros((1, 3), np.float32)
    stats = check_lanes(mitsuba_brdf, n, l, v, zero, zero, np.array([[0.5]], np.float32), label="opposite")
    assert stats["defined"] == 1
    assert stats["mitsuba_max_rel"] < 1e-5 < stats["torch_max_rel"] < 1e-2  # the gap COND_H exists for


# ---------------------------------------------------------------------------------------------------------------
# the same edges through the two scene-level paths: the flash render (both renderers) and the loss (torch)

def _edge_maps(res: int, rng: np.random.Generator) -> np.ndarray:
    """(res, res, 10) float32 maps whose texels take edge values independently per channel group."""
    normals = np.array(EDGE_NORMALS + [[0.9, 0, 0.44], [-0.7, 0.7, 0.1]], np.float32)
    n = normals[rng.integers(0, len(normals), (res, res))]
    d = rng.choice([0.0, 1.0, 0.3], (res, res, 3))
    s = rng.choice([0.0, 1.0, 0.04], (res, res, 3))
    r = rng.choice([0.0, 1e-4, 0.01, 0.1, 1.0], (res, res, 1))
    return pack_maps(SVBRDF(normal=n, diffuse=d, specular=s, roughness=r))


@pytest.mark.parametrize("light_xy", [(0.0, 0.0), (0.5, -0.3), (3.0, 0.0)])
def test_flash_render_edges(light_xy):
    """Edge-valued maps in the capture scene: Mitsuba (pixel centres) and torch finite, torch gradients
    finite, and equal where defined. The light is always above the plane here; (3, 0) puts it far outside
    the picture (grazing light at the left edge)."""
    from pipeline.render.scene import FlashScene
    from storage.views import ViewParams

    res = 32
    packed = _edge_maps(res, np.random.default_rng(7))
    maps = unpack_maps(packed)
    mi_img = FlashScene(res, 1, "point", "centre").render_maps(maps, ViewParams(*light_xy), clip=False)
    x = torch.tensor(packed).permute(2, 0, 1)[None].requires_grad_(True)
    t_img = flash_render(x, torch.tensor(light_xy), clip=False)
    torch.log(t_img + 0.01).sum().backward()
    t_img = t_img.detach()[0].permute(1, 2, 0).numpy().astype(np.float64)
    assert np.isfinite(mi_img).all() and np.isfinite(t_img).all() and np.isfinite(x.grad.numpy()).all()

    # per-pixel directions at pixel centres (train.render / FlashScene geometry)
    j, i = np.meshgrid(np.arange(res), np.arange(res))
    p = np.stack([-1 + (j + 0.5) * 2 / res, 1 - (i + 0.5) * 2 / res, np.zeros((res, res))], -1).reshape(-1, 3)
    l = unit(np.array([light_xy[0], light_xy[1], CAMERA_DISTANCE]) - p)
    v = unit(np.array([0.0, 0.0, CAMERA_DISTANCE]) - p)
    flat = unpack_maps(packed.reshape(-1, N_CHANNELS))
    defined, undefined = classify(flat.normal, l, v)
    ref = render_point_flash(SVBRDF(normal=shared_normal(flat.normal).reshape(res, res, 3).astype(np.float32),
                                    diffuse=maps.diffuse, specular=maps.specular, roughness=maps.roughness),
                             light_xy, FLASH_INTENSITY, CAMERA_DISTANCE).reshape(-1, 3)
    spec = render_point_flash(SVBRDF(normal=shared_normal(flat.normal).reshape(res, res, 3).astype(np.float32),
                                     diffuse=np.zeros_like(maps.diffuse), specular=maps.specular,
                                     roughness=maps.roughness),
                              light_xy, FLASH_INTENSITY, CAMERA_DISTANCE).reshape(-1, 3)
    tol = tolerance(ref, spec, flat.roughness, l, v)
    for name, img in (("mitsuba", mi_img.reshape(-1, 3)), ("torch", t_img.reshape(-1, 3))):
        bad = defined[:, None] & ~(np.abs(img - ref) <= tol)
        assert not bad.any(), (name, np.nonzero(bad.any(1))[0][:5], img[bad.any(1)][:3], ref[bad.any(1)][:3])
    assert (mi_img.reshape(-1, 3)[undefined] == 0).all()
    assert defined.sum() > res * res // 4


def test_rendering_loss_gradients_at_edges():
    """The training loss (9 configurations, torch) on edge-valued predictions against edge-valued targets:
    finite loss and finite gradients w.r.t. every map channel."""
    rng = np.random.default_rng(3)
    pred = torch.tensor(_edge_maps(24, rng)).permute(2, 0, 1)[None].repeat(2, 1, 1, 1).requires_grad_(True)
    target = torch.tensor(_edge_maps(24, rng)).permute(2, 0, 1)[None].repeat(2, 1, 1, 1)
    cfg = sample_configs(2, torch.Generator().manual_seed(0))
    loss = rendering_loss(pred, target, cfg=cfg)
    loss.backward()
    assert torch.isfinite(loss) and torch.isfinite(pred.grad).all()


def test_opposite_grazing_directions_regression(mitsuba_brdf):
    """Found by the hypothesis sweep: l = (-1, 0, z), v = (1, 0, z) with z ~ 1e-38 (or any z < ~1e-19) made
    the plugin's normalize(wi + wo) return NaN (|wi + wo|^2 underflows); fixed in pipeline/render/bsdf.py."""
    zs = np.array([1.1754944e-38, 1e-30, 1e-20, 1e-19, 0.0], np.float32)
    m = len(zs)
    l = np.stack([-np.ones(m), np.zeros(m), zs], 1).astype(np.float32)
    v = np.stack([np.ones(m), np.zeros(m), zs], 1).astype(np.float32)
    n = np.tile(np.array([[0, 0, 1]], np.float32), (m, 1))
    zero, one = np.zeros((m, 3), np.float32), np.ones((m, 3), np.float32)
    for r in (0.0, 1.0):
        check_lanes(mitsuba_brdf, n, l, v, zero, one, np.full((m, 1), r, np.float32), label="opposite")
