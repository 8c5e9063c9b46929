"""Export a store to files other tools read: the 2018 dataset layout, linear EXR, PNG previews, parquet.

Formats (a registry: name -> exporter of a store into an empty folder; the first three write a renders store's
views one by one through a writer of one view, :func:`per_view`):

* ``deschaintre``: one PNG per view, ``input | normal | diffuse | roughness | specular`` side by side, each
  res x res, 8-bit, maps linear and normals encoded (n + 1) / 2, roughness repeated over RGB -- the layout
  the original code (``material_net.py``) splits into 1 input + 4 targets -- and a JSON sidecar per view with
  the light and camera positions, texture scale (zoom), rotation and shift, and the source material.
* ``exr``: per view a folder of linear float EXR files (input, normal in [-1, 1], diffuse, roughness,
  specular) via OpenEXR, plus the same JSON sidecar.
* ``png``: per view a folder of previews for people: sRGB-encoded input, diffuse and specular
  (colour-science), encoded normal, roughness as grey.
* ``parquet``: a renders or variants store as parquet shards with `datasets` image columns and a dataset card
  (:mod:`pipeline.export_parquet`).
"""
from __future__ import annotations

import json
import os
import re
import shutil
from pathlib import Path
from typing import Callable

import numpy as np

from materials.maps import SVBRDF, encode_normal

from svcore.errors import StoreError
from svcore.outputs import FORCE_FLAG, holds_something, refuse_existing
from svcore.image_io import srgb_encode, write_exr, write_png
from svcore.progress import progress

from storage.store import refuse_inside

#: a writer of one view: (folder, view name, image, aligned maps, sidecar) -> files written
Writer = Callable[[Path, str, np.ndarray, SVBRDF, dict], list[Path]]
#: an exporter: (store, empty output folder, limit) -> rows (views, samples) written
Exporter = Callable[[object, Path, "int | None"], int]
FORMATS: dict[str, Exporter] = {}


def register_format(name: str):
    def deco(fn: Exporter) -> Exporter:
        FORMATS[name] = fn
        return fn

    return deco


def per_view(name: str):
    """Register a writer of one view as the format ``name``: every view of a renders store, in order."""

    def deco(write: Writer) -> Writer:
        def run(store, out: Path, limit: int | None) -> int:
            from storage.renders_store import RendersReader

            reader = RendersReader(store)
            n = len(reader) if limit is None else min(limit, len(reader))
            with progress(n, f"export {name}", unit="view") as bar:
                for i in range(n):
                    write(out, f"{i:07d}", reader.image(i), reader.maps(i), view_meta(reader, i))
                    bar.update(1)
            return n

        register_format(name)(run)
        return write

    return deco


def _rgb(a: np.ndarray) -> np.ndarray:
    return np.repeat(a, 3, axis=-1) if a.shape[-1] == 1 else a


def _sidecar(path: Path, meta: dict) -> Path:
    path.write_text(json.dumps(meta, indent=1, sort_keys=True))
    return path


@per_view("deschaintre")
def write_deschaintre(out: Path, name: str, image: np.ndarray, maps: SVBRDF, meta: dict) -> list[Path]:
    strip = np.concatenate([image, encode_normal(maps.normal), maps.diffuse, _rgb(maps.roughness), maps.specular],
                           axis=1)
    return [write_png(out / f"{name}.png", strip), _sidecar(out / f"{name}.json", meta)]


@per_view("exr")
def write_exr_set(out: Path, name: str, image: np.ndarray, maps: SVBRDF, meta: dict) -> list[Path]:
    d = out / name
    d.mkdir(exist_ok=True)
    files = [write_exr(d / "input.exr", image)]
    files += [write_exr(d / f"{k}.exr", _rgb(v)) for k, v in maps.as_dict().items()]
    return files + [_sidecar(d / "meta.json", meta)]


@per_view("png")
def write_previews(out: Path, name: str, image: np.ndarray, maps: SVBRDF, meta: dict) -> list[Path]:
    d = out / name
    d.mkdir(exist_ok=True)
    return [write_png(d / "input.png", srgb_encode(image)), write_png(d / "normal.png", encode_normal(maps.normal)),
            write_png(d / "diffuse.png", srgb_encode(maps.diffuse)),
            write_png(d / "roughness.png", _rgb(maps.roughness)),
            write_png(d / "specular.png", srgb_encode(maps.specular)), _sidecar(d / "meta.json", meta)]


def view_meta(reader, i: int) -> dict:
    """The JSON sidecar of view ``i``: light, camera, texture transform, source material."""
    from .render.scene import scene_constants

    v = reader.view_params(i)
    c = scene_constants()
    return {"view": int(i), "light": [float(v.light_x), float(v.light_y), float(c["camera_distance"])],
            "camera": [0.0, 0.0, float(c["camera_distance"])], "fov_deg": float(c["fov_deg"]),
            "scale": float(v.zoom), "rotation_rad": float(v.rotation), "shift": [float(v.shift_u), float(v.shift_v)],
            "seed": int(v.seed), "source": reader.source(i), "encoding": FORMAT_ENCODINGS}


FORMAT_ENCODINGS = {"input": "linear LDR [0,1]", "normal": "(n+1)/2 (deschaintre/png), n (exr)",
                    "diffuse": "linear (deschaintre/exr), sRGB (png)", "roughness": "perceptual r, alpha = r^2",
                    "specular": "linear F0 (deschaintre/exr), sRGB (png)"}


@register_format("parquet")
def write_parquet(store, out: Path, limit: int | None) -> int:
    from .export_parquet import write_parquet as write

    return write(store, out, limit)


#: what an export folder holds: per view ``0000012.png`` + ``0000012.json`` or a folder ``0000012``; or (parquet)
#: ``README.md`` and ``data/`` of shards ``train-00000-of-00002.parquet`` (``.parquet`` before their rename)
EXPORT_ENTRY = re.compile(r"\d{7}(\.png|\.json)?")
PARQUET_SHARD = re.compile(r"[A-Za-z0-9_]+-\d{5}(-of-\d{5})?\.parquet")


def is_export(path: Path) -> bool:
    """Whether ``path`` is a folder that holds nothing but what an export writes (what ``--force`` may replace)."""
    if not path.is_dir() or path.is_symlink():
        return False
    names = {p.name for p in path.iterdir()}
    if "data" in names:  # a parquet export: README.md (once written) and data/ of shards, nothing else
        data = path / "data"
        return names <= {"README.md", "data"} and data.is_dir() and not data.is_symlink() and \
            all(PARQUET_SHARD.fullmatch(p.name) and p.is_file() for p in data.iterdir())
    return all(EXPORT_ENTRY.fullmatch(n) for n in names)


def _check_out(out: Path, store, force: bool) -> None:
    """The output checks, before any work: not inside the store, and the one overwrite rule
    (:func:`svcore.outputs.refuse_existing`), ``--force`` replacing only an export."""
    refuse_inside(out, store)
    refuse_existing([out], force)
    if force and holds_something(out) and not is_export(out):
        raise StoreError(f"output {out} exists and is not an export (it holds files an export does not write); "
                         f"{FORCE_FLAG} replaces only an export: delete it yourself or choose another path")


def _fresh_partial(out: Path) -> Path:
    """The empty ``<out>.partial`` folder to write into (an interrupted export's is cleared)."""
    tmp = out.with_name(out.name + ".partial")
    if tmp.exists():
        if not is_export(tmp):
            raise StoreError(f"{tmp} exists and is not an interrupted export; delete it or choose another path")
        shutil.rmtree(tmp)  # an interrupted export: its views may be of another store or format
    tmp.mkdir(parents=True)
    return tmp


def export(store, out, fmt: str, limit: int | None = None, force: bool = False) -> int:
    """Write every view (or the first ``limit``) of a renders store (parquet: or every sample of a variants store)
    to ``out`` in format ``fmt``.

    Writes into ``<out>.partial`` and renames when complete, so a killed export never looks complete. An ``out``
    that holds files is refused unless ``force``, and then replaced only once the new export is complete, and only
    if it is an export (:func:`is_export`): ``--force`` never deletes a folder of other files.

    Returns:
        number of views (rows) written.

    Raises:
        StoreError: an unknown format; a store the format does not read; ``out`` inside the store, existing
            without ``force``, or not an export.
    """
    if fmt not in FORMATS:
        raise StoreError(f"unknown export format {fmt!r}; known: {', '.join(FORMATS)}")
    out = Path(out)
    _check_out(out, store, force)
    tmp = _fresh_partial(out)
    try:
        n = FORMATS[fmt](store, tmp, limit)
    except BaseException:
        if not any(tmp.iterdir()):  # refused before writing (not a store of the right kind): leave nothing behind
            tmp.rmdir()
        raise
    if holds_something(out):  # --force, checked above: the old export goes only now that the new one is whole
        shutil.rmtree(out)
    os.replace(tmp, out)  # rename(2) replaces an empty folder
    return n
