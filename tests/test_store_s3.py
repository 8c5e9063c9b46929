"""Stores on object storage (issue #12) against a real S3 protocol server on 127.0.0.1 (moto server mode).

The same promises as local stores: the same bytes as a local run (one process, or a dask cluster whose workers
write their chunks straight to the bucket), a kill -9 resumed to identical bytes rewriting only unfinished chunks,
an incomplete store refused by readers, a second writer refused by the conditional-put lock, and every fault
(missing bucket, wrong credentials, unreachable endpoint, a misspelt scheme) one line with exit 2.
"""
from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from s3_fixtures import s3, s3_server  # noqa: F401  (fixtures)
from test_render_resume import ARGS, N_SVBRDF, reference, variants  # noqa: F401  (module fixtures)

from pipeline.config import SampleConfig
from pipeline.sample import run_sample
from storage.store import DONE_DIR, MANIFEST, open_store, open_writer
from svcore.config import build
from svcore.errors import StoreError

SAMPLE = dict(presets=("paint/glossy_red", "wood/mahogany_veneer"), per_preset=2)


def _svgen(*args):
    return [sys.executable, "-c", "from pipeline.cli import main; main()", *map(str, args)]


def _env():
    return {**os.environ, "SVGEN_NO_PROGRESS": "1", "PYTHONPATH": os.getcwd()}


#: the only fields that may differ between a store written to S3 and the same run written locally, all in the
#: group's attributes: paths of the run's inputs, recorded relative to the output store (storage.store.recorded_path),
#: which an ``s3://`` output cannot be, so there they are absolute. Every array's zarr.json must be equal.
PLACE_DEPENDENT = {
    "path": "an input store's path (render, blend: attributes 'inputs' / 'source')",
    "source": "an imported material's source folder (import: 'materials')",
    "sources": "import's source folders ('import')",
    "history": "the command line, whose local paths are relative to a local output, absolute for an s3:// one "
               "(CF history, svcore.history)",
    "stores": "the stores an imported sample re-reads ('imported')",
}


def _strip_places(meta: dict) -> dict:
    """A zarr.json without the fields that name places (:data:`PLACE_DEPENDENT`), at any depth of its attributes."""
    if isinstance(meta, dict):
        return {k: _strip_places(v) for k, v in meta.items() if k not in PLACE_DEPENDENT}
    if isinstance(meta, list):
        return [_strip_places(v) for v in meta]
    return meta


def assert_same_metadata(s3, url: str, local: Path):
    """Every array's zarr.json (dimension_names, CF attributes, codecs, shards) and the group's zarr.json with its
    consolidated metadata equal the local store's, apart from :data:`PLACE_DEPENDENT`; and xarray, through
    s3fs against the server, decodes every variable of the S3 store exactly as it decodes the local copy."""
    import xarray as xr

    fs, root = s3.fs(), url.split("://", 1)[1]
    metas = sorted(str(p.relative_to(local)) for p in local.rglob("zarr.json"))
    assert len(metas) > 1 and metas == sorted(k[len(root) + 1:] for k in fs.find(root) if k.endswith("zarr.json"))
    for k in metas:
        got, want = json.loads(fs.cat_file(f"{root}/{k}")), json.loads((local / k).read_text())
        if k != "zarr.json":
            assert got == want, k  # an array: nothing may differ
            assert got["dimension_names"] and got["attributes"], k
        assert _strip_places(got) == _strip_places(want), k
    ds = xr.open_zarr(url, storage_options={"endpoint_url": s3.endpoint})
    dl = xr.open_zarr(local)
    assert sorted(ds.data_vars) == sorted(dl.data_vars) and ds.sizes == dl.sizes
    for name in dl.data_vars:
        a, b = ds[name], dl[name]
        assert a.dims == b.dims and a.attrs == b.attrs and a.dtype == b.dtype, name
        assert a.encoding.get("scale_factor") == b.encoding.get("scale_factor"), name
        np.testing.assert_array_equal(a.values, b.values, err_msg=name)


def assert_same_store(s3, url: str, local: Path):
    """Every chunk object equals the local chunk file byte for byte, every zarr.json equals the local one and
    xarray decodes both alike (:func:`assert_same_metadata`), decoded values agree, manifests are equal, and no
    marker or lock is left in the bucket."""
    fs, root = s3.fs(), url.split("://", 1)[1]
    man = json.loads(fs.cat_file(f"{root}/{MANIFEST}"))
    assert man == json.loads((local / MANIFEST).read_text())
    keys = {k[len(root) + 1:] for k in fs.find(root)}
    files = {str(p.relative_to(local)) for p in local.rglob("*") if p.is_file()}
    chunks = {k for k in files if "/c/" in k}
    assert chunks and chunks == {k for k in keys if "/c/" in k}
    for k in sorted(chunks):
        assert fs.cat_file(f"{root}/{k}") == (local / k).read_bytes(), k
    assert not any(k.startswith(DONE_DIR) for k in keys), "markers left in a finished store"
    assert not fs.exists(root + ".lock"), "lock left behind"
    g, gl = open_store(url, ("variants", "renders")), open_store(local, ("variants", "renders"))
    assert sorted(g) == sorted(gl)
    for name in gl:
        np.testing.assert_array_equal(g[name][:], gl[name][:], err_msg=name)
    assert_same_metadata(s3, url, local)


def test_sample_to_s3_equals_local(s3, tmp_path):
    cfg = build(SampleConfig, "tiny", **SAMPLE)
    run_sample(tmp_path / "v.zarr", cfg, workers=0)
    assert run_sample(s3.url("v.zarr"), cfg, workers=0)
    assert_same_store(s3, s3.url("v.zarr"), tmp_path / "v.zarr")
    g = open_store(s3.url("v.zarr"), "variants")
    assert g.attrs["svgen"]["complete"] is True
    with pytest.raises(StoreError, match="already exists"):
        run_sample(s3.url("v.zarr"), cfg, workers=0)


def test_cluster_workers_write_to_s3_same_bytes(variants, reference, s3):  # noqa: F811
    """A LocalCluster on 127.0.0.1 with 2 worker processes reading the variants from the bucket: the workers get
    their inputs from S3 and put their chunks there, the client only plans and commits."""
    s3.fs().put(str(variants), f"{s3.bucket}/in/variants.zarr", recursive=True)
    url = s3.url("r.zarr")
    r = subprocess.run(_svgen("render", s3.url("in/variants.zarr"), url, *ARGS, "--workers", "2"),
                       capture_output=True, text=True, env=_env(), timeout=300)
    assert r.returncode == 0, r.stderr
    assert "Unclosed" not in r.stderr and "INFO" not in r.stderr, r.stderr  # no asyncio/boto noise
    assert_same_store(s3, url, reference)


def _versions(s3, prefix: str) -> dict[str, int]:
    import boto3

    c = boto3.client("s3", endpoint_url=s3.endpoint)
    out: dict[str, int] = {}
    for v in c.list_object_versions(Bucket=s3.bucket, Prefix=prefix).get("Versions", []):
        out[v["Key"]] = out.get(v["Key"], 0) + 1
    return out


def test_sigkill_mid_render_then_rerun_is_identical(variants, reference, s3):  # noqa: F811
    """kill -9 right after the first chunk's marker (SVGEN_TEST_KILL_AT=chunk, as the local kill tests): readers
    refuse the store; the rerun takes over the dead run's lock, writes only the chunks without a marker (bucket
    versioning counts the writes of each chunk object) and ends identical."""
    import boto3

    boto3.client("s3", endpoint_url=s3.endpoint).put_bucket_versioning(
        Bucket=s3.bucket, VersioningConfiguration={"Status": "Enabled"})
    url, fs = s3.url("k.zarr"), s3.fs()
    proc = subprocess.run(_svgen("render", variants, url, *ARGS, "--workers", "0"), capture_output=True,
                          text=True, env={**_env(), "SVGEN_TEST_KILL_AT": "chunk"}, timeout=300)
    assert proc.returncode == -signal.SIGKILL, proc.stderr
    done = f"{s3.bucket}/k.zarr/{DONE_DIR}"
    finished = sorted(int(k.rsplit("/", 1)[1]) for k in fs.find(done))
    assert len(finished) == 1 < N_SVBRDF, finished
    assert fs.exists(f"{s3.bucket}/k.zarr.lock"), "the killed run's lock should be left (stale)"
    with pytest.raises(StoreError, match="incomplete"):
        open_store(url, "renders")
    r = subprocess.run(_svgen("render", variants, url, *ARGS, "--workers", "0"), capture_output=True, text=True,
                       env=_env(), timeout=300)
    assert r.returncode == 0, r.stderr
    assert_same_store(s3, url, reference)
    writes = _versions(s3, "k.zarr/image/c/")
    assert len(writes) == N_SVBRDF and writes[f"k.zarr/image/c/{finished[0]}/0/0/0/0"] == 1, \
        f"the rerun rewrote chunk {finished[0]}, finished before the kill: {writes}"
    assert sum(writes.values()) == N_SVBRDF, f"a chunk written twice: {writes}"


def test_server_stops_mid_run_then_resumes_identical(variants, reference, s3, tmp_path):  # noqa: F811
    """The S3 server goes away while the writer is paused after its first chunk's marker (SVGEN_TEST_PAUSE_DIR):
    the run then fails with one line (no hang); with the server back the same command resumes (the dead run's lock
    is taken over) and ends identical to a local run."""
    from moto.server import ThreadedMotoServer

    port = _closed_port()  # a second server on the same moto state, which this test can stop
    url, fs = s3.url("s.zarr"), s3.fs()
    cmd = _svgen("render", variants, url, *ARGS, "--workers", "0", "--storage-option",
                 f"endpoint_url=http://127.0.0.1:{port}")
    pause = tmp_path / "pause"
    pause.mkdir()
    srv = ThreadedMotoServer(ip_address="127.0.0.1", port=port, verbose=False)
    srv.start()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env={**_env(), "SVGEN_TEST_PAUSE_DIR": str(pause)})
    deadline = time.time() + 300
    while not (pause / "paused").exists() and proc.poll() is None and time.time() < deadline:
        time.sleep(0.05)
    assert (pause / "paused").exists(), "the writer never reached its first chunk's marker"
    srv.stop()
    (pause / "resume").touch()
    _, err = proc.communicate(timeout=120)
    assert len(fs.find(f"{s3.bucket}/s.zarr/{DONE_DIR}")) == 1  # (through the fixture's server: the state is shared)
    lines = [ln for ln in err.strip().splitlines() if ln.strip()]
    assert proc.returncode == 2 and len(lines) == 1 and "unreachable" in lines[0], err
    srv = ThreadedMotoServer(ip_address="127.0.0.1", port=port, verbose=False)
    srv.start()
    try:
        r = subprocess.run(cmd, capture_output=True, text=True, env=_env(), timeout=300)
    finally:
        srv.stop()
    assert r.returncode == 0, r.stderr
    assert_same_store(s3, url, reference)


def test_second_writer_is_refused(s3):
    """The lock object is created with a conditional put: while one writer holds it, another is refused."""
    from storage.svbrdf_store import array_specs

    args = (s3.url("busy.zarr"), "variants", 4, 2, array_specs("variants", 8, 2), {"x": 1})
    with open_writer(*args) as w:
        assert w.pending() == [0, 1]
        with pytest.raises(StoreError, match="another run is writing"):
            open_writer(*args).__enter__()
    with open_writer(*args) as w2:  # released on exit (nothing written: the prefix is cleared too)
        assert w2.pending() == [0, 1]


def _closed_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.parametrize("case", ["missing bucket", "scheme typo", "unreachable endpoint", "wrong credentials",
                                  "bad storage option", "incomplete store"])
def test_faults_are_one_line(case, s3, svgen_cli, monkeypatch, tmp_path):
    cmd = ["sample", "--config-preset", "tiny", "--per-preset", "1", "--workers", "0"]
    want = {"missing bucket": "bucket 'no-such-bucket' does not exist", "scheme typo": "unknown storage scheme 's4'",
            "unreachable endpoint": "unreachable", "wrong credentials": "access denied",
            "bad storage option": "must be KEY=VALUE", "incomplete store": "incomplete"}[case]
    if case == "missing bucket":
        args = [*cmd, "s3://no-such-bucket/v.zarr"]
    elif case == "scheme typo":
        args = [*cmd, "s4://svgen-test/v.zarr"]
    elif case == "unreachable endpoint":
        args = [*cmd, "--storage-option", f"endpoint_url=http://127.0.0.1:{_closed_port()}", s3.url("v.zarr")]
    elif case == "bad storage option":
        args = [*cmd, "--storage-option", "endpoint_url", s3.url("v.zarr")]
    elif case == "wrong credentials":
        import moto.settings

        # moto checks signatures only when told to: every request from now on is authenticated against its IAM
        monkeypatch.setattr(moto.settings, "INITIAL_NO_AUTH_ACTION_COUNT", 0)
        monkeypatch.setenv("AWS_ACCESS_KEY_ID", "AKIAWRONGWRONGWRONG0")
        monkeypatch.setenv("AWS_SECRET_ACCESS_KEY", "wrong")
        args = [*cmd, s3.url("v.zarr")]
    else:  # a store whose run was killed: readers refuse it
        from storage.svbrdf_store import array_specs

        w = open_writer(s3.url("v.zarr"), "variants", 2, 1, array_specs("variants", 8, 2), {"x": 1}).__enter__()
        from storage.store import write_chunk

        write_chunk(w.partial, 0, 0, {"seed": np.zeros(1, np.uint64)})
        w._unlock()
        args = ["render", s3.url("v.zarr"), tmp_path / "r.zarr", "--workers", "0"]
    t = time.time()
    code, err = svgen_cli(*args)
    assert code == 2, err
    lines = [ln for ln in err.strip().splitlines() if ln.strip()]
    assert len(lines) == 1 and want in lines[0] and "Traceback" not in err, err
    assert time.time() - t < 120, "no hang"  # a guard, not a speed claim: botocore's defaults retry for minutes
    if case not in ("incomplete store", "wrong credentials"):  # (with wrong credentials nothing can be written)
        assert not s3.fs().exists(f"{s3.bucket}/v.zarr/zarr.json"), "a failed run left a store"


def _tiny_renders(s3, tmp_path) -> tuple[str, Path]:
    """A 2-SVBRDF renders store at 32^2, rendered locally and uploaded (a real svgen render to S3 is tested above)."""
    from pipeline.config import RenderConfig
    from pipeline.render.stage import run_render

    run_sample(tmp_path / "tv.zarr", build(SampleConfig, "tiny", presets=SAMPLE["presets"], per_preset=1), workers=0)
    run_render([str(tmp_path / "tv.zarr")], str(tmp_path / "tr.zarr"), build(RenderConfig, "tiny", res=32, views=2),
               workers=0)
    s3.fs().put(str(tmp_path / "tr.zarr"), f"{s3.bucket}/tr.zarr", recursive=True)
    return s3.url("tr.zarr"), tmp_path / "tr.zarr"


def test_loader_workers_read_s3_like_local(s3, tmp_path):
    """Forked loader workers (fsspec file systems are not fork-safe: the store rebuilds its own) give the batches
    a local store gives."""
    import torch

    from storage.renders_store import RendersReader
    from train.data import PairDataset, make_loader

    url, local = _tiny_renders(s3, tmp_path)
    batches = []
    for path, workers in ((url, 2), (local, 0)):
        src = RendersReader(path)
        batches.append(list(make_loader(PairDataset(src, range(len(src)), 16, seed=0), 2, 0, 3, workers=workers)))
    for (x, y), (u, v) in zip(*batches, strict=True):
        assert torch.equal(x, u) and torch.equal(y, v)


def test_train_two_steps_from_s3(s3, tmp_path):
    """svtrain fit --store s3://… trains through the local chunk cache and records the URL for eval."""
    from test_train_cli import run as svtrain

    url, _ = _tiny_renders(s3, tmp_path)
    code, out, err = svtrain("fit", "--out", tmp_path / "run", "--store", url, "--iterations", 2,
                             "--set", "model.base_width=4", "--set", "model.max_width=8", "--set", "model.levels=3",
                             "--set", "data.crop=16", "--set", "data.holdout=0.5", "--set", "optim.batch_size=1",
                             "--workers", "0", "--no-compile")
    assert code == 0, err
    assert any(p.is_file() for p in (tmp_path / "s3cache").rglob("*")), "nothing went through the chunk cache"
    info = json.loads((tmp_path / "run" / "run.json").read_text())
    assert info["train_store"]["from_run"] == url



def test_export_reads_s3(s3, tmp_path, svgen_cli):
    """`svgen export` takes an s3:// renders store as its input and writes what it writes from the local copy."""
    url, local = _tiny_renders(s3, tmp_path)
    for src, out in ((url, tmp_path / "e_s3"), (local, tmp_path / "e_local")):
        code, err = svgen_cli("export", src, out, "--format", "png", "--limit", "2")
        assert code == 0, err
    files = sorted(p.relative_to(tmp_path / "e_local") for p in (tmp_path / "e_local").rglob("*") if p.is_file())
    assert files and files == sorted(p.relative_to(tmp_path / "e_s3") for p in (tmp_path / "e_s3").rglob("*")
                                     if p.is_file())
    for f in files:
        assert (tmp_path / "e_s3" / f).read_bytes() == (tmp_path / "e_local" / f).read_bytes(), f


def test_import_to_s3_equals_local(s3, tmp_path, svgen_cli):
    """`svgen import` keeps its per-chunk records beside the chunks: in the bucket too, and they are gone after."""
    from import_fixtures import ambientcg, bumpy_normals

    ambientcg(tmp_path / "src", "GL", 32, np.random.default_rng(1), {"GL": bumpy_normals(32, np.random.default_rng(2))})
    for out in (tmp_path / "i.zarr", s3.url("i.zarr")):
        code, err = svgen_cli("import", tmp_path / "src", out, "--size", "16", "--workers", "0")
        assert code == 0, err
    assert_same_store(s3, s3.url("i.zarr"), tmp_path / "i.zarr")
    assert not s3.fs().find(f"{s3.bucket}/i.zarr/.import_records")


def test_file_url_is_the_plain_local_store(tmp_path):
    """file://PATH is the local store at PATH: the same files, byte for byte, as the plain path gives."""
    from conftest import tree_digest

    cfg = build(SampleConfig, "tiny", **SAMPLE)
    run_sample(tmp_path / "a" / "v.zarr", cfg, workers=0)
    run_sample(f"file://{tmp_path}/b/v.zarr", cfg, workers=0)
    assert tree_digest(tmp_path / "a" / "v.zarr") == tree_digest(tmp_path / "b" / "v.zarr")
    assert open_store(f"file://{tmp_path}/b/v.zarr", "variants").attrs["svgen"]["complete"] is True


def test_stores_uploaded_together_read_their_inputs_on_s3(s3, tmp_path):
    """A folder of stores uploaded as it is keeps its relative records: a renders store without maps (format 6) reads
    its maps from its inputs in the bucket, a recipe blends input mixing them from its variants there too."""
    from pipeline.blend import run_blend
    from pipeline.config import BlendConfig, RenderConfig
    from pipeline.render.stage import run_render
    from storage.renders_store import RendersReader

    d = tmp_path / "up"
    run_sample(d / "v.zarr", build(SampleConfig, "tiny", presets=SAMPLE["presets"], per_preset=1), workers=0)
    run_blend(d / "v.zarr", d / "b.zarr", build(BlendConfig, "tiny", count=2), workers=0)
    run_render([str(d / "v.zarr"), str(d / "b.zarr")], str(d / "r.zarr"),
               build(RenderConfig, "tiny", res=32, views=1, maps="inputs"), workers=0)
    for name in ("v.zarr", "b.zarr", "r.zarr"):
        s3.fs().put(str(d / name), f"{s3.bucket}/up/{name}", recursive=True)
    remote, local = RendersReader(s3.url("up/r.zarr")), RendersReader(d / "r.zarr")
    assert remote.inputs is not None and [st.path for st in remote.inputs.stores] == [s3.url("up/v.zarr"),
                                                                                       s3.url("up/b.zarr")]
    for s in range(local.n_svbrdf):
        got, want = remote.base_codes(s), local.base_codes(s)
        assert all(np.array_equal(got[k], want[k]) for k in want), s
