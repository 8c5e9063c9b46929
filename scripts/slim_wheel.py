"""Write a smaller copy of a wheel, to carry to a machine that cannot download (docs/GPU.md, issue #44).

    python3 scripts/slim_wheel.py IN.whl OUT_DIR [--variants llvm_ad_rgb,cuda_ad_rgb] [--no-strip]
                                                 [--compression lzma|deflate|stored]

Every wheel: ELF shared objects lose their static symbol tables and debug sections (``strip --strip-unneeded``: the
dynamic symbols that loading needs stay), and members are compressed with LZMA instead of deflate (pip installs
through Python's ``zipfile``, which reads both). A mitsuba wheel is also cut to the variants svgen renders in (the
variant modules of other variants go, and ``mitsuba/config.py`` lists only the kept ones), to the plugins svgen's
scene loads (:data:`PLUGINS`), and loses its C++ headers, CMake and pkg-config files, type stubs and the spectral
data that RGB variants never read. The ``RECORD`` is rewritten with the new files' hashes and sizes, so pip installs
the result like the original. The same input gives the same bytes (fixed member dates and order).

tests/test_slim_wheel.py installs a slimmed mitsuba into a temporary folder and renders svgen's scene from it.
"""
from __future__ import annotations

import argparse
import base64
import hashlib
import re
import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

#: the variants svgen renders in (svcore.mi_env.VARIANTS; a test holds them equal)
VARIANTS = ("llvm_ad_rgb", "cuda_ad_rgb")
#: the Mitsuba plugins svgen's scene names (pipeline/render/scene.py; batch: several views per launch), those its
#: loading adds (merge: the scene's shapes; diffuse: the sphere light's BSDF), and those Mitsuba instantiates when a
#: scene leaves them out (integrator path, rfilter gaussian, spectra srgb and d65). The plugins a process loaded are the
#: ``plugins/*.so`` of its /proc/self/maps; a scene that needs another fails to load, naming it.
PLUGINS = frozenset({"area", "batch", "box", "direct", "hdrfilm", "independent", "stratified", "perspective",
                     "point", "rectangle", "sphere", "uniform", "merge", "diffuse", "path", "gaussian", "srgb", "d65"})
#: a variant module's name: mitsuba/<variant>.cpython-312-x86_64-linux-gnu.so
_VARIANT_MODULE = re.compile(r"^mitsuba/((?:scalar|llvm|cuda)_[a-z_]+)\.cpython-[^/]+\.so$")
#: mitsuba's folders and files no svgen render reads
_MITSUBA_DROPPED = ("mitsuba/include/", "mitsuba/cmake/", "mitsuba/pkgconfig/", "mitsuba/mitsuba_stubs/",
                    "mitsuba/data/srgb.coeff", "mitsuba/data/sunsky/", "mitsuba/data/ior/")
#: a fixed date for every member (zip's earliest): the output is a function of the input alone
_DATE = (1980, 1, 1, 0, 0, 0)


def keep_member(name: str, variants=VARIANTS) -> bool:
    """Whether a mitsuba wheel's member ``name`` stays in the slimmed wheel."""
    m = _VARIANT_MODULE.match(name)
    if m:
        return m.group(1) in variants
    if name.startswith("mitsuba/plugins/"):
        return Path(name).stem in PLUGINS
    if name.endswith(".pyi") or name.startswith(_MITSUBA_DROPPED):
        return False
    return True


def _mitsuba_config(text: str, variants) -> str:
    """mitsuba/config.py with ``MI_VARIANTS`` listing only ``variants`` (in its own order)."""
    m = re.search(r"^MI_VARIANTS = (\[.*\])$", text, re.M)
    if m is None:
        raise SystemExit("mitsuba/config.py has no MI_VARIANTS line: not a Mitsuba 3 wheel this script knows")
    listed = eval(m.group(1), {})  # a list of string literals, written by Mitsuba's build
    missing = [v for v in variants if v not in listed]
    if missing:
        raise SystemExit(f"the wheel has no variant(s) {missing}; it has {listed}")
    kept = [v for v in listed if v in variants]
    return text[:m.start(1)] + repr(kept) + text[m.end(1):]


def _strip_elf(data: bytes, strip: str) -> bytes:
    """``data`` (an ELF file) without its static symbols and debug sections; unchanged if strip fails."""
    with tempfile.TemporaryDirectory() as d:
        src, dst = Path(d, "in"), Path(d, "out")
        src.write_bytes(data)
        r = subprocess.run([strip, "--strip-unneeded", "-o", str(dst), str(src)], capture_output=True)
        return dst.read_bytes() if r.returncode == 0 and dst.exists() else data


def _record_hash(data: bytes) -> str:
    return "sha256=" + base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()


#: member compression by name: LZMA (the smallest), deflate (level 9: what wheels use), stored (tests: fastest)
COMPRESSION = {"lzma": zipfile.ZIP_LZMA, "deflate": zipfile.ZIP_DEFLATED, "stored": zipfile.ZIP_STORED}


def slim(wheel: str | Path, out_dir: str | Path, variants=VARIANTS, strip: bool = True,
         compression: str = "lzma") -> Path:
    """Write the slimmed copy of ``wheel`` into ``out_dir`` (same file name) and return its path.

    Args:
        wheel: a wheel file; a mitsuba wheel is also cut to ``variants`` and :data:`PLUGINS`.
        variants: the mitsuba variants kept.
        strip: strip ELF members' symbol tables (needs binutils' ``strip``; skipped where there is none).
        compression: a key of :data:`COMPRESSION`.
    """
    wheel, out_dir = Path(wheel), Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    out = out_dir / wheel.name
    if out.resolve() == wheel.resolve():
        raise SystemExit(f"{out} would overwrite its input: give another OUT_DIR")
    is_mitsuba = wheel.name.startswith("mitsuba-")
    strip_tool = shutil.which("strip") if strip else None
    method = COMPRESSION[compression]
    with zipfile.ZipFile(wheel) as zin:
        names = [n for n in zin.namelist() if not n.endswith("/")]
        records = [n for n in names if re.fullmatch(r"[^/]+\.dist-info/RECORD", n)]
        if len(records) != 1:
            raise SystemExit(f"{wheel}: expected one .dist-info/RECORD, found {records}")
        record_name = records[0]
        rows, members = [], []
        for name in names:
            if name == record_name or (is_mitsuba and not keep_member(name, variants)):
                continue
            data = zin.read(name)
            if is_mitsuba and name == "mitsuba/config.py":
                data = _mitsuba_config(data.decode(), variants).encode()
            if strip_tool and data[:4] == b"\x7fELF":
                data = _strip_elf(data, strip_tool)
            members.append((name, data, zin.getinfo(name).external_attr))
            rows.append(f"{name},{_record_hash(data)},{len(data)}")
    rows.append(f"{record_name},,")
    tmp = out.with_name(out.name + ".part")
    with zipfile.ZipFile(tmp, "w") as zout:
        for name, data, attr in members + [(record_name, ("\n".join(rows) + "\n").encode(), 0o644 << 16)]:
            info = zipfile.ZipInfo(name, _DATE)
            info.external_attr = attr
            info.compress_type = method
            level = 9 if method == zipfile.ZIP_DEFLATED else None
            zout.writestr(info, data, compress_type=method, compresslevel=level)
    tmp.replace(out)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("wheel", help="the wheel to slim")
    ap.add_argument("out_dir", help="folder for the slimmed wheel (same file name)")
    ap.add_argument("--variants", default=",".join(VARIANTS), help="mitsuba variants kept (comma-separated)")
    ap.add_argument("--no-strip", action="store_true", help="keep ELF symbol tables")
    ap.add_argument("--compression", choices=tuple(COMPRESSION), default="lzma", help="member compression")
    a = ap.parse_args(argv)
    if not Path(a.wheel).is_file():
        print(f"no wheel at {a.wheel}", file=sys.stderr)
        return 2
    out = slim(a.wheel, a.out_dir, tuple(v for v in a.variants.split(",") if v), not a.no_strip, a.compression)
    print(f"{out} {Path(a.wheel).stat().st_size} -> {out.stat().st_size} bytes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
