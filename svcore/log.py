"""One logger per package: ``get_logger(__name__)`` resolves to ``svgen.<package>``."""
from __future__ import annotations

import logging

_CONFIGURED = False


def get_logger(name: str) -> logging.Logger:
    """Return the package logger for a module name (``pipeline.render`` -> ``svgen.pipeline``)."""
    return logging.getLogger("svgen." + name.split(".")[0])


def configure(verbose: bool = False) -> None:
    """Configure console logging once (CLI entry points call this)."""
    global _CONFIGURED
    if _CONFIGURED:
        return
    logging.basicConfig(level=logging.DEBUG if verbose else logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    # dask.distributed narrates every connection at INFO: keep its warnings, drop the chatter
    for name in ("distributed", "tornado", "bokeh"):
        logging.getLogger(name).setLevel(logging.DEBUG if verbose else logging.WARNING)
    _CONFIGURED = True
