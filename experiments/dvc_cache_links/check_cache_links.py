"""How much disk does `dvc repro` take beside the outputs, and may DVC link its cache instead of copying (#42)?

DVC's default cache type is "reflink,copy": on a filesystem without reflinks (ext4, this machine) every output is
stored twice, once in the workspace and once in .dvc/cache. With ``cache.type hardlink,symlink`` an output and its
cache entry share one inode, which is safe only if nothing writes into a finished output in place: svgen writes
stores under ``OUT.partial`` and renames them, and the fit's persisted checkpoint is replaced with ``os.replace``.

For each cache type (the default, and hardlink,symlink), on a clone of this repository's HEAD with tiny
params: `dvc repro` (in process, SVGEN_WORKERS=0), then a second fit over the persisted checkpoint (`dvc repro fit`
after raising train.optim.iterations: a changed config, so the fit starts again and replaces the checkpoint that DVC
left in place, linked to the cache in the second case), then the bytes of the outputs and of the cache (counting
each inode once), how many output files share their inode with the cache, and whether every cache file's MD5 is
still its name (a write through a link would break it).

Usage: python3 experiments/dvc_cache_links/check_cache_links.py [--out experiments/dvc_cache_links/results/links.json]
"""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import yaml

from svcore.config import merge

ROOT = Path(__file__).resolve().parents[2]
#: tiny params (tests/dvc_project.py's TINY, fewer keys): the DVC mechanics, not the data, are measured here
TINY = {
    "sample": {"per_preset": 1, "size": 64, "chunk": 8, "classes": ["fabric", "metal", "stone", "wood"]},
    "blend": {"count": 8, "chunk": 8},
    "render": {"views": 2, "res": 64, "chunk": 2},
    "train": {"model": {"base_width": 4, "max_width": 8, "levels": 3}, "data": {"crop": 32, "workers": 0},
              "optim": {"iterations": 4, "batch_size": 2, "checkpoint_every": 2, "compile_loss": False}},
    "eval": {"limit": 8, "extra_stores": []},
    "stress": {"per_category": 1, "size": 64},
    "import": {"sources": []},
    "reference": {"sources": []},
}
OUTS = ("data", "runs")
ENV = {**os.environ, "SVGEN_NO_PROGRESS": "1", "SVGEN_WORKERS": "0", "PYTHONPATH": str(ROOT),
       "GIT_AUTHOR_NAME": "t", "GIT_AUTHOR_EMAIL": "t@t", "GIT_COMMITTER_NAME": "t", "GIT_COMMITTER_EMAIL": "t@t"}


def sh(cmd, cwd: Path) -> str:
    r = subprocess.run(cmd, cwd=cwd, env=ENV, capture_output=True, text=True, shell=isinstance(cmd, str))
    if r.returncode:
        sys.exit(f"{cmd} failed ({r.returncode}): {(r.stderr or r.stdout)[-2000:]}")
    return r.stdout


def project(d: Path) -> Path:
    """A clone of this repository's HEAD in ``d`` with :data:`TINY` merged into params.yaml and no dvc.lock."""
    sh(["git", "clone", "-q", str(ROOT), str(d)], ROOT)
    params = yaml.safe_load((d / "params.yaml").read_text())
    merge(params, TINY)
    (d / "params.yaml").write_text(yaml.safe_dump(params, sort_keys=False))
    (d / "dvc.lock").unlink()
    sh("git commit -qam 'tiny params, no lock'", d)
    return d


def files(root: Path) -> list[Path]:
    return [p for p in root.rglob("*") if p.is_file() and not p.is_symlink()]


def measure(d: Path) -> dict:
    """Bytes of the outputs and of the cache (each inode once), outputs sharing an inode with the cache, and the
    cache files whose MD5 is not their name."""
    cache = files(d / ".dvc" / "cache" / "files")
    cache_inodes = {p.stat().st_ino for p in cache}
    outs = [p for o in OUTS for p in files(d / o)]
    links = [p for o in OUTS for p in (d / o).rglob("*") if p.is_symlink()]
    seen: set[int] = set()
    total = 0
    for p in outs + cache:
        st = p.stat()
        if st.st_ino not in seen:
            seen.add(st.st_ino)
            total += st.st_size
    bad = [str(p.relative_to(d)) for p in cache
           if hashlib.md5(p.read_bytes()).hexdigest() != p.parent.name + p.name.removesuffix(".dir")]
    return {"output_files": len(outs), "output_symlinks": len(links),
            "output_bytes": sum(p.stat().st_size for p in outs),
            "outputs_sharing_an_inode_with_the_cache": sum(p.stat().st_ino in cache_inodes for p in outs),
            "cache_files": len(cache), "cache_bytes": sum(p.stat().st_size for p in cache),
            "disk_bytes_each_inode_once": total, "cache_files_not_matching_their_md5": bad}


def run(cache_type: str | None, d: Path) -> dict:
    d = project(d)
    if cache_type:
        sh(["dvc", "config", "cache.type", cache_type], d)
    sh(["dvc", "repro"], d)
    first = measure(d)
    params = yaml.safe_load((d / "params.yaml").read_text())
    params["train"]["optim"]["iterations"] = 8  # a changed config: a new fit over the persisted checkpoint
    (d / "params.yaml").write_text(yaml.safe_dump(params, sort_keys=False))
    ck = d / "runs" / "train" / "checkpoint.pt"
    linked_before = ck.stat().st_nlink
    sh(["dvc", "repro", "fit"], d)
    status = sh(["dvc", "status", "fit"], d)  # the stages after it are stale, as they should be
    return {"cache_type": cache_type or "default (reflink,copy)", "after_repro": first,
            "checkpoint_links_before_the_second_fit": linked_before, "after_second_fit": measure(d),
            "fit_stage_up_to_date": "up to date" in status}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(Path(__file__).parent / "results" / "links.json"))
    a = ap.parse_args()
    if shutil.which("dvc") is None:
        sys.exit("dvc is not installed: run scripts/setup.sh")
    tmp = Path(tempfile.mkdtemp(prefix="dvc-links-"))
    try:
        rows = [run(t, tmp / name) for t, name in ((None, "default"), ("hardlink,symlink", "hardlink"))]
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    fs = subprocess.run(["df", "-T", str(ROOT)], capture_output=True, text=True).stdout.split("\n")[1].split()[1]
    res = {"experiment": "dvc_cache_links", "filesystem": fs, "commit": sh(["git", "rev-parse", "HEAD"], ROOT).strip(),
           "rows": rows, "command": "python3 " + " ".join([os.path.relpath(__file__, ROOT), *sys.argv[1:]])}
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps(res, indent=1) + "\n")
    for r in rows:
        x = r["after_second_fit"]
        print(f"{r['cache_type']:24s} outputs {x['output_bytes'] / 1e6:7.1f} MB, cache {x['cache_bytes'] / 1e6:7.1f} MB, "
              f"on disk {x['disk_bytes_each_inode_once'] / 1e6:7.1f} MB; shared inodes "
              f"{x['outputs_sharing_an_inode_with_the_cache']}/{x['output_files']}; bad cache files "
              f"{len(x['cache_files_not_matching_their_md5'])}; checkpoint links before the 2nd fit "
              f"{r['checkpoint_links_before_the_second_fit']}; fit up to date {r['fit_stage_up_to_date']}")
    print(f"wrote {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
