"""svcore: the infrastructure every svgen package shares (materials, pipeline, train).

errors (the user-error family), log (one logger per package), progress (the one progress bar), seeds
(derive_seed and its named purposes), image_io (image files at the edges), config (typed configs, presets,
params.yaml and ``--set``), cli (the one-line error funnel, ``--version``), mi_env and llvm (mitsuba and drjit
the one right way, for the renderer and the renders store's reader). Importing svcore loads none of mitsuba,
drjit, dask or torch: mi_env loads mitsuba and drjit on first use.
"""
