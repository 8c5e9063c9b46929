"""experiments/sim2real/paired_effects.py: the gain is the control's RMSE minus the arm's, paired view by view, its
interval resamples whole SVBRDFs, and two evaluations of different views are refused."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "experiments" / "sim2real"))
import paired_effects as pe  # noqa: E402


def _write(folder: Path, normal: np.ndarray, views=None, per_svbrdf: int = 4) -> Path:
    folder.mkdir()
    views = range(len(normal)) if views is None else views
    rows = ["group,view,svbrdf,rerender,normal,diffuse,roughness,specular"]
    rows += [f"all,{v},{v // per_svbrdf},0.05,{n},0.03,0.1,0.02" for v, n in zip(views, normal)]
    (folder / "per_view.csv").write_text("\n".join(rows) + "\n")
    return folder


def test_a_better_arm_has_a_positive_gain_beyond_noise_and_the_same_views_give_zero(tmp_path):
    rng = np.random.default_rng(0)
    control = 0.03 + 0.01 * rng.random(40)
    c = _write(tmp_path / "c", control)
    a = _write(tmp_path / "a", control - 0.004)  # the arm is better by 0.004 on every view
    e = pe.effects(c, a)
    assert e["normal"]["gain"] == pytest.approx(0.004, abs=1e-5)
    assert e["normal"]["ci95"][0] > 0 and e["normal"]["beyond_noise"] == "better"
    assert e["diffuse"]["gain"] == 0 and e["diffuse"]["beyond_noise"] == "no"
    assert e["svbrdfs"] == 10 and e["views"] == 40
    worse = pe.effects(a, c)  # swapped: the same effect with the other sign
    assert worse["normal"]["gain"] == pytest.approx(-0.004, abs=1e-5) and worse["normal"]["beyond_noise"] == "worse"


def test_evaluations_of_different_views_are_refused(tmp_path):
    c = _write(tmp_path / "c", np.full(8, 0.03))
    a = _write(tmp_path / "a", np.full(8, 0.03), views=range(4, 12))
    with pytest.raises(SystemExit, match="same views"):
        pe.effects(c, a)


def test_seed_noise_widens_the_interval_by_the_seed_pairs_gain(tmp_path):
    """An effect beyond the bootstrap interval but smaller than the training-seed noise is not beyond seed noise;
    one several times larger is; no seed noise (a seed pair that changed nothing) leaves the interval as it was."""
    rng = np.random.default_rng(0)
    control = 0.03 + 0.01 * rng.random(40)
    c = _write(tmp_path / "c", control)
    small, large = _write(tmp_path / "s", control - 0.002), _write(tmp_path / "l", control - 0.02)
    seed = {"normal": {"gain": -0.003}, **{k: {"gain": 0.0} for k in pe.COLUMNS if k != "normal"}}
    e_small, e_large, e_none = pe.effects(c, small), pe.effects(c, large), pe.effects(c, small)
    pe.with_seed_noise(e_small, seed)
    pe.with_seed_noise(e_large, seed)
    pe.with_seed_noise(e_none, {k: {"gain": 0.0} for k in pe.COLUMNS})
    assert e_small["normal"]["beyond_noise"] == "better" and e_small["normal"]["beyond_seed_noise"] == "no"
    assert e_small["normal"]["seed_allowance"] == pytest.approx(1.96 * 0.003, abs=1e-5)  # one pair: sigma_d = |g|
    assert e_large["normal"]["beyond_seed_noise"] == "better"
    assert e_none["normal"]["ci95_with_seed"] == pytest.approx(e_none["normal"]["ci95"], abs=1e-5)
    assert e_none["normal"]["beyond_seed_noise"] == "better"


def test_more_seed_pairs_estimate_the_noise_from_all_runs():
    """Runs at 0, -g_1, -g_2: sigma_d = sqrt(2) x their standard deviation; a second pair that agrees with the
    control shrinks the allowance, one that disagrees as much as the first keeps it near."""
    g = 0.003
    base = {c: {"gain": 0.0} for c in pe.COLUMNS}
    one = [{**base, "normal": {"gain": g}}]
    agree = one + [{**base, "normal": {"gain": 0.0}}]
    spread = one + [{**base, "normal": {"gain": -g}}]
    assert pe.seed_sigma(one, "normal") == pytest.approx(g)
    assert pe.seed_sigma(agree, "normal") == pytest.approx(np.sqrt(2) * np.std([0, -g, 0], ddof=1))
    assert pe.seed_sigma(agree, "normal") < pe.seed_sigma(one, "normal") < pe.seed_sigma(spread, "normal") * 1.01
    assert pe.seed_sigma(agree, "diffuse") == 0.0


def test_seed_noise_without_the_set_is_refused(tmp_path):
    import json

    c = _write(tmp_path / "c", np.full(8, 0.03))
    seed = tmp_path / "seed.json"
    seed.write_text(json.dumps({"sets": {"other": {}}}))
    with pytest.raises(SystemExit, match="no set 'x'"):
        pe.main(["--pair", "x", str(c), str(c), "--seed-noise", str(seed), "--out", str(tmp_path / "o.json")])
