"""``svtrain fit``: the training loop, checkpoints that resume bit-for-bit, metrics and the loss curve.

Resume equivalence: everything random is either a pure function of (seed, step) (the batches, see
``train.data``) or a generator whose state is checkpointed (loss configurations: ``loss_rng``;
dropout: torch's global RNG). So stopping at any checkpoint and resuming reproduces the
uninterrupted run exactly on the same machine and thread count.

Outputs in the run directory: ``config.yaml`` (resolved), ``checkpoint.pt`` (full state),
``model.pt`` (weights + config + provenance), ``provenance.json`` (data source, config preset, library
versions), ``metrics.json``, ``loss.csv``, ``loss.png``.
"""
from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np
import torch
import yaml

from svcore.errors import ConfigError, SvgenError
from svcore.log import get_logger
from svcore.progress import progress
from svcore.seeds import stream_seed
from svcore.versions import library_versions

from . import checkpoint
from .config import Config, OptimConfig
from .data import PairDataset, make_loader, open_source, split_by_source
from .loss import make_loss
from .net import SVBRDFNet, count_parameters

log = get_logger(__name__)


def build(cfg: Config) -> tuple[SVBRDFNet, torch.optim.Optimizer, torch.Generator]:
    """Fresh model (seeded init), Adam, and the loss-configuration generator."""
    o = cfg.optim
    torch.manual_seed(stream_seed(o.seed, "train.init"))
    model = SVBRDFNet(cfg.model)
    opt = torch.optim.Adam(model.parameters(), lr=o.lr, betas=(o.beta1, o.beta2))
    gen = torch.Generator().manual_seed(stream_seed(o.seed, "train.loss_configs"))
    torch.manual_seed(stream_seed(o.seed, "train.dropout"))
    return model, opt, gen


def provenance(cfg: Config, src) -> dict:
    """What a run trained on and with: the config preset, the data source (a renders store's path and config
    hash, or the synthetic source's settings) and the library versions (stores record the same)."""
    if cfg.data.store:
        meta = getattr(src, "attrs", {}).get("svgen", {})
        data = {"store": str(cfg.data.store), "store_resolved": str(Path(cfg.data.store).resolve()),
                "kind": meta.get("kind"), "config_hash": meta.get("config_hash"), "n": meta.get("n")}
    else:  # the source actually used (a caller may pass its own), not the config's synthetic_* defaults
        data = {"synthetic": {k: getattr(src, a, None) for k, a in (("samples", "n"), ("size", "size"),
                                                                    ("materials", "n_materials"), ("seed", "seed"),
                                                                    ("kind", "kind"))}}
    return {"config_preset": cfg.preset, "data": data, "versions": library_versions()}


def lr_at(o: OptimConfig, step: int) -> float:
    """Learning rate of step ``step`` (0-based) of a run of ``o.iterations`` steps."""
    if o.schedule == "constant" or o.iterations <= 1:
        return o.lr
    t = min(step, o.iterations - 1) / (o.iterations - 1)
    return o.lr * (o.lr_final + (1.0 - o.lr_final) * 0.5 * (1.0 + math.cos(math.pi * t)))


def train_step(model: SVBRDFNet, opt: torch.optim.Optimizer, loss_fn, image: torch.Tensor, maps: torch.Tensor,
               gen: torch.Generator, o: OptimConfig, step: int) -> tuple[float, float]:
    """One optimisation step of ``svtrain fit`` (benchmarks call this too, so they measure the same step).

    Args:
        image: (B, 3, H, W) linear input photos. maps: (B, 10, H, W) packed target maps.
        step: 0-based index of this step (sets the scheduled learning rate).

    Returns:
        (loss, gradient norm before clipping).
    """
    for group in opt.param_groups:
        group["lr"] = lr_at(o, step)
    pred = model(image)
    loss = loss_fn(pred, maps, gen)
    if o.map_l1 > 0:
        loss = loss + o.map_l1 * (pred - maps).abs().mean()
    if o.normal_l2 > 0:
        loss = loss + o.normal_l2 * ((pred[:, 0:2] - maps[:, 0:2]) ** 2).mean()
    opt.zero_grad(set_to_none=True)
    loss.backward()
    # clip_grad_norm_ with max_norm=inf only measures the norm (same code path, no rescale)
    norm = torch.nn.utils.clip_grad_norm_(model.parameters(), o.grad_clip if o.grad_clip > 0 else math.inf)
    opt.step()
    return float(loss.detach()), float(norm)


def _write_outputs(out: Path, cfg: Config, losses: list[float], extra: dict) -> dict:
    o = cfg.optim
    arr = np.asarray(losses, np.float64)
    rows = []
    for end in range(o.log_every, len(arr) + 1, o.log_every):
        rows.append((end, float(arr[end - o.log_every:end].mean())))
    if len(arr) % o.log_every:
        rows.append((len(arr), float(arr[len(arr) - len(arr) % o.log_every:].mean())))
    with open(out / "loss.csv", "w") as f:
        f.write("step,loss\n")
        f.writelines(f"{s},{v:.6g}\n" for s, v in rows)
    tail = arr[-max(1, min(len(arr), 5 * o.log_every)):] if len(arr) else arr
    metrics = {"step": int(len(arr)), "loss_final": float(tail.mean()) if len(tail) else None,
               "loss_first": float(arr[:o.log_every].mean()) if len(arr) else None, **extra}
    (out / "metrics.json").write_text(json.dumps(metrics, indent=2) + "\n")
    _plot(out / "loss.png", rows)
    return metrics


def _plot(path: Path, rows: list[tuple[int, float]]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 3.5), dpi=100)
    if rows:
        ax.plot([r[0] for r in rows], [r[1] for r in rows])
    ax.set_xlabel("step")
    ax.set_ylabel("loss (rendering log-L1 + map terms)")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def fit(cfg: Config, out_dir: str | Path, resume: bool = True, source=None, stop_after: int | None = None,
        show_progress: bool | None = None) -> dict:
    """Train (or continue training) into ``out_dir``.

    Args:
        cfg: validated config.
        out_dir: run directory (created).
        resume: continue from ``out_dir/checkpoint.pt`` when it exists.
        source: a data source (default: ``open_source(cfg.data)``).
        stop_after: stop after this many steps of *this call* (tests simulate an interruption),
            checkpointing first.
        show_progress: force the progress bar on/off.

    Returns:
        the metrics dict (also in metrics.json).
    """
    cfg.check()
    o = cfg.optim
    # open the data first: a bad store must fail before the run directory exists
    src = source if source is not None else open_source(cfg.data)
    train_idx, test_idx = split_by_source(src, cfg.data.holdout, o.seed)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    if o.threads:
        torch.set_num_threads(o.threads)
    ckpt_path = out / "checkpoint.pt"
    model, opt, gen = build(cfg)
    start, losses = 0, []
    if resume and ckpt_path.exists():
        state = checkpoint.load(ckpt_path)
        if state["config"]["model"] != cfg.to_dict()["model"]:
            raise ConfigError(f"{out} holds a run with a different model config; use a new --out or --no-resume")
        model.load_state_dict(state["model"])
        opt.load_state_dict(state["optim"])
        gen.set_state(state["loss_rng"])
        torch.set_rng_state(state["torch_rng"])
        start, losses = int(state["step"]), list(state["losses"])
        log.info("resuming %s at step %d", out, start)
    (out / "config.yaml").write_text(yaml.safe_dump(cfg.to_dict(), sort_keys=False))
    (out / "provenance.json").write_text(json.dumps(provenance(cfg, src), indent=2) + "\n")
    ds = PairDataset(src, train_idx, cfg.data.crop, o.seed, train=True, flips=cfg.data.augment)
    stop = o.iterations if stop_after is None else min(o.iterations, start + stop_after)
    loss_fn = make_loss(o.compile_loss)

    def save(step: int) -> None:
        checkpoint.save(ckpt_path, {"config": cfg.to_dict(), "model": model.state_dict(), "optim": opt.state_dict(),
                                    "loss_rng": gen.get_state(), "torch_rng": torch.get_rng_state(), "step": step,
                                    "losses": losses})

    step = start
    t0 = time.perf_counter()
    bar = progress(total=o.iterations, desc="fit", unit="it", initial=start, disable=None if show_progress is None
                   else not show_progress)
    model.train()
    try:
        if stop > start:
            # A dedicated loader generator: DataLoader otherwise draws its base seed from torch's global
            # RNG, which would shift the dropout stream between an uninterrupted and a resumed run.
            loader = make_loader(ds, o.batch_size, start, stop, cfg.data.workers)
            loader.generator = torch.Generator().manual_seed(stream_seed(o.seed, "train.loader"))
            for image, maps in loader:
                loss, _ = train_step(model, opt, loss_fn, image, maps, gen, o, step)
                if not math.isfinite(loss):  # the weights are now non-finite too: keep the last good checkpoint
                    raise SvgenError(f"the loss became {loss} at step {step}: lower optim.lr or set optim.grad_clip "
                                     f"(the last checkpoint in {out} is from before it)")
                losses.append(loss)
                step += 1
                bar.update(1)
                bar.set_postfix(loss=f"{np.mean(losses[-o.log_every:]):.4f}")
                if step % o.checkpoint_every == 0 and step < stop:
                    save(step)
    except KeyboardInterrupt:
        save(step)
        bar.close()
        log.info("interrupted at step %d; checkpoint saved, rerun the same command to resume", step)
        raise
    bar.close()
    elapsed = time.perf_counter() - t0
    save(step)
    checkpoint.save(out / "model.pt", {"config": cfg.to_dict(), "model": model.state_dict(), "step": step,
                                       "provenance": provenance(cfg, src)})
    extra = {"it_per_s": (step - start) / elapsed if step > start and elapsed > 0 else None,
             "parameters": count_parameters(model), "train_samples": int(len(train_idx)),
             "test_samples": int(len(test_idx)), "done": step >= o.iterations}
    return _write_outputs(out, cfg, losses, extra)
