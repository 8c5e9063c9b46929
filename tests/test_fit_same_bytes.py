"""Same inputs, same bytes for the training stages (issue #40 part 1): every file dvc.yaml's ``fit`` and ``eval``
stages declare is a function of the code, the params and the data; not of the working directory, the spelling of
the paths, the time, the time zone, the worker count of the machine, the installed package version (which names the
commit) or code that training cannot run. DVC hashes these files into dvc.lock: a fresh clone's `dvc repro` must
leave it as committed. What does vary (the clock, the store's absolute path, the package version) is written to
timing.json, which dvc.yaml does not declare (train/timing.py)."""
from __future__ import annotations

import json
import os
import shlex
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

REPO = Path(__file__).resolve().parents[1]
STAGES = yaml.safe_load((REPO / "dvc.yaml").read_text())["stages"]
TRAIN = {"config_preset": "compact", "model": {"base_width": 4, "max_width": 8, "levels": 3},
         "data": {"crop": 32, "eval_views": 4},
         "optim": {"batch_size": 2, "iterations": 4, "checkpoint_every": 2, "log_every": 2, "eval_every": 2,
                   "compile_loss": False}}
PARAMS = {"train": TRAIN, "eval": {"limit": 6}}
#: a package version of another commit, as setuptools-scm writes it: a fake distribution first on the path
OTHER_VERSION = "0.0.1.dev9+gdeadbee"


def declared(stage: str) -> list[str]:
    """The files a dvc.yaml stage declares (outs, metrics, plots), as written in dvc.yaml."""
    st = STAGES[stage]
    return [next(iter(o)) if isinstance(o, dict) else o for key in ("outs", "metrics", "plots")
            for o in st.get(key, [])]


def stage_words(stage: str) -> list[str]:
    """The stage's dvc.yaml command as words, ``${eval.limit}`` filled from :data:`PARAMS`."""
    return shlex.split(STAGES[stage]["cmd"].replace("${eval.limit}", str(PARAMS["eval"]["limit"])))


def svtrain(words: list[str], cwd: Path, **env: str) -> subprocess.CompletedProcess:
    """``svtrain WORDS`` in a fresh process in ``cwd`` (this checkout's code; ``PYTHONPATH`` extra first)."""
    path = os.pathsep.join(p for p in (env.pop("PYTHONPATH", ""), str(REPO)) if p)
    r = subprocess.run([sys.executable, "-c", "from train.cli import main; main()", *words], cwd=cwd,
                       capture_output=True, text=True,
                       env={**os.environ, "SVGEN_NO_PROGRESS": "1", **env, "PYTHONPATH": path})
    assert r.returncode == 0, f"{words}: {r.stderr[-2000:]}"
    return r


@pytest.fixture(scope="module")
def renders(tmp_path_factory) -> Path:
    """A tiny renders store: 2 presets x 3 SVBRDFs x 2 views at 32² (in-process, no workers)."""
    from pipeline.config import RenderConfig, SampleConfig
    from pipeline.render.stage import run_render
    from pipeline.sample import run_sample
    from svcore.config import build

    d = tmp_path_factory.mktemp("fit_same_bytes")
    run_sample(d / "v.zarr", build(SampleConfig, "tiny", presets=("paint/glossy_red", "metal/aluminium_plate"),
                                   per_preset=3, size=64), workers=0)
    run_render(d / "v.zarr", d / "r.zarr", build(RenderConfig, "tiny", res=32, views=2, chunk=2), workers=0)
    return d / "r.zarr"


def _project(root: Path, renders: Path) -> Path:
    """A project folder as the DVC pipeline has it: params.yaml and data/renders.zarr (a copy: a link would resolve
    to the same place from both projects)."""
    (root / "data").mkdir(parents=True)
    shutil.copytree(renders, root / "data" / "renders.zarr")
    (root / "params.yaml").write_text(yaml.safe_dump(PARAMS, sort_keys=False))
    return root


def _fake_version(root: Path) -> Path:
    """A folder holding an ``svgen`` distribution of :data:`OTHER_VERSION` (what another commit installs)."""
    info = root / f"svgen-{OTHER_VERSION}.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: svgen\nVersion: {OTHER_VERSION}\n")
    return root


@pytest.mark.slow  # fresh processes: 4 svtrain commands / 3 fit scripts in a copied tree
def test_fit_and_eval_write_the_same_bytes_in_another_folder_time_zone_worker_count_and_version(renders, tmp_path):
    files = [p for s in ("fit", "eval") for p in declared(s)]
    assert {"runs/train/model.pt", "runs/train/checkpoint.pt", "runs/train/provenance.json", "runs/train/metrics.json",
            "runs/train/heldout.csv", "runs/eval/eval.json", "runs/eval/eval.png"} <= set(files), files
    a = _project(tmp_path / "a", renders)
    b = _project(tmp_path / "elsewhere" / "deeper" / "b", renders)
    # a: dvc.yaml's own commands, from the project folder
    started = time.time()
    svtrain(stage_words("fit")[1:], a, SVGEN_WORKERS="0")
    svtrain(stage_words("eval")[1:], a, SVGEN_WORKERS="0")
    # b: another folder, other spellings of every path but the store's (the config records it as given, as
    # dvc.yaml's command spells it), another time zone, at least a second later, another loader worker count and
    # another installed package version
    time.sleep(max(0.0, started + 1.1 - time.time()))
    other = {"TZ": "Pacific/Kiritimati", "SVGEN_WORKERS": "1", "PYTHONPATH": str(_fake_version(tmp_path / "dist"))}
    svtrain(["fit", "--params", str(b / "params.yaml"), "--store", "data/renders.zarr", "--out",
             "./runs/x/../train/", "--resume-if-unchanged"], b, **other)
    svtrain(["eval", "--checkpoint", str(b / "runs" / "train"), "--store", "data/renders.zarr", "--limit", "6",
             "--out", "runs/./eval"], b, **other)
    differ = [f for f in files if (a / f).read_bytes() != (b / f).read_bytes()]
    assert not differ, f"declared outputs differ between the two runs: {differ}"
    # what varies is beside them, undeclared: the clock, the absolute store path, the package version
    ta, tb = (json.loads((p / "runs" / "train" / "timing.json").read_text()) for p in (a, b))
    assert "runs/train/timing.json" not in files
    assert ta["it_per_s"] > 0 and ta["train_cpu_s"] > 0 and [r["step"] for r in ta["heldout"]] == [0, 2, 4]
    assert ta["store_resolved"] == str((a / "data" / "renders.zarr").resolve())
    assert OTHER_VERSION in tb["svgen"] and OTHER_VERSION not in ta["svgen"]  # the fake version was the one running
    metrics = json.loads((a / "runs" / "train" / "metrics.json").read_text())
    assert not {"it_per_s", "train_wall_s", "train_cpu_s", "resumed_from"} & set(metrics), metrics
    assert (a / "runs" / "train" / "heldout.csv").read_text().splitlines()[0] == \
        "step,rerender,normal,diffuse,roughness,specular"
    # no place, no date, no version of the checkout in any declared byte (pickled strings are stored as they are)
    from svcore.versions import package_version

    for f in files:
        data = (a / f).read_bytes()
        for absent in (str(tmp_path), time.strftime("%Y-%m-%d", time.gmtime()), time.strftime("%Y-%m-%d"),
                       *[v for v in (package_version(),) if v != "unknown"], OTHER_VERSION):
            assert absent.encode() not in data, (f, absent)


@pytest.mark.slow  # fresh processes: 4 svtrain commands / 3 fit scripts in a copied tree
def test_an_edit_training_cannot_run_changes_no_byte_and_continues_a_checkpoint(tmp_path):
    """A run names its code by the digest of what ``train.fit`` can import (train.runinfo.code_digest), not by the
    whole tree nor the commit: an edit elsewhere (the gallery, committed) leaves every output of a fit
    byte-identical and `--resume-if-unchanged` continues a checkpoint from before it; an edit to the training code
    changes the recorded code and the same checkpoint is not continued (the run starts over)."""
    root, tree = REPO, tmp_path / "tree"
    for pkg in ("svcore", "storage", "pipeline", "materials", "train"):
        shutil.copytree(root / pkg, tree / pkg, ignore=shutil.ignore_patterns("__pycache__", "bundled"))
    git = ["git", "-c", "user.name=t", "-c", "user.email=t@t", "-c", "commit.gpgsign=false"]

    def commit() -> None:
        for cmd in (["add", "-A"], ["commit", "-qm", "x"]):
            subprocess.run(git + cmd, cwd=tree, check=True, capture_output=True)

    script = """
import json, sys
from train.config import resolve
from train.fit import fit
cfg = resolve("compact", None, {"model.base_width": 4, "model.max_width": 8, "model.levels": 3, "data.crop": 32,
                                "data.workers": 0, "data.synthetic_size": 40, "data.synthetic_samples": 12,
                                "data.synthetic_materials": 4, "optim.batch_size": 2, "optim.iterations": 4,
                                "optim.checkpoint_every": 2, "optim.compile_loss": False})
out = {}
for job in sys.argv[1:]:
    what, run = job.split("=")
    kw = {"stop_after": 2, "resume": False} if what == "stop" else \\
        {"resume": "if-unchanged"} if what == "continue" else {"resume": False}
    out[run] = fit(cfg, run, show_progress=False, **kw).get("resumed_from")
print(json.dumps(out))
"""

    def fits(*jobs: str) -> dict:
        r = subprocess.run([sys.executable, "-c", script, *jobs], cwd=tmp_path, capture_output=True, text=True,
                           env={**os.environ, "PYTHONPATH": str(tree), "SVGEN_NO_PROGRESS": "1"})
        assert r.returncode == 0, r.stderr[-2000:]
        return json.loads(r.stdout.strip().splitlines()[-1])

    def outputs(run: str) -> dict[str, bytes]:
        return {f: (tmp_path / run / f).read_bytes() for f in ("model.pt", "checkpoint.pt", "provenance.json",
                                                               "config.yaml", "metrics.json", "heldout.csv")}

    subprocess.run(git + ["init", "-q"], cwd=tree, check=True, capture_output=True)
    commit()
    fits("full=before", "stop=ck_outside", "stop=ck_inside")
    with open(tree / "pipeline" / "gallery" / "page.py", "a") as f:
        f.write("# an edit to code training cannot run\n")
    commit()
    assert fits("full=outside", "continue=ck_outside") == {"outside": None, "ck_outside": 2}
    assert outputs("outside") == outputs("before")
    assert outputs("ck_outside") == outputs("before")  # a resumed run, too
    with open(tree / "train" / "loss.py", "a") as f:
        f.write("# an edit to the training code\n")
    assert fits("full=inside", "continue=ck_inside") == {"inside": None, "ck_inside": None}  # started over
    inside = outputs("inside")
    assert inside["provenance.json"] != outputs("before")["provenance.json"]  # the recorded code digest
    assert inside["metrics.json"] == outputs("before")["metrics.json"]  # a comment: the same losses


def test_the_clock_continues_across_a_resume_and_restarts_without_its_file(tmp_path, monkeypatch):
    """timing.json is written with every checkpoint: a run interrupted (Ctrl-C: the checkpoint is saved, nothing
    else) and resumed continues its clock and its held-out times; a checkpoint without it (restored by DVC, say)
    restarts the clock and says from which step it counts. The curve is the same either way."""
    import train.fit as fit_module
    from train import timing
    from train.config import resolve

    cfg = resolve("compact", None, {"model.base_width": 4, "model.max_width": 8, "model.levels": 3,
                                    "data.crop": 32, "data.workers": 0, "data.synthetic_size": 40,
                                    "data.synthetic_samples": 12, "data.synthetic_materials": 4,
                                    "data.eval_views": 2, "optim.batch_size": 2, "optim.iterations": 6,
                                    "optim.checkpoint_every": 2, "optim.eval_every": 2,
                                    "optim.compile_loss": False})
    real_step = fit_module.train_step

    def interrupted(*args, **kw):  # Ctrl-C during the 5th step (index 4): fit saves the checkpoint of step 4
        if args[7] == 4:
            raise KeyboardInterrupt
        return real_step(*args, **kw)

    monkeypatch.setattr(fit_module, "train_step", interrupted)
    with pytest.raises(KeyboardInterrupt):
        fit_module.fit(cfg, tmp_path / "a", resume=False, show_progress=False)
    monkeypatch.setattr(fit_module, "train_step", real_step)
    assert not (tmp_path / "a" / "model.pt").exists()  # interrupted: no final outputs, only the checkpoint's
    before = timing.read(tmp_path / "a")
    assert before.get("checkpoint", {}).get("step") == 4 and [r["step"] for r in before["heldout"]] == [0, 2, 4]
    shutil.copytree(tmp_path / "a", tmp_path / "b")
    (tmp_path / "b" / timing.FILE).unlink()
    m = fit_module.fit(cfg, tmp_path / "a", show_progress=False)
    after = timing.read(tmp_path / "a")
    assert m["resumed_from"] == after["resumed_from"] == 4 and after["clock_from_step"] == 0
    assert after["heldout"][:3] == before["heldout"]  # the times before the checkpoint, kept
    cpu = [r["cpu_s"] for r in after["heldout"]]
    assert [r["step"] for r in after["heldout"]] == [0, 2, 4, 6] and cpu == sorted(cpu) and cpu[-1] > cpu[2]
    assert after["train_cpu_s"] >= cpu[-1] > before["train_cpu_s"]
    fit_module.fit(cfg, tmp_path / "b", show_progress=False)
    restarted = timing.read(tmp_path / "b")
    assert restarted["clock_from_step"] == 4 and [r["step"] for r in restarted["heldout"]] == [6]
    # the curve itself is the same either way: heldout.csv holds steps and errors only
    assert (tmp_path / "a" / "heldout.csv").read_bytes() == (tmp_path / "b" / "heldout.csv").read_bytes()
