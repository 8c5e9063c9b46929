"""Are two zarr stores the same bytes? Compares the SHA-256 of every chunk file (``*/c/...``) of each pair, as the
round 6 report checks the default pipeline's stores against the retrain's (``runs/rsf``).

    python3 experiments/real_shape/same_store.py data/variants.zarr runs/rsf/variants.zarr \\
        data/blends.zarr runs/rsf/blends.zarr data/renders.zarr runs/rsf/renders.zarr
"""
from __future__ import annotations

import hashlib
import sys
from pathlib import Path


def chunks(root: Path) -> dict[str, str]:
    return {str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(root.rglob("*")) if p.is_file() and "c" in p.relative_to(root).parts}


def main(argv: list[str]) -> int:
    if len(argv) % 2 or not argv:
        raise SystemExit("give pairs of stores: A1 B1 [A2 B2 ...]")
    differ = 0
    for a, b in zip(argv[::2], argv[1::2]):
        x, y = chunks(Path(a)), chunks(Path(b))
        bad = sorted(k for k in x.keys() | y.keys() if x.get(k) != y.get(k))
        differ += len(bad)
        print(f"{a} vs {b}: {len(x)} and {len(y)} chunk files, {len(bad)} differ {bad[:5]}")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
