"""What specular does a renders store teach? The ground truth's specular statistics per SVBRDF (#39, round 9).

For every SVBRDF of a renders store (its maps at every ``--stride``-th pixel): the correlation of specular with
diffuse luminance and the specular chroma (``train.spec_stats``, the statistics `svtrain eval` reports for the
predicted maps), and the CV of specular luminance; summarised over the store (median, mean, the share of SVBRDFs
with a correlation beyond +-0.3) and per material class (the preset's class; blends under their first preset's
class with "+blend").

Usage: python3 experiments/real_shape/spec_truth.py STORE [STORE ...] [--stride 4] [--out results/spec_truth.json]
"""
from __future__ import annotations

import argparse
import collections
import json
from pathlib import Path

import numpy as np
import torch
import zarr

from storage.svbrdf_store import decode_maps
from train.spec_stats import LUMA, chroma, correlation

MAPS = ("normal", "diffuse", "specular", "roughness")


def chw(a: np.ndarray) -> torch.Tensor:
    return torch.from_numpy(np.ascontiguousarray(a.transpose(2, 0, 1)))[None]


def rows_of(store: str, stride: int) -> list[dict]:
    g = zarr.open_group(store, mode="r")
    names = g["preset_name"][:]
    rows = []
    for lo in range(0, names.shape[0], 64):
        hi = min(names.shape[0], lo + 64)
        block = {k: g[k][lo:hi, ::stride, ::stride] for k in MAPS}
        for b in range(hi - lo):
            m = decode_maps({k: v[b] for k, v in block.items()})
            y = m.specular.astype(np.float64) @ np.asarray(LUMA)
            rows.append({"class": names[lo + b][0].split("/")[0] + ("+blend" if names[lo + b][1] else ""),
                         "corr": float(correlation(chw(m.specular), chw(m.diffuse))[0]),
                         "chroma": float(chroma(chw(m.specular))[0]), "cv": float(y.std() / y.mean())})
    return rows


def summary(rows: list[dict]) -> dict:
    c = np.array([r["corr"] for r in rows])
    return {"svbrdfs": len(rows), "corr_median": round(float(np.median(c)), 3), "corr_mean": round(float(c.mean()), 3),
            "share_corr_above_0.3": round(float((c > 0.3).mean()), 3),
            "share_corr_below_-0.3": round(float((c < -0.3).mean()), 3),
            "chroma_mean": round(float(np.mean([r["chroma"] for r in rows])), 4),
            "cv_mean": round(float(np.mean([r["cv"] for r in rows])), 4)}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("stores", nargs="+")
    ap.add_argument("--stride", type=int, default=4, help="every stride-th pixel of the maps")
    ap.add_argument("--out", default=None, help="results JSON, one key per store (its folder's name)")
    a = ap.parse_args(argv)
    res = {}
    for store in a.stores:
        rows = rows_of(store, a.stride)
        by = collections.defaultdict(list)
        for r in rows:
            by[r["class"]].append(r)
        res[Path(store).parent.name] = {"all": summary(rows), "by_class": {k: summary(v) for k, v in sorted(by.items())}}
        print(Path(store).parent.name, res[Path(store).parent.name]["all"])
    if a.out:
        Path(a.out).write_text(json.dumps({"stride": a.stride, **res}, indent=1) + "\n")


if __name__ == "__main__":
    main()
