"""Other in-spec layouts before the levels (#42): channel planes (zarr's ``transpose``), byte shuffle, blosc.

Per image and map array of a renders store, ``--samples`` SVBRDFs spread evenly: bytes and encode CPU per sample of
zstd 3/5/9 on the stored layout, on channel planes, on byte-shuffled planes, and of blosc zstd with shuffle. Each
arm once (a probe, not a timing study: the levels' own curve is ``bench_levels.py``). Writes results/layouts.csv.

    python3 experiments/store_levels/probe_layouts.py --renders ../lockA/data/renders.zarr
"""
from __future__ import annotations

import argparse
import csv
import time
from pathlib import Path

import numpy as np
import zarr
from numcodecs import Blosc, Zstd

RESULTS = Path(__file__).resolve().parent / "results"


def shuffle(a: np.ndarray) -> np.ndarray:
    """The bytes of ``a`` as byte planes (what blosc's and HDF5's shuffle filter does)."""
    return np.ascontiguousarray(a.view(np.uint8).reshape(-1, a.dtype.itemsize).T)


def planar(a: np.ndarray) -> np.ndarray:
    """Channels last -> first (zarr's transpose codec)."""
    return np.ascontiguousarray(np.moveaxis(a, -1, 0))


ARMS = {
    "zstd3": lambda a: Zstd(3).encode(a),
    "zstd5": lambda a: Zstd(5).encode(a),
    "zstd9": lambda a: Zstd(9).encode(a),
    "planar-zstd3": lambda a: Zstd(3).encode(planar(a)),
    "shuffle-zstd3": lambda a: Zstd(3).encode(shuffle(a)),
    "planar-shuffle-zstd3": lambda a: Zstd(3).encode(shuffle(planar(a))),
    "blosc-zstd3-shuffle": lambda a: Blosc("zstd", 3, Blosc.SHUFFLE).encode(a),
    "planar-blosc-zstd3-shuffle": lambda a: Blosc("zstd", 3, Blosc.SHUFFLE).encode(planar(a)),
}


def main(argv=None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--renders", required=True)
    ap.add_argument("--samples", type=int, default=24)
    a = ap.parse_args(argv)
    Blosc.use_threads = False
    g = zarr.open_group(a.renders, mode="r")
    idx = np.linspace(0, g["image"].shape[0] - 1, a.samples).astype(int)
    rows = []
    for name in ("image", "diffuse", "normal", "roughness", "specular"):
        chunks = [g[name][int(i)] for i in idx]
        for arm, f in ARMS.items():
            t = time.process_time()
            kb = sum(len(f(c)) for c in chunks) / len(chunks) / 1e3
            ms = (time.process_time() - t) / len(chunks) * 1e3
            rows.append({"array": name, "arm": arm, "kb": round(kb, 1), "encode_ms": round(ms, 2),
                         "raw_kb": chunks[0].nbytes / 1e3})
            print(f"{name:10s} {arm:28s} {kb:8.1f} KB {ms:6.2f} ms", flush=True)
    RESULTS.mkdir(exist_ok=True)
    with open(RESULTS / "layouts.csv", "w", newline="") as f:
        w = csv.DictWriter(f, list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    return rows


if __name__ == "__main__":
    main()
