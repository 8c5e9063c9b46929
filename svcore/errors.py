"""User-facing errors: the CLI prints one line for these and exits 2, never a traceback.

Every package's bad-input exception derives from :class:`SvgenError` (materials' ``UnknownMaterial``,
``BadParameter``, ``InvalidMaps``; pipeline's ``LLVMNotFound``, ``MitsubaUnavailable``; ``ImageError``), so
the CLI funnel catches one type and needs to import nothing else to know them.
"""
from __future__ import annotations


class SvgenError(Exception):
    """Base class of every error caused by the user's input or environment (bad option, foreign store ...)."""

    exit_code = 2


class StoreError(SvgenError):
    """A store that is missing, of the wrong kind, incomplete, corrupt, locked or already exists."""


class ConfigError(SvgenError):
    """A configuration value that is unknown or out of range."""
