"""The images' zstd encode at levels 2, 3 and 4, alone and with a second copy running at once (#42).

Does contention on 2 cores (the render stage's 2 workers) make level 4 dearer than the isolated curve says?
``--samples`` images of a renders store, each encoded at every level in 3 rounds; the median CPU ms per SVBRDF
(10 views) is printed. Run it alone, then as two processes at once:

    python3 experiments/store_levels/probe_contention.py --renders ../ps2/renders.zarr --tag alone
    python3 experiments/store_levels/probe_contention.py --renders ../ps2/renders.zarr --tag A & \\
    python3 experiments/store_levels/probe_contention.py --renders ../ps2/renders.zarr --tag B; wait
"""
from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
import zarr
from numcodecs import Zstd


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--renders", required=True)
    ap.add_argument("--samples", type=int, default=24)
    ap.add_argument("--tag", default="alone")
    a = ap.parse_args(argv)
    g = zarr.open_group(a.renders, mode="r")
    idx = np.linspace(0, g["image"].shape[0] - 1, a.samples).astype(int)
    chunks = [np.ascontiguousarray(g["image"][int(i)]) for i in idx]
    res: dict[int, list[float]] = {}
    for _ in range(3):
        for lv in (3, 4, 2):
            z, t = Zstd(level=lv), time.process_time()
            for c in chunks:
                z.encode(c)
            res.setdefault(lv, []).append((time.process_time() - t) / len(chunks) * 1e3)
    out = {lv: round(statistics.median(v), 2) for lv, v in sorted(res.items())}
    print(a.tag, "encode ms per SVBRDF image:", out, flush=True)
    return out


if __name__ == "__main__":
    main()
