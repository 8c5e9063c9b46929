"""The one configuration mechanism (svcore.config) as both command lines expose it: every key discoverable from
--help, --print-config round trips, one precedence order, one type conversion, silent defaults said out loud."""
from __future__ import annotations

import contextlib
import io
import logging
import subprocess
import sys
import typing

import pytest
import yaml

from pipeline.cli import cli
from pipeline.config import STAGE_CONFIGS, BlendConfig, ImportConfig, LightModel, RenderConfig, Sampler, SampleConfig
from svcore.cli import run_cli, version
from svcore.config import keys, parse_sets, read_yaml, validate
from svcore.errors import ConfigError
from train.cli import svtrain
from train.config import Config

#: (command group, program, argv prefix, config class) of every configured command.
COMMANDS = [(cli, "svgen", ["sample"], SampleConfig), (cli, "svgen", ["blend"], BlendConfig),
            (cli, "svgen", ["render"], RenderConfig), (cli, "svgen", ["stress"], STAGE_CONFIGS["stress"]),
            (cli, "svgen", ["import"], ImportConfig), (svtrain, "svtrain", ["fit"], Config)]


def call(group, prog, args) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = run_cli(group, prog, [str(a) for a in args])
    return code, out.getvalue(), err.getvalue()


@pytest.mark.parametrize("group, prog, cmd, cls", COMMANDS, ids=[" ".join(c[2]) for c in COMMANDS])
def test_every_config_key_is_listed_in_help_with_its_documentation(group, prog, cmd, cls):
    code, out, _ = call(group, prog, [*cmd, "--help"])
    assert code == 0
    text = " ".join(out.split())
    assert "--set KEY=VALUE" in text and "--config-preset" in text and "--print-config" in text
    listed = text.split("Config keys (--set KEY=VALUE")[1]  # the key table, not the flags' help above it
    for key, _, _, doc in keys(cls):
        assert f" {key} (" in listed, f"--help of {prog} {cmd[0]} does not list the config key {key}"
        assert doc and " ".join(doc.split()[:4]) in listed, f"{key}: its field documentation is not in --help"


@pytest.mark.parametrize("group, prog, cmd, cls", COMMANDS, ids=[" ".join(c[2]) for c in COMMANDS])
def test_print_config_round_trips_through_a_params_file(group, prog, cmd, cls, tmp_path):
    preset = [p for p in cls.PRESETS if p != cls.DEFAULT_PRESET][0]
    one = "seed=7" if "seed" in cls.model_fields else "optim.seed=7" if "optim" in cls.model_fields else "chunk=7"
    code, printed, err = call(group, prog, [*cmd, "--config-preset", preset, "--set", one, "--print-config"])
    assert code == 0, err
    (tmp_path / "p.yaml").write_text(printed)
    code, again, err = call(group, prog, [*cmd, "--params", tmp_path / "p.yaml", "--print-config"])
    assert code == 0 and again == printed, err
    assert validate(cls, yaml.safe_load(printed)[cls.SECTION]).as_dict() == yaml.safe_load(printed)[cls.SECTION]


def test_precedence_defaults_preset_params_set_flag(tmp_path):
    (tmp_path / "p.yaml").write_text("sample:\n  per_preset: 3\n  size: 128\n")
    layers = [["--config-preset", "tiny"], ["--params", tmp_path / "p.yaml"], ["--set", "per_preset=4"],
              ["--per-preset", "5"]]
    expect = [12, 2, 3, 4, 5]  # class default, preset tiny, params, --set, flag
    for k in range(len(layers) + 1):
        args = [a for layer in layers[:k] for a in layer]
        code, out, err = call(cli, "svgen", ["sample", *args, "--print-config"])
        assert code == 0, err
        assert yaml.safe_load(out)["sample"]["per_preset"] == expect[k], args
    # a params section may name its own preset; the command line's wins over it
    (tmp_path / "q.yaml").write_text("render:\n  config_preset: tiny\n")
    assert yaml.safe_load(call(cli, "svgen", ["render", "--params", tmp_path / "q.yaml", "--print-config"])[1])[
        "render"]["res"] == 64
    assert yaml.safe_load(call(cli, "svgen", ["render", "--params", tmp_path / "q.yaml", "--config-preset", "paper",
                                              "--print-config"])[1])["render"]["res"] == 288


def test_values_are_yaml_values_everywhere(tmp_path):
    """One conversion: params.yaml and --set both read YAML 1.2 (1e-3 is a number), then types are strict."""
    (tmp_path / "p.yaml").write_text("train:\n  optim:\n    lr: 1e-3\n    grad_clip: 2\n")
    assert read_yaml(tmp_path / "p.yaml")["train"]["optim"]["lr"] == 1e-3  # PyYAML alone reads "1e-3" as text
    code, out, err = call(svtrain, "svtrain", ["fit", "--params", tmp_path / "p.yaml", "--set", "optim.beta1=5e-1",
                                               "--set", "data.store=null", "--print-config"])
    optim = yaml.safe_load(out)["train"]["optim"]
    assert code == 0 and optim["lr"] == 1e-3 and optim["beta1"] == 0.5 and optim["grad_clip"] == 2.0, err
    assert parse_sets(["presets=[paint/glossy_red, wood/oak_planks]", "seed=0", "mode=mask"]) == {
        "presets": ["paint/glossy_red", "wood/oak_planks"], "seed": 0, "mode": "mask"}
    code, out, _ = call(cli, "svgen", ["sample", "--set", "presets=[paint/glossy_red]", "--print-config"])
    assert yaml.safe_load(out)["sample"]["presets"] == ["paint/glossy_red"]


@pytest.mark.parametrize("cls, values, words", [
    (RenderConfig, {"views": True}, "render.views must be an integer, got True"),
    (SampleConfig, {"sigma": "0.25"}, "sample.sigma must be a number, got '0.25'"),
    (SampleConfig, {"seed": 1.0}, "sample.seed must be an integer"),
    (BlendConfig, {"mask_per_map": 1}, "blend.mask_per_map must be true or false, got 1"),
    (BlendConfig, {"mode": "stripes"}, "blend.mode must be one of 'scalar' or 'mask'"),
    (SampleConfig, {"presets": "paint/glossy_red"}, "sample.presets must be a list"),
    (Config, {"model": 3}, "'train.model' is a section"),
    (Config, {"optim": {"schedule": "linear"}}, "train.optim.schedule must be one of"),
    (Config, {"data": {"crop": 100}}, "data.crop=100 must be a multiple of 2^model.levels"),
])
def test_types_are_strict_and_errors_name_the_key(cls, values, words):
    with pytest.raises(ConfigError) as e:
        validate(cls, values)
    assert words in str(e.value) and "\n" not in str(e.value)


def test_ints_are_accepted_where_floats_are_expected():
    assert validate(SampleConfig, {"sigma": 1}).sigma == 1.0


@pytest.mark.parametrize("content, words", [("", "is empty"), ("render:\n  views: 2\n", "has no 'stress' section")])
def test_other_params_files_without_the_section_are_refused(content, words, tmp_path):
    """Issue #25 item 2: a params file other than the project's params.yaml was given for this command (e.g. a
    run's config.yaml given to another command): running the defaults instead would be a silent surprise."""
    (tmp_path / "p.yaml").write_text(content)
    code, out, err = call(cli, "svgen", ["stress", "--params", tmp_path / "p.yaml", "--print-config"])
    assert code == 2 and out == "" and err.count("\n") == 1, err
    assert words in err and "needs a 'stress:' section" in err, err


@pytest.mark.parametrize("content, words", [("", "is empty"), ("render:\n  views: 2\n", "has no 'stress' section")])
def test_empty_params_or_missing_section_runs_the_defaults_and_says_so(content, words, tmp_path, caplog):
    (tmp_path / "params.yaml").write_text(content)  # the project's params file: a section may be absent
    with caplog.at_level(logging.WARNING):
        code, out, err = call(cli, "svgen", ["stress", "--params", tmp_path / "params.yaml", "--print-config"])
    assert code == 0, err
    said = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert len(said) == 1 and words in said[0] and "defaults" in said[0], said
    assert yaml.safe_load(out)["stress"] == STAGE_CONFIGS["stress"]().as_dict()


def test_config_names_agree_with_the_scene_registries():
    """The render config lists light models and samplers without importing mitsuba; the scene implements them."""
    from pipeline.render.scene import LIGHT_MODELS, SAMPLERS

    assert set(typing.get_args(LightModel)) == set(LIGHT_MODELS)
    assert set(typing.get_args(Sampler)) == set(SAMPLERS)


@pytest.mark.parametrize("group, prog", [(cli, "svgen"), (svtrain, "svtrain")])
def test_version(group, prog):
    """Issue #25 item 3: the package version from its metadata, the code digest and git describe as detail."""
    import importlib.metadata as md

    from svcore.versions import code_digest

    code, out, _ = call(group, prog, ["--version"])
    assert code == 0 and out.startswith(f"{prog} {md.version('svgen')} (code {code_digest()[:12]}"), out
    assert version() == f"{md.version('svgen')} (code {code_digest()[:12]})" and out.count("\n") == 1


def test_the_recorded_version_ignores_edited_data_files_and_names_edited_code(tmp_path):
    """Issue #25 item 3: `dvc exp run -S` edits params.yaml (and dvc.lock): what stores and runs record must not
    call that modified code; an edited source file changes the recorded code digest."""
    import shutil
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    for pkg in ("svcore", "pipeline", "materials", "train"):
        shutil.copytree(root / pkg, tmp_path / pkg, ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(root / "params.yaml", tmp_path / "params.yaml")
    git = ["git", "-c", "user.name=t", "-c", "user.email=t@t", "-c", "commit.gpgsign=false"]
    for cmd in (["init", "-q"], ["add", "-A"], ["commit", "-qm", "x"]):
        subprocess.run(git + cmd, cwd=tmp_path, check=True, capture_output=True)
    show = "from svcore.versions import library_versions as v; import json; print(json.dumps(v()))"

    def recorded() -> dict:
        r = subprocess.run([sys.executable, "-c", show], cwd=tmp_path, capture_output=True, text=True,
                           env={**__import__("os").environ, "PYTHONPATH": str(tmp_path)})
        assert r.returncode == 0, r.stderr[-300:]
        return __import__("json").loads(r.stdout)

    clean = recorded()
    with open(tmp_path / "params.yaml", "a") as f:  # what `dvc exp run -S` does
        f.write("# an experiment\n")
    assert recorded() == clean and "dirty" not in clean["svgen"], clean["svgen"]
    with open(tmp_path / "svcore" / "seeds.py", "a") as f:
        f.write("# edited\n")
    edited = recorded()
    assert edited["svgen_code"] != clean["svgen_code"] and edited["svgen"] != clean["svgen"]
    assert edited["svgen_package"] == clean["svgen_package"]


def test_core_and_cli_import_no_heavy_library():
    """Listing error types, reading configs and `svgen --help` must not load mitsuba, drjit, dask or torch."""
    code = ("import sys, svcore.errors, svcore.cli, svcore.config, pipeline.cli, pipeline.config; "
            "from pipeline.cli import cli; from svcore.cli import run_cli; run_cli(cli, 'svgen', ['--help']); "
            "bad = sorted(m for m in ('mitsuba', 'drjit', 'dask', 'distributed', 'torch') if m in sys.modules); "
            "print(bad); sys.exit(1 if bad else 0)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout[-300:] + r.stderr[-300:]


def test_progress_is_silent_when_stderr_is_not_a_terminal(monkeypatch):
    from svcore.progress import progress

    monkeypatch.delenv("SVGEN_NO_PROGRESS", raising=False)
    monkeypatch.delenv("SVGEN_PROGRESS", raising=False)
    monkeypatch.setattr(sys, "stderr", io.StringIO())  # a pipe or a log file: not a TTY
    assert progress(3, "x").disable
    monkeypatch.setenv("SVGEN_PROGRESS", "1")
    assert not progress(3, "x").disable


@pytest.mark.parametrize("group, prog", [(cli, "svgen"), (svtrain, "svtrain")])
def test_bare_command_prints_the_normal_help_and_exits_0(group, prog):
    """Issue #25 item 5: no arguments is a request for help (click's no_args_is_help), not a one-line error."""
    code, out, err = call(group, prog, [])
    assert code == 0 and err == "", err
    assert out.startswith(f"Usage: {prog} [OPTIONS] COMMAND") and "\nCommands:\n" in out and out.count("\n") > 8


@pytest.mark.parametrize("value, words, hint", [("abc", "train.optim.lr must be a number, got 'abc'", False),
                                                ('"1e-3"', "train.optim.lr must be a number, got '1e-3'", True),
                                                ("yes please", "train.optim.compile_loss must be true or false", False)])
def test_a_wrong_type_names_the_expected_type_and_mentions_quotes_only_when_quoted(value, words, hint):
    """Issue #25 item 6: `--set optim.lr=abc` quoted nothing; the quoting hint is for a quoted number only."""
    key = "optim.compile_loss" if "compile" in words else "optim.lr"
    code, _, err = call(svtrain, "svtrain", ["fit", "--set", f"{key}={value}", "--print-config"])
    assert code == 2 and words in err and err.count("\n") == 1, err
    assert ("quoted" in err) == hint, err


#: a progress bar on a pseudo-terminal (on by tqdm's own detection), in a fresh process: tqdm reads its TQDM_*
#: variables when it is imported
_BAR_ON_A_TTY = ("import os, sys; m, s = os.openpty(); sys.stderr = os.fdopen(s, 'w'); "
                 "from svcore.progress import progress; b = progress(3, 'x'); "
                 "print(bool(b.disable), getattr(b, 'smoothing', ''), getattr(b, 'mininterval', ''))")


@pytest.mark.parametrize("env, shown", [({}, "False 0.1 0.1"), ({"TQDM_DISABLE": "1"}, "True"),
                                        ({"TQDM_DISABLE": "1", "SVGEN_PROGRESS": "1"}, "True"),
                                        ({"TQDM_SMOOTHING": "0.5", "TQDM_MININTERVAL": "2"}, "False 0.5 2.0"),
                                        ({"SVGEN_NO_PROGRESS": "1"}, "True")])
def test_progress_honours_tqdms_own_environment_variables(env, shown):
    """Issue #25 item 9: TQDM_DISABLE=1 (and any TQDM_<argument>) wins; the SVGEN switches stay as aliases."""
    import os

    base = {k: v for k, v in os.environ.items() if not k.startswith(("TQDM_", "SVGEN_NO_PROGRESS", "SVGEN_PROGRESS"))}
    r = subprocess.run([sys.executable, "-c", _BAR_ON_A_TTY], capture_output=True, text=True, env={**base, **env})
    assert r.returncode == 0, r.stderr[-300:]
    assert r.stdout.startswith(shown), (env, r.stdout)
