"""Import Mitsuba 3 the one right way: libLLVM located first, an AD variant selected, never a scalar one.

A Python BSDF is traced into a kernel only in ``llvm_ad_*``/``cuda_ad_*``; in
``scalar_*`` it would run per ray in Python, unusable for data. So this module
refuses scalar variants outright.

It lives in svcore (with :mod:`svcore.llvm`) because two packages need drjit: the renderer (``pipeline.render``)
and the renders store's reader (:mod:`storage.views`, whose transform the training loader's crops run). Importing
it loads nothing: mitsuba and drjit are loaded on first use (``mi``, ``dr``, :func:`load_mitsuba`).
"""
from __future__ import annotations

import os

from svcore.errors import SvgenError

from .llvm import ensure_llvm

DEFAULT_VARIANT = "llvm_ad_rgb"
#: the variants ``svgen render --variant`` offers (pipeline.config.MitsubaVariant; a test holds them equal)
VARIANTS = ("llvm_ad_rgb", "cuda_ad_rgb")
#: the environment variable that names the variant of a process (read when mitsuba is first loaded)
VARIANT_ENV = "SVGEN_MI_VARIANT"


class MitsubaUnavailable(SvgenError, RuntimeError):
    """Mitsuba/drjit cannot be used on this machine (with the reason and a fix)."""


def load_mitsuba(variant: str | None = None):
    """Return the ``mitsuba`` module with an AD variant set.

    Args:
        variant: "llvm_ad_rgb" (default, or ``SVGEN_MI_VARIANT``) or "cuda_ad_rgb".

    Raises:
        MitsubaUnavailable: no libLLVM >= 16, or a scalar/unknown variant was asked for.
    """
    variant = variant or os.environ.get(VARIANT_ENV, DEFAULT_VARIANT)
    if not (variant.startswith("llvm_ad_") or variant.startswith("cuda_ad_")):
        raise MitsubaUnavailable(f"variant {variant!r} is not supported: svgen renders only in llvm_ad_* or cuda_ad_* "
                                 "(a Python BSDF runs per ray in Python in scalar variants)")
    if variant.startswith("llvm"):
        try:
            ensure_llvm()
        except RuntimeError as e:
            raise MitsubaUnavailable(str(e)) from None
    else:
        _require_cuda(variant)
    import mitsuba as mi

    if mi.variant() != variant:
        try:
            mi.set_variant(variant)
        except Exception as e:  # mitsuba raises ImportError/RuntimeError variants
            raise MitsubaUnavailable(f"cannot use Mitsuba variant {variant!r}: {e}") from None
    return mi


def _require_cuda(variant: str) -> None:
    """Refuse a ``cuda_ad_*`` variant, in one line, where drjit finds no CUDA driver or GPU (before mitsuba tries
    it: its own error names a drjit internal, ``jit_init_thread_state()``)."""
    import drjit as dr

    if not dr.has_backend(dr.JitBackend.CUDA):
        raise MitsubaUnavailable(f"variant {variant!r} needs an NVIDIA GPU, and drjit finds no CUDA driver or device "
                                 f"on this machine (libcuda.so); render with --variant {DEFAULT_VARIANT} here")


#: the variant a registered plugin class (the svgen BSDF) was built in; set by :func:`bind_variant`, so that this
#: module knows it without importing the renderer above it.
_BOUND_VARIANT: str | None = None


def bind_variant(variant: str) -> None:
    """Record that a plugin class of ``variant`` is registered in this process (the svgen BSDF calls it on import):
    :func:`use_variant` then refuses any other variant."""
    global _BOUND_VARIANT
    _BOUND_VARIANT = variant


def use_variant(variant: str):
    """Make ``variant`` the variant this process renders in, and return ``mitsuba`` with it set.

    The svgen BSDF (:mod:`pipeline.render.bsdf`) is a class of the variant that was current when it was first
    imported, so a process renders in one variant: the first call (or ``SVGEN_MI_VARIANT``) decides it, through the
    environment, which the render stage's worker processes inherit.

    Raises:
        MitsubaUnavailable: the variant cannot run here (no CUDA, no libLLVM), or this process already renders in
            another variant.
    """
    if variant.startswith("cuda_ad_"):  # the machine's reason first, before any state changes
        _require_cuda(variant)
    bound = _BOUND_VARIANT
    if bound is not None and bound != variant:
        raise MitsubaUnavailable(f"this process already renders in {bound!r} (the svgen BSDF is bound to the variant "
                                 f"it was loaded in): render in {variant!r} from a new process")
    mi = load_mitsuba(variant)
    os.environ[VARIANT_ENV] = variant
    return mi


def __getattr__(name: str):
    """``from svcore.mi_env import mi, dr``: the one place modules take mitsuba and drjit from.

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
