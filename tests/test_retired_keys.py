"""Config keys retired in #41 (arms that lost, removed with their code paths): a stored config holding one at its old
default still loads, at any other value it is refused in one line naming the key and the commit that still runs it
(50a7983 for the first arms removed, 614fe8c for #39's pixel coordinates, normal decoder and highlight cue); the bundled model,
trained before #41, still loads and predicts."""
from __future__ import annotations

import json
import shutil

import pytest
import torch
import yaml

from svcore.errors import ConfigError
from train import checkpoint
from train.config import RETIRED, RETIRED_AT, RETIRED_AT_39, RETIRED_VALUES, from_dict, preset, resolve

from test_train_cli import SMALL, run  # noqa: E402  (one svtrain-in-process helper)

#: a non-default value of each retired key, and each retired form of a kept key, with the last commit that runs it
REFUSED = [("model.fullres_convs", 2, RETIRED_AT), ("model.normal_head", True, RETIRED_AT),
           ("model.normal_param", "slope", RETIRED_AT), ("optim.grazing_lights", 0.5, RETIRED_AT),
           *((k, v, RETIRED_AT) for k, (forms, _) in RETIRED_VALUES.items() for v in forms),
           ("model.coord_channels", True, "614fe8c"), ("model.normal_decoder", True, "614fe8c"),
           ("model.highlight_cue", True, "614fe8c")]


def test_every_retired_key_and_form_is_tested_with_its_own_commit():
    assert {k for k, _, _ in REFUSED} == set(RETIRED) | set(RETIRED_VALUES)
    assert all(commit == (RETIRED[k][1] if k in RETIRED else RETIRED_VALUES[k][1]) for k, _, commit in REFUSED)
    assert RETIRED_AT == "50a7983" and RETIRED_AT_39 == "614fe8c"


def _with(values: dict, key: str, value) -> dict:
    """A copy of a nested config dict with the dotted ``key`` set."""
    section, _, name = key.partition(".")
    return {**values, section: {**values[section], name: value}}


def _old(cfg_dict: dict) -> dict:
    """A config dict as a run from before #41 wrote it: every retired key at its default."""
    for key, (value, _) in RETIRED.items():
        cfg_dict = _with(cfg_dict, key, value)
    return cfg_dict


def test_a_stored_config_with_retired_keys_at_their_defaults_loads_as_without_them():
    cfg = preset("compact")
    assert from_dict(_old(cfg.to_dict())).to_dict() == cfg.to_dict()
    assert from_dict({**_old(cfg.to_dict()), "preset": "compact"}).to_dict() == cfg.to_dict()  # an older field too


@pytest.mark.parametrize("key, value, commit", REFUSED)
def test_a_retired_key_at_another_value_is_refused_naming_it_and_the_last_commit(key, value, commit):
    with pytest.raises(ConfigError) as e:
        from_dict(_with(_old(preset("compact").to_dict()), key, value))
    msg = str(e.value)
    assert f"train.{key}={value!r}" in msg and "#41" in msg and f"commit {commit} " in msg and "\n" not in msg, msg
    other = RETIRED_AT_39 if commit == RETIRED_AT else RETIRED_AT
    assert other not in msg, msg  # its own commit, not the other retirement's


def test_false_is_not_zero():
    """A retired key counts as at its default only with its default's type (bool is an int in Python)."""
    with pytest.raises(ConfigError, match="fullres_convs"):
        from_dict(_with(preset("compact").to_dict(), "model.fullres_convs", False))


def test_an_old_params_file_loads_and_one_using_a_retired_arm_is_refused_in_one_line(tmp_path):
    """A run's config.yaml (or an older params.yaml) is a params file: `--params` reads it with the retired keys at
    their defaults; at another value one line, exit 2."""
    cfg = resolve("compact", None, {"model.levels": 3, "data.crop": 32})
    old = tmp_path / "old.yaml"
    old.write_text(yaml.safe_dump({"train": _old(cfg.to_dict())}, sort_keys=False))
    assert resolve(None, old).to_dict() == cfg.to_dict()
    code, out, err = run("fit", "--params", old, "--print-config")
    assert code == 0 and "fullres_convs" not in out and "levels: 3" in out, err
    used = tmp_path / "used.yaml"
    used.write_text(yaml.safe_dump({"train": _with(_old(cfg.to_dict()), "model.normal_head", True)}))
    code, out, err = run("fit", "--params", used, "--print-config")
    assert code == 2 and err.count("\n") == 1 and "model.normal_head=True" in err and RETIRED_AT in err, err
    assert "Traceback" not in err
    used.write_text(yaml.safe_dump({"train": _with(_old(cfg.to_dict()), "model.coord_channels", True)}))
    code, out, err = run("fit", "--params", used, "--print-config")
    assert code == 2 and err.count("\n") == 1 and "model.coord_channels=True" in err and RETIRED_AT_39 in err, err
    assert "Traceback" not in err


@pytest.mark.parametrize("key", ["model.normal_head", "model.coord_channels", "model.normal_decoder",
                                 "model.highlight_cue"])
def test_setting_a_retired_key_on_the_command_line_is_an_unknown_key(tmp_path, key):
    code, out, err = run("fit", "--out", tmp_path, "--set", f"{key}=true", "--print-config")
    assert code == 2 and err.count("\n") == 1 and f"unknown config key 'train.{key}'" in err, err


def test_a_checkpoint_from_before_the_retirement_loads_fine_tunes_and_resumes(tmp_path):
    """A checkpoint whose config holds the retired keys at their defaults: its model loads, ``--init`` accepts it,
    and a plain ``svtrain fit --out`` continues it; one with a retired arm on is refused in one line."""
    code, out, err = run("fit", "--out", tmp_path / "run", "--iterations", 2, *SMALL)
    assert code == 0, err
    for name in ("checkpoint.pt", "model.pt"):
        state = torch.load(tmp_path / "run" / name, map_location="cpu", weights_only=True)
        state["config"] = _old(state["config"])
        torch.save(state, tmp_path / "run" / name)
    model, cfg = checkpoint.load_model(tmp_path / "run")
    assert "fullres_convs" not in cfg.to_dict()["model"]
    code, out, err = run("fit", "--out", tmp_path / "run", "--iterations", 3, *SMALL)  # resumes: the same model
    assert code == 0 and json.loads(out.strip().splitlines()[-1])["resumed_from"] == 2, err
    code, out, err = run("fit", "--out", tmp_path / "ft", "--iterations", 1, *SMALL,
                         "--set", f"optim.init={tmp_path / 'run' / 'model.pt'}")
    assert code == 0, err
    state = torch.load(tmp_path / "run" / "model.pt", map_location="cpu", weights_only=True)
    state["config"] = _with(state["config"], "model.fullres_convs", 1)
    shutil.rmtree(tmp_path / "run")
    (tmp_path / "run").mkdir()
    torch.save(state, tmp_path / "run" / "model.pt")
    with pytest.raises(ConfigError, match="fullres_convs=1"):
        checkpoint.load_model(tmp_path / "run" / "model.pt")
    code, out, err = run("fit", "--out", tmp_path / "ft2", "--iterations", 1, *SMALL,
                         "--set", f"optim.init={tmp_path / 'run' / 'model.pt'}")
    assert code == 2 and err.count("\n") == 1 and "fullres_convs=1" in err, err


def test_the_bundled_model_trained_before_the_retirement_loads_and_predicts():
    state = checkpoint.load("bundled")
    old_keys = {"fullres_convs", "normal_head", "normal_param", "coord_channels", "normal_decoder"}
    assert old_keys <= set(state["config"]["model"])  # an old config, with both retirements' keys at their defaults
    assert not state["config"]["model"]["coord_channels"] and not state["config"]["model"]["normal_decoder"]
    model, cfg = checkpoint.load_model("bundled")
    assert not old_keys & set(cfg.to_dict()["model"])
    s = 2 ** cfg.model.levels
    with torch.no_grad():
        y = model(torch.rand(1, 3, s, s, generator=torch.Generator().manual_seed(0)))
    assert y.shape == (1, 10, s, s) and torch.isfinite(y).all()
    torch.testing.assert_close(y[:, 0:3].norm(dim=1), torch.ones(1, s, s))
