"""Checkpoint files: atomic writes, and loading a trained model with one-line errors.

Checkpoints hold only plain data (dicts, lists, tuples, strings, numbers, booleans, None) and tensors, so they load
with ``torch.load(weights_only=True)``: torch's restricted unpickler, which refuses any other object instead of
running the code a pickled object can carry (a downloaded checkpoint is untrusted input). :func:`save` converts
numpy values to plain ones and refuses anything else, so a checkpoint this code writes can always be read back.
Checkpoints written before this rule already held only such values (RNG states are tensors) and load unchanged.
"""
from __future__ import annotations

import os
import pickle
import sys
from pathlib import Path
from typing import Any

import numpy as np
import torch

from svcore.errors import SvgenError

from .config import Config, ModelConfig, drop_retired, from_dict
from .net import SVBRDFNet

FORMAT = "svtrain-checkpoint/1"
#: what the weights mean to :class:`SVBRDFNet` (input mapping, layer layout, output decoding): recorded in every
#: checkpoint; bump it when train/net.py changes any of these, so that exports and loads of older weights are refused
#: by name instead of silently computing something else (checkpoints written before it was recorded are format 1).
NETWORK_FORMAT = 1


def plain(value: Any, where: str = "state") -> Any:
    """``value`` with numpy scalars/arrays turned into Python numbers/tensors, checked to hold nothing that a
    ``weights_only`` load refuses; strings interned, so that equal states pickle to equal bytes (pickle writes an
    object it meets twice as a reference to the first: the strings of a state loaded from a checkpoint are other
    objects than a fresh run's, and a resumed run's checkpoint would differ from the uninterrupted run's).

    Raises:
        TypeError: another type (a programming error: the checkpoint could not be loaded back).
    """
    if type(value) is str:
        return sys.intern(value)
    if value is None or isinstance(value, (bool, int, float, str, torch.Tensor, torch.dtype, torch.device)):
        return value
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return torch.from_numpy(np.ascontiguousarray(value))
    if isinstance(value, dict):
        return {sys.intern(k) if type(k) is str else k: plain(v, f"{where}[{k!r}]") for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return type(value)(plain(v, f"{where}[{i}]") for i, v in enumerate(value))
    raise TypeError(f"checkpoint {where} is a {type(value).__name__}: store plain data or tensors")


def save(path: str | Path, state: dict[str, Any]) -> None:
    """Write ``state`` to ``path`` atomically (a kill mid-write leaves the previous file intact).

    ``state`` holds plain data and tensors only (:func:`plain`), so that :func:`load` can read it safely.
    """
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    torch.save(plain({"format": FORMAT, "network_format": NETWORK_FORMAT, **state}), tmp)
    os.replace(tmp, path)


def load(path: str | Path) -> dict[str, Any]:
    """Read a checkpoint (``weights_only``: tensors and plain data, nothing that runs code).

    Args:
        path: a checkpoint file, a run directory (its model.pt, else checkpoint.pt), or ``"bundled"``: the model
            shipped in the package (:mod:`train.bundled_model`).

    Raises:
        SvgenError: missing, unreadable or foreign file, or one that carries other pickled objects.
    """
    from . import bundled_model

    path = Path(bundled_model.resolve(path))  # the name "bundled": the package's model, checked (one-line errors)
    if path.is_dir():
        for name in ("model.pt", "checkpoint.pt"):
            if (path / name).is_file():
                path = path / name
                break
    if not path.is_file():
        raise SvgenError(f"checkpoint {str(path)!r} does not exist (train one with `svtrain fit`)")
    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except pickle.UnpicklingError:  # torch's restricted unpickler met a class or a function: it never ran it
        raise SvgenError(f"checkpoint {str(path)!r} holds pickled objects other than tensors and plain data; "
                         f"refused (loading it could run arbitrary code)") from None
    except Exception as e:  # torch raises many types for truncated/foreign files
        raise SvgenError(f"checkpoint {str(path)!r} is unreadable: {type(e).__name__}") from None
    if not isinstance(state, dict) or state.get("format") != FORMAT:
        raise SvgenError(f"{str(path)!r} is not an svtrain checkpoint")
    return state


def load_model(path: str | Path) -> tuple[SVBRDFNet, Config]:
    """The trained network (in eval mode) and its config from a checkpoint or run directory."""
    return model_from_state(load(path))


def model_from_state(state: dict[str, Any]) -> tuple[SVBRDFNet, Config]:
    """The network (in eval mode) and its config from a loaded checkpoint (:func:`load`)."""
    cfg = from_dict(state["config"])
    model = SVBRDFNet(cfg.model)
    model.load_state_dict(state["model"])
    model.eval()
    return model, cfg


def init_weights(source: str | None, model: ModelConfig) -> dict[str, torch.Tensor] | None:
    """The weights ``source`` names (``optim.init``: fine-tuning), checked to fit the network of ``model`` (this
    run's model config); None without one.

    Raises:
        SvgenError: not a checkpoint, run or "bundled"; a model config other than this run's.
    """
    if not source:
        return None
    state = load(source)
    theirs = drop_retired(state["config"])["model"]  # a run from before #41 may hold retired keys at their defaults
    ours = model.to_dict()
    weights = state["model"]
    if {k: theirs.get(k, v) for k, v in ours.items()} != ours:
        differ = ", ".join(f"model.{k}={theirs.get(k)!r} (this run: {v!r})" for k, v in ours.items()
                           if theirs.get(k, v) != v)
        raise SvgenError(f"--init {source}: its network differs from this run's ({differ}); set the same model "
                         f"config (--set model.KEY=VALUE) to fine-tune it, or --set optim.init=null to train from scratch")
    return weights
