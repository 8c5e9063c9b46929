"""Find a libLLVM >= 16 for drjit before drjit is imported.

drjit 1.5's LLVM backend crashes on LLVM 15 ("Cannot select ... fmaximum"), and
Debian 12 ships 14/15 by default. This module is the one place that locates a
usable library and exports ``DRJIT_LIBLLVM_PATH``; every module that imports
drjit or mitsuba calls :func:`ensure_llvm` first (``svcore.mi_env`` does).
"""
from __future__ import annotations

import glob
import os
import re

from svcore.errors import SvgenError

MIN_LLVM = 16
INSTALL_HINT = (
    "drjit needs libLLVM >= 16 and none was found. Install it with "
    "`apt-get install libllvm19` (Debian 12) or point DRJIT_LIBLLVM_PATH at a libLLVM.so of version >= 16."
)

_SEARCH = [
    "/usr/lib/llvm-*/lib/libLLVM*.so*",
    "/usr/lib/x86_64-linux-gnu/libLLVM*.so*",
    "/usr/lib/aarch64-linux-gnu/libLLVM*.so*",
    "/usr/local/lib/libLLVM*.so*",
    "/opt/homebrew/opt/llvm/lib/libLLVM.dylib",
]


class LLVMNotFound(SvgenError, RuntimeError):
    """Raised when no libLLVM >= 16 can be located."""


def _version(path: str) -> int | None:
    m = re.search(r"llvm-(\d+)", path) or re.search(r"libLLVM[-.](?:so\.)?(\d+)", os.path.basename(path))
    return int(m.group(1)) if m else None


def find_llvm() -> str | None:
    """Return the path of the newest libLLVM >= 16 on this machine, or None."""
    env = os.environ.get("DRJIT_LIBLLVM_PATH")
    if env and os.path.exists(env):
        return env
    best: tuple[int, str] | None = None
    for pattern in _SEARCH:
        for path in glob.glob(pattern):
            if path.endswith(".a") or not os.path.isfile(path):
                continue
            v = _version(path)
            if v is not None and v >= MIN_LLVM and (best is None or v > best[0]):
                best = (v, path)
    return best[1] if best else None


def ensure_llvm() -> str:
    """Export DRJIT_LIBLLVM_PATH for drjit, or raise :class:`LLVMNotFound` with install advice.

    Returns:
        The library path in use.
    """
    path = find_llvm()
    if path is None:
        raise LLVMNotFound(INSTALL_HINT)
    os.environ["DRJIT_LIBLLVM_PATH"] = path
    return path
