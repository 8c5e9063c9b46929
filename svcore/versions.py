"""What a result records about the code that made it: library versions and the svgen version."""
from __future__ import annotations

import subprocess
from functools import lru_cache
from pathlib import Path

#: the libraries whose versions shape the bytes of stores and trained models.
LIBRARIES = ("svgen", "numpy", "scipy", "zarr", "dask", "mitsuba", "drjit", "colour-science", "torch", "pydantic")


def library_versions() -> dict[str, str]:
    """Installed versions of :data:`LIBRARIES` (those not installed are left out), plus ``svgen_source``: the
    git describe of the source tree when it is a checkout (see :func:`svcore.cli.version`)."""
    import importlib.metadata as md

    from .cli import version

    out = {}
    for pkg in LIBRARIES:
        try:
            out[pkg] = md.version(pkg)
        except md.PackageNotFoundError:
            pass
    out["svgen_source"] = version()
    return out


@lru_cache(maxsize=1)
def code_version() -> str:
    """The version of this code: ``git describe --tags --always --dirty`` of the source tree when it is a git
    checkout (``v0.2.0-3-gabc1234-dirty``: three commits after the tag, with uncommitted changes), else the
    installed package's version, which setuptools-scm derived from the same tags at build time
    (``0.2.1.dev3+gabc1234``; ``0.1.0.dev0`` when built without git metadata); ``unknown`` when neither exists."""
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
