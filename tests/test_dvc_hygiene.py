"""DVC as its users expect it (issue #14): deps that cover every imported module, no machine settings in the
commands, a small flat `dvc metrics show`, `dvc plots show` drawing the charts of docs/PERFORMANCE.md, every config
key one `dvc exp run -S` away, and a `dvc push` / `dvc pull` round trip through a local directory remote.

The static checks read dvc.yaml, params.yaml and the source; the others use the temporary copy of the repository
with the repository's params.yaml and tiny values that one `dvc repro` brought up to date (conftest's
tiny_dvc_project, shared with tests/test_dvc_pipeline.py).
"""
from __future__ import annotations

import hashlib
import json
import math
import shutil
import sys

import pytest
import yaml

from conftest import tree_digest
from dvc_project import ENV, FAST, REPO, clone_project, sh

sys.path.insert(0, str(REPO / "scripts"))
import params_yaml  # noqa: E402
import stage_deps  # noqa: E402

# the xdist worker of test_dvc_pipeline: the tiny `dvc repro` project (about 80 s on 2 cores) is made once for both
pytestmark = pytest.mark.xdist_group("dvc_pipeline")
STAGES = yaml.safe_load((REPO / "dvc.yaml").read_text())["stages"]


def _dep_paths(stage: dict) -> list[str]:
    return [d if isinstance(d, str) else next(iter(d)) for d in stage.get("deps", [])]


def _out_paths(stage: dict) -> list[str]:
    return [o if isinstance(o, str) else next(iter(o))
            for key in ("outs", "metrics", "plots") for o in stage.get(key, [])]


# -- 1. deps complete by construction -------------------------------------------------------------------------
def test_the_import_graph_sees_lazy_and_registry_imports():
    """The finder is not vacuous: svgen's lazily imported stage module, the modules it imports inside functions
    and the material classes the registry imports by name are all seen."""
    sample = {str(p.relative_to(REPO)) for p in stage_deps.stage_files(STAGES["sample"]["cmd"])}
    assert {"pipeline/commands/sample.py", "pipeline/sample.py", "pipeline/sample_from.py", "svcore/seeds.py",
            "materials/registry.py", "materials/classes/wood.py"} <= sample, sorted(sample)
    evaluate = {str(p.relative_to(REPO)) for p in stage_deps.stage_files(STAGES["eval"]["cmd"])}
    assert {"train/cli.py", "train/commands/eval.py", "train/evaluate.py"} <= evaluate, sorted(evaluate)
    assert "train/fit.py" not in evaluate and "train/commands/fit.py" not in evaluate  # only `eval`'s module


def test_the_fast_import_reader_sees_what_a_whole_parse_sees_in_every_module(tmp_path):
    """svcore.codegraph reads a module's imports from its import lines (a store computes its code's closure on every
    run, and whole parses cost ~1 s): on every module of the project the imported names equal a whole-file parse's,
    and a statement the text pattern cuts short falls back to the whole parse."""
    import ast

    from svcore.codegraph import PACKAGES, import_tree, imported_names

    for pkg in PACKAGES:
        for path in sorted((REPO / pkg).rglob("*.py")):
            parts = path.relative_to(REPO).with_suffix("").parts
            name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
            whole = imported_names(ast.parse(path.read_text()), name, path, REPO)
            assert imported_names(import_tree(path), name, path, REPO) == whole, name
    cut = tmp_path / "cut.py"  # a statement the line pattern cuts short (a backslash continuation)
    cut.write_text("from svcore.seeds import derive_seed, \\\n    stream_seed\n")
    assert imported_names(import_tree(cut), "cut", cut, REPO) >= {"svcore.seeds", "svcore.seeds.stream_seed"}


def test_every_stage_dep_covers_the_modules_its_command_imports():
    missing = {stage: files for stage, files in stage_deps.uncovered().items() if files}
    assert not missing, ("stages whose deps miss modules their command imports (a change there would not rerun "
                         f"them; `python3 scripts/stage_deps.py` lists them): {missing}")


def test_every_input_a_command_names_is_a_dep():
    """A path in a command that another stage writes is an input: it must be a dep, or the stage would not rerun
    when it changes (and DVC would not order the stages)."""
    produced = {o: name for name, st in STAGES.items() for o in _out_paths(st)}
    for name, st in STAGES.items():
        deps = _dep_paths(st)
        for word in st["cmd"].replace("&&", " ").split():
            owner = produced.get(word.rstrip("/"))
            if owner is not None and owner != name:
                assert word.rstrip("/") in deps, f"stage {name}: {word} (written by {owner}) is not a dep"


def test_no_file_dep_is_empty():
    """DVC warns "'pipeline/__init__.py' is empty." for every empty file dep, in every stage of every run (issue #25
    item 16): a package's __init__.py says what the package is instead."""
    empty = sorted({d for st in STAGES.values() for d in _dep_paths(st)
                    if (REPO / d).is_file() and (REPO / d).stat().st_size == 0})
    assert not empty, f"empty files among the stage deps (dvc repro warns about each): {empty}"


# -- 2. machine settings out of the commands ------------------------------------------------------------------
def test_no_worker_count_in_commands_or_params():
    params = yaml.safe_load((REPO / "params.yaml").read_text())
    assert "workers" not in params
    for name, st in STAGES.items():
        assert "workers" not in st["cmd"], f"stage {name} puts a worker count in its command: {st['cmd']}"


def test_svgen_workers_environment_variable_is_read(tmp_path):
    """SVGEN_WORKERS reaches --workers (an invalid value is refused naming it) and svtrain's loader workers."""
    r = sh([sys.executable, "-c", "from pipeline.cli import main; main()", "sample", str(tmp_path / "v.zarr"),
            "--per-preset", "1", "--size", "64"], REPO, check=False, env={**ENV, "SVGEN_WORKERS": "-1"})
    assert r.returncode == 2 and "SVGEN_WORKERS" in r.stderr and "Traceback" not in r.stderr, r.stderr
    r = sh([sys.executable, "-c", "from train.cli import main; main()", "fit", "--print-config"], REPO,
           env={**ENV, "SVGEN_WORKERS": "5"})
    assert yaml.safe_load(r.stdout)["train"]["data"]["workers"] == 5


# -- 5. every config key in params.yaml -----------------------------------------------------------------------
def test_params_yaml_holds_every_config_key():
    params = yaml.safe_load((REPO / "params.yaml").read_text())
    missing = params_yaml.missing_keys(params)
    assert not missing, f"params.yaml lacks {missing}: run python3 scripts/params_yaml.py --write"
    # the generator is the file's source: regenerating changes nothing (values and comments)
    assert params_yaml.generate(params) == (REPO / "params.yaml").read_text()


def test_params_yaml_check_names_a_missing_key(tmp_path):
    params = yaml.safe_load((REPO / "params.yaml").read_text())
    del params["train"]["model"]["base_width"]
    path = tmp_path / "params.yaml"
    path.write_text(yaml.safe_dump(params))
    r = sh([sys.executable, str(REPO / "scripts" / "params_yaml.py"), "--check", "--params", str(path)], REPO,
           check=False)
    assert r.returncode == 1 and "train.model.base_width" in r.stderr, r.stderr


# -- the tiny pipeline ----------------------------------------------------------------------------------------
@pytest.fixture
def repro(tiny_dvc_project):
    """The shared tiny project, `dvc repro` done (conftest's tiny_dvc_project): tests here leave it as they found
    it (the experiment runs on a copy)."""
    return tiny_dvc_project.path


def test_every_file_the_fit_stage_writes_is_an_output(repro):
    """run.json and provenance.json among them (issue 25: a checkout lost them): nothing under runs/train that
    `dvc checkout` would not bring back, but timing.json: the run's clock, which differs on every run, is
    deliberately no output (DVC would hash it into dvc.lock; train/timing.py)."""
    from train import timing

    declared = {o for st in STAGES.values() for o in _out_paths(st)}
    written = {str(p.relative_to(repro)) for p in (repro / "runs" / "train").rglob("*")
               if p.is_file() and not p.name.startswith(".")}
    assert {"runs/train/run.json", "runs/train/provenance.json", f"runs/train/{timing.FILE}"} <= written
    assert f"runs/train/{timing.FILE}" not in declared
    assert written - {f"runs/train/{timing.FILE}"} <= declared, sorted(written - declared)


def test_changing_the_worker_count_reruns_nothing(repro):
    for workers in ("0", "1", "3"):
        env = {**ENV, "SVGEN_WORKERS": workers}
        assert "up to date" in sh(["dvc", "status"], repro, env=env).stdout
        again = sh(["dvc", "repro"], repro, env=env)
        assert "Running stage" not in again.stdout, again.stdout


def test_bytecode_in_the_code_deps_reruns_nothing(repro):
    """Python writes __pycache__/*.pyc into the packages a stage lists as deps (unless PYTHONDONTWRITEBYTECODE is
    set, as on some machines): they must not count, or dvc.lock depends on the machine and the Python version that
    ran it, and a checkout whose lock was written with bytecode reruns every stage (.dvcignore)."""
    made = []
    try:
        for pkg in ("materials", "svcore", "pipeline", "train"):
            cache = repro / pkg / "__pycache__"
            cache.mkdir(exist_ok=True)
            pyc = cache / "maps.cpython-311.pyc"
            pyc.write_bytes(b"not from this repository")
            made.append(pyc)
        status = sh(["dvc", "status"], repro, env=FAST).stdout
        assert "up to date" in status, f"bytecode files changed the stages' deps:\n{status}"
    finally:
        for pyc in made:
            pyc.unlink(missing_ok=True)


# -- 3. a small flat metrics table ----------------------------------------------------------------------------
def _leaves(d, prefix=""):
    for k, v in d.items():
        if isinstance(v, dict):
            yield from _leaves(v, f"{prefix}{k}.")
        else:
            yield prefix + k, v


def test_metrics_show_is_small_flat_and_numeric(repro):
    shown = json.loads(sh(["dvc", "metrics", "show", "--json"], repro, env=FAST).stdout)
    files = shown[""]["data"]
    columns = {}
    for name, f in files.items():
        assert "error" not in f, (name, f)
        for key, value in _leaves(f["data"]):
            assert key.count(".") <= 1, f"{name}: {key} nests deeper than one level"
            columns[f"{name}:{key}"] = value
    assert len(columns) < 40, sorted(columns)
    bad = {k: v for k, v in columns.items()
           if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v)}
    assert not bad, f"metrics that are not finite numbers: {bad}"
    assert not any("per_s" in k for k in columns), "machine-dependent speeds are not metrics"
    assert set(files) == {"runs/train/fit_metrics.json", "runs/eval/eval_metrics.json",
                          "runs/eval_stress/eval_metrics.json", "runs/eval_extra/eval_metrics.json",
                          "runs/eval_reference/eval_metrics.json"}, set(files)
    # the table that matters is there: the held-out eval of the model and its baselines, the training loss
    assert {"runs/eval/eval_metrics.json:model.rerender", "runs/eval/eval_metrics.json:dataset_mean.rerender",
            "runs/train/fit_metrics.json:loss_final"} <= set(columns)
    # and the full records are still written, as outputs
    assert json.loads((repro / "runs/train/metrics.json").read_text())["done"] is True


# -- 4. plots that draw the docs' charts ----------------------------------------------------------------------
def test_plots_show_draws_the_readme_charts(repro):
    shown = json.loads(sh(["dvc", "plots", "show", "--json"], repro, env=FAST).stdout)
    assert not shown.get("errors"), shown.get("errors")
    plots = shown["data"]
    for chart in ("render", "training", "scaleout", "agreement", "stress"):
        path = f"runs/charts/chart_{chart}.png"
        assert path in plots, sorted(plots)
        assert [p["type"] for p in plots[path]] == ["image"], plots[path]
        assert (repro / path).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    loss = plots["runs/train/loss.csv"]
    assert [p["type"] for p in loss] == ["vega"], loss
    values = loss[0]["content"]["data"]["values"]
    steps = [float(v["step"]) for v in values]
    # one series whose x only grows: a line, not a zig-zag across series that DVC joined
    assert len(steps) >= 2 and steps == sorted(steps) and len(set(steps)) == len(steps), steps
    content = json.dumps(loss[0]["content"])
    spec = loss[0]["content"]
    assert spec["mark"]["type"] == "line" and "loess" not in content  # the curve itself, as fit's loss.png draws it
    assert (spec["encoding"]["x"]["field"], spec["encoding"]["y"]["field"]) == ("step", "loss")
    # no data plot of a several-series CSV is declared (they drew one zig-zag line); heldout.csv is one fit's held-out
    # curve (optim.eval_every; only its header here, where it is 0)
    assert not [p for p in plots if p.endswith(".csv") and p not in ("runs/train/loss.csv", "runs/train/heldout.csv")
                ], sorted(plots)


# -- 6. a remote ----------------------------------------------------------------------------------------------
def test_push_then_pull_from_a_local_remote_is_bit_identical(repro, tmp_path):
    cached = [o for st in STAGES.values() for o in st.get("outs", []) if isinstance(o, str)]
    assert "data/renders.zarr" in cached and "runs/train/model.pt" in cached

    def digest(rel):
        p = repro / rel
        return tree_digest(p) if p.is_dir() else {"": hashlib.sha256(p.read_bytes()).hexdigest()}

    before = {o: digest(o) for o in cached}
    assert any(before[o] for o in cached if o.endswith(".zarr")), "the stores are empty: the test proves nothing"
    sh(["dvc", "remote", "add", "-f", "-d", "local", str(tmp_path / "remote")], repro)
    sh(["dvc", "push"], repro, env=FAST)
    shutil.rmtree(repro / ".dvc" / "cache")
    for o in cached:
        p = repro / o
        if p.is_dir():
            shutil.rmtree(p)
        else:
            p.unlink()
    sh(["dvc", "pull"], repro, env=FAST)
    after = {o: digest(o) for o in cached}
    assert after == before
    assert "up to date" in sh(["dvc", "status"], repro, env=FAST).stdout
    sh(["dvc", "remote", "remove", "local"], repro)


# -- 5. one `dvc exp run -S` of a nested key ------------------------------------------------------------------
def test_exp_run_sets_a_nested_training_key(repro, tmp_path):
    """A key the tiny overrides do not touch (the train.model section was missing from params.yaml before, and
    DVC refuses -S on a key that is not in the file: "Key 'model' is not in struct")."""
    repro = clone_project(repro, tmp_path / "proj")  # the experiment changes params.yaml and the fit's outputs
    sh("git add -A && git commit -qm repro", repro)
    # the fit stage alone: what follows it would rerun too, and proves nothing more about -S
    r = sh(["dvc", "exp", "run", "-S", "train.model.decoder_convs=2", "fit"], repro, env=FAST)
    assert "Running stage 'fit'" in r.stdout and "Running stage 'sample'" not in r.stdout, r.stdout
    cfg = yaml.safe_load((repro / "runs/train/config.yaml").read_text())["train"]
    assert cfg["model"]["decoder_convs"] == 2
    assert yaml.safe_load((repro / "params.yaml").read_text())["train"]["model"]["decoder_convs"] == 2
