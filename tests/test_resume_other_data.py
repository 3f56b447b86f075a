"""Resuming a store on other data: new rows name the new data; the worker's render cache keys on it.

Issue 11: a rerun on the same ``--out`` with another ``--data-dir`` must not hand the new
conditions the previous data's rendered scenes (the worker keeps rendered geometry groups
in a cache; two SNRs of one group share one render).  Runs in this process (workers=1),
so the cache survives between the two runs exactly as in a long-lived worker.
"""

from __future__ import annotations

import numpy as np
import pytest
import soundfile as sf

from benchmarks.run import worker
from benchmarks.run.runner import run_sweep
from benchmarks.run.sweep import parse_sweep
from benchmarks.store.sqlite import ResultStore
from data_recipes.artificial_voice import artificial_voice

FS = 16000
SWEEP = """\
[sweep]
name = "two-snrs"

[axes]
enhancers = ["passthrough"]
noise = ["wind"]
snr_db = [0, 10]

[fixed]
duration_s = 1.5
"""


@pytest.fixture
def other_data(tmp_path):
    root = tmp_path / "data"
    (root / "speech").mkdir(parents=True)
    (root / "noise").mkdir()
    voice, _ = artificial_voice(2.0, fs=FS, seed=7)
    sf.write(root / "speech" / "talker_1.wav", voice, FS, subtype="FLOAT")
    wind = 0.1 * np.random.default_rng(5).standard_normal(3 * FS)
    sf.write(root / "noise" / "wind_1.wav", wind, FS, subtype="FLOAT")
    return root


def test_resumed_rows_name_the_new_data(tmp_path, other_data):
    sweep = parse_sweep(SWEEP)
    a, b = sweep.conditions()
    assert a.group_id == b.group_id  # one render serves both SNRs: the cache is exercised
    out = tmp_path / "out"
    run_sweep(sweep, out, workers=1, limit=1, report=False, progress=False)  # built-in data
    with pytest.warns(UserWarning, match="data"):  # the driver says the data changed
        run_sweep(sweep, out, workers=1, data_dir=other_data, report=False, progress=False)
    with ResultStore.open(out, readonly=True) as store:
        rows = {r["condition_id"]: r for r in store.rows()}
    assert str(other_data) not in rows[a.id]["speech_source"]  # kept from the first run
    assert str(other_data.resolve()) in rows[b.id]["speech_source"]
    assert str(other_data.resolve()) in rows[b.id]["noise_source"]


def test_render_cache_key_includes_the_data_directory(other_data):
    cond = parse_sweep(SWEEP).conditions()[0]
    worker._IMAGES.clear()
    _, builtin_speech, _ = worker.render_group(cond, None)
    _, local_speech, local_noise = worker.render_group(cond, str(other_data.resolve()))
    assert builtin_speech != local_speech
    assert str(other_data.resolve()) in local_speech and str(other_data.resolve()) in local_noise
