"""Map roles recognised in file names: a registry of case-insensitive aliases.

A file stem is split into tokens at separators (``_ - . space``) and camel-case boundaries are ignored (the
comparison is on lower case); tokens that only say resolution or format (``2K``, ``4k``, ``1024``, ``JPG``,
``PNG``) are dropped. The role is decided by the *last* remaining token(s), so ``Bricks076_2K-JPG_NormalGL.jpg``
is a normal map (OpenGL) and ``wood_base_color-4k.png`` a base colour map.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

IMAGE_EXTS = (".png", ".jpg", ".jpeg", ".exr", ".tif", ".tiff")

#: role -> aliases, best first (a folder with two files of one role keeps the better alias). Multi-word aliases
#: are token tuples. "diffuse" is a colour alias too: it is the colour map of a specular workflow.
ROLES: dict[str, tuple[tuple[str, ...], ...]] = {
    "basecolor": (("basecolor",), ("base", "color"), ("basecolour",), ("base", "colour"), ("albedo",), ("color",),
                  ("colour",), ("diffuse",), ("diff",), ("col",)),
    "normal": (("normalgl",), ("normal", "gl"), ("normal",), ("normalmap",), ("normal", "map"), ("nrm",),
               ("nor",), ("normaldx",), ("normal", "dx"), ("nor", "gl"), ("nor", "dx")),
    "roughness": (("roughness",), ("rough",), ("rgh",)),
    "glossiness": (("glossiness",), ("gloss",)),
    "metallic": (("metallic",), ("metalness",), ("metal",)),
    "specular": (("specular",), ("spec",)),
    "height": (("height",), ("displacement",), ("disp",), ("bump",)),
}
#: roles known to exist and deliberately not used (listed as ignored in the store).
IGNORED_ROLES = (("ambientocclusion",), ("ambient", "occlusion"), ("ao",), ("opacity",), ("alpha",), ("mask",),
                 ("emission",), ("emissive",), ("preview",), ("thumbnail",), ("cavity",), ("curvature",))
_NOISE = re.compile(r"^(\d+k|\d+|jpg|jpeg|png|exr|tif|tiff|8bit|16bit|\d+bit)$")
DX_TOKENS = {"normaldx", "dx"}
GL_TOKENS = {"normalgl", "gl"}


@dataclass(frozen=True)
class Match:
    """A file's role: role name, alias rank (0 best) and the normal convention its name says, if any."""

    role: str
    rank: int
    convention: str | None = None
    alias: str = ""


def tokens(stem: str) -> list[str]:
    """Lower-case name tokens without resolution/format tokens."""
    return [t for t in re.split(r"[_\-.\s]+", stem.lower()) if t and not _NOISE.match(t)]


def classify(filename: str) -> Match | str | None:
    """The role of an image file name: a :class:`Match`, the string "ignored" for known unused maps (AO,
    opacity ...), or None for names that say nothing."""
    low = filename.lower()
    if not low.endswith(IMAGE_EXTS):
        return None
    toks = tokens(low.rsplit(".", 1)[0])
    best = None
    for role, aliases in ROLES.items():
        for rank, alias in enumerate(aliases):
            if tuple(toks[-len(alias):]) == alias and (best is None or len(alias) > len(best[1])):
                best = (role, alias, rank)
    if best is not None:
        role, alias, rank = best
        conv = None
        if role == "normal":
            conv = "directx" if DX_TOKENS & set(alias) else "opengl" if GL_TOKENS & set(alias) else None
        return Match(role, rank, conv, "_".join(alias))
    if any(tuple(toks[-len(a):]) == a for a in IGNORED_ROLES):
        return "ignored"
    return None
