"""Training: a tiny fit lowers the loss; resume after an interruption equals the uninterrupted run."""
from __future__ import annotations

import json

import pytest
import torch

from svcore.errors import ConfigError
from train.config import resolve
from train.fit import build, fit, lr_at, train_step
from train.loss import make_loss
from train.synthetic import SyntheticSource

TINY = {"model.base_width": 4, "model.max_width": 16, "model.levels": 4, "data.crop": 32, "data.workers": 0,
        "optim.compile_loss": False, "optim.batch_size": 4, "optim.checkpoint_every": 3, "optim.log_every": 2}


@pytest.fixture(scope="module")
def src():
    return SyntheticSource(16, 40, 4, seed=2)


def fixed_batch(src, n: int) -> tuple[torch.Tensor, torch.Tensor]:
    """The top-left 32² of the first ``n`` samples: (n, 3, 32, 32) images and (n, 10, 32, 32) maps."""
    img = torch.stack([torch.from_numpy(src.image(i)[:32, :32]).permute(2, 0, 1) for i in range(n)])
    maps = torch.stack([torch.from_numpy(src.packed(i)[:32, :32]).permute(2, 0, 1) for i in range(n)])
    return img, maps


def test_tiny_fit_lowers_loss_on_fixed_batch(src):
    cfg = resolve("compact", None, {**TINY, "optim.lr": 2e-3, "model.dropout": 0.0})
    model, opt, gen = build(cfg)
    loss_fn = make_loss(False)
    img, maps = fixed_batch(src, 4)
    eval_gen = lambda: torch.Generator().manual_seed(123)  # noqa: E731  same configs before/after
    with torch.no_grad():
        before = loss_fn(model(img), maps, eval_gen()).item()
    for _ in range(40):
        loss = loss_fn(model(img), maps, gen)
        opt.zero_grad()
        loss.backward()
        opt.step()
    with torch.no_grad():
        after = loss_fn(model(img), maps, eval_gen()).item()
    assert after < 0.8 * before


@pytest.mark.parametrize("optim", [{"optim.schedule": "constant", "optim.grad_clip": 0.0},
                                   {"optim.schedule": "cosine", "optim.grad_clip": 0.05}], ids=["constant", "cosine_clip"])
def test_resume_equals_uninterrupted(src, tmp_path, optim, monkeypatch):
    cfg = resolve("compact", None, {**TINY, **optim, "optim.iterations": 8})
    full = fit(cfg, tmp_path / "a", source=src)
    fit(cfg, tmp_path / "b", source=src, stop_after=4)  # "interrupted" after 4 steps (checkpoint at 3 and 4)
    ck = torch.load(tmp_path / "b" / "checkpoint.pt", weights_only=False)
    assert ck["step"] == 4
    import train.fit as fit_module

    steps, real_step = [], fit_module.train_step

    def counted(*args, **kw):  # the real step, recording its index: the rerun must start at the checkpoint's step
        steps.append(args[7])  # train_step(model, opt, loss_fn, image, maps, gen, o, step, ...)
        return real_step(*args, **kw)

    monkeypatch.setattr(fit_module, "train_step", counted)
    resumed = fit(cfg, tmp_path / "b", source=src)
    assert steps == [4, 5, 6, 7], f"the resumed run ran steps {steps}, not 4..7 from its checkpoint"
    monkeypatch.setattr(fit_module, "train_step", real_step)
    a = torch.load(tmp_path / "a" / "model.pt", weights_only=False)["model"]
    b = torch.load(tmp_path / "b" / "model.pt", weights_only=False)["model"]
    for k in a:
        assert torch.equal(a[k], b[k]), k
    assert full["loss_final"] == resumed["loss_final"]
    # a different seed gives a different run (the check above can fail)
    other = fit(resolve("compact", None, {**TINY, **optim, "optim.iterations": 8, "optim.seed": 1}), tmp_path / "c",
                source=src)
    assert other["loss_final"] != full["loss_final"]


def test_outputs_written(src, tmp_path):
    cfg = resolve("compact", None, {**TINY, "optim.iterations": 5})
    fit(cfg, tmp_path, source=src)
    for name in ("config.yaml", "checkpoint.pt", "model.pt", "metrics.json", "loss.csv", "loss.png"):
        assert (tmp_path / name).is_file(), name
    m = json.loads((tmp_path / "metrics.json").read_text())
    assert m["step"] == 5 and m["done"] and "it_per_s" not in m  # the clock is timing.json's (not a DVC output)
    assert json.loads((tmp_path / "timing.json").read_text())["it_per_s"] > 0
    rows = (tmp_path / "loss.csv").read_text().splitlines()
    assert rows[0] == "step,loss" and rows[-1].startswith("5,")


def test_lr_schedule():
    o = resolve("compact", None, {"optim.lr": 1e-3, "optim.iterations": 101, "optim.schedule": "cosine",
                                  "optim.lr_final": 0.1}).optim
    lrs = [lr_at(o, t) for t in range(o.iterations)]
    assert lrs[0] == pytest.approx(1e-3) and lrs[-1] == pytest.approx(1e-4)
    assert lrs[50] == pytest.approx(0.55e-3)  # halfway: the mean of the two ends
    assert all(a >= b for a, b in zip(lrs, lrs[1:]))
    o.schedule = "constant"
    assert {lr_at(o, t) for t in range(o.iterations)} == {1e-3}


def test_grad_clip_bounds_the_gradient(src):
    """After a clipped step the gradient's global norm is the clip value; unclipped it is larger (can fail)."""
    img, maps = fixed_batch(src, 2)
    norms = {}
    for clip in (0.0, 1e-3):
        cfg = resolve("compact", None, {**TINY, "optim.grad_clip": clip})
        model, opt, gen = build(cfg)
        _, before = train_step(model, opt, make_loss(False), img, maps, gen, cfg.optim, 0)
        after = torch.linalg.vector_norm(torch.stack([p.grad.norm() for p in model.parameters() if p.grad is not None]))
        norms[clip] = (before, float(after))
    assert norms[0.0][0] == pytest.approx(norms[0.0][1], rel=1e-5) and norms[0.0][1] > 1e-2
    assert norms[1e-3][0] == pytest.approx(norms[0.0][0], rel=1e-5)  # same init, same batch: same raw gradient
    assert norms[1e-3][1] == pytest.approx(1e-3, rel=1e-3)


def test_map_l1_adds_the_map_term(src):
    """optim.map_l1 = w adds w x mean |pred - maps| to the rendering loss (same init, batch, configs, dropout)."""
    img, maps = fixed_batch(src, 2)
    losses = {}
    for w in (0.0, 0.5):
        cfg = resolve("compact", None, {**TINY, "optim.map_l1": w})
        model, opt, gen = build(cfg)
        losses[w], _ = train_step(model, opt, make_loss(False), img, maps, gen, cfg.optim, 0)
    model, _, _ = build(cfg)  # the same weights and dropout stream as the steps above
    with torch.no_grad():
        expected = 0.5 * float((model.train()(img) - maps).abs().mean())
    assert expected > 1e-3
    assert losses[0.5] - losses[0.0] == pytest.approx(expected, rel=1e-4)


def test_normal_l2_adds_a_squared_term_on_the_normals_only(src):
    """optim.normal_l2 = w adds w x mean (pred_xy - maps_xy)² to the rendering loss; the other maps get no gradient
    from it (the output layer's rows for diffuse, specular and roughness see the same gradient with and without)."""
    img, maps = fixed_batch(src, 2)
    losses, grads = {}, {}
    for w in (0.0, 3.0):
        # no clipping: a clipped gradient is rescaled by the total norm, which the extra term changes
        cfg = resolve("compact", None, {**TINY, "optim.normal_l2": w, "optim.normal_loss": "l2",
                                        "model.zero_output": False, "optim.grad_clip": 0.0})
        model, opt, gen = build(cfg)
        losses[w], _ = train_step(model, opt, make_loss(False), img, maps, gen, cfg.optim, 0)
        grads[w] = model.out_conv.weight.grad.clone()
    model, _, _ = build(cfg)
    with torch.no_grad():
        expected = 3.0 * float(((model.train()(img)[:, 0:2] - maps[:, 0:2]) ** 2).mean())
    assert expected > 1e-4
    assert losses[3.0] - losses[0.0] == pytest.approx(expected, rel=1e-4)
    assert torch.allclose(grads[3.0][2:], grads[0.0][2:], rtol=1e-4, atol=1e-7)
    assert not torch.allclose(grads[3.0][0:2], grads[0.0][0:2], rtol=1e-2, atol=1e-6)


def test_a_run_records_its_data_preset_and_library_versions(src, tmp_path):
    """Stores record versions and seeds; a training run records the same about itself (provenance.json, model.pt)."""
    import importlib.metadata as md

    cfg = resolve("compact", None, {**TINY, "optim.iterations": 1})
    fit(cfg, tmp_path / "run", source=src, show_progress=False)
    prov = json.loads((tmp_path / "run" / "provenance.json").read_text())
    assert prov["config_preset"] == "compact"
    assert prov["data"]["synthetic"] == {"samples": 16, "size": 40, "materials": 4, "seed": 2, "kind": "simple"}
    assert prov["versions"]["torch"] == md.version("torch") and prov["versions"]["numpy"] == md.version("numpy")
    assert torch.load(tmp_path / "run" / "model.pt", weights_only=False)["provenance"] == prov


def test_resume_if_unchanged_continues_only_the_same_run(src, tmp_path):
    """DVC's fit stage (``--resume-if-unchanged``; its checkpoint persists): a checkpoint of the same config, data
    and code is continued from its step; one trained with another config is not, and the run starts over."""
    cfg = resolve("compact", None, {**TINY, "optim.iterations": 6})
    fit(cfg, tmp_path / "a", source=src, stop_after=3)
    same = fit(cfg, tmp_path / "a", source=src, resume="if-unchanged")
    assert same["resumed_from"] == 3
    # another lr: the old checkpoint (its model config is the same, so a plain resume would continue it) is stale
    other = resolve("compact", None, {**TINY, "optim.iterations": 6, "optim.lr": 2.5e-4})
    fit(other, tmp_path / "b", source=src, stop_after=3)
    restarted = fit(cfg, tmp_path / "b", source=src, resume="if-unchanged")
    assert restarted["resumed_from"] is None
    fresh = fit(cfg, tmp_path / "c", source=src, resume=False)
    assert restarted["loss_final"] == fresh["loss_final"] == same["loss_final"]
    # the plain resume refuses it, naming what changed (issue #25 item 1); resume=False starts over
    fit(other, tmp_path / "d", source=src, stop_after=3)
    with pytest.raises(ConfigError, match=r"optim.lr 0.00025 -> 0.0005\).*--no-resume"):
        fit(cfg, tmp_path / "d", source=src)


def test_a_key_added_since_a_checkpoint_counts_as_its_default(src, tmp_path):
    """A checkpoint written before a config key existed resumes when this run keeps that key's default (a new key's
    default is the behaviour from before it), and is refused, naming the key, when the run sets another value."""
    import torch

    cfg = resolve("compact", None, {**TINY, "optim.iterations": 6})
    fit(cfg, tmp_path / "a", source=src, stop_after=3)
    ck = tmp_path / "a" / "checkpoint.pt"
    state = torch.load(ck, map_location="cpu", weights_only=False)
    del state["config"]["optim"]["normal_late_weight"]  # as written by the code before the key
    torch.save(state, ck)
    assert fit(cfg, tmp_path / "a", source=src)["resumed_from"] == 3
    fit(cfg, tmp_path / "b", source=src, stop_after=3)
    state = torch.load(tmp_path / "b" / "checkpoint.pt", map_location="cpu", weights_only=False)
    del state["config"]["optim"]["normal_late_weight"]
    torch.save(state, tmp_path / "b" / "checkpoint.pt")
    other = resolve("compact", None, {**TINY, "optim.iterations": 6, "optim.normal_late_weight": 10.0})
    with pytest.raises(ConfigError, match=r"optim.normal_late_weight 30.0 -> 10.0"):
        fit(other, tmp_path / "b", source=src)


@pytest.fixture(scope="module")
def two_renders(tmp_path_factory):
    """Two renders stores of the same kind and size from the same variants, rendered with another render seed: the
    same SVBRDFs under other views, so other data with the same kind and sample count (only the config hash
    differs)."""
    from pipeline.config import RenderConfig, SampleConfig
    from pipeline.render.stage import run_render
    from pipeline.sample import run_sample
    from svcore.config import build

    d = tmp_path_factory.mktemp("renders")
    run_sample(d / "v.zarr", build(SampleConfig, "tiny", presets=("paint/glossy_red", "metal/aluminium_plate"),
                                   per_preset=2, size=64), workers=0)
    for seed in (0, 1):
        run_render(d / "v.zarr", d / f"r{seed}.zarr", build(RenderConfig, "tiny", res=32, views=2, chunk=2,
                                                            seed=seed), workers=0)
    return d / "r0.zarr", d / "r1.zarr"


def test_a_resume_on_a_store_rendered_with_another_config_is_refused(two_renders, tmp_path):
    """The checkpoint records which store it trained on by kind, config hash and size: a store of the same kind
    and size rendered with another config is other data, so a plain resume refuses it, naming both, and
    --resume-if-unchanged starts over."""
    import zarr

    a, b = two_renders
    meta = [dict(zarr.open_group(str(s), mode="r").attrs)["svgen"] for s in (a, b)]
    assert (meta[0]["kind"], meta[0]["n"]) == (meta[1]["kind"], meta[1]["n"])
    assert meta[0]["config_hash"] != meta[1]["config_hash"]
    over = {**TINY, "optim.iterations": 4, "optim.batch_size": 2, "data.holdout": 0.5}
    fit(resolve("compact", None, {**over, "data.store": str(a)}), tmp_path / "run", stop_after=2,
        show_progress=False)
    cfg_b = resolve("compact", None, {**over, "data.store": str(b)})
    with pytest.raises(ConfigError, match=rf"config hash {meta[0]['config_hash']}\) -> .*config hash "
                                          rf"{meta[1]['config_hash']}\).*--no-resume"):
        fit(cfg_b, tmp_path / "run", show_progress=False)
    assert fit(cfg_b, tmp_path / "run", resume="if-unchanged", show_progress=False)["resumed_from"] is None

