"""zstd levels chosen again per array, on the measured curve of bytes against CPU (#42's codec deliverable).

#12 chose one codec for every array of every store (zstd 3 + CRC32C, ``storage.local._compressors``) from whole
stores at 256². #42 asks for codecs and levels chosen again on the curve of bytes against CPU, at the paper's
scale (288², mostly blends), with the disk aim (at most 50 GB) and the time aim (at most 30 minutes on 2 cores)
in view. This measures, for each image and map array of a paper-size renders store and of its variants store, what
every zstd level costs: bytes per sample, encode CPU (what the stage pays once) and decode CPU (what a reader pays
per read), each sample's inner chunk encoded exactly as :func:`storage.local.encode_shard` encodes it (numcodecs'
Zstd, no checksum; the CRC32C on top is the same for every level and left out).

Input: ``--samples`` SVBRDFs spread evenly over the renders store (its variants and blends in their proportion)
and as many variants spread over the variants store. Every level is timed in ``--reps`` rounds (each round times
every level once, so a load change spreads over all of them); the median is kept. Every decode is compared with
the input.

Rule (:func:`choose`): the two aims priced alike. At the paper's scale a sample's bytes count against 50 GB and its
CPU against 30 minutes on 2 cores, over the same number of samples, so the count cancels: one ms of CPU per sample
costs the time aim as much as ``MS_AS_KB`` KB per sample costs the disk aim. A sample's score is
``KB + MS_AS_KB * (encode + decode ms)`` (one write, one read). A map has one level in every store
(``storage.svbrdf_store.map_specs``), so its level is the one with the smallest score summed over the stores,
each weighted by its samples at the paper's scale (:data:`PAPER_SAMPLES`: 21,820 SVBRDFs rendered, 1,820 variants).

    python3 experiments/store_levels/bench_levels.py --renders ../ps2/renders.zarr --variants ../ps2/variants.zarr
"""
from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

import numpy as np
import zarr
from numcodecs import Zstd

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))
from harness import parser, write_csv, write_results  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"
#: the paper-scale aims (#42): bytes against 50 GB, CPU against 30 minutes of 2 cores
AIM_BYTES, AIM_CPU_S = 50e9, 30 * 60 * 2
#: one ms of CPU per sample weighs on the time aim as this many KB per sample weigh on the disk aim
MS_AS_KB = (1e-3 / AIM_CPU_S) / (1e3 / AIM_BYTES)
#: samples of each store at the paper's scale (1,820 variants + 20,000 blends rendered; the variants)
PAPER_SAMPLES = {"renders": 21_820, "variants": 1_820}
ARRAYS = {"renders": ("image", "diffuse", "normal", "roughness", "specular"),
          "variants": ("diffuse", "normal", "roughness", "specular")}


def measure(chunks: list[np.ndarray], level: int) -> dict:
    """Bytes and CPU (ms per sample) of one level over ``chunks`` (one sample each), checked lossless."""
    z = Zstd(level=level, checksum=False)
    t0 = time.process_time()
    bodies = [z.encode(c.view(np.uint8)) for c in chunks]
    t1 = time.process_time()
    backs = [z.decode(b) for b in bodies]
    t2 = time.process_time()
    for c, b in zip(chunks, backs):
        if bytes(b) != c.tobytes():
            raise SystemExit(f"zstd {level}: not lossless")
    n = len(chunks)
    return {"kb": sum(map(len, bodies)) / n / 1e3, "encode_ms": (t1 - t0) / n * 1e3, "decode_ms": (t2 - t1) / n * 1e3}


def choose(rows: list[dict]) -> dict[str, int]:
    """Per array name, the level with the smallest score summed over the stores holding it, each store weighted by
    its samples at the paper's scale (:data:`PAPER_SAMPLES`)."""
    total: dict[str, dict[int, float]] = {}
    for r in rows:
        per = total.setdefault(r["array"], {})
        per[r["level"]] = per.get(r["level"], 0.0) + PAPER_SAMPLES[r["store"]] * r["score_kb"]
    return {name: min(per, key=per.get) for name, per in total.items()}


def paper_scale(rows: list[dict], levels: dict[str, int], today: int = 3) -> dict:
    """Bytes (GB) and encode + decode CPU (s) of the images and maps at the paper's scale, today's level and chosen."""
    out = {}
    for label, lv in (("today", None), ("chosen", levels)):
        gb = cpu = 0.0
        for r in rows:
            if r["level"] == (today if lv is None else lv[r["array"]]):
                gb += PAPER_SAMPLES[r["store"]] * r["kb"] / 1e6
                cpu += PAPER_SAMPLES[r["store"]] * (r["encode_ms"] + r["decode_ms"]) / 1e3
        out[label] = {"gb": round(gb, 2), "encode_decode_cpu_s": round(cpu, 1)}
    return out


def main(argv=None) -> dict:
    ap = parser(__doc__)
    ap.add_argument("--renders", required=True)
    ap.add_argument("--variants", required=True)
    ap.add_argument("--samples", type=int, default=48)
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--levels", default="-1,1,2,3,4,5,7,9")
    a = ap.parse_args(argv)
    levels = [int(x) for x in a.levels.split(",")]
    rows, t_start = [], time.time()
    for store, path in (("renders", a.renders), ("variants", a.variants)):
        g = zarr.open_group(path, mode="r")
        n = g["diffuse"].shape[0]
        idx = np.unique(np.linspace(0, n - 1, a.samples).astype(int))
        for name in ARRAYS[store]:
            chunks = [np.ascontiguousarray(g[name][int(i)]) for i in idx]
            reps = {lv: [] for lv in levels}
            for _ in range(a.reps):
                for lv in levels:
                    reps[lv].append(measure(chunks, lv))
            for lv in levels:
                m = {k: statistics.median(r[k] for r in reps[lv]) for k in ("kb", "encode_ms", "decode_ms")}
                score = m["kb"] + MS_AS_KB * (m["encode_ms"] + m["decode_ms"])
                rows.append({"store": store, "array": name, "level": lv, "samples": len(idx),
                             "raw_kb": chunks[0].nbytes / 1e3, **{k: round(v, 4) for k, v in m.items()},
                             "score_kb": round(score, 3)})
                print(f"{store:8s} {name:9s} zstd {lv:2d}: {m['kb']:8.1f} KB {m['encode_ms']:6.2f} ms encode "
                      f"{m['decode_ms']:5.2f} ms decode  score {score:8.1f}", flush=True)
    chosen = choose(rows)
    result = {"benchmark": "store_levels", "renders": a.renders, "variants": a.variants, "levels": levels,
              "reps": a.reps, "ms_as_kb": round(MS_AS_KB, 3), "paper_samples": PAPER_SAMPLES,
              "rule": "per array, the level with the smallest KB + ms_as_kb * (encode + decode ms) per sample, "
                      "summed over the stores weighted by their samples at the paper's scale",
              "chosen": chosen, "paper_scale": paper_scale(rows, chosen), "rows": rows,
              "wall_s": round(time.time() - t_start, 1)}
    print("chosen:", chosen, result["paper_scale"])
    write_csv(RESULTS / "levels.csv", rows)
    write_results(RESULTS / "levels.json", result, a.note)
    return result


if __name__ == "__main__":
    main()
