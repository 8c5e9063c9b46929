"""Scale-out of `svgen render`: views/s against the number of dask workers.

Configurations: 1 and 2 local worker processes (LocalCluster, the default path), and a dask.distributed
cluster on loopback (a `dask scheduler` and two `dask worker` processes started here, reached through
--scheduler-address). Each renders the same 12 SVBRDFs x 10 views at 256^2 (default quality). Reported:
views/s over the whole command (cluster start included) and in steady state (first chunk per worker
excluded), plus whether every store is byte-identical to the 1-worker store.

    python3 benchmarks/bench_scaleout.py            # -> benchmarks/results/scaleout.json
"""
from __future__ import annotations

import os
import shutil
import socket
import subprocess
import sys
import tempfile
from pathlib import Path

from harness import RESULTS, parser, timed, tree_digest, write_results

N_PRESET = 6  # x 2 variants = 12 SVBRDFs


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _render(inp: Path, out: Path, extra: list[str]) -> float:
    """Wall seconds of one ``svgen render`` command."""
    env = {**os.environ, "SVGEN_NO_PROGRESS": "1"}
    return timed(lambda: subprocess.run([sys.executable, "-c", "from pipeline.cli import main; main()", "render",
                                         str(inp), str(out), "--chunk", "1", *extra],
                                        check=True, env=env, capture_output=True)).wall_s


def _steady(inp: Path, out: Path, workers: int, address: str | None) -> float:
    """views/s with the cluster already running: chunk tasks only (first task per worker excluded)."""
    from svcore.config import build
    from pipeline.parallel import dask_client, run_chunks
    from pipeline.config import RenderConfig
    from pipeline.render.stage import chunk_task, render_writer

    cfg = build(RenderConfig)
    writer, n = render_writer(inp, out, cfg)
    with writer as w, dask_client(workers, address) as client:
        task = chunk_task(w, inp, cfg, n)
        todo = w.pending()
        warm = todo[:max(1, len(client.scheduler_info()["workers"]))]
        client.gather(client.map(task, warm, [1] * len(warm), pure=False))
        rest = todo[len(warm):]
        threads = [max(1, (os.cpu_count() or 1) // max(1, workers))] * len(rest)
        dt = timed(lambda: client.gather(client.map(task, rest, threads, pure=False))).wall_s
    return len(rest) * cfg.views / dt


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--out", default=str(RESULTS / "scaleout.json"))
    args = ap.parse_args(argv)
    from pipeline.config import SampleConfig
    from svcore.config import build
    from pipeline.sample import run_sample

    import materials

    tmp = Path(tempfile.mkdtemp(prefix="svgen-scaleout-"))
    try:
        inp = tmp / "v.zarr"
        presets = tuple(p.name for p in materials.presets()[:: max(1, len(materials.presets()) // N_PRESET)][:N_PRESET])
        run_sample(inp, build(SampleConfig, presets=presets, per_preset=2), workers=0)
        n_views = len(presets) * 2 * 10
        rows = []
        for w in (1, 2):
            wall = _render(inp, tmp / f"local{w}.zarr", ["--workers", str(w)])
            rows.append({"config": f"local {w} worker{'s' if w > 1 else ''}", "workers": w, "wall_s": wall,
                         "views_per_s_total": n_views / wall,
                         "views_per_s_steady": _steady(inp, tmp / f"steady{w}.zarr", w, None)})
        port = _free_port()
        addr = f"tcp://127.0.0.1:{port}"
        env = {**os.environ, "DASK_DISTRIBUTED__WORKER__DAEMON": "False"}
        sched = subprocess.Popen(["dask", "scheduler", "--host", "127.0.0.1", "--port", str(port),
                                  "--no-dashboard"], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
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
        res = {"benchmark": "render_scaleout", "svbrdfs": len(presets) * 2, "views": n_views, "res": 256,
               "rows": rows, "stores_identical": identical}
        write_results(args.out, res, args.note)
        for r in rows:
            print(f"{r['config']:50s} {r['views_per_s_total']:6.1f} views/s total, {r['views_per_s_steady']:6.1f} steady")
        print("identical stores:", identical)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
