"""A DVC remote on the S3 endpoint of the stores (issue #12, README "On a cluster"): a tiny DVC project whose
stage writes a store, `dvc push` to an ``s3://`` remote on the loopback S3 server, cache and outputs deleted,
`dvc pull` restores them byte for byte (the dvc-s3 plugin)."""
from __future__ import annotations

import os
import shutil
import subprocess

import pytest
from s3_fixtures import s3, s3_server  # noqa: F401  (fixtures)

from conftest import tree_digest

pytestmark = pytest.mark.slow

STAGE = ("svgen sample data/variants.zarr --config-preset tiny --preset paint/glossy_red --per-preset 2 "
         "--workers 0")


def _env(empty, **extra) -> dict[str, str]:
    """No AWS settings but those given (none from files either: ``empty`` is an empty file): each step shows where
    DVC takes them from."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("AWS_")}
    env.update({"SVGEN_NO_PROGRESS": "1", "PYTHONPATH": os.getcwd(), "AWS_SHARED_CREDENTIALS_FILE": str(empty),
                "AWS_CONFIG_FILE": str(empty), "AWS_DEFAULT_REGION": "us-east-1", "GIT_AUTHOR_NAME": "t",
                "GIT_AUTHOR_EMAIL": "t@t", "GIT_COMMITTER_NAME": "t", "GIT_COMMITTER_EMAIL": "t@t", **extra})
    return env


def sh(cmd: str, cwd, env, check=True) -> subprocess.CompletedProcess:
    r = subprocess.run(cmd, cwd=cwd, env=env, shell=True, capture_output=True, text=True, timeout=300)
    if check and r.returncode != 0:
        raise AssertionError(f"{cmd} failed ({r.returncode}):\n{r.stdout[-2000:]}\n{r.stderr[-2000:]}")
    return r


def test_push_then_pull_through_an_s3_remote_is_bit_identical(s3, tmp_path):
    if shutil.which("dvc") is None:
        pytest.fail("dvc is not installed: run scripts/setup.sh")
    proj = tmp_path / "proj"
    proj.mkdir()
    (tmp_path / "aws_empty").touch()
    plain = _env(tmp_path / "aws_empty")
    sh("git init -q && dvc init -q", proj, plain)
    sh(f"dvc stage add -n sample -o data/variants.zarr '{STAGE}'", proj, plain)
    sh("dvc repro", proj, plain)
    store = proj / "data" / "variants.zarr"
    before = tree_digest(store)
    assert any("/c/" in k for k in before), "the store holds no chunk: the test proves nothing"

    # README "On a cluster", the DVC remote: the bucket of the stores, its endpoint, credentials kept out of git
    sh(f"dvc remote add -d storage s3://{s3.bucket}/dvc", proj, plain)
    sh(f"dvc remote modify storage endpointurl {s3.endpoint}", proj, plain)
    sh("dvc remote modify --local storage access_key_id testing", proj, plain)
    sh("dvc remote modify --local storage secret_access_key testing", proj, plain)
    assert "testing" not in (proj / ".dvc" / "config").read_text(), "credentials in the committed config"
    sh("dvc push", proj, plain)  # with the --local credentials (the environment has none)
    pushed = s3.fs().find(f"{s3.bucket}/dvc")
    assert len(pushed) >= sum(1 for k in before), f"the remote holds {len(pushed)} objects"

    shutil.rmtree(proj / ".dvc" / "cache")
    shutil.rmtree(store)
    (proj / ".dvc" / "config.local").unlink()  # the other way: boto's variables, as the svgen workers take them
    sh("dvc pull", proj, _env(tmp_path / "aws_empty", AWS_ACCESS_KEY_ID="testing", AWS_SECRET_ACCESS_KEY="testing"))
    assert tree_digest(store) == before
    assert "up to date" in sh("dvc status", proj, plain).stdout
