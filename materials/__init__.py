"""Procedural SVBRDF generators: one module per material class, registered by name."""
from .maps import MAP_CHANNELS, MAP_NAMES, SVBRDF, InvalidMaps
from .params import Param, ParamTable
from .registry import (BadParameter, MaterialClass, Preset, UnknownMaterial, classes, get_class, get_preset,
                       presets, register_class, register_preset)

__all__ = ["MAP_CHANNELS", "MAP_NAMES", "SVBRDF", "InvalidMaps", "Param", "ParamTable", "BadParameter",
           "MaterialClass", "Preset", "UnknownMaterial", "classes", "get_class", "get_preset", "presets",
           "register_class", "register_preset"]
