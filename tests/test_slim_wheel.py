"""scripts/slim_wheel.py (issue #44): a mitsuba wheel cut to svgen's variants and plugins, installed by pip into a
temporary folder, imports, sets llvm_ad_rgb and renders svgen's scene bit for bit as the full install does; its
RECORD matches its files; LZMA members install through pip.

The wheel is rebuilt offline from this machine's installed mitsuba (its dist-info RECORD names the files), stored
uncompressed so that the test spends its time on what it checks, not on compression."""
from __future__ import annotations

import base64
import hashlib
import importlib.metadata as md
import json
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "scripts"))

import slim_wheel  # noqa: E402

#: rendered from the slimmed install in a subprocess: the scene of svgen render, a point and a sphere flash, and two
#: views in one launch (the batch sensor of ``render.views_per_launch``, which the prepared GPU run uses)
RENDER = """
import sys, json
import numpy as np
sys.path.insert(0, {site!r})
import mitsuba
assert mitsuba.__file__.startswith({site!r}), mitsuba.__file__
from svcore.mi_env import load_mitsuba
mi = load_mitsuba("llvm_ad_rgb")
from pipeline.render.scene import FlashScene
from storage.views import ViewParams
sys.path.insert(0, {tests!r})
from render_helpers import checker_svbrdf
from test_slim_wheel import views_per_launch
maps = checker_svbrdf(16, cells=4)
view = ViewParams(light_x=0.1, light_y=-0.2, seed=7)
np.save({out!r}, np.stack([FlashScene(16, 1, light, "centre").render_maps(maps, view, clip=False)
                           for light in ("point", "sphere")]))
np.save({out_views!r}, views_per_launch(maps))
print(json.dumps({{"variant": mi.variant(), "file": mitsuba.__file__}}))
"""


def views_per_launch(maps) -> np.ndarray:
    """Two views of ``maps`` in one launch (sRGB codes): what the batch sensor renders."""
    from pipeline.render.scene import FlashScene
    from storage.views import planes_of

    p = planes_of(maps)
    return FlashScene(16, 1, "point", "centre", views=2).render_views_srgb8([p, p], [(0.1, -0.2), (-0.3, 0.2)], 0)


def _installed_wheel(dist: str, out_dir: Path) -> Path:
    """A wheel of the installed distribution ``dist`` (the files its RECORD lists, stored uncompressed)."""
    d = md.distribution(dist)
    info = next(f for f in d.files if f.name == "WHEEL" and f.parent.name.endswith(".dist-info"))
    tag = next(line.split(": ", 1)[1] for line in Path(d.locate_file(info)).read_text().splitlines()
               if line.startswith("Tag: "))
    out = out_dir / f"{d.metadata['Name']}-{d.version}-{tag}.whl"
    with zipfile.ZipFile(out, "w", zipfile.ZIP_STORED) as z:
        for f in d.files:
            if str(f).startswith("..") or "__pycache__" in f.parts or f.name in ("INSTALLER", "REQUESTED",
                                                                                   "direct_url.json"):
                continue
            z.write(d.locate_file(f), str(f))
    return out


@pytest.fixture(scope="module")
def slim_install(tmp_path_factory):
    """(slimmed wheel, folder it was pip-installed into)."""
    tmp = tmp_path_factory.mktemp("slim")
    full = _installed_wheel("mitsuba", tmp)
    wheel = slim_wheel.slim(full, tmp / "out", compression="stored")
    site = tmp / "site"
    r = subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-index", "--no-deps", "--no-compile",
                        "--target", str(site), str(wheel)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return wheel, site


def test_the_slim_wheel_keeps_svgens_variants_and_plugins_only(slim_install):
    wheel, site = slim_install
    names = zipfile.ZipFile(wheel).namelist()
    modules = {Path(n).name.split(".")[0] for n in names if slim_wheel._VARIANT_MODULE.match(n)}
    assert modules == set(slim_wheel.VARIANTS)
    assert {Path(n).stem for n in names if n.startswith("mitsuba/plugins/")} == slim_wheel.PLUGINS
    assert not any(n.startswith("mitsuba/include/") or n.endswith(".pyi") for n in names)
    assert "MI_VARIANTS = ['llvm_ad_rgb', 'cuda_ad_rgb']" in (site / "mitsuba" / "config.py").read_text()


def test_its_record_names_every_file_with_its_hash(slim_install):
    wheel, _ = slim_install
    with zipfile.ZipFile(wheel) as z:
        record = next(n for n in z.namelist() if n.endswith(".dist-info/RECORD"))
        rows = [line.split(",") for line in z.read(record).decode().splitlines()]
        assert sorted(r[0] for r in rows) == sorted(z.namelist())
        for name, digest, size in rows:
            if name != record:
                data = z.read(name)
                b64 = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
                assert (digest, int(size)) == (f"sha256={b64}", len(data)), name


def test_the_slim_install_renders_svgens_scene_as_the_full_one_does(slim_install, tmp_path):
    _, site = slim_install
    out, out_views = tmp_path / "slim.npy", tmp_path / "slim_views.npy"
    code = RENDER.format(site=str(site), tests=str(REPO / "tests"), out=str(out), out_views=str(out_views))
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO)
    assert r.returncode == 0, r.stderr[-3000:]
    got = json.loads(r.stdout.strip().splitlines()[-1])
    assert got["variant"] == "llvm_ad_rgb" and got["file"].startswith(str(site)), got
    from pipeline.render.scene import FlashScene
    from storage.views import ViewParams
    from render_helpers import checker_svbrdf

    maps, view = checker_svbrdf(16, cells=4), ViewParams(light_x=0.1, light_y=-0.2, seed=7)
    full = np.stack([FlashScene(16, 1, light, "centre").render_maps(maps, view, clip=False)
                     for light in ("point", "sphere")])
    assert full.mean() > 0.05 and np.array_equal(np.load(out), full)
    views = views_per_launch(maps)
    assert views.mean() > 10 and np.array_equal(np.load(out_views), views)


def test_lzma_members_install_through_pip(tmp_path):
    """The carried wheels are LZMA-compressed: pip (through zipfile) must install such a wheel as it is."""
    src = tmp_path / "tiny_pkg-1.0-py3-none-any.whl"
    with zipfile.ZipFile(src, "w") as z:
        z.writestr("tiny_pkg/__init__.py", "VALUE = 42\n")
        z.writestr("tiny_pkg-1.0.dist-info/METADATA", "Metadata-Version: 2.1\nName: tiny-pkg\nVersion: 1.0\n")
        z.writestr("tiny_pkg-1.0.dist-info/WHEEL", "Wheel-Version: 1.0\nRoot-Is-Purelib: true\nTag: py3-none-any\n")
        z.writestr("tiny_pkg-1.0.dist-info/RECORD", "")
    wheel = slim_wheel.slim(src, tmp_path / "out")
    assert {i.compress_type for i in zipfile.ZipFile(wheel).infolist()} == {zipfile.ZIP_LZMA}
    site = tmp_path / "site"
    r = subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-index", "--no-deps", "--target",
                        str(site), str(wheel)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    r = subprocess.run([sys.executable, "-c", "import tiny_pkg; print(tiny_pkg.VALUE)"], capture_output=True,
                       text=True, cwd=site)
    assert r.stdout.strip() == "42", r.stderr


def test_the_variants_are_those_svgen_renders_in():
    from svcore.mi_env import VARIANTS

    assert slim_wheel.VARIANTS == VARIANTS
