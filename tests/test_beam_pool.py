"""Pooled DAS mix weight (:mod:`enhancers.beam.beam_pool`).

Oracles: the closed-form DAS weight (1 in noise that is incoherent between the mics, 0 for a rear plane wave the
differential null removes) and the ramp's closed form.
"""

from __future__ import annotations

import numpy as np
import pytest
from signals import FS, plane_wave_pair

from enhancers.beam.beam_pool import pooled_mix_step
from enhancers.core.registry import make
from enhancers.kernels import frames as fast_frames

NFFT = 256
F_HZ = np.arange(NFFT // 2 + 1) * FS / NFFT


@pytest.mark.parametrize("bands", [(), (250.0, 500.0, 1000.0, 2000.0, 4000.0)])
def test_pooled_alpha_goes_to_one_in_incoherent_noise(bands):
    """Independent white noise per mic (closed form alpha = 1 in every bin): the pooled weight (whole band or
    octaves, prior 0) averages >= 0.95 after 1 s in every bin from 150 Hz to 1.7 kHz, where the differential
    path is >= 4 dB noisier than the delay-and-sum (as the per-bin test in test_robust_eb; above it the gate's
    selection of cells biases the ratio: 0.89 at 2-4 kHz with octaves)."""
    white = np.random.default_rng(31).standard_normal((2, 6 * FS))
    r = make("eb-robust", mix_bands_hz=bands, mix_alpha0=0.0).process(white, FS)
    alpha = r.trace["alpha"][FS // 128:].mean(axis=0)
    band = (F_HZ >= 150) & (F_HZ <= 1700)
    assert alpha[band].min() >= 0.95, alpha[band].min()


def test_pooled_alpha_stays_off_for_a_rear_plane_wave(rng):
    """White noise from 135 deg (closed form alpha = 0: the differential null removes it): pooled over the whole
    band, alpha <= 0.05 on average after 3 s in every bin."""
    x = plane_wave_pair(rng.standard_normal(6 * FS), az_deg=135)
    alpha = make("eb-robust", mix_bands_hz=()).process(x, FS).trace["alpha"][3 * FS // 128:].mean(axis=0)
    assert alpha.max() <= 0.05


def test_pooled_alpha_ramps_from_its_prior(rng):
    """The ramp: the first frame applies the prior exactly; with ramp_cells = n cells learned so far the weight
    applied is alpha0 + (n / ramp) (alpha_ls - alpha0) (closed form, to 1e-12 against the unramped run)."""
    F, Kb = 40, 8
    g = lambda: rng.standard_normal((F, Kb)) + 1j * rng.standard_normal((F, Kb))  # noqa: E731
    Yo, n = g(), g()
    Yd = Yo + n
    z = np.zeros(1)
    kw = dict(onehot=np.ones((Kb, 1)), lam=0.9, eps=0.0, alpha0=0.5)
    a0, *_ = pooled_mix_step(Yd, Yd - Yo, np.ones((F, Kb)), None, z, z, z, z, **kw)
    a1, *_ = pooled_mix_step(Yd, Yd - Yo, np.ones((F, Kb)), None, z, z, z, z, ramp_cells=1e3, **kw)
    learned = np.arange(F) * Kb  # cells learned before each frame
    expected = 0.5 + np.minimum(1.0, learned / 1e3)[:, None] * (a0 - 0.5)
    assert np.all(a1[0] == 0.5)
    np.testing.assert_allclose(a1, expected, rtol=0, atol=1e-12)


def test_pooled_modes_are_opt_in():
    """Defaults run the compiled kernel as before; any pooled field sends eb-robust to the numpy reference; a
    bad value is a one-line parameter error."""
    assert fast_frames.kernel_supports(make("eb-robust").params)
    for kw in ({"mix_bands_hz": ()}, {"mix_ramp_cells": 10.0}):
        assert not fast_frames.kernel_supports(make("eb-robust", **kw).params)
    from scenesim.errors import ParameterError

    for kw in ({"beta_model": "direction"}, {"mix_bands_hz": (2000.0, 1000.0)}, {"mix_bands_hz": [1000.0]}):
        with pytest.raises(ParameterError):
            make("eb-robust", **kw)


