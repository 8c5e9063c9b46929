"""Does the 8-bit sRGB encoding need its second threshold comparison? Every float32 in [0, 1], both rules (#42).

The encoder (storage/srgb8.py) finds a value's code from a table of 8,192 buckets. Until 2026-12-03 it started from
the bucket below x's bucket and compared x with the next threshold twice, in case ``x * 8192`` rounded across a
bucket start. It cannot: 8,192 is a power of two, so ``x * 8192`` is exact in float32 and its floor is x's bucket.
The buckets (1.2e-4 wide) are narrower than the closest two thresholds (3.0e-4 apart, on the curve's linear part),
so at most one threshold lies between x's bucket start and x: one comparison from x's own bucket finishes the count.

This script checks the claim on all 1,065,353,217 float32 values in [0, 1] (values outside are clipped to its ends
first). It runs both rules in numpy, 16.8 M values at a time, and counts the values whose codes differ.

    PYTHONPATH=. python3 experiments/direct_calls/check_encoder_rule.py   # -> results/encoder_rule.json, ~1 min
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from harness import parser, write_results  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--out", default=str(RESULTS / "encoder_rule.json"))
    a = ap.parse_args(argv)
    from storage.srgb8 import _BUCKETS, _bucket_codes

    codes, thr = _bucket_codes()
    last = int(np.float32(1.0).view(np.uint32))
    step = 1 << 24
    differ = checked = 0
    for lo in range(0, last + 1, step):
        x = np.arange(lo, min(lo + step, last + 1), dtype=np.uint32).view(np.float32)
        # the rule before: from the bucket below, two comparisons
        b = np.maximum((x * _BUCKETS).astype(np.int64) - 1, 0)
        c_two = codes[b]
        c_two += x >= thr[c_two]
        c_two += x >= thr[c_two]
        # one comparison from x's own bucket
        c_one = codes[(x * _BUCKETS).astype(np.int64)]
        c_one += x >= thr[c_one]
        differ += int(np.count_nonzero(c_one != c_two))
        checked += x.size
    result = {"experiment": "direct_calls.check_encoder_rule", "float32_values_checked": checked,
              "first": 0.0, "last": 1.0, "differing_codes": differ}
    write_results(a.out, result, a.note)
    print(result)


if __name__ == "__main__":
    main()
