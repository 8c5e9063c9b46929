"""The model shipped in the package (train/bundled/): predict without --checkpoint, eval and fit --init by name,
one line for a damaged or missing file, the input check of photos far from the training ones, and `svtrain bundle`
writing a model with its card."""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import torch
import yaml
from PIL import Image

from pipeline.config import RenderConfig, SampleConfig
from pipeline.render.stage import run_render
from pipeline.sample import run_sample
from svcore.config import build
from train import bundle, bundled_model, checkpoint
from train.config import preset
from train.data import PairDataset, open_source, split_for
from train.evaluate import evaluate, means_from_record
from train.fit import Trainer

from test_train_cli import run  # noqa: E402  (one svtrain-in-process helper)
from test_train_predict import SMALL

REPO = Path(__file__).resolve().parents[1]
BUNDLED = REPO / "train" / "bundled"


@pytest.fixture(scope="module")
def renders(tmp_path_factory):
    """A renders store at 128² (the bundled model's crop): 2 presets x 2 variants x 2 views, in-process."""
    d = tmp_path_factory.mktemp("store")
    run_sample(d / "v.zarr", build(SampleConfig, "tiny", presets=("paint/glossy_red", "metal/aluminium_plate"),
                                   per_preset=2, size=128), workers=0)
    run_render(d / "v.zarr", d / "r.zarr", build(RenderConfig, "tiny", res=128, chunk=2), workers=0)
    return d / "r.zarr"


def _flash(h=256, w=256, gain=1.0, flash=True, seed=0) -> np.ndarray:
    """A linear photo of a textured sample: a centred flash lobe (or even light) times a texture, times gain."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:h, 0:w] / h - 0.5
    light = 1.0 / (1.0 + (xx ** 2 + yy ** 2) / 0.02) if flash else np.full((h, w), 0.35)
    return np.clip(gain * light[..., None] * rng.uniform(0.3, 0.9, (h, w, 3)), 0, 1).astype(np.float32)


def _save_srgb(path: Path, linear: np.ndarray) -> Path:
    from svcore.image_io import srgb_encode

    Image.fromarray((255 * srgb_encode(linear) + 0.5).astype(np.uint8)).save(path)
    return path


# -- the shipped files ------------------------------------------------------------------------------------------
def test_the_shipped_model_is_weights_only_small_and_matches_its_manifest():
    path = bundled_model.model_path()  # size and SHA-256 checked against bundled.json
    assert path == BUNDLED / "model.pt"
    state = torch.load(path, map_location="cpu", weights_only=True)  # torch's restricted unpickler accepts it
    assert set(state) >= {"config", "model", "step", "provenance", "network_format"} and "optim" not in state
    # a few MB: the compact network's float32 weights (2.4 M parameters at width 16: 9.5 MB); the wheel's 20 MB
    # bar is measured by benchmarks/bench_bundled.py
    assert path.stat().st_size < 12e6
    assert "store_resolved" not in json.dumps(state["provenance"])  # no path of the training machine
    card = (BUNDLED / "MODEL_CARD.md").read_text()
    assert ("Placeholder" in card) is bundled_model.manifest()["placeholder"]
    for part in ("## Data", "## Training", "## Licence", "### Held-out materials", "95 % interval",
                 "### Stress suite", "## Known failure cases", "## Intended use", "### Real-material reference"):
        assert part in card, part
    assert f"{state['step']}" in card and bundled_model.manifest()["steps"] == state["step"]


def test_the_card_recipe_is_the_frozen_dvc_stage():
    stage = yaml.safe_load((REPO / "dvc.yaml").read_text())["stages"]["train_bundled"]
    assert stage["frozen"] is True  # `dvc repro` leaves it out
    assert [" ".join(c.split()) for c in stage["cmd"].split("&&")] == list(bundle.RECIPE)
    card = (BUNDLED / "MODEL_CARD.md").read_text()
    assert all(c in card for c in bundle.RECIPE)
    assert "train/bundled/" in (REPO / ".dvcignore").read_text()  # a new model reruns no other stage


# -- by name ----------------------------------------------------------------------------------------------------
def test_predict_without_checkpoint_uses_the_bundled_model(tmp_path):
    photo = _save_srgb(tmp_path / "p.png", _flash())
    code, stdout, err = run("predict", photo, "--out", tmp_path / "m", "--size", 128)
    assert code == 0, err
    said = [line for line in err.splitlines() if "shipped with svgen" in line]
    assert len(said) == 1 and "MODEL_CARD.md" in said[0], err
    meta = json.loads((tmp_path / "m" / "prediction.json").read_text())
    assert meta["checkpoint"] == str(BUNDLED / "model.pt")
    assert meta["input_check"]["out_of_distribution"] is False, meta["input_check"]
    code, _, err = run("predict", photo, "--checkpoint", "bundled", "--out", tmp_path / "n", "--size", 128)
    assert code == 0 and "shipped with svgen" not in err  # named: no notice
    for m in ("normal", "diffuse", "roughness", "specular"):
        assert (tmp_path / "m" / f"{m}.exr").read_bytes() == (tmp_path / "n" / f"{m}.exr").read_bytes()


def test_the_bundled_model_evaluates_on_a_store_without_its_training_store(renders, tmp_path, monkeypatch):
    """No user has the bundled model's training store: the model carries the training means its baselines use
    (bundled.json), so `svtrain eval --checkpoint bundled --store S` works in an empty folder, and the baselines'
    numbers are those of the recorded means."""
    work = tmp_path / "empty"
    work.mkdir()
    shutil.copytree(renders, work / "s.zarr")
    monkeypatch.chdir(work)  # no data/renders.zarr here, nor anywhere relative to the package's model
    code, out, err = run("eval", "--checkpoint", "bundled", "--store", "s.zarr", "--out", "e")
    assert code == 0, err
    res = json.loads((work / "e" / "eval.json").read_text())
    assert res["samples"] == 8 and res["suite"] == "all" and "| model |" in out
    recorded = bundled_model.manifest()["train_means"]
    # a model trained since fit records its means carries them itself (bundle copies them into bundled.json); an
    # older one has them from bundled.json alone: either way the same means, none read from a training store
    assert res["train_means"]["maps"] == recorded
    assert res["train_means"]["from"] in ("recorded with the model at fit time", "the bundled model's bundled.json")
    cfg = checkpoint.load("bundled")["config"]
    src = open_source(preset("compact").data.model_copy(update={"store": str(work / "s.zarr")}))
    base = evaluate(None, src, np.arange(len(src)), cfg["data"]["crop"], means_from_record(recorded),
                    cfg["optim"]["batch_size"], cfg["optim"]["seed"])
    for b in ("input_as_diffuse", "dataset_mean"):
        assert res[b] == base[b], b


def test_fine_tuning_starts_at_the_bundled_weights():
    """The weights the first step's forward pass sees (before its update) are the bundled ones, bit for bit."""
    cfg = preset("compact")
    cfg.data.synthetic_samples, cfg.data.synthetic_materials, cfg.data.workers = 8, 4, 0
    cfg.optim.iterations, cfg.optim.batch_size, cfg.optim.compile_loss = 1, 2, False
    cfg.optim.init = "bundled"
    # the bundled network's shape (the compact default may have moved on since it was trained)
    shipped_model = checkpoint.load("bundled")["config"]["model"]
    cfg.model.base_width, cfg.model.max_width = shipped_model["base_width"], shipped_model["max_width"]
    cfg.check()
    trainer = Trainer(cfg)
    seen = []
    trainer.net.register_forward_pre_hook(lambda m, _: seen.append({k: v.clone() for k, v in m.state_dict().items()})
                                          if not seen else None)
    src = open_source(cfg.data)
    train_idx, _ = split_for(src, cfg.data)
    steps = list(trainer.run(PairDataset(src, train_idx, cfg.data.crop, 0, train=True), 0, 1))
    assert len(steps) == 1 and seen
    shipped = checkpoint.load("bundled")["model"]
    assert seen[0].keys() == shipped.keys()
    for k, v in shipped.items():
        assert torch.equal(seen[0][k], v), k
    after = trainer.net.state_dict()
    assert any(not torch.equal(after[k], v) for k, v in shipped.items())  # and the step did update them


def test_fit_init_refuses_another_network_in_one_line(tmp_path):
    code, _, err = run("fit", "--out", tmp_path / "r", "--iterations", 1, *SMALL, "--init", "bundled")
    assert code == 2 and len(err.strip().splitlines()) == 1 and "model.base_width" in err, err
    assert not (tmp_path / "r").exists()  # refused before the run directory is made


# -- damaged or missing ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("damage", ["truncated", "altered", "missing", "manifest_missing"])
def test_a_damaged_or_missing_bundled_file_is_one_line_naming_it(tmp_path, damage):
    where = tmp_path / "bundled"
    shutil.copytree(BUNDLED, where)
    bundled_model.model_path(where)  # the intact copy passes
    model = where / "model.pt"
    if damage == "truncated":
        model.write_bytes(model.read_bytes()[:1000])
    elif damage == "altered":
        raw = bytearray(model.read_bytes())
        raw[len(raw) // 2] ^= 1
        model.write_bytes(bytes(raw))
    elif damage == "missing":
        model.unlink()
    else:
        (where / "bundled.json").unlink()
    with pytest.raises(bundled_model.BundledModelError) as e:
        bundled_model.model_path(where)
    msg = str(e.value)
    assert len(msg.splitlines()) == 1 and "reinstall" in msg
    assert str(where / ("bundled.json" if damage == "manifest_missing" else "model.pt")) in msg


# -- photos far from the training ones ------------------------------------------------------------------------
def test_photos_far_from_the_training_ones_are_flagged_in_prediction_json(tmp_path, caplog):
    photos = tmp_path / "photos"
    photos.mkdir()
    _save_srgb(photos / "ok.png", _flash())
    _save_srgb(photos / "dark.png", _flash(gain=0.01))
    _save_srgb(photos / "clipped.png", _flash(gain=14.0))  # a third clipped at 128²
    _save_srgb(photos / "noflash.png", _flash(flash=False))
    code, _, err = run("predict", photos, "--checkpoint", "bundled", "--out", tmp_path / "maps", "--size", 128)
    assert code == 0, err
    expect = {"ok": None, "dark": "very dark", "clipped": "saturated highlights", "noflash": "no flash lobe"}
    for name, reason in expect.items():
        check = json.loads((tmp_path / "maps" / name / "prediction.json").read_text())["input_check"]
        assert check["out_of_distribution"] is (reason is not None), (name, check)
        if reason:
            assert len(check["warnings"]) == 1 and check["warnings"][0].startswith(reason), (name, check)
            assert (tmp_path / "maps" / name / "normal.exr").is_file()  # it still predicted
            assert name + ".png is far from the training photos" in caplog.text


# -- svtrain bundle ---------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def tiny_run(renders, tmp_path_factory):
    """A 2-step run of a tiny network on the tiny store."""
    run_dir = tmp_path_factory.mktemp("bundle") / "run"
    code, _, err = run("fit", "--out", run_dir, "--iterations", 2, *SMALL, "--store", renders,
                       "--set", "data.synthetic_size=32")
    assert code == 0, err
    return run_dir


def test_bundle_writes_a_loadable_model_with_its_card(tiny_run, tmp_path):
    run_dir = tiny_run
    into = tmp_path / "bundled"
    code, _, err = run("bundle", run_dir, "--into", into, "--limit", 4)
    assert code == 0, err
    path = bundled_model.model_path(into)
    net_state = checkpoint.load(path)
    assert net_state["step"] == 2 and "optim" not in net_state
    card = (into / "MODEL_CARD.md").read_text()
    assert "Placeholder" in card and "### Held-out materials" in card and "95 % interval" in card
    manifest = json.loads((into / "bundled.json").read_text())
    assert manifest["placeholder"] is True
    # the baselines' means travel with the model: those the run recorded at fit time
    recorded = json.loads((run_dir / "provenance.json").read_text())["train_means"]
    assert manifest["train_means"] == recorded == net_state["provenance"]["train_means"]
    assert "Not evaluated for this card: no reference store" in card
    assert "store_resolved" not in json.dumps(net_state["provenance"])  # no resolved path of this machine
    code, _, err = run("bundle", tmp_path, "--into", into)  # not a run: one line
    assert code == 2 and len(err.strip().splitlines()) == 1, err


def test_bundle_evaluates_the_reference_store_when_params_list_sources(tiny_run, renders, tmp_path):
    """With reference sources listed, the card's real-material table is the model's eval on every view of the
    reference store (here the tiny store stands in for one); listed but absent is refused in one line."""
    params = tmp_path / "params.yaml"
    params.write_text(yaml.safe_dump({"reference": {"sources": [str(tmp_path / "materials-cc0")], "crop": 0.5}}))
    into = tmp_path / "bundled"
    code, _, err = run("bundle", tiny_run, "--into", into, "--limit", 4, "--reference-store", renders,
                       "--params", params, "--final")
    assert code == 0, err
    card = (into / "MODEL_CARD.md").read_text()
    assert "Placeholder" not in card
    section = card.split("### Real-material reference store")[1].split("## Intended use")[0]
    assert "4 real CC0 materials (materials-cc0, imported at crop 0.5)" in section, section  # 4 SVBRDFs x 2 views
    assert str(tmp_path) not in card  # folder names only, no paths of this machine
    ref = json.loads((tiny_run / "bundle_eval_reference" / "eval" / "eval.json").read_text())
    assert ref["samples"] == 8  # every view of the store, as svtrain eval-reference evaluates
    assert f"| model | {ref['model']['rerender']:.4f} | {ref['model']['normal']:.4f} |" in section
    manifest = json.loads((into / "bundled.json").read_text())
    assert manifest["placeholder"] is False and manifest["reference_normal_rmse"] == round(ref["model"]["normal"], 5)
    code, _, err = run("bundle", tiny_run, "--into", tmp_path / "b2", "--reference-store", tmp_path / "none.zarr",
                       "--params", params)
    assert code == 2 and len(err.strip().splitlines()) == 1, err
