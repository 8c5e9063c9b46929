"""Pipeline faults: a corrupted chunk in an input store is detected and named (never silently used), and a
full disk gives one clear line, leaves no complete-looking store, and keeps earlier outputs intact."""
from __future__ import annotations

import contextlib
import os
import sys
import warnings
import io
import shutil
import subprocess
import uuid
from pathlib import Path

import pytest

from conftest import tree_digest
from pipeline.cli import cli
from pipeline.config import RenderConfig, SampleConfig
from pipeline.render.stage import run_render
from pipeline.sample import run_sample
from svcore.cli import run_cli
from svcore.config import build

PRESETS = ("paint/glossy_red", "wood/oak_planks")


def call(*args) -> tuple[int, str]:
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = run_cli(cli, "svgen", [str(a) for a in args])
    return code, err.getvalue()


def corrupt(path: Path) -> None:
    b = bytearray(path.read_bytes())
    b[len(b) // 2] ^= 0x5A
    path.write_bytes(bytes(b))


@pytest.fixture
def variants(tmp_path):
    out = tmp_path / "v.zarr"
    run_sample(out, build(SampleConfig, "tiny", presets=PRESETS, per_preset=2, chunk=2), workers=0)
    return out


def test_render_names_a_corrupted_input_chunk(variants, tmp_path):
    corrupt(variants / "diffuse" / "c" / "1" / "0" / "0" / "0")
    code, err = call("render", variants, tmp_path / "r.zarr", "--config-preset", "tiny", "--workers", "0")
    assert code != 0 and err.count("\n") == 1
    assert "corrupt data" in err and "'diffuse'" in err and "chunk 1" in err, err
    assert not (tmp_path / "r.zarr").exists()


def test_training_refuses_a_corrupted_renders_chunk(variants, tmp_path):
    from train.cli import svtrain

    r = tmp_path / "r.zarr"
    run_render(variants, r, build(RenderConfig, "tiny", chunk=1), workers=0)
    corrupt(r / "image" / "c" / "2" / "0" / "0" / "0" / "0")
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = run_cli(svtrain, "svtrain", ["fit", "--store", r, "--out", tmp_path / "run", "--iterations", 6,
                                            "--set", "model.base_width=4", "--set", "model.max_width=8",
                                            "--set", "model.levels=3", "--set", "data.crop=32",
                                            "--set", "data.holdout=0.5", "--set", "optim.batch_size=4",
                                            "--workers", "0", "--no-compile"])
    msg = err.getvalue()
    assert code != 0 and "corrupt data" in msg and "'image'" in msg and "chunk 2" in msg, msg


@pytest.fixture
def small_disk():
    """A 3 MiB tmpfs (root can mount one here and in CI); skipped with the reason where mounting is not allowed."""
    mnt = Path("/tmp") / f"svgen-full-{uuid.uuid4().hex[:8]}"
    mnt.mkdir()
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=3m", "tmpfs", str(mnt)], capture_output=True, text=True)
    if r.returncode != 0:
        mnt.rmdir()
        # loud: CI can mount, so there a failure to mount fails; elsewhere a warning in the summary, and
        # test_full_disk_through_dask_workers_is_one_line_and_resumes covers the message without a mount
        msg = f"cannot mount a small tmpfs here: {r.stderr.strip()}"
        if os.environ.get("CI"):
            pytest.fail(msg)
        warnings.warn(f"test_full_disk_is_one_line_and_keeps_earlier_outputs SKIPPED: {msg}")
        pytest.skip(msg)
    try:
        yield mnt
    finally:
        subprocess.run(["umount", "-l", str(mnt)], check=False)
        shutil.rmtree(mnt, ignore_errors=True)


def test_full_disk_is_one_line_and_keeps_earlier_outputs(small_disk):
    first = small_disk / "small.zarr"
    code, err = call("sample", first, "--config-preset", "tiny", "--preset", PRESETS[0], "--per-preset", "1",
                     "--workers", "0")
    assert code == 0, err
    before = tree_digest(first)
    # every preset x 2 variants of 128^2 uint16 maps: far more than the 3 MiB disk holds. Since #24 the up-front
    # bound uses the compression real stores measure (raw / 2), so the run is refused before it writes anything
    # (a full disk met mid-write is test_full_disk_through_dask_workers_is_one_line_and_resumes below)
    big = small_disk / "big.zarr"
    code, err = call("sample", big, "--size", "128", "--per-preset", "2", "--chunk", "2", "--workers", "0")
    assert code != 0 and err.count("\n") == 1 and "Traceback" not in err, err
    assert "need about" in err and "free under" in err, err
    assert not big.exists() and not (small_disk / "big.zarr.partial").exists()  # nothing written at all
    assert tree_digest(first) == before


def test_full_disk_through_dask_workers_is_one_line_and_resumes(tmp_path):
    """ENOSPC raised in a dask worker (injected after chunk 1: no small disk needs mounting) reaches the user as
    svgen's one line, without the workers' 5-line "Compute Failed" report; the rerun resumes."""
    out = tmp_path / "v.zarr"
    cmd = [sys.executable, "-c", "from pipeline.cli import main; main()", "sample", str(out), "--config-preset", "tiny",
           "--per-preset", "1", "--chunk", "1", "--workers", "1", "--preset", PRESETS[0], "--preset", PRESETS[1]]
    env = {**os.environ, "SVGEN_NO_PROGRESS": "1", "SVGEN_TEST_ENOSPC_AFTER_CHUNK": "1"}
    r = subprocess.run(cmd, capture_output=True, text=True, env=env)
    assert r.returncode == 1 and "No space left on device" in r.stderr and "resumes" in r.stderr, r.stderr
    assert r.stderr.count("\n") == 1 and "Compute Failed" not in r.stderr, r.stderr
    assert not out.exists()
    env.pop("SVGEN_TEST_ENOSPC_AFTER_CHUNK")
    r = subprocess.run(cmd, capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr
