"""How much the contact sheet changed when its private numpy BRDF gave way to materials.brdf_reference (issue #13).

The old ``materials.catalog.flash_render`` (read from git at ``BASE``) differed from the reference renderer of
the data in three ways: an alpha floor of 1e-3 instead of 1e-4 (r >= 0.032 instead of 0.01), a light power of
14.5 instead of FLASH_INTENSITY = pi D^2 = 14.448, and cosines clamped to >= 1e-4 instead of masking texels that
face away from the light or camera. This script renders every preset with both, at the sheet's generation size,
and writes the differences (linear radiance and the sheet's 8-bit sRGB codes) and the sheet pixel differences.

    python3 scripts/contact_sheet_change.py  ->  scripts/contact_sheet_change.json
"""
from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import types
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
BASE = "8cb09ceca3bdb632bbfbc77cf520421527d6ba3f"  # the last commit with the catalogue's own BRDF
GEN = 160  # contact_sheet(tile=80) generates maps at 2 x tile


def _old_catalog() -> types.ModuleType:
    src = subprocess.run(["git", "show", f"{BASE}:materials/catalog.py"], cwd=ROOT, check=True,
                         capture_output=True, text=True).stdout
    mod = types.ModuleType("materials.catalog_old")
    mod.__package__ = "materials"
    exec(compile(src, "materials/catalog.py@" + BASE[:8], "exec"), mod.__dict__)  # noqa: S102 (our own file)
    return mod


def main(out: Path) -> None:
    from PIL import Image

    import materials
    from materials import catalog
    from materials.color import linear_to_srgb

    old = _old_catalog()
    rows, worst = [], None
    for p in materials.presets():
        m = p.generate(None, GEN, 0)
        a, b = old.flash_render(m), catalog.flash_render(m)
        lin = np.abs(b.astype(np.float64) - a)
        codes = np.abs(np.round(linear_to_srgb(b) * 255).astype(int) - np.round(linear_to_srgb(a) * 255).astype(int))
        row = {"preset": p.name, "linear_max": float(lin.max()), "linear_mean": float(lin.mean()),
               "srgb8_max": int(codes.max()), "srgb8_mean": float(codes.mean()),
               "srgb8_share_changed": float((codes > 0).mean()),
               "roughness_below_0.032_share": float((m.roughness < 1e-3 ** 0.5).mean()),
               "masked_share": float(((b == 0) & (a > 0)).any(-1).mean())}  # facing away: black now
        rows.append(row)
        worst = row if worst is None or row["srgb8_max"] > worst["srgb8_max"] else worst
    with tempfile.TemporaryDirectory() as d:
        new_png = catalog.contact_sheet(Path(d) / "new.png")
        new_fr = catalog.flash_render
        catalog.flash_render = old.flash_render  # preview_tiles looks it up in the module: the old sheet
        try:
            old_png = catalog.contact_sheet(Path(d) / "old.png")
        finally:
            catalog.flash_render = new_fr
        a = np.asarray(Image.open(old_png).convert("RGB"), int)
        b = np.asarray(Image.open(new_png).convert("RGB"), int)
    sheet = np.abs(a - b).max(-1)
    result = {
        "base_commit": BASE, "gen_size": GEN,
        "summary": {
            "presets": len(rows),
            "linear_max": max(r["linear_max"] for r in rows),
            "linear_mean": float(np.mean([r["linear_mean"] for r in rows])),
            "srgb8_max": max(r["srgb8_max"] for r in rows),
            "srgb8_mean": float(np.mean([r["srgb8_mean"] for r in rows])),
            "worst_preset": worst["preset"],
            "sheet_pixels": int(sheet.size), "sheet_pixels_changed_share": float((sheet > 0).mean()),
            "sheet_max_code_change": int(sheet.max()), "sheet_mean_code_change": float(sheet.mean()),
        },
        "presets": rows,
    }
    out.write_text(json.dumps(result, indent=1) + "\n")
    print(json.dumps(result["summary"], indent=1))


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "scripts" / "contact_sheet_change.json")
