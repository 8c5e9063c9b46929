"""`svgen materials`: catalogue listing, class filter, docs and contact sheet, bad input."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
from PIL import Image

from materials import presets


def test_lists_every_preset_and_parameter(svgen_cli):
    code, out = svgen_cli("materials")
    assert code == 0
    for p in presets():
        assert p.name in out
    n_rows = sum(len(p.exposed) for p in presets())
    body = [ln for ln in out.splitlines() if ln and not ln.startswith(("class ", "#"))]
    assert len(body) == n_rows


def test_class_filter(svgen_cli):
    code, out = svgen_cli("materials", "--class", "wood")
    assert code == 0 and "wood/oak_planks" in out and "metal/" not in out


def test_unknown_class_is_one_line_error():
    # a real process: the exit status and stderr as a user sees them
    r = subprocess.run([sys.executable, "-c", "from pipeline.cli import main; main()", "materials",
                        "--class", "marble"], capture_output=True, text=True)
    assert r.returncode == 2
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "unknown material class 'marble'" in lines[0], r.stderr


def test_writes_docs_and_sheet(svgen_cli, tmp_path):
    sheet, docs = tmp_path / "sheet.png", tmp_path / "m.md"
    code, out = svgen_cli("materials", "--class", "plastic", "-q", "--tile", "48", "--sheet", sheet, "--docs", docs)
    assert code == 0, out
    md = docs.read_text()
    assert "## plastic" in md and "plastic/glossy_blue" in md and "`roughness`" in md
    with Image.open(sheet) as f:
        assert f.mode == "RGB"  # not a palette image
        im = np.asarray(f)
    n = len(presets("plastic"))
    header = im[:19]  # the column-header band (pad 6 + label 13) holds text brighter than the background
    assert (header.max(-1) > 150).sum() > 100, "no column headers"
    assert im.shape[1] >= 3 * 5 * 48 and im.shape[0] >= -(-n // 3) * 48
    assert im.std() > 10  # not blank


def test_existing_output_is_not_overwritten(svgen_cli, tmp_path):
    docs = tmp_path / "m.md"
    docs.write_text("keep")
    code, out = svgen_cli("materials", "-q", "--docs", docs)
    assert code == 2 and "already exists" in out and docs.read_text() == "keep"
    assert "pass --force to overwrite it, or choose another path" in out  # the one rule's line (svcore.outputs)
    code, _ = svgen_cli("materials", "-q", "--docs", docs, "--force", "--class", "metal")
    assert code == 0 and "## metal" in docs.read_text()
