"""Checkpoint files: atomic writes, and loading a trained model with one-line errors."""
from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import torch

from svcore.errors import SvgenError

from .config import Config, from_dict
from .net import SVBRDFNet

FORMAT = "svtrain-checkpoint/1"


def save(path: str | Path, state: dict[str, Any]) -> None:
    """Write ``state`` to ``path`` atomically (a kill mid-write leaves the previous file intact)."""
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    torch.save({"format": FORMAT, **state}, tmp)
    os.replace(tmp, path)


def load(path: str | Path) -> dict[str, Any]:
    """Read a checkpoint; missing or foreign files raise :class:`SvgenError`."""
    path = Path(path)
    if path.is_dir():
        for name in ("model.pt", "checkpoint.pt"):
            if (path / name).is_file():
                path = path / name
                break
    if not path.is_file():
        raise SvgenError(f"checkpoint {str(path)!r} does not exist (train one with `svtrain fit`)")
    try:
        state = torch.load(path, map_location="cpu", weights_only=False)
    except Exception as e:  # torch raises many types for truncated/foreign files
        raise SvgenError(f"checkpoint {str(path)!r} is unreadable: {type(e).__name__}") from None
    if not isinstance(state, dict) or state.get("format") != FORMAT:
        raise SvgenError(f"{str(path)!r} is not an svtrain checkpoint")
    return state


def load_model(path: str | Path) -> tuple[SVBRDFNet, Config]:
    """The trained network (in eval mode) and its config from a checkpoint or run directory."""
    state = load(path)
    cfg = from_dict(state["config"])
    model = SVBRDFNet(cfg.model)
    model.load_state_dict(state["model"])
    model.eval()
    return model, cfg
