"""`svgen gallery` on a large store: peak memory and time against the store's size and --max.

Builds variants stores of 2,000 and 20,000 SVBRDFs at 64² (the real store layout, written by
storage.local.StoreWriter; sample i holds the maps of preset i mod 8 at its defaults, so building takes seconds
rather than the ~45 min that `svgen sample` would), then runs `svgen gallery` on each in its own process and reads
that process's peak resident memory (os.wait4). Memory that does not grow from 2,000 to 20,000 SVBRDFs is what
"written in bounded memory" means; --max sets the page's size. When Chromium is present, the time for it to load
the largest page and take a screenshot says whether the page stays usable.

    python3 experiments/gallery_memory/bench_gallery.py -> experiments/gallery_memory/results/gallery.json
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

# harness.py (and freshness.py) stay in benchmarks/; this finished experiment imports them from there
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from harness import ROOT, SVGEN, parser, write_results  # noqa: E402

#: this experiment's frozen results (experiments/gallery_memory/results/)
RESULTS = Path(__file__).resolve().parent / "results"

SIZE, CHUNK, TEMPLATES = 64, 64, 8


def build(path: Path, n: int) -> None:
    """A finished variants store of ``n`` SVBRDFs (preset i mod 8 at its defaults)."""
    import materials
    from storage import local as S
    from storage.svbrdf_store import array_specs, encode_maps

    chosen = materials.presets()[::6][:TEMPLATES]
    enc = [encode_maps(p.generate(None, SIZE, 0)) for p in chosen]
    names = [p.name for p in chosen]
    arrays = array_specs("variants", SIZE, 0)
    with S.StoreWriter(path, "variants", n, CHUNK, arrays, {"bench": "gallery", "n": n},
                       {"presets": names, "param_names": {}}) as w:
        for c in range(-(-n // CHUNK)):
            a, b = w.chunk_range(c)
            t = np.arange(a, b) % TEMPLATES
            data = {k: np.stack([enc[j][k] for j in t]) for k in enc[0]}
            data["seed"] = np.arange(a, b, dtype=np.uint64)
            data["preset"] = np.stack([t, np.full_like(t, -1)], 1).astype(np.int32)
            S.write_chunk(w.partial, c, a, data)
        w.finalize()


def run_gallery(store: Path, out: Path, max_n: int) -> dict:
    """`svgen gallery STORE --out OUT --max N` in a child process: its wall time and peak RSS."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "SVGEN_NO_PROGRESS": "1"}
    t = time.perf_counter()
    p = subprocess.Popen([*SVGEN, "gallery", str(store), "--out", str(out), "--max", str(max_n)], env=env)
    _, status, usage = os.wait4(p.pid, 0)
    wall = time.perf_counter() - t
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"svgen gallery failed on {store}")
    files = list((out / "thumbs").rglob("*.png"))
    return {"max": max_n, "wall_s": round(wall, 2), "peak_rss_mb": round(usage.ru_maxrss / 1024, 1),
            "page_kb": round((out / "index.html").stat().st_size / 1024, 1), "thumbnails": len(files),
            "thumbnail_mb": round(sum(f.stat().st_size for f in files) / 2**20, 2)}


def chromium_load_s(page: Path, shot: Path) -> float | None:
    """Seconds for headless Chromium to open ``page`` and write a screenshot (None without Chromium)."""
    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    if exe is None:
        return None
    t = time.perf_counter()
    subprocess.run([exe, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars", "--window-size=1280,900",
                    f"--screenshot={shot}", page.as_uri()], check=True, capture_output=True, timeout=600)
    return round(time.perf_counter() - t, 2)


def main() -> None:
    ap = parser(__doc__)
    ap.set_defaults(note="2 CPU cores shared with other jobs; 64² maps; one run each")
    ap.add_argument("--sizes", type=int, nargs="+", default=[2000, 20000])
    ap.add_argument("--max", dest="maxes", type=int, nargs="+", default=[200, 2000])
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        for n in args.sizes:
            t = time.perf_counter()
            build(d / f"s{n}.zarr", n)
            built = round(time.perf_counter() - t, 1)
            for m in args.maxes:
                if m > n:
                    continue
                r = run_gallery(d / f"s{n}.zarr", d / f"g{n}_{m}", m)
                r.update(svbrdfs=n, build_s=built)
                if n == max(args.sizes) and m == max(args.maxes):
                    r["chromium_load_s"] = chromium_load_s(d / f"g{n}_{m}" / "index.html", d / "shot.png")
                rows.append(r)
                print(json.dumps(r))
    write_results(RESULTS / "gallery.json", {"map_size": SIZE, "runs": rows}, note=args.note)


if __name__ == "__main__":
    main()
