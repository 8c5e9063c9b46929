"""The pretrained model shipped inside the package (``train/bundled/``): finding it, checking it, loading it by name.

``train/bundled/`` holds package data, not code (pyproject ``[tool.setuptools.package-data]``):

- ``model.pt``: a weights-only svtrain checkpoint (:mod:`train.checkpoint` format: config, weights, step,
  provenance), loadable with ``torch.load(weights_only=True)``;
- ``bundled.json``: its manifest: the file's SHA-256 and size (a damaged file is named, never loaded half-way), the
  run it came from, whether it is a placeholder, and the training split's map means that ``svtrain eval``'s
  baselines use (``train_means``; a model bundled since ``svtrain fit`` records them carries them in its
  provenance too), so that the model evaluates on any store without its training store;
- ``MODEL_CARD.md``: what the model is (data, training, licence, evaluation tables, known failure cases), written
  by ``svtrain bundle`` (:mod:`train.bundle`).

Commands accept the model by the name :data:`NAME` wherever they take a checkpoint (``--checkpoint bundled``,
``svtrain fit --init bundled``), and ``svtrain predict`` uses it when no ``--checkpoint`` is given.
"""
from __future__ import annotations

import hashlib
import json
from importlib import resources
from pathlib import Path
from typing import Any

from svcore.errors import SvgenError

#: the name that stands for the bundled model where a checkpoint is expected.
NAME = "bundled"
MODEL_FILE = "model.pt"
MANIFEST_FILE = "bundled.json"
CARD_FILE = "MODEL_CARD.md"
#: how to get intact package data back (the files ship in the wheel; a checkout has them in git).
REINSTALL = ("reinstall svgen (`pip install --force-reinstall --no-deps svgen`, or `pip install .` in a checkout; "
             "in a git checkout `git checkout -- train/bundled`)")


class BundledModelError(SvgenError):
    """The bundled model's files are missing or damaged."""


def folder() -> Path:
    """The installed ``train/bundled`` folder (a path on disk: the package is installed as files, not zipped)."""
    return Path(str(resources.files("train").joinpath("bundled")))


def is_bundled(checkpoint: str | Path | None) -> bool:
    """Whether a ``--checkpoint`` value names the bundled model (the exact word :data:`NAME`)."""
    return isinstance(checkpoint, str) and checkpoint == NAME


def sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def manifest(where: Path | None = None) -> dict[str, Any]:
    """The bundled model's manifest (``bundled.json``).

    Raises:
        BundledModelError: missing or unreadable (names the file and how to reinstall).
    """
    path = (where or folder()) / MANIFEST_FILE
    if not path.is_file():
        raise BundledModelError(f"the bundled model's manifest {path} is missing: {REINSTALL}")
    try:
        data = json.loads(path.read_text())
        _ = data["sha256"], data["bytes"]
    except (OSError, ValueError, KeyError, TypeError):
        raise BundledModelError(f"the bundled model's manifest {path} is damaged: {REINSTALL}") from None
    return data


def model_path(where: Path | None = None) -> Path:
    """The bundled weights file, checked against its manifest (size and SHA-256).

    Raises:
        BundledModelError: the file or its manifest is missing, or the file differs from what the manifest
            records (truncated, altered).
    """
    where = where or folder()
    info = manifest(where)
    path = where / MODEL_FILE
    if not path.is_file():
        raise BundledModelError(f"the bundled model {path} is missing: {REINSTALL}")
    if path.stat().st_size != info["bytes"] or sha256(path) != info["sha256"]:
        raise BundledModelError(f"the bundled model {path} is damaged (its size or SHA-256 differs from "
                                f"{MANIFEST_FILE}): {REINSTALL}")
    return path


def resolve(checkpoint: str | Path) -> str | Path:
    """``checkpoint`` as a path: the checked bundled file for :data:`NAME`, anything else unchanged."""
    return model_path() if is_bundled(checkpoint) else checkpoint


def describe(where: Path | None = None) -> str:
    """One line saying which bundled model runs (for ``svtrain predict`` without ``--checkpoint``).

    Raises:
        BundledModelError: see :func:`model_path` (checked first, so that a damaged model says only that).
    """
    where = where or folder()
    model_path(where)
    info = manifest(where)
    what = "a placeholder model" if info.get("placeholder") else "the bundled model"
    return (f"using {what} shipped with svgen ({where / MODEL_FILE}, {info.get('steps', '?')} steps on "
            f"{info.get('data', 'svgen data')}; card: {where / CARD_FILE}); pass --checkpoint RUN for your own")
