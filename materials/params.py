"""Parameter tables: every procedural parameter has a name, a default and a range."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Param:
    """One scalar procedural parameter.

    Attributes:
        name: identifier, unique within a material class.
        default: value used when none is given.
        low, high: the valid, inclusive range; perturbation stays inside it.
        doc: one line for the generated documentation.
        kind: "float", "int" (rounded when used) or "srgb" (a colour channel an artist thinks of in sRGB,
            decoded to linear once by the class with colour-science).
    """

    name: str
    default: float
    low: float
    high: float
    doc: str = ""
    kind: str = "float"

    def __post_init__(self):
        if not (self.low <= self.default <= self.high):
            raise ValueError(f"param {self.name}: default {self.default} outside [{self.low}, {self.high}]")
        if self.kind not in ("float", "int", "srgb"):
            raise ValueError(f"param {self.name}: unknown kind {self.kind!r}")

    def with_(self, **kw) -> "Param":
        d = {**self.__dict__, **kw}
        return Param(**d)


@dataclass(frozen=True)
class ParamTable:
    """An ordered table of parameters."""

    params: tuple[Param, ...] = field(default_factory=tuple)

    def __iter__(self):
        return iter(self.params)

    def __len__(self):
        return len(self.params)

    def names(self) -> list[str]:
        return [p.name for p in self.params]

    def __getitem__(self, name: str) -> Param:
        for p in self.params:
            if p.name == name:
                return p
        raise KeyError(name)

    def defaults(self) -> dict[str, float]:
        return {p.name: float(p.default) for p in self.params}


def perturb(preset, k: int, sigma: float, rng: np.random.Generator) -> dict[str, float]:
    """Parameters of variant ``k`` of ``preset`` (anything with an ``exposed`` :class:`ParamTable`: a preset, an
    imported material): defaults for k == 0, else truncated-normal draws around them.

    Returns:
        exposed parameter name -> value (inside the preset's range).
    """
    from scipy.stats import truncnorm  # scipy on first use: importing materials stays light

    # one vectorised draw for all the drawn parameters: the same uniforms in the same order as one draw per
    # parameter (truncnorm draws U(0, 1) and inverts its cdf elementwise), at a quarter of the cost
    drawn = [p for p in preset.exposed if not (k == 0 or p.high == p.low)]
    values = {}
    if drawn:
        if not sigma > 0:
            raise ValueError(f"perturbation sigma must be > 0, got {sigma}")
        default = np.array([p.default for p in drawn], float)
        low, high = np.array([p.low for p in drawn], float), np.array([p.high for p in drawn], float)
        scale = sigma * (high - low)
        v = truncnorm.rvs((low - default) / scale, (high - default) / scale, loc=default, scale=scale,
                          random_state=rng)
        values = dict(zip((p.name for p in drawn), np.atleast_1d(v).tolist()))
    out = {}
    for p in preset.exposed:
        v = values.get(p.name, p.default)
        if p.kind == "int":
            v = float(np.clip(np.round(v), p.low, p.high))
        out[p.name] = float(np.clip(v, p.low, p.high))
    return out
