"""experiments/quantisation/probe_quantisation.py: the 8- and 16-bit quantisers are the stored sRGB curve at their step counts,
and the relief-to-quantisation ratio is the dB figure that uniform quantisation noise predicts."""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "experiments" / "quantisation"))
import probe_quantisation as pq  # noqa: E402

from storage.srgb8 import decode_srgb8, encode_srgb8  # noqa: E402
from svcore.image_io import srgb_decode, srgb_encode  # noqa: E402


@pytest.mark.parametrize("bits", [8, 16])
def test_quantise_is_the_srgb_curve_at_its_step_count(bits):
    x = np.random.default_rng(0).random(50_000).astype(np.float32)
    q = pq.quantise(x, bits)
    top = 2 ** bits - 1
    code = np.asarray(srgb_encode(q.astype(np.float64)), np.float64) * top
    # every output is a code of the curve (up to float32 storage of the linear value), the nearest one to x
    assert np.abs(code - np.round(code)).max() < (0.02 if bits == 8 else 0.2)
    assert np.abs(code - np.asarray(srgb_encode(x.astype(np.float64)), np.float64) * top).max() <= 0.5 + 0.2
    if bits == 8:
        assert np.array_equal(q, decode_srgb8(encode_srgb8(x)))


@pytest.mark.parametrize("bits", [8, 16])
def test_the_ratio_is_what_uniform_quantisation_noise_predicts(bits):
    """A smooth ramp (fractional codes spread evenly) plus a relief imprint of known RMS: the noise power is the
    mean of step^2 / 12 over the pixels, step the linear width of the code each pixel falls in. Tolerance 0.3 dB
    (7 % in RMS): the uniform-noise model on 65,536 pixels is good to about 1 %."""
    n = 256
    yy, xx = np.mgrid[0:n, 0:n] / n
    flat = (0.15 + 0.1 * xx + 0.003 * yy)[..., None].repeat(3, -1)
    amp = 0.004 if bits == 8 else 4e-6
    image = flat + amp * np.sin(2 * np.pi * 9 * xx + 1.0)[..., None]
    top = 2 ** bits - 1
    c = np.floor(np.asarray(srgb_encode(image), np.float64) * top + 0.5)
    edge = lambda k: np.asarray(srgb_decode(np.clip(k, 0, top) / top))  # noqa: E731
    step = edge(c + 0.5) - edge(c - 0.5)
    expected = 10 * math.log10(np.mean((image - flat) ** 2) / np.mean(step ** 2 / 12))
    got = pq.imprint_ratio_db(image.astype(np.float32), flat.astype(np.float32), bits)
    assert abs(got - expected) < 0.3, (got, expected)
    # the same imprint is about 48 dB further above 16-bit noise (256x finer steps)
    if bits == 8:
        assert pq.imprint_ratio_db(image.astype(np.float32), flat.astype(np.float32), 16) - got > 40
