"""Moved to :mod:`svcore.llvm` (#41: the renders store's reader, in storage, needs drjit too); import it from there.

This file holds no code. It stays only because dvc.yaml still names ``pipeline/llvm.py`` as a dep of its stages
(svcore/, where the module now lives, is a dep of every stage already); delete it when dvc.yaml drops that dep.
"""
