"""`svgen render` as a stage: every SVBRDF of a variants/blends store -> V flash views -> a renders store.

One dask task renders one chunk of SVBRDFs (all their views) and writes that whole chunk. A task is a pure
function of (config, chunk id, input bytes): view k of SVBRDF s is drawn from derive_seed(seed, "render", s, k),
the render is per pixel (no cross-pixel reduction, so drjit's thread count does not change a bit), and the
image encoding is a table lookup; hence the same bytes for any number of workers, local or distributed.
"""
from __future__ import annotations

import functools

import numpy as np

from materials.maps import MAP_NAMES

from svcore.errors import StoreError

from storage.store import StoreWriter, write_chunk

from ..config import RenderConfig
from ..exec.runner import Stage

_SCENES: dict[tuple, object] = {}
_INPUTS: dict[str, SVBRDFStore] = {}


def _scene(res: int, spp: int, light: str, sampler: str, views: int = 1):
    """The worker process's scene for these settings: loaded once, reused by every task (no recompilation)."""
    from .scene import FlashScene

    key = (res, spp, light, sampler, views)
    if key not in _SCENES:
        # one setting per process at a time (each scene holds its textures and a compiled kernel); its scenes for
        # different views per call stay side by side: a task's last launch may be shorter than the others
        if any(k[:4] != key[:4] for k in _SCENES):
            _SCENES.clear()
        # one view per launch: the view's transform inside the render kernel (the same codes, one kernel less)
        _SCENES[key] = FlashScene(res, spp, light, sampler, views, in_kernel=views == 1)
    return _SCENES[key]


def scene_for(cfg: RenderConfig):
    """``views -> FlashScene``: the worker's scene for cfg rendering that many views per call (:func:`render_svbrdf`)."""
    return functools.partial(_scene, cfg.res, cfg.spp, cfg.light, cfg.sampler)


def launch_groups(views: int, per_launch: int) -> list[range]:
    """The views of one SVBRDF, in launches of ``per_launch`` (the last may be shorter)."""
    return [range(k, min(views, k + per_launch)) for k in range(0, views, per_launch)]


def render_svbrdf(scene, maps, index: int, cfg: RenderConfig,
                  light_radius: tuple[float, float] | None = None,
                  out: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """All views of one SVBRDF.

    Args:
        scene: ``views -> FlashScene`` matching cfg, rendering that many views per call.
        maps: (B, B, C) base maps (decoded from the store bytes).
        index: the SVBRDF's index (seeds its views).
        cfg: the render configuration.
        light_radius: optional (min, max) light offset radius replacing the default range (stress sets).
        out: (V, R, R, 3) uint8 array the images are written into (a row of the chunk's image array: no
            per-SVBRDF allocation and no copy of the chunk's images into a stacked one), else a new one.

    Returns:
        images (V, R, R, 3) uint8 sRGB codes (``out`` where given); views (V, 7) float64 view parameters.
    """
    from storage.views import texels_of, transform_planes

    from .views import R_MAX, R_MIN, draw_views

    base = texels_of(maps)
    b = maps.normal.shape[0]
    views = draw_views(cfg.seed, index, cfg.views, light_radius or (R_MIN, R_MAX), tuple(cfg.zoom))
    images = np.empty((cfg.views, cfg.res, cfg.res, 3), np.uint8) if out is None else out
    for group in launch_groups(cfg.views, cfg.views_per_launch):
        if len(group) == 1:  # one view per call (its own seed): the stored bytes of every default store
            images[group[0]] = scene(1).render_view_srgb8(base, views[group[0]])
            continue
        planes = [transform_planes(base, b, views[k], cfg.res) for k in group]
        lights = [(views[k].light_x, views[k].light_y) for k in group]
        # the launch's sampler seed is its first view's (the default 'centre' sampler draws nothing)
        images[group.start:group.stop] = scene(len(group)).render_views_srgb8(planes, lights, views[group[0]].seed)
    return images, np.stack([v.as_array() for v in views])


def _chunk_task(c: int, threads: int, *, partial: str, inputs: tuple[str, ...], cfg: RenderConfig, n: int) -> int:
    """Worker: render the SVBRDFs of chunk c and write the whole chunk. Returns the number of views."""
    from storage.svbrdf_store import SVBRDFInputs, decode_maps
    from svcore.mi_env import use_variant

    use_variant(cfg.variant)  # before the scene's modules load: a worker process renders in the run's variant
    from svcore.mi_env import dr

    dr.set_thread_count(max(1, threads))
    if inputs not in _INPUTS:  # opening the stores costs ~6 ms each: once per worker process
        _INPUTS.clear()
        _INPUTS[inputs] = SVBRDFInputs(inputs)
    src = _INPUTS[inputs]
    start, stop = c * cfg.chunk, min(n, (c + 1) * cfg.chunk)
    scene = scene_for(cfg)
    raw = src.read(start, stop)
    # the chunk's images rendered in place: a stacked copy of them was the render stage's largest fresh allocation
    # (160 MB per 64-SVBRDF chunk at 288², page-faulted in and copied: experiments/chunk_buffers)
    images = np.empty((stop - start, cfg.views, cfg.res, cfg.res, 3), np.uint8)
    views = []
    for j in range(stop - start):
        s = start + j
        maps = decode_maps({k: raw[k][j] for k in MAP_NAMES})
        try:
            maps.validate(normal_tol=1e-3)
        except ValueError as e:
            raise StoreError(f"{src.paths[raw['input'][j]]}: sample {raw['index'][j]}: {e}") from None
        radius = tuple(raw["light_radius"][j]) if np.isfinite(raw["light_radius"][j]).all() else None
        _, vw = render_svbrdf(scene, maps, s, cfg, radius, out=images[j])
        views.append(vw)
    stored = {k: raw[k] for k in MAP_NAMES} if cfg.maps == "stored" else {}  # else read from the inputs
    data = {"image": images, "view": np.stack(views), **stored,
            "source": raw["index"], "source_seed": raw["seed"], "input": raw["input"], "preset": raw["preset"],
            "category": raw["category"]}
    write_chunk(partial, c, start, data)
    return (stop - start) * cfg.views


def render_stage(inputs, cfg: RenderConfig) -> Stage:
    """The render stage of ``inputs`` under ``cfg`` (opens and checks the inputs; writes nothing).

    Args:
        inputs: one or more variants/blends/stress store paths, rendered as one sequence in this order.

    Raises:
        StoreError: an input missing or of the wrong kind.
        MitsubaUnavailable: ``cfg.variant`` cannot render here (e.g. cuda_ad_rgb without CUDA).
    """
    from storage.svbrdf_store import SVBRDFInputs
    from svcore.mi_env import use_variant

    use_variant(cfg.variant)  # refused before anything is opened or written; the workers inherit it
    from . import scene as scene_module
    from .scene import mi, scene_constants, scene_description
    from storage.renders_store import KIND, array_specs
    from .views import R_MAX, R_MIN

    src = SVBRDFInputs(inputs)
    n = len(src)
    fixed = {
        "presets": src.presets,
        "categories": src.categories,
        "scene": {**scene_constants(), "light_model": cfg.light, "spp": cfg.spp, "sampler": cfg.sampler,
                  "output": "linear LDR radiance clipped to [0, 1]", "mitsuba_variant": mi.variant(),
                  "description": scene_description(cfg.light, cfg.spp, cfg.sampler)},
        "view_distribution": {"light_radius": [R_MIN, R_MAX], "light_radius_law": "uniform over the annulus",
                              "light_radius_override": "per-sample light_radius of stress inputs",
                              "zoom": list(cfg.zoom), "zoom_law": "log-uniform", "rotation": "U(0, 2 pi)",
                              "shift": "U(0, 1)^2 tiles", "seed": "derive_seed(seed, 'render', svbrdf, view)"},
        "aligned_maps": "recomputed: storage.views.transform_maps(base maps, view, res)",
        **({} if cfg.maps == "stored" else {"base_maps": BASE_MAPS_NOTE}),
    }

    def attrs(out):  # the inputs' paths relative to the output: the same strings for any spelling of them
        return {"inputs": src.describe(out), **fixed}

    # the inputs' identity (kind, size, config hash: not how their path is spelled) is part of the config:
    # resuming against different inputs must be refused, with any spelling of the same inputs accepted
    config = {**{k: v for k, v in cfg.as_dict().items() if k not in cfg.dropped_keys()},
              "inputs": [{k: v for k, v in d.items() if k != "path"} for d in src.describe()],
              "integrator": scene_module.integrator_name(cfg.light)}
    specs = array_specs(cfg.views, cfg.res, src.size, cfg.maps == "stored")
    return Stage(KIND, n, cfg.chunk, specs, config, attrs, _chunk_task,
                 dict(inputs=_paths(inputs), cfg=cfg, n=n), desc="render", unit="view", units_per_sample=cfg.views,
                 inputs=_paths(inputs), finish=record_split)


#: the group attribute of a renders store without maps (format version 6): where a reader finds them
BASE_MAPS_NOTE = ("not stored: SVBRDF s's base maps are sample source[s] of the input store inputs[input[s]] (its "
                  "path relative to this store's folder; a recipe blends store mixes them from its variants store), "
                  "the codes it was rendered from; svgen's readers check the inputs' config hashes and seeds. Keep "
                  "the input stores beside this one")


def record_split(partial) -> dict:
    """The stage's finish hook: the held-out split of training's defaults (:mod:`svcore.split`), recorded in the
    store so that a reader without svgen (and ``svtrain``) sees the same split; no ``split`` attribute where the
    store has fewer than 2 base materials."""
    import zarr

    from svcore.split import split_record

    from storage.objstore import zarr_location

    g = zarr.open_group(zarr_location(partial), mode="r")
    names = list(g.attrs.get("presets", []))
    ids = [tuple(names[p] for p in row if p >= 0) for row in g["preset"][:]]
    rec = split_record(ids, "svbrdf")
    return {} if rec is None else {"split": rec}


def render_writer(inputs, out, cfg: RenderConfig) -> tuple[StoreWriter, int]:
    """The StoreWriter of a render run (not entered yet) and the number of SVBRDFs (benchmarks drive it)."""
    stage = render_stage(inputs, cfg)
    return stage.writer(out), stage.n


def chunk_task(w: StoreWriter, inputs, cfg: RenderConfig, n: int):
    """The picklable worker function ``(chunk id, threads) -> views written`` of a render run."""
    return functools.partial(_chunk_task, partial=str(w.partial), inputs=_paths(inputs), cfg=cfg, n=n)


def _paths(inputs) -> tuple[str, ...]:
    return (str(inputs),) if isinstance(inputs, str) or hasattr(inputs, "__fspath__") else tuple(map(str, inputs))


def run_render(inputs, out, cfg: RenderConfig, workers: int = 2, scheduler_address: str | None = None) -> str:
    """Render every SVBRDF of the input store(s) into a renders store at ``out`` (resuming a killed run).

    Args:
        inputs: a store path or a sequence of them (e.g. variants and blends), rendered in order.

    Raises:
        StoreError: an input missing, of the wrong kind or with invalid maps; output exists or is being written.
        ConfigError: unreachable scheduler.
    """
    return render_stage(inputs, cfg).run(out, workers, scheduler_address)
