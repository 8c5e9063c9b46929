"""Shared, seeded fixtures. Helpers that several test files use live here (append, don't rewrite)."""
from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numpy as np
import pytest

os.environ.setdefault("SVGEN_NO_PROGRESS", "1")


@pytest.fixture(autouse=True)
def dask_scheduler_config_unchanged():
    """Every test leaves this process's dask ``scheduler`` config as it found it. A leaked "dask.distributed" (a
    default Client that never closed) broke every later test on the same xdist worker that reads a store through
    xarray (CI of stop 31); this names the test that leaked it instead."""
    import sys

    def scheduler():
        return sys.modules["dask"].config.get("scheduler", None) if "dask" in sys.modules else None

    before = scheduler()
    yield
    after = scheduler()
    if after != before:  # put it back, so that the tests after this one still run as they would
        if before is None:
            sys.modules["dask"].config.config.pop("scheduler", None)
        else:
            sys.modules["dask"].config.set(scheduler=before)
        pytest.fail(f"this test left dask.config scheduler={after!r} (was {before!r}) in the test process")


@pytest.fixture
def rng() -> np.random.Generator:
    """A fresh generator with a fixed seed for every test."""
    return np.random.default_rng(12345)


def tree_digest(path: str | os.PathLike) -> dict[str, str]:
    """relative file path -> sha256 of every file under ``path``: the byte-identity of stores, every file included
    (zarr.json with its CF ``history`` and versions, the card): a store's bytes are a function of its seed, code,
    configuration and inputs alone (svcore.history, svcore.versions.store_versions)."""
    root = Path(path)
    return {str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(root.rglob("*")) if p.is_file()}


@pytest.fixture
def svgen_cli():
    """Run ``svgen`` in-process: returns (exit code, stderr text) and never raises."""
    import contextlib
    import io

    from pipeline.cli import cli
    from svcore.cli import run_cli

    def run(*args: str) -> tuple[int, str]:
        err, out = io.StringIO(), io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
            code = run_cli(cli, "svgen", [str(a) for a in args])
        return code, err.getvalue() + out.getvalue()

    return run


# --- materials (tests/test_materials_*.py) ---

def dump_maps(maps, tag: str) -> str:
    """Save an SVBRDF's maps as PNGs in a fresh temp dir (for failing image checks); returns the dir."""
    import tempfile

    from PIL import Image

    d = Path(tempfile.mkdtemp(prefix=f"svgen-{tag.replace('/', '_')}-"))
    for name, a in maps.as_dict().items():
        a = (a + 1) / 2 if name == "normal" else a
        a = np.repeat(a, 3, -1) if a.shape[-1] == 1 else a
        Image.fromarray((np.clip(a, 0, 1) * 255).astype(np.uint8)).save(d / f"{name}.png")
    return str(d)


@pytest.fixture(scope="session")
def material_presets():
    """Every registered preset (materials library), sorted by name."""
    from materials import presets

    return presets()



def chunk_stats(store, chunks, array, ndim):
    """chunk id -> (inode, mtime) of the chunk file of ``array`` (``ndim`` dimensions) for each of ``chunks``.

    zarr writes a chunk to a temp file and renames it, so a chunk written again has a new inode: what a resume
    test compares to prove that finished chunks were kept, not redone (equal bytes alone prove only determinism).
    """
    out = {}
    for c in chunks:
        st = (Path(store) / array / "c" / str(c) / "/".join(["0"] * (ndim - 1))).stat()
        out[c] = (st.st_ino, st.st_mtime_ns)
    return out


def stop_processes(procs) -> None:
    """Terminate server processes a test started (last started first), killing any that outlive 10 s."""
    import subprocess

    for p in procs[::-1]:
        p.terminate()
    for p in procs:
        try:
            p.wait(timeout=10)
        except subprocess.TimeoutExpired:
            p.kill()


@pytest.fixture(scope="session")
def tiny_dvc_project(tmp_path_factory):
    """The repository as a git + DVC project with tiny params (tests/dvc_project.py), `dvc repro` done once in
    this process (SVGEN_WORKERS=0): (the project, that repro's stdout). Shared: tests that change it take a copy
    (``dvc_project.clone_project``)."""
    from types import SimpleNamespace

    from dvc_project import FAST, copy_project, sh

    d = copy_project(tmp_path_factory.mktemp("tiny_dvc"))
    r = sh(["dvc", "repro"], d, env=FAST)
    return SimpleNamespace(path=d, repro_stdout=r.stdout)
