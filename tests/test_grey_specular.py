"""``sample.grey_specular`` (#39, round 9): a chosen variant's dielectric pixels share one grey F0, metal pixels
keep theirs, nothing else in the variant moves, and the option at 0 leaves the stage's bytes and config alone.
"""
from __future__ import annotations

import numpy as np
import pytest
import torch

import materials
from pipeline.config import SampleConfig
from pipeline.grey_specular import DIELECTRIC_MAX, LUMA, GreySpecular
from pipeline.sample import make_variant, plan
from svcore.config import build
from train.spec_stats import chroma, correlation

SIZE = 64


def variant(preset: str, k: int = 1) -> tuple[materials.SVBRDF, int]:
    """Variant ``k`` of ``preset`` at SIZE² and its derived seed (the default config's plan)."""
    spec = next(s for s in plan(build(SampleConfig, presets=(preset,), per_preset=k + 1)) if s.k == k)
    return make_variant(spec, 0.25, SIZE)[0], spec.seed


def chw(a: np.ndarray) -> torch.Tensor:
    return torch.from_numpy(np.ascontiguousarray(a.transpose(2, 0, 1)))[None]


def test_dielectric_specular_becomes_one_grey_value_and_stops_following_the_albedo():
    """Ceramic tiles' glaze and grout differ in F0 with their colour; made grey, the specular statistics of #39
    (train.spec_stats) read a grey constant map: correlation 0, chroma 0."""
    m, seed = variant("ceramic_tiles/red_brick")
    y = m.specular.astype(np.float64) @ LUMA
    assert y.max() < DIELECTRIC_MAX and y.std() > 1e-3  # a dielectric whose F0 varies: the case the option is for
    g = GreySpecular(1.0).apply(m, seed)
    assert np.ptp(g.specular) == 0.0  # one value on every pixel and channel
    assert g.specular[0, 0, 0] == pytest.approx(y.mean(), rel=1e-6)  # the variant's mean F0 is kept
    assert correlation(chw(g.specular), chw(g.diffuse)).item() == 0.0
    assert chroma(chw(g.specular)).item() == 0.0
    for k in ("normal", "diffuse", "roughness"):
        assert np.array_equal(getattr(g, k), getattr(m, k)), k


def test_metal_pixels_keep_their_coloured_f0():
    """Painted, rusted metal sheet: the paint and rust pixels (dielectric) are made grey, the bare metal keeps its
    F0 byte for byte; a threshold that takes every pixel fails here."""
    m, seed = variant("metal_sheet/corrugated_rusty")
    y = m.specular.astype(np.float64) @ LUMA
    metal = y >= DIELECTRIC_MAX
    assert 0.1 < metal.mean() < 0.9
    g = GreySpecular(1.0).apply(m, seed)
    assert np.array_equal(g.specular[metal], m.specular[metal])
    d = g.specular[~metal]
    assert np.ptp(d) == 0.0 and d[0, 0] == pytest.approx(y[~metal].mean(), rel=1e-6)


def test_share_draws_from_the_variants_own_stream():
    """At share 0.5 about half the default library's variants are chosen (binomial, 4 sigma); at 0 none and at 1
    all; an imported material's variant (``modes`` False) is never changed."""
    specs = list(plan(build(SampleConfig)))
    n = len(specs)
    hits = sum(GreySpecular(0.5).chosen(s.seed) for s in specs)
    assert abs(hits - n / 2) < 4 * np.sqrt(n / 4), (hits, n)
    assert not any(GreySpecular(0.0).chosen(s.seed) for s in specs[:50])
    assert all(GreySpecular(1.0).chosen(s.seed) for s in specs[:50])
    m, seed = variant("ceramic_tiles/red_brick")
    assert GreySpecular(1.0).apply(m, seed, modes=False) is m


def test_off_by_default_and_left_out_of_the_recorded_config():
    """At 0 the key is dropped from the recorded config, so a default store keeps its config hash and bytes."""
    assert build(SampleConfig).grey_specular == 0.0
    assert "grey_specular" in build(SampleConfig).dropped_keys()
    assert "grey_specular" not in build(SampleConfig, grey_specular=0.5).dropped_keys()
    m, seed = variant("ceramic_tiles/red_brick")
    assert GreySpecular.of(build(SampleConfig)).apply(m, seed) is m
