"""Where a library's relief sits by scale, against the real reference: round 7's measure for the coarse-relief option.

For each variants store: the normal maps' slopes (x, y) split into the bands of ``relief_signal.py`` (coarse: a
Gaussian blur at 8 px; middle: 2-8 px; fine: below 2 px), and the share of the slope energy in each band, pooled over
the store's materials (as ``relief_signal.py`` pools the views) and as the median of the materials' own shares.
The coarse stores need ``sample.coarse_relief``, removed after round 7: run these at commit 568d4b4.

    svgen import ../shared/materials-cc0 runs/cs/real.zarr
    svgen sample runs/cs/default.zarr --params params.yaml --per-preset 1
    for r in 0.03 0.06 0.1; do
      svgen sample runs/cs/coarse$r.zarr --params params.yaml --per-preset 1 --set coarse_relief=$r; done
    svgen sample runs/cs/c04s1.zarr --params params.yaml --per-preset 1 --set coarse_relief=0.04 --set coarse_share=1
    python3 experiments/real_shape/coarse_share.py real=runs/cs/real.zarr default=runs/cs/default.zarr \
        coarse_0.03=runs/cs/coarse0.03.zarr coarse_0.06=runs/cs/coarse0.06.zarr coarse_0.1=runs/cs/coarse0.1.zarr \
        coarse_0.04_share_1=runs/cs/c04s1.zarr --out experiments/real_shape/results/coarse_share.json
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).parent))

from relief_signal import bands  # noqa: E402

from storage.svbrdf_store import SVBRDFStore  # noqa: E402


#: RMS slope below which a material counts as flat (16-bit normals quantise a flat map to about 1e-4)
FLAT_RMS = 0.005


def shares(path: str) -> dict:
    """Band shares of the slope energy of every material in the variants store at ``path``."""
    store = SVBRDFStore(path, kind="variants")
    energy = {b: [] for b in ("coarse", "middle", "fine")}
    rms = []
    for i in range(len(store)):
        n = store.maps(i).normal.astype(np.float64)                  # (H, W, 3)
        xy = (-n[..., :2] / np.maximum(n[..., 2:], 1e-3)).transpose(2, 0, 1)[None]  # slopes (1, 2, H, W)
        for b, v in bands(xy).items():
            energy[b].append(float((v * v).mean()))
        rms.append(float(np.sqrt((xy * xy).sum(1).mean())))
    e = {b: np.array(v) for b, v in energy.items()}
    total = sum(e.values())
    relief = np.array(rms) > FLAT_RMS  # a flat map's shares are its quantisation noise's
    return {"materials": len(store), "flat_materials": int((~relief).sum()),
            "rms_slope_median": round(float(np.median(rms)), 4),
            "pooled_share": {b: round(float(v.sum() / total.sum()), 4) for b, v in e.items()},
            "median_share": {b: round(float(np.median(v[relief] / total[relief])), 4) for b, v in e.items()}}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("stores", nargs="+", metavar="NAME=STORE")
    ap.add_argument("--out", required=True)
    a = ap.parse_args(argv)
    res = {"bands_px": "coarse: blur σ 8; middle: σ 2-8; fine: below σ 2 (relief_signal.bands)", "stores": {}}
    for item in a.stores:
        name, _, path = item.partition("=")
        res["stores"][name] = shares(path)
        print(name, json.dumps(res["stores"][name]), flush=True)
    res["command"] = "python3 experiments/real_shape/coarse_share.py " + " ".join(sys.argv[1:] if argv is None else argv)
    Path(a.out).write_text(json.dumps(res, indent=1) + "\n")


if __name__ == "__main__":
    main()
