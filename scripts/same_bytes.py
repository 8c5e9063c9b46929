"""Hash the bytes of a tiny end-to-end run (sample, blend, stress, render, fit) to prove a refactor changes none.

Runs the real command lines (``svgen``/``svtrain`` of the importable tree) into a temporary directory and
writes ``{store: {array: sha256}, "fit": {tensor: sha256}, ...}`` as JSON: the four stores, two tiny fits (on
the renders store and on the synthetic source) and the synthetic source itself. Only flags that mean the
same before and after the #13 restructuring are used (no config-preset flag), so the same script runs on both
sides. Attributes are left out on purpose: they may gain fields; the arrays and the state dict must not change.

Usage: python3 scripts/same_bytes.py OUT.json [--check REFERENCE.json]
"""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

SVGEN = [sys.executable, "-c", "import sys; from pipeline.cli import main; sys.argv[0] = 'svgen'; main()"]
SVTRAIN = [sys.executable, "-c", "import sys; from train.cli import main; sys.argv[0] = 'svtrain'; main()"]

#: four presets of different classes, 2 variants each (the held-out split is by material: it needs several).
PRESETS = ("plastic/glossy_blue", "paint/matte_wall", "metal/brushed_steel", "leather/tan_worn")


def _run(cmd: list[str]) -> None:
    env = {**os.environ, "SVGEN_NO_PROGRESS": "1"}
    r = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if r.returncode != 0:
        raise SystemExit(f"{' '.join(cmd[3:])} failed ({r.returncode}): {r.stderr.strip()}")


def store_hashes(path: Path) -> dict[str, str]:
    """sha256 of every array's bytes (C order, on-disk dtype) plus its shape and dtype."""
    import zarr

    g = zarr.open_group(path, mode="r")
    out = {}
    for name, arr in sorted(g.arrays()):
        a = arr[:]
        # string arrays (preset and category names) by their values: an object or variable-width string array's
        # buffer holds pointers, which differ from run to run
        raw = "\n".join(map(str, a.ravel().tolist())).encode() if a.dtype.kind in "OTU" else a.tobytes()
        out[name] = f"{a.dtype}{list(a.shape)}:" + hashlib.sha256(raw).hexdigest()
    return out


def state_hashes(path: Path) -> dict[str, str]:
    """sha256 of every tensor of a saved model's state dict."""
    import torch

    state = torch.load(path, map_location="cpu", weights_only=True)["model"]
    return {k: hashlib.sha256(v.detach().contiguous().numpy().tobytes()).hexdigest() for k, v in sorted(state.items())}


def run(tmp: Path) -> dict:
    v, b, s, r = tmp / "v.zarr", tmp / "b.zarr", tmp / "s.zarr", tmp / "r.zarr"
    sel = [a for p in PRESETS for a in ("--preset", p)]
    _run([*SVGEN, "sample", str(v), "--per-preset", "2", "--size", "64", "--chunk", "2", "--seed", "3",
          "--workers", "0", *sel])
    _run([*SVGEN, "blend", str(v), str(b), "--count", "3", "--chunk", "2", "--seed", "5", "--workers", "0"])
    _run([*SVGEN, "stress", str(s), "--per-category", "1", "--size", "64", "--seed", "7", "--category",
          "highlight_edge", "--category", "print_pattern", "--workers", "0"])
    _run([*SVGEN, "render", str(v), str(b), str(s), str(r), "--views", "2", "--res", "32", "--chunk", "2",
          "--seed", "11", "--workers", "0"])
    _run([*SVTRAIN, "fit", "--store", str(r), "--out", str(tmp / "run"), "--iterations", "4", "--batch-size", "2",
          "--seed", "13", "--workers", "0", "--no-compile", "--set", "model.levels=3", "--set", "data.crop=16",
          "--set", "data.holdout=0.3"])
    _run([*SVTRAIN, "fit", "--out", str(tmp / "run_synthetic"), "--iterations", "3", "--batch-size", "2",
          "--seed", "19", "--workers", "0", "--no-compile", "--set", "model.levels=3", "--set", "data.crop=16",
          "--set", "data.synthetic_samples=8", "--set", "data.synthetic_size=24", "--set",
          "data.synthetic_materials=4", "--set", "data.holdout=0.5"])
    return {"variants": store_hashes(v), "blends": store_hashes(b), "stress": store_hashes(s),
            "renders": store_hashes(r), "fit": state_hashes(tmp / "run" / "model.pt"),
            "fit_synthetic": state_hashes(tmp / "run_synthetic" / "model.pt"),
            **{f"synthetic_{kind}": synthetic_hashes(kind) for kind in ("simple", "presets")}}


def synthetic_hashes(kind: str) -> dict[str, str]:
    """sha256 of the in-memory synthetic training source (its seed streams are not in any store)."""
    import numpy as np

    from train.synthetic import SyntheticSource

    src = SyntheticSource(4, 64 if kind == "presets" else 32, 2, seed=17, kind=kind)  # presets: 64 at least
    arrays = {"image": np.stack([src.image(i) for i in range(len(src))]),
              "maps": np.stack([src.packed(i) for i in range(len(src))]), "light": np.asarray(src.light)}
    return {k: f"{a.dtype}{list(a.shape)}:" + hashlib.sha256(np.ascontiguousarray(a).tobytes()).hexdigest()
            for k, a in arrays.items()}


def diff(a: dict, b: dict) -> list[str]:
    """Keys whose hashes differ (or exist on one side only)."""
    out = []
    for k in sorted(set(a) | set(b)):
        for name in sorted(set(a.get(k, {})) | set(b.get(k, {}))):
            if a.get(k, {}).get(name) != b.get(k, {}).get(name):
                out.append(f"{k}/{name}")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", help="JSON file to write the hashes to")
    ap.add_argument("--check", help="reference JSON: exit 1 naming every array that differs")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        hashes = run(Path(tmp))
    Path(a.out).write_text(json.dumps(hashes, indent=1, sort_keys=True) + "\n")
    if a.check:
        bad = diff(json.loads(Path(a.check).read_text()), hashes)
        if bad:
            raise SystemExit(f"{len(bad)} arrays differ: {', '.join(bad)}")
        print(f"identical: {sum(map(len, hashes.values()))} arrays/tensors")


if __name__ == "__main__":
    main()
