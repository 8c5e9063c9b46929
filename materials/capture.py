"""The capture scene of DESIGN.md ("The capture scene", "The BRDF"): the numbers every renderer shares.

One home for them: the Mitsuba scene and BSDF plugin (``pipeline/render/scene.py``, ``bsdf.py``), the torch
renderer of the loss (``train/render.py``, ``train/brdf.py``), the numpy reference
(:mod:`materials.brdf_reference`) and the catalogue's contact sheet all import these names; none restates
them. It imports only ``math``, so that every layer (materials -> pipeline -> train) can use it.

Geometry: the 2 x 2 material plane at z = 0 fills a pinhole camera at (0, 0, D) looking down -z with a
``FOV_DEG`` field of view, so D = 1 / tan(FOV / 2). The flash is a small light in the plane z = D at an offset
from the camera; its intensity is fixed (the paper's scale ambiguity).
"""
from __future__ import annotations

import math

#: field of view of the pinhole camera (degrees, across the image width).
FOV_DEG = 50.0
#: side of the square material plane, centred at the origin (world units); it fills the image exactly.
PLANE_SIZE = 2.0
#: camera height above the plane, D = (PLANE_SIZE / 2) / tan(FOV / 2) ~ 2.1445: the plane fills the picture.
CAMERA_DISTANCE = (PLANE_SIZE / 2) / math.tan(math.radians(FOV_DEG / 2))
#: radiant intensity of the flash (W/sr; a Mitsuba ``point`` light's ``intensity``): pi D^2, so a centred flash
#: gives irradiance pi at the image centre and a white Lambertian texel renders as exactly 1 there.
FLASH_INTENSITY = math.pi * CAMERA_DISTANCE**2
#: range of the flash's offset from the camera centre in the plane z = D (radius, world units). For a flat
#: mirror the highlight sits at half the offset, so LIGHT_R_MAX = 0.7 keeps it within 0.35 of the image centre;
#: LIGHT_R_MIN = 0.1 keeps a sphere flash off the camera's frustum (see pipeline/render/views.py).
LIGHT_R_MIN, LIGHT_R_MAX = 0.1, 0.7

#: perceptual roughness floor, r >= 0.01: alpha = r^2 >= ALPHA_MIN.
ROUGHNESS_MIN = 0.01
#: GGX alpha floor (= ROUGHNESS_MIN^2, exactly 1e-4 in float64): keeps D (peak 1 / (pi alpha^2) ~ 3e7) and its
#: gradient finite in float32 and the VNDF sampler stable. Every BRDF implementation applies it.
ALPHA_MIN = ROUGHNESS_MIN**2
#: floor on a texel normal's z before renormalising: a normal at or below the horizon becomes a grazing one.
NORMAL_Z_MIN = 1e-4
#: spherical-Gaussian Schlick Fresnel of DESIGN.md: F = s + (1 - s) 2^((-A VH - B) VH).
FRESNEL_SG_A, FRESNEL_SG_B = 5.55473, 6.98316
