"""`dvc repro` end to end on a temporary copy of the repository with a tiny parameter set: every stage runs (the
reference stages skip in one line each without sources), metrics and plots are readable, a second `dvc repro` does
nothing, and a SIGKILL in the middle of each of the blend, render and fit stages followed by `dvc repro STAGE`
resumes it (the chunks finished before the kill are kept, not rewritten; the fit continues from its checkpoint's
step) and ends with the outputs of an uninterrupted run."""
from __future__ import annotations

import difflib
import json
import os
import shlex
import signal
import subprocess
import sys
import time

import pytest
import yaml

from conftest import chunk_stats, tree_digest
from dvc_project import ENV, REPO, clone_project, merge, sh

# one xdist worker for this module and test_dvc_hygiene: they share the tiny project of one `dvc repro` (conftest's
# tiny_dvc_project), and the kill tests each continue the copy the previous kill left
pytestmark = pytest.mark.xdist_group("dvc_pipeline")


@pytest.fixture(scope="module")
def project(tiny_dvc_project, tmp_path_factory):
    """A copy of the shared tiny project, up to date: the kill tests change its params and kill its stages."""
    return clone_project(tiny_dvc_project.path, tmp_path_factory.mktemp("kills") / "proj")


def test_repro_runs_every_stage_then_nothing(tiny_dvc_project):
    project, stdout = tiny_dvc_project.path, tiny_dvc_project.repro_stdout
    for stage in ("sample", "blend", "render", "fit", "eval", "stress", "eval_stress", "reference", "eval_reference",
                  "charts"):
        assert f"Running stage '{stage}'" in stdout, stdout[-2000:]
    for out in ("data/variants.zarr", "data/blends.zarr", "data/renders.zarr", "runs/train/checkpoint.pt",
                "runs/eval/eval.json", "runs/eval/eval.md", "runs/train/loss.csv", "runs/eval_stress/eval.md",
                "runs/charts/chart_render.png", "runs/charts/chart_stress.png", "runs/eval_stress/eval.png"):
        assert (project / out).exists(), out
    # reference.sources is empty (the default): the reference stages skip in one line each and leave empty outputs
    said = [ln for ln in stdout.splitlines() if ln.startswith("no reference sources")]
    assert len(said) == 2, stdout
    assert (project / "data/reference").is_dir() and not any((project / "data/reference").iterdir())
    assert json.loads((project / "runs/eval_reference/eval_metrics.json").read_text()) == {}
    assert not any((project / "runs/eval_reference/eval").iterdir())
    metrics = sh(["dvc", "metrics", "show", "--json"], project).stdout
    assert "rerender" in metrics and "eval_metrics.json" in metrics and "it_per_s" not in metrics
    again = sh(["dvc", "repro"], project)
    assert "Running stage" not in again.stdout, again.stdout
    assert "up to date" in sh(["dvc", "status"], project).stdout
    # the data stages rerun minutes later, in another time zone and another commit, write the same bytes (issue 40:
    # a store once recorded the time and the commit, so a fresh clone's `dvc repro` left dvc.lock changed)
    lock = (project / "dvc.lock").read_text()
    sh("git add -A && git commit -qm 'the first run'", project)
    data = ["import", "sample", "blend", "render", "stress", "reference"]
    # with dask workers (the first run had none: SVGEN_WORKERS=0), so the worker count must change no byte either
    later = sh(["dvc", "repro", "--force", "--single-item", *data], project, env={**ENV, "TZ": "Pacific/Kiritimati"})
    assert all(f"Running stage '{stage}'" in later.stdout for stage in data), later.stdout[-2000:]
    changed = list(difflib.unified_diff(lock.splitlines(), (project / "dvc.lock").read_text().splitlines(), n=6))
    assert not changed, "\n".join(changed[:60])
    assert "up to date" in sh(["dvc", "status"], project).stdout


#: stage -> (params that make it (and what follows) run again, a file that shows it is under way, how many
#: entries that folder must hold before the kill; None: the file's existence).
#: sample is not here: its kill and resume are tests/test_sample_resume.py's, through the chunk-task code that blend
#: and render share with it; what DVC adds (`dvc repro` after a kill) is shown for a store stage by those two.
KILLS = {
    # stored maps: a recipe blend (the default) takes milliseconds, so 40 of them could finish before the kill
    "blend": ({"blend": {"seed": 1, "chunk": 1, "count": 40, "maps": "stored"}}, "data/blends.zarr.partial/.done", 2),
    "render": ({"render": {"seed": 1, "chunk": 1}}, "data/renders.zarr.partial/.done", 3),
    # 120 steps: ~6 s at the tiny model's ~20 it/s, so the kill (within 20 ms of the step-2 checkpoint) lands with
    # ~5 s to spare on this machine and seconds more on a loaded one; each of the test's two fits runs them all
    "fit": ({"train": {"optim": {"seed": 1, "iterations": 120, "checkpoint_every": 2}}}, "runs/train/checkpoint.pt",
            None),
}
#: stage -> (an array of its output store, its number of dimensions): whose chunk files show a resume kept them.
CHUNKED = {"blend": ("diffuse", 4), "render": ("image", 5)}
# the reference runs the svgen that `dvc repro` runs (the installed console script, not the project copy's modules)
SVGEN = ["svgen"]
STAGES = yaml.safe_load((REPO / "dvc.yaml").read_text())["stages"]
SVTRAIN = [sys.executable, "-c", "from train.cli import main; main()"]


@pytest.mark.parametrize("stage", list(KILLS))
def test_sigkill_during_a_stage_then_repro_gives_the_same_outputs(project, stage):
    """SIGKILL the whole `dvc repro STAGE` session while ``stage`` is half done, `dvc repro STAGE` again: its output
    equals a clean run of the same command (written here beside it, in this process's own worker setting)."""
    change, marker, entries = KILLS[stage]
    params = yaml.safe_load((project / "params.yaml").read_text())
    merge(params, change)
    (project / "params.yaml").write_text(yaml.safe_dump(params))
    marker = project / marker
    for name in ("checkpoint.pt", "model.pt"):  # not mistaken for the new run's
        (project / "runs" / "train" / name).unlink(missing_ok=True)

    def under_way() -> bool:
        if entries is None:
            return marker.exists()
        return marker.is_dir() and len(list(marker.iterdir())) >= entries

    # `dvc repro STAGE`: the stage and what it depends on, not the stages after it (test_repro_runs_every_stage_
    # then_nothing covers those): rerunning every later stage after each kill took 2/3 of this test's time
    log = open(project.parent / f"repro_{stage}.log", "w")  # said in the failure: why a stage never got under way
    proc = subprocess.Popen(["dvc", "repro", stage], cwd=project, env=ENV, stdout=log, stderr=subprocess.STDOUT,
                            start_new_session=True)
    # 600 s for a stage to get under way (a failure only costs the wait): all four cases ran out of 300 s once in a full
    # suite beside two `dvc repro` runs (load average 12-15), and each passed alone (sample: 232 s, fixture included)
    deadline = time.time() + 600
    while time.time() < deadline and not under_way() and proc.poll() is None:
        time.sleep(0.02)
    os.killpg(proc.pid, signal.SIGKILL)  # dvc, svgen and its dask workers: the whole session
    proc.wait()
    log.close()
    assert under_way(), (f"the {stage} stage never got under way (dvc exit {proc.returncode}); its output:\n"
                         + (project.parent / f"repro_{stage}.log").read_text()[-3000:])
    final = {"blend": "data/blends.zarr", "render": "data/renders.zarr", "fit": "runs/train/model.pt"}[stage]
    assert not (project / final).exists(), f"{stage} had finished before the kill: the test proves nothing"
    # what the rerun must keep: the finished chunks' files (inode, mtime) or the checkpoint's step
    if stage == "fit":
        import torch

        ck_step = int(torch.load(project / "runs/train/checkpoint.pt", weights_only=False)["step"])
    else:
        array, ndim = CHUNKED[stage]
        # a marker is named by its chunk id; 'N.tmp' is one the kill caught being written (not finished: the
        # store's pending() rewrites that chunk), so only whole ids count
        finished = sorted(int(m.name) for m in marker.iterdir() if m.name.isdigit())
        kept = chunk_stats(marker.parent, finished, array, ndim)

    sh(["dvc", "repro", stage], project)
    assert "up to date" in sh(["dvc", "status", stage], project).stdout
    # beside the output: a store records its inputs relative to its own directory (path independence), so a
    # reference written elsewhere would record other relative paths
    ref = project / "data" / f"ref_{stage}.zarr" if stage != "fit" else project / f"ref_{stage}"
    if stage == "fit":
        sh(SVTRAIN + ["fit", "--params", "params.yaml", "--store", "data/renders.zarr", "--out", str(ref),
                      "--no-resume"], project)
        import torch

        import json

        resumed = json.loads((project / "runs/train/timing.json").read_text())["resumed_from"]  # the run's clock
        assert resumed == ck_step, f"dvc repro's fit started at {resumed}, not at the checkpoint's step {ck_step}"
        a = torch.load(project / final, weights_only=False)["model"]
        b = torch.load(ref / "model.pt", weights_only=False)["model"]
        assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)
        # the resumed run's outputs are the uninterrupted run's bytes (what dvc.lock hashes; run.json names the
        # store relative to its own run directory, which differs here)
        for name in ("model.pt", "checkpoint.pt", "metrics.json", "provenance.json", "config.yaml", "loss.csv"):
            assert (project / "runs" / "train" / name).read_bytes() == (ref / name).read_bytes(), name
        return
    # the stage's own command (its history line is part of the bytes), writing to ref, in this process's workers
    words = [str(ref) if w == final else w for w in shlex.split(STAGES[stage]["cmd"])]
    assert words[0] == "svgen" and str(ref) in words, words
    sh(SVGEN + words[1:] + ["--workers", "0"], project)
    assert tree_digest(project / final) == tree_digest(ref)
    assert chunk_stats(project / final, finished, array, ndim) == kept, \
        f"dvc repro's {stage} rewrote chunks finished before the kill"
