"""Audio I/O round trips and resampling.

Oracles: the written array itself (FLOAT is exact to float32 rounding, PCM_16 to one
quantisation step 1/32768) and, for resampling, a tone's analytic samples.
"""

from __future__ import annotations

import numpy as np
import pytest
import soundfile as sf

from scenesim.audio import read_audio, resample, write_audio
from scenesim.errors import DataError, ParameterError


def test_float_round_trip(tmp_path, rng):
    x = rng.uniform(-1.5, 1.5, (2, 1000))  # FLOAT may exceed full scale
    write_audio(tmp_path / "a.wav", x, 16000)
    y, fs = read_audio(tmp_path / "a.wav")
    assert fs == 16000 and y.shape == (2, 1000) and y.dtype == np.float64
    np.testing.assert_allclose(y, x, rtol=1e-7, atol=1e-7)  # float32 rounding


def test_pcm16_round_trip(tmp_path, rng):
    x = rng.uniform(-0.99, 0.99, (1, 1000))
    write_audio(tmp_path / "b.wav", x[0], 8000, subtype="PCM_16")
    y, fs = read_audio(tmp_path / "b.wav")
    assert fs == 8000 and y.shape == (1, 1000)
    np.testing.assert_allclose(y, x, atol=1.0 / 32768)
    assert sf.info(str(tmp_path / "b.wav")).subtype == "PCM_16"


def test_pcm_refuses_clipping_unless_normalized(tmp_path):
    x = np.array([[0.5, -2.0, 1.5]])
    with pytest.raises(ParameterError, match="x"):
        write_audio(tmp_path / "c.wav", x, 16000, subtype="PCM_16")
    assert not (tmp_path / "c.wav").exists()
    write_audio(tmp_path / "c.wav", x, 16000, subtype="PCM_16", normalize=True)
    y, _ = read_audio(tmp_path / "c.wav")
    np.testing.assert_allclose(y, x * 0.99 / 2.0, atol=1.0 / 32768)


def test_write_refuses_nan_and_leaves_no_temp_file(tmp_path):
    with pytest.raises(ParameterError, match="x"):
        write_audio(tmp_path / "d.wav", np.array([0.0, np.nan]), 16000)
    with pytest.raises(ParameterError, match="subtype"):
        write_audio(tmp_path / "d.wav", np.zeros(10), 16000, subtype="MP3")
    with pytest.raises(ParameterError, match="path"):
        write_audio(tmp_path / "d.xyz", np.zeros(10), 16000)
    assert list(tmp_path.iterdir()) == []


def test_read_resamples(tmp_path):
    # Oracle: a 440 Hz tone sampled at 16 kHz directly; 1e-3 in the interior (polyphase
    # filter ripple), edges excluded because of the filter's transient.
    t44 = np.arange(44100) / 44100
    write_audio(tmp_path / "e.wav", 0.5 * np.sin(2 * np.pi * 440 * t44), 44100, subtype="DOUBLE")
    y, fs = read_audio(tmp_path / "e.wav", fs=16000)
    assert fs == 16000 and y.shape == (1, 16000)
    t16 = np.arange(16000) / 16000
    np.testing.assert_allclose(
        y[0, 500:-500], 0.5 * np.sin(2 * np.pi * 440 * t16)[500:-500], atol=1e-3
    )
    assert resample(np.ones((2, 10)), 16000, 16000).shape == (2, 10)


def test_unreadable_and_empty_files_raise_data_error_naming_the_file(tmp_path):
    bad = tmp_path / "bad.wav"
    bad.write_bytes(b"not audio at all")
    with pytest.raises(DataError, match="bad.wav"):
        read_audio(bad)
    with pytest.raises(DataError, match="missing.wav"):
        read_audio(tmp_path / "missing.wav")
    empty = tmp_path / "empty.wav"
    sf.write(str(empty), np.zeros((0, 1)), 16000)
    with pytest.raises(DataError, match="empty.wav"):
        read_audio(empty)


@pytest.mark.parametrize("rate", [1, 100_000_000])
def test_every_reader_holds_the_header_rate_to_the_range_of_fs(tmp_path, rate):
    """read_audio (simulate --speech, the API) refuses a 1 Hz or 100 MHz header before reading; the data
    folder scan lists such a file as unusable with its rate (it used to hang or ask for 132 GiB)."""
    import soundfile as sf

    from data_recipes.local import check_audio_file
    from scenesim.audio import read_audio
    from scenesim.errors import DataError

    path = tmp_path / "odd.wav"
    sf.write(path, np.zeros(4000), rate)
    with pytest.raises(DataError, match=rf"odd.wav says its sample rate is {rate} Hz: expected a rate in \[8000"):
        read_audio(path, fs=16000)
    x, fs, reason = check_audio_file(path)
    assert x is None and reason.startswith(f"header sample rate is {rate} Hz")
