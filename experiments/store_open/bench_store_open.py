"""What the chunk-manifest check costs on every open: open_store with and without check_chunks, and verify_store.

A store of N chunks x A arrays of tiny samples (the cost is per chunk file, not per byte: one stat each), as many
files as a renders store of 2 * N SVBRDFs at chunk 2 with its 13 arrays.

    python3 experiments/store_open/bench_store_open.py [--chunks 2000]   # -> results/store_open.json
"""
from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from storage import local as L
from storage import store as S

# harness.py (and freshness.py) stay in benchmarks/; this finished experiment imports them from there
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from harness import parser, write_results  # noqa: E402

#: this experiment's frozen results (experiments/store_open/results/)
RESULTS = Path(__file__).resolve().parent / "results"

ARRAYS = 13


def build(path: Path, chunks: int) -> None:
    arrays = {f"a{k}": S.ArraySpec((4,), "uint16") for k in range(ARRAYS)}
    with S.StoreWriter(path, "renders", chunks * 2, 2, arrays, {"bench": True}) as w:
        for c in range(chunks):
            a, b = w.chunk_range(c)
            S.write_chunk(w.partial, c, a, {k: np.full((b - a, 4), c + 1, np.uint16) for k in arrays})
        w.finalize()


def best(fn, repeat: int = 5) -> float:
    out = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t)
    return min(out)


def main() -> None:
    ap = parser(__doc__)
    ap.set_defaults(note="2 shared CPU cores (5 helpers at once), warm page cache; best of 5 (verify: of 2)")
    ap.add_argument("--chunks", type=int, default=2000)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "s.zarr"
        build(p, args.chunks)
        with_check = best(lambda: S.open_store(p, "renders"))
        # open_store calls storage.local's check_chunks (since #26; storage.store only re-exports it)
        real = L.check_chunks
        L.check_chunks = lambda *a: None
        try:
            without = best(lambda: S.open_store(p, "renders"))
        finally:
            L.check_chunks = real
        verify = best(lambda: S.verify_store(p), 2)
    res = {"chunks": args.chunks, "arrays": ARRAYS, "chunk_files": args.chunks * ARRAYS,
           "open_s_with_manifest_check": with_check, "open_s_without": without,
           "check_s_per_1000_files": (with_check - without) / (args.chunks * ARRAYS) * 1000,
           "verify_store_s": verify}
    write_results(RESULTS / "store_open.json", res, note=args.note)
    print(json.dumps(res, indent=1))


if __name__ == "__main__":
    main()
