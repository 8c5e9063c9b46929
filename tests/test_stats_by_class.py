"""experiments/library_stats/stats_by_class.py: categories come from the reference README's table (header and rule rows
left out), the per-group summary and Wasserstein pull columns are right on tiny arrays, and a missing reference
folder is refused in one line."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "experiments" / "library_stats"))
import stats_by_class as sbc  # noqa: E402


def test_categories_from_the_readme_table(tmp_path):
    (tmp_path / "README.md").write_text("# x\n\n| asset | category | site |\n|---|---|---|\n"
                                        "| Wood047 | wood | ambientCG |\n| rusty_metal_05 | metal | Poly Haven |\n")
    assert sbc.reference_categories(tmp_path) == {"Wood047": "wood", "rusty_metal_05": "metal"}
    assert sbc.reference_categories(tmp_path / "none") == {}


def test_a_class_far_from_the_reference_pulls_the_library_away():
    ref = {s: np.full((2, 4), 0.5) for s in sbc.STATS}
    lib = {s: np.array([[0.5] * 4, [0.5] * 4, [0.9] * 4]) for s in sbc.STATS}
    out = sbc.by_group(lib, ["near", "near", "far"], ref)["roughness"]
    assert out["far"]["w_alone"] == 0.4 and out["near"]["w_alone"] == 0.0
    assert out["far"]["w_without_delta"] > 0 > out["near"]["w_without_delta"]
    assert out["_all"]["mean"] == round((0.5 * 8 + 0.9 * 4) / 12, 4)


def test_missing_reference_is_refused_in_one_line(tmp_path):
    r = subprocess.run([sys.executable, str(ROOT / "experiments" / "library_stats" / "stats_by_class.py"),
                        str(tmp_path / "nope")],
                       capture_output=True, text=True)
    assert r.returncode == 2 and r.stderr.strip().count("\n") == 0 and "no reference folder" in r.stderr


def test_per_material_statistics_count_each_material_once():
    """cv_specular is one value per material (svgen stats compares those), so a material's pixel count must not
    weight it: values() gives (M, 1), and a class's summary is over its materials."""
    from types import SimpleNamespace

    p = SimpleNamespace(pixels={s: np.zeros((3, 16)) for s in sbc.PIXEL_STATS},
                        per_material={s: np.array([0.0, 0.0, 1.2]) for s in sbc.MATERIAL_STATS})
    v = sbc.values(p)
    assert v["cv_specular"].shape == (3, 1) and v["roughness"].shape == (3, 16)
    out = sbc.by_group(v, ["paint", "paint", "metal_sheet"], {s: np.zeros((2, 1)) for s in sbc.STATS})
    assert out["cv_specular"]["metal_sheet"]["mean"] == 1.2 and out["cv_specular"]["paint"]["w_alone"] == 0.0
    assert out["cv_specular"]["metal_sheet"]["w_without_delta"] > 0
