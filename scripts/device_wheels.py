"""Prepare .device/ for the prepared GPU run (docs/GPU.md): the wheels the bare GPU machine lacks, slimmed, and a
small real-material reference store; then the size of everything that travels against the 64 MiB limit.

    python3 scripts/device_wheels.py [--reference-from ../shared/materials-cc0] [--reference-count 6]

The GPU machine has Python 3.12 with torch, numpy, scipy, click, xarray, fsspec, pillow, matplotlib, tqdm, pyyaml,
psutil, jinja2, msgpack, toolz, cloudpickle, sortedcontainers, huggingface-hub, pyarrow and tifffile, and cannot
download. :data:`PACKAGES` are the rest of what ``svgen render``, ``svtrain fit`` and ``svtrain eval`` import, at
the versions installed here (the tested ones): each is fetched with ``pip download --no-deps --only-binary=:all:
--python-version 3.12`` for manylinux x86-64 into .device/download/ (kept between runs), slimmed by
scripts/slim_wheel.py into .device/wheels/ (mitsuba to llvm_ad_rgb + cuda_ad_rgb), and the total printed: the
working tree (tracked and untracked files that git does not ignore) plus .device/wheels and .device/reference must
stay under 64 MiB, or the device call is refused. Exit 1 when it does not.
"""
from __future__ import annotations

import argparse
import importlib.metadata as md
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))
sys.path.insert(0, str(ROOT))

import slim_wheel  # noqa: E402

#: what svgen's render/fit/eval import that the GPU machine's image lacks (docs/GPU.md lists what it has)
PACKAGES = ("mitsuba", "drjit", "zarr", "numcodecs", "google-crc32c", "donfig", "dask", "distributed", "partd",
            "locket", "tblib", "zict", "tornado", "pydantic", "pydantic-core", "annotated-types",
            "typing-inspection", "typing-extensions", "openexr", "pypng")
#: pip download's target: CPython 3.12 on manylinux x86-64 (pip matches each manylinux tag exactly)
PLATFORMS = ("manylinux_2_28_x86_64", "manylinux_2_27_x86_64", "manylinux_2_17_x86_64", "manylinux2014_x86_64",
             "manylinux1_x86_64", "manylinux_2_5_x86_64")
LIMIT = 64 * 2 ** 20


def download(dest: Path) -> list[Path]:
    """Each of :data:`PACKAGES` at its installed version, as a cp312 manylinux wheel in ``dest`` (kept)."""
    dest.mkdir(parents=True, exist_ok=True)
    wanted = [f"{p}=={md.version(p)}" for p in PACKAGES]
    cmd = [sys.executable, "-m", "pip", "download", "-q", "--no-deps", "--only-binary=:all:", "--python-version",
           "3.12", "--implementation", "cp", *[x for p in PLATFORMS for x in ("--platform", p)], "-d", str(dest),
           *wanted]
    subprocess.run(cmd, check=True)
    got = sorted(dest.glob("*.whl"))
    names = {_dist(w) for w in got}
    missing = [p for p in PACKAGES if _norm(p) not in names]
    if missing:
        raise SystemExit(f"pip downloaded no wheel for {missing}")
    return [w for w in got if _dist(w) in {_norm(p) for p in PACKAGES}]


def _norm(name: str) -> str:
    return name.lower().replace("-", "_")


def _dist(wheel: Path) -> str:
    return _norm(wheel.name.split("-")[0])


def slim_all(wheels: list[Path], dest: Path) -> list[Path]:
    """Slimmed copies in ``dest`` (a wheel slimmed before is kept; others there are removed)."""
    dest.mkdir(parents=True, exist_ok=True)
    for old in dest.glob("*.whl"):
        if old.name not in {w.name for w in wheels}:
            old.unlink()
    out = []
    for w in wheels:
        target = dest / w.name
        if not target.exists() or target.stat().st_mtime < w.stat().st_mtime:
            slim_wheel.slim(w, dest)
        out.append(target)
    return out


def reference(src: Path, count: int, dest: Path) -> Path:
    """An imported materials store of ``count`` materials of ``src`` (evenly spaced in name order) at 256^2."""
    store = dest / "materials.zarr"
    if store.exists():
        return store
    folders = sorted(p for p in src.iterdir() if p.is_dir())
    if not folders:
        raise SystemExit(f"no material folders in {src}")
    step = max(1, len(folders) // count)
    chosen = folders[::step][:count]
    cmd = [sys.executable, "-c", "import sys; from pipeline.cli import main; sys.argv[0] = 'svgen'; main()",
           "import", *map(str, chosen), str(store), "--size", "256", "--workers", "1"]
    subprocess.run(cmd, check=True, cwd=ROOT)
    return store


def llvm_views(path: Path, count: int = 2, size: int = 256, views: int = 10, res: int = 256) -> Path:
    """The llvm_ad_rgb views of the first ``count`` SVBRDFs of device_run.py's store (its defaults: the first preset
    of all, ``size``, ``views``, ``res``), rendered here, for the comparison where the GPU machine has no libLLVM."""
    import tempfile

    import materials
    from device_run import write_llvm_views
    from pipeline.config import RenderConfig, SampleConfig
    from pipeline.render.stage import run_render
    from pipeline.sample import run_sample
    from svcore.config import build

    if path.exists():
        return path
    with tempfile.TemporaryDirectory() as d:
        first = materials.presets()[0].name  # a variant's seed is of its preset and index alone
        run_sample(Path(d, "v.zarr"), build(SampleConfig, presets=(first,), per_preset=count, size=size), workers=0)
        run_render(Path(d, "v.zarr"), Path(d, "r.zarr"), build(RenderConfig, views=views, res=res), workers=0)
        return write_llvm_views(Path(d, "r.zarr"), count, path)


def tree_bytes() -> int:
    """Bytes of what a device call sends besides the carried paths: tracked and untracked-not-ignored files."""
    r = subprocess.run(["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"], cwd=ROOT,
                       capture_output=True, check=True)
    return sum((ROOT / f).stat().st_size for f in r.stdout.decode().split("\0") if f and (ROOT / f).is_file())


def du(path: Path) -> int:
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file()) if path.exists() else 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dest", default=str(ROOT / ".device"), help="the carried folder (git-ignored)")
    ap.add_argument("--reference-from", default=None, help="a folder of material folders (../shared/materials-cc0)")
    ap.add_argument("--reference-count", type=int, default=6, help="materials in the carried reference store")
    a = ap.parse_args(argv)
    dest = Path(a.dest)
    wheels = slim_all(download(dest / "download"), dest / "wheels")
    if a.reference_from:
        reference(Path(a.reference_from), a.reference_count, dest / "reference")
    llvm_views(dest / "reference" / "llvm_views.npz")
    for w in wheels:
        print(f"{w.stat().st_size:>12,}  {w.name}  (downloaded {(dest / 'download' / w.name).stat().st_size:,})")
    sizes = {"tree": tree_bytes(), "wheels": du(dest / "wheels"), "reference": du(dest / "reference")}
    total = sum(sizes.values())
    for k, v in sizes.items():
        print(f"{v:>12,}  {k}")
    print(f"{total:>12,}  total ({total / 2 ** 20:.1f} MiB of {LIMIT / 2 ** 20:.0f} MiB)")
    if total >= LIMIT:
        print("over the device call's limit: carry less", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
