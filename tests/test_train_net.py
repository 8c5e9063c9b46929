"""Network shapes per preset, output ranges, dropout only in training, global track matters."""
from __future__ import annotations

import pytest
import torch

from train.config import Config, ModelConfig, preset
from train.net import SVBRDFNet, log_map


@pytest.mark.parametrize("name", sorted(Config.PRESETS))
def test_shapes_per_preset(name):
    cfg = preset(name)
    torch.manual_seed(0)
    net = SVBRDFNet(cfg.model).eval()
    s = 2 ** cfg.model.levels  # the smallest input the depth allows (the paper preset: 256)
    with torch.no_grad():
        y = net(torch.rand(1, 3, s, s))
    assert y.shape == (1, 10, s, s)
    assert cfg.model.widths()[0] == (64 if name == "paper" else cfg.model.base_width)
    if name == "paper":
        assert cfg.model.widths() == [64, 128, 256, 512, 512, 512, 512, 512] and cfg.data.crop == 256


def test_outputs_in_range_and_unit_normals():
    net = SVBRDFNet(ModelConfig(base_width=4, max_width=16, levels=4)).eval()
    with torch.no_grad():
        y = net(torch.rand(2, 3, 32, 32))
    n = y[:, 0:3]
    torch.testing.assert_close(n.norm(dim=1), torch.ones(2, 32, 32))
    assert (n[:, 2] > 0).all()
    assert (y[:, 3:] >= 0).all() and (y[:, 3:] <= 1).all()


def test_dropout_only_in_training():
    torch.manual_seed(0)
    net = SVBRDFNet(ModelConfig(base_width=4, max_width=16, levels=4, dropout=0.5))
    x = torch.rand(1, 3, 32, 32)
    net.eval()
    with torch.no_grad():
        assert torch.equal(net(x), net(x))
    net.train()
    with torch.no_grad():
        assert not torch.equal(net(x), net(x))


def test_global_track_carries_image_statistics():
    """Through instance norm alone a constant gain would vanish; the global track must see it."""
    torch.manual_seed(0)
    net = SVBRDFNet(ModelConfig(base_width=4, max_width=16, levels=3)).eval()
    x = torch.rand(1, 3, 16, 16) * 0.3
    with torch.no_grad():
        net.out_conv.weight.zero_()  # drop the input skip: only normalised features + global biases remain
        a, b = net(x), net(x * 3.0)
        assert (a - b).abs().max() > 1e-6
        for m in net.modules():  # control: cut the global->local biases and the difference vanishes
            if hasattr(m, "to_bias"):
                m.to_bias.weight.zero_()
        net.out_bias.weight.zero_()
        a, b = net(x), net(x * 3.0)
    assert (a - b).abs().max() < 1e-7


def test_log_map_range():
    x = torch.tensor([0.0, 1.0, 2.0, -1.0])
    torch.testing.assert_close(log_map(x), torch.tensor([0.0, 1.0, 1.0, 0.0]))


@pytest.mark.parametrize("zero_output", [True, False])
def test_untrained_network_predicts_its_initial_material(zero_output):
    """The output biases are a plausible material (flat normal, INIT_*); with zero_output the untrained network
    predicts exactly that, up to the small global-bias term; with random output weights it varies per pixel."""
    from train.net import INIT_DIFFUSE, INIT_ROUGHNESS, INIT_SPECULAR

    torch.manual_seed(0)
    net = SVBRDFNet(ModelConfig(base_width=4, max_width=16, levels=4, zero_output=zero_output)).eval()
    with torch.no_grad():
        y = net(torch.rand(2, 3, 32, 32))
    init = torch.tensor([0.0, 0.0, 1.0, *[INIT_DIFFUSE] * 3, *[INIT_SPECULAR] * 3, INIT_ROUGHNESS])
    err = (y - init[None, :, None, None]).abs().amax((0, 2, 3))
    spread = y.std((2, 3)).amax()
    if zero_output:
        assert err.max() < 0.02 and spread < 1e-6, (err, spread)  # out_bias weights have std 0.01
    else:
        assert spread > 1e-3, spread


def test_shape_flags_give_unit_normals_and_start_flat():
    """Unit normals with z > 0, a flat start under zero_output, and the output layer actually in the normal's path
    (a gradient reaches it)."""
    cfg = ModelConfig(base_width=4, max_width=16, levels=4, zero_output=True)
    torch.manual_seed(0)
    net = SVBRDFNet(cfg)
    y = net(torch.rand(2, 3, 32, 32))
    n = y[:, 0:3]
    torch.testing.assert_close(n.norm(dim=1), torch.ones(2, 32, 32))
    assert (n[:, 2] > 0.999).all()  # flat at the start, up to the small global output bias
    y[:, 0:2].sum().backward()
    assert any(p.grad is not None and p.grad.abs().sum() > 0 for p in net.out_conv.parameters())
