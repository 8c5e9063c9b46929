"""Writers of the fixture material folders the import tests build themselves (no downloads)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from svcore.image_io import write_png, write_png16


def png8(path: Path, a: np.ndarray) -> Path:
    """Values in [0, 1], (H, W) or (H, W, C) -> 8-bit PNG."""
    return write_png(path, a)


def png16(path: Path, a: np.ndarray) -> Path:
    """Values in [0, 1] -> 16-bit PNG (grey or RGB)."""
    return write_png16(path, a)


def exr(path: Path, a: np.ndarray, channels: str = "RGB") -> Path:
    import OpenEXR

    a = np.asarray(a, np.float32)
    if a.ndim == 2:
        a = a[..., None]
    chans = {c: np.ascontiguousarray(a[..., i]) for i, c in enumerate(channels)}
    with OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}, chans) as f:
        f.write(str(path))
    return path


def unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def bumpy_normals(s: int, rng) -> np.ndarray:
    """(s, s, 3) smooth unit normals with varied x and y slopes (OpenGL convention); ``rng`` draws the two waves'
    phases, so materials made with different draws differ (white noise would break the smoothness tests rely on)."""
    u = (np.arange(s) + 0.5) / s
    x, y = np.meshgrid(u, 1 - u)
    px, py = rng.uniform(0, 2 * np.pi, 2)
    sx = 0.4 * np.sin(2 * np.pi * (x + 0.3 * y) + px)
    sy = 0.5 * np.cos(2 * np.pi * (2 * y - x) + py)
    return unit(np.stack([-sx, -sy, np.ones_like(sx)], -1)).astype(np.float32)


def height_field(s: int) -> tuple[np.ndarray, callable]:
    """Height h = 0.5 + 0.25 sin(2 pi u) cos(2 pi v) at pixel centres (u right, v up) and its analytic gradient."""
    c = (np.arange(s) + 0.5) / s
    u, v = np.meshgrid(c, 1 - c)
    h = 0.5 + 0.25 * np.sin(2 * np.pi * u) * np.cos(2 * np.pi * v)

    def grad(uu, vv):
        return (0.25 * 2 * np.pi * np.cos(2 * np.pi * uu) * np.cos(2 * np.pi * vv),
                -0.25 * 2 * np.pi * np.sin(2 * np.pi * uu) * np.sin(2 * np.pi * vv))

    return h, grad


def ambientcg(root: Path, name: str, s: int, rng, normals: dict[str, np.ndarray]) -> Path:
    """An ambientCG-style folder: <name>_2K-PNG_Color/Roughness/NormalGL|NormalDX/AmbientOcclusion.png."""
    d = root / name
    d.mkdir(parents=True)
    stem = f"{name}_2K-PNG"
    png8(d / f"{stem}_Color.png", rng.random((s, s, 3)))
    png8(d / f"{stem}_Roughness.png", rng.random((s, s)))
    png8(d / f"{stem}_AmbientOcclusion.png", rng.random((s, s)))
    for conv, n in normals.items():
        png8(d / f"{stem}_Normal{conv}.png", (n + 1) / 2)
    return d


def matsynth(root: Path, name: str, s: int, base: np.ndarray, metal: np.ndarray, height: np.ndarray,
             meta: dict | None = None) -> Path:
    """A MatSynth-style folder: basecolor.png (16-bit), metallic.png, roughness.png, height.png (16-bit),
    metadata.json."""
    d = root / name
    d.mkdir(parents=True)
    png16(d / "basecolor.png", base)
    png8(d / "metallic.png", metal)
    png8(d / "roughness.png", np.full((s, s), 0.5))
    png16(d / "height.png", height)
    (d / "metadata.json").write_text(json.dumps(meta or {"category": "metal", "license": "CC0"}))
    return d


#: MatSynth's columns and class names, as its dataset card lists them (gvecchio/MatSynth on the Hugging Face hub)
MATSYNTH_IMAGES = ("basecolor", "diffuse", "displacement", "height", "metallic", "normal", "opacity", "roughness",
                   "specular", "blend_mask")
MATSYNTH_CLASSES = ("ceramic", "concrete", "fabric", "ground", "leather", "marble", "metal", "misc", "plaster",
                    "plastic", "stone", "terracotta", "wood")


def matsynth_schema():
    """MatSynth's parquet schema (pyarrow), with the `datasets` features in its metadata as `datasets` writes them
    (the class label's names live there)."""
    import pyarrow as pa

    image = pa.struct([("bytes", pa.binary()), ("path", pa.string())])
    strings = pa.list_(pa.string())
    meta = pa.struct([("authors", strings), ("category", pa.string()), ("description", pa.string()),
                      ("height_factor", pa.float32()), ("height_mean", pa.float32()), ("license", pa.string()),
                      ("link", pa.string()), ("maps", strings), ("method", pa.string()), ("name", pa.string()),
                      ("physical_size", pa.float32()), ("source", pa.string()), ("stationary", pa.bool_()),
                      ("tags", strings), ("version_date", pa.string())])
    features = {"name": {"dtype": "string", "_type": "Value"},
                "category": {"names": list(MATSYNTH_CLASSES), "_type": "ClassLabel"},
                "metadata": {f.name: {"feature": {"dtype": "string", "_type": "Value"}, "_type": "Sequence"}
                             if pa.types.is_list(f.type) else {"dtype": {"float": "float32"}.get(str(f.type), str(f.type)),
                                                               "_type": "Value"} for f in meta},
                **{c: {"_type": "Image"} for c in MATSYNTH_IMAGES}}
    fields = [pa.field("name", pa.string()), pa.field("category", pa.int64()), pa.field("metadata", meta)]
    fields += [pa.field(c, image) for c in MATSYNTH_IMAGES]
    return pa.schema(fields, metadata={"huggingface": json.dumps({"info": {"features": features}})})


def matsynth_row(name: str, category: str, maps: dict[str, bytes], **metadata) -> dict:
    """One row: ``maps`` column -> encoded image bytes (missing columns are null), ``metadata`` fields by name."""
    meta = {"authors": ["svgen tests"], "license": "CC0", "source": "svgen fixtures", "name": name,
            "stationary": True, "physical_size": None, **metadata}
    row = {"name": name, "category": MATSYNTH_CLASSES.index(category), "metadata": meta}
    row.update({c: {"bytes": maps[c], "path": f"{name}/{c}.png"} if c in maps else None for c in MATSYNTH_IMAGES})
    return row


def matsynth_shard(path: Path, rows: list[dict], row_group_size: int | None = None) -> Path:
    """A parquet shard as `datasets` (>= 4) writes one: image leaves PLAIN-encoded and uncompressed, content-defined
    pages, a page index."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    schema = matsynth_schema()
    leaves = [f"{c}.{f}" for c in MATSYNTH_IMAGES for f in ("bytes", "path")]
    pq.write_table(pa.Table.from_pylist(rows, schema=schema), path, row_group_size=row_group_size,
                   compression={**{c: "snappy" for c in ("name", "category")}, **{leaf: "none" for leaf in leaves}},
                   use_dictionary=["name"], column_encoding={leaf: "PLAIN" for leaf in leaves},
                   use_content_defined_chunking=True, write_page_index=True)
    return path
