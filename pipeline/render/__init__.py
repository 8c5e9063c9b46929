"""The render core of ``svgen render``: the GGX BSDF plugin, view sampling, the flash scene, the stage.

Modules:
    bsdf: the DESIGN.md Cook-Torrance/GGX BRDF as a Mitsuba 3 Python BSDF ("svgen_ggx").
    integrator: the point-flash integrator of the capture scene (``svgen_plane_flash``).
    views: the view distribution (how each view's light offset, texture transform and seed are drawn).
    scene: the capture scene, loaded once, re-rendered per view through ``mi.traverse``.
    stage: ``svgen render``'s stage (chunks of SVBRDFs, their views, the renders store).

What a view is and the transform of base maps into it (the textures the scene renders), the renders store's
schema and reader, and the 8-bit sRGB encoding of its images belong to the store: :mod:`storage.views`,
:mod:`storage.renders_store`, :mod:`storage.srgb8` (the training loader reads them without this package).

The scene's constants and the numpy reference of the BRDF live in ``materials.capture`` and
``materials.brdf_reference`` (numpy only, importable from every layer).
"""
