"""experiments/sim2real/seed_screen.py: every effects file screened against a seed pair, set by set, the records
unchanged."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "experiments" / "sim2real"))
import paired_effects as pe  # noqa: E402
import seed_screen as ss  # noqa: E402


def _set(normal_gain: float, half: float) -> dict:
    cols = {c: {"control": 0.05, "arm": 0.05, "gain": 0.0, "ci95": [-0.001, 0.001], "beyond_noise": "no"}
            for c in pe.COLUMNS}
    cols["normal"] = {"control": 0.05, "arm": 0.05 - normal_gain, "gain": normal_gain,
                      "ci95": [normal_gain - half, normal_gain + half],
                      "beyond_noise": "better" if normal_gain - half > 0 else "no"}
    return {"views": 40, "svbrdfs": 10, **cols}


def test_only_effects_larger_than_the_seed_noise_stand_out_and_records_are_kept(tmp_path):
    seed = {"sets": {"real_crop1": {c: {"gain": 0.0} for c in pe.COLUMNS},
                     "heldout_default": {c: {"gain": 0.0} for c in pe.COLUMNS}}}
    seed["sets"]["real_crop1"]["normal"]["gain"] = 0.002  # allowance 1.96 * 0.002 = 0.0039
    seed["sets"]["heldout_default"]["normal"]["gain"] = 0.0001
    (tmp_path / "effects_seed.json").write_text(json.dumps(seed))
    small = {"what": "small", "sets": {"real_crop1": _set(0.003, 0.001), "heldout_before": _set(0.003, 0.001),
                                       "other_store": _set(0.003, 0.001)}}
    large = {"what": "large", "sets": {"real_crop1": _set(0.02, 0.002)}}
    (tmp_path / "effects_small.json").write_text(json.dumps(small))
    (tmp_path / "effects_large.json").write_text(json.dumps(large))
    before = {p.name: p.read_text() for p in tmp_path.glob("*.json")}
    out = tmp_path / "effects_seed_screen.json"
    r = ss.main(["--seed", str(tmp_path / "effects_seed.json"), "--results", str(tmp_path), "--out", str(out)])
    sets = r["files"]["effects_small.json"]["sets"]
    assert sets["real_crop1"]["normal"]["beyond_noise"] == "better"
    assert sets["real_crop1"]["normal"]["beyond_seed_noise"] == "no"  # 0.003 within the seed pair's 0.0039
    assert sets["heldout_before"]["screened_with"] == "heldout_default"
    assert sets["heldout_before"]["normal"]["beyond_seed_noise"] == "better"  # the held-out seed noise is small
    assert sets["other_store"] == {"screened_with": None}
    assert r["files"]["effects_large.json"]["sets"]["real_crop1"]["normal"]["beyond_seed_noise"] == "better"
    assert sorted(r["standing_out"]) == sorted([
        "effects_large.json real_crop1 normal: better +0.0200 " + str(
            r["files"]["effects_large.json"]["sets"]["real_crop1"]["normal"]["ci95_with_seed"]),
        "effects_small.json heldout_before normal: better +0.0030 " + str(sets["heldout_before"]["normal"]["ci95_with_seed"])])
    assert "effects_seed.json" not in r["files"] and out.is_file()
    assert {p.name: p.read_text() for p in tmp_path.glob("*.json") if p != out} == before  # records as they were
    lo = 0.02 - np.hypot(0.002, 1.96 * 0.002)
    assert r["files"]["effects_large.json"]["sets"]["real_crop1"]["normal"]["ci95_with_seed"][0] == round(lo, 5)
