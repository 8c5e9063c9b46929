"""The specular-copy statistics (#39 deliverable 3): a grey constant specular scores as grey and unrelated, a copy
of the diffuse map as a copy, an independent map as independent."""
from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from train.brdf import DIFFUSE, SPECULAR
from train.spec_stats import CHROMA, CORRELATION, chroma, correlation, quartiles, spec_stats

N = 64  # 64 x 64 pixels per map


def packed(diffuse: torch.Tensor, specular: torch.Tensor) -> torch.Tensor:
    """(B, 3, H, W) diffuse and specular -> (B, 10, H, W) packed maps (flat normal, mid roughness)."""
    b, _, h, w = diffuse.shape
    maps = torch.zeros(b, 10, h, w)
    maps[:, 2] = 1.0
    maps[:, DIFFUSE], maps[:, SPECULAR] = diffuse, specular
    maps[:, 9] = 0.5
    return maps


@pytest.fixture
def diffuse():
    """A coloured, textured albedo: each channel its own random field."""
    return torch.rand(2, 3, N, N, generator=torch.Generator().manual_seed(0)) * 0.8 + 0.05


def test_a_grey_constant_specular_scores_chroma_0_and_correlation_0(diffuse):
    s = spec_stats(packed(diffuse, torch.full_like(diffuse, 0.04)))
    np.testing.assert_array_equal(s[CHROMA], 0.0)
    np.testing.assert_array_equal(s[CORRELATION], 0.0)  # undefined for a constant map: defined as 0


def test_a_grey_textured_specular_has_chroma_0_whatever_its_texture(diffuse):
    grey = diffuse.mean(1, keepdim=True).expand(-1, 3, -1, -1)  # follows the albedo, but grey
    s = spec_stats(packed(diffuse, grey))
    np.testing.assert_allclose(s[CHROMA], 0.0, atol=1e-7)
    assert (s[CORRELATION] > 0.5).all()  # copied texture shows in the correlation even without colour


@pytest.mark.parametrize("scale", [1.0, 0.3])
def test_a_copy_of_the_diffuse_map_scores_as_a_copy(diffuse, scale):
    """A copy, or a darker copy, correlates 1 and has the diffuse map's own chroma."""
    s = spec_stats(packed(diffuse, scale * diffuse))
    np.testing.assert_allclose(s[CORRELATION], 1.0, atol=1e-9)
    np.testing.assert_allclose(s[CHROMA], chroma(diffuse).numpy(), rtol=1e-9)
    assert (s[CHROMA] > 0.2).all()  # the copied colours are there to see
    np.testing.assert_allclose(correlation(1.0 - diffuse, diffuse).numpy(), -1.0, atol=1e-9)  # an inverted copy


def test_an_independent_specular_scores_near_0(diffuse):
    """Over n = 4096 pixels of independent maps, the sample correlation has standard deviation 1/sqrt(n) = 0.016;
    |r| < 5/sqrt(n) = 0.078 fails by chance with probability 6e-7 (and the seed is fixed)."""
    spec = torch.rand(2, 3, N, N, generator=torch.Generator().manual_seed(1))
    r = spec_stats(packed(diffuse, spec))[CORRELATION]
    assert (np.abs(r) < 5 / math.sqrt(N * N)).all(), r


def test_chroma_of_known_pixels():
    """Per pixel std / mean over R, G, B (std over the three values), averaged over pixels."""
    rgb = torch.tensor([[1.0, 0.0, 0.0], [0.2, 0.2, 0.2]]).T.reshape(1, 3, 1, 2)  # one red, one grey pixel
    np.testing.assert_allclose(chroma(rgb).numpy(), [math.sqrt(2) / 2], rtol=1e-12)


def test_quartiles():
    assert quartiles([4, 1, 3, 2, 5]) == {"q25": 2.0, "median": 3.0, "q75": 4.0}
