"""Held-out error against training time within one fit (``optim.eval_every``): the curve of benchmarks/ablation.py.

Every ``eval_every`` steps (and before the first and after the last) the network is evaluated on a fixed subset of
the held-out split, ``data.eval_views`` views spread evenly over it, centre-cropped: the same views for every run
with the same data, split seed and store, whatever the training seed, loss or model. heldout.csv holds each row's
step and errors (a DVC plot: the same bytes on any machine); the training clock at each row goes to timing.json
(train/timing.py, not hashed by DVC). The clock counts training only: the time spent here is excluded, so two
arms' curves compare error at equal training cost.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import torch

from .evaluate import COLUMNS, metrics

HEADER = ("step", *COLUMNS)
FILE = "heldout.csv"


def subset(test_idx: np.ndarray, n: int) -> np.ndarray:
    """``n`` indices spread evenly over ``test_idx`` (all of them when there are fewer): a store lists its views
    preset by preset, so the first n would be a handful of materials."""
    test_idx = np.asarray(test_idx, np.int64)
    if len(test_idx) <= n:
        return test_idx
    return test_idx[np.linspace(0, len(test_idx) - 1, n).round().astype(np.int64)]


class TrainClock:
    """Wall and CPU seconds of training, with pauses (evaluation) left out. CPU is this process's (all its threads;
    DataLoader worker processes are not counted)."""

    def __init__(self, wall: float = 0.0, cpu: float = 0.0):
        self.wall, self.cpu = float(wall), float(cpu)
        self._mark: tuple[float, float] | None = None

    def start(self) -> None:
        self._mark = (time.perf_counter(), time.process_time())

    def totals(self) -> tuple[float, float]:
        """(wall, cpu) up to now, the clock left running if it was (what a checkpoint records)."""
        if self._mark is not None:
            self.stop()
            self.start()
        return self.wall, self.cpu

    def stop(self) -> tuple[float, float]:
        """Add the time since :meth:`start`; returns the totals."""
        if self._mark is not None:
            self.wall += time.perf_counter() - self._mark[0]
            self.cpu += time.process_time() - self._mark[1]
            self._mark = None
        return self.wall, self.cpu


class HeldoutProbe:
    """Evaluates a network on a fixed held-out subset; the batches are loaded once.

    Args:
        src: the data source. test_idx: the held-out indices. crop: centre-crop side.
        views: how many held-out views. batch_size: views per forward pass.
    """

    def __init__(self, src, test_idx, crop: int, views: int, batch_size: int = 8):
        from .data import PairDataset

        self.indices = subset(test_idx, views)
        ds = PairDataset(src, self.indices, crop, 0, train=False)
        items = [ds[k] for k in range(len(ds))]
        self.batches = [(torch.stack([x[0] for x in items[lo:lo + batch_size]]),
                         torch.stack([x[1] for x in items[lo:lo + batch_size]]))
                        for lo in range(0, len(items), batch_size)]

    @torch.no_grad()
    def __call__(self, net: torch.nn.Module, device: torch.device) -> dict[str, float]:
        """Mean RMSE per column (:data:`train.evaluate.COLUMNS`); the network is put back in training mode."""
        net.eval()
        acc: dict[str, list] = {c: [] for c in COLUMNS}
        try:
            for img, gt in self.batches:
                for c, v in metrics(net(img.to(device)).float(), gt.to(device)).items():
                    acc[c].extend(v.tolist())
        finally:
            net.train()
        return {c: float(np.mean(v)) for c, v in acc.items()}


def write(path: Path, rows: list[dict]) -> None:
    """heldout.csv: one row per evaluation (:data:`HEADER`); only the header when there was none."""
    with open(path, "w") as f:
        f.write(",".join(HEADER) + "\n")
        for r in rows:
            f.write(",".join(str(r["step"]) if k == "step" else f"{r[k]:.6g}" for k in HEADER) + "\n")
