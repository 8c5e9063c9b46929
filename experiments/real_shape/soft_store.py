"""Round 12 of issue #39: the default store with its diffuse texture at half its contrast (the ``soft`` data arm).

Round 11 (``relief_visibility.py``) found that the diffuse texture moves svgen's flash photos by 17-20 sRGB codes and
the real reference's by 5-7, while relief moves both by about 2: the relief a network must read sits under 2.5-3x
more texture in svgen's views than in real ones. This makes the store that tests it. Every SVBRDF's diffuse map keeps
its mean per channel and half its deviation from it (``d' = m + k (d - m)``, ``k`` = 0.5: about the real texture's
codes); every other map, every view and every seed stays as it was, so the arm differs from the control's store in
the diffuse alone and trains on the same materials, split and views.

The variants and blends stores of ``svgen sample`` / ``svgen blend --params params.yaml`` are copied with their
diffuse shards re-encoded (:func:`storage.local.encode_shard`, the stages' own encoder) and their manifest records
updated, then rendered with ``svgen render --params params.yaml``. A pipeline option would have changed the
pipeline's code (and every locked stage): this stays an experiment until it wins.

    python3 experiments/real_shape/soft_store.py --work runs/dc --control runs/rs/train/renders.zarr

Writes WORK/{variants,blends}.zarr (the stages'), WORK/{variants,blends}_soft.zarr, WORK/renders.zarr and
WORK/soft.json (what was changed, and the check that only the diffuse differs from the control's store);
the stages' output goes to WORK/build.log.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).parent))

from control import PARAMS, sh  # noqa: E402
from storage.local import MANIFEST, _atomic_write, _chunk_key, encode_shard, open_store, verify_store  # noqa: E402

#: arrays of the renders store that must equal the control's byte for byte (everything but the diffuse and the
#: images rendered from it)
SAME = ("normal", "roughness", "specular", "view", "source_seed", "preset")


def soften(codes: np.ndarray, k: float) -> np.ndarray:
    """Each SVBRDF's diffuse at ``k`` times its contrast about its own mean, per channel.

    Args:
        codes: (n, H, W, 3) uint16, linear * 65535 (the stores' diffuse encoding).
        k: the factor on each pixel's deviation from the map's mean.

    Returns:
        (n, H, W, 3) uint16 in the same encoding.
    """
    d = codes.astype(np.float64)
    m = d.mean(axis=(1, 2), keepdims=True)
    return np.clip(np.rint(m + k * (d - m)), 0, 65535).astype(np.uint16)


def soft_copy(src: Path, dst: Path, k: float) -> None:
    """Copy a complete variants or blends store with its diffuse softened; its manifest records the new shards."""
    if dst.exists():
        return
    tmp = dst.with_name(dst.name + ".tmp")
    shutil.rmtree(tmp, ignore_errors=True)
    shutil.copytree(src, tmp)
    g = open_store(tmp, ("variants", "blends"))
    arr = g["diffuse"]
    man = json.loads((tmp / MANIFEST).read_text())
    n, chunk = int(man["n"]), int(man["chunk"])
    for c in range(-(-n // chunk)):
        start, stop = c * chunk, min(n, (c + 1) * chunk)
        shard = encode_shard(arr, c, start, soften(arr[start:stop], k))
        if shard is None:
            raise SystemExit(f"{src}: the diffuse array's layout is not the stages' own; cannot re-encode it here")
        _atomic_write(tmp / "diffuse" / _chunk_key(arr, c), shard)
        man["arrays"]["diffuse"][c] = [len(shard), hashlib.sha256(shard).hexdigest()[:32]]
    (tmp / MANIFEST).write_text(json.dumps(man, sort_keys=True, separators=(",", ":")))
    verify_store(tmp)
    os.replace(tmp, dst)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--work", required=True, help="scratch folder for the stores")
    ap.add_argument("--control", required=True, help="the control's renders store (control.py's train store)")
    ap.add_argument("--k", type=float, default=0.5, help="factor on the diffuse's deviation from its mean")
    a = ap.parse_args(argv)
    work = Path(a.work).resolve()
    work.mkdir(parents=True, exist_ok=True)
    log = work / "build.log"  # the stages' output (control.sh)
    v, b = work / "variants.zarr", work / "blends.zarr"
    vs, bs, r = work / "variants_soft.zarr", work / "blends_soft.zarr", work / "renders.zarr"
    if not v.is_dir():
        sh(["svgen", "sample", str(v), "--params", PARAMS], log)
    if not b.is_dir():
        sh(["svgen", "blend", str(v), str(b), "--params", PARAMS], log)
    soft_copy(v, vs, a.k)
    soft_copy(b, bs, a.k)
    if not r.is_dir():
        sh(["svgen", "render", str(vs), str(bs), str(r), "--params", PARAMS], log)
    ctl, arm = open_store(a.control, "renders"), open_store(r, "renders")
    same = {name: bool(np.array_equal(ctl[name][:], arm[name][:])) for name in SAME}
    if not all(same.values()):
        raise SystemExit(f"{r} differs from {a.control} beyond the diffuse: {same}")
    dc, da = ctl["diffuse"][:].astype(np.float64), arm["diffuse"][:].astype(np.float64)
    # per SVBRDF and channel, the within-map spread (what was halved; the channels' means, the colour, were kept)
    ratio = float(np.median(da.std(axis=(1, 2)) / np.maximum(dc.std(axis=(1, 2)), 1)))
    mean_shift = float(np.abs(da.mean(axis=(1, 2)) - dc.mean(axis=(1, 2))).max() / 65535)
    rec = {"k": a.k, "what": "each SVBRDF's diffuse: its mean per channel plus k times its deviation from it",
           "equal_to_control": same, "diffuse_channel_std_over_control_median": round(ratio, 4),
           "diffuse_mean_shift_max": round(mean_shift, 5),
           "images_differing": float(np.mean(ctl["image"][:64] != arm["image"][:64]))}
    (work / "soft.json").write_text(json.dumps(rec, indent=1) + "\n")
    print(json.dumps(rec))


if __name__ == "__main__":
    main()
