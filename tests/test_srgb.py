"""svcore.srgb is colour-science's sRGB curve bit for bit (so no stored byte changed when the stages stopped
importing colour-science), and the data stages' hot paths no longer import colour-science (its 2-second import)."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from svcore import srgb

colour = pytest.importorskip("colour")
REPO = Path(__file__).resolve().parents[1]


def _inputs() -> dict[str, np.ndarray]:
    rng = np.random.default_rng(0)
    knees = np.array([srgb.LINEAR_KNEE, srgb.ENCODED_KNEE])
    return {
        "8-bit codes": np.arange(256) / 255.0,
        "16-bit codes": np.arange(65536) / 65535.0,
        "grid over [-0.2, 1.2]": np.linspace(-0.2, 1.2, 400_001),
        "random float64": rng.random(400_000),
        "random float32": rng.random(400_000).astype(np.float32),
        # either side of both knees, to the last bit: the branch taken must be colour-science's
        "knees": np.concatenate([knees, np.nextafter(knees, 0), np.nextafter(knees, 1), [0.0, -0.0, 1.0]]),
    }


@pytest.mark.parametrize("direction", ["encode", "decode"])
def test_bit_for_bit_colour_science(direction):
    ours = getattr(srgb, direction)
    theirs = {"encode": colour.cctf_encoding, "decode": colour.cctf_decoding}[direction]
    for name, x in _inputs().items():
        want = np.asarray(theirs(x, function="sRGB"), np.float64)
        got = ours(x)
        assert got.dtype == np.float64 and got.shape == want.shape, name
        bad = np.flatnonzero(got.view(np.int64) != want.view(np.int64))
        assert bad.size == 0, (f"{direction} differs from colour-science on {bad.size} of {x.size} {name} values, "
                               f"e.g. x={x.flat[bad[0]]!r}: {got.flat[bad[0]]!r} vs {want.flat[bad[0]]!r}")


def test_float32_wrappers_match_colour_science():
    """The float32 helpers every stage uses (materials.color, svcore.image_io) equal colour-science cast once."""
    from materials.color import linear_to_srgb, srgb_to_linear
    from svcore.image_io import srgb_decode, srgb_encode

    x = np.random.default_rng(1).random((64, 64, 3)).astype(np.float32)
    for f, g in ((srgb_to_linear, colour.cctf_decoding), (srgb_decode, colour.cctf_decoding),
                 (linear_to_srgb, colour.cctf_encoding), (srgb_encode, colour.cctf_encoding)):
        want = np.asarray(g(np.clip(x, 0, 1), function="sRGB"), np.float32)
        np.testing.assert_array_equal(f(x), want, err_msg=f.__qualname__)


def test_sample_and_render_stages_do_not_import_colour_science(tmp_path):
    """The guard of the speed-up: `svgen sample` and `svgen render` run in one fresh process (in process, no dask
    workers) leave colour-science unimported (an import anywhere on these paths costs every stage process and each
    of its dask workers ~2 s of start)."""
    v, r = tmp_path / "v.zarr", tmp_path / "r.zarr"
    code = (
        "import sys\n"
        "from pipeline.cli import cli as main\n"
        f"main(['sample', {str(v)!r}, '--per-preset', '1', '--size', '64', '--class', 'wood', '--workers', '0'],"
        " standalone_mode=False)\n"
        f"main(['render', {str(v)!r}, {str(r)!r}, '--views', '1', '--res', '32', '--workers', '0'],"
        " standalone_mode=False)\n"
        "print(sorted(m for m in sys.modules if m == 'colour' or m.startswith('colour.'))[:5])\n"
    )
    res = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0 and r.is_dir(), res.stderr[-2000:]
    assert res.stdout.strip().splitlines()[-1] == "[]", f"colour-science imported by a stage: {res.stdout[-300:]}"
