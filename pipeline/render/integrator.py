"""The capture scene's integrator for a point flash, ``svgen_plane_flash``: the plane's own intersection, no shadow ray.

The scene of :mod:`pipeline.render.scene` is one plane lit from the camera's side by a point flash, so every
camera ray that hits the plane sees the flash unoccluded (a plane cannot shadow itself, and nothing else is in
the scene). Mitsuba's ``direct`` integrator (1 emitter sample, 0 BSDF samples) computes, per camera ray, the
hit by the scene's acceleration structure (Embree on the LLVM variants), the flash's direction sample, a shadow
ray and the BSDF. This integrator computes the same product without the two parts the scene does not need:

* the hit comes from the rectangle's own ray-plane code (``shape.ray_intersect_preliminary``), not Embree;
* the flash's direction sample is taken with ``test_visibility=False``: no shadow ray.

The image equals ``direct``'s up to float32 rounding of the hit point (the two intersection codes round
differently): ``tests/test_render_integrator.py`` bounds the difference, and ``experiments/render_floor/probe_render_floor.py``
measured it (max relative difference ~1e-5, about 2 differing 8-bit codes per million) and the time saved.

Only for the point flash: a sphere flash uses MIS with BSDF samples, whose rays must find the sphere, and keeps
``direct``.
"""
from __future__ import annotations

from svcore.mi_env import dr, mi

PLUGIN_NAME = "svgen_plane_flash"


class PlaneFlashIntegrator(mi.SamplingIntegrator):
    """``direct`` for a scene of one plane (the scene's first shape) lit by one point light."""

    def sample(self, scene, sampler, ray, medium=None, active=True):
        r = mi.Ray3f(ray)
        pi = scene.shapes()[0].ray_intersect_preliminary(r, 0, active)
        si = pi.compute_surface_interaction(r, mi.RayFlags.All, active)
        valid = si.is_valid()
        act = mi.Bool(active) & valid
        ds, em = scene.sample_emitter_direction(si, sampler.next_2d(act), False, act)
        act &= ds.pdf != 0.0
        val = si.bsdf(ray).eval(mi.BSDFContext(), si, si.to_local(ds.d), act)
        return mi.Spectrum(dr.select(act, val * em, 0.0)), valid, []

    def aov_names(self):
        return []

    def to_string(self):
        return "PlaneFlashIntegrator[]"


def register() -> None:
    """Register the integrator under :data:`PLUGIN_NAME` (idempotent; mitsuba keeps the last registration)."""
    mi.register_integrator(PLUGIN_NAME, lambda props: PlaneFlashIntegrator(props))


register()
