"""Codec and sharding of the stores (issue #12): bytes and CPU-s per view against objects per 10,000 views.

Real rendered data, read-only: the first ``--samples`` SVBRDFs of a renders store (every array a renders store
holds: the uint8 sRGB images (V, R, R, 3), the view parameters, the uint16 base maps and the provenance columns)
and, with ``--variants``, of a variants store (its maps and columns, per variant). Each array is rewritten
exactly as :func:`storage.store.write_chunk` writes it -- one aligned region per dask task into a
``zarr.Array`` created first -- with every candidate codec pipeline (:data:`CODECS`, each ending in CRC32C like
the stores today) in every layout (:func:`layouts`):

* ``chunked``: "today", the stores before #12 applied this measurement: unsharded, one chunk per task (render 2
  SVBRDFs, sample 8: ``TODAY_RENDER_TASK``, ``TODAY_SAMPLE_TASK``);
* ``shard=task``: zarr's sharding codec, one shard per today's task, inner chunks of one sample;
* ``shard=N``: one shard per larger task, N samples (the smallest power of two that keeps the objects at or under
  the aim of 200 per 10,000 views), inner chunks of one sample, so a random read still decodes one sample.

Per candidate and layout: bytes per view (the files written, zarr.json excluded), CPU seconds per view to
encode + write (``time.process_time`` around the region writes only: all threads of this process, zarr's
I/O and codec threads included), to read + decode (whole arrays; the files are in the page cache), the
median of ``--reps`` fresh writes (in rounds: every candidate once per round, so load changes on a shared machine
spread over all of them), and objects per 10,000 views counted from the files written. Every
candidate's read-back is compared with the input (``lossless`` must hold: the run fails otherwise).

The default is chosen by a stated rule (:func:`choose`) and written into the results with the rule.

A finished experiment (#12 applied its in-spec choice; REPORT.md): its results are frozen in
experiments/store_codecs/results/ (codecs.json and codecs.csv). Usage:
    python3 experiments/store_codecs/bench_codecs.py [--renders data/renders.zarr] [--variants data/variants.zarr]
                                                     [--samples 64] [--reps 3] [--note ...]
"""
from __future__ import annotations

import json
import math
import shutil
import statistics
import sys
import tempfile
import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
import zarr
from zarr.codecs import BloscCodec, Crc32cCodec, TransposeCodec, ZstdCodec
from zarr.codecs.numcodecs import Delta

from storage.store import open_store
from svcore.errors import StoreError

# harness.py (and freshness.py) stay in benchmarks/; this finished experiment imports them from there
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from harness import RESULTS as BENCH_RESULTS, ROOT, command, parser, write_csv, write_results  # noqa: E402

#: this experiment's frozen results (experiments/store_codecs/results/)
RESULTS = Path(__file__).resolve().parent / "results"
#: the maintained render benchmark's results (benchmarks/results/render.json): the end-to-end estimate joins its
#: cpu_s_per_view to this run's write CPU
RENDER_JSON = BENCH_RESULTS / "render.json"

# numcodecs' Delta is not in the zarr v3 spec (zarr says so on every use); the results record it per candidate
warnings.filterwarnings("ignore", message="Numcodecs codecs are not in the Zarr version 3 specification")

#: the issue's aims (#12): per 256^2 view, end to end, and objects of a store
AIM_CPU_S_PER_VIEW = 0.010
AIM_BYTES_PER_VIEW = 150_000
AIM_OBJECTS_PER_10K_VIEWS = 200
TODAY = "zstd5"
#: the tasks of the baseline ("today" in the results: the stores before #12 applied the measurement); since, the
#: configs' defaults are the measured task of 64, so the baseline is pinned here, not read from them
TODAY_RENDER_TASK, TODAY_SAMPLE_TASK = 2, 8


@dataclass(frozen=True)
class Codec:
    """A candidate codec pipeline for one array (zarr v3 ``filters`` + ``compressors``).

    Attributes:
        name: short id (the chart's label).
        family: zstd, blosc or delta (the chart's colour).
        about: what it is, in words.
        make: (numpy dtype, ndim) -> (filters, compressors) for that array.
        in_spec: whether every codec is in the zarr v3 spec (readable by any zarr v3 implementation).
    """

    name: str
    family: str
    about: str
    make: Callable[[np.dtype, int], tuple[list, list]]
    in_spec: bool = True


def _plain(*compressors):
    return lambda dtype, ndim: ([], [*compressors, Crc32cCodec()])


def _blosc(cname: str, shuffle: str):
    return lambda dtype, ndim: ([], [BloscCodec(cname=cname, clevel=5, shuffle=shuffle), Crc32cCodec()])


def _delta(*compressors):
    """Channel-planar left-neighbour prediction (a PNG "Sub"-like filter) for images and maps: the chunk is
    transposed so each channel plane is contiguous, then numcodecs' Delta (wrapping integer differences, exact)
    runs over it. Scalars and small tables get the compressors only."""

    def make(dtype, ndim):
        if ndim < 4 or dtype.kind != "u":
            return [], [*compressors, Crc32cCodec()]
        order = (*range(ndim - 3), ndim - 1, ndim - 3, ndim - 2)  # (..., H, W, C) -> (..., C, H, W)
        return [TransposeCodec(order=order), Delta(dtype=dtype.str)], [*compressors, Crc32cCodec()]

    return make


#: name -> candidate: the registry the benchmark runs through
CODECS: dict[str, Codec] = {c.name: c for c in (
    Codec("zstd1", "zstd", "zstd level 1", _plain(ZstdCodec(level=1))),
    Codec("zstd3", "zstd", "zstd level 3", _plain(ZstdCodec(level=3))),
    Codec("zstd5", "zstd", "zstd level 5 (the stores before #12)", _plain(ZstdCodec(level=5))),
    Codec("zstd9", "zstd", "zstd level 9", _plain(ZstdCodec(level=9))),
    Codec("blosc-zstd-shuf", "blosc", "blosc zstd clevel 5, byte-shuffle", _blosc("zstd", "shuffle")),
    Codec("blosc-zstd-bit", "blosc", "blosc zstd clevel 5, bit-shuffle", _blosc("zstd", "bitshuffle")),
    Codec("blosc-lz4-shuf", "blosc", "blosc lz4 clevel 5, byte-shuffle", _blosc("lz4", "shuffle")),
    Codec("blosc-lz4-bit", "blosc", "blosc lz4 clevel 5, bit-shuffle", _blosc("lz4", "bitshuffle")),
    Codec("delta-zstd1", "delta", "planar left-delta + zstd level 1", _delta(ZstdCodec(level=1)), False),
    Codec("delta-zstd3", "delta", "planar left-delta + zstd level 3", _delta(ZstdCodec(level=3)), False),
    Codec("delta-blosc-zstd-shuf", "delta", "planar left-delta + blosc zstd clevel 5 byte-shuffle",
          _delta(BloscCodec(cname="zstd", clevel=5, shuffle="shuffle")), False),
)}


@dataclass(frozen=True)
class Layout:
    """How an array is cut into objects.

    Attributes:
        name: short id.
        task: samples one dask task writes (one region write per task).
        inner: samples per (inner) chunk: the unit a random read decodes.
        sharded: whether the task's region is one shard holding ``task // inner`` inner chunks.
    """

    name: str
    task: int
    inner: int
    sharded: bool


def layouts(today_task: int, arrays: int, views: int, most: int) -> list[Layout]:
    """Today's chunks, sharding at today's task, and sharding at the smallest power-of-two task that meets the
    objects aim (``arrays`` objects per task, ``views`` views per sample), at most ``most`` samples (the
    samples measured: a variants store, one "view" per sample, would need more than it holds)."""
    need = math.ceil(arrays * 10_000 / (views * AIM_OBJECTS_PER_10K_VIEWS))
    big = min(1 << max(0, math.ceil(math.log2(need))), 1 << int(math.log2(most)))
    out = [Layout("chunked", today_task, today_task, False), Layout("shard=task", today_task, 1, True)]
    return out + [Layout(f"shard={big}", big, 1, True)] if big != today_task else out


def _files(root: Path) -> list[Path]:
    """The chunk/shard files of a store (every file but zarr.json metadata)."""
    return [p for p in root.rglob("*") if p.is_file() and p.name != "zarr.json"]


def write_store(root: Path, data: dict[str, np.ndarray], codec: Codec, layout: Layout) -> float:
    """Create the arrays (untimed), then write every task's region of every array; returns the CPU seconds of
    the writes (this process, all threads)."""
    g = zarr.open_group(root, mode="w", zarr_format=3)
    arrays = {}
    for name, a in data.items():
        filters, compressors = codec.make(a.dtype, a.ndim)
        rest = a.shape[1:]
        arrays[name] = g.create_array(
            name, shape=a.shape, dtype=a.dtype, fill_value=0, filters=filters, compressors=compressors,
            chunks=(layout.inner, *rest), shards=(layout.task, *rest) if layout.sharded else None)
    n = len(next(iter(data.values())))
    c0 = time.process_time()
    for start in range(0, n, layout.task):  # one task: every array's region, as storage.store.write_chunk does
        for name, a in data.items():
            arrays[name][start:start + layout.task] = a[start:start + layout.task]
    return time.process_time() - c0


def read_store(root: Path, names) -> tuple[float, dict[str, np.ndarray]]:
    """Open and read every array whole; returns (CPU seconds, arrays)."""
    c0 = time.process_time()
    g = zarr.open_group(root, mode="r")
    out = {name: g[name][:] for name in names}
    return time.process_time() - c0, out


def measure_once(data: dict[str, np.ndarray], codec: Codec, layout: Layout, root: Path) -> dict:
    """One fresh write and read of one candidate in one layout at ``root``; verifies the read-back.

    Returns:
        write and read CPU seconds, the number of files and the bytes per array written.

    Raises:
        AssertionError: the read-back differs from the input in any bit (a lossy pipeline).
    """
    w_cpu = write_store(root, data, codec, layout)
    r_cpu, back = read_store(root, data)
    # bit for bit (NaN padding of a variants store's params included)
    bad = [k for k in data if back[k].dtype != data[k].dtype or back[k].shape != data[k].shape
           or back[k].tobytes() != data[k].tobytes()]
    if bad:
        raise AssertionError(f"{codec.name} in layout {layout.name} is not lossless on {bad}")
    files = _files(root)
    return {"write": w_cpu, "read": r_cpu, "files": len(files),
            "bytes": {k: sum(p.stat().st_size for p in files if p.relative_to(root).parts[0] == k) for k in data}}


def row_of(data: dict[str, np.ndarray], views: int, codec: Codec, layout: Layout, runs: list[dict]) -> dict:
    """The results row of one candidate in one layout from its runs (medians of the CPU; bytes and files of the
    last run, which every run repeats exactly)."""
    n_views = len(next(iter(data.values()))) * views
    last = runs[-1]
    total = sum(last["bytes"].values())
    w = statistics.median(r["write"] for r in runs)
    rd = statistics.median(r["read"] for r in runs)
    return {
        "codec": codec.name, "family": codec.family, "layout": layout.name, "sharded": layout.sharded,
        "task_samples": layout.task, "inner_chunk_samples": layout.inner,
        "bytes_per_view": total / n_views, "ratio": sum(a.nbytes for a in data.values()) / total,
        "write_cpu_s_per_view": w / n_views, "read_cpu_s_per_view": rd / n_views,
        "write_read_cpu_s_per_view": (w + rd) / n_views,
        "objects": last["files"], "objects_per_10k_views": last["files"] * 10_000 / n_views,
        "bytes_per_view_by_array": {k: v / n_views for k, v in last["bytes"].items()},
        "write_cpu_s_reps": [r["write"] for r in runs], "read_cpu_s_reps": [r["read"] for r in runs],
        "lossless": True,
    }


def measure(data: dict[str, np.ndarray], views: int, codec: Codec, layout: Layout, reps: int, tmp: Path) -> dict:
    """One candidate in one layout, ``reps`` fresh writes and reads in a row (medians); verifies each read-back.

    Raises:
        AssertionError: the read-back differs from the input in any bit (a lossy pipeline).
    """
    runs = []
    for r in range(reps):
        root = tmp / f"{codec.name}-{layout.name}-{r}.zarr"
        runs.append(measure_once(data, codec, layout, root))
        shutil.rmtree(root)
    return row_of(data, views, codec, layout, runs)


def load(path: Path, kind: str, samples: int) -> tuple[dict[str, np.ndarray], list[int]]:
    """``samples`` samples evenly spread over a complete svgen store (read-only), so that every part of it
    (variants of every class, blends) is measured: every array's values and the sample indices."""
    g = open_store(path, kind)
    n = int(g.attrs["svgen"]["n"])
    idx = np.unique(np.linspace(0, n - 1, min(samples, n)).round().astype(int))
    # numeric arrays only: the string name arrays (storage/labels.py) are derived at commit, tiny, and not what the
    # codecs are chosen for
    return {name: np.ascontiguousarray(a.oindex[idx]) for name, a in sorted(g.arrays())
            if a.dtype.kind in "iuf"}, idx.tolist()


def stores_codec() -> str:
    """The candidate the renders stores write their images with (read from ``storage.renders_store.array_specs``,
    its one home; the image is most of their bytes and of their write): render.json's cpu_s_per_view is measured
    with it, so the end-to-end estimate swaps its write for the chosen one's."""
    from storage.renders_store import array_specs

    return f"zstd{array_specs(10, 8, 8)['image'].zstd_level}"


def score(row: dict) -> float:
    """Distance from zero in units of the aims: bytes / 150 KB + encode+write+read+decode CPU / 10 ms per view.
    1 + 1 would sit on the aim box's corner; each 10 % over either aim costs the same."""
    return row["bytes_per_view"] / AIM_BYTES_PER_VIEW + row["write_read_cpu_s_per_view"] / AIM_CPU_S_PER_VIEW


def choose(rows: list[dict], render_cpu_s_per_view: float | None) -> dict:
    """The rule: among the renders-store rows whose layout meets the objects aim (<= 200 objects per 10,000
    views; every layout if none does), a row meeting both the bytes aim (<= 150 KB per view) and, with the
    render's own CPU, the end-to-end CPU aim wins outright (the cheapest such); otherwise the knee: the smallest
    score = bytes / 150 KB + (write + read CPU) / 10 ms per view, both aims weighted alike. The same rule among
    codecs in the zarr v3 spec only gives ``in_spec`` (for stores other zarr implementations must read)."""
    how = []
    ok_layout = [r for r in rows if r["objects_per_10k_views"] <= AIM_OBJECTS_PER_10K_VIEWS]
    if not ok_layout:
        how.append("no layout meets the objects aim: every layout considered")
        ok_layout = rows
    today = next((r for r in rows if r["codec"] == TODAY and r["layout"] == "chunked"), None)
    # the write render.json paid: the stores' codec in its largest sharded layout (what the stores write now)
    ours = stores_codec()
    applied = max((r for r in rows if r["codec"] == ours and r["layout"].startswith("shard=")),
                  key=lambda r: r["task_samples"], default=None)
    render_only = (render_cpu_s_per_view - applied["write_cpu_s_per_view"]
                   if render_cpu_s_per_view is not None and applied is not None else 0.0)

    def pick_from(cands):
        meets = [r for r in cands if r["bytes_per_view"] <= AIM_BYTES_PER_VIEW and
                 render_only + r["write_cpu_s_per_view"] <= AIM_CPU_S_PER_VIEW]
        if meets:
            return min(meets, key=lambda r: r["write_read_cpu_s_per_view"]), "meets both aims: the cheapest"
        return min(cands, key=score), "no row meets both aims: the knee (smallest score)"

    pick, branch = pick_from(ok_layout)
    how.append(branch)
    spec_rows = [r for r in ok_layout if CODECS[r["codec"]].in_spec]
    in_spec = pick_from(spec_rows)[0] if spec_rows else None

    def summary(r):
        return {"codec": r["codec"], "about": CODECS[r["codec"]].about,
                "in_zarr_v3_spec": CODECS[r["codec"]].in_spec,
                "layout": r["layout"], "task_samples": r["task_samples"],
                "inner_chunk_samples": r["inner_chunk_samples"], "bytes_per_view": r["bytes_per_view"],
                "write_cpu_s_per_view": r["write_cpu_s_per_view"], "read_cpu_s_per_view": r["read_cpu_s_per_view"],
                "objects_per_10k_views": r["objects_per_10k_views"], "score": score(r),
                "meets_bytes_aim": r["bytes_per_view"] <= AIM_BYTES_PER_VIEW}

    out = {"rule": " ".join(choose.__doc__.split()), "applied": "; ".join(how), **summary(pick),
           "in_spec": summary(in_spec) if in_spec else None,
           "today_score": score(today) if today else None}
    if render_cpu_s_per_view is not None and applied is not None:
        est = render_only + pick["write_cpu_s_per_view"]
        out.update({"end_to_end_cpu_s_per_view_estimate": est, "meets_cpu_aim_estimate": est <= AIM_CPU_S_PER_VIEW,
                    "end_to_end_note": f"render.json cpu_s_per_view (measured with the stores' {ours}, sharded) "
                                       f"minus this run's {ours} {applied['layout']} write CPU plus the chosen "
                                       "write CPU: an estimate joining two runs, not a measurement"})
    out["stores_codec"] = ours
    return out


def run_store(label: str, path: Path, kind: str, samples: int, today_task: int, reps: int, tmp: Path,
              codecs: list[str], keep: Path | None = None) -> dict:
    """Every candidate in every layout on the first ``samples`` samples of one store (a renders store's unit is
    the view, V per sample; a variants store's the variant)."""
    data, idx = load(path, kind, samples)
    views = int(data["image"].shape[1]) if kind == "renders" else 1
    n = len(next(iter(data.values())))
    lays = layouts(today_task, len(data), views, n)
    for lay in lays:
        if n % lay.task:
            raise SystemExit(f"--samples {samples}: {label} has {n} samples, not a multiple of the task "
                             f"{lay.task} of layout {lay.name} (objects would be counted on a partial shard)")
    # reps outermost: every candidate is measured once per round, so a change of the shared machine's load
    # during the run spreads over all of them instead of favouring the ones measured in a quiet minute
    runs: dict[tuple[str, str], list[dict]] = {}
    for rep in range(reps):
        for lay in lays:
            for name in codecs:
                root = tmp / f"{name}-{lay.name}.zarr"
                runs.setdefault((name, lay.name), []).append(measure_once(data, CODECS[name], lay, root))
                if keep is not None and rep == reps - 1:  # the last write, for a test to recount its files
                    (keep / label).mkdir(parents=True, exist_ok=True)
                    shutil.move(root, keep / label / root.name)
                else:
                    shutil.rmtree(root)
                row = row_of(data, views, CODECS[name], lay, runs[(name, lay.name)])
                print(f"{label:8s} rep {rep} {lay.name:10s} {name:22s} {row['bytes_per_view'] / 1e3:8.1f} KB/view  "
                      f"write {row['write_cpu_s_per_view'] * 1e3:6.2f} ms  read "
                      f"{row['read_cpu_s_per_view'] * 1e3:6.2f} ms  {row['objects_per_10k_views']:7.0f} obj/10k",
                      flush=True)
    rows = [row_of(data, views, CODECS[name], lay, runs[(name, lay.name)]) for lay in lays for name in codecs]
    return {"store": str(path), "kind": kind, "samples": n, "sample_indices": idx, "views_per_sample": views,
            "views": n * views,
            "arrays": {k: {"shape": list(a.shape[1:]), "dtype": str(a.dtype)} for k, a in data.items()},
            "raw_bytes_per_view": sum(a.nbytes for a in data.values()) / (n * views),
            "today_task_samples": today_task, "rows": rows}


def _codecs(spec: str) -> list[str]:
    names = [c for c in spec.split(",") if c]
    unknown = [c for c in names if c not in CODECS]
    if unknown or not names:
        raise SystemExit(f"bench_codecs: unknown codec(s) {unknown or spec!r}; choose from {','.join(CODECS)}")
    return names


def _write(args, stores: dict, render_task: int, t0: float) -> None:
    """Write the results (after each store, so an interrupted run keeps the renders rows)."""
    render_cpu = json.loads(RENDER_JSON.read_text())["cpu_s_per_view"] if RENDER_JSON.exists() else None
    used = list(dict.fromkeys(r["codec"] for d in stores.values() for r in d["rows"]))
    result = {
        "benchmark": "codecs", "aims": {"cpu_s_per_view_end_to_end": AIM_CPU_S_PER_VIEW,
                                        "bytes_per_view": AIM_BYTES_PER_VIEW,
                                        "objects_per_10k_views": AIM_OBJECTS_PER_10K_VIEWS},
        "today": {"codec": TODAY, "layout": "chunked", "task_samples": render_task},
        "codecs": {c: {"about": CODECS[c].about, "family": CODECS[c].family, "in_zarr_v3_spec": CODECS[c].in_spec}
                   for c in used},
        "reps": args.reps, "render_json_cpu_s_per_view": render_cpu,
        "chosen": choose(stores["renders"]["rows"], render_cpu),
        "stores": stores, "wall_s": time.perf_counter() - t0, "complete": len(stores) == 2 or
        str(args.variants) == "none",
        "timing_note": "CPU-s = time.process_time (all threads of this process) around the region writes "
                       "(encode + write) and around open + whole-array reads (read + decode, files in the page "
                       "cache); medians of the reps",
        "objects_note": "objects = chunk or shard files written (zarr.json metadata, one per array, excluded); "
                        "zarr writes no file for a chunk that is all fill value (0), so a column of zeros counts 0",
    }
    write_results(args.out, result, args.note)
    write_csv(args.out.with_suffix(".csv"),
              [{"store": s, **{k: v for k, v in r.items() if not isinstance(v, (dict, list))}}
               for s, d in stores.items() for r in d["rows"]])


def main(argv=None) -> int:
    ap = parser(__doc__)
    ap.add_argument("--renders", type=Path, default=ROOT / "data" / "renders.zarr", help="renders store (read only)")
    ap.add_argument("--variants", type=Path, default=ROOT / "data" / "variants.zarr",
                    help="variants store (read only); 'none' skips it")
    ap.add_argument("--samples", type=int, default=64,
                    help="SVBRDFs (renders) / variants measured, evenly spread over each store")
    ap.add_argument("--reps", type=int, default=2, help="fresh writes and reads per candidate (median)")
    ap.add_argument("--codecs", default=",".join(CODECS), help="comma-separated subset of the candidates")
    ap.add_argument("--variants-codecs", default=None, help="the candidates run on the variants store "
                    "(default: --codecs)")
    ap.add_argument("--tmp", type=Path, default=None, help="scratch folder (default: a temporary one)")
    ap.add_argument("--out", type=Path, default=RESULTS / "codecs.json")
    ap.add_argument("--keep", type=Path, default=None,
                    help="keep each candidate's last written store here (<store>/<codec>-<layout>.zarr)")
    ap.add_argument("--choose-only", action="store_true",
                    help="measure nothing: apply this script's rule (choose) to the rows already in --out and "
                         "rewrite its 'chosen' (the measurement, command and machine kept)")
    args = ap.parse_args(argv)
    if args.choose_only:
        res = json.loads(args.out.read_text())
        res["chosen"] = choose(res["stores"]["renders"]["rows"], res.get("render_json_cpu_s_per_view"))
        res["chosen_note"] = f"chosen re-applied to the measured rows by: {command()}"
        write_results(args.out, res, res.get("note"))
        print(json.dumps(res["chosen"], indent=1))
        return 0
    codecs = _codecs(args.codecs)
    variant_codecs = _codecs(args.variants_codecs) if args.variants_codecs else codecs
    tmp = Path(tempfile.mkdtemp(prefix="svgen-bench-codecs-", dir=args.tmp))
    t0 = time.perf_counter()
    try:
        stores = {"renders": run_store("renders", args.renders, "renders", args.samples, TODAY_RENDER_TASK,
                                       args.reps, tmp, codecs, args.keep)}
        _write(args, stores, TODAY_RENDER_TASK, t0)
        if str(args.variants) != "none":
            stores["variants"] = run_store("variants", args.variants, "variants", args.samples, TODAY_SAMPLE_TASK,
                                           args.reps, tmp, variant_codecs, args.keep)
            _write(args, stores, TODAY_RENDER_TASK, t0)
    except StoreError as e:
        raise SystemExit(f"bench_codecs: {e}") from None
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print(json.loads(args.out.read_text())["chosen"])
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
