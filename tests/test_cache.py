"""scenesim.room.cache.cached_array and its users (babble bank, MS1994 bias compensation).

Oracles: a call counter on ``compute`` (computed once, then loaded), the recomputed value
itself (bit-identical, ``assert_array_equal``: the cache stores exactly what was computed),
and the files left in the cache directory.  A "fresh process" is simulated by clearing the
in-memory LRU and the ``functools.lru_cache`` in front of each user.
"""

from __future__ import annotations

import numpy as np
import pytest

from data_recipes import noise_synthesis
from enhancers.single import noise_tracking
from scenesim.errors import ParameterError
from scenesim.room import cache


def _fresh_process() -> None:
    cache.clear_memory_cache()
    noise_synthesis._artificial_babble_bank.cache_clear()
    noise_tracking._calibrate_cached.cache_clear()


class _Counter:
    def __init__(self, value: np.ndarray):
        self.value, self.calls = value, 0

    def __call__(self) -> np.ndarray:
        self.calls += 1
        return self.value


def test_computed_once_then_loaded_from_disk(tmp_path):
    key = cache.array_key("test-once", 1, n=5)
    compute = _Counter(np.arange(10, dtype=np.int32).reshape(2, 5))
    _fresh_process()
    a = cache.cached_array(key, compute, cache_dir=tmp_path)
    assert compute.calls == 1
    assert [p.name for p in tmp_path.iterdir()] == [f"{key}.npy"]  # no temporary file left
    b = cache.cached_array(key, compute, cache_dir=tmp_path)  # memory hit
    a[:] = -1  # the caller's copy: the cache is untouched
    _fresh_process()
    c = cache.cached_array(key, compute, cache_dir=tmp_path)  # disk hit
    assert compute.calls == 1
    for x in (b, c):
        np.testing.assert_array_equal(x, compute.value)
        assert x.dtype == np.int32 and x.flags.writeable


def test_corrupt_file_is_recomputed_and_rewritten(tmp_path):
    key = cache.array_key("test-corrupt", 1)
    compute = _Counter(np.linspace(0.0, 1.0, 7))
    path = tmp_path / f"{key}.npy"
    for torn in (b"", b"torn", np.lib.format.MAGIC_PREFIX + b"\x01\x00garbage"):
        path.write_bytes(torn)
        _fresh_process()
        calls = compute.calls
        np.testing.assert_array_equal(cache.cached_array(key, compute, cache_dir=tmp_path), compute.value)
        assert compute.calls == calls + 1
        np.testing.assert_array_equal(np.load(path), compute.value)


def test_leftover_tmp_file_is_ignored(tmp_path):
    # A writer killed between mkstemp and os.replace leaves "<key>.<random>.tmp" behind.
    key = cache.array_key("test-tmp", 1)
    (tmp_path / f"{key}.abc123.tmp").write_bytes(b"half a file")
    compute = _Counter(np.ones(3))
    _fresh_process()
    np.testing.assert_array_equal(cache.cached_array(key, compute, cache_dir=tmp_path), np.ones(3))
    assert compute.calls == 1
    np.testing.assert_array_equal(np.load(tmp_path / f"{key}.npy"), np.ones(3))


def test_unwritable_cache_dir_warns_and_still_returns(tmp_path):
    not_a_dir = tmp_path / "file"
    not_a_dir.write_bytes(b"")
    compute = _Counter(np.arange(3.0))
    _fresh_process()
    with pytest.warns(RuntimeWarning, match="cannot write the disk cache"):
        out = cache.cached_array(cache.array_key("test-readonly", 1), compute, cache_dir=not_a_dir)
    np.testing.assert_array_equal(out, compute.value)


def test_no_disk_cache_when_env_is_empty(tmp_path, monkeypatch):
    monkeypatch.setenv("SCENESIM_CACHE", "")
    monkeypatch.chdir(tmp_path)
    assert cache._cache_dir(None) is None
    compute = _Counter(np.zeros(2))
    _fresh_process()
    cache.cached_array(cache.array_key("test-empty", 1), compute)
    assert compute.calls == 1 and list(tmp_path.iterdir()) == []


def test_keys_differ_by_kind_version_and_params():
    keys = {
        cache.array_key("a", 1, x=1.0),
        cache.array_key("b", 1, x=1.0),
        cache.array_key("a", 2, x=1.0),
        cache.array_key("a", 1, x=1.5),
        cache.array_key("a", 1, y=1.0),
    }
    assert len(keys) == 5
    assert cache.array_key("a", 1, x=1.0) == cache.array_key("a", 1, x=1)  # canonical floats


def test_bad_key_is_rejected(tmp_path):
    for key in ("", "../escape", "a.b"):
        with pytest.raises(ParameterError, match="key"):
            cache.cached_array(key, lambda: np.zeros(1), cache_dir=tmp_path)


def test_babble_bank_key_holds_everything_it_depends_on(tmp_path, monkeypatch):
    """A cheap stand-in voice counts generator calls: a changed input must recompute."""
    calls = []

    def fake_voice(duration_s, *, fs, seed, talker):
        calls.append(seed)
        return np.full(int(round(duration_s * fs)), seed, dtype=float), talker

    monkeypatch.setattr(noise_synthesis, "artificial_voice", fake_voice)
    monkeypatch.setenv("SCENESIM_CACHE", str(tmp_path))
    n_talkers = len(noise_synthesis.TALKERS)

    def bank_calls(fs=8000):
        _fresh_process()
        before = len(calls)
        noise_synthesis._artificial_babble_bank(fs)
        return len(calls) - before

    assert bank_calls() == n_talkers
    assert bank_calls() == 0  # loaded from disk
    assert bank_calls(fs=16000) == n_talkers
    monkeypatch.setattr(noise_synthesis, "VOICE_VERSION", noise_synthesis.VOICE_VERSION + 1)
    assert bank_calls() == n_talkers
    monkeypatch.setattr(noise_synthesis, "BABBLE_BANK_S", 1.0)
    assert bank_calls() == n_talkers
    monkeypatch.setattr(noise_synthesis, "BABBLE_BANK_SEED", 7)
    assert bank_calls() == n_talkers
    monkeypatch.setattr(noise_synthesis, "TALKERS", noise_synthesis.TALKERS[::-1])
    assert bank_calls() == n_talkers
    _fresh_process()


def _bank_signals(fs: int) -> np.ndarray:
    _fresh_process()
    return np.stack([item.signal for item in noise_synthesis._artificial_babble_bank(fs)])


def test_babble_bank_bit_identical_with_and_without_disk_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SCENESIM_CACHE", "")
    direct = _bank_signals(8000)  # computed, memory only
    monkeypatch.setenv("SCENESIM_CACHE", str(tmp_path))
    written = _bank_signals(8000)  # computed and written
    loaded = _bank_signals(8000)  # read back from disk
    assert len(list(tmp_path.glob("*.npy"))) == 1
    np.testing.assert_array_equal(written, direct)
    np.testing.assert_array_equal(loaded, direct)
    bank = noise_synthesis._artificial_babble_bank(8000)
    assert [item.talker for item in bank] == [t.name for t in noise_synthesis.TALKERS]
    assert not bank[0].signal.flags.writeable
    _fresh_process()


def test_omin_bit_identical_with_and_without_disk_cache(tmp_path, monkeypatch):
    kwargs = dict(alpha=0.9, n_sub=4, sub_len=8, n_frames=3000)
    monkeypatch.setenv("SCENESIM_CACHE", "")
    _fresh_process()
    direct = noise_tracking.calibrate_omin(**kwargs)
    monkeypatch.setenv("SCENESIM_CACHE", str(tmp_path))
    _fresh_process()
    written = noise_tracking.calibrate_omin(**kwargs)
    _fresh_process()
    loaded = noise_tracking.calibrate_omin(**kwargs)
    assert len(list(tmp_path.glob("*.npy"))) == 1
    np.testing.assert_array_equal(written, direct)
    np.testing.assert_array_equal(loaded, direct)
    assert not loaded.flags.writeable
    _fresh_process()
    noise_tracking.calibrate_omin(**dict(kwargs, seed=1))  # another argument set: another file
    assert len(list(tmp_path.glob("*.npy"))) == 2
    _fresh_process()


def test_every_secondary_parameter_of_an_rir_reaches_its_cache_key(tmp_path):
    """Oracle: the uncached computation.  Memoised RIRs that differ only in a secondary
    parameter (high-pass corner, hybrid seed, scattering, image order, rate) are each the
    RIR of their own parameters, never the first one computed (1e-12 of the peak)."""
    from dataclasses import replace

    from scenesim.room.cache import cached_rir
    from scenesim.room.render import room_rir
    from scenesim.room.shoebox import ShoeBox

    cache.clear_memory_cache()
    room = ShoeBox((5.0, 4.0, 3.0), 0.3, scattering=0.5)
    src, mics = (1.0, 1.2, 1.4), np.array([(3.5, 2.5, 1.2)])
    base = dict(fs=16000, length_s=0.2, highpass_hz=20.0, seed=0)
    variants = [({}, room), ({"highpass_hz": 200.0}, room), ({"seed": 1}, room),
                ({}, replace(room, scattering=0.2)), ({"max_order": 3}, room), ({"fs": 8000}, room)]
    for change, r in variants:
        kw = {**base, **change}
        got = cached_rir(r, src, mics, cache_dir=tmp_path, **kw)
        want = room_rir(r, src, mics, **kw)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * np.abs(want).max(), err_msg=str(change))
