"""A training read's cost by the kind of SVBRDF (variant or blend), from a renders store with maps and one without
(#42): what the paper's mix, 92 % blends, costs a loader, from measured per-kind figures.

The two stores must hold the same SVBRDFs (the same inputs rendered with ``render.maps`` stored and inputs). Reads
are 256² crops of random views (:meth:`storage.renders_store.RendersReader.crop`), the same views in the same
order from each store, blocks of ``--block`` alternating between the stores, with one loader worker's budget;
each read's CPU time is kept under its SVBRDF's input kind.

    python3 experiments/renders_inputs/read_by_kind.py --stored ../ps2/renders.zarr --inputs ../ps2/renders_v6.zarr
"""
from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np

#: the paper's counts: 1,820 variants (182 base materials x 10) and 20,000 blends
PAPER = {"variants": 1820, "blends": 20000}


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--stored", required=True)
    ap.add_argument("--inputs", required=True)
    ap.add_argument("--reads", type=int, default=1200)
    ap.add_argument("--block", type=int, default=50)
    ap.add_argument("--crop", type=int, default=256)
    ap.add_argument("--cache-mib", type=int, default=512)
    ap.add_argument("--note", default="")
    ap.add_argument("--out", default=str(Path(__file__).parent / "results" / "read_by_kind.json"))
    a = ap.parse_args(argv)
    from storage.renders_store import RendersReader

    readers = {"stored": RendersReader(a.stored), "inputs": RendersReader(a.inputs)}
    assert readers["stored"].inputs is None and readers["inputs"].inputs is not None, "a store with maps, one without"
    for r in readers.values():
        r.set_cache_bytes(a.cache_mib << 20)
    kinds = readers["stored"].input_kinds_of_views()
    assert kinds == readers["inputs"].input_kinds_of_views(), "the stores must hold the same SVBRDFs"
    n, res = len(kinds), readers["stored"].res
    rng = np.random.default_rng(0)
    views = rng.integers(0, n, a.reads)
    corner = rng.integers(0, res - a.crop + 1, (a.reads, 2))
    cpu = {k: {"variants": [], "blends": []} for k in readers}
    for b0 in range(0, a.reads, a.block):
        for k in (("stored", "inputs") if (b0 // a.block) % 2 == 0 else ("inputs", "stored")):
            for j in range(b0, min(a.reads, b0 + a.block)):
                c = time.process_time()
                readers[k].crop(int(views[j]), int(corner[j, 0]), int(corner[j, 1]), a.crop)
                cpu[k][kinds[views[j]]].append(1000 * (time.process_time() - c))
    per = {k: {kind: {"reads": len(v), "cpu_ms_mean": round(statistics.fmean(v), 2)} for kind, v in d.items() if v}
           for k, d in cpu.items()}
    share = PAPER["blends"] / (PAPER["blends"] + PAPER["variants"])
    mix = {k: round(share * d["blends"]["cpu_ms_mean"] + (1 - share) * d["variants"]["cpu_ms_mean"], 2)
           for k, d in per.items()}
    res = {"experiment": "renders_inputs.read_by_kind", "stored": a.stored, "inputs": a.inputs, "reads": a.reads,
           "crop": a.crop, "cache_mib": a.cache_mib, "per_kind": per, "paper_blend_share": round(share, 4),
           "paper_mix_cpu_ms_per_read": mix, "paper_mix_inputs_over_stored": round(mix["inputs"] / mix["stored"], 4),
           "note": a.note, "command": "python3 experiments/renders_inputs/read_by_kind.py " + " ".join(
               argv or sys.argv[1:])}
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps(res, indent=1) + "\n")
    print(json.dumps({k: res[k] for k in ("per_kind", "paper_mix_cpu_ms_per_read", "paper_mix_inputs_over_stored")}))
    return res


if __name__ == "__main__":
    main()
