"""The dataset card (``README.md``) of a store: Hugging Face style, generated from the store's own attributes.

:meth:`storage.local.StoreWriter.finalize` writes it into the store before the store is moved into place (so a
partial store never has one), and ``svgen card STORE [--write]`` prints or regenerates it. It holds nothing that
is not in the store. Its "How it was made" prints the store's CF ``history`` (the commands that wrote it, normalised
by :mod:`svcore.history`: no time, paths relative to the store's directory, no worker options), so that, like the
rest of the store, the card is a function of the seed, code, configuration and inputs.

Pairing an image with its maps: the aligned maps are not stored, they are the base maps under the view's
transform. The card states that transform as a formula rather than offering an export of aligned maps: the
formula costs no bytes (aligned maps at 256² would add 170 KB per view, doubling the store), it is exactly what
:func:`storage.views.transform_planes` computes, and a reader who wants the arrays can apply it in a
few lines of numpy; ``svgen export --format exr|deschaintre`` already writes aligned maps as files for those who
prefer files.
"""
from __future__ import annotations

import json

import yaml

CARD = "README.md"
#: the licence of generated data (the code's licence is the repository's LICENSE, MIT).
DATA_LICENSE = "cc-by-4.0"

CITATION = """@article{deschaintre2018single,
  title   = {Single-Image SVBRDF Capture with a Rendering-Aware Deep Network},
  author  = {Deschaintre, Valentin and Aittala, Miika and Durand, Fr\\'edo and Drettakis, George and
             Bousseau, Adrien},
  journal = {ACM Transactions on Graphics (Proceedings of SIGGRAPH)},
  volume  = {37}, number = {4}, articleno = {128}, year = {2018},
  doi     = {10.1145/3197517.3201378}
}"""

_WHAT = {
    "variants": "procedural SVBRDFs: perturbed variants of the svgen base materials (or imported materials), four "
                "tileable maps each (normal, diffuse, specular, roughness) with the parameters and seed that made them",
    "blends": "alpha-blends of random pairs of variants (normals blended as slopes), four tileable maps each",
    "stress": "evaluation SVBRDFs of the paper's failure cases, one category per sample",
    "renders": "flash photographs of SVBRDFs (several random views each) with the base maps they were rendered "
               "from and each view's light offset and texture transform: the (image, maps) pairs of single-image "
               "SVBRDF capture",
}

PAIRING = """Aligned maps are not stored: the maps of view `v` of sample `s` are the base maps of sample `s`
(`normal`, `diffuse`, `specular`, `roughness`, decoded) under the view's transform. With the view row
`light_x, light_y, zoom, rotation, shift_u, shift_v, seed = view[s, v]` (rotation θ), the base-map side `B` and
the image side `R`, for output pixel (row i, column j), numpy row 0 at the image top:

    ss = max(1, ceil(zoom * B / R))                      # subsamples per axis (box prefilter when minifying)
    for each subsample (a, b) in 0..ss-1:
        x = (j + (b + 0.5) / ss) / R - 0.5               # picture coordinates, x right, y up, in picture widths
        y = 0.5 - (i + (a + 0.5) / ss) / R
        u = zoom * ( cos θ * x + sin θ * y) + shift_u    # texture coordinates in tiles
        t = zoom * (-sin θ * x + cos θ * y) + shift_v
        col = u * B - 0.5 + B / 2 ;  row = -t * B - 0.5 + B / 2   (both modulo B: the maps tile)
        value = bilinear lookup of the base maps at (row, col), wrapping at the borders
    m = mean of the ss * ss values (all 10 channels: normal xyz, diffuse rgb, specular rgb, roughness)
    normal = normalize(cos θ * m_x - sin θ * m_y,  sin θ * m_x + cos θ * m_y,  max(m_z, 1e-4))
    diffuse, specular, roughness = clip(m, 0, 1)

The base normal is decoded as `code * 2 / 65535 - 1` and renormalised before the lookup. This is
`storage.views.transform_planes`, the very function that made the render's textures, so these maps line
up with the image pixel for pixel (svgen's tests hold the two together). Why a formula and not a stored copy:
stored aligned maps would double the store (about 170 KB more per 256² view) for values that are a pure
function of what is stored; `svgen export RENDERS OUT --format exr` writes them as files when files are wanted."""

#: the card's first words on xarray (issue 40): why svgen's helper, not plain ``xarray.open_zarr``. What it says of
#: the plain open, tests/test_open_data.py holds true of every store kind.
XARRAY_NOTE = (
    "To read it in xarray, use svgen's `storage.dataset.open_dataset(store)`: it gives float32 maps, `preset` and "
    "`category` string coordinates, one dask chunk per shard, and attributes that `to_netcdf` writes. Plain "
    "`xarray.open_zarr(store)` opens the store but falls short: the maps decode to float64 (xarray takes the "
    "decoded type from the Python type of `scale_factor`, and zarr attributes are JSON, whose numbers read back "
    "as 64-bit floats), and `to_netcdf` raises TypeError on the nested `svgen` and `config` attributes (netCDF "
    "attributes are flat); the names are there as the coordinates `preset_name`/`category_name`.")

_LIMITS = {
    "renders": [
        "Synthetic: procedural materials rendered with one BRDF model (GGX, Schlick Fresnel) and only direct light "
        "from a point flash; real photographs add noise, lens effects, interreflections and other BRDFs.",
        "Fixed flash intensity and camera distance (the paper's scale ambiguity): albedo and light are not "
        "separable beyond that convention.",
        "The paper's failure cases (its Section 6), reproduced by `svgen stress`: saturated glossy highlights, "
        "a highlight at the image edge, print-like patterns on a flat surface read as relief, very dark or very "
        "bright albedo, maps whose features do not correlate.",
        "Images are 8-bit sRGB-encoded low-dynamic-range values clipped to [0, 1]: highlights saturate.",
    ],
}
_LIMITS["variants"] = _LIMITS["blends"] = [
    "Procedural materials of 9 classes (paint, plastic, leather, metal, wood, fabric, stone, ceramic tiles, "
    "ground): they cover what the generators can express, not the world's materials.",
    "Maps are 16-bit codes of linear values: quantisation step 1.5e-5.",
]
_LIMITS["stress"] = ["Made to fail: these samples are for evaluation, not training (README 'Where the method fails')."]


def hf_feature(name: str, shape: list[int], dtype: str) -> dict:
    """One entry of ``dataset_info.features`` in Hugging Face's schema (what ``datasets.Features._to_yaml_list``
    writes): a scalar is a ``Value`` dtype, a vector a fixed-length ``list``, 2 to 5 axes an ``ArrayND``. The
    axes' names are in the card's table (the schema has no place for them).

    Args:
        name: the array's name.
        shape: the shape of one sample (without the sample axis).
        dtype: numpy dtype name (numpy's names are Hugging Face's ``Value`` dtypes).
    """
    if not shape:
        return {"name": name, "dtype": dtype}
    if len(shape) == 1:
        return {"name": name, "list": dtype, "length": int(shape[0])}
    if len(shape) > 5:
        raise ValueError(f"array {name!r}: {len(shape)} axes per sample; Hugging Face's arrays have 2 to 5")
    return {"name": name, "dtype": {f"array{len(shape)}_d": {"shape": [int(x) for x in shape], "dtype": dtype}}}


def _size_category(n: int) -> str:
    for bound, name in ((1_000, "n<1K"), (10_000, "1K<n<10K"), (100_000, "10K<n<100K"), (1_000_000, "100K<n<1M")):
        if n < bound:
            return name
    return "1M<n<10M"


def _command(kind: str, attrs: dict) -> tuple[str, str]:
    """(command line, params.yaml section name) that makes a store of this kind with these attributes."""
    if "import" in attrs:
        extra = " --as renders" if kind == "renders" else ""
        return f"svgen import SOURCE... OUT{extra} --params params.yaml", "import"
    inputs = " ".join(i.get("path", "?") for i in attrs.get("inputs", []))
    return {"variants": ("svgen sample OUT --params params.yaml", "sample"),
            "blends": ("svgen blend VARIANTS OUT --params params.yaml", "blend"),
            "stress": ("svgen stress OUT --params params.yaml", "stress"),
            "renders": (f"svgen render {inputs or 'INPUTS...'} OUT --params params.yaml", "render")}.get(
        kind, (f"(a {kind} store: no svgen command makes it)", kind))


#: keys a stage records in a store's ``config`` beside its params.yaml settings: the inputs' identities (``inputs``
#: of render, ``materials`` of import, ``from`` of sample, ``source_hash`` of blend) and the integrator render chose.
#: The card leaves them out of the params.yaml section; tests/test_open_data.py holds that what remains of every
#: stage's store is exactly the keys of its settings class (``pipeline.config.STAGE_CONFIGS``).
NOT_SETTINGS = frozenset({"inputs", "materials", "from", "source_hash", "integrator"})


def _section(config: dict) -> dict:
    """The keys of ``config`` that are settable in a params.yaml section (:data:`NOT_SETTINGS` are not)."""
    return {k: v for k, v in config.items() if k not in NOT_SETTINGS}


def _decode(a: dict) -> str:
    if "scale_factor" in a:
        return f"code * {a['scale_factor']:.10g} + {a.get('add_offset', 0.0):g}"
    if "transfer_function" in a:
        return f"{a['transfer_function']}: {a.get('decode', '')}"
    return "as stored"


def render_card(group) -> str:
    """The dataset card of an open store group (complete or being finalized)."""
    attrs = dict(group.attrs)
    meta = attrs.get("svgen", {})
    kind = meta.get("kind", "?")
    n = int(meta.get("n", 0))
    from .labels import LABELS, label_array

    arrays = []
    names = [*meta.get("arrays", {}), *(label_array(i) for i in LABELS if label_array(i) in group)]
    for name in sorted(names):
        arr = group[name]
        dims = list(arr.metadata.dimension_names or [])
        # Hugging Face's (and Arrow's) name of a variable-length UTF-8 string (storage.labels)
        dtype = "string" if arr.dtype.kind in "OTU" else str(arr.dtype)
        arrays.append((name, dims, list(arr.shape), dtype, dict(arr.attrs)))
    views = int(group["image"].shape[1]) if kind == "renders" and "image" in group else 1
    split = attrs.get("split")
    from huggingface_hub import DatasetCard, DatasetCardData

    card_data = DatasetCardData(
        license=DATA_LICENSE, pretty_name=f"svgen {kind}", task_categories=["image-to-image"],
        tags=["svbrdf", "material-capture", "inverse-rendering", "synthetic", "zarr"],
        size_categories=[_size_category(n * views)],
        dataset_info={
            "features": [hf_feature(a[0], a[2][1:], a[3]) for a in arrays],
            "splits": ([{"name": s, "num_examples": split["counts"][s] * views} for s in ("train", "test")]
                       if split else [{"name": "all", "num_examples": n * views}]),
        })
    cmd, section = _command(kind, attrs)
    config = attrs.get("config", {})
    seeds = {k: v for k, v in config.items() if "seed" in k and not isinstance(v, (dict, list))}
    versions = meta.get("versions", {})
    out = ["---", card_data.to_yaml().rstrip(), "---", "",
           f"# svgen {kind} store", "",
           f"A zarr v3 store written by svgen (`{versions.get('svgen', 'unknown')}`): "
           f"{_WHAT.get(kind, kind)}. {n} samples"
           + (f" x {views} views = {n * views} (image, maps) pairs" if kind == "renders" else "") + ".", "",
           "## What it contains", "",
           XARRAY_NOTE, "",
           "Every array has the sample axis first (`sample`, chunked along it) and named dimensions; integer codes "
           "decode by their `scale_factor`/`add_offset` (xarray applies them) or, for the sRGB-encoded images, by "
           "the transfer function named in their attributes.", "",
           "| array | dims | shape | dtype | decoded value | meaning |", "|---|---|---|---|---|---|"]
    for name, dims, shape, dtype, a in arrays:
        units = f" [{a['units']}]" if "units" in a else ""
        out.append(f"| `{name}` | {', '.join(dims)} | {tuple(shape)} | {dtype} | {_decode(a)} | "
                   f"{a.get('long_name', '')}{units} |")
    if kind == "blends" and "recipe" in attrs:  # storage.recipe (storage imports no pipeline: the text is here)
        src = (attrs.get("inputs") or [{}])[0]
        out += ["", f"**A recipe store: no maps are stored.** Each blend's maps are mixed on read from the variants "
                    f"store recorded as `{src.get('path', '?')}` (relative to this store's folder; config hash "
                    f"`{src.get('config_hash', '?')}`), from the blend's `parents`, `alpha` and `mask_seed` under the "
                    f"rule `{attrs.get('blend_rule', '')}` ({attrs['recipe'].get('mode')} mode). svgen's readers "
                    "and `storage.dataset.open_dataset` mix them; plain `xr.open_zarr` shows the recipe only. "
                    "Keep the variants store beside this one."]
    if kind == "renders" and "image" in group and "diffuse" not in group:  # format 6 (storage/renders_inputs.py)
        out += ["", "**No base maps are stored.** Each SVBRDF's base maps are sample `source` of the input store "
                    "`inputs[input]` (group attribute `inputs`: paths relative to this store's folder, with their "
                    "config hashes): " + ", ".join(f"`{d.get('path', '?')}` ({d.get('kind', '?')})"
                                                  for d in attrs.get("inputs", []))
                + ". svgen's readers and `storage.dataset.open_dataset` read them from there (a recipe blends store "
                  "mixes them from its variants store); plain `xr.open_zarr` shows the images and indices only. Keep "
                  "the input stores beside this one."]
    if kind == "renders" and "view" in group:
        va = dict(group["view"].attrs)
        out += ["", "View parameters (`view` array, last axis in this order):", "",
                "| field | unit | meaning |", "|---|---|---|"]
        for f in va.get("fields", []):
            out.append(f"| `{f}` | {va.get('field_units', {}).get(f, '')} | "
                       f"{va.get('field_long_names', {}).get(f, '')} |")
    for key in ("presets", "categories"):
        if attrs.get(key):
            out += ["", f"`{key}` (group attribute; index arrays point into it, their `*_name` arrays hold the "
                        "names): "
                        + ", ".join(f"`{p}`" for p in attrs[key]) + "."]
    if kind == "renders":
        scene = attrs.get("scene", {})
        out += ["", "## The scene", "", scene.get("description", json.dumps(scene, sort_keys=True)),
                "", f"Mitsuba variant: `{scene.get('mitsuba_variant', 'n/a')}`.", "",
                "## Pairing an image with its maps", "", PAIRING]
    out += ["", "## Splits", ""]
    if split:
        out += [f"{split['rule'].capitalize()}. Held out with fraction {split['holdout']} and seed {split['seed']} "
                f"(stream `{split['seed_stream']}`; what `svtrain` uses with `data.holdout={split['holdout']}` and "
                f"`data.split_seed={split['seed']}`): test materials " + ", ".join(f"`{t}`" for t in
                                                                             split["test_materials"])
                + f". Samples: {split['counts']['train']} train, {split['counts']['test']} test, "
                  f"{split['counts']['dropped']} dropped (views of a sample share its split)."]
    else:
        out += ["No split recorded: every sample is in one set (a building block of the pipeline, or fewer than two "
                "base materials)."]
    history = attrs.get("history")
    if history:  # recorded (svcore.history): what was typed, not a reconstruction
        made = ["The commands that wrote it (the store's CF `history` attribute; `OUT` is this store, other paths are "
                "relative to its directory, and options that change no byte, such as worker counts, storage options "
                "and the time, are not recorded):", "", "```", history, "```", "",
                f"The resolved `{section}:` section of `params.yaml` (`{cmd}` reproduces it; the whole "
                "configuration, with the inputs' identities, is the store's `config` attribute):"]
    else:  # a store written before history was recorded
        made = ["```", cmd, "```", "", f"with this `{section}:` section of `params.yaml` (the resolved "
                "configuration; the whole of it, with the inputs' identities, is the store's `config` attribute):"]
    out += ["", "## How it was made", "", *made, "", "```yaml",
            yaml.safe_dump({section: _section(config)}, sort_keys=False, width=120).rstrip(), "```", "",
            "Every sample is a pure function of (the stage's master seed, the sample index) and the code: the same "
            "command gives the same bytes with any number of workers. Seeds: "
            + (", ".join(f"`{k}` = {v}" for k, v in seeds.items()) or "none") + "."]
    if attrs.get("inputs"):
        out += ["", "Inputs (paths relative to this store's directory):", ""]
        out += [f"- `{i.get('path')}`: {i.get('kind')}, {i.get('n')} samples, config hash `{i.get('config_hash')}`"
                for i in attrs["inputs"]]
    out += ["", "Versions: " + ", ".join(f"{k} {v}" for k, v in sorted(versions.items())) + "."]
    if "svgen_code_of" in versions:  # stores before it named the commit (the package version) instead
        out += ["", "The svgen code is named by `svgen_code`, the sha256 of the source that module "
                    f"`{versions['svgen_code_of']}` can run (it and the project modules it imports): any checkout "
                    "of that code writes these bytes."]
    out += ["",
            "## Intended use", "",
            "Training and evaluating single-image SVBRDF capture networks (Deschaintre et al. 2018), and studying "
            "their failure cases. Not a catalogue of real materials: do not read measured reflectance into it.", "",
            "## Known limits", ""]
    out += [f"- {x}" for x in _LIMITS.get(kind, [])]
    out += ["", "## Licence", "",
            f"The data: CC BY 4.0 ({DATA_LICENSE}). The svgen code that made it: MIT (the repository's LICENSE). "
            "Imported materials keep their own licences (the `materials` attribute records their sources).", "",
            "## Citation", "", "The method this data follows:", "", "```bibtex", CITATION, "```", ""]
    return str(DatasetCard("\n".join(out)))
