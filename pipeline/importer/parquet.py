"""Parquet shards with `datasets` image columns (MatSynth's, as published on the Hugging Face hub) -> materials.

MatSynth's dataset card (gvecchio/MatSynth): one material per row; ``name`` (string), ``category`` (a class label:
ceramic, concrete, fabric, ground, leather, marble, metal, misc, plaster, plastic, stone, terracotta, wood), a
``metadata`` struct (``license``, ``authors``, ``source``, ``link``, ``physical_size`` float32, ``stationary``
bool, ...), and image columns (``basecolor``, ``diffuse``, ``displacement``, ``height``, ``metallic``, ``normal``,
``opacity``, ``roughness``, ``specular``, ``blend_mask``) in the `datasets` image encoding, a struct of ``bytes``
(the encoded file) and ``path``. Any parquet with image columns of these names reads the same way.

Which columns make the maps (:data:`ROLE_COLUMNS`): the metallic workflow, ``basecolor`` + ``metallic``, as the folder
importer converts it (:func:`.convert.convert`, the same code on in-memory blobs): MatSynth's ``diffuse`` and
``specular`` are derived from those two and are not read (a parquet without a ``metallic`` column but with a
``specular`` one is a specular workflow, as a folder would be). ``roughness``, ``normal`` and ``height`` are read;
normals come from ``height`` only in rows without ``normal``. A row needs :data:`REQUIRED` maps, else it is skipped.

Reading, and why memory is one row:

* plan (:func:`find`): the small columns (``name``, ``category``, ``metadata``) through pyarrow's dataset reader;
  no image byte is read. Then (:func:`check`) one pass over the rows that remain reads each row's maps, checks
  their headers (and every PNG chunk's CRC) and the folder importer's preflight, and lets the row go: rows with a
  missing map, a bad image or bad metadata are skipped, one line each.
* convert (:func:`convert_rows`): each chunk task streams its rows again and converts one at a time.

Rows are streamed with ``pyarrow.parquet.ParquetFile.iter_batches(batch_size=1)`` over a buffered input stream,
not with the dataset scanner: measured with pyarrow 26, the scanner (``Fragment.to_batches(batch_size=1)``, with
``use_buffered_stream`` and no pre-buffering) holds a whole row group at a time, 32 MB for a row group of 80
rows x 2 maps of 200 KB, against 3 MB for ``iter_batches``. A row is read page by page where a data page holds
about one value, as in files written by `datasets` 4 and later (image columns PLAIN-encoded, uncompressed,
content-defined pages); a dictionary-encoded image column (pyarrow's default writer settings) holds its whole
column chunk in its dictionary page, and there a row group is the unit of memory. A task reads from the start of
the first row group that holds one of its rows (parquet has no row-level seek in pyarrow), so a row group of R
rows is read about R / (2 * chunk) times in all: I/O, not decoding.
"""
from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Iterator

from . import ImportInputError
from .discover import MaterialSource, walk
from .readers import Blob, verify

#: map role -> the image column that fills it (the folder importer's role names; aliases.ROLES)
ROLE_COLUMNS = {"basecolor": "basecolor", "normal": "normal", "roughness": "roughness", "glossiness": "glossiness",
                "metallic": "metallic", "specular": "specular", "height": "height"}
#: image columns read for no role, and why (listed per material as ``ignored``)
NOT_READ = {"diffuse": "derived from basecolor and metallic (metallic workflow)",
            "specular": "derived from basecolor and metallic (metallic workflow)",
            "displacement": "height is used", "opacity": "not used by this BRDF model",
            "blend_mask": "not used by this BRDF model"}
#: what a row must have: every group holds at least one role (else: skipped as a missing map)
REQUIRED = (("basecolor",), ("roughness", "glossiness"), ("normal", "height"))
#: physical_size unit -> centimetres
UNIT_CM = {"m": 100.0, "cm": 1.0, "mm": 0.1}
#: bytes of the buffered input stream a row's pages are read through
BUFFER = 1 << 20
LAYOUT = "matsynth"


@dataclass
class ParquetMaterial(MaterialSource):
    """One row of a shard (``root`` is the shard). ``files`` is empty until the row is read (:func:`stream`), then
    holds a :class:`~.readers.Blob` per role.

    Attributes:
        row: the row's index in its shard.
        columns: role -> image column.
        nbytes: role -> bytes of the encoded image (known once the row was read).
    """

    row: int = 0
    columns: dict[str, str] = field(default_factory=dict)
    nbytes: dict[str, int] = field(default_factory=dict)


@dataclass(frozen=True)
class Skipped:
    """A row left out, and why (one line of the import's report)."""

    shard: str
    row: int
    name: str
    reason: str

    def line(self) -> str:
        return f"skipped {self.shard} row {self.row} ({self.name}): {self.reason}"

    def as_dict(self) -> dict:
        return {"shard": self.shard, "row": self.row, "name": self.name, "reason": self.reason}


def find_shards(sources: list[Path], split: str = "") -> list[Path]:
    """Every ``.parquet`` file of the sources (files, or folders searched recursively), sorted, of ``split`` only
    when given: a shard is of split S when its name starts with ``S-``, ``S_`` or ``S.`` (the hub's
    ``train-00000-of-00008.parquet``) or one of its folders under the source is named S.

    Raises:
        ImportInputError: a missing source, one without parquet files, none of the split.
    """
    found: list[tuple[Path, Path]] = []
    for src in sources:
        if not src.exists():
            raise ImportInputError(f"source {src} does not exist")
        files = [src] if src.is_file() else [d / n for d, names in walk(src) for n in names]
        shards = [(src, f) for f in files if f.suffix.lower() == ".parquet"]
        if not shards:
            raise ImportInputError(f"no .parquet files under {src} (the matsynth layout reads parquet shards)")
        found += shards
    if split:
        pick = re.compile(rf"^{re.escape(split)}[-_.]")
        found = [(s, f) for s, f in found if pick.match(f.name)
                 or (s.is_dir() and split in f.relative_to(s).parent.parts)]
        if not found:
            raise ImportInputError(f"no shard of split {split!r} under {', '.join(map(str, sources))} (looked for "
                                   f"{split}-*.parquet or a folder named {split})")
    return sorted({f for _, f in found}, key=str)


def _class_names(schema) -> list[str] | None:
    """The names of the ``category`` class label, from the `datasets` features stored in the schema metadata."""
    raw = (schema.metadata or {}).get(b"huggingface")
    try:
        feat = json.loads(raw)["info"]["features"]["category"] if raw else None
    except (ValueError, KeyError, TypeError):
        return None
    names = feat.get("names") if isinstance(feat, dict) else None
    return [str(n) for n in names] if isinstance(names, list) else None


def _is_image(t) -> bool:
    import pyarrow as pa

    if pa.types.is_struct(t):  # the `datasets` image encoding: {bytes, path}
        i = t.get_field_index("bytes")
        t = t.field(i).type if i >= 0 else None
    return t is not None and (pa.types.is_binary(t) or pa.types.is_large_binary(t))


def role_columns(schema) -> tuple[dict[str, str], dict[str, str]]:
    """(role -> image column read, image column not read -> why) of a shard's schema.

    Raises:
        ImportInputError: no colour column (basecolor, or diffuse as its stand-in).
    """
    images = [f.name for f in schema if _is_image(f.type)]
    roles = {r: c for r, c in ROLE_COLUMNS.items() if c in images}
    if "metallic" in roles:
        roles.pop("specular", None)  # MatSynth's specular is derived from basecolor and metallic
    if "basecolor" not in roles and "diffuse" in images:
        roles["basecolor"] = "diffuse"  # a specular workflow's colour map (as a folder's diffuse file)
    if "basecolor" not in roles:
        raise ImportInputError("no basecolor (or diffuse) image column; image columns: " + (", ".join(images) or "none"))
    used = set(roles.values())
    ignored = {c: NOT_READ.get(c, "not a map role") for c in images if c not in used}
    return roles, ignored


def _physical_cm(value, unit: str, capture_cm: float | None) -> float | None:
    """A row's tile width in cm, when capture_cm needs it; None: not stated.

    Raises:
        ValueError: a stated size that is not a positive number (the row is skipped).
    """
    if capture_cm is None or value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        raise ValueError(f"metadata.physical_size {value!r} is not a positive number")
    return float(value) * UNIT_CM[unit]


def _meta(row: dict, names: list[str] | None, cfg) -> dict:
    """The material's meta (as :func:`.discover.sidecar` gives a folder's): licence, category, physical size,
    stationarity, and MatSynth's own name, licence, authors, source and link under ``metadata``.

    Raises:
        ValueError: a bad physical size (only checked when ``capture_cm`` uses it).
    """
    md = row.get("metadata") or {}
    cat = row.get("category")
    if isinstance(cat, int) and not isinstance(cat, bool):
        cat = names[cat] if names and 0 <= cat < len(names) else str(cat)
    cat = cat if isinstance(cat, str) and cat else md.get("category")
    meta = {"metadata": {k: md[k] for k in ("name", "license", "authors", "source", "link") if md.get(k) is not None}}
    if md.get("license") is not None:
        meta["licence"] = md["license"]
    if isinstance(cat, str) and cat:
        meta["category"] = cat
    if md.get("stationary") is not None:
        meta["stationary"] = bool(md["stationary"])
    if md.get("physical_size") is not None:
        meta["physical_size"] = float(md["physical_size"])
        meta["physical_size_unit"] = cfg.physical_size_unit or "not stated"
    cm = _physical_cm(md.get("physical_size"), cfg.physical_size_unit, cfg.capture_cm)
    if cm is not None:
        meta["physical_size_cm"] = cm
    return meta


def find(sources: list[Path], cfg) -> tuple[list[ParquetMaterial], list[Skipped]]:
    """The rows of the shards (sorted by shard, then row) from their small columns; no image byte is read.

    Raises:
        ImportInputError: no shard, a shard without a colour column or unreadable, ``capture_cm`` without
            ``physical_size_unit``.
    """
    import pyarrow.dataset as ds

    if cfg.capture_cm is not None and not cfg.physical_size_unit:
        raise ImportInputError("--capture-cm with parquet shards needs --physical-size-unit m|cm|mm: MatSynth's "
                               "dataset card declares metadata.physical_size as a float32 without a unit, and svgen "
                               "does not guess units")
    mats, skipped, seen = [], [], {}
    for shard in find_shards(sources, cfg.split):
        try:
            d = ds.dataset(shard, format="parquet")
            roles, ignored = role_columns(d.schema)
            small = [c for c in ("name", "category", "metadata") if c in d.schema.names]
            rows = d.to_table(columns=small).to_pylist()
        except ImportInputError as e:
            raise ImportInputError(f"{shard}: {e}") from None
        except Exception as e:  # pyarrow's errors: not a parquet file, truncated footer ...
            raise ImportInputError(f"cannot read parquet {shard}: {' '.join(str(e).split())}") from None
        names = _class_names(d.schema)
        for i, row in enumerate(rows):
            given = row.get("name")
            name = (given if isinstance(given, str) and given else f"{shard.stem}-row{i}").replace("/", "-")
            try:
                meta = _meta(row, names, cfg)
            except ValueError as e:
                skipped.append(Skipped(shard.name, i, name, str(e)))
                continue
            if name in seen:
                skipped.append(Skipped(shard.name, i, name, f"duplicate name (first at {seen[name]})"))
                continue
            seen[name] = f"{shard.name} row {i}"
            mats.append(ParquetMaterial(name=name, root=shard, layout=LAYOUT, meta=meta, row=i, columns=dict(roles),
                                        ignored=dict(ignored)))
    return mats, skipped


def _cell(v) -> bytes | None:
    """The encoded image of one cell: a `datasets` image struct's ``bytes``, or a binary value."""
    return v.get("bytes") if isinstance(v, dict) else v


def _rows(shard: Path, rows: list[int], columns: list[str]) -> Iterator[tuple[int, dict]]:
    """(row, {column: cell}) for each of ``rows`` (sorted) of one shard, one row in memory at a time."""
    import pyarrow.parquet as pq

    pf = pq.ParquetFile(shard, buffer_size=BUFFER, pre_buffer=False)
    starts, n = [], 0
    for g in range(pf.metadata.num_row_groups):
        starts.append(n)
        n += pf.metadata.row_group(g).num_rows
    todo = list(rows)
    for g, start in enumerate(starts):
        stop = start + pf.metadata.row_group(g).num_rows
        if not todo or todo[0] >= stop:
            continue
        batches = pf.iter_batches(batch_size=1, row_groups=[g], columns=columns, use_threads=False)
        for r, batch in enumerate(batches, start):
            if r == todo[0]:
                yield r, batch.to_pylist()[0]
                todo.pop(0)
                if not todo or todo[0] >= stop:
                    break  # closes the reader: the rest of the row group is not read


def stream(mats: list[ParquetMaterial]) -> Iterator[tuple[ParquetMaterial, ParquetMaterial | str]]:
    """Each material (in the order given, sorted by shard then row) with its maps as blobs, or why it has none:
    one row in memory at a time.

    Raises:
        ImportInputError: a shard that cannot be read.
    """
    by_shard: dict[Path, list[ParquetMaterial]] = {}
    for m in mats:
        by_shard.setdefault(m.root, []).append(m)
    for shard, group in by_shard.items():
        group.sort(key=lambda m: m.row)
        cols = sorted({c for m in group for c in m.columns.values()})
        try:
            for m, (_, cells) in zip(group, _rows(shard, [m.row for m in group], cols)):
                yield m, _loaded(m, cells)
        except ImportInputError:
            raise
        except Exception as e:  # pyarrow's errors
            raise ImportInputError(f"cannot read parquet {shard}: {' '.join(str(e).split())}") from None


def _loaded(m: ParquetMaterial, cells: dict) -> ParquetMaterial | str:
    """The material with a blob per role, or the missing maps (:data:`REQUIRED`) as a reason."""
    files = {role: Blob(f"{m.root.name} row {m.row} {col}", data) for role, col in m.columns.items()
             if (data := _cell(cells.get(col)))}
    missing = [" or ".join(g) for g in REQUIRED if not any(r in files for r in g)]
    if missing:
        return "missing map: " + ", ".join(missing)
    return replace(m, files=files, nbytes={r: len(b.data) for r, b in files.items()})


def check(mats: list[ParquetMaterial], cfg, preflight) -> tuple[list[ParquetMaterial], list[Skipped]]:
    """The rows whose maps are all there and readable (header, PNG chunk CRCs) and pass ``preflight(material)``
    (the folder importer's checks), the first ``cfg.limit`` of them; the others skipped with their reason. Reads
    every byte of the rows it checks, one row at a time, and keeps none."""
    kept, skipped = [], []
    rows = stream(mats)
    for m, loaded in rows:
        try:
            if isinstance(loaded, str):
                raise ImportInputError(loaded)
            for b in loaded.files.values():
                verify(b)
            preflight(loaded)
        except ImportInputError as e:
            skipped.append(Skipped(m.root.name, m.row, m.name, str(e)))
            continue
        kept.append(replace(loaded, files={}))
        if cfg.limit is not None and len(kept) == cfg.limit:
            rows.close()
            break
    return kept, skipped


def convert_rows(mats: list[ParquetMaterial], convert_one) -> Iterator[tuple]:
    """``convert_one(material)`` of each row, its maps read as it comes (one row in memory at a time).

    Raises:
        ImportInputError: a row whose maps are gone since the import was planned (the shard changed).
    """
    for m, loaded in stream(mats):
        if isinstance(loaded, str):
            raise ImportInputError(f"{m.root} row {m.row} ({m.name}): {loaded}, but it had every map when the import "
                                   "was planned: the shard changed")
        yield convert_one(loaded)


def describe(m: ParquetMaterial, source_root: Path) -> dict:
    """Provenance of a row known before conversion (the shard relative to its source, so spelling-independent)."""
    shard = m.root.resolve()
    rel = shard.relative_to(source_root) if shard != source_root and shard.is_relative_to(source_root) else shard.name
    return {"source": str(shard), "source_relative": str(rel), "row": m.row, "layout": m.layout,
            "files": {r: m.columns[r] for r in m.nbytes}, "bytes": dict(m.nbytes), "ignored": dict(m.ignored),
            "metadata": m.meta.get("metadata", {})}
