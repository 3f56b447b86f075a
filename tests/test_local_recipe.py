"""The ``local`` recipe: scanning ../shared/data, manifest, bad-file reports, conversion."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf

import data_recipes.registry as registry
from data_recipes.local import noise_type_from_name, scan_local, talker_from_name
from scenesim.errors import DataError, ParameterError


def _write_tone(path: Path, seconds: float, fs: int = 16000, amp: float = 0.1) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    t = np.arange(int(seconds * fs)) / fs
    sf.write(str(path), amp * np.sin(2 * np.pi * 440 * t), fs, subtype="PCM_16")


@pytest.fixture
def messy_dir(tmp_path: Path) -> Path:
    """A data dir with one good speech file, one good noise file and four bad files."""
    _write_tone(tmp_path / "speech" / "good.wav", 1.0)
    _write_tone(tmp_path / "noise" / "hum_test.wav", 1.0, fs=8000)
    (tmp_path / "speech" / "corrupt.wav").write_bytes(b"RIFF\x10\x00\x00\x00WAVEjunkjunkjunk")
    (tmp_path / "speech" / "empty.flac").write_bytes(b"")
    _write_tone(tmp_path / "speech" / "short.wav", 0.2)
    _write_tone(tmp_path / "noise" / "quiet_silent.wav", 1.0, amp=0.0)
    return tmp_path


def test_shared_data_has_nine_speech_files_and_four_noise_types(shared_data_dir):
    scan = scan_local(shared_data_dir)
    assert len(scan.speech) == 9
    assert scan.noise_types == ("cafe", "dishes", "machinery", "wind")
    assert scan.bad == ()


def test_shared_manifest_has_sha256_durations_and_talkers(shared_data_dir):
    manifest = scan_local(shared_data_dir).manifest()
    entries = manifest["speech"] + manifest["noise"]
    assert len(entries) == 13
    for entry in entries:
        assert re.fullmatch(r"[0-9a-f]{64}", entry["sha256"])
        info = sf.info(str(shared_data_dir / entry["file"]))
        # Oracle: soundfile's header (frames / samplerate); rounding to 1 us in the manifest.
        np.testing.assert_allclose(entry["duration_s"], info.frames / info.samplerate, atol=1e-6)
        assert entry["fs"] == info.samplerate
    talkers = {e["file"]: e["talker"] for e in manifest["speech"]}
    assert talkers["speech/cmu_arctic_us_aew_a0001.wav"] == "aew"
    assert talkers["speech/cmu_arctic_us_axb_a0005.wav"] == "axb"
    assert talkers["speech/cmu_arctic_awb_a0007.wav"] == "awb"
    assert talkers["speech/cmu_arctic_a0009.wav"] is None
    json.dumps(manifest)  # JSON-ready


def test_bad_files_are_reported_by_name(messy_dir):
    scan = scan_local(messy_dir)
    reasons = {b.path.name: b.reason for b in scan.bad}
    assert set(reasons) == {"corrupt.wav", "empty.flac", "short.wav", "quiet_silent.wav"}
    assert reasons["empty.flac"].startswith("empty")
    assert reasons["corrupt.wav"].startswith("unreadable")
    assert reasons["short.wav"].startswith("too short")
    assert reasons["quiet_silent.wav"].startswith("silent")
    assert [e.path.name for e in scan.speech] == ["good.wav"]
    assert scan.noise_types == ("hum",)


def test_strict_prepare_raises_listing_every_bad_file(messy_dir):
    with pytest.raises(DataError) as info:
        registry.prepare("local", src=messy_dir)
    for name in ("corrupt.wav", "empty.flac", "short.wav", "quiet_silent.wav"):
        assert name in str(info.value)


def test_lenient_prepare_converts_to_dest_with_manifest(messy_dir, tmp_path):
    dest = tmp_path / "out"
    manifest = registry.prepare("local", dest, src=messy_dir, fs=8000, strict=False)
    written = json.loads((dest / "manifest.json").read_text())
    assert written == manifest
    assert [e["file"] for e in manifest["speech"]] == ["speech/good.wav"]
    assert [e["file"] for e in manifest["noise"]] == ["noise/hum_test.wav"]
    assert all(e["fs"] == 8000 for e in manifest["speech"] + manifest["noise"])
    assert {Path(b["file"]).name for b in manifest["bad"]} == {
        "corrupt.wav", "empty.flac", "short.wav", "quiet_silent.wav"}
    # Resampling 16 kHz -> 8 kHz keeps the duration (1 s) to within one output sample.
    np.testing.assert_allclose(manifest["speech"][0]["duration_s"], 1.0, atol=1 / 8000)


def test_missing_or_empty_folder_is_a_data_error(tmp_path):
    with pytest.raises(DataError, match="does not exist"):
        scan_local(tmp_path / "nope")
    with pytest.raises(DataError, match="speech/"):
        scan_local(tmp_path)


def test_local_needs_src():
    with pytest.raises(ParameterError, match="src"):
        registry.prepare("local")


def test_name_parsing():
    assert talker_from_name("cmu_arctic_us_aew_a0001.wav") == "aew"
    assert talker_from_name("cmu_arctic_awb_a0007.wav") == "awb"
    assert talker_from_name("x/cmu_us_slt_arctic/wav/arctic_a0001.wav") == "slt"
    assert talker_from_name("cmu_arctic_a0009.wav") is None
    assert noise_type_from_name("machinery_exercise-bike_ccby.wav") == "machinery"
    assert noise_type_from_name("babble.wav") == "babble"


def _write_noise(path: Path, seconds: float, fs: int = 8000, seed: int = 0) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    x = 0.1 * np.random.default_rng(seed).standard_normal(int(seconds * fs))
    sf.write(str(path), x, fs, subtype="PCM_16")


def test_noisex92_files_become_typed_noise_files(tmp_path):
    src, dest = tmp_path / "noisex", tmp_path / "data"
    _write_noise(src / "babble.wav", 61.0)
    _write_noise(src / "factory1.wav", 61.0, seed=1)
    _write_noise(src / "Factory2.wav", 61.0, seed=2)
    _write_noise(src / "readme.wav", 61.0)  # not a NOISEX name: ignored
    manifest = registry.prepare("noisex92", dest, src=src, fs=16000)
    names = sorted(p.name for p in (dest / "noise").iterdir())
    assert names == ["babble_noisex92.wav", "factory_noisex92-2.wav", "factory_noisex92.wav"]
    assert scan_local(dest).noise_types == ("babble", "factory")
    for entry in manifest["files"]:
        assert entry["fs"] == 16000 and re.fullmatch(r"[0-9a-f]{64}", entry["sha256"])
        # 61 s at 8 kHz resampled to 16 kHz keeps its duration exactly (integer ratio 2).
        np.testing.assert_allclose(entry["duration_s"], 61.0, atol=1e-9)
    assert "white" in manifest["missing"]


def test_noisex92_rejects_short_files_by_name_and_empty_folders(tmp_path):
    _write_noise(tmp_path / "nx" / "white.wav", 5.0)
    with pytest.raises(DataError, match="white.wav"):
        registry.prepare("noisex92", tmp_path / "d", src=tmp_path / "nx")
    (tmp_path / "none").mkdir()
    with pytest.raises(DataError, match="babble.wav"):
        registry.prepare("noisex92", tmp_path / "d", src=tmp_path / "none")
