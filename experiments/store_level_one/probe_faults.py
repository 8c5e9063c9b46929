"""What one inner chunk's zstd encode costs at each level, in a fresh process: CPU, page faults and bytes.

Each level is measured in its own fresh process (as a stage's worker meets it): ``--calls`` encodes of ``--arrays``
of 16 samples spread evenly over ``--store`` (one sample of one array is one inner chunk of the stores: a variant's
map, or an SVBRDF's 10 views of the renders' image), through the stages' own encoder (numcodecs' Zstd, as
``storage.local.encode_shard`` calls it). Reported per call: CPU (user and system, from ``resource.getrusage``),
minor page faults and compressed KB. It was written to test a guess (zstd 3 costs the sample stage more than an
isolated encode because of per-call page faults), which it refuted.

    python3 experiments/store_level_one/probe_faults.py --store V.zarr            # maps -> results/faults.json
    python3 experiments/store_level_one/probe_faults.py --store R.zarr --arrays image --out results/images.json
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
MAPS = ("diffuse", "normal", "roughness", "specular")

CHILD = r"""
import json, resource, sys
import numpy as np, zarr
from numcodecs import Zstd
level, calls, store, arrays = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3], sys.argv[4].split(",")
g = zarr.open_group(store, mode="r")
n = g[arrays[0]].shape[0]
maps = [np.ascontiguousarray(g[m][int(i)]) for i in np.linspace(0, n - 1, min(n, 16)).round() for m in arrays]
z = Zstd(level=level, checksum=False)
z.encode(maps[0].view(np.uint8))  # the codec's first use (its import and one-off set-up) is not counted
r0 = resource.getrusage(resource.RUSAGE_SELF)
size = 0
for k in range(calls):
    size += len(z.encode(maps[k % len(maps)].view(np.uint8)))
r1 = resource.getrusage(resource.RUSAGE_SELF)
print(json.dumps({"level": level, "calls": calls, "user_ms_per_call": 1e3 * (r1.ru_utime - r0.ru_utime) / calls,
                  "sys_ms_per_call": 1e3 * (r1.ru_stime - r0.ru_stime) / calls,
                  "minor_faults_per_call": (r1.ru_minflt - r0.ru_minflt) / calls, "kb_per_call": size / calls / 1e3}))
"""


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--store", "--variants", dest="store", required=True,
                    help="a store (e.g. svgen sample --config-preset paper)")
    ap.add_argument("--arrays", default=",".join(MAPS), help="its arrays to encode (default: the four maps)")
    ap.add_argument("--levels", default="1,3")
    ap.add_argument("--calls", type=int, default=400)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--note", default="")
    ap.add_argument("--out", default=str(HERE / "results" / "faults.json"))
    a = ap.parse_args(argv)
    rows = []
    for r in range(a.rounds):
        for level in [int(x) for x in a.levels.split(",")]:
            out = subprocess.run([sys.executable, "-c", CHILD, str(level), str(a.calls), a.store, a.arrays], check=True,
                                 capture_output=True, text=True).stdout
            rows.append({"round": r, **json.loads(out)})
            print(rows[-1], flush=True)
    res = {"experiment": "store_level_one.probe_faults", "arrays": a.arrays.split(","), "rows": rows, "note": a.note,
           "command": "python3 experiments/store_level_one/probe_faults.py " + " ".join(argv or sys.argv[1:])}
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps(res, indent=1) + "\n")
    return res


if __name__ == "__main__":
    main()
