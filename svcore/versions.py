"""What a result records about the code that made it: library versions and the svgen version.

The svgen version is the installed package's version (its metadata) beside a digest of the source that runs
(:func:`code_digest`), not ``git describe``: a checkout where only ``dvc.lock`` or ``params.yaml`` changed (what
``dvc exp run -S`` does) is not "-dirty" code, and an edited source file is told apart from the package's release
by its digest. ``git describe`` stays a detail of ``--version`` (:func:`git_description`).

A store records neither: its bytes must not change with the commit or the install, so it names its code by
:func:`closure_digest`, the digest of the source its stage can run (:mod:`svcore.codegraph`), which is also exactly
what the stage's DVC deps cover (tests/test_dvc_hygiene.py): code outside it (training, the gallery) changes no byte
of a store, and a change inside it reruns the stage.
"""
from __future__ import annotations

import hashlib
import subprocess
from functools import lru_cache
from pathlib import Path

#: the libraries whose versions shape the bytes of stores and trained models.
LIBRARIES = ("svgen", "numpy", "scipy", "zarr", "dask", "mitsuba", "drjit", "colour-science", "torch", "pydantic")

#: the packages whose source decides a result (stores and trained models); their digest names the code.
CODE_PACKAGES = ("svcore", "pipeline", "materials", "train")
#: hex digits of the code digest shown in a version string (48 bits: enough to tell two trees apart by eye)
SHORT_DIGEST = 12


def code_digest() -> str:
    """sha256 (hex) of the source of :data:`CODE_PACKAGES`: each ``*.py`` file's path and bytes, in path order."""
    root = Path(__file__).resolve().parents[1]
    return _files_digest(root, [f for pkg in CODE_PACKAGES for f in sorted((root / pkg).rglob("*.py"))])


@lru_cache(maxsize=None)
def closure_digest(module: str) -> str:
    """sha256 (hex) of the source that project module ``module`` can run: the files of its import closure
    (:func:`svcore.codegraph.closure`), hashed as :func:`code_digest` hashes its files."""
    from .codegraph import ROOT, closure

    return _files_digest(ROOT, sorted(closure({module: None})))


def _files_digest(root: Path, files) -> str:
    """sha256 (hex) of each file's path (relative to ``root``) and bytes, in the order given."""
    h = hashlib.sha256()
    for f in files:
        h.update(str(f.relative_to(root)).encode() + b"\0" + f.read_bytes() + b"\0")
    return h.hexdigest()


def package_version() -> str:
    """The installed svgen package's version (setuptools-scm derives it from the git tags at install time:
    ``0.2.1.dev3+gabc1234``), else ``"unknown"``."""
    import importlib.metadata as md

    try:
        return md.version("svgen")
    except md.PackageNotFoundError:
        return "unknown"


@lru_cache(maxsize=1)
def svgen_version() -> str:
    """The version of the svgen code that runs: ``"PACKAGE (code DIGEST)"``, the package version and the first
    :data:`SHORT_DIGEST` hex digits of :func:`code_digest` (e.g. ``0.1.0.dev284+g5dbbc3b77 (code 3f2a9c1d7e4b)``)."""
    return f"{package_version()} (code {code_digest()[:SHORT_DIGEST]})"


@lru_cache(maxsize=1)
def git_description() -> str | None:
    """``git describe --tags --always --dirty`` of the source tree when it is a git checkout, else None (detail of
    ``--version`` only: "-dirty" also counts edits to data files such as dvc.lock)."""
    root = Path(__file__).resolve().parents[1]
    if not (root / ".git").exists():
        return None
    try:
        r = subprocess.run(["git", "describe", "--tags", "--always", "--dirty"], cwd=root, capture_output=True,
                           text=True, timeout=5)
    except (OSError, subprocess.SubprocessError):
        return None
    return r.stdout.strip() or None if r.returncode == 0 else None


def library_versions() -> dict[str, str]:
    """Installed versions of :data:`LIBRARIES` (those not installed are left out), with ``svgen`` the version of
    the running code (:func:`svgen_version`: package version and code digest), ``svgen_package`` the package's
    version alone and ``svgen_code`` the full :func:`code_digest`."""
    return {**_installed(svgen_version()), "svgen_package": package_version(), "svgen_code": code_digest()}


def store_versions(module: str) -> dict[str, str]:
    """What a store records of the code that wrote it: the installed versions of :data:`LIBRARIES` but svgen's
    (whose package version names the commit), ``svgen`` as ``"code DIGEST"`` (the first :data:`SHORT_DIGEST` hex
    digits of :func:`closure_digest` of ``module``, the stage's own module), ``svgen_code`` the full digest and
    ``svgen_code_of`` the module it covers."""
    digest = closure_digest(module)
    return {**_installed(f"code {digest[:SHORT_DIGEST]}"), "svgen_code": digest, "svgen_code_of": module}


def _installed(svgen: str) -> dict[str, str]:
    """Installed versions of :data:`LIBRARIES` in their order, with ``svgen`` as given."""
    import importlib.metadata as md

    out = {}
    for pkg in LIBRARIES:
        try:
            out[pkg] = svgen if pkg == "svgen" else md.version(pkg)
        except md.PackageNotFoundError:
            pass
    return out
