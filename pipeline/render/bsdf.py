"""The DESIGN.md Cook-Torrance/GGX BRDF as a Mitsuba 3 BSDF written in Python (drjit), name ``svgen_ggx``.

Model (alpha = r**2, clamped to ``ALPHA_MIN``; every vector in the shading frame of the texel's normal; the
constants come from :mod:`materials.capture`, the numpy statement of the model is :mod:`materials.brdf_reference`):

    D = a^2 / (pi (NH^2 (a^2 - 1) + 1)^2)
    G = G1(NL) G1(NV),  G1(x) = x / (x (1 - k) + k),  k = a / 2
    F = s + (1 - s) 2^((-5.55473 VH - 6.98316) VH)
    f = d (1 - s) / pi + D F G / (4 NL NV)

The specular term is evaluated as ``D F / (4 (NL(1-k)+k) (NV(1-k)+k))``: algebraically identical (the NL NV of
G cancel the 1/(4 NL NV)), but its denominator is >= k^2 > 0, so nothing divides by a cosine that reaches 0.

Textures: the four maps are 10 channel planes, each a flat float buffer of H*W texels (:data:`CHANNELS`, the
packed layout of :mod:`materials.maps`; see :func:`storage.views.to_planes`), looked up with nearest filtering
from the surface uv: column ``floor(u W)``, numpy row ``floor((1 - v) H)`` -- a Mitsuba ``rectangle`` has v = 0
at its bottom edge (y = -1), while numpy row 0 is the image top. Ten gathers are far cheaper than four bitmap
textures, and the planes are exposed to ``mi.traverse`` as ``tex_<channel>`` so a loaded scene takes new maps
without recompiling its kernel (a buffer is a kernel input, not a literal). Planes, not one interleaved buffer:
a transform kernel can then write all channels as separate outputs of one kernel, with no scatter.

Normal map: a texel's normal n (tangent space: x right, y up, z out) is expressed in the surface's local frame,
which for the plane of the capture scene is (s, t, n) = (+x, +y, +z) = (image right, image up, to the camera).
The BRDF is evaluated in ``Frame3f(n)``; the returned value includes the cosine ``max(n . wo, 0)``, the cosine
of DESIGN.md's shading. Directions below the geometric surface are rejected as well (a plane cannot be lit
from behind), so the BSDF is zero unless both the geometric and the mapped cosines are positive.

Sampling: a mixture of GGX visible-normal sampling (Heitz 2018) and cosine sampling, with the specular
probability from the texel's albedos (see :meth:`GGXBSDF._spec_prob`); pdf() is the exact mixture density.
"""
from __future__ import annotations

import numpy as np

from materials.capture import ALPHA_MIN, FRESNEL_SG_A, FRESNEL_SG_B, NORMAL_Z_MIN
from materials.maps import CHANNEL_NAMES, MAP_SLICES, SVBRDF, pack_maps

from svcore.mi_env import bind_variant, load_mitsuba

from storage.views import supersampling, to_planes, view_inputs, view_texel

mi = load_mitsuba()
import drjit as dr  # noqa: E402  (after load_mitsuba: drjit must see the libLLVM path first)

#: the variant this module's BSDF class belongs to (the current one at import: svcore.mi_env.use_variant)
VARIANT = mi.variant()
bind_variant(VARIANT)

PLUGIN_NAME = "svgen_ggx"
#: channel planes of the texture, in the packed order: normal xyz, diffuse rgb, specular rgb, roughness.
CHANNELS = CHANNEL_NAMES
#: smallest probability of choosing the specular lobe (it is never exactly zero: F -> 1 at grazing angles).
SPEC_PROB_MIN = 0.1
_INV_PI = 1.0 / np.pi


def _schlick_sg(s, vh):
    """Spherical-Gaussian Schlick Fresnel, s: Color3f (F0), vh: Float."""
    return s + (1.0 - s) * dr.exp2((-FRESNEL_SG_A * vh - FRESNEL_SG_B) * vh)


def _ggx_d(h, a2):
    """GGX normal distribution D(h) for a unit half vector h (local to the normal frame), a2 = alpha^2."""
    # NH^2 (a^2 - 1) + 1 = NH^2 a^2 + (1 - NH^2), and 1 - NH^2 = hx^2 + hy^2 for unit h: computed from the
    # tangential components it keeps full float32 precision near the peak, where 1 - NH would cancel to a
    # few ulps (r = 0.05: 1 - NH ~ 3e-6, ulp 6e-8 -> ~10 % error on D).
    nh = dr.maximum(h.z, 0.0)
    t = dr.fma(nh * nh, a2, h.x * h.x + h.y * h.y)
    return dr.select(h.z > 0.0, a2 * _INV_PI / dr.maximum(t * t, 1e-30), 0.0)


def _half(wi, wo):
    """Unit half vector of wi, wo and where it exists: |wi + wo|^2 > 1e-30 (wo = -wi has none; for grazing
    opposite directions the squared norm underflows and a plain normalize gives NaN). Where it does not
    exist, wi and wo lie within 1e-15 of opposite, so one cosine is <= ~1e-15: callers return 0 there."""
    hh = wi + wo
    n2 = dr.squared_norm(hh)
    return hh * dr.rsqrt(dr.maximum(n2, 1e-30)), n2 > 1e-30


def _smith_g1_exact(v, a2):
    """Exact Smith G1 of GGX (the shadowing of the VNDF sampler, not the BRDF's Schlick-Smith G)."""
    z2 = dr.maximum(v.z * v.z, 1e-12)
    tan2 = dr.maximum(1.0 - z2, 0.0) / z2
    return 2.0 / (1.0 + dr.sqrt(1.0 + a2 * tan2))


def _sample_vndf(wi, alpha, u):
    """Heitz 2018 visible-normal sample of isotropic GGX; wi: Vector3f (z > 0), u: Point2f -> microfacet normal."""
    vh = dr.normalize(mi.Vector3f(alpha * wi.x, alpha * wi.y, wi.z))
    lensq = vh.x * vh.x + vh.y * vh.y
    inv = dr.rsqrt(dr.maximum(lensq, 1e-20))
    t1v = dr.select(lensq > 1e-20, mi.Vector3f(-vh.y * inv, vh.x * inv, 0.0), mi.Vector3f(1.0, 0.0, 0.0))
    t2v = dr.cross(vh, t1v)
    r = dr.sqrt(u.x)
    sin_phi, cos_phi = dr.sincos(2.0 * dr.pi * u.y)
    t1 = r * cos_phi
    t2 = r * sin_phi
    s = 0.5 * (1.0 + vh.z)
    t2 = (1.0 - s) * dr.safe_sqrt(1.0 - t1 * t1) + s * t2
    nh = t1 * t1v + t2 * t2v + dr.safe_sqrt(1.0 - t1 * t1 - t2 * t2) * vh
    return dr.normalize(mi.Vector3f(alpha * nh.x, alpha * nh.y, dr.maximum(nh.z, 1e-6)))


class GGXBSDF(mi.BSDF):
    """Spatially varying DESIGN.md GGX BRDF with a per-texel normal map.

    Plugin properties (all optional; constant maps are for tests and chi2):
        width, height (int): texture resolution (default 1 x 1); the texel grid spans uv [0, 1]^2.
        views (int): textures per plane, one per view of a several-views launch (default 1): each plane holds
            views * height * width texels, view k's from k * height * width on, picked by the interaction's
            ``time`` (the view index: :mod:`pipeline.render.integrator`). The constant maps fill the first view.
        diffuse, specular (float or 3-vector): constant initial albedo / F0 (defaults 0.5, 0.04).
        roughness (float): constant perceptual roughness (default 0.5).
        normal (3-vector): constant tangent-space normal (default (0, 0, 1)); renormalised.

    Traversable parameters:
        tex_nx ... tex_rough (Float, H*W each): the channel planes of :func:`~storage.views.to_planes`; replace them
        through ``mi.traverse(scene)`` with planes of the same resolution.
    """

    def __init__(self, props):
        mi.BSDF.__init__(self, props)
        self.width = int(props.get("width", 1))
        self.height = int(props.get("height", 1))
        self.views = int(props.get("views", 1))

        def rgb(name, default):
            v = props.get(name, default)
            return np.broadcast_to(np.asarray(v, np.float32).reshape(-1), (3,))

        n = np.asarray(props.get("normal", [0.0, 0.0, 1.0]), np.float64)
        n = (n / np.linalg.norm(n)).astype(np.float32)
        hw = (self.height, self.width)
        planes = to_planes(pack_maps(SVBRDF(
            normal=np.broadcast_to(n, hw + (3,)),
            diffuse=np.broadcast_to(rgb("diffuse", 0.5), hw + (3,)),
            specular=np.broadcast_to(rgb("specular", 0.04), hw + (3,)),
            roughness=np.full(hw + (1,), float(props.get("roughness", 0.5)), np.float32),
        )))
        for name, plane in zip(CHANNELS, planes):
            setattr(self, "tex_" + name, mi.Float(np.tile(plane, self.views)))
        flags = (
            mi.BSDFFlags.DiffuseReflection
            | mi.BSDFFlags.GlossyReflection
            | mi.BSDFFlags.FrontSide
            | mi.BSDFFlags.SpatiallyVarying
        )
        self.m_flags = flags
        self.m_components = [mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.FrontSide | mi.BSDFFlags.SpatiallyVarying,
                             mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.FrontSide | mi.BSDFFlags.SpatiallyVarying]

    # ---- parameters -------------------------------------------------------------------------------------------
    def traverse(self, callback):
        for name in CHANNELS:
            callback.put("tex_" + name, getattr(self, "tex_" + name), mi.ParamFlags.NonDifferentiable)

    def parameters_changed(self, keys=[]):
        # params.update() has already set the attributes named like the parameters (tex_<channel>)
        expected = self.width * self.height * self.views
        for name in CHANNELS:
            plane = getattr(self, "tex_" + name)
            if dr.width(plane) != expected:
                raise ValueError(f"svgen_ggx: plane {name} has {dr.width(plane)} texels, expected {expected} "
                                 f"({self.height}x{self.width}{self._of_views()})")

    def to_string(self):
        return f"GGXBSDF[{self.height}x{self.width}{self._of_views()}]"

    def _of_views(self) -> str:
        return f" x {self.views} views" if self.views > 1 else ""

    # ---- texture lookup ---------------------------------------------------------------------------------------
    def _pixel(self, si):
        """The texel (and film pixel) a hit falls in: (row, col) mi.UInt32, numpy row 0 = image top."""
        col = mi.UInt32(dr.clip(mi.Int32(dr.floor(si.uv.x * self.width)), 0, self.width - 1))
        row = mi.UInt32(dr.clip(mi.Int32(dr.floor((1.0 - si.uv.y) * self.height)), 0, self.height - 1))
        return row, col

    def _channels(self, si, active) -> list:
        """The hit's texel: its 10 channel values, looked up (nearest) in the planes."""
        row, col = self._pixel(si)
        idx = row * self.width + col
        if self.views > 1:  # the view's own textures (one view per launch compiles without this term)
            idx += mi.UInt32(si.time) * (self.height * self.width)
        return [dr.gather(mi.Float, getattr(self, "tex_" + name), idx, active) for name in CHANNELS]

    def _texel(self, si, active):
        """Nearest-texel lookup -> (normal Vector3f, diffuse Color3f, specular Color3f, alpha Float)."""
        c = self._channels(si, active)
        n = mi.Vector3f(*c[MAP_SLICES["normal"]])
        d = mi.Color3f(*c[MAP_SLICES["diffuse"]])
        s = mi.Color3f(*c[MAP_SLICES["specular"]])
        (r,) = c[MAP_SLICES["roughness"]]
        n = dr.normalize(mi.Vector3f(n.x, n.y, dr.maximum(n.z, NORMAL_Z_MIN)))
        alpha = dr.maximum(r * r, ALPHA_MIN)
        return n, d, s, alpha

    @staticmethod
    def _spec_prob(nv, d, s):
        """Probability of sampling the GGX lobe: its share of an albedo estimate (Fresnel at the view angle)."""
        ws = dr.mean(_schlick_sg(s, nv))
        wd = dr.mean(d * (1.0 - s))
        return dr.clip(ws / dr.maximum(ws + wd, 1e-8), SPEC_PROB_MIN, 1.0)

    # ---- the model --------------------------------------------------------------------------------------------
    @staticmethod
    def _brdf_cos(wi, wo, d, s, alpha):
        """f * cos(wo) in the normal-map frame (wi, wo local to it); 0 where either cosine is <= 0."""
        nv, nl = wi.z, wo.z
        h, has_h = _half(wi, wo)
        vh = dr.maximum(dr.dot(wi, h), 0.0)
        a2 = alpha * alpha
        k = 0.5 * alpha
        D = _ggx_d(h, a2)
        F = _schlick_sg(s, vh)
        # D F G / (4 NL NV) with G's NL NV cancelled: denominator >= k^2 > 0.
        spec = D * F / (4.0 * dr.fma(nl, 1.0 - k, k) * dr.fma(nv, 1.0 - k, k))
        f = d * (1.0 - s) * _INV_PI + spec
        ok = (nv > 0.0) & (nl > 0.0) & has_h
        return dr.select(ok, f * nl, 0.0)

    @staticmethod
    def _pdf_local(wi, wo, alpha, p_spec):
        """Mixture pdf (solid angle) of wo given wi, both local to the normal-map frame."""
        a2 = alpha * alpha
        h, has_h = _half(wi, wo)
        # VNDF: p(m) = G1(wi) max(0, wi.m) D(m) / wi.z; Jacobian of reflection 1/(4 wo.m), and wo.m = wi.m.
        p_s = _smith_g1_exact(wi, a2) * _ggx_d(h, a2) / (4.0 * dr.maximum(wi.z, 1e-8))
        p_d = dr.maximum(wo.z, 0.0) * _INV_PI
        ok = (wi.z > 0.0) & (wo.z > 0.0) & has_h
        return dr.select(ok, p_spec * p_s + (1.0 - p_spec) * p_d, 0.0)

    def _setup(self, si, wo, active):
        n, d, s, alpha = self._texel(si, active)
        frame = mi.Frame3f(n)
        wi_n = frame.to_local(si.wi)
        wo_n = frame.to_local(wo)
        geometric = (si.wi.z > 0.0) & (wo.z > 0.0)
        return wi_n, wo_n, d, s, alpha, geometric

    def eval(self, ctx, si, wo, active=True):
        wi_n, wo_n, d, s, alpha, geometric = self._setup(si, wo, active)
        value = self._brdf_cos(wi_n, wo_n, d, s, alpha)
        return dr.select(active & geometric, value, 0.0)

    def pdf(self, ctx, si, wo, active=True):
        wi_n, wo_n, d, s, alpha, geometric = self._setup(si, wo, active)
        p = self._pdf_local(wi_n, wo_n, alpha, self._spec_prob(wi_n.z, d, s))
        return dr.select(active & geometric, p, 0.0)

    def eval_pdf(self, ctx, si, wo, active=True):
        wi_n, wo_n, d, s, alpha, geometric = self._setup(si, wo, active)
        ok = active & geometric
        value = self._brdf_cos(wi_n, wo_n, d, s, alpha)
        p = self._pdf_local(wi_n, wo_n, alpha, self._spec_prob(wi_n.z, d, s))
        return dr.select(ok, value, 0.0), dr.select(ok, p, 0.0)

    def sample(self, ctx, si, sample1, sample2, active=True):
        n, d, s, alpha = self._texel(si, active)
        frame = mi.Frame3f(n)
        wi_n = frame.to_local(si.wi)
        p_spec = self._spec_prob(wi_n.z, d, s)
        pick_spec = sample1 < p_spec

        m = _sample_vndf(wi_n, alpha, sample2)
        wo_spec = mi.reflect(wi_n, m)  # mi.reflect(v, m) = 2 (v.m) m - v
        wo_diff = mi.warp.square_to_cosine_hemisphere(sample2)
        wo_n = dr.select(pick_spec, wo_spec, wo_diff)
        wo = frame.to_world(wo_n)

        value = self._brdf_cos(wi_n, wo_n, d, s, alpha)
        p = self._pdf_local(wi_n, wo_n, alpha, p_spec)
        ok = active & (si.wi.z > 0.0) & (wi_n.z > 0.0) & (wo.z > 0.0) & (wo_n.z > 0.0) & (p > 0.0)

        bs = dr.zeros(mi.BSDFSample3f)
        bs.wo = wo
        bs.pdf = dr.select(ok, p, 0.0)
        bs.eta = 1.0
        bs.sampled_type = mi.UInt32(dr.select(pick_spec, int(mi.BSDFFlags.GlossyReflection),
                                              int(mi.BSDFFlags.DiffuseReflection)))
        bs.sampled_component = dr.select(pick_spec, mi.UInt32(1), mi.UInt32(0))
        weight = dr.select(ok, value / dr.maximum(p, 1e-20), 0.0)
        return bs, weight


class ViewGGXBSDF(GGXBSDF):
    """:class:`GGXBSDF` whose texel is computed in the render kernel from the base maps and the view's transform, name
    ``svgen_ggx_view``: the render stage's BSDF at one view per launch.

    The planes path is two kernels: :func:`storage.views.transform_planes` writes the view's 10 planes, then the
    render kernel gathers its pixel's texel back from them, a float per plane. Here the hit's pixel (the one the
    nearest lookup finds) goes through :func:`storage.views.view_texel`, the transform's own function, inside the
    render kernel: the same floats, one kernel and 10 gathers per pixel less (experiments/fused_transform).

    Set the view with :meth:`set_view` before rendering (its transform enters the kernel as opaque inputs: one
    compiled kernel per subsample count). The ``tex_*`` planes are unused.
    """

    def __init__(self, props):
        GGXBSDF.__init__(self, props)
        if self.views != 1 or self.width != self.height:
            raise ValueError("svgen_ggx_view renders one square view per launch")
        self._texels = None
        self._ss = 1
        self._inputs = None

    def set_view(self, texels, view, res: int) -> None:
        """Render ``view`` of base maps ``texels`` (:class:`storage.views.BaseTexels`) at the film's ``res``."""
        if res != self.width:
            raise ValueError(f"svgen_ggx_view: the film is {self.width}^2, not {res}^2")
        self._texels, self._ss, self._inputs = texels, supersampling(view, res, texels.base), view_inputs(view)

    @property
    def has_view(self) -> bool:
        return self._texels is not None

    def _channels(self, si, active) -> list:
        if self._texels is None:
            # drjit traces every live BSDF instance into a kernel that dispatches over BSDFs (symbolic calls), so
            # another scene's render traces this one too: give it its (unused) constant planes, not an error
            return GGXBSDF._channels(self, si, active)
        row, col = self._pixel(si)
        return view_texel(self._texels, self._inputs, self._ss, self.width, row, col, active)

    def to_string(self):
        return f"ViewGGXBSDF[{self.height}x{self.width}]"


#: the plugin name of :class:`ViewGGXBSDF`
VIEW_PLUGIN_NAME = "svgen_ggx_view"


def register() -> None:
    """Register the plugins under :data:`PLUGIN_NAME` and :data:`VIEW_PLUGIN_NAME` (idempotent; mitsuba keeps the
    last registration)."""
    mi.register_bsdf(PLUGIN_NAME, lambda props: GGXBSDF(props))
    mi.register_bsdf(VIEW_PLUGIN_NAME, lambda props: ViewGGXBSDF(props))


register()
