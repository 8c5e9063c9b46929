"""`svgen export STORE OUT --format parquet`: a renders or variants store as parquet shards with `datasets` image
columns, and a dataset card (README.md) whose YAML header the Hugging Face hub reads.

What OUT holds::

    README.md                              the card: configs/data_files, features, splits, licence
    data/train-00000-of-00002.parquet ...  and test-* when the renders store records a held-out split

One row per view (renders) or per sample (variants). Image columns are `datasets`' encoding, a struct of ``bytes``
(a PNG file) and ``path`` (a name for it), and the schema carries `datasets`' features, so
``datasets.load_dataset("parquet", data_files=...)`` (or ``load_dataset(OUT)``, through the card) gives ``Image``
columns:

* ``image`` (renders): the render's 8-bit sRGB codes as stored, an 8-bit RGB PNG: lossless.
* ``normal``, ``diffuse``, ``specular``, ``roughness``: 16-bit PNGs in the store's encoding (normal (n + 1) / 2,
  the others linear, no transfer function; roughness grey): 8 bits would band linear albedo in dark colours
  (storage/svbrdf_store.py). A variants store's codes are written as stored (lossless); a view's maps are the base
  maps under the view's transform (:meth:`~storage.renders_store.RendersReader.maps`, aligned with the image pixel
  for pixel), quantised to 16 bits like the store's.

Pillow, which `datasets` decodes images with, reads a 16-bit colour PNG as 8 bits (the card says so and how to read
all 16). Shards close at :data:`MAX_SHARD_BYTES` (`datasets`' ``max_shard_size`` for the hub), row groups at
:data:`ROW_GROUP_BYTES`; image leaves are written as `datasets` 4 writes them (PLAIN, uncompressed: PNG is
compressed already; content-defined pages), so ``svgen import`` streams them back one row at a time.
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterator

import numpy as np

from materials.maps import MAP_NAMES

from svcore.errors import StoreError
from svcore.image_io import png_bytes
from svcore.progress import progress

#: `datasets`' default max_shard_size for the hub (500 MB)
MAX_SHARD_BYTES = 500 << 20
#: rows are buffered and written as one row group up to this many bytes (the writer's memory)
ROW_GROUP_BYTES = 64 << 20
#: decoded store chunks a reader keeps (rows are read in order: a chunk or two is all it needs)
READ_CACHE_BYTES = 256 << 20
#: what each map column holds (the card's table)
MAP_DOC = {"normal": "16-bit RGB PNG: (n + 1) / 2 of the unit normal, tangent space, x right, y up (OpenGL)",
           "diffuse": "16-bit RGB PNG: linear diffuse albedo (no transfer function)",
           "specular": "16-bit RGB PNG: linear specular albedo F0 (no transfer function)",
           "roughness": "16-bit grey PNG: perceptual roughness r (GGX alpha = r^2)"}


@dataclass(frozen=True)
class Column:
    """One column: name, `datasets` feature (the card's ``dtype``), Arrow type, and what it holds."""

    name: str
    dtype: str  # "image", or a datasets Value dtype ("string", "int64", "float64" ...)
    doc: str

    def arrow(self):
        import pyarrow as pa

        if self.dtype == "image":
            return pa.struct([("bytes", pa.binary()), ("path", pa.string())])
        return pa.string() if self.dtype == "string" else pa.from_numpy_dtype(np.dtype(self.dtype))

    def feature(self) -> dict:
        """The column in the schema metadata's `datasets` features."""
        return {"_type": "Image"} if self.dtype == "image" else {"dtype": self.dtype, "_type": "Value"}


@dataclass
class Source:
    """What a store exports: its columns, the rows of each split (indices in :attr:`row`'s numbering) and the row
    function."""

    kind: str
    columns: list[Column]
    splits: dict[str, list[int]]
    row: Callable[[int], dict]
    attrs: dict


def _image(a: np.ndarray, path: str) -> dict:
    return {"bytes": png_bytes(a), "path": path}


def _renders(store) -> Source:
    """The views of a renders store: image, aligned maps, material, view parameters."""
    from storage.svbrdf_store import encode_maps
    from svcore.split import split_indices

    from storage.renders_store import RendersReader
    from storage.views import VIEW_FIELDS, VIEW_LONG_NAMES, VIEW_UNITS

    reader = RendersReader(store)
    reader.set_cache_bytes(max(reader.min_cache_bytes(), READ_CACHE_BYTES))
    presets, cats = reader.presets_of_svbrdf(), reader.categories_of_views()
    split = reader.stored_split()
    if split:  # the held-out split the store records (svcore.split.RULE), per SVBRDF: its views share it
        train, test = split_indices(presets, split["test_materials"])
        per = {"train": train, "test": test}
    else:
        per = {"train": np.arange(reader.n_svbrdf)}
    splits = {k: [int(s) * reader.views + v for s in idx for v in range(reader.views)] for k, idx in per.items()}
    views = [Column(f, "int64" if f == "seed" else "float64", f"{VIEW_LONG_NAMES[f]} [{VIEW_UNITS[f]}]")
             for f in VIEW_FIELDS]
    columns = [Column("image", "image", "8-bit RGB PNG: the flash photograph, sRGB-encoded (IEC 61966-2-1), as "
                                        "stored"),
               *(Column(k, "image", MAP_DOC[k] + "; the view's maps, aligned with the image") for k in MAP_NAMES),
               Column("material", "string", "base material(s) of the SVBRDF, ' + ' between a blend's two"),
               Column("category", "string", "stress category (empty outside stress sets)"),
               Column("svbrdf", "int64", "index of the SVBRDF in the store"),
               Column("view", "int64", "index of the view among the SVBRDF's views"), *views]

    def row(i: int) -> dict:
        s, v = divmod(i, reader.views)
        img = reader.image_codes(s)[v]
        p = reader.view_params(i)
        codes = encode_maps(reader.maps(i))
        return {"image": _image(img, f"{i:07d}/image.png"),
                **{k: _image(codes[k], f"{i:07d}/{k}.png") for k in MAP_NAMES},
                "material": " + ".join(presets[s]), "category": cats[i] or "", "svbrdf": s, "view": v,
                **{f: (int(p.seed) if f == "seed" else float(getattr(p, f))) for f in VIEW_FIELDS}}

    return Source("renders", columns, splits, row, reader.attrs)


def _variants(store) -> Source:
    """The samples of a variants store: its maps' codes as stored, material, seed (and licence when imported)."""
    from storage.svbrdf_store import SVBRDFStore

    st = SVBRDFStore(store, "variants", cache_bytes=READ_CACHE_BYTES)
    imported = {m["preset"]: m for m in st.attrs.get("materials", [])}  # an `svgen import` store
    columns = [*(Column(k, "image", MAP_DOC[k] + "; the stored codes") for k in MAP_NAMES),
               Column("material", "string", "base material (category/name)"),
               Column("seed", "uint64", "the sample's seed (imported: crc32 of the material name)")]
    if imported:
        columns.append(Column("licence", "string", "the imported material's own licence, as its source states it"))
    table, seeds = st.preset_table(), st.group["seed"][:]  # (N, 2) and (N,): small, read once

    def row(i: int) -> dict:
        codes = st.codes(i)
        name = st.presets[int(table[i, 0])] if table[i, 0] >= 0 else ""
        out = {**{k: _image(codes[k], f"{i:07d}/{k}.png") for k in MAP_NAMES}, "material": name,
               "seed": int(seeds[i])}
        if imported:
            out["licence"] = str(imported.get(name, {}).get("licence") or "")
        return out

    return Source("variants", columns, {"train": list(range(len(st)))}, row, st.attrs)


def source(store) -> Source:
    """The export of a renders or variants store.

    Raises:
        StoreError: missing, incomplete, or another kind.
    """
    from storage.store import open_store

    kind = open_store(store, ("renders", "variants")).attrs["svgen"]["kind"]
    return _renders(store) if kind == "renders" else _variants(store)


def schema(src: Source):
    """The Arrow schema, with `datasets`' features in its metadata (what load_dataset reads image columns by)."""
    import pyarrow as pa

    features = {c.name: c.feature() for c in src.columns}
    return pa.schema([pa.field(c.name, c.arrow()) for c in src.columns],
                     metadata={"huggingface": json.dumps({"info": {"features": features}})})


def _writer_options(src: Source) -> dict:
    """`datasets` 4's choices: image leaves PLAIN and uncompressed, others snappy with dictionaries; a page index;
    content-defined pages (each map in pages of its own where it is large)."""
    leaves = [f"{c.name}.{f}" for c in src.columns if c.dtype == "image" for f in ("bytes", "path")]
    others = [c.name for c in src.columns if c.dtype != "image"]
    return {"compression": {**{k: "snappy" for k in others}, **{k: "none" for k in leaves}},
            "use_dictionary": others, "column_encoding": {k: "PLAIN" for k in leaves},
            "use_content_defined_chunking": True, "write_page_index": True}


class _Shards:
    """Rows -> ``data/{split}-NNNNN.parquet`` files: a row group each ``group_bytes`` of images, a new file after
    ``shard_bytes`` (named ``{split}-NNNNN-of-NNNNN.parquet`` when all are written)."""

    def __init__(self, out: Path, split: str, src: Source, shard_bytes: int, group_bytes: int):
        self.out, self.split, self.shard_bytes, self.group_bytes = out / "data", split, shard_bytes, group_bytes
        self.schema, self.opts = schema(src), _writer_options(src)
        self.files: list[Path] = []
        self.rows: list[dict] = []
        self.buffered = self.written = 0
        self.writer = None

    def add(self, row: dict) -> None:
        self.rows.append(row)
        self.buffered += sum(len(v["bytes"]) for v in row.values() if isinstance(v, dict))
        if self.buffered >= self.group_bytes:
            self._flush()

    def _flush(self) -> None:
        import pyarrow as pa
        import pyarrow.parquet as pq

        if not self.rows:
            return
        if self.writer is None:
            self.files.append(self.out / f"{self.split}-{len(self.files):05d}.parquet")
            self.writer = pq.ParquetWriter(self.files[-1], self.schema, **self.opts)
        self.writer.write_table(pa.Table.from_pylist(self.rows, schema=self.schema))
        self.written += self.buffered
        self.rows, self.buffered = [], 0
        if self.written >= self.shard_bytes:
            self.writer.close()
            self.writer, self.written = None, 0

    def close(self) -> list[str]:
        """Write what is buffered, close, name the shards ``{split}-{k}-of-{n}``; returns their names."""
        self._flush()
        if self.writer is not None:
            self.writer.close()
        names = []
        for k, f in enumerate(self.files):
            names.append(f"{self.split}-{k:05d}-of-{len(self.files):05d}.parquet")
            os.replace(f, f.with_name(names[-1]))
        return names


def _rows_of(src: Source, limit: int | None) -> Iterator[tuple[str, int]]:
    """(split, row index) in export order (splits in order, rows ascending), the first ``limit``."""
    n = 0
    for split, rows in src.splits.items():
        for i in rows:
            if limit is not None and n >= limit:
                return
            yield split, i
            n += 1


def write_parquet(store, out: Path, limit: int | None = None, shard_bytes: int = MAX_SHARD_BYTES,
                  group_bytes: int = ROW_GROUP_BYTES) -> int:
    """Write the store's rows (the first ``limit``) as parquet shards and a dataset card into the empty folder
    ``out``: row groups of about ``group_bytes`` of images, shards of about ``shard_bytes``. Returns the rows
    written.

    Raises:
        StoreError: not a complete renders or variants store; nothing to write.
    """
    src = source(store)
    order = list(_rows_of(src, limit))
    if not order:
        raise StoreError(f"{store}: no rows to export")
    (out / "data").mkdir()
    shards: dict[str, _Shards] = {}
    with progress(len(order), "export parquet", unit="row") as bar:
        for split, i in order:
            if split not in shards:
                shards[split] = _Shards(out, split, src, shard_bytes, group_bytes)
            shards[split].add(src.row(i))
            bar.update(1)
    counts = {s: sum(1 for sp, _ in order if sp == s) for s in shards}
    files = {s: w.close() for s, w in shards.items()}
    (out / "README.md").write_text(card(src, counts, files, out), encoding="utf-8")
    return len(order)


def card(src: Source, counts: dict[str, int], files: dict[str, list[str]], out: Path) -> str:
    """The dataset card: YAML header (licence, configs/data_files, features, splits) and what the columns hold."""
    from huggingface_hub import DatasetCard, DatasetCardData

    from storage.card import CITATION, DATA_LICENSE, _size_category

    imported = any(c.name == "licence" for c in src.columns)
    meta = src.attrs.get("svgen", {})
    data = DatasetCardData(
        license="other" if imported else DATA_LICENSE, pretty_name=f"svgen {src.kind} (parquet)",
        task_categories=["image-to-image"], tags=["svbrdf", "material-capture", "inverse-rendering", "synthetic"],
        size_categories=[_size_category(sum(counts.values()))],
        configs=[{"config_name": "default",
                  "data_files": [{"split": s, "path": f"data/{s}-*"} for s in counts]}],
        dataset_info={"features": [{"name": c.name, "dtype": c.dtype} for c in src.columns],
                      "splits": [{"name": s, "num_bytes": sum((out / "data" / f).stat().st_size for f in files[s]),
                                  "num_examples": n} for s, n in counts.items()]})
    rows = "view" if src.kind == "renders" else "sample"
    out = ["---", data.to_yaml().rstrip(), "---", "", f"# svgen {src.kind}, as parquet", "",
           f"{sum(counts.values())} rows, one per {rows}, exported by `svgen export STORE OUT --format parquet` from "
           f"an svgen {src.kind} store (config hash `{meta.get('config_hash', '?')}`, "
           f"svgen `{meta.get('versions', {}).get('svgen', 'unknown')}`). Files: "
           + "; ".join(f"{s}: " + ", ".join(f"`data/{f}`" for f in fs) for s, fs in files.items()) + ".", "",
           "| column | feature | holds |", "|---|---|---|"]
    out += [f"| `{c.name}` | {c.dtype} | {c.doc} |" for c in src.columns]
    out += ["", "## Reading it", "", "```python", "from datasets import load_dataset", "",
            'ds = load_dataset("parquet", data_files={'
            + ", ".join(f'"{s}": "data/{s}-*.parquet"' for s in counts) + "})", "```", "",
            "The map columns are 16-bit PNGs. Pillow, which `datasets` decodes images with, reads a 16-bit RGB PNG "
            "as 8 bits per channel (a 16-bit grey one keeps its 16 bits, mode `I;16`). For all 16 bits, cast the "
            "column to `datasets.Image(decode=False)` and decode its `bytes` with a reader that keeps them "
            "(pypng, imageio, OpenCV's `IMREAD_UNCHANGED`); values are `code / 65535` (normals: `code * 2 / 65535 "
            "- 1`, then renormalise)."]
    if src.kind == "renders":
        split = src.attrs.get("split")
        out += ["", "## Splits", "", (f"{split['rule'].capitalize()}; held-out materials: "
                                      + ", ".join(f"`{t}`" for t in split["test_materials"]) + ".") if split else
                "One split, `train`: the store records no held-out split."]
    out += ["", "## Licence", "",
            ("Each row's `licence` column is the imported material's own licence, as its source states it; "
             f"svgen's processing adds no restriction (its generated data is {DATA_LICENSE})." if imported else
             f"The data: CC BY 4.0 ({DATA_LICENSE}). The svgen code that made it: MIT."),
            "", "## Citation", "", "The method this data follows:", "", "```bibtex", CITATION, "```", ""]
    return str(DatasetCard("\n".join(out)))
