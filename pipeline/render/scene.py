"""The capture scene of DESIGN.md, loaded once and re-rendered per view (its constants: :mod:`materials.capture`).

Geometry: a 2 x 2 ``rectangle`` at z = 0 (normal +z), a pinhole camera at (0, 0, D) looking down -z with up +y
and a 50 degree field of view, D = 1 / tan(25 deg), so the plane fills the picture exactly and film pixel
(row i, col j) sees the plane square x in [-1 + 2j/res, -1 + 2(j+1)/res], y in [1 - 2(i+1)/res, 1 - 2i/res].
The BSDF's texture has one texel per film pixel (nearest lookup, numpy row 0 = image top), so the maps of a
view are exactly the textures it was rendered with.

Flash: a point light, or a sphere of radius ``SPHERE_RADIUS``, in the plane z = D at the view's offset.
Its intensity is fixed (the scale ambiguity of the paper): ``FLASH_INTENSITY = pi D^2`` W/sr, so a centred
flash gives irradiance pi at the image centre, where a white Lambertian texel renders as exactly 1 and typical
albedos (0.1 - 0.6) land mid-range, with the inverse-square and cosine fall-off to ~0.6x in the corners and
highlights clipping. A sphere gets the radiance pi D^2 / (pi r^2) that gives it the same intensity.

Per view only two things change, through ``mi.traverse`` + ``params.update()``: the BSDF's packed map buffer
and the light's position (or the sphere's transform). Both are kernel inputs, not literals, so the render
kernel is compiled once per scene and reused (``tests/test_render_scene.py`` checks the kernel history).

Several views per launch (``views`` > 1, point flash only): the sensor is a Mitsuba ``batch`` of that many copies
of the camera side by side on one film (camera k moved by k * ``integrator.VIEW_PITCH`` in x, which the integrator
takes back off), the BSDF's planes hold every view's textures one after the other, and the flash of each view is
the integrator's (:mod:`pipeline.render.integrator`). One ``mi.render`` call then renders all of them: its
per-call cost (tracing the Python integrator and BSDF, the kernel launch: ~2.5 ms of CPU) is paid once per
launch. The images equal a launch per view up to the float rounding of the pixel position on the wider film
(``tests/test_render_views_per_launch.py``).

Integrator: for the point flash, ``svgen_plane_flash`` (:mod:`pipeline.render.integrator`): what Mitsuba's
``direct`` computes with 1 emitter sample and 0 BSDF samples (a point light is a delta light, reachable only by
emitter sampling), with the plane's own intersection and no shadow ray (a plane lit from its front cannot shadow
itself). A small sphere uses ``direct`` with MIS, one sample of each (BSDF sampling wins for lobes narrower than
the sphere's ~0.5 degrees).
"""
from __future__ import annotations

import math

import numpy as np

from materials.capture import CAMERA_DISTANCE, FLASH_INTENSITY, FOV_DEG, PLANE_SIZE
from materials.maps import SVBRDF

from . import bsdf as _bsdf
from . import integrator as _integrator
from storage.views import ViewParams, planes_of, transform_planes

mi = _bsdf.mi
dr = _bsdf.dr

SPHERE_RADIUS = 0.02
LIGHT_MODELS = ("point", "sphere")
SAMPLERS = ("independent", "stratified", "centre")


def scene_constants() -> dict:
    """Scene constants for store attributes."""
    return {"fov_deg": FOV_DEG, "camera_distance": CAMERA_DISTANCE, "plane_size": PLANE_SIZE,
            "flash_intensity_w_sr": FLASH_INTENSITY, "sphere_radius": SPHERE_RADIUS}


def integrator_name(light_model: str) -> str:
    """The integrator that renders a light model: the plane's own (:mod:`pipeline.render.integrator`) for the point
    flash, Mitsuba's ``direct`` for the sphere (the render stage records it in its config: a partial store of
    another integrator, e.g. a version-3 store's ``direct``, is not resumed into a mix of both)."""
    return _integrator.PLUGIN_NAME if light_model == "point" else "direct"


def scene_description(light_model: str, spp: int, sampler: str) -> str:
    """The capture scene in words and numbers, for a reader without svgen (a renders store's attributes and its
    dataset card); every number comes from :mod:`materials.capture`."""
    light = ("a point light" if light_model == "point" else f"a sphere light of radius {SPHERE_RADIUS}")
    integ = ("the plane's own intersection, no shadow ray: a plane lit from its front cannot shadow itself"
             if light_model == "point" else "Mitsuba integrator 'direct'")
    return (f"A {PLANE_SIZE:g} x {PLANE_SIZE:g} material plane at z = 0, centred at the origin, fills the image of a "
            f"pinhole camera at (0, 0, {CAMERA_DISTANCE:.6f}) looking down -z with up +y and a {FOV_DEG:g} degree "
            f"field of view across the width. The flash is {light} of intensity pi D^2 = {FLASH_INTENSITY:.6f} W/sr "
            f"in the plane z = D at the view's offset (light_x, light_y) from the camera. The BRDF is Cook-Torrance "
            f"GGX (alpha = roughness^2, Schlick-Smith G with k = alpha/2, spherical-Gaussian Schlick Fresnel, "
            f"diffuse d (1 - s) / pi). Only direct light ({integ}), {spp} sample(s) per pixel, "
            f"sampler '{sampler}'; the output is linear radiance clipped to [0, 1] (a gamma-inverted LDR photo).")


def _sphere_transform(x: float, y: float):
    return mi.ScalarTransform4f().translate([x, y, CAMERA_DISTANCE]).scale(SPHERE_RADIUS)


def scene_dict(res: int, spp: int, light_model: str = "point", sampler: str = "independent", views: int = 1,
               in_kernel: bool = False) -> dict:
    """The Mitsuba scene description (light at a default offset; views move it).

    ``views`` > 1 (point flash only): that many views per launch (the module docstring). ``in_kernel``: the plane's
    BSDF is ``svgen_ggx_view`` (:class:`pipeline.render.bsdf.ViewGGXBSDF`: the view's transform inside the render
    kernel; one view per launch), not ``svgen_ggx`` with its planes.

    Samplers (:data:`SAMPLERS`): "independent" (random positions in the pixel); "stratified" (one random
    position in each cell of a k x k grid, spp = k^2); "centre" (the centres of that grid, no randomness:
    k = 1 shades exactly the pixel centre, deterministic and free of pixel noise).
    """
    if light_model not in LIGHT_MODELS:
        raise ValueError(f"unknown light model {light_model!r}; use one of {LIGHT_MODELS}")
    if sampler not in SAMPLERS:
        raise ValueError(f"unknown sampler {sampler!r}; use one of {SAMPLERS}")
    if sampler != "independent" and math.isqrt(spp) ** 2 != spp:
        raise ValueError(f"sampler {sampler!r} needs a square spp (1, 4, 9, 16 ...), got {spp}")
    if views < 1 or (views > 1 and light_model != "point"):
        raise ValueError(f"views per launch must be 1, or more with the point flash; got {views} with {light_model!r}")
    if in_kernel and views != 1:
        raise ValueError(f"the transform inside the render kernel renders one view per launch, not {views}")
    sampler_dict = ({"type": "independent", "sample_count": spp} if sampler == "independent"
                    else {"type": "stratified", "sample_count": spp, "jitter": sampler == "stratified"})
    d = {
        "type": "scene",
        "integrator": ({"type": integrator_name(light_model)} if light_model == "point"
                       else {"type": integrator_name(light_model), "emitter_samples": 1, "bsdf_samples": 1}),
        "sensor": {
            "type": "perspective",
            "fov": FOV_DEG,
            "fov_axis": "x",
            "near_clip": 1e-3,
            "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, CAMERA_DISTANCE], target=[0, 0, 0], up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": res, "height": res, "rfilter": {"type": "box"},
                     "pixel_format": "rgb", "component_format": "float32", "sample_border": False},
            "sampler": sampler_dict,
        },
        "plane": {"type": "rectangle", "bsdf": {"type": _bsdf.VIEW_PLUGIN_NAME if in_kernel else _bsdf.PLUGIN_NAME,
                                                "width": res, "height": res}},
    }
    if views > 1:
        camera = {k: v for k, v in d["sensor"].items() if k not in ("film", "sampler")}
        d["sensor"] = {"type": "batch", "film": {**d["sensor"]["film"], "width": views * res},
                       "sampler": sampler_dict}
        for k in range(views):
            x = k * _integrator.VIEW_PITCH
            d["sensor"][f"view{k}"] = {**camera, "to_world": mi.ScalarTransform4f().look_at(
                origin=[x, 0, CAMERA_DISTANCE], target=[x, 0, 0], up=[0, 1, 0])}
        d["integrator"]["views"] = views
        d["plane"]["bsdf"]["views"] = views
    if light_model == "point":
        d["light"] = {"type": "point", "position": [0.0, 0.3, CAMERA_DISTANCE],
                      "intensity": {"type": "uniform", "value": FLASH_INTENSITY}}
    else:
        d["light"] = {"type": "sphere", "to_world": _sphere_transform(0.0, 0.3),
                      "emitter": {"type": "area", "radiance": {
                          "type": "uniform", "value": FLASH_INTENSITY / (math.pi * SPHERE_RADIUS**2)}}}
    return d


class FlashScene:
    """The capture scene at one resolution, loaded once; render views by changing maps and light.

    Args:
        res: film and texture side length (256 default, 288 as in the paper).
        spp: samples per pixel.
        light_model: "point" or "sphere".
        sampler: "independent", "stratified" or "centre" (see :func:`scene_dict`).
        views: views per launch (point flash only; :meth:`render_views_srgb8` renders them).
        in_kernel: the view's transform inside the render kernel (one view per launch: :meth:`render_view_srgb8`,
            the render stage's path); the planes methods need the default, False.
    """

    def __init__(self, res: int = 256, spp: int = 1, light_model: str = "point", sampler: str = "independent",
                 views: int = 1, in_kernel: bool = False):
        if res < 1 or spp < 1:
            raise ValueError(f"res and spp must be positive, got {res}, {spp}")
        self.res, self.spp, self.light_model, self.sampler = int(res), int(spp), light_model, sampler
        self.views, self.in_kernel = int(views), bool(in_kernel)
        self.scene = mi.load_dict(scene_dict(self.res, self.spp, light_model, sampler, self.views, self.in_kernel))
        self.params = mi.traverse(self.scene)
        # the plane's BSDF (the sphere flash is a shape too)
        self._plane_bsdf = next(b for b in (sh.bsdf() for sh in self.scene.shapes())
                                if isinstance(b, _bsdf.GGXBSDF))
        self._plane_keys = ["plane.bsdf.tex_" + c for c in _bsdf.CHANNELS]
        self._light_key = "light.position" if light_model == "point" else "light.to_world"
        self._encoder = None

    def set_light(self, x: float, y: float) -> None:
        """Move the flash to (x, y, D) (not applied until the next render/update)."""
        if self.light_model == "point":
            self.params[self._light_key] = mi.Point3f(x, y, CAMERA_DISTANCE)
        else:
            self.params[self._light_key] = _sphere_transform(x, y)

    def set_planes(self, planes: list) -> None:
        """Set the textures: 10 channel planes (mi.Float, views * res * res each) already in screen space."""
        if self.in_kernel:
            raise ValueError("an in_kernel scene renders views of base maps (render_view_srgb8), not planes")
        if len(planes) != len(self._plane_keys) or any(dr.width(p) != self.views * self.res ** 2 for p in planes):
            raise ValueError(f"need {len(self._plane_keys)} planes of {self.views} x {self.res}^2 texels")
        for key, plane in zip(self._plane_keys, planes):
            self.params[key] = plane

    def render_planes(self, planes: list, light_xy: tuple[float, float], seed: int, clip: bool = True) -> np.ndarray:
        """Render screen-space channel planes under a flash at light_xy.

        Args:
            planes: 10 mi.Float channel planes of res^2 texels.
            light_xy: flash offset in the camera plane.
            seed: sampler seed.
            clip: clip to [0, 1] (the LDR output); False gives the raw radiance (tests, benchmarks).

        Returns:
            (res, res, 3) float32 linear RGB, numpy row 0 = image top.
        """
        self.set_planes(planes)
        self.set_light(*light_xy)
        self.params.update()
        img = np.asarray(self.radiance(seed), dtype=np.float32).reshape(self.res, self.res, 3)
        return np.clip(img, 0.0, 1.0) if clip else img

    def render_planes_srgb8(self, planes: list, light_xy: tuple[float, float], seed: int) -> np.ndarray:
        """As :meth:`render_planes` (clipped), but returns the stored encoding: (res, res, 3) uint8 sRGB codes,
        encoded by drjit before the image leaves it (see :class:`storage.srgb8.DrjitEncoder`)."""
        self.set_planes(planes)
        self.set_light(*light_xy)
        self.params.update()
        return self._srgb8(seed)

    def render_view_srgb8(self, texels, view: ViewParams) -> np.ndarray:
        """A view of base maps, its transform computed inside the render kernel (an ``in_kernel`` scene): the codes
        :meth:`render_planes_srgb8` gives for ``transform_planes(texels, base, view, res)``, one kernel less.

        Args:
            texels: the base maps (:class:`storage.views.BaseTexels`, :func:`storage.views.texels_of`).
            view: the view (its transform, flash and seed).

        Returns:
            (res, res, 3) uint8 sRGB codes.
        """
        if not self.in_kernel:
            raise ValueError("render_view_srgb8 needs a FlashScene(in_kernel=True)")
        self._plane_bsdf.set_view(texels, view, self.res)
        self.set_light(view.light_x, view.light_y)
        self.params.update()
        return self._srgb8(view.seed)

    def _srgb8(self, seed: int) -> np.ndarray:
        """The scene as set, rendered with sampler seed ``seed`` and encoded: (res, res, 3) uint8 sRGB codes.

        Film-free (:meth:`radiance`), the encoding runs in the render's own kernel, one output per channel
        (:meth:`storage.srgb8.DrjitEncoder.channels`): the same codes as encoding :meth:`radiance`'s floats, one
        kernel and a float scatter per pixel less (experiments/direct_calls).
        """
        encoder = self._srgb8_encoder()
        if self.spp != 1 or self.views != 1:
            return encoder(self.render_film(seed)).reshape(self.res, self.res, 3)
        rgb = self._film_free_rgb(seed)
        return encoder.channels([rgb[0], rgb[1], rgb[2]]).reshape(self.res, self.res, 3)

    def _srgb8_encoder(self):
        """The scene's 8-bit sRGB encoder, made on first use (its tables are drjit arrays of the scene's variant)."""
        from storage.srgb8 import DrjitEncoder

        if self._encoder is None:
            self._encoder = DrjitEncoder()
        return self._encoder

    def radiance(self, seed: int):
        """The scene as set (textures, flash) rendered with sampler seed ``seed``: a drjit Float of res * res * 3
        linear RGB values in the film's order (pixels row by row, channels interleaved), unclipped.

        With one sample per pixel and one view per launch (every store's default), Mitsuba's sensor, integrator and
        BSDF render without its film (:meth:`_film_free`): the same floats, about 1.2 ms less per 288^2 view
        (experiments/film_free). Otherwise the film averages the samples: :meth:`render_film`.
        """
        if self.in_kernel and not self._plane_bsdf.has_view:
            raise ValueError("an in_kernel scene renders a view set on it first (render_view_srgb8)")
        if self.spp != 1 or self.views != 1:
            return self.render_film(seed)
        return self._film_free(seed)

    def render_film(self, seed: int):
        """As :meth:`radiance`, through ``mi.render`` and the scene's film (any spp and views per launch)."""
        return mi.render(self.scene, params=self.params, seed=int(seed), spp=self.spp).array

    def _film_free_rgb(self, seed: int):
        """:meth:`radiance` at one sample per pixel, without the film, as a traced (not evaluated) Spectrum of res * res
        pixels, row by row.

        Mitsuba's ``SamplingIntegrator.render`` (src/render/integrator.cpp) seeds the sensor's sampler with
        (seed, pixels), draws each pixel's position sample, maps it to the film as fmadd(pixel + sample, 1 / size,
        -offset), samples the sensor's ray, calls the integrator's ``sample`` and puts ray weight x radiance into
        the film's block at the pixel (a box filter ignores the position inside it); with one sample per pixel the
        develop step divides by the single sample's weight, 1. This is those steps without the block: the film's
        scatter-add of 4 channels per pixel, its develop kernel and ``mi.render``'s wrapper were ~1.2 ms of a
        288^2 view's CPU. tests/test_render_film_free.py holds the floats equal to ``mi.render``'s.
        """
        sensor = self.scene.sensors()[0]
        n = self.res * self.res
        sampler = sensor.sampler().clone()
        sampler.seed(int(seed), n)
        idx = dr.arange(mi.UInt32, n)
        row = idx // self.res
        pixel = mi.Vector2f(mi.Float(idx - row * self.res), mi.Float(row))
        film_pos = dr.fma(pixel + sampler.next_2d(), mi.Vector2f(1.0 / self.res), mi.Vector2f(-0.0))
        ray, weight = sensor.sample_ray_differential(sensor.shutter_open(), 0.0, film_pos, mi.Point2f(0.5))
        spec, _, _ = self.scene.integrator().sample(self.scene, sampler, ray, None, True)
        return weight * spec

    def _film_free(self, seed: int):
        """:meth:`radiance` at one sample per pixel, without the film: :meth:`_film_free_rgb`'s channels interleaved."""
        return dr.ravel(self._film_free_rgb(seed), order="F")  # F: the 3 channels of a pixel side by side, as the film

    def render_views_srgb8(self, planes: list, lights: list, seed: int) -> np.ndarray:
        """All views of a several-views scene in one launch, as :meth:`render_planes_srgb8` renders one.

        Args:
            planes: per view, its 10 mi.Float channel planes of res^2 texels (screen space).
            lights: per view, its flash offset (x, y).
            seed: the launch's sampler seed.

        Returns:
            (views, res, res, 3) uint8 sRGB codes.
        """
        if self.views < 2 or len(planes) != self.views or len(lights) != self.views:
            raise ValueError(f"this scene renders {self.views} views per launch, got {len(planes)} planes and "
                             f"{len(lights)} lights")
        self.set_planes([dr.concat([p[c] for p in planes]) for c in range(len(self._plane_keys))])
        self.params["integrator.flash_x"] = mi.Float([float(x) for x, _ in lights])
        self.params["integrator.flash_y"] = mi.Float([float(y) for _, y in lights])
        self.params.update()
        img = mi.render(self.scene, params=self.params, seed=int(seed), spp=self.spp)
        codes = self._srgb8_encoder()(img.array).reshape(self.res, self.views, self.res, 3)
        return np.ascontiguousarray(codes.transpose(1, 0, 2, 3))

    def render_view(self, base_planes: list, base_res: int, view: ViewParams) -> tuple[np.ndarray, list]:
        """Transform base maps into ``view`` and render them.

        Args:
            base_planes: 10 mi.Float of base_res^2 texels: tileable base maps (see :func:`planes_of`).
            base_res: side length of the base maps.
            view: light offset, texture transform and seed.

        Returns:
            image (res, res, 3) float32 in [0, 1]; the screen-space planes it was rendered with.
        """
        planes = transform_planes(base_planes, base_res, view, self.res)
        return self.render_planes(planes, (view.light_x, view.light_y), view.seed), planes

    def render_maps(self, maps: SVBRDF, view: ViewParams, clip: bool = True) -> np.ndarray:
        """Render screen-space numpy maps (already aligned: (res, res, C)) under the view's light and seed."""
        if maps.normal.shape[:2] != (self.res, self.res):
            raise ValueError(f"maps are {maps.normal.shape[:2]}, the scene renders {self.res}^2")
        return self.render_planes(planes_of(maps), (view.light_x, view.light_y), view.seed, clip)
