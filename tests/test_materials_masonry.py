"""The masonry classes of issue #23 (bricks, roofing, concrete, rock): every perturbed variant inside its class's
declared ``PHYSICAL`` ranges, relief present and mostly at mid scales (issue #22), and the presets distinct."""
from __future__ import annotations

import importlib

import numpy as np
import pytest

from materials import presets
from materials.params import perturb
from pipeline.stats.realism import octave_shares
from svcore.seeds import rng_for

MASONRY = ("bricks", "roofing", "concrete", "rock")
NAMES = [p.name for c in MASONRY for p in presets(c)]
#: variants per preset drawn at the default perturbation sigma
VARIANTS = 3
SIGMA = 0.25


def _physical(cls: str) -> dict:
    return importlib.import_module(f"materials.classes.{cls}").PHYSICAL


@pytest.mark.parametrize("cls", MASONRY)
def test_every_variant_inside_the_physical_ranges(cls):
    phys = _physical(cls)
    assert set(phys) == {"diffuse", "specular", "roughness"}
    for i, p in enumerate(presets(cls)):
        for k in range(VARIANTS):
            params = perturb(p, k, SIGMA, rng_for(7, "sample", i, k))
            m = p.generate(params, 64, k)
            for key, a in (("diffuse", m.diffuse), ("specular", m.specular), ("roughness", m.roughness)):
                lo, hi = phys[key]
                assert lo - 1e-6 <= float(a.min()) and float(a.max()) <= hi + 1e-6, \
                    f"{p.name} variant {k} {key} [{a.min():.4f}, {a.max():.4f}] outside {phys[key]} ({params})"
            # the ranges are calibrated, not just clamped: few diffuse pixels sit on a bound
            lo, hi = phys["diffuse"]
            at_bound = float(np.mean((m.diffuse <= lo + 1e-6) | (m.diffuse >= hi - 1e-6)))
            assert at_bound < 0.05, f"{p.name} variant {k}: {at_bound:.1%} of diffuse values on a PHYSICAL bound"


@pytest.mark.parametrize("name", NAMES)
def test_relief_mostly_at_mid_scales(name):
    # periods of 8-64 px at 256² (4-32 cycles per map) hold more slope power than periods <= 8 px (>= 32 cycles)
    p = next(q for q in presets(name.split("/")[0]) if q.name == name)
    m = p.generate(None, 256, 0)
    tilt = float(np.degrees(np.arccos(np.clip(m.normal[..., 2], -1, 1))).mean())
    assert tilt > 1.0, f"{name}: mean normal tilt {tilt:.2f} degrees: no relief"
    share = octave_shares(m.normal)
    fine, mid = float(share[5:].sum()), float(share[2:5].sum())
    assert fine < 0.5 and mid > fine, f"{name}: slope power at >= 32 cycles {fine:.2f}, at 4-32 cycles {mid:.2f}"


@pytest.mark.parametrize("cls", MASONRY)
def test_presets_of_a_class_are_distinct(cls):
    # each preset's mean diffuse, roughness and relief differ from every other preset's of the class
    feats = {}
    for p in presets(cls):
        m = p.generate(None, 64, 0)
        tilt = np.degrees(np.arccos(np.clip(m.normal[..., 2], -1, 1)))
        feats[p.name] = np.array([*m.diffuse.mean((0, 1)) * 10, m.roughness.mean() * 5, m.diffuse.std() * 10,
                                  tilt.mean() / 5])
    assert len(feats) >= 10, f"{cls}: {len(feats)} presets"
    names = list(feats)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            d = float(np.abs(feats[a] - feats[b]).sum())
            assert d > 0.05, f"{a} and {b} look alike (feature distance {d:.3f})"
