"""What a result records about the code that made it: library versions and the svgen version."""
from __future__ import annotations

import subprocess
from functools import lru_cache
from pathlib import Path

#: the libraries whose versions shape the bytes of stores and trained models.
LIBRARIES = ("svgen", "numpy", "scipy", "zarr", "dask", "mitsuba", "drjit", "colour-science", "torch", "pydantic")


@lru_cache(maxsize=1)
def svgen_version() -> str:
    """The version of the svgen code that runs: ``git describe --tags --always --dirty`` of its source tree when
    that is a git checkout (a tag, commits since it, the commit, ``-dirty`` for uncommitted changes), else the
    installed package's version (setuptools-scm derives it from the same tags at build time: ``0.2.1.dev3+gabc1234``;
    ``0.1.0.dev0`` when built without git metadata), else ``"unknown"``."""
    root = Path(__file__).resolve().parents[1]
    if (root / ".git").exists():
        try:
            r = subprocess.run(["git", "describe", "--tags", "--always", "--dirty"], cwd=root, capture_output=True,
                               text=True, timeout=5)
            if r.returncode == 0 and r.stdout.strip():
                return r.stdout.strip()
        except (OSError, subprocess.SubprocessError):
            pass
    import importlib.metadata as md

    try:
        return md.version("svgen")
    except md.PackageNotFoundError:
        return "unknown"


def library_versions() -> dict[str, str]:
    """Installed versions of :data:`LIBRARIES` (those not installed are left out), with ``svgen`` the version of
    the running code (:func:`svgen_version`: git describe in a checkout, not the package's fixed number) and
    ``svgen_package`` the installed package's version."""
    import importlib.metadata as md

    out = {}
    for pkg in LIBRARIES:
        try:
            out[pkg] = md.version(pkg)
        except md.PackageNotFoundError:
            pass
    if "svgen" in out:
        out["svgen_package"] = out["svgen"]
    out["svgen"] = svgen_version()
    return out
