"""Data-parallel training on the CPU (gloo, 2 processes, torch's elastic launcher: ``svtrain fit --nproc`` and
``torchrun -m train.cli fit``).

- equivalence: 2 ranks x batch 4 end with the parameters of 1 process x batch 8 on the same samples;
- a killed rank stops the run with one line on stderr (no hang), naming the rank and the checkpoint;
- resuming from that checkpoint gives the uninterrupted run's parameters.
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import torch

from train.config import resolve
from train.fit import fit

#: tiny network and data; dropout off (per-rank dropout streams differ by design); one thread per rank.
TINY = {"model.base_width": 4, "model.max_width": 8, "model.levels": 3, "model.dropout": 0.0, "data.crop": 32,
        "data.synthetic_size": 40, "data.synthetic_samples": 24, "data.synthetic_materials": 4, "data.holdout": 0.25,
        "data.workers": 0, "optim.compile_loss": False, "optim.lr": 1e-3, "optim.iterations": 6,
        "optim.checkpoint_every": 2, "optim.log_every": 1, "optim.threads": 1}
#: Float tolerance of the equivalence. DDP averages the two ranks' gradients (g0 + g1) / 2 where one process sums
#: all 8 samples' terms in one reduction: the same sum in another order, ~1e-7 relative per step; 6 Adam steps of
#: lr 1e-3 keep parameter differences far below 1e-5 (a step moves a parameter by up to lr = 1e-3, so a wrong
#: sample, configuration or averaging shows up at the 1e-4..1e-3 level).
ATOL, RTOL = 2e-5, 1e-4


def svtrain(out: Path, *extra: str, env: dict | None = None, torchrun: bool = False) -> subprocess.Popen:
    """``svtrain fit --nproc 2`` (svtrain's launcher), or the same workers started by ``torchrun``."""
    launcher = ["-m", "torch.distributed.run", "--standalone", "--nproc-per-node", "2"] if torchrun else []
    args = [sys.executable, *launcher, "-m", "train.cli", "fit", "--out", str(out), "--batch-size", "4"]
    args += [] if torchrun else ["--nproc", "2"]
    for k, v in TINY.items():
        args += ["--set", f"{k}={v}"]
    return subprocess.Popen(args + list(extra), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "SVGEN_NO_PROGRESS": "1", **(env or {})})


def finish(p: subprocess.Popen, timeout: float = 240) -> tuple[int, str, str]:
    out, err = p.communicate(timeout=timeout)
    return p.returncode, out, err


def params(run: Path) -> dict[str, torch.Tensor]:
    return torch.load(run / "model.pt", weights_only=False)["model"]


@pytest.fixture(scope="module")
def ddp_run(tmp_path_factory) -> Path:
    """An uninterrupted 2-process run started by torchrun (the reference of the tests; the resumed run of svtrain's
    own launcher must match it bit for bit, so the two routes are one)."""
    d = tmp_path_factory.mktemp("ddp") / "run"
    code, out, err = finish(svtrain(d, torchrun=True))
    assert code == 0, err
    m = json.loads(out.strip().splitlines()[-1])
    assert m["world_size"] == 2 and m["global_batch"] == 8 and m["step"] == 6
    return d


def test_two_ranks_equal_one_process(ddp_run, tmp_path):
    single = fit(resolve("compact", None, {**TINY, "optim.batch_size": 8}), tmp_path / "one")
    assert single["world_size"] == 1 and single["global_batch"] == 8
    a, b = params(ddp_run), params(tmp_path / "one")
    # the starting parameters: a run stopped before its first step (optim.iterations must be >= 1)
    start = fit(resolve("compact", None, {**TINY, "optim.batch_size": 8}), tmp_path / "zero", stop_after=0)
    assert start["step"] == 0
    moved = max(float((a[k] - params(tmp_path / "zero")[k]).abs().max()) for k in a)
    assert moved > 100 * ATOL, "training did not move the parameters: the comparison would prove nothing"
    worst = {k: float((a[k] - b[k]).abs().max()) for k in a}
    for k in a:
        torch.testing.assert_close(a[k], b[k], atol=ATOL, rtol=RTOL, msg=lambda m: f"{k}: {m} (worst {worst})")
    # the logged loss of the global batch is the same curve
    la = torch.load(ddp_run / "checkpoint.pt", weights_only=False)["losses"]
    lb = torch.load(tmp_path / "one" / "checkpoint.pt", weights_only=False)["losses"]
    torch.testing.assert_close(torch.tensor(la), torch.tensor(lb), atol=1e-5, rtol=1e-5)


def test_killed_rank_stops_with_one_line_and_resume_continues_exactly(ddp_run, tmp_path):
    run, marker = tmp_path / "run", tmp_path / "paused"
    p = svtrain(run, env={"SVTRAIN_PAUSE_AT_STEP": f"1:3:{marker}"})  # rank 1 stops before step 3 (checkpoint at 2)
    t0 = time.time()
    while not marker.is_file() or not marker.read_text():
        assert p.poll() is None, p.communicate()
        assert time.time() - t0 < 120, "rank 1 never reached step 3"
        time.sleep(0.2)
    os.kill(int(marker.read_text()), signal.SIGKILL)
    t_kill = time.time()
    code, out, err = finish(p, timeout=120)  # a hang fails here
    assert code != 0
    # the failure is one line; what rank 0 logged before it (the synthetic demo source note) is not part of it
    lines = [ln for ln in err.splitlines() if ln.strip() and not ln.startswith("WARNING svgen.")]
    assert len(lines) == 1, err
    assert lines[0].startswith("svtrain: error: rank 1 of 2 was killed by SIGKILL"), err
    assert "step 2" in lines[0] and "resume" in lines[0], err
    assert time.time() - t_kill < 60
    assert torch.load(run / "checkpoint.pt", weights_only=False)["step"] == 2

    code, out, err = finish(svtrain(run))  # the same command resumes
    assert code == 0, err
    m = json.loads(out.strip().splitlines()[-1])
    assert m["resumed_from"] == 2 and m["step"] == 6
    a, b = params(ddp_run), params(run)
    for k in a:
        assert torch.equal(a[k], b[k]), k


def test_other_world_size_resume(ddp_run, tmp_path):
    """A 2 x 4 checkpoint continues in one process only with the same global batch, and says why otherwise."""
    import shutil

    from svcore.errors import ConfigError

    run = tmp_path / "run"
    shutil.copytree(ddp_run, run)
    cfg = resolve("compact", None, {**TINY, "optim.iterations": 8})  # batch_size 8 (default) x 1 = 8: continues
    m = fit(cfg, run)
    assert m["resumed_from"] == 6 and m["step"] == 8
    with pytest.raises(ConfigError, match="global batch of 8.*--global-batch 8"):
        fit(resolve("compact", None, {**TINY, "optim.batch_size": 4, "optim.iterations": 10}), run)


def test_rank_batches_partition_the_global_batch():
    """Rank r's positions of step t are the r-th block of the one-process batch: together exactly that batch."""
    from train.data import StepSampler

    one = list(StepSampler(8, 3, 6))
    ranks = [list(StepSampler(4, 3, 6, global_batch=8, rank=r)) for r in range(2)]
    assert [a + b for a, b in zip(*ranks)] == one
    assert one[0] == list(range(24, 32))


def test_launcher_params_read_back_as_the_resolved_config(tmp_path):
    """``svtrain fit --nproc`` hands its resolved config to the workers as a params file: the loader must read back
    every value (floats such as 2e-5, a null store, nested sections) and the preset's name, with nproc 1."""
    from train.distributed import write_worker_params

    cfg = resolve("paper", None, {"optim.lr": 2e-5, "optim.normal_l2": 0.5, "data.synthetic_size": 288,
                                  "compute.device": "cpu", "compute.precision": "bf16", "compute.nproc": 4,
                                  "compute.global_batch": 12})
    back = resolve(None, write_worker_params(cfg, tmp_path / "params.yaml"))
    assert back.preset == "paper" and back.compute.nproc == 1
    assert back.as_dict() == {**cfg.as_dict(), "compute": {**cfg.as_dict()["compute"], "nproc": 1}}
