"""Two-channel WPE (enhancers.peers.wpe) against nara-wpe's own wpe_v7, its replay, and what it does to reverberation.

Skips with a reason when the optional package is absent (pip install -e '.[wpe]').
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import fftconvolve

from benchmarks.metrics import speech as M
from benchmarks.metrics.srmr import srmr
from scenesim.errors import ParameterError

pytest.importorskip("nara_wpe", reason="optional extra not installed: pip install -e '.[wpe]'")

from nara_wpe.wpe import wpe_v7  # noqa: E402

import enhancers  # noqa: E402
import scenesim  # noqa: E402
from data_recipes.artificial_voice import artificial_voice  # noqa: E402
from enhancers.peers.wpe import Wpe  # noqa: E402

FS = 16000


def test_output_is_nara_wpe_v7(rng):
    """Oracle: nara_wpe.wpe.wpe_v7 on the same STFT (the filter is computed with the same
    arithmetic, conjugates hoisted out of the loop): equal to 1e-12 relative."""
    x = 0.1 * rng.standard_normal((2, 3 * FS))
    e = Wpe(taps=8, delay=2, iterations=3)
    expected = e._istft(wpe_v7(e._stft(x), taps=8, delay=2, iterations=3), x.shape[1])
    np.testing.assert_allclose(e.process(x, FS).output, expected, rtol=0, atol=1e-12 * np.max(np.abs(expected)))


def test_replay_is_the_same_linear_filter(rng):
    """Once estimated, WPE is linear: replay(s) + replay(n) == output of s + n (1e-12), replay(x) == output."""
    s, n = 0.1 * rng.standard_normal((2, 2, 2 * FS))
    result = Wpe().process(s + n, FS)
    scale = np.max(np.abs(result.output))
    np.testing.assert_allclose(result.replay(s) + result.replay(n), result.output, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(result.replay(s + n), result.output, rtol=0, atol=1e-12 * scale)


def test_bad_params_are_refused():
    with pytest.raises(ParameterError, match="taps"):
        Wpe(taps=0)
    with pytest.raises(ParameterError, match="stft_shift"):
        Wpe(stft_size=256, stft_shift=200)


def _room_pair(rt60_s: float):
    """Artificial voice (6 s) at the 2.14 cm pair in a 6 x 5 x 3 m room; RT60 0 = anechoic (absorption 1).

    Returns the two mic signals (2, n) and the target, direct path + 50 ms at mic 0 (n,), same scale."""
    s, _ = artificial_voice(6.0, fs=FS, seed=1)
    room = (scenesim.ShoeBox(dims_m=(6, 5, 3), absorption=1.0) if rt60_s == 0
            else scenesim.ShoeBox(dims_m=(6, 5, 3), rt60_s=rt60_s))
    h = scenesim.image_source_rir(room, (2, 3, 1.5), [(4, 2, 1.2), (4.0214, 2, 1.2)], fs=FS)
    x = np.stack([fftconvolve(s, hh)[: s.size] for hh in h])
    early = h[0].copy()
    early[int(np.argmax(np.abs(h[0]))) + int(0.05 * FS):] = 0.0
    target = fftconvolve(s, early)[: s.size]
    scale = 0.05 / np.std(x)
    return scale * x, scale * target


def test_dereverberates_at_rt60_0_8():
    """RT60 0.8 s: SRMR of mic 0 rises from 2.51 to 2.83 and SI-SDR against the direct path +
    50 ms from 1.8 to 3.1 dB (measured); pinned: SRMR up >= 0.2, SI-SDR up >= 1 dB."""
    x, target = _room_pair(0.8)
    y = Wpe().process(x, FS).output
    assert srmr(y[0], FS) >= srmr(x[0], FS) + 0.2
    assert M.si_sdr_db(target, y[0]) >= M.si_sdr_db(target, x[0]) + 1.0


def test_leaves_anechoic_speech_almost_unchanged():
    """RT60 0 (what the report says WPE does there): nothing to predict, so the output is the
    input to within -36.6 dB (SI-SDR 36.6 dB measured; pinned >= 30 dB) and SRMR changes by < 0.01."""
    x, _ = _room_pair(0.0)
    y = Wpe().process(x, FS).output
    assert M.si_sdr_db(x[0], y[0]) >= 30.0
    assert abs(srmr(y[0], FS) - srmr(x[0], FS)) < 0.01


def test_chains_feed_the_two_dereverberated_mics_to_the_beamformer():
    for name, n_stages in (("wpe-eb-robust", 2), ("wpe-eb-robust-ss", 3)):
        chain = enhancers.make(name)
        assert len(chain.stage_enhancers) == n_stages and chain.stage_enhancers[0].name == "wpe"
        assert (chain.tags.channels_in, chain.tags.channels_out, chain.tags.replayable) == (2, 1, True)
