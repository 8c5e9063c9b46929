"""Plausible perturbations (#23): every variant of every preset, drawn as `svgen sample` draws it at the default
sigma, stays inside the physical ranges its class module declares in ``PHYSICAL``."""
from __future__ import annotations

import importlib

import numpy as np
import pytest

from materials.registry import classes, presets  # not `materials.classes`: the subpackage shadows it once imported
from pipeline.config import SampleConfig
from pipeline.sample import Plan, make_variant

#: perturbed variants checked per preset (variant 0 is the preset's defaults), at this size
VARIANTS, SIZE = 6, 64
#: the share of a map's pixels allowed outside the range on each side: a few pixels of a scratch, a chip edge or
#: a crease may go further; the body of the material may not
TAIL = 0.01
MAPS = {"diffuse": "diffuse", "specular": "specular", "roughness": "roughness"}


def physical(cls: str) -> dict[str, tuple[float, float]]:
    """The ``PHYSICAL`` table of a class module (materials/classes/<cls>.py)."""
    return importlib.import_module(f"materials.classes.{cls}").PHYSICAL


@pytest.mark.parametrize("cls", sorted(classes()))
def test_every_class_declares_its_physical_ranges(cls):
    ph = physical(cls)
    assert set(ph) == set(MAPS), (cls, sorted(ph))
    for k, (lo, hi) in ph.items():
        assert 0.0 <= lo < hi <= 1.0, (cls, k, lo, hi)


def violations(name: str, ph: dict, variants: int = VARIANTS, size: int = SIZE) -> list[str]:
    """Variants of preset ``name`` (the sample stage's own draws, seed 0) whose maps leave ``ph``: their
    per-channel TAIL and 1 - TAIL quantiles must lie inside the declared [lo, hi]."""
    sigma = SampleConfig().sigma
    bad = []
    for spec in Plan([name], variants, 0):
        m, params = make_variant(spec, sigma, size)
        for key, (lo, hi) in ph.items():
            a = getattr(m, MAPS[key]).reshape(-1, getattr(m, MAPS[key]).shape[-1])
            q_lo, q_hi = np.quantile(a, [TAIL, 1 - TAIL], axis=0)
            if q_lo.min() < lo - 1e-4 or q_hi.max() > hi + 1e-4:
                bad.append(f"{name} k={spec.k} {key} [{q_lo.min():.4f}, {q_hi.max():.4f}] not in [{lo}, {hi}]")
    return bad


@pytest.mark.parametrize("cls", sorted(classes()))
def test_variants_stay_inside_their_class_physical_ranges(cls):
    ph = physical(cls)
    bad = [b for p in presets(cls) for b in violations(p.name, ph)]
    assert not bad, "\n".join(bad[:20])


def test_a_range_broken_on_purpose_is_caught():
    # a dielectric class's F0 narrowed below what its presets produce: the check must report it
    ph = dict(physical("plastic"))
    ph["specular"] = (0.02, 0.03)
    assert violations("plastic/glossy_blue", ph, variants=2)
