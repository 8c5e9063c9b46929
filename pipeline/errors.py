"""User-facing errors: the CLI prints one line for these and exits non-zero, never a traceback."""
from __future__ import annotations


class SvgenError(Exception):
    """Base class of every error caused by the user's input or environment (bad option, foreign store ...)."""

    exit_code = 2


class StoreError(SvgenError):
    """A store that is missing, of the wrong kind, incomplete, corrupt, locked or already exists."""


class ConfigError(SvgenError):
    """A configuration value that is unknown or out of range."""


def user_error_types() -> tuple[type[BaseException], ...]:
    """All exception types that mean 'bad input' across the packages (printed as one line)."""
    from materials.maps import InvalidMaps
    from materials.registry import BadParameter, UnknownMaterial

    from .llvm import LLVMNotFound
    from .mi_env import MitsubaUnavailable

    return (SvgenError, BadParameter, UnknownMaterial, InvalidMaps, LLVMNotFound, MitsubaUnavailable)
