"""Shared, seeded fixtures. Helpers that several test files use live here (append, don't rewrite)."""
from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numpy as np
import pytest

os.environ.setdefault("SVGEN_NO_PROGRESS", "1")


@pytest.fixture
def rng() -> np.random.Generator:
    """A fresh generator with a fixed seed for every test."""
    return np.random.default_rng(12345)


def tree_digest(path: str | os.PathLike) -> dict[str, str]:
    """relative file path -> sha256 of every file under ``path`` (byte-identity of stores)."""
    root = Path(path)
    return {str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(root.rglob("*")) if p.is_file()}


@pytest.fixture
def svgen_cli():
    """Run ``svgen`` in-process: returns (exit code, stderr text) and never raises."""
    import contextlib
    import io

    from pipeline.cli import cli, run_cli

    def run(*args: str) -> tuple[int, str]:
        err, out = io.StringIO(), io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
            code = run_cli(cli, "svgen", [str(a) for a in args])
        return code, err.getvalue() + out.getvalue()

    return run
