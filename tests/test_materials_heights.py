"""Relief set by slope (materials/heights.py) and where the organic classes put their slope power (#23)."""
import numpy as np
import pytest

from materials import presets
from materials.heights import at_slope, band_pair, slope_rms
from materials.noise import Tex
from pipeline.stats.realism import octave_shares

#: the classes whose relief is built with materials/heights.py
CLASSES = ("paper", "cork", "rubber", "bark", "knit", "metal_sheet")
#: share of slope power a preset must keep at 4-32 cycles per texture (#23: mid scales carry the relief)
MID_SHARE = 0.5


def test_at_slope_sets_the_rms_slope():
    tex = Tex(64, np.random.default_rng(0))
    h = tex.fbm(0.2, beta=3.0)
    for rms in (0.01, 0.2):
        assert slope_rms(at_slope(h, rms)) == pytest.approx(rms, rel=1e-4)
    assert not at_slope(np.zeros((64, 64), np.float32), 0.3).any()  # flat stays flat, no division by zero


def test_band_pair_independent_fields_in_their_bands():
    a, b = band_pair(128, 7, 8.0, 32.0)
    assert abs(np.corrcoef(a.ravel(), b.ravel())[0, 1]) < 0.1
    f = np.hypot(*np.meshgrid(np.fft.fftfreq(128, 1 / 128), np.fft.fftfreq(128, 1 / 128)))
    for x, c in ((a, 8.0), (b, 32.0)):
        pw = np.abs(np.fft.fft2(x)) ** 2
        peak = float((pw * f).sum() / pw.sum())  # power-weighted mean frequency
        assert c * 0.7 < peak < c * 1.4, (c, peak)
    # same seed, same fields; another seed, others
    a2, _ = band_pair(128, 7, 8.0, 32.0)
    a3, _ = band_pair(128, 8, 8.0, 32.0)
    assert np.array_equal(a, a2) and not np.allclose(a, a3)


@pytest.mark.parametrize("cls", CLASSES)
def test_relief_mostly_at_mid_scales(cls):
    # at 128² the octaves are [1,2) ... [64,64]; 4-32 cycles are octaves 2-4 (#22: finer relief is not learned)
    low = []
    for p in presets(cls):
        sh = octave_shares(p.generate(None, 128, 0).normal)
        if sh.sum() and sh[2:5].sum() < MID_SHARE:
            low.append(f"{p.name}: {sh[2:5].sum():.2f}")
    assert not low, f"presets with less than {MID_SHARE} of their slope power at 4-32 cycles: {low}"
