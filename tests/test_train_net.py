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


@pytest.mark.parametrize("flags", [{}, {"normal_decoder": True}])
def test_shape_flags_give_unit_normals_and_start_flat(flags):
    """Unit normals with z > 0, a flat start under zero_output, and the layer that gives the normal (the output
    layer, or the normal decoder) actually in the normal's path (a gradient reaches it)."""
    cfg = ModelConfig(base_width=4, max_width=16, levels=4, zero_output=True, **flags)
    torch.manual_seed(0)
    net = SVBRDFNet(cfg)
    y = net(torch.rand(2, 3, 32, 32))
    n = y[:, 0:3]
    torch.testing.assert_close(n.norm(dim=1), torch.ones(2, 32, 32))
    assert (n[:, 2] > 0.999).all()  # flat at the start, up to the small global output bias
    y[:, 0:2].sum().backward()
    part = net.normal_decoder if flags.get("normal_decoder") else net.out_conv
    assert any(p.grad is not None and p.grad.abs().sum() > 0 for p in part.parameters())


def test_pixel_coords_span_the_image_given():
    """x along the columns, y along the rows, at the pixel centres in (-1, 1), whatever the image's size: a crop
    gets the coordinates of a whole photo of its size, not of its place in the view."""
    from train.net import pixel_coords

    c = pixel_coords(torch.rand(2, 3, 2, 4))
    assert c.shape == (2, 2, 2, 4)
    torch.testing.assert_close(c[1, 0], torch.tensor([[-0.75, -0.25, 0.25, 0.75]] * 2))
    torch.testing.assert_close(c[1, 1], torch.tensor([[-0.5] * 4, [0.5] * 4]))


def test_coord_channels_reach_the_first_and_the_output_layer():
    """model.coord_channels: the two channels enter the first encoder convolution and the output layer (the full-
    resolution skip), and the network's output depends on them."""
    torch.manual_seed(0)
    net = SVBRDFNet(ModelConfig(base_width=4, max_width=16, levels=3, coord_channels=True))
    assert net.enc[0].conv.in_channels == 5 and net.out_conv.in_channels == 4 + 5
    x = torch.rand(1, 3, 16, 16)
    net(x).sum().backward()
    assert net.enc[0].conv.weight.grad[:, 3:].abs().sum() > 0 and net.out_conv.weight.grad[:, -2:].abs().sum() > 0
    with torch.no_grad():
        a = net(x)
        net.out_conv.weight[:, -2:] = 0
        net.enc[0].conv.weight[:, 3:] = 0
        assert (net(x) - a).abs().max() > 1e-4  # the coordinates were in use


def test_normal_decoder_alone_gives_the_normal():
    """model.normal_decoder: the normal comes from the second decoder only, the other maps from the main one."""
    torch.manual_seed(0)
    net = SVBRDFNet(ModelConfig(base_width=4, max_width=16, levels=3, normal_decoder=True)).eval()
    assert net.out_conv.out_channels == 7 and net.normal_decoder.out_conv.out_channels == 2
    x = torch.rand(1, 3, 16, 16)
    with torch.no_grad():
        a = net(x)
        net.out_conv.weight.mul_(2.0)  # the main decoder changes: every map but the normal changes
        b = net(x)
        torch.testing.assert_close(a[:, 0:3], b[:, 0:3], rtol=0, atol=0)
        assert (a[:, 3:] - b[:, 3:]).abs().max() > 1e-4
        net.normal_decoder.out_conv.weight.mul_(2.0)  # the normal decoder changes: only the normal changes
        c = net(x)
        torch.testing.assert_close(b[:, 3:], c[:, 3:], rtol=0, atol=0)
        assert (b[:, 0:3] - c[:, 0:3]).abs().max() > 1e-4


def test_the_options_add_only_the_normal_decoders_parameters():
    """With the options off there is no trace of them in the weights (the bundled model loads as it always did)."""
    torch.manual_seed(0)
    plain = SVBRDFNet(ModelConfig(base_width=4, max_width=16, levels=3))
    torch.manual_seed(0)
    both = SVBRDFNet(ModelConfig(base_width=4, max_width=16, levels=3, coord_channels=True, normal_decoder=True))
    assert not any(k.startswith("normal_decoder") for k in plain.state_dict())
    extra = set(both.state_dict()) - set(plain.state_dict())
    assert extra and all(k.startswith("normal_decoder.") for k in extra)


@pytest.mark.parametrize("global_track", [True, False])
def test_a_grown_normal_decoder_starts_as_the_network_it_grew_from(global_track):
    """``grow_normal_decoder``: a trained one-decoder network's weights -> the two-decoder network with the same
    maps (the paired fine-tune arm starts from the control's model). Random output layers, so every map depends on
    every copied weight; eval mode (dropout off)."""
    from train.net import grow_normal_decoder

    cfg = dict(base_width=4, max_width=16, levels=3, zero_output=False, global_track=global_track)
    torch.manual_seed(0)
    one = SVBRDFNet(ModelConfig(**cfg)).eval()
    two = SVBRDFNet(ModelConfig(**cfg, normal_decoder=True)).eval()
    two.load_state_dict(grow_normal_decoder(one.state_dict()))  # strict: every key present, none left over
    x = torch.rand(2, 3, 32, 32, generator=torch.Generator().manual_seed(1))
    with torch.no_grad():
        a, b = one(x), two(x)
    assert a[:, 0:2].abs().max() > 1e-3  # the normal is not flat: its copy is tested, not two zeros
    torch.testing.assert_close(b, a, rtol=0, atol=1e-6)


def test_fit_init_grows_a_normal_decoder_from_a_one_decoder_run(tmp_path):
    """``svtrain fit --init RUN --set model.normal_decoder=true`` accepts a one-decoder run (any other model change
    is still refused) and its first model is the run's model grown."""
    from svcore.errors import SvgenError
    from train.checkpoint import init_weights
    from train.config import resolve
    from train.net import grow_normal_decoder

    small = {"model.base_width": 4, "model.max_width": 16, "model.levels": 3, "model.zero_output": False}
    torch.manual_seed(0)
    base = resolve("compact", None, small)
    net = SVBRDFNet(base.model)
    from train.checkpoint import FORMAT

    torch.save({"format": FORMAT, "model": net.state_dict(), "config": base.to_dict()}, tmp_path / "one.pt")
    grown = resolve("compact", None, {**small, "model.normal_decoder": True, "optim.init": str(tmp_path / "one.pt")})
    got = init_weights(grown.optim.init, grown.model)
    want = grow_normal_decoder(net.state_dict())
    assert got.keys() == want.keys() and all(torch.equal(got[k], want[k]) for k in want)
    other = resolve("compact", None, {**small, "model.normal_decoder": True, "model.levels": 4,
                                      "optim.init": str(tmp_path / "one.pt")})
    with pytest.raises(SvgenError, match="model.levels"):
        init_weights(other.optim.init, other.model)


def test_grown_coordinate_channels_start_as_the_network_they_grew_from(tmp_path):
    """``grow_input_channels`` (``svtrain fit --init`` with model.coord_channels): the grown network's maps equal the
    original's for any coordinates (zero weights on them), every photo-fed layer grew, and training can move the
    new weights (they get gradients). ``init_weights`` grows them from a checkpoint and still refuses other changes."""
    from svcore.errors import SvgenError
    from train.checkpoint import FORMAT, init_weights
    from train.config import resolve
    from train.net import grow_input_channels

    small = {"model.base_width": 4, "model.max_width": 16, "model.levels": 3, "model.zero_output": False}
    torch.manual_seed(0)
    base = resolve("compact", None, small)
    one = SVBRDFNet(base.model).eval()
    torch.save({"format": FORMAT, "model": one.state_dict(), "config": base.to_dict()}, tmp_path / "one.pt")
    grown_cfg = resolve("compact", None, {**small, "model.coord_channels": True,
                                          "optim.init": str(tmp_path / "one.pt")})
    rng_before = torch.get_rng_state()
    weights = init_weights(grown_cfg.optim.init, grown_cfg.model)
    assert torch.equal(torch.get_rng_state(), rng_before)  # building the shapes drew no random numbers
    two = SVBRDFNet(grown_cfg.model).eval()
    two.load_state_dict(weights)  # strict: every key present with its grown shape
    grew = [k for k in weights if weights[k].shape != one.state_dict()[k].shape]
    assert len(grew) == 2  # the first encoder conv and the output layer
    x = torch.rand(2, 3, 32, 32, generator=torch.Generator().manual_seed(1))
    xy = torch.rand(2, 2, 32, 32, generator=torch.Generator().manual_seed(2)) * 2 - 1
    with torch.no_grad():
        a = one(x)
        torch.testing.assert_close(two(x), a, rtol=0, atol=1e-6)
        torch.testing.assert_close(two(x, xy), a, rtol=0, atol=1e-6)
    two.train()
    two(x, xy).sum().backward()
    assert two.enc[0].conv.weight.grad[:, 3:].abs().sum() > 0
    with pytest.raises(ValueError, match="cannot grow"):
        grow_input_channels({"enc.0.conv.weight": torch.zeros(4, 3, 4, 4)},
                            {"enc.0.conv.weight": torch.zeros(4, 6, 4, 4)}, 2)
    other = resolve("compact", None, {**small, "model.coord_channels": True, "model.levels": 4,
                                      "optim.init": str(tmp_path / "one.pt")})
    with pytest.raises(SvgenError, match="model.levels"):
        init_weights(other.optim.init, other.model)


def test_given_view_coordinates_replace_the_photos_own():
    """``forward(image, coords)``: a training crop's view coordinates are what the network sees (not the crop's
    own grid); None gives the whole photo's (inference)."""
    from train.net import pixel_coords

    torch.manual_seed(0)
    net = SVBRDFNet(ModelConfig(base_width=4, max_width=16, levels=3, coord_channels=True)).eval()
    x = torch.rand(1, 3, 16, 16)
    with torch.no_grad():
        own = net(x)
        torch.testing.assert_close(net(x, pixel_coords(x)), own, rtol=0, atol=0)
        assert (net(x, 0.5 * pixel_coords(x)) - own).abs().max() > 1e-5


def test_the_highlight_cue_keeps_small_white_detail_only():
    """model.highlight_cue: on a grey photo, a white spot narrower than the window shows in the cue; a red spot of
    the same size (albedo colour: the darkest channel does not see it) and a white plateau wider than the window
    (the flash's broad highlight) do not."""
    from train.net import HIGHLIGHT_WINDOW, highlight_cue, log_map

    img = torch.full((1, 3, 48, 48), 0.2)
    img[:, :, 8:10, 8:10] += 0.3  # white spot, 2 px
    img[:, 0, 8:10, 30:32] += 0.3  # red spot, 2 px
    w = HIGHLIGHT_WINDOW + 7
    img[:, :, 30:30 + w, 20:20 + w] += 0.3  # white plateau wider than the window
    cue = highlight_cue(log_map(img))
    assert cue.shape == (1, 1, 48, 48) and (cue >= 0).all()
    spot = float(log_map(torch.tensor(0.5)) - log_map(torch.tensor(0.2)))
    torch.testing.assert_close(cue[0, 0, 8:10, 8:10], torch.full((2, 2), spot), rtol=0, atol=1e-6)
    rest = cue.clone()
    rest[..., 8:10, 8:10] = 0
    assert rest.abs().max() < 1e-6  # the red spot, the plateau and the grey background give nothing


def test_the_highlight_cue_reaches_the_network_and_grows_from_a_model_without_it(tmp_path):
    """The cue enters the first encoder convolution and the output layer, after the coordinates; ``init_weights``
    grows a model without it (and one with coordinates only) with zero weights: the same maps at step 0; it
    refuses to grow coordinates in front of a cue."""
    from svcore.errors import SvgenError
    from train.checkpoint import FORMAT, init_weights
    from train.config import resolve

    small = {"model.base_width": 4, "model.max_width": 16, "model.levels": 3, "model.zero_output": False}
    x = torch.rand(2, 3, 32, 32, generator=torch.Generator().manual_seed(1))
    for before, after, cin in (({}, {"model.highlight_cue": True}, 4),
                               ({"model.coord_channels": True}, {"model.coord_channels": True,
                                                                 "model.highlight_cue": True}, 6),
                               ({}, {"model.coord_channels": True, "model.highlight_cue": True}, 6)):
        torch.manual_seed(0)
        base = resolve("compact", None, {**small, **before})
        one = SVBRDFNet(base.model).eval()
        torch.save({"format": FORMAT, "model": one.state_dict(), "config": base.to_dict()}, tmp_path / "one.pt")
        grown = resolve("compact", None, {**small, **after, "optim.init": str(tmp_path / "one.pt")})
        two = SVBRDFNet(grown.model).eval()
        assert two.enc[0].conv.in_channels == cin and two.out_conv.in_channels == 4 + cin
        two.load_state_dict(init_weights(grown.optim.init, grown.model))
        with torch.no_grad():
            torch.testing.assert_close(two(x), one(x), rtol=0, atol=1e-6)
        two.train()
        two(x).sum().backward()
        assert two.enc[0].conv.weight.grad[:, -1].abs().sum() > 0  # training moves the cue's weights
    torch.manual_seed(0)
    cue_only = resolve("compact", None, {**small, "model.highlight_cue": True})
    torch.save({"format": FORMAT, "model": SVBRDFNet(cue_only.model).state_dict(), "config": cue_only.to_dict()},
               tmp_path / "cue.pt")
    both = resolve("compact", None, {**small, "model.coord_channels": True, "model.highlight_cue": True,
                                     "optim.init": str(tmp_path / "cue.pt")})
    with pytest.raises(SvgenError, match="cannot be grown"):
        init_weights(both.optim.init, both.model)
