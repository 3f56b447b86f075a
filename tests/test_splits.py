"""Dev/test splits (issue 30): deterministic assignment, speakers kept whole, noise types never
emptied, the manifest, built-in seeds, and a split carried through sweeps, rows and reports."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf

from benchmarks.cli.main import main
from benchmarks.report.core import write_report
from benchmarks.run.runner import run_sweep
from benchmarks.run.sweep import parse_sweep
from benchmarks.store.sqlite import ResultStore
from data_recipes.artificial_voice import artificial_voice
from data_recipes.local import scan_local
from data_recipes.source import open_data
from data_recipes.splits import (
    SALT,
    TEST_FRACTION,
    plan_split,
    side_of,
    speaker_of,
    split_hash,
)
from scenesim.errors import ConfigError, ParameterError

FS = 16000
SPEAKERS = ("aew", "axb", "bdl", "slt", "clb", "rms")


def _wav(path: Path, x: np.ndarray) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    sf.write(str(path), x, FS, subtype="FLOAT")


def _tone(f_hz: float, seconds: float) -> np.ndarray:
    return 0.1 * np.sin(2 * np.pi * f_hz * np.arange(int(seconds * FS)) / FS)


def _hashing_to(side: str, stems, kind: str = "noise") -> list[str]:
    return [s for s in stems if side_of(f"{kind}/{s}") == side]


@pytest.fixture(scope="module")
def data_dir(tmp_path_factory) -> Path:
    """Six CMU-named speakers x 2 utterances of the artificial voice, two speech files of unknown
    speaker, noise type ``hum`` with one recording (300 Hz, then 2 kHz after 70 %: the split
    point), and type ``fan`` with four recordings, at least one hashed to each side."""
    root = tmp_path_factory.mktemp("splitdata")
    for k, spk in enumerate(SPEAKERS):
        for u in (1, 2):
            x, _ = artificial_voice(1.2, fs=FS, seed=100 + 2 * k + u)
            _wav(root / "speech" / f"cmu_arctic_us_{spk}_a000{u}.wav", x)
    for name in ("loose1", "loose2"):
        _wav(root / "speech" / f"{name}.wav", artificial_voice(1.2, fs=FS, seed=len(name) + int(name[-1]))[0])
    _wav(root / "noise" / "hum_only.wav", np.concatenate([_tone(300.0, 2.8), _tone(2000.0, 1.2)]))
    fans = [f"fan_{k}" for k in range(40)]
    chosen = _hashing_to("dev", fans)[:2] + _hashing_to("test", fans)[:2]
    rng = np.random.default_rng(7)
    for stem in chosen:
        _wav(root / "noise" / f"{stem}.wav", 0.1 * rng.standard_normal(2 * FS))
    return root


def test_assignment_is_deterministic_and_a_new_salt_redeals_it():
    """Oracle: the hash is a pure function; its test share over 2000 keys is the binomial
    mean 0.3 within 4 standard deviations (sqrt(0.3 * 0.7 / 2000) = 0.0102 -> +-0.041)."""
    keys = [f"speaker/s{k}" for k in range(2000)]
    first = [side_of(k) for k in keys]
    assert first == [side_of(k) for k in keys]
    assert abs(first.count("test") / len(keys) - TEST_FRACTION) < 0.041
    other = [side_of(k, salt=SALT + "-other") for k in keys]
    assert sum(a != b for a, b in zip(first, other)) > 500  # about 2 * 0.3 * 0.7 of them move
    assert 0.0 <= split_hash("x") < 1.0


def test_speaker_is_parsed_from_cmu_and_librispeech_names_else_none():
    assert speaker_of("cmu_arctic_us_aew_a0001.wav") == "aew"
    assert speaker_of("cmu_arctic_awb_a0007.wav") == "awb"
    assert speaker_of("cmu_arctic_a0009.wav") is None
    assert speaker_of("train/19/198/19-198-0001.flac") == "19"


def test_a_speaker_never_straddles_and_the_splits_share_no_file(data_dir):
    scan = scan_local(data_dir, hash_files=False)
    dev, test = plan_split(scan, "dev"), plan_split(scan, "test")
    assert plan_split(scan, "dev") == dev  # the same inputs, the same split
    files = {s: {p.entry.path for p in plan.speech} for s, plan in (("dev", dev), ("test", test))}
    assert files["dev"] and files["test"] and not files["dev"] & files["test"]
    assert files["dev"] | files["test"] == {e.path for e in scan.speech}
    speakers = {s: {speaker_of(f) for f in fs} - {None} for s, fs in files.items()}
    assert not speakers["dev"] & speakers["test"]
    expected_test = {s for s in SPEAKERS if side_of(f"speaker/{s}") == "test"}
    assert speakers["test"] == expected_test  # the hash decides where a speaker goes
    fans = {s: {p.entry.path.stem for p in plan.noise["fan"]} for s, plan in (("dev", dev), ("test", test))}
    assert fans["dev"] and fans["test"] and not fans["dev"] & fans["test"]
    assert all(p.whole for p in dev.noise["fan"] + test.noise["fan"])


def test_a_single_recording_noise_type_is_cut_into_disjoint_time_segments(data_dir):
    """Oracle: hum_only.wav is 300 Hz for its first 70 % and 2 kHz after; the dev clip must hold
    no 2 kHz and the test clip no 300 Hz (each below -40 dB of the other tone's power)."""
    clips = {s: open_data(data_dir, fs=FS, split=s).noise("hum", 3.0, seed=1) for s in ("dev", "test")}
    bounds = {s: c.files[0].split("[")[1].split("]")[0].split(":") for s, c in clips.items()}
    n = 4 * FS
    assert bounds["dev"] == ["0", str(int(0.7 * n))] and bounds["test"] == [str(int(0.7 * n)), str(n)]

    def band_db(x, f_hz):
        spec = np.abs(np.fft.rfft(x)) ** 2
        f = np.fft.rfftfreq(x.size, 1 / FS)
        return 10 * np.log10(spec[np.abs(f - f_hz) < 50].sum() + 1e-30)

    dev, test = clips["dev"].signal, clips["test"].signal
    assert band_db(dev, 2000.0) < band_db(dev, 300.0) - 40.0
    assert band_db(test, 300.0) < band_db(test, 2000.0) - 40.0


def test_noise_whose_recordings_hash_to_one_side_is_segmented_too(tmp_path):
    stems = _hashing_to("dev", [f"drone_{k}" for k in range(20)])[:2]
    for stem in stems:
        _wav(tmp_path / "noise" / f"{stem}.wav", _tone(500.0, 1.0))
    scan = scan_local(tmp_path, hash_files=False)
    dev, test = plan_split(scan, "dev").noise["drone"], plan_split(scan, "test").noise["drone"]
    assert [(p.start, p.stop) for p in dev] == [(0.0, 0.7)] * 2
    assert [(p.start, p.stop) for p in test] == [(0.7, 1.0)] * 2


def test_each_split_gets_speech_and_a_single_speech_file_is_cut(tmp_path):
    stems = _hashing_to("dev", [f"talk{k}" for k in range(20)], kind="speech")[:2]
    for stem in stems:
        _wav(tmp_path / "speech" / f"{stem}.wav", _tone(200.0, 1.0))
    scan = scan_local(tmp_path, hash_files=False)
    dev, test = plan_split(scan, "dev"), plan_split(scan, "test")
    assert len(dev.speech) == len(test.speech) == 1
    moved = min(stems, key=lambda s: split_hash(f"speech/{s}"))
    assert test.speech[0].entry.path.stem == moved and "moved" in test.notes[0]
    (tmp_path / "speech" / f"{stems[1]}.wav").unlink()
    one = scan_local(tmp_path, hash_files=False)
    assert [(p.start, p.stop) for p in plan_split(one, "dev").speech] == [(0.0, 0.7)]
    assert [(p.start, p.stop) for p in plan_split(one, "test").speech] == [(0.7, 1.0)]


def test_manifest_overrides_the_hash(data_dir, tmp_path):
    root = tmp_path / "d"
    (root / "speech").mkdir(parents=True)
    for f in (data_dir / "speech").iterdir():
        (root / "speech" / f.name).symlink_to(f)
    hashed_test = sorted(s for s in SPEAKERS if side_of(f"speaker/{s}") == "test")
    (root / "splits.toml").write_text(f'dev = ["{hashed_test[0]}"]\ntest = ["loose1.wav"]\n')
    scan = scan_local(root, hash_files=False)
    dev = {speaker_of(p.entry.path) or p.entry.path.stem for p in plan_split(scan, "dev").speech}
    test = {speaker_of(p.entry.path) or p.entry.path.stem for p in plan_split(scan, "test").speech}
    assert hashed_test[0] in dev and "loose1" in test and "loose1" not in dev


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ('dev = ["aew"]\nvalid = ["x"]\n', ["key 'valid'", "unknown key"]),
        ('dev = "aew"\n', ["key 'dev'", "'aew'", "list of speaker or file names"]),
        ('dev = ["aew"]\ntest = ["aew"]\n', ["line 2", "key 'test'", "'aew'", "both dev and test"]),
        ('test = ["nobody"]\n', ["line 1", "key 'test'", "'nobody'", "names no speaker or file"]),
        ('dev = ["hum_only.wav"]\n', ["key 'dev'", "'hum_only.wav'", "only recording of noise type 'hum'"]),
        ('dev = [\n', ["invalid TOML"]),
    ],
)
def test_a_bad_manifest_is_a_one_line_error_naming_file_key_and_value(data_dir, tmp_path, text, words):
    root = tmp_path / "d"
    root.mkdir()
    for sub in ("speech", "noise"):
        (root / sub).symlink_to(data_dir / sub)
    (root / "splits.toml").write_text(text)
    with pytest.raises(ConfigError) as info:
        open_data(root, fs=FS, split="dev")
    message = str(info.value)
    assert "\n" not in message and str(root / "splits.toml") in message
    for word in words:
        assert word in message
    open_data(root, fs=FS)  # "all" never reads the manifest: today's behaviour


def test_builtin_dev_and_test_clips_differ_and_share_no_seed():
    """Built-in material comes from disjoint seed streams: no dev clip equals a test clip for
    seeds 0-2, none equals the "all" clip, and built-in babble speaks from disjoint bank segments."""
    ds = {s: open_data(None, fs=FS, split=s) for s in ("dev", "test", "all")}
    speech = {s: [d.speech(0.5, seed=k).signal for k in range(3)] for s, d in ds.items()}
    for a in speech["dev"]:
        assert all(not np.array_equal(a, b) for b in speech["test"] + speech["all"])
    for noise in ("factory", "wind", "babble"):
        dev, test = ds["dev"].noise(noise, 0.5, seed=0), ds["test"].noise(noise, 0.5, seed=0)
        assert not np.array_equal(dev.signal, test.signal) and dev.files[0] != test.files[0]
    bank = {s: ds[s].noise("babble", 0.5, seed=0).files[1] for s in ("dev", "test")}
    assert "[0:" in bank["dev"] and "[0:" not in bank["test"]


def _sweep_text(split_line: str = "", noises=("hum", "fan")) -> str:
    return f"""\
[sweep]
name = "splits"
{split_line}

[axes]
enhancers = ["passthrough"]
noise = {json.dumps(list(noises))}
snr_db = [5]
seeds = [0, 1]

[fixed]
duration_s = 1.5
"""


def _files(row, key):
    return [f.split("[")[0].split("@")[0] for f in json.loads(row[key])]


def test_a_dev_sweep_draws_only_dev_files_and_rows_carry_the_split(data_dir, tmp_path):
    toml = tmp_path / "s.toml"
    toml.write_text(_sweep_text())
    out = tmp_path / "out"
    for split in ("dev", "test"):
        code = main(["bench", "run", str(toml), "--out", str(out), "--workers", "1", "--split", split,
                     "--data-dir", str(data_dir), "--no-report"])
        assert code == 0
    with ResultStore.open(out, readonly=True) as store:
        rows, runs = store.rows(), store.runs()
    assert [json.loads(r["options_json"])["split"] for r in runs] == ["dev", "test"]
    assert json.loads(runs[0]["options_json"])["seeds_used"] == [0, 1]
    assert len(rows) == 8 and len({r["condition_id"] for r in rows}) == 8  # dev and test ids differ
    scan = scan_local(data_dir, hash_files=False)
    for split in ("dev", "test"):
        mine = [r for r in rows if r["split"] == split]
        assert len(mine) == 4 and all(r["status"] == "ok" for r in mine)
        allowed = {str(p.entry.path) for p in plan_split(scan, split).speech}
        speakers = {speaker_of(f) for f in allowed} - {None}
        assert speakers == {s for s in SPEAKERS if side_of(f"speaker/{s}") == split}
        assert {f for r in mine for f in _files(r, "speech_files")} <= allowed
        fans = {f for r in mine if r["noise"] == "fan" for f in _files(r, "noise_files")}
        assert fans and all(side_of(f"noise/{Path(f).stem}") == split for f in fans)
        hums = [f for r in mine if r["noise"] == "hum" for f in json.loads(r["noise_files"])]
        assert all(("[0:" in f) == (split == "dev") for f in hums)


def test_split_all_gives_the_numbers_of_a_sweep_without_the_key(tmp_path, monkeypatch):
    """Oracle: the run without a split key (today's behaviour, same condition ids as before
    splits existed); values equal to the last bit."""
    monkeypatch.delenv("SCENESIM_DATA", raising=False)
    plain = parse_sweep(_sweep_text(noises=("wind",)))
    keyed = parse_sweep(_sweep_text('split = "all"', noises=("wind",)))
    assert keyed.split == plain.split == "all"
    assert all("split" not in c.to_json() for c in keyed.conditions())
    for name, sweep in (("plain", plain), ("keyed", keyed)):
        run_sweep(sweep, tmp_path / name, workers=1, progress=False, report=None)
    with ResultStore.open(tmp_path / "plain") as a, ResultStore.open(tmp_path / "keyed") as b:
        rows_a, rows_b = a.rows(), b.rows()
    metrics = ("condition_id", "snr_out_db", "snr_i_db", "pesq_nb_out", "stoi_out", "speech_files", "noise_files")
    assert [tuple(r[m] for m in metrics) for r in rows_a] == [tuple(r[m] for m in metrics) for r in rows_b]
    assert {r["split"] for r in rows_a} == {"all"}


def test_sweep_split_key_is_validated_and_with_split_copies(tmp_path):
    with pytest.raises(ConfigError, match=r"s.toml: line 3: key 'sweep.split': expected one of .* got 'tset'"):
        parse_sweep(_sweep_text('split = "tset"'), source="s.toml")
    text = _sweep_text().replace("[fixed]", '[fixed]\nsplit = "dev"')
    assert parse_sweep(text).split == "dev"
    with pytest.raises(ConfigError, match="key 'axes.split'"):
        parse_sweep(_sweep_text().replace("[axes]", '[axes]\nsplit = ["dev"]'))
    sweep = parse_sweep(_sweep_text())
    assert sweep.with_split("test").split == "test" and sweep.split == "all"
    with pytest.raises(ParameterError, match="split='x'"):
        sweep.with_split("x")


def test_an_old_store_opens_and_its_rows_say_split_all(tmp_path):
    import sqlite3

    from benchmarks.store.sqlite import CONTRACT_COLUMNS

    db = sqlite3.connect(tmp_path / "results.sqlite")
    cols = ", ".join(f"{n} {t}" for n, t in CONTRACT_COLUMNS)
    db.execute(f"CREATE TABLE results ({cols}, UNIQUE(condition_id, enhancer))")
    db.execute("INSERT INTO results (condition_id, enhancer, status) VALUES ('c', 'ss', 'ok')")
    db.commit()
    db.close()
    with ResultStore.open(tmp_path) as store:
        assert [r["split"] for r in store.rows()] == ["all"]
        store.write_rows([{"condition_id": "d", "enhancer": "ss", "status": "ok", "split": "dev"}])
        assert [r["split"] for r in store.rows()] == ["all", "dev"]


def _report_rows(splits):
    rows = []
    for k, split in enumerate(splits):
        for name, snr_i in (("passthrough", 0.0), ("ss", 3.0 + k)):
            rows.append({"condition_id": f"c{k}", "enhancer": name, "noise": "wind", "snr_in_db": 5.0,
                         "rt60_s": 0.0, "speech_az_deg": 45.0, "noise_az_deg": 270.0, "seed": k,
                         "snr_i_db": snr_i, "status": "ok", "split": split})
    return rows


def test_the_report_names_its_split_in_header_sections_and_captions(tmp_path):
    paths = write_report(_report_rows(["dev", "dev"]), tmp_path / "a")
    summary = (tmp_path / "a" / "report" / "summary.md").read_text()
    assert "- **split**: dev" in summary.splitlines()[:4]
    headings = [ln for ln in summary.splitlines() if ln.startswith("## ") and ln not in ("## Contents", "## Files")]
    assert headings and summary.count("*split: dev*") == len(headings)
    page = next(p for p in paths if p.name == "index.html").read_text()
    assert "<title>scenesim benchmark report (split: dev)</title>" in page
    assert "(split: dev)</figcaption>" in page
    write_report(_report_rows(["dev", "test"]), tmp_path / "b")
    mixed = (tmp_path / "b" / "report" / "summary.md").read_text()
    assert "**splits**: dev+test" in mixed and "averaged together" in mixed and "*splits: dev+test*" in mixed


def test_split_all_draws_exactly_what_the_source_drew_before_splits(data_dir, monkeypatch):
    """Oracle: the pre-split rules restated here (the generator called with the user's seed; a
    local directory's utterances in the order of ``default_rng([seed, crc32("speech")])``, each
    at RMS 0.05 with a 0.2-0.5 s pause), equal to the last bit."""
    import zlib

    from data_recipes.local import load_mono
    from data_recipes.noise_synthesis import synthesize_noise

    monkeypatch.delenv("SCENESIM_DATA", raising=False)
    builtin = open_data(None, fs=FS)
    np.testing.assert_array_equal(builtin.speech(0.7, seed=5).signal, artificial_voice(0.7, fs=FS, seed=5)[0])
    rng = np.random.default_rng([5, zlib.crc32(b"noise:factory")])
    expected = synthesize_noise("factory", int(0.7 * FS), fs=FS, rng=rng).signal[0]
    np.testing.assert_array_equal(builtin.noise("factory", 0.7, seed=5).signal, expected)

    entries = scan_local(data_dir, hash_files=False).speech
    rng = np.random.default_rng([3, zlib.crc32(b"speech")])
    order, pieces, n = rng.permutation(len(entries)), [], int(4.0 * FS)
    while sum(p.size for p in pieces) < n:
        utt = load_mono(entries[int(order[len(pieces) // 2 % len(order)])].path, fs=FS)
        pieces += [utt * (0.05 / np.sqrt(np.mean(utt**2))), np.zeros(int(rng.uniform(0.2, 0.5) * FS))]
    x = np.concatenate(pieces)[:n]
    got = open_data(data_dir, fs=FS).speech(4.0, seed=3).signal
    np.testing.assert_array_equal(got, x * (0.05 / np.sqrt(np.mean(x**2))))
