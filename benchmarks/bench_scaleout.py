"""Scale-out of `svgen render`: views/s against the number of dask workers.

Configurations: 1 and 2 local worker processes (LocalCluster, the default path), and a dask.distributed
cluster on loopback (a `dask scheduler` and two `dask worker` processes started here, reached through
--scheduler-address). Each renders the same 12 SVBRDFs x 10 views at 256^2 (default quality). Reported:
views/s over the whole command (cluster start included) and in steady state (first chunk per worker
excluded), plus whether every store is byte-identical to the 1-worker store.

S3 rows (issue #12): the same render into an ``s3://`` store on a loopback S3 server (moto's ThreadedMotoServer,
a Python server: far slower per request than MinIO or AWS, so these rows bound the protocol's overhead from
above) against local disk with 1 and 2 workers, and the training loader's samples/s from the S3 store (cold
chunk cache, then warm) against the local store. ``--s3-only`` runs just those (on ``--svbrdfs`` SVBRDFs) and
puts them into the results file beside the rows already there, under ``s3_run`` its own command, note and machine
(the two parts may come from different runs: each says when and how it was measured).

    python3 benchmarks/bench_scaleout.py            # -> benchmarks/results/scaleout.json (all rows)
    python3 benchmarks/bench_scaleout.py --s3-only --svbrdfs 4   # -> the S3 rows of scaleout.json
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

from harness import RESULTS, SVGEN, parser, timed, tree_digest, write_results

N_PRESET = 6  # x 2 variants = 12 SVBRDFs


def _scheduler(env: dict, folder: Path) -> tuple[subprocess.Popen, str]:
    """`dask scheduler` on a port of its own choosing, its address read from its scheduler file (a port picked here
    and released could be taken by another process before the scheduler binds it)."""
    file = folder / "scheduler.json"
    proc = subprocess.Popen(["dask", "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                             "--scheduler-file", str(file)], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    while True:
        try:
            return proc, json.loads(file.read_text())["address"]
        except (FileNotFoundError, ValueError, KeyError):
            pass
        if proc.poll() is not None or time.monotonic() > deadline:
            proc.kill()
            raise SystemExit("bench_scaleout: `dask scheduler` did not start")
        time.sleep(0.1)


def _render(inp: Path, out: Path, extra: list[str]) -> float:
    """Wall seconds of one ``svgen render`` command."""
    env = {**os.environ, "SVGEN_NO_PROGRESS": "1"}
    return timed(lambda: subprocess.run([*SVGEN, "render", str(inp), str(out), "--chunk", "1", *extra],
                                        check=True, env=env, capture_output=True)).wall_s


def _steady(inp: Path, out: Path, workers: int, address: str | None) -> float:
    """views/s with the cluster already running: chunk tasks only (first task per worker excluded)."""
    from svcore.config import build
    from pipeline.exec.parallel import dask_client
    from pipeline.config import RenderConfig
    from pipeline.render.stage import chunk_task, render_writer

    # one SVBRDF per task, as _render's --chunk 1: with the default 64-SVBRDF task the warm-up task would hold every
    # SVBRDF of this benchmark and leave nothing to time
    cfg = build(RenderConfig, chunk=1)
    writer, n = render_writer(inp, out, cfg)
    with writer as w, dask_client(workers, address) as client:
        task = chunk_task(w, inp, cfg, n)
        todo = w.pending()
        warm = todo[:max(1, len(client.scheduler_info()["workers"]))]
        client.gather(client.map(task, warm, [1] * len(warm), pure=False))
        rest = todo[len(warm):]
        if not rest:
            raise SystemExit(f"{len(todo)} tasks leave none after the warm-up of {len(warm)}: render more SVBRDFs")
        threads = [max(1, (os.cpu_count() or 1) // max(1, workers))] * len(rest)
        dt = timed(lambda: client.gather(client.map(task, rest, threads, pure=False))).wall_s
    return len(rest) * cfg.views / dt


def _s3_server():
    """A moto S3 server on 127.0.0.1 with the bucket ``bench``; AWS_* variables point this process and its
    children at it. Returns (server, endpoint)."""
    from moto.server import ThreadedMotoServer
    import s3fs

    srv = ThreadedMotoServer(ip_address="127.0.0.1", port=0, verbose=False)
    srv.start()
    host, port = srv.get_host_and_port()
    ep = f"http://{host}:{port}"
    os.environ.update({"AWS_ACCESS_KEY_ID": "bench", "AWS_SECRET_ACCESS_KEY": "bench",
                       "AWS_DEFAULT_REGION": "us-east-1", "AWS_ENDPOINT_URL": ep})
    s3fs.S3FileSystem(endpoint_url=ep, skip_instance_cache=True).mkdir("bench")
    return srv, ep


def _loader_rate(path, steps: int, batch: int, workers: int) -> float:
    """Training-loader samples/s over ``steps`` batches (the first batch, worker start-up, excluded)."""
    import time

    from storage.renders_store import RendersReader
    from train.data import PairDataset, make_loader

    src = RendersReader(path)
    it = iter(make_loader(PairDataset(src, range(len(src)), 128, seed=0), batch, 0, steps + 1, workers=workers))
    next(it)
    t = time.perf_counter()
    for _ in it:
        pass
    return steps * batch / (time.perf_counter() - t)


def s3_rows(inp: Path, tmp: Path, n_views: int, steps: int = 20, batch: int = 8) -> dict:
    """Render views/s local vs loopback S3 (1 and 2 workers) and loader samples/s local vs S3 (cold, warm)."""
    import numpy as np

    srv, ep = _s3_server()
    try:
        rows = []
        for w in (1, 2):
            for where, out in (("local disk", tmp / f"s3cmp_local{w}.zarr"), ("loopback S3", f"s3://bench/r{w}.zarr")):
                wall = _render(inp, out, ["--workers", str(w)])
                rows.append({"config": f"render to {where}, {w} worker{'s' if w > 1 else ''}", "workers": w,
                             "wall_s": wall, "views_per_s_total": n_views / wall})
        from storage.store import open_store

        a, b = open_store(tmp / "s3cmp_local1.zarr", "renders"), open_store("s3://bench/r2.zarr", "renders")
        same = all(np.array_equal(a[k][:], b[k][:]) for k in a)
        loader = []
        for w in (0, 2):
            local = _loader_rate(tmp / "s3cmp_local1.zarr", steps, batch, w)
            os.environ["SVGEN_OBJECT_CACHE"] = str(tmp / f"cache{w}")
            cold = _loader_rate("s3://bench/r1.zarr", steps, batch, w)
            warm = _loader_rate("s3://bench/r1.zarr", steps, batch, w)
            loader.append({"loader_workers": w, "batch": batch, "crop": 128, "local_samples_per_s": local,
                           "s3_cold_cache_samples_per_s": cold, "s3_warm_cache_samples_per_s": warm})
        return {"s3_server": "moto ThreadedMotoServer on 127.0.0.1 (Python; a lower bound for a real S3 service)",
                "s3_rows": rows, "s3_equals_local": bool(same), "loader_rows": loader}
    finally:
        srv.stop()


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--out", default=None, help="results file (default: benchmarks/results/scaleout.json)")
    ap.add_argument("--s3-only", action="store_true", help="only the S3 rows (render and loader, S3 vs local)")
    ap.add_argument("--svbrdfs", type=int, default=2 * N_PRESET, help="--s3-only: SVBRDFs rendered (2 variants per preset)")
    args = ap.parse_args(argv)
    if args.s3_only:
        return _main_s3(args)
    tmp = Path(tempfile.mkdtemp(prefix="svgen-scaleout-"))
    try:
        inp, n_views = _inputs(tmp, 2 * N_PRESET)
        rows = []
        for w in (1, 2):
            wall = _render(inp, tmp / f"local{w}.zarr", ["--workers", str(w)])
            rows.append({"config": f"local {w} worker{'s' if w > 1 else ''}", "workers": w, "wall_s": wall,
                         "views_per_s_total": n_views / wall,
                         "views_per_s_steady": _steady(inp, tmp / f"steady{w}.zarr", w, None)})
        env = {**os.environ, "DASK_DISTRIBUTED__WORKER__DAEMON": "False"}
        sched, addr = _scheduler(env, tmp)
        workers = [subprocess.Popen(["dask", "worker", addr, "--nthreads", "1", "--no-dashboard",
                                     "--host", "127.0.0.1"], env=env, stdout=subprocess.DEVNULL,
                                    stderr=subprocess.DEVNULL) for _ in range(2)]
        try:
            from distributed import Client

            with Client(addr, timeout="60s") as c:
                c.wait_for_workers(2, timeout=60)
            wall = _render(inp, tmp / "dist.zarr", ["--scheduler-address", addr])
            rows.append({"config": "distributed: scheduler + 2 workers on loopback", "workers": 2, "wall_s": wall,
                         "views_per_s_total": n_views / wall,
                         "views_per_s_steady": _steady(inp, tmp / "steady_dist.zarr", 2, addr)})
        finally:
            for p in workers + [sched]:
                p.terminate()
            for p in workers + [sched]:
                p.wait(timeout=30)
        ref = tree_digest(tmp / "local1.zarr")
        identical = all(tree_digest(tmp / n) == ref for n in ("local2.zarr", "dist.zarr"))
        res = {"benchmark": "render_scaleout", "svbrdfs": n_views // 10, "views": n_views, "res": 256,
               "rows": rows, "stores_identical": identical, **s3_rows(inp, tmp, n_views)}
        write_results(args.out or str(RESULTS / "scaleout.json"), res, args.note)
        for r in rows:
            print(f"{r['config']:50s} {r['views_per_s_total']:6.1f} views/s total, {r['views_per_s_steady']:6.1f} steady")
        print("identical stores:", identical)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _inputs(tmp: Path, svbrdfs: int) -> tuple[Path, int]:
    from pipeline.config import SampleConfig
    from pipeline.sample import run_sample
    from svcore.config import build

    import materials

    n_preset = max(1, svbrdfs // 2)
    presets = tuple(p.name for p in materials.presets()[:: max(1, len(materials.presets()) // n_preset)][:n_preset])
    inp = tmp / "v.zarr"
    run_sample(inp, build(SampleConfig, presets=presets, per_preset=2), workers=0)
    return inp, len(presets) * 2 * 10


S3_KEYS = ("s3_server", "s3_rows", "s3_equals_local", "loader_rows")


def merge_s3(out: str | None, res: dict, note: str | None) -> dict:
    """The results file's record with the S3 part of ``res`` put in (its other rows kept), and under ``s3_run`` the
    command, note, machine and size of the run that measured the S3 part."""
    import json

    from harness import command, machine_info

    path = Path(out or RESULTS / "scaleout.json")
    record = json.loads(path.read_text()) if path.exists() else {"benchmark": "render_scaleout"}
    # rows written before the harness recorded commands came from the default run
    record.setdefault("command", "python3 benchmarks/bench_scaleout.py")
    record.update({k: res[k] for k in S3_KEYS})
    record["s3_run"] = {"command": command(), "note": note, "svbrdfs": res["svbrdfs"], "views": res["views"],
                        "res": res["res"], "machine": machine_info()}
    return record


def _main_s3(args) -> None:
    tmp = Path(tempfile.mkdtemp(prefix="svgen-scaleout-s3-"))
    try:
        inp, n_views = _inputs(tmp, args.svbrdfs)
        res = {"benchmark": "render_scaleout_s3", "svbrdfs": n_views // 10, "views": n_views, "res": 256,
               **s3_rows(inp, tmp, n_views)}
        write_results(args.out or str(RESULTS / "scaleout.json"), merge_s3(args.out, res, args.note))
        for r in res["s3_rows"]:
            print(f"{r['config']:40s} {r['views_per_s_total']:6.2f} views/s")
        for r in res["loader_rows"]:
            print(r)
        print("S3 store equals local:", res["s3_equals_local"])
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
