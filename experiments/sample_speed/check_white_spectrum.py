"""The white spectrum from PCG64's raw stream against the float draws it replaced (#42): bytes and time.

For every size in ``--sizes`` (default: 64..299 in steps of 7 and the sizes around the powers of two) and 4 seeds,
:func:`materials.noise.white_spectrum` must equal the float-draw construction (the test's reference,
``tests/test_materials_noise._white_spectrum_by_float_draws``) word for word. Then both are timed at 256 and 288
(the default and the paper's size), the median of ``--reps`` calls after a warm-up, in this process.

    PYTHONPATH=. python3 experiments/sample_speed/check_white_spectrum.py   # -> results/white_spectrum.json
"""
from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(ROOT))

from materials.noise import white_spectrum  # noqa: E402
from tests.test_materials_noise import _white_spectrum_by_float_draws as by_float_draws  # noqa: E402

SIZES = sorted(set(range(64, 300, 7)) | {64, 127, 128, 129, 255, 256, 257, 288, 300, 384, 511, 512, 513, 640, 1000,
                                          1023, 1024})
SEEDS = (0, 1, 987654321, 2**63 - 5)


def median_ms(f, reps: int) -> float:
    f()
    times = []
    for _ in range(reps):
        t = time.perf_counter()
        f()
        times.append(time.perf_counter() - t)
    return 1000 * statistics.median(times)


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--reps", type=int, default=300)
    ap.add_argument("--out", default=str(HERE / "results" / "white_spectrum.json"))
    a = ap.parse_args(argv)
    differ = [(n, s) for n in SIZES for s in SEEDS
              if white_spectrum(n, s).view(np.uint32).tobytes() != by_float_draws(n, s).view(np.uint32).tobytes()]
    timing = {}
    for n in (256, 288):
        timing[str(n)] = {"float_draws_ms": round(median_ms(lambda: by_float_draws(n, 5), a.reps), 3),
                          "raw_stream_ms": round(median_ms(lambda: white_spectrum(n, 5), a.reps), 3)}
    result = {"experiment": "sample_speed/check_white_spectrum", "sizes": len(SIZES), "seeds": len(SEEDS),
              "differing": differ, "median_ms": timing, "reps": a.reps,
              "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())}
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps(result, indent=1) + "\n")
    print(json.dumps(result))
    return result


if __name__ == "__main__":
    main()
