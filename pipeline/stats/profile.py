"""A store's realism profile: the per-material statistics of :mod:`pipeline.stats.realism` for each of its materials,
kept per material so that a reference can be split into halves (the noise floor, :mod:`pipeline.stats.compare`).
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from svcore.errors import StoreError
from svcore.progress import progress

from . import realism
from . import maps_reader


@dataclasses.dataclass(frozen=True)
class Profile:
    """Per-material realism statistics of one store.

    Attributes:
        name: label of the store in tables and charts.
        kind: the store's kind (variants, blends, stress, renders).
        size: map side in pixels (octave shares count cycles per map at this size).
        pixels: statistic -> (M, P) pixel values (:data:`pipeline.stats.realism.PIXEL_STATS`, P = GRID² or fewer).
        per_material: statistic -> (M,) values (variation and correlation statistics).
        octaves: (M, 7) shares of slope power per octave.
    """

    name: str
    kind: str
    size: int
    pixels: dict[str, np.ndarray]
    per_material: dict[str, np.ndarray]
    octaves: np.ndarray

    def __len__(self) -> int:
        return int(self.octaves.shape[0])

    def subset(self, idx) -> "Profile":
        """The profile of materials ``idx`` only (a list or array of material positions)."""
        idx = np.asarray(idx, int)
        return dataclasses.replace(self, pixels={k: v[idx] for k, v in self.pixels.items()},
                                   per_material={k: v[idx] for k, v in self.per_material.items()},
                                   octaves=self.octaves[idx])


def material_stats(m) -> tuple[dict, dict, np.ndarray]:
    """(pixel samples, variation + correlation values, octave shares) of one material's maps (an SVBRDF)."""
    args = (m.diffuse, m.specular, m.roughness, m.normal)
    return (realism.pixel_samples(*args), {**realism.variation(*args), **realism.correlations(*args)},
            realism.octave_shares(m.normal))


def check_reference(path) -> None:
    """Refuse, in one line, a reference that is not a store of materials (before any other work is done).

    Raises:
        StoreError: missing, not a store (a folder of material files gets the import command to run first), or
            holding fewer than 2 materials (no halves to measure a noise floor with).
    """
    try:
        _, n, _ = maps_reader(path)
    except StoreError as e:
        if Path(str(path)).is_dir() and not (Path(str(path)) / "zarr.json").exists():
            raise StoreError(f"reference {path} is not a store: import the folder first "
                             f"(svgen import {path} REF.zarr) and pass REF.zarr") from e
        raise StoreError(f"reference: {e}") from e
    if n < 2:
        raise StoreError(f"reference {path} holds {n} materials: at least 2 are needed (its halves give the "
                         "noise floor)")


def profile(path, limit: int | None = None, name: str | None = None) -> Profile:
    """The realism profile of a variants, blends, stress or renders store (base maps), over all its materials or an
    evenly spaced ``limit`` of them.

    Raises:
        StoreError: not a store of those kinds, or one holding no materials.
    """
    kind, n, maps_of = maps_reader(path)
    if n == 0:
        raise StoreError(f"{path} holds no materials")
    idx = np.unique(np.linspace(0, n - 1, min(n, limit or n)).round().astype(int))
    pix, per, octs, size = {}, {}, [], None
    with progress(len(idx), "realism", unit="material") as bar:
        for i in idx:
            m = maps_of(int(i))
            size = m.normal.shape[0]
            p, v, o = material_stats(m)
            for k, x in p.items():
                pix.setdefault(k, []).append(x)
            for k, x in v.items():
                per.setdefault(k, []).append(x)
            octs.append(o)
            bar.update(1)
    return Profile(name or Path(str(path).rstrip("/")).name, kind, int(size),
                   {k: np.stack(v) for k, v in pix.items()}, {k: np.asarray(v, np.float64) for k, v in per.items()},
                   np.stack(octs))
