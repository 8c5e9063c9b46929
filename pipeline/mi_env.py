"""Import Mitsuba 3 the one right way: libLLVM located first, an AD variant selected, never a scalar one.

A Python BSDF is traced into a kernel only in ``llvm_ad_*``/``cuda_ad_*``; in
``scalar_*`` it would run per ray in Python, unusable for data. So this module
refuses scalar variants outright.
"""
from __future__ import annotations

import os

from svcore.errors import SvgenError

from .llvm import ensure_llvm

DEFAULT_VARIANT = "llvm_ad_rgb"


class MitsubaUnavailable(SvgenError, RuntimeError):
    """Mitsuba/drjit cannot be used on this machine (with the reason and a fix)."""


def load_mitsuba(variant: str | None = None):
    """Return the ``mitsuba`` module with an AD variant set.

    Args:
        variant: "llvm_ad_rgb" (default, or ``SVGEN_MI_VARIANT``) or "cuda_ad_rgb".

    Raises:
        MitsubaUnavailable: no libLLVM >= 16, or a scalar/unknown variant was asked for.
    """
    variant = variant or os.environ.get("SVGEN_MI_VARIANT", DEFAULT_VARIANT)
    if not (variant.startswith("llvm_ad_") or variant.startswith("cuda_ad_")):
        raise MitsubaUnavailable(f"variant {variant!r} is not supported: svgen renders only in llvm_ad_* or cuda_ad_* "
                                 "(a Python BSDF runs per ray in Python in scalar variants)")
    if variant.startswith("llvm"):
        try:
            ensure_llvm()
        except RuntimeError as e:
            raise MitsubaUnavailable(str(e)) from None
    import mitsuba as mi

    if mi.variant() != variant:
        try:
            mi.set_variant(variant)
        except Exception as e:  # mitsuba raises ImportError/RuntimeError variants
            raise MitsubaUnavailable(f"cannot use Mitsuba variant {variant!r}: {e}") from None
    return mi


def __getattr__(name: str):
    """``from pipeline.mi_env import mi, dr``: the one place modules take mitsuba and drjit from.

    Resolved on first use (PEP 562), so importing this module costs nothing until a renderer needs them;
    drjit is imported only after :func:`load_mitsuba` has exported the libLLVM path.
    """
    if name == "mi":
        return load_mitsuba()
    if name == "dr":
        load_mitsuba()
        import drjit

        return drjit
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
