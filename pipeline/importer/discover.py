"""Find materials under the sources: one material per folder (a folder is a material when it holds at least one
map file), anywhere in a tree; the 2018 strips are single files. Symlinks are followed, loops refused.

Per material this records which file fills each role, which files were ignored and why, and what a sidecar
``metadata.json`` (MatSynth style) says about licence and category.
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path

from . import ImportInputError
from .aliases import IMAGE_EXTS, ROLES, Match, classify

#: extension preference when two files fill one role with the same alias: more precision first.
EXT_RANK = {".exr": 0, ".tif": 1, ".tiff": 1, ".png": 2, ".jpg": 3, ".jpeg": 3}


@dataclass
class MaterialSource:
    """One material found on disk.

    Attributes:
        name: unique material name (the folder's name, or the strip file's stem).
        root: the folder (or strip file).
        layout: "folders" or "deschaintre".
        files: role -> chosen file (folders); {"strip": file} (deschaintre).
        conventions: role -> normal convention its file name says ("opengl"/"directx"), if it says one.
        ignored: file name -> why it is not used.
        meta: licence/category and other sidecar fields.
    """

    name: str
    root: Path
    layout: str
    files: dict[str, Path] = field(default_factory=dict)
    conventions: dict[str, str] = field(default_factory=dict)
    ignored: dict[str, str] = field(default_factory=dict)
    meta: dict = field(default_factory=dict)
    colour_alias: str = ""


def walk(src: Path) -> list[tuple[Path, list[str]]]:
    """(folder, file names) of every folder under ``src`` (followed symlinks included), sorted.

    Raises:
        ImportInputError: a symlink that points back into its own ancestry (a loop).
    """
    out, stack = [], [(src, (os.path.realpath(src),))]
    while stack:
        d, ancestors = stack.pop()
        try:
            entries = sorted(os.scandir(d), key=lambda e: e.name)
        except OSError as e:
            raise ImportInputError(f"cannot list {d}: {e.strerror}") from None
        files = []
        for e in entries:
            if e.is_dir(follow_symlinks=True):
                real = os.path.realpath(e.path)
                if real in ancestors:
                    raise ImportInputError(f"symlink loop: {e.path} points back to {real}")
                stack.append((Path(e.path), ancestors + (real,)))
            elif e.is_file(follow_symlinks=True):
                files.append(e.name)
            elif e.is_symlink():
                raise ImportInputError(f"broken symlink {e.path}")
        out.append((d, files))
    return sorted(out, key=lambda t: str(t[0]))


def folder_material(folder: Path, names: list[str], convention: str) -> MaterialSource | None:
    """The material of one folder, or None when no file names a map role.

    Args:
        convention: "auto", "opengl" or "directx": which normal file wins when both exist.
    """
    cands: dict[str, list[tuple[tuple, str, Match]]] = {}
    ignored = {}
    for n in names:
        m = classify(n)
        if isinstance(m, Match):
            wanted = convention if convention != "auto" else "opengl"  # which normal file wins when both exist
            pref = 0 if (m.role != "normal" or m.convention in (None, wanted)) else 1
            key = (pref, m.rank, EXT_RANK.get(Path(n).suffix.lower(), 9), n)
            cands.setdefault(m.role, []).append((key, n, m))
        elif m == "ignored":
            ignored[n] = "not used by this BRDF model"
        elif n.lower().endswith(IMAGE_EXTS):
            ignored[n] = "name names no map role"
    if not cands:
        return None
    mat = MaterialSource(name=folder.name, root=folder, layout="folders", ignored=ignored)
    for role in ROLES:
        if role not in cands:
            continue
        ranked = sorted(cands[role])
        _, n, m = ranked[0]
        mat.files[role] = folder / n
        if m.convention:
            mat.conventions[role] = m.convention
        if role == "basecolor":
            mat.colour_alias = m.alias
        for _, other, _ in ranked[1:]:
            mat.ignored[other] = f"another {role} map ({n}) was preferred"
    # a "diffuse" file beside a base colour is the diffuse of a specular workflow (MatSynth ships both)
    diffuse = [n for _, n, m in cands.get("basecolor", []) if m.alias in ("diffuse", "diff")]
    if "specular" in mat.files and diffuse:
        chosen = mat.files["basecolor"].name
        if chosen != diffuse[0]:
            mat.ignored[chosen] = f"specular workflow: {diffuse[0]} is the diffuse map"
            mat.ignored.pop(diffuse[0], None)
            mat.files["basecolor"] = folder / diffuse[0]
            mat.colour_alias = "diffuse"
    side = folder / "metadata.json"
    if side.is_file():
        mat.meta = sidecar(side)
    return mat


def sidecar(path: Path) -> dict:
    """Licence, category, physical size and stationarity from a MatSynth-style metadata.json (missing keys are left
    out).

    Raises:
        ImportInputError: the file is not JSON.
    """
    try:
        d = json.loads(path.read_text())
    except (OSError, ValueError) as e:
        raise ImportInputError(f"{path} is not valid JSON: {' '.join(str(e).split())}") from None
    if not isinstance(d, dict):
        return {}
    out = {}
    for key, names in {"licence": ("license", "licence"), "category": ("category",),
                       "physical_size": ("physical_size", "physical size"), "physical_size_cm": ("physical_size_cm",),
                       "source_name": ("name",), "stationary": ("stationary",)}.items():
        for k in names:
            if k in d and isinstance(d[k], (str, int, float)):
                out[key] = d[k]
                break
    return out


def find_folders(sources: list[Path], convention: str) -> list[MaterialSource]:
    """Every material folder under the sources, sorted by name.

    Raises:
        ImportInputError: a missing source, an empty one, one with no recognisable maps, a symlink loop,
            two materials with one name.
    """
    mats = []
    for src in sources:
        if not src.exists():
            raise ImportInputError(f"source {src} does not exist")
        if not src.is_dir():
            raise ImportInputError(f"source {src} is not a folder (the folders layout imports folders of maps)")
        tree = walk(src)
        if not any(files for _, files in tree):
            raise ImportInputError(f"source {src} is empty")
        found = [m for d, files in tree if (m := folder_material(d, files, convention)) is not None]
        if not found:
            raise ImportInputError(f"no recognisable maps under {src} (looked for file names ending in "
                                   "basecolor/albedo/color/diffuse, normal, roughness, metallic, specular, height ...)")
        mats += found
    return unique(mats)


def unique(mats: list[MaterialSource]) -> list[MaterialSource]:
    """Sorted by name; two materials with one name are refused (names key provenance, splits and --from)."""
    seen: dict[str, MaterialSource] = {}
    for m in mats:
        if m.name in seen:
            raise ImportInputError(f"duplicate material name {m.name!r}: {seen[m.name].root} and {m.root}; rename one")
        seen[m.name] = m
    return [seen[k] for k in sorted(seen)]
