"""The render core of ``svgen render``: the GGX BSDF plugin, view sampling and map transforms, the flash scene.

Modules:
    bsdf: the DESIGN.md Cook-Torrance/GGX BRDF as a Mitsuba 3 Python BSDF ("svgen_ggx").
    views: per-view random parameters and the numpy transform of base maps into a view.
    scene: the capture scene, loaded once, re-rendered per view through ``mi.traverse``.

The scene's constants and the numpy reference of the BRDF live in ``materials.capture`` and
``materials.brdf_reference`` (numpy only, importable from every layer).
"""
