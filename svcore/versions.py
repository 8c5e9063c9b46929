"""What a result records about the code that made it: library versions and the svgen version."""
from __future__ import annotations

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
