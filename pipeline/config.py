"""Typed stage configurations with named presets; click options and params.yaml only fill these in.

Every field has a docstring (the attribute docstring below it). The resolved
configuration is stored in the attributes of the store a stage writes.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any, TypeVar

from .errors import ConfigError

T = TypeVar("T")


@dataclass(frozen=True)
class SampleConfig:
    """`svgen sample`: perturbed variants of every base material."""

    per_preset: int = 12
    """Variants per base material (the paper: ~1,850 variants of 155 materials, i.e. 12 each). Variant 0 is the
    preset's defaults; the others are perturbed."""
    size: int = 256
    """Map resolution (square, 64..1024)."""
    seed: int = 0
    """Master seed of the stage; variant k of preset P uses derive_seed(seed, "sample", crc32(P), k)."""
    sigma: float = 0.25
    """Perturbation: each exposed parameter ~ Normal(default, sigma * (high - low)) truncated to [low, high]."""
    presets: tuple[str, ...] = ()
    """Restrict to these presets (empty: all)."""
    classes: tuple[str, ...] = ()
    """Restrict to these classes (empty: all)."""
    chunk: int = 8
    """Samples per zarr chunk (one dask task writes one chunk)."""

    def check(self) -> "SampleConfig":
        _positive(self, "per_preset", "chunk")
        if not (0 < self.sigma <= 10):
            raise ConfigError(f"sigma must be in (0, 10], got {self.sigma}")
        _seed(self.seed)
        return self


@dataclass(frozen=True)
class BlendConfig:
    """`svgen blend`: convex combinations of random pairs of variants."""

    count: int = 120
    """Number of blends (the paper: ~10x the number of variants)."""
    seed: int = 0
    """Master seed; blend j uses derive_seed(seed, "blend", j) for its pair, alpha and mask."""
    alpha_low: float = 0.2
    """Lower end of alpha ~ U(alpha_low, alpha_high): weight of the first variant."""
    alpha_high: float = 0.8
    """Upper end of the alpha range."""
    mode: str = "scalar"
    """"scalar": one alpha for the whole maps (the paper). "mask": a tileable procedural mask in [0,1] whose mean
    is alpha, so the two materials occupy different regions."""
    mask_per_map: bool = False
    """With mode="mask": a different mask per map (normal, diffuse, specular, roughness), decorrelating the maps."""
    mask_scale: float = 4.0
    """With mode="mask": features per tile of the mask noise (larger: finer patches)."""
    chunk: int = 8
    """Samples per zarr chunk."""

    def check(self) -> "BlendConfig":
        _positive(self, "count", "chunk")
        if not (0.0 <= self.alpha_low <= self.alpha_high <= 1.0):
            raise ConfigError(f"need 0 <= alpha_low <= alpha_high <= 1, got {self.alpha_low}, {self.alpha_high}")
        if self.mode not in ("scalar", "mask"):
            raise ConfigError(f"unknown blend mode {self.mode!r}; use 'scalar' or 'mask'")
        if not (0.5 <= self.mask_scale <= 64):
            raise ConfigError(f"mask_scale must be in [0.5, 64], got {self.mask_scale}")
        _seed(self.seed)
        return self


#: named presets per stage config ("tiny" for tests and smoke runs).
PRESETS: dict[type, dict[str, dict[str, Any]]] = {
    SampleConfig: {"default": {}, "tiny": {"per_preset": 2, "size": 64}, "paper": {"per_preset": 12, "size": 288}},
    BlendConfig: {"default": {}, "tiny": {"count": 6}, "paper": {"count": 20000}},
}


def _positive(cfg, *names):
    for n in names:
        v = getattr(cfg, n)
        if not isinstance(v, int) or v < 1:
            raise ConfigError(f"{n} must be a positive integer, got {v!r}")


def _seed(seed):
    if not isinstance(seed, int) or seed < 0:
        raise ConfigError(f"seed must be a non-negative integer, got {seed!r}")


def field_docs(cls) -> dict[str, str]:
    """Field name -> attribute docstring (parsed from the source), for help texts and docs."""
    import ast
    import inspect
    import textwrap

    tree = ast.parse(textwrap.dedent(inspect.getsource(cls)))
    body = tree.body[0].body
    out = {}
    for a, b in zip(body, body[1:]):
        if isinstance(a, ast.AnnAssign) and isinstance(b, ast.Expr) and isinstance(getattr(b, "value", None), ast.Constant):
            out[a.target.id] = " ".join(str(b.value.value).split())
    return out


def build(cls: type[T], preset: str = "default", params_file: str | Path | None = None, section: str | None = None,
          **overrides) -> T:
    """Resolve a config: class defaults < named preset < params.yaml section < explicit overrides (not None).

    Raises:
        ConfigError: unknown preset, unknown key in the params file, or a value out of range.
    """
    presets = PRESETS.get(cls, {"default": {}})
    if preset not in presets:
        raise ConfigError(f"unknown preset {preset!r} for {cls.__name__}; known: {', '.join(presets)}")
    values: dict[str, Any] = dict(presets[preset])
    if params_file is not None:
        values.update(load_section(params_file, section))
    values.update({k: v for k, v in overrides.items() if v is not None})
    names = {f.name: f for f in fields(cls)}
    unknown = set(values) - set(names)
    if unknown:
        raise ConfigError(f"unknown {cls.__name__} option(s): {', '.join(sorted(unknown))}")
    for k, v in list(values.items()):
        if isinstance(v, list):
            values[k] = tuple(v)
    try:
        cfg = cls(**values)
    except TypeError as e:
        raise ConfigError(str(e)) from None
    return cfg.check() if hasattr(cfg, "check") else cfg


def load_section(params_file: str | Path, section: str | None) -> dict[str, Any]:
    import yaml

    p = Path(params_file)
    if not p.exists():
        raise ConfigError(f"params file {p} does not exist")
    try:
        data = yaml.safe_load(p.read_text()) or {}
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        raise ConfigError(f"params file {p} is not valid YAML{where}: {getattr(e, 'problem', None) or e}") from None
    if section is not None:
        data = data.get(section, {})
    if not isinstance(data, dict):
        raise ConfigError(f"section {section!r} of {p} is not a mapping")
    return data


def as_dict(cfg) -> dict[str, Any]:
    """JSON-able dict of a config dataclass."""
    return {k: list(v) if isinstance(v, tuple) else v for k, v in dataclasses.asdict(cfg).items()}


# --- svgen import (pipeline/importer/) -------------------------------------------------------------------------------
IMPORT_LAYOUTS = ("auto", "folders", "deschaintre")
NORMAL_CONVENTIONS = ("auto", "opengl", "directx")


@dataclass(frozen=True)
class ImportConfig:
    """`svgen import`: material folders or 2018 strips -> a variants store (or a renders store)."""

    sources: tuple[str, ...] = ()
    """Source folders (a material folder, a tree of them, or a folder of 2018 strips). params.yaml lists them under
    import.sources; empty by default, so the default pipeline imports nothing."""
    layout: str = "auto"
    """"folders" (one material per folder of map files), "deschaintre" (5-tile PNG strips), or "auto" (strips when
    every image is a PNG 5 times as wide as high, else folders)."""
    size: int = 256
    """Output map side: sources are centre-cropped to a square and area-averaged down to it."""
    normal_convention: str = "auto"
    """"opengl" (y up, DESIGN.md), "directx" (green flipped), or "auto": the file name (NormalGL/NormalDX), else
    the agreement with a height map's gradient, else OpenGL (recorded per material)."""
    category: str = ""
    """Category of materials whose sidecar metadata.json gives none (empty: "imported"); names become
    "<category>/<material>"."""
    allow_upscale: bool = False
    """Permit maps smaller than size (periodic bilinear upsampling); otherwise such materials are refused."""
    as_kind: str = "variants"
    """"variants" (maps, re-rendered by svgen render), or "renders" (deschaintre layout only: the strip's own photo
    as a one-view renders store with the identity view transform, for svtrain eval --store)."""
    input_space: str = "linear"
    """Deschaintre layout: how the strip's input photo is encoded ("linear": as the 2018 code read it; "srgb")."""
    height_strength: float = 0.02
    """Relief of height value 1 in tile widths: height-derived normals are normalize(-s dh/du, -s dh/dv, 1)."""
    per_material: int = 3
    """DVC pipeline only: variants per imported material that `svgen sample --from-dir` adds to the variants."""
    chunk: int = 4
    """Materials per zarr chunk (one dask task converts and writes one chunk)."""

    def check(self) -> "ImportConfig":
        _positive(self, "chunk", "per_material")
        if self.layout not in IMPORT_LAYOUTS:
            raise ConfigError(f"unknown layout {self.layout!r}; use one of {', '.join(IMPORT_LAYOUTS)}")
        if self.normal_convention not in NORMAL_CONVENTIONS:
            raise ConfigError(f"unknown normal convention {self.normal_convention!r}; use one of "
                              f"{', '.join(NORMAL_CONVENTIONS)}")
        if self.as_kind not in ("variants", "renders"):
            raise ConfigError(f"--as must be 'variants' or 'renders', got {self.as_kind!r}")
        if self.as_kind == "renders" and self.layout == "folders":
            raise ConfigError("--as renders needs the deschaintre layout (folders hold maps, not photographs)")
        if self.input_space not in ("linear", "srgb"):
            raise ConfigError(f"--input-space must be 'linear' or 'srgb', got {self.input_space!r}")
        if not isinstance(self.size, int) or not 16 <= self.size <= 4096:
            raise ConfigError(f"size must be an integer in [16, 4096], got {self.size!r}")
        if not 0 < self.height_strength <= 10:
            raise ConfigError(f"height_strength must be in (0, 10], got {self.height_strength}")
        if "/" in self.category:
            raise ConfigError(f"category {self.category!r} must not contain '/'")
        return self


PRESETS[ImportConfig] = {"default": {}, "tiny": {"size": 64, "chunk": 2}}
