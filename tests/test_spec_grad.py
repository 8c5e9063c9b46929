"""``optim.spec_grad`` (#39, round 9): an L1 term on the specular map's neighbour differences, predicted against
true. It prices texture the truth lacks, leaves the specular's level to the other terms, and adds exactly its
weight times its value to the training loss."""
from __future__ import annotations

import pytest
import torch

from train.brdf import SPECULAR
from train.config import OptimConfig
from train.fit import loss_terms, spec_grad_term


def maps_pair(seed: int = 0) -> tuple[torch.Tensor, torch.Tensor]:
    g = torch.Generator().manual_seed(seed)
    return torch.rand(2, 10, 8, 8, generator=g), torch.rand(2, 10, 8, 8, generator=g)


def test_texture_costs_and_level_does_not():
    """A constant true specular: the same map shifted costs 0, a column ramp of slope s costs s / 2 (the row
    differences are 0, the column differences s; the term averages both directions); the other maps are ignored."""
    t, p = maps_pair()
    t[:, SPECULAR] = 0.04
    p[:, SPECULAR] = 0.3  # a wrong level, no texture
    assert float(spec_grad_term(p, t)) == 0.0
    s = 0.01
    p[:, SPECULAR] = 0.04 + s * torch.arange(8.0)  # along columns: the last axis
    assert float(spec_grad_term(p, t)) == pytest.approx(s / 2, rel=1e-5)
    # the truth's own texture, predicted, costs nothing; the ramp moved to the truth costs the same
    assert float(spec_grad_term(p, p.clone())) == 0.0
    assert float(spec_grad_term(t, p)) == pytest.approx(s / 2, rel=1e-5)
    # rows: the ramp turned by 90 degrees costs the same
    assert float(spec_grad_term(p.transpose(-1, -2), t)) == pytest.approx(s / 2, rel=1e-5)
    # a truth textured in both directions: predicted exactly, or at another level, it costs nothing
    _, r = maps_pair(3)
    assert float(spec_grad_term(r.clone(), r)) == 0.0
    assert float(spec_grad_term(r + 0.25, r)) == pytest.approx(0.0, abs=1e-6)


def test_the_loss_adds_weight_times_the_term_and_nothing_at_zero():
    t, p = maps_pair(1)
    base = OptimConfig(render_weight=0.0, map_l1=0.1, normal_l2=0.0)
    g = torch.Generator().manual_seed(0)
    without = float(loss_terms(p, t, None, g, base))
    with_term = float(loss_terms(p, t, None, g, base.model_copy(update={"spec_grad": 4.0})))
    assert with_term - without == pytest.approx(4.0 * float(spec_grad_term(p, t)), rel=1e-5)
    assert base.spec_grad == 0.0 and without == pytest.approx(0.1 * float((p - t).abs().mean()), rel=1e-6)


def test_descending_the_term_flattens_a_copied_texture():
    """Gradient steps on the term alone remove a texture the truth does not have and keep the specular's mean."""
    t, p = maps_pair(2)
    t[:, SPECULAR] = 0.04
    p = p.clone().requires_grad_(True)
    mean0 = float(p.detach()[:, SPECULAR].mean())
    opt = torch.optim.SGD([p], lr=2.0)
    for _ in range(200):
        opt.zero_grad()
        spec_grad_term(p, t).backward()
        opt.step()
    assert float(spec_grad_term(p.detach(), t)) < 0.2 * float(spec_grad_term(maps_pair(2)[1], t))
    assert float(p.detach()[:, SPECULAR].mean()) == pytest.approx(mean0, abs=1e-4)
