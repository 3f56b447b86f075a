"""Black-box peers (webrtc-ns, rnnoise), their frame-buffering base and the 16 <-> 48 kHz resampler.

The peers' tests skip with a reason when the optional package is absent; the base's tests
(a frame-identity toy) and the "not installed" listing always run.
"""

from __future__ import annotations

import subprocess
import sys
from typing import ClassVar

import numpy as np
import pytest
import soundfile
from scipy.signal import lfilter

from benchmarks.metrics import speech as M
from enhancers.peers.blackbox import FramedBlackBox, Resampler16to48, _lowpass
from enhancers.testing import stream

FS = 16000


class _FrameIdentity(FramedBlackBox):
    """Frames of 160 returned unchanged (plus a frame counter in the engine)."""

    name = "toy-frame-identity"
    frame_samples: ClassVar[int] = 160

    def _open(self):
        return {"frames": 0}

    def _run_frame(self, engine, frame):
        engine["frames"] += 1
        return frame.copy()


def test_framing_delays_by_frame_minus_one_and_streams_exactly(rng):
    """Oracle: an identity library gives the input delayed by exactly F - 1 = 159 samples; blocks of
    1, 97, 160 and 1000 samples give the batch output bit for bit."""
    e = _FrameIdentity()
    x = rng.standard_normal((1, 1234))
    y = e.process(x, FS).output
    assert e.tags.latency_samples == 159 and not e.tags.replayable
    np.testing.assert_array_equal(y[0, 159:], x[0, :-159])
    np.testing.assert_array_equal(y[0, :159], 0.0)
    for block in (1, 97, 160, 1000):
        np.testing.assert_array_equal(stream(e, x, FS, block), y)


class _LfilterResampler:
    """Slow reference: the former implementation (zero-stuffing, then the whole 97-tap FIR by
    scipy.signal.lfilter with state, decimation of the full-rate output)."""

    def __init__(self):
        self.h = _lowpass()
        self.zi_up, self.zi_down = np.zeros(96), np.zeros(96)

    def up(self, x16):
        up = np.zeros(3 * x16.size)
        up[::3] = x16
        up, self.zi_up = lfilter(3 * self.h, 1.0, up, zi=self.zi_up)
        return up

    def down(self, y48):
        down, self.zi_down = lfilter(self.h, 1.0, y48, zi=self.zi_down)
        return down[::3]


def test_polyphase_resampler_equals_the_full_rate_filter(rng):
    """Oracle: the full-rate FIR (lfilter, slow reference) on the same frames; the polyphase
    sums reorder the same products, so they agree to 1e-14 (measured <= 2e-16 at unit level)."""
    r, ref = Resampler16to48(), _LfilterResampler()
    for k in (160, 160, 1, 7, 33, 500):
        x = rng.standard_normal(k)
        up = r.up(x)
        np.testing.assert_allclose(up, ref.up(x), rtol=0, atol=1e-14)
        y = rng.standard_normal(3 * k)
        np.testing.assert_allclose(r.down(y), ref.down(y), rtol=0, atol=1e-14)


def test_polyphase_resampler_streams_bit_exactly_and_scales_into_a_float32_buffer(rng):
    """Blocks of 1, 7, 32 and 161 samples give the one-call output bit for bit (every output
    sample is the same sum in the same order); up_into = clip(gain * up) rounded to float32
    (oracle: numpy on the float64 output), down's gain = a product after the filter."""
    x = rng.standard_normal(1000)
    whole = Resampler16to48().up(x)
    for k in (1, 7, 32, 161):
        r = Resampler16to48()
        np.testing.assert_array_equal(np.concatenate([r.up(x[i:i + k]) for i in range(0, x.size, k)]), whole)
        r = Resampler16to48()
        down = np.concatenate([r.down(whole[i:i + 3 * k]) for i in range(0, whole.size, 3 * k)])
        np.testing.assert_array_equal(down, Resampler16to48().down(whole))
    buf = np.empty(3 * x.size, dtype=np.float32)
    Resampler16to48().up_into(x, buf, 3.0, -2.0, 2.5)
    np.testing.assert_array_equal(buf, np.clip(3.0 * whole, -2.0, 2.5).astype(np.float32))
    np.testing.assert_array_equal(Resampler16to48().down(whole, 0.25), 0.25 * Resampler16to48().down(whole))
    with pytest.raises(ValueError, match="multiple of 3"):
        Resampler16to48().down(whole[:10])


def _speech(shared_data_dir, n_files=3):
    files = sorted((shared_data_dir / "speech").glob("cmu_arctic_*.wav"))[:n_files]
    s = np.concatenate([soundfile.read(f, dtype="float64")[0] for f in files])[None]
    return 0.05 * s / np.std(s)  # -26 dBFS, the level of the rendered scenes


def _level_db(x):
    return 10 * np.log10(np.mean(np.square(x)))


def _phase_inversion_snr_i(e, s, n):
    """SNR improvement measured as the benchmark measures black boxes (benchmarks.metrics.evaluate)."""
    L, start = e.tags.latency_samples, 2 * FS
    y1, y2 = e.process(s + n, FS).output, e.process(s - n, FS).output
    s_out, n_out = 0.5 * (y1 + y2), 0.5 * (y1 - y2)
    return (_level_db(s_out[:, start + L:]) - _level_db(n_out[:, start + L:])
            - (_level_db(s[:, start:-L]) - _level_db(n[:, start:-L])))


def _noise_attenuation(e, rng):
    x = 0.05 * rng.standard_normal((1, 5 * FS))
    y = e.process(x, FS).output
    L, start = e.tags.latency_samples, 2 * FS
    return _level_db(x[:, start:-L]) - _level_db(y[:, start + L:])


# -- webrtc-ns -------------------------------------------------------------------------------
@pytest.fixture
def webrtc():
    pytest.importorskip("webrtc_noise_gain", reason="optional extra not installed: pip install -e '.[webrtc]'")
    from enhancers.peers.webrtc_ns import WebrtcNoiseSuppression

    return WebrtcNoiseSuppression


@pytest.mark.parametrize(("level", "lo", "hi"), [(2, 11.0, 13.5), (4, 20.0, 22.5)])
def test_webrtc_white_noise_attenuation_matches_its_level(webrtc, rng, level, lo, hi):
    """Oracle: WebRTC's documented suppression targets, moderate 12 dB (level 2) and very high
    21 dB (level 4); measured 12.2 and 21.3 dB on white noise at -26 dBFS after 2 s."""
    assert lo <= _noise_attenuation(webrtc(noise_suppression_level=level), rng) <= hi


def test_webrtc_latency_and_snr_improvement_on_speech(webrtc, rng, shared_data_dir):
    """Real speech: the output's cross-correlation lag is the declared 255 samples (+-3: the
    high-pass filter's phase moves the peak; measured 252-255); at 5 dB white noise, SNR-I by
    phase inversion measured 8.9 dB, pinned >= 8.0 dB."""
    e = webrtc()
    s = _speech(shared_data_dir)
    lag = M.estimate_lag(e.process(s, FS).output[0], s[0], max_lag=1000)
    assert abs(lag - e.tags.latency_samples) <= 3
    n = rng.standard_normal(s.shape)
    n *= np.sqrt(np.mean(s**2) / np.mean(n**2) / 10**0.5)
    assert _phase_inversion_snr_i(e, s, n) >= 8.0


# -- rnnoise ---------------------------------------------------------------------------------
@pytest.fixture
def rnnoise():
    pytest.importorskip("pyrnnoise", reason="optional extra not installed: pip install -e '.[rnnoise]'")
    from enhancers.peers.rnnoise import RNNoise

    return RNNoise


def test_rnnoise_white_noise_is_removed(rnnoise, rng):
    """White noise alone at -26 dBFS: measured 33-39 dB attenuation (seeds 1, 2), pinned >= 30 dB."""
    assert _noise_attenuation(rnnoise(), rng) >= 30.0


def test_rnnoise_latency_and_snr_improvement_on_speech(rnnoise, rng, shared_data_dir):
    """Real speech: lag of the output exactly the declared 511 samples (+-1) for each of 3 utterances;
    at 5 dB white noise, SNR-I by phase inversion measured 11.9-12.0 dB, pinned >= 11.0 dB."""
    e = rnnoise()
    for f in sorted((shared_data_dir / "speech").glob("cmu_arctic_*.wav"))[:3]:
        s = 0.5 * soundfile.read(f, dtype="float64")[0]
        assert abs(M.estimate_lag(e.process(s[None], FS).output[0], s, max_lag=1000) - 511) <= 1
    s = _speech(shared_data_dir)
    n = rng.standard_normal(s.shape)
    n *= np.sqrt(np.mean(s**2) / np.mean(n**2) / 10**0.5)
    assert _phase_inversion_snr_i(e, s, n) >= 11.0


# -- listing when the packages are absent ------------------------------------------------------
def test_bench_list_says_how_to_install_absent_peers():
    """With both packages hidden (sys.modules[name] = None makes find_spec report them absent),
    `scenesim bench list` shows the pip command and make() raises EnhancerNotInstalled."""
    code = (
        "import sys; sys.modules['webrtc_noise_gain'] = None; sys.modules['pyrnnoise'] = None\n"
        "from benchmarks.cli.main import main\n"
        "main(['bench', 'list'])\n"
        "import enhancers\n"
        "from enhancers.core.registry import EnhancerNotInstalled\n"
        "try:\n    enhancers.make('rnnoise')\nexcept EnhancerNotInstalled as exc:\n    print('MAKE:', exc)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    lines = {line.split()[0]: line for line in out.splitlines() if line.startswith("  ") and line.split()}
    assert "not installed: pip install -e '.[webrtc]'" in lines["webrtc-ns"]
    assert "not installed: pip install -e '.[rnnoise]'" in lines["rnnoise"]
    assert "MAKE: enhancer 'rnnoise' is not installed: pip install -e '.[rnnoise]'" in out
