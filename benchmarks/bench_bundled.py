"""The bundled model's figures: its size, the wheel's size, and its ONNX export against torch.

Measured:

* the bundled weights file (``train/bundled/model.pt``): bytes and parameters;
* the wheel (``pip wheel . --no-deps --no-build-isolation`` of a copy of the tracked files): bytes (bar: 20 MB);
* ``svtrain export-model bundled --format onnx``: export seconds, the first in the process (what one
  `svtrain export-model` call pays: it imports the onnx package, timed alone in a fresh process as
  ``onnx_import_s``) and a second one (``onnx_export_warm_s``), the .onnx bytes, and on ``--photos`` seeded
  synthetic flash photos (a falloff lobe over a random texture, linear [0, 1]) at two sizes, 256² and 256 x 384
  (dynamic axes), the largest absolute difference between onnxruntime's and torch's decoded maps, and the
  seconds per photo of each runtime (one thread each, the median of 3 runs).

Writes benchmarks/results/bundled.json. Usage: python3 benchmarks/bench_bundled.py [--photos N] [--note TEXT]
"""
from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from harness import RESULTS, ROOT, parser, run_child, timed, write_results

SIZES = ((256, 256), (256, 384))
WHEEL_BAR = 20 * 1024 * 1024


def photos(n: int, h: int, w: int) -> np.ndarray:
    """(n, 3, h, w) float32 linear flash photos (seeded)."""
    rng = np.random.default_rng(0)
    yy, xx = np.mgrid[0:h, 0:w] / h - 0.5
    out = []
    for _ in range(n):
        cx, cy, k = rng.uniform(-0.15, 0.15, 2).tolist() + [rng.uniform(0.01, 0.08)]
        lobe = 1.0 / (1.0 + ((xx - cx) ** 2 + (yy - cy) ** 2) / k)
        out.append(np.clip(lobe[..., None] * rng.uniform(0.1, 1.0, (1, 1, 3)) * rng.uniform(0.5, 1.0, (h, w, 3)), 0, 1))
    return np.stack(out).transpose(0, 3, 1, 2).astype(np.float32)


def wheel_bytes(tmp: Path) -> int:
    files = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard"], cwd=ROOT,
                           capture_output=True, text=True, check=True).stdout.split("\n")
    src = tmp / "src"
    for f in filter(None, files):
        if (ROOT / f).is_file():
            (src / f).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(ROOT / f, src / f)
    subprocess.run([sys.executable, "-m", "pip", "wheel", ".", "--no-deps", "--no-build-isolation", "-q", "-w",
                    str(tmp / "dist")], cwd=src, check=True)
    return next((tmp / "dist").glob("svgen-*.whl")).stat().st_size


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--photos", type=int, default=8)
    args = ap.parse_args()
    import onnxruntime as ort
    import torch

    from train import bundled_model
    from train.export import DecodedMaps, export_onnx, load_for_export
    from train.net import count_parameters

    torch.set_num_threads(1)
    model_file = bundled_model.model_path()
    net, state, _ = load_for_export("bundled")
    wrapped = DecodedMaps(net)
    with tempfile.TemporaryDirectory() as td:
        tmp = Path(td)
        wheel = wheel_bytes(tmp)
        t = timed(lambda: export_onnx("bundled", tmp / "bundled.onnx"))
        warm = timed(lambda: export_onnx("bundled", tmp / "bundled.onnx"))
        onnx_bytes = (tmp / "bundled.onnx").stat().st_size
        opts = ort.SessionOptions()
        opts.intra_op_num_threads = 1
        sess = ort.InferenceSession(str(tmp / "bundled.onnx"), opts, providers=["CPUExecutionProvider"])
        rows = []
        for h, w in SIZES:
            x = photos(args.photos, h, w)
            got = timed(lambda: [sess.run(None, {"image": x[i:i + 1]}) for i in range(len(x))], reps=3)
            with torch.no_grad():
                want = timed(lambda: [[o.numpy() for o in wrapped(torch.from_numpy(x[i:i + 1]))]
                                      for i in range(len(x))], reps=3)
            diff = max(float(np.abs(g - w_).max()) for gs, ws in zip(got.result, want.result)
                       for g, w_ in zip(gs, ws))
            rows.append({"size": [h, w], "photos": len(x), "max_abs_diff": diff,
                         "onnxruntime_s_per_photo": got.wall_s / len(x), "torch_s_per_photo": want.wall_s / len(x)})
    write_results(RESULTS / "bundled.json", {
        "benchmark": "bench_bundled",
        "model_bytes": model_file.stat().st_size, "parameters": count_parameters(net), "steps": state["step"],
        "wheel_bytes": wheel, "wheel_bar_bytes": WHEEL_BAR, "wheel_under_bar": wheel < WHEEL_BAR,
        "onnx_bytes": onnx_bytes, "onnx_export_s": t.wall_s,
        "onnx_export_warm_s": warm.wall_s,
        "onnx_import_s": run_child([sys.executable, "-c", "import onnx"])["wall_s"], "onnx_vs_torch": rows,
        "max_abs_diff": max(r["max_abs_diff"] for r in rows)}, args.note)
    print(f"model {model_file.stat().st_size / 1e6:.2f} MB, wheel {wheel / 1e6:.2f} MB, onnx {onnx_bytes / 1e6:.2f} "
          f"MB, max |onnx - torch| {max(r['max_abs_diff'] for r in rows):.2e}")


if __name__ == "__main__":
    main()
