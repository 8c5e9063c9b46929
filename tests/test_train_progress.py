"""A long fit seen from outside: progress lines when stderr is not a terminal, loss.csv written as the run goes,
checkpoints on a time interval (so a run that dies loses minutes), and a resume from such a checkpoint."""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
import torch

from train.config import resolve
from train.evaluate import fit_means
from train.fit import fit
from train.synthetic import SyntheticSource

ROOT = Path(__file__).resolve().parents[1]
TINY = {"model.base_width": 4, "model.max_width": 16, "model.levels": 4, "data.crop": 32, "data.workers": 0,
        "optim.compile_loss": False, "optim.batch_size": 4, "optim.log_every": 2, "optim.iterations": 12,
        "optim.checkpoint_every": 1000}
#: a fit: "fit: 3/6 (50%)  2.10it/s, ETA 00:01, loss=0.1234"
LINE = re.compile(r"fit: (\d+)/6 \(\d+%\) +[\d.?]+\s*(?:s/)?it(?:/s)?, ETA [\d:?]+, loss=\d")


class DiesAt(SyntheticSource):
    """The synthetic source, failing when the batch of 0-based step ``step`` is loaded, after ``step`` steps (a run
    killed mid-way)."""

    def __init__(self, step: int, batch: int, before: int = 0):
        super().__init__(16, 40, 4, seed=2)
        self.reads, self.limit = 0, step * batch + before

    def image(self, i):
        self.reads += 1
        if self.reads > self.limit:
            raise RuntimeError("the run dies here")
        return super().image(i)


def test_fit_prints_progress_lines_when_stderr_is_a_pipe(tmp_path):
    env = {k: v for k, v in os.environ.items() if k not in ("SVGEN_NO_PROGRESS", "TQDM_DISABLE", "SVGEN_PROGRESS")}
    env.update(PYTHONPATH=str(ROOT), SVGEN_PROGRESS_EVERY="0", OMP_NUM_THREADS="1")
    sets = {**TINY, "optim.iterations": 6, "data.synthetic_samples": 16, "data.synthetic_size": 40,
            "data.synthetic_materials": 4}
    args = [sys.executable, "-m", "train.cli", "fit", "--out", str(tmp_path / "run"), "--no-compile"]
    for k, v in sets.items():
        if k != "optim.compile_loss":
            args += ["--set", f"{k}={v}"]
    proc = subprocess.run(args, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    steps = [int(m.group(1)) for m in LINE.finditer(proc.stderr)]
    assert steps == [1, 2, 3, 4, 5, 6], proc.stderr  # every step with a 0 s interval, none twice
    assert "\r" not in proc.stderr  # lines, not a bar's redraws


def test_loss_csv_and_time_checkpoints_are_written_as_the_run_goes(tmp_path):
    b = TINY["optim.batch_size"]
    cfg = resolve("compact", None, {**TINY, "optim.checkpoint_minutes": 1e-9})
    # the images fit reads before its first step (the baselines' training means), counted, not assumed
    probe = DiesAt(10 ** 9, b)
    fit_means(probe, cfg.data, cfg.optim.seed)
    before = probe.reads
    with pytest.raises(RuntimeError, match="the run dies here"):
        fit(cfg, tmp_path / "timed", source=DiesAt(7, b, before))
    run = tmp_path / "timed"
    # loss.csv holds the rows of the steps done before the run died (before: written only at the end)
    assert (run / "loss.csv").read_text().splitlines()[0] == "step,loss"
    assert [int(r.split(",")[0]) for r in (run / "loss.csv").read_text().splitlines()[1:]] == [2, 4, 6]
    # the time interval checkpointed long before the first checkpoint by steps (1000)
    assert torch.load(run / "checkpoint.pt", weights_only=False)["step"] == 7  # every step done, here

    # by steps only, the same death leaves no checkpoint at all
    by_steps = resolve("compact", None, {**TINY, "optim.checkpoint_minutes": 0})
    with pytest.raises(RuntimeError):
        fit(by_steps, tmp_path / "steps", source=DiesAt(7, b, before))
    assert not (tmp_path / "steps" / "checkpoint.pt").exists()

    # the run continues from the timed checkpoint, and its outputs equal an uninterrupted run's
    fit(cfg, run, source=SyntheticSource(16, 40, 4, seed=2))
    whole = fit(cfg, tmp_path / "whole", source=SyntheticSource(16, 40, 4, seed=2))
    assert (run / "loss.csv").read_text() == (tmp_path / "whole" / "loss.csv").read_text()
    assert whole["resumed_from"] is None
    a = torch.load(run / "model.pt", weights_only=False)["model"]
    w = torch.load(tmp_path / "whole" / "model.pt", weights_only=False)["model"]
    assert all(torch.equal(a[k], w[k]) for k in w)
