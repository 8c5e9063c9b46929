"""The capture scene's integrator for a point flash, ``svgen_plane_flash``: the plane's own intersection, no shadow ray.

The scene of :mod:`pipeline.render.scene` is one plane lit from the camera's side by a point flash, so every
camera ray that hits the plane sees the flash unoccluded (a plane cannot shadow itself, and nothing else is in
the scene). Mitsuba's ``direct`` integrator (1 emitter sample, 0 BSDF samples) computes, per camera ray, the
hit by the scene's acceleration structure (Embree on the LLVM variants), the flash's direction sample, a shadow
ray and the BSDF. This integrator computes the same product without the two parts the scene does not need:

* the hit comes from the rectangle's own ray-plane code (``shape.ray_intersect_preliminary``), not Embree;
* the flash's direction sample is taken with no shadow ray;
* the plane, its BSDF and the flash are called on the objects themselves (:func:`plane_hit`), not through the
  scene's dispatch over shapes, emitters and BSDFs: the same floats, 16-19 % less CPU per render call
  (experiments/direct_calls).

The image equals ``direct``'s up to float32 rounding of the hit point (the two intersection codes round
differently): ``tests/test_render_integrator.py`` bounds the difference, and ``experiments/render_floor/probe_render_floor.py``
measured it (max relative difference ~1e-5, about 2 differing 8-bit codes per million) and the time saved.

Several views per launch (property ``views`` = V > 1, :class:`pipeline.render.scene.FlashScene`): the scene's
sensor is a Mitsuba ``batch`` of V cameras side by side on one film, camera k at x = k * :data:`VIEW_PITCH`
(otherwise the one camera of the scene). Each ray is moved back to the one camera's frame (its origin's x minus
k * pitch: a power of two, so the view index is exact and the move loses at most ~2e-9 of the origin) and meets
the one plane; the view index rides in the ray's ``time`` (nothing in the scene moves), which the BSDF reads to
pick the view's textures (:mod:`pipeline.render.bsdf`). The flash of view k is a point at (flash_x[k],
flash_y[k], D), evaluated as Mitsuba's ``point`` emitter does (intensity / distance^2); the scene's own emitter
serves one view per launch only.

Only for the point flash: a sphere flash uses MIS with BSDF samples, whose rays must find the sphere, and keeps
``direct``.
"""
from __future__ import annotations

from materials.capture import CAMERA_DISTANCE, FLASH_INTENSITY

from svcore.mi_env import dr, mi

PLUGIN_NAME = "svgen_plane_flash"

#: x distance between the cameras of a several-views launch: a power of two (k * pitch and the move back are exact)
#: larger than twice the near-clip offset of a ray's origin (|d.x| near / d.z < 5e-4 in the 50 degree frustum)
VIEW_PITCH = 2.0 ** -8


class PlaneFlashIntegrator(mi.SamplingIntegrator):
    """``direct`` for a scene of one plane (the scene's first shape) lit by one point flash per view."""

    def __init__(self, props):
        mi.SamplingIntegrator.__init__(self, props)
        self.views = int(props.get("views", 1))
        self.flash_x = mi.Float(0.0)
        self.flash_y = mi.Float(0.0)

    def traverse(self, callback):
        if self.views > 1:
            callback.put("flash_x", self.flash_x, mi.ParamFlags.NonDifferentiable)
            callback.put("flash_y", self.flash_y, mi.ParamFlags.NonDifferentiable)

    def parameters_changed(self, keys=[]):
        if self.views > 1 and (dr.width(self.flash_x) != self.views or dr.width(self.flash_y) != self.views):
            raise ValueError(f"svgen_plane_flash: flash_x and flash_y need {self.views} values, got "
                             f"{dr.width(self.flash_x)} and {dr.width(self.flash_y)}")

    def sample(self, scene, sampler, ray, medium=None, active=True):
        if self.views > 1:
            return self._sample_views(scene, sampler, ray, active)
        plane = scene.shapes()[0]
        si, valid = plane_hit(plane, mi.Ray3f(ray), active)
        act = mi.Bool(active) & valid
        ds, em = scene.emitters()[0].sample_direction(si, sampler.next_2d(act), act)
        act &= ds.pdf != 0.0
        val = plane.bsdf().eval(mi.BSDFContext(), si, si.to_local(ds.d), act)
        return mi.Spectrum(dr.select(act, val * em, 0.0)), valid, []

    def _sample_views(self, scene, sampler, ray, active):
        """One lane of a several-views launch: the view index from the camera's offset, then the one-view product."""
        view_f = dr.round(ray.o.x * (1.0 / VIEW_PITCH))
        r = mi.Ray3f(ray)
        r.o.x = ray.o.x - view_f * VIEW_PITCH
        r.time = view_f  # the view index, for the BSDF's texture lookup (si.time)
        plane = scene.shapes()[0]
        si, valid = plane_hit(plane, r, active)
        act = mi.Bool(active) & valid
        sampler.next_2d(act)  # the emitter sample of the one-view path (a point light does not use it)
        view = mi.UInt32(view_f)
        flash = mi.Point3f(dr.gather(mi.Float, self.flash_x, view, act), dr.gather(mi.Float, self.flash_y, view, act),
                           CAMERA_DISTANCE)
        # Mitsuba's point emitter: d = p - it.p, inv = rsqrt(|d|^2), d * inv, intensity * inv^2
        d = flash - si.p
        inv = dr.rsqrt(dr.squared_norm(d))
        em = mi.Spectrum(FLASH_INTENSITY) * dr.square(inv)
        val = plane.bsdf().eval(mi.BSDFContext(), si, si.to_local(d * inv), act)
        return mi.Spectrum(dr.select(act, val * em, 0.0)), valid, []

    def aov_names(self):
        return []

    def to_string(self):
        return f"PlaneFlashIntegrator[views={self.views}]"


def plane_hit(plane, ray, active):
    """The plane's surface interaction with ``ray``, computed by the plane's own methods.

    This is what ``PreliminaryIntersection3f.compute_surface_interaction`` gives, down to the float, for the fields the
    BSDF and the flash read (uv, p, the shading frame, wi, t, time). It skips that call's dispatch over the scene's
    shapes. Likewise :meth:`PlaneFlashIntegrator.sample` calls the flash's ``sample_direction`` and the plane's BSDF
    on the objects themselves, not through the scene's and the interaction's dispatch.

    Why: drjit compiles each dispatch as a call that reads its object's data through per-lane gathers. Without the
    three dispatches a 256^2 view's render call took 16-19 % less CPU (experiments/direct_calls). Their results are
    the same floats (tests/test_render_integrator.py compares them with the dispatching integrator, exactly).

    The steps after the plane's ``compute_surface_interaction`` are Mitsuba's
    ``SurfaceInteraction::finalize_surface_interaction`` (include/mitsuba/render/interaction.h), the part of it
    that is used here.

    Returns:
        (SurfaceInteraction3f, Bool valid): the interaction and where the ray meets the plane.
    """
    pi = plane.ray_intersect_preliminary(ray, 0, active)
    valid = mi.Bool(active) & pi.is_valid()
    si = plane.compute_surface_interaction(ray, pi, mi.RayFlags.All, valid)
    si.t = dr.select(valid, pi.t, dr.inf)
    si.time = ray.time
    si.initialize_sh_frame()
    si.wi = dr.select(valid, si.sh_frame.to_local(-ray.d), -ray.d)
    return si, valid


def register() -> None:
    """Register the integrator under :data:`PLUGIN_NAME` (idempotent; mitsuba keeps the last registration)."""
    mi.register_integrator(PLUGIN_NAME, lambda props: PlaneFlashIntegrator(props))


register()
