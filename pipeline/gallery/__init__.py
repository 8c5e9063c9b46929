"""`svgen gallery`: a static HTML page of the SVBRDFs of one or more stores, for people to look at.

Per store (variants, blends, stress, renders; imported stores are variants or renders stores) a section of cards;
a card holds the SVBRDF's four maps as thumbnails, for a renders store its first views, and what made it: preset
and parameters, both parents of a blend, the stress category, or the source material of an imported store.
``--reference`` stores go in a column of their own beside the others.

Thumbnails are small PNGs under ``DIR/thumbs/`` (the page links them relatively, so the folder works offline and
can be moved whole). Display encodings: normals (n + 1) / 2, diffuse and specular sRGB-encoded from linear
(colour-science, :func:`svcore.image_io.srgb_encode`), roughness as grey, views sRGB-encoded; each is
downsampled in its linear values first (area average), then encoded.

A store larger than ``max_n`` is shown as a sample of ``max_n`` SVBRDFs drawn with the stated seed (stream
``gallery.sample`` of :mod:`svcore.seeds`); the indices are on the page and in ``gallery.json``. The store is read
in blocks of at most :data:`BLOCK_BYTES`, so memory does not grow with the store: a block spans shown samples
that follow each other, or lie less than :data:`GAP_BYTES` of samples apart (reading a few unshown small samples
costs less than another read call; at 256² no gap is bridged).
"""
from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import numpy as np

from materials.maps import MAP_NAMES, N_CHANNELS, encode_normal

from svcore.errors import StoreError
from svcore.image_io import srgb_encode, write_png
from svcore.progress import progress
from svcore.seeds import stream_rng

from .page import MAP_ORDER, PER_ROW, Card, Layout, Section, page
from storage.recipe import is_recipe
from storage.renders_store import RendersReader
from storage.store import is_object_url, open_store, read_region, refuse_inside
from storage.svbrdf_store import SVBRDFStore

KINDS = ("variants", "blends", "stress", "renders")
#: raw bytes of one read block at most (on-disk dtypes; decoded float maps of one sample exist at a time)
BLOCK_BYTES = 64 << 20
#: unshown samples a block may read between two shown ones, in raw bytes at most
GAP_BYTES = 1 << 20
#: the file that marks a folder as a gallery svgen wrote (what --force may replace)
MARKER = "gallery.json"
#: the file that marks a partial folder as this command's (what a rerun may delete)
PARTIAL_MARKER = ".svgen-gallery-partial"


def pick(n: int, max_n: int, seed: int) -> tuple[list[int], bool]:
    """The SVBRDFs shown of a store of ``n``: all when ``n <= max_n``, else ``max_n`` drawn without replacement.

    Returns:
        (ascending indices, whether they are a sample).
    """
    if n <= max_n:
        return list(range(n)), False
    idx = stream_rng(seed, "gallery.sample").choice(n, size=max_n, replace=False)
    return sorted(int(i) for i in idx), True


def blocks(indices: list[int], per_block: int, max_gap: int = 0):
    """Runs of ascending indices to read at once: each spans at most ``per_block`` samples (first to last), and
    skips at most ``max_gap`` unshown samples between two of its indices."""
    run: list[int] = []
    for i in indices:
        if run and (i - run[-1] - 1 > max_gap or i - run[0] >= per_block):
            yield run
            run = []
        run.append(i)
    if run:
        yield run


def shrink(a: np.ndarray, size: int) -> np.ndarray:
    """Area-average (H, W, C) float values to (size, size, C) (Pillow's box filter on float channels)."""
    from PIL import Image

    if a.shape[0] == size and a.shape[1] == size:
        return a.astype(np.float32)
    chans = [np.asarray(Image.fromarray(np.ascontiguousarray(a[..., c], np.float32), mode="F")
                        .resize((size, size), Image.Resampling.BOX)) for c in range(a.shape[-1])]
    return np.stack(chans, -1)


def display(name: str, a: np.ndarray, size: int) -> np.ndarray:
    """A map (or a linear view with ``name`` "view") as the thumbnail's display values in [0, 1]."""
    if name == "normal":
        return shrink(encode_normal(a), size)
    small = shrink(a, size)
    return small if name == "roughness" else srgb_encode(small)


def _fmt(v: float) -> str:
    return f"{v:.3g}"


def _param_text(keys: list[str], values) -> str | None:
    """``name=value, ...`` of a preset's parameters (NaN padding dropped); None when there are none."""
    vals = np.asarray(values, np.float64)[:len(keys)]
    return ", ".join(f"{k}={_fmt(v)}" for k, v in zip(keys, vals) if np.isfinite(v)) or None


class _Source:
    """Reads the shown SVBRDFs of one store in blocks and says what each is."""

    def __init__(self, path, views: int):
        self.path = path
        self.group = open_store(path, KINDS)
        self.attrs = dict(self.group.attrs)
        self.kind = self.attrs["svgen"]["kind"]
        # a recipe blends store (storage.recipe) holds no maps: its reader mixes them from the variants store
        # as does a renders store without maps (format version 6): its reader reads them from its input stores
        self.mixer = SVBRDFStore(path, "blends") if is_recipe(self.attrs) else (
            RendersReader(path, cache_bytes=0) if self.kind == "renders" and "diffuse" not in self.group else None)
        self.n = len(self.mixer) if is_recipe(self.attrs) else int(self.group["image" if self.kind == "renders"
                                                                            else "diffuse"].shape[0])
        self.presets = list(self.attrs.get("presets", []))
        self.param_names = self.attrs.get("param_names", {})
        self.materials = {r.get("preset", r.get("name")): r for r in self.attrs.get("materials", [])}
        self.views = min(views, int(self.group["image"].shape[1])) if self.kind == "renders" else 0
        arrays = ([] if self.mixer else list(MAP_NAMES)) + (["image"] if self.views else [])  # every view is read
        self.sample_bytes = sum(int(np.prod(self.group[k].shape[1:])) * self.group[k].dtype.itemsize for k in arrays)
        if self.mixer:  # the mixed (or input) maps' codes, held like read ones
            self.sample_bytes += self._map_size() ** 2 * N_CHANNELS * 2
        self._inputs: dict[int, object] = {}

    def read(self, run: list[int]) -> dict[str, np.ndarray]:
        """Raw arrays of samples ``run[0]`` .. ``run[-1]``: maps, images, and the per-sample facts."""
        a, b = run[0], run[-1] + 1
        names = ([] if self.mixer else list(MAP_NAMES)) + [
            k for k in ("preset", "params", "seed", "alpha", "parents", "category", "source", "source_seed", "input")
            if k in self.group]
        d = {k: read_region(self.group, k, a, b) for k in names}
        if self.mixer:  # only the shown blends are mixed (the block's rows between them stay zero: never shown)
            for i in run:
                codes = self.mixer.base_codes(i) if self.kind == "renders" else self.mixer.codes(i)
                for k, v in codes.items():
                    d.setdefault(k, np.zeros((b - a, *v.shape), v.dtype))[i - a] = v
        if self.views:
            d["image"] = read_region(self.group, "image", a, b)[:, :self.views]
        return d

    def _map_size(self) -> int:
        return self.mixer.base_res if self.kind == "renders" else self.mixer.size

    def _names(self, row) -> list[str]:
        return [self.presets[p] for p in row if p >= 0]

    def _material_lines(self, name: str) -> list[str]:
        rec = self.materials.get(name)
        if not rec:
            return []
        out = [f"source: {rec.get('source_relative') or rec.get('source')}"]
        if rec.get("licence"):
            out.append(f"licence: {rec['licence']}")
        return out

    def _input_params(self, d: dict, j: int) -> str | None:
        """A renders store's SVBRDF's parameters, from its input store when that is a local store still there."""
        k = int(d["input"][j])
        if k not in self._inputs:
            self._inputs[k] = None
            rec = self.attrs.get("inputs", [])[k] if k < len(self.attrs.get("inputs", [])) else {}
            if rec.get("kind") == "variants" and not is_object_url(self.path):
                try:
                    self._inputs[k] = SVBRDFStore(Path(self.path).parent / rec["path"], "variants")
                except StoreError:
                    pass  # moved or deleted: the card says what the renders store knows
        st = self._inputs[k]
        if st is None or "params" not in st.group:
            return None
        i = int(d["source"][j])
        names = self._names(d["preset"][j])
        row = read_region(st.group, "params", i, i + 1)[0]
        return _param_text(st.attrs.get("param_names", {}).get(names[0], []) if names else [], row)

    def describe(self, d: dict, j: int) -> tuple[str, list[str], list[str]]:
        """(title, classes, lines) of the sample in row ``j`` of block ``d``."""
        names = self._names(d["preset"][j])
        classes = sorted({n.split("/")[0] for n in names})
        lines: list[str] = []
        if self.kind == "stress":
            cat = self.attrs["categories"][int(d["category"][j])]
            return f"stress: {cat}", [f"stress:{cat}"], [f"seed {int(d['seed'][j])}"]
        if self.kind == "blends":
            lines.append(f"blend of #{int(d['parents'][j][0])} and #{int(d['parents'][j][1])}, "
                         f"weight of the first {_fmt(float(d['alpha'][j]))}")
        for n in names:
            lines += self._material_lines(n)
        if self.kind == "variants" and "params" in d and names:
            p = _param_text(self.param_names.get(names[0]) or [], d["params"][j])
            if p:
                lines.append(p)
        if self.kind == "renders":
            cat = int(d["category"][j])
            if cat >= 0:
                classes.append(f"stress:{self.attrs['categories'][cat]}")
            rec = self.attrs.get("inputs", [])[int(d["input"][j])]
            lines.append(f"input: {rec['kind']} {rec['path']} #{int(d['source'][j])}")
            p = self._input_params(d, j)
            if p:
                lines.append(p)
            lines.append(f"seed {int(d['source_seed'][j])}")
        else:
            lines.append(f"seed {int(d['seed'][j])}")
        return (" + ".join(names) or "(no preset)"), classes or ["(none)"], lines


def _section(src: _Source, k: int, reference: bool, out: Path, max_n: int, seed: int, thumb: int) -> Section:
    """Read the shown SVBRDFs of store ``src`` and write their thumbnails under ``out/thumbs/s<k>``."""
    from storage.srgb8 import decode_srgb8
    from storage.svbrdf_store import decode_maps

    path = src.path
    indices, sampled = pick(src.n, max_n, seed)
    rel = Path("thumbs") / f"s{k}"
    (out / rel).mkdir(parents=True)
    cards = []
    per_block = max(1, BLOCK_BYTES // src.sample_bytes)
    max_gap = GAP_BYTES // src.sample_bytes
    with progress(len(indices), f"gallery {Path(str(path)).name}", unit="SVBRDF") as bar:
        for run in blocks(indices, per_block, max_gap):
            d = src.read(run)
            for i in run:
                j = i - run[0]  # row of sample i in the block
                m = decode_maps({name: d[name][j] for name in MAP_NAMES})
                maps = {}
                for name in MAP_ORDER:
                    f = rel / f"{i:07d}_{name}.png"
                    write_png(out / f, display(name, getattr(m, name), thumb))
                    maps[name] = f.as_posix()
                vs = []
                for v in range(src.views):
                    f = rel / f"{i:07d}_view{v}.png"
                    write_png(out / f, display("view", decode_srgb8(d["image"][j, v]), thumb))
                    vs.append(f.as_posix())
                title, classes, lines = src.describe(d, j)
                cards.append(Card(i, title, classes, lines, maps, vs))
                bar.update(1)
            del d
    return Section(str(path), src.kind, src.n, reference, indices, sampled, cards)


def _prepare_out(out: Path, inputs: list, force: bool) -> Path:
    """Check the output folder; returns the partial folder to write into (fresh)."""
    refuse_inside(out, inputs)
    if out.exists():
        if not force:
            raise StoreError(f"output {out} already exists; pass --force to replace it, or choose another path")
        if not (out / MARKER).is_file():
            raise StoreError(f"output {out} exists and is not a gallery (no {MARKER}); --force replaces only a "
                             "gallery svgen wrote: delete it yourself or choose another path")
    tmp = out.with_name(out.name + ".partial")
    if tmp.exists():
        if not (tmp / PARTIAL_MARKER).is_file():
            raise StoreError(f"{tmp} exists and is not an interrupted gallery; delete it or choose another --out")
        shutil.rmtree(tmp)  # an interrupted run of this command: start again
    tmp.mkdir(parents=True)
    (tmp / PARTIAL_MARKER).touch()
    return tmp


def gallery(stores: list, out, references: list | None = None, max_n: int = 200, seed: int = 0, views: int = 3,
            thumb: int = 64, force: bool = False) -> Path:
    """Write the gallery of ``stores`` (and ``references``) into the folder ``out``.

    Writes into ``<out>.partial`` and moves it into place when complete (a killed run never leaves a page that
    looks complete).

    Args:
        stores: procedural (or any) store paths/URLs, one section each.
        out: the folder to create (index.html, gallery.json, thumbs/).
        references: stores shown in the reference column.
        max_n: at most this many SVBRDFs per store (a seeded sample beyond).
        seed: the sample's seed.
        views: views per SVBRDF of a renders store (at most 4, one row).
        thumb: thumbnail side in px.
        force: replace an existing gallery at ``out``.

    Returns:
        the page's path.

    Raises:
        StoreError: a store that is missing, unfinished or of another kind; an existing output without ``force``.
    """
    from svcore.versions import svgen_version

    references = list(references or [])
    if not 1 <= views <= PER_ROW:
        raise StoreError(f"--views must be between 1 and {PER_ROW} (one row of thumbnails), got {views}")
    out = Path(out)
    # open every store before writing anything: an unfinished or empty store is refused with nothing written
    sources = [_Source(s, views) for s in list(stores) + references]
    for src in sources:
        if src.n == 0:
            raise StoreError(f"{src.path} holds no SVBRDFs")
    tmp = _prepare_out(out, list(stores) + references, force)
    sections = [_section(src, k, k >= len(stores), tmp, max_n, seed, thumb) for k, src in enumerate(sources)]
    layout = Layout(thumb=thumb)
    meta = {"svgen_version": svgen_version(), "seed": seed, "max": max_n, "views": views, "thumb": thumb,
            "sampling": "all SVBRDFs when a store holds at most max, else max indices drawn without replacement "
                        "by numpy's default_rng(svcore.seeds.stream_seed(seed, 'gallery.sample')).choice",
            "stores": [{"store": s.name, "kind": s.kind, "n": s.n, "reference": s.reference, "sampled": s.sampled,
                        "indices": s.indices} for s in sections]}
    (tmp / "index.html").write_text(page(sections, seed, max_n, layout, meta), encoding="utf-8")
    (tmp / MARKER).write_text(json.dumps(meta, indent=1, sort_keys=True) + "\n")
    (tmp / PARTIAL_MARKER).unlink()
    if out.exists():  # force, checked above: a gallery svgen wrote
        shutil.rmtree(out)
    os.replace(tmp, out)
    return out / "index.html"
