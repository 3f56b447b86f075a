"""``open_data`` / ``DataSource``: built-in default, local directory, fallbacks, provenance."""

from __future__ import annotations

import pickle
import warnings

import numpy as np
import pytest

from data_recipes.source import DataFallbackWarning, open_data
from scenesim.errors import DataError, ParameterError

FS = 16000


@pytest.fixture
def no_env(monkeypatch):
    monkeypatch.delenv("SCENESIM_DATA", raising=False)


def test_builtin_gives_speech_and_thesis_noises_without_warnings(no_env):
    ds = open_data(fs=FS)
    assert ds.description.startswith("built-in")
    assert {"babble", "factory", "wind"} <= set(ds.noise_types())
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the built-in source synthesizes by design: no warning
        speech = ds.speech(2.0, seed=4)
        assert speech.source == "artificial-voice"
        assert speech.signal.shape == (2 * FS,) and speech.fs == FS
        assert "seed=4" in speech.files[0]
        for noise_type in ("babble", "factory", "wind"):
            clip = ds.noise(noise_type, 1.5, seed=4)
            assert clip.source == f"synthetic:{noise_type}"
            assert clip.signal.shape == (int(1.5 * FS),)
            assert np.all(np.isfinite(clip.signal))


def test_builtin_is_deterministic_per_seed(no_env):
    ds = open_data(fs=FS)
    np.testing.assert_array_equal(ds.speech(1.0, seed=1).signal, ds.speech(1.0, seed=1).signal)
    assert not np.allclose(ds.speech(1.0, seed=1).signal, ds.speech(1.0, seed=2).signal)
    a, b = ds.noise("factory", 1.0, seed=3), ds.noise("factory", 1.0, seed=3)
    np.testing.assert_array_equal(a.signal, b.signal)


def test_two_channel_noise_has_independent_channels(no_env):
    clip = open_data(fs=FS).noise("wind", 2.0, seed=0, n_channels=2)
    assert clip.signal.shape == (2, 2 * FS)
    assert not np.allclose(clip.signal[0], clip.signal[1])


def test_unknown_noise_type_lists_available_types(no_env):
    with pytest.raises(ParameterError, match="noise_type") as info:
        open_data(fs=FS).noise("rain", 1.0, seed=0)
    assert "babble" in str(info.value) and "wind" in str(info.value)


def test_local_dir_speech_files_wind_file_factory_synthesized(shared_data_dir):
    ds = open_data(shared_data_dir, fs=FS)
    assert ds.description == f"local:{shared_data_dir.resolve()}"
    assert {"cafe", "dishes", "machinery", "wind", "babble", "factory"} <= set(ds.noise_types())
    speech = ds.speech(12.0, seed=1)
    assert speech.source.startswith("local:")
    assert speech.signal.shape == (12 * FS,)
    assert len(speech.files) >= 3 and all("/speech/" in f for f in speech.files)
    wind = ds.noise("wind", 20.0, seed=1, n_channels=2)  # longer than the 14.8 s file: looped
    assert wind.source.startswith("local:") and all("wind_cc0.wav" in f for f in wind.files)
    assert wind.signal.shape == (2, 20 * FS)
    assert not np.allclose(wind.signal[0], wind.signal[1])  # different offsets
    with pytest.warns(DataFallbackWarning, match="factory"):
        factory = ds.noise("factory", 2.0, seed=1)
    assert factory.source == "synthetic:factory"


def test_local_babble_is_built_from_local_speech(shared_data_dir):
    ds = open_data(shared_data_dir, fs=FS)
    with pytest.warns(DataFallbackWarning, match="babble"):
        clip = ds.noise("babble", 2.0, seed=0)
    assert sum("/speech/" in f for f in clip.files) == 6


def test_env_var_selects_the_directory(shared_data_dir, monkeypatch):
    monkeypatch.setenv("SCENESIM_DATA", str(shared_data_dir))
    assert open_data(fs=FS).description.startswith("local:")
    # The argument wins over the environment.
    assert open_data(shared_data_dir / "speech" / "..", fs=FS).description.startswith("local:")


def test_resampled_delivery_and_pickling(shared_data_dir):
    ds = open_data(shared_data_dir, fs=8000)
    clip = ds.noise("cafe", 1.0, seed=2)
    assert clip.signal.shape == (8000,) and clip.fs == 8000
    again = pickle.loads(pickle.dumps(ds)).noise("cafe", 1.0, seed=2)
    np.testing.assert_array_equal(clip.signal, again.signal)


def test_bad_files_are_skipped_with_a_warning_naming_them(tmp_path):
    (tmp_path / "speech").mkdir()
    (tmp_path / "speech" / "broken.wav").write_bytes(b"not audio at all")
    import soundfile as sf

    sf.write(str(tmp_path / "speech" / "ok.wav"), 0.1 * np.random.default_rng(0).standard_normal(FS), FS)
    with pytest.warns(DataFallbackWarning, match="broken.wav"):
        ds = open_data(tmp_path, fs=FS)
    assert ds.speech(1.0, seed=0).files == (str((tmp_path / "speech" / "ok.wav").resolve()),)


def test_directory_with_nothing_usable_is_a_data_error(tmp_path):
    (tmp_path / "speech").mkdir()
    (tmp_path / "speech" / "broken.wav").write_bytes(b"")
    with pytest.warns(DataFallbackWarning), pytest.raises(DataError, match="no usable audio"):
        open_data(tmp_path, fs=FS)


def test_directory_made_by_cmu_arctic_recipe_is_described_as_such(tmp_path):
    import json

    import soundfile as sf

    (tmp_path / "speech").mkdir()
    noise = 0.1 * np.random.default_rng(0).standard_normal(FS)
    sf.write(str(tmp_path / "speech" / "cmu_arctic_us_slt_a0001.wav"), noise, FS)
    (tmp_path / "manifest.json").write_text(json.dumps({"recipe": "cmu-arctic", "files": []}))
    clip = open_data(tmp_path, fs=FS).speech(1.0, seed=0)
    assert clip.source == f"cmu-arctic:{tmp_path.resolve()}"


def test_looping_crossfade_weights_sum_to_one():
    # Oracle: complementary raised-cosine ramps sum to 1, so a looped constant stays constant.
    from data_recipes.source import _loop

    y = _loop(np.ones(1000), 3500, FS)
    assert y.size >= 3500
    np.testing.assert_allclose(y[:3500], 1.0, atol=1e-12)


def test_bad_arguments_name_the_parameter(no_env):
    ds = open_data(fs=FS)
    with pytest.raises(ParameterError, match="duration_s"):
        ds.speech(0.0, seed=0)
    with pytest.raises(ParameterError, match="seed"):
        ds.noise("wind", 1.0, seed=-1)
    with pytest.raises(ParameterError, match="n_channels"):
        ds.noise("wind", 1.0, seed=0, n_channels=0)
    with pytest.raises(ParameterError, match="fs"):
        open_data(fs=0)
    with pytest.raises(DataError, match="does not exist"):
        open_data("/nonexistent/scenesim-data", fs=FS)
