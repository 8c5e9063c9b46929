"""Registries of material classes (one module each) and presets (base materials).

A *class* is a generator ``fn(params: dict, size: int, rng) -> SVBRDF`` plus its
full parameter table. A *preset* is a class plus its own default values and
ranges for the parameters it exposes (1-36 of them); the class parameters it
does not expose stay at the preset's fixed values.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from svcore.errors import SvgenError

from .maps import SVBRDF
from .params import Param, ParamTable

MIN_SIZE, MAX_SIZE = 64, 1024

Generator = Callable[[dict, int, np.random.Generator], SVBRDF]


class UnknownMaterial(SvgenError, KeyError):
    """An unknown class or preset name."""

    def __str__(self):
        return str(self.args[0])


class BadParameter(SvgenError, ValueError):
    """A parameter that is unknown or outside its range, or a bad size."""


@dataclass(frozen=True)
class MaterialClass:
    name: str
    table: ParamTable
    fn: Generator
    doc: str = ""


@dataclass(frozen=True)
class Preset:
    """A base material.

    Attributes:
        name: unique preset name, e.g. "paint/glossy_red".
        cls: material class name.
        exposed: the perturbable parameters with this preset's defaults and ranges.
        fixed: values of the class parameters that this preset does not expose.
    """

    name: str
    cls: str
    exposed: ParamTable
    fixed: dict = field(default_factory=dict)

    @property
    def material_class(self) -> MaterialClass:
        return get_class(self.cls)

    def defaults(self) -> dict[str, float]:
        return self.exposed.defaults()

    def resolve(self, params: dict | None = None) -> dict[str, float]:
        """Full class parameter dict: class defaults < preset fixed < preset defaults < ``params``.

        Raises:
            BadParameter: unknown name or value outside the preset's range.
        """
        params = dict(params or {})
        for k, v in params.items():
            try:
                p = self.exposed[k]
            except KeyError:
                raise BadParameter(f"preset {self.name!r} has no parameter {k!r}; it has: {', '.join(self.exposed.names())}") from None
            if not np.isfinite(v) or not (p.low <= v <= p.high):
                raise BadParameter(f"parameter {k}={v} of preset {self.name!r} is outside its range [{p.low}, {p.high}]")
        out = self.material_class.table.defaults()
        out.update(self.fixed)
        out.update(self.exposed.defaults())
        out.update({k: float(v) for k, v in params.items()})
        return out

    def generate(self, params: dict | None, size: int, seed: int) -> SVBRDF:
        """Maps for ``params`` (exposed names only; missing ones take defaults) at ``size``², from ``seed``."""
        check_size(size)
        full = self.resolve(params)
        rng = np.random.default_rng(seed)
        return self.material_class.fn(full, size, rng)


_CLASSES: dict[str, MaterialClass] = {}
_PRESETS: dict[str, Preset] = {}


def check_size(size: int) -> None:
    if not isinstance(size, (int, np.integer)) or not (MIN_SIZE <= size <= MAX_SIZE):
        raise BadParameter(f"size must be an integer from {MIN_SIZE} to {MAX_SIZE}, got {size!r}")


def register_class(name: str, params: list[Param], doc: str = ""):
    """Decorator: register ``fn(params, size, rng) -> SVBRDF`` as material class ``name``."""

    def deco(fn: Generator) -> Generator:
        if name in _CLASSES:
            raise ValueError(f"material class {name!r} registered twice")
        _CLASSES[name] = MaterialClass(name, ParamTable(tuple(params)), fn, doc or (fn.__doc__ or "").strip().split("\n")[0])
        return fn

    return deco


def register_preset(name: str, cls: str, exposed: dict[str, tuple], fixed: dict | None = None) -> Preset:
    """Register a base material.

    Args:
        name: preset name (unique; conventionally "<class>/<name>").
        cls: a registered class.
        exposed: ``{param: (default, low, high)}``; docs and kinds come from the class table.
        fixed: values for non-exposed class parameters.
    """
    mc = get_class(cls)
    ps = []
    for pname, (d, lo, hi) in exposed.items():
        base = mc.table[pname]
        if lo < base.low or hi > base.high:
            raise ValueError(f"preset {name}: range of {pname} [{lo},{hi}] exceeds class range [{base.low},{base.high}]")
        ps.append(base.with_(default=float(d), low=float(lo), high=float(hi)))
    for k in fixed or {}:
        mc.table[k]  # KeyError for typos at import time
    if name in _PRESETS:
        raise ValueError(f"preset {name!r} registered twice")
    p = Preset(name, cls, ParamTable(tuple(ps)), dict(fixed or {}))
    _PRESETS[name] = p
    return p


def _load():
    # import by full name: `from . import classes` would return the `classes()` function that
    # materials/__init__.py re-exports under the same name, and never import the subpackage
    import importlib

    import sys

    importlib.import_module(f"{__package__}.classes")  # registers every class module and preset
    # importing the subpackage binds it as the package attribute `classes`, over the re-exported function: put the
    # function back, so `from materials import classes` means the same whatever was imported first
    sys.modules[__package__].classes = classes


def get_class(name: str) -> MaterialClass:
    _load()
    if name not in _CLASSES:
        raise UnknownMaterial(f"unknown material class {name!r}; known: {', '.join(sorted(_CLASSES))}")
    return _CLASSES[name]


def get_preset(name: str) -> Preset:
    _load()
    if name not in _PRESETS:
        raise UnknownMaterial(f"unknown preset {name!r}; see `svgen materials` for the catalogue")
    return _PRESETS[name]


def classes() -> dict[str, MaterialClass]:
    _load()
    return dict(_CLASSES)


def presets(cls: str | None = None) -> list[Preset]:
    """All presets, sorted by name; optionally of one class."""
    _load()
    if cls is not None:
        get_class(cls)
    return sorted((p for p in _PRESETS.values() if cls is None or p.cls == cls), key=lambda p: p.name)
