"""What a user's terminal and logs see: no progress bar in redirected output (tqdm's own TTY detection), a bar
when forced with SVGEN_PROGRESS=1, and every command ending with the line that names where its outputs are."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

SMALL = ["--set", "model.base_width=4", "--set", "model.max_width=8", "--set", "model.levels=3",
         "--set", "data.crop=32", "--set", "data.synthetic_size=40", "--set", "data.synthetic_samples=8",
         "--set", "data.synthetic_materials=4", "--set", "data.holdout=0.5", "--set", "optim.batch_size=2",
         "--workers", "0", "--no-compile"]
BAR = ("%|",)  # tqdm draws "NN%|###|" (text mode turns its carriage returns into newlines)


def cli(prog: str, *args, force: bool = False) -> subprocess.CompletedProcess:
    """Run svgen/svtrain as a user would, with stdout and stderr redirected to pipes (not terminals)."""
    env = {k: v for k, v in os.environ.items() if k not in ("SVGEN_NO_PROGRESS", "SVGEN_PROGRESS")}
    if force:
        env["SVGEN_PROGRESS"] = "1"
    mod = {"svgen": "pipeline.cli", "svtrain": "train.cli"}[prog]
    r = subprocess.run([sys.executable, "-c", f"from {mod} import main; main()", *map(str, args)],
                       capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    return r


def last_line(text: str) -> str:
    return text.strip().splitlines()[-1]


def test_svgen_sample_redirected_has_no_bar_and_names_the_store(tmp_path):
    out = tmp_path / "v.zarr"
    args = ("sample", out, "--config-preset", "tiny", "--per-preset", "2", "--chunk", "1", "--workers", "0",
            "--preset", "paint/glossy_red")
    r = cli("svgen", *args)
    assert not any(b in r.stderr for b in BAR), r.stderr
    assert last_line(r.stdout) == f"wrote {out}"
    forced = cli("svgen", *(a if a != out else tmp_path / "w.zarr" for a in args), force=True)
    assert all(b in forced.stderr for b in BAR), forced.stderr  # the switch reaches the bar: the test can fail


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    d = tmp_path_factory.mktemp("term") / "run"
    r = cli("svtrain", "fit", "--out", d, "--iterations", 2, *SMALL)
    return d, r


def test_svtrain_fit_keeps_json_on_stdout_and_names_the_run_directory(fitted):
    d, r = fitted
    assert json.loads(r.stdout)["step"] == 2  # stdout stays one JSON document
    assert not any(b in r.stderr for b in BAR), r.stderr
    assert last_line(r.stderr).startswith(f"wrote {d} ") and (d / "model.pt").is_file()


def test_svtrain_eval_bar_only_when_forced_and_names_its_outputs(fitted, tmp_path):
    d, _ = fitted
    r = cli("svtrain", "eval", "--checkpoint", d, "--out", tmp_path / "e")
    assert not any(b in r.stderr for b in BAR), r.stderr
    assert last_line(r.stderr).startswith(f"wrote {tmp_path / 'e'} ") and (tmp_path / "e" / "eval.json").is_file()
    forced = cli("svtrain", "eval", "--checkpoint", d, "--out", tmp_path / "f", force=True)
    assert "eval" in forced.stderr and all(b in forced.stderr for b in BAR), forced.stderr
