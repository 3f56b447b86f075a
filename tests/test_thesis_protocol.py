"""The thesis search's honesty checks (issue 30 part 4) and its command line (issue 33 class 6).

Oracles: constructed cells whose distance to the printed tables is known by construction (the
held-out number must be the other family's, the identifiability set is known), the closed form of
``y - s`` for a pure gain system, the registered ``eb-ss`` chain for the search's split EB-SS run,
and the data source's own draw for a split.
"""

from __future__ import annotations

import json
import math
import os

import numpy as np
import pytest

from benchmarks.thesis.measure import output_snrs, snr_hagerman_db, snr_y_minus_s_db
from benchmarks.thesis.protocol import agreement, bootstrap_scores, held_out, identifiable_set
from benchmarks.thesis.readings import Reading, Score, score_cells
from benchmarks.thesis.reference import load_thesis_tables

SHARED = os.environ.get("SCENESIM_DATA") or "/work/shared/data"


def _cells(offsets: dict[str, tuple[float, float]]) -> dict[tuple, tuple]:
    """Every printed cell, each noise's SNR-I and PESQ moved by ``offsets[noise]`` from the thesis'."""
    return {(r.system, r.noise, r.snr_in_db): (r.snr_i_db + offsets[r.noise][0], r.pesq_out + offsets[r.noise][1])
            for r in load_thesis_tables()}


def test_held_out_number_is_the_other_familys_never_the_chosen_one():
    """A reading that fits babble exactly and factory+wind by 3 dB / 0.4 off: chosen on babble, its
    held-out error must be exactly 3 dB / 0.4 over the 36 factory+wind cells, although the evaluator
    also returns the perfect babble cells; and the reverse direction must score babble's 0."""
    fits_babble = Reading(adapt="slow")
    fits_rest = Reading(adapt="free")
    got = {fits_babble: _cells({"babble": (0.0, 0.0), "factory": (3.0, -0.4), "wind": (-3.0, 0.4)}),
           fits_rest: _cells({"babble": (0.0, 0.0), "factory": (0.5, 0.0), "wind": (0.5, 0.0)})}
    chosen_for = {("babble",): fits_babble, ("factory", "wind"): fits_rest}
    asked = []

    def choose(family):
        r = chosen_for[family]
        return r, score_cells({k: v for k, v in got[r].items() if k[1] in family})

    def evaluate(reading, family):
        asked.append(family)
        return got[reading]  # every cell, the chosen family's included

    out = held_out(choose, evaluate)
    first, second = out
    assert (first["chosen_on"], first["scored_on"]) == (["babble"], ["factory", "wind"])
    assert first["in_sample"]["snr_i"] == pytest.approx(0.0, abs=1e-12)
    assert first["held_out"]["snr_i"] == pytest.approx(3.0, abs=1e-12)
    assert first["held_out"]["pesq"] == pytest.approx(0.4, abs=1e-12)
    assert first["held_out"]["n_snr"] == 36
    assert second["held_out"]["snr_i"] == pytest.approx(0.0, abs=1e-12) and second["held_out"]["n_snr"] == 18
    assert asked == [("factory", "wind"), ("babble",)]


def test_identifiability_set_and_agreement_on_constructed_scores():
    """One cell, thesis SNR-I T.  Reading a sits 1 dB off on every seed, b 0.4 or 1.6 dB off (mean 1.02),
    c 2 dB off: b's paired interval against a straddles 0, c's is exactly [1, 1].  So the set is
    {a, b}; they agree on adapt ("slow") and not on beta_max."""
    row = load_thesis_tables()[0]
    key = (row.system, row.noise, row.snr_in_db)

    def seeds(ds):
        return [{key: (row.snr_i_db + d, None)} for d in ds]

    a, b, c = Reading(adapt="slow", beta_max=0.2), Reading(adapt="slow", beta_max=1.0), Reading(adapt="free")
    per_seed = {a: seeds([1, 1, 1, 1, 1]), b: seeds([0.4, 1.6, 0.4, 1.6, 1.1]), c: seeds([2, 2, 2, 2, 2])}
    full, boots = bootstrap_scores(per_seed, lambda cells: score_cells(cells).snr_i, n_boot=400, seed=3)
    assert full[a] == pytest.approx(1.0) and full[b] == pytest.approx(1.02) and full[c] == pytest.approx(2.0)
    assert boots[b].shape == (400,) and boots[b].min() < 1.0 < boots[b].max()  # b's resamples fall both sides of a
    rows = identifiable_set(full, boots)
    assert [r["reading"] for r in rows] == [a, b, c]
    assert [r["in_set"] for r in rows] == [True, True, False]
    assert rows[2]["diff_lo"] == pytest.approx(1.0) and rows[2]["diff_hi"] == pytest.approx(1.0)
    agree = agreement(rows, ["adapt", "beta_max"])
    assert agree == {"adapt": ["slow"], "beta_max": [0.2, 1.0]}


def test_y_minus_s_of_a_pure_gain_system_is_the_closed_form():
    """y = g (s + n), delayed by L samples: SNR_out = P(s) / P((g - 1) s + g n); Hagerman and replay give
    P(s) / P(n).  Tolerance 1e-9 dB (float rounding of mean squares)."""
    rng = np.random.default_rng(5)
    s, n = rng.standard_normal(4000), 0.3 * rng.standard_normal(4000)
    g, lat = 0.5, 13
    delay = np.zeros(lat)
    y = np.concatenate([delay, g * (s + n)])
    y2 = np.concatenate([delay, g * (s - n)])
    closed = 10 * math.log10(np.mean(s ** 2) / np.mean(((g - 1) * s + g * n) ** 2))
    assert snr_y_minus_s_db(y, s, latency=lat) == pytest.approx(closed, abs=1e-9)
    plain = 10 * math.log10(np.mean(s ** 2) / np.mean(n ** 2))
    assert snr_hagerman_db(y, y2, latency=lat) == pytest.approx(plain, abs=1e-9)
    out = output_snrs(ys=g * s, yn=g * n, y=y, y2=y2, s_ref=s, latency=lat)
    assert out["replay"] == pytest.approx(plain, abs=1e-9) and out["y-s"] == pytest.approx(closed, abs=1e-9)
    assert closed < plain - 3  # the distortion (g - 1) s counts as noise: not a vacuous check


@pytest.mark.parametrize("data_dir", [None, SHARED])
def test_cells_draw_the_split_they_are_given(data_dir):
    from benchmarks.thesis.readings import Cells
    from data_recipes import open_data

    if data_dir is not None and not os.path.isdir(os.path.join(data_dir, "speech")):
        pytest.skip(f"no real recordings at {data_dir} (set SCENESIM_DATA)")
    aliases = {"babble": "cafe"} if data_dir else {}
    got = {sp: Cells(data_dir, duration_s=1.0, split=sp, noises=("babble",), aliases=aliases) for sp in ("dev", "test")}
    for sp, cells in got.items():
        ds = open_data(data_dir, fs=16000, split=sp)
        assert cells.split == sp
        np.testing.assert_array_equal(cells.speech, ds.speech(1.0, seed=0).signal)
        np.testing.assert_array_equal(cells.noise["babble"], ds.noise(aliases.get("babble", "babble"), 1.0, seed=0).signal)
    assert not np.array_equal(got["dev"].speech, got["test"].speech)
    assert not np.array_equal(got["dev"].noise["babble"], got["test"].noise["babble"])


def test_search_eb_ss_run_is_the_registered_chain():
    """The search feeds the EB's run to ss (so 36 SS settings share one EB run); its output must be the
    registered ``eb-ss`` chain's, to 1e-9 of the peak (same arithmetic, same order)."""
    from benchmarks.thesis.readings import Cells, _make, cell_runs

    cells = Cells(duration_s=1.0, noises=("wind",), snrs=(10.0,))
    r = Reading(osub="fixed2", subtract="power", subf=0.05)
    runs = cell_runs(cells, r, with_pesq=False, systems=("EB-SS",))
    mix = cells.images(r, "wind").mix(10.0)
    chain = _make("eb-ss", eb=r.eb_params(), ss=r.ss_params())
    res = chain.process(mix.mixture, fs=cells.fs)
    ours = cells._eb_runs
    assert set(runs) == {("EB-SS", "wind", 10.0)}
    from benchmarks.thesis.readings import _system_run

    mine = _system_run(cells, r, "EB-SS", _make("ss", **r.ss_params()), "wind", 10.0, mix)
    assert ours and mine["latency"] == chain.tags.latency_samples
    assert np.max(np.abs(mine["y"] - res.output[0])) <= 1e-9 * np.max(np.abs(res.output[0]))
    ys = res.replay(mix.speech_image)[0]
    assert np.max(np.abs(mine["ys"] - ys)) <= 1e-9 * np.max(np.abs(ys))


def test_ss_unknowns_reach_the_ss_params():
    assert Reading().ss_params() == {"n_sub": 8, "sub_len": 25, "omin": 0.99, "alpha": 0.9}
    p = Reading(osub="fixed1", subf=0.05, subtract="power").ss_params()
    assert (p["osub_slope"], p["osub_min"], p["osub_max"], p["subf"], p["subtract"]) == (0.0, 1.0, 1.0, 0.05, "power")


# -- the command line ----------------------------------------------------------------------

BAD = [
    (["--duration", "1e9"], "--duration='1e9'"),
    (["--duration", "0.5"], "--duration='0.5'"),
    (["--duration", "nan"], "--duration='nan'"),
    (["--duration", "abc"], "--duration='abc'"),
    (["--seed", "-1"], "--seed='-1'"),
    (["--seed", "1.5"], "--seed='1.5'"),
    (["--alias", "babble"], "--alias='babble'"),
    (["--alias", "fan=wind"], "--alias='fan=wind'"),
    (["--alias", "babble=nosuch"], "--alias='babble=nosuch'"),
    (["--data-dir", "/nonexistent/thesis"], "/nonexistent/thesis"),
    (["--seeds", "1"], "--seeds='1'"),
    (["--boot", "10"], "--boot='10'"),
    (["--ident-top", "5"], "--ident-top='5'"),
    (["--top", "0"], "--top='0'"),
]


@pytest.mark.parametrize(("args", "named"), BAD)
def test_cli_refuses_each_bad_input_in_one_line(args, named, tmp_path, capsys):
    from benchmarks.cli.main import main

    out = tmp_path / "never"
    assert main(["thesis", "search", *args, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("scenesim: error:") and named in err
    assert "Traceback" not in err
    assert not out.exists()  # refused before any work: nothing left behind


def test_cli_refuses_a_type_missing_from_the_data_folder(capsys):
    """--alias to a type the folder has no file of (it would be synthesized) is refused, naming the folder's types."""
    from benchmarks.cli.main import main

    if not os.path.isdir(os.path.join(SHARED, "noise")):
        pytest.skip(f"no real recordings at {SHARED} (set SCENESIM_DATA)")
    assert main(["thesis", "evaluate", "--data-dir", SHARED, "--alias", "factory=factory"]) == 2
    err = capsys.readouterr().err
    assert "--alias='factory=factory'" in err and "wind" in err and err.count("\n") == 1


def test_standalone_module_gives_the_same_one_line_errors(capsys):
    from benchmarks.thesis.search import main

    assert main(["--evaluate", "--duration", "100"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("scenesim: error:") and "--duration='100'" in err and err.count("\n") == 1


def test_results_file_round_trip_and_lookup(tmp_path, monkeypatch):
    from benchmarks.thesis.results import find_results, load_results, protocol_lines, write_results

    row = {"reading": {"adapt": "slow"}, "label": "r", "score": 1.0, "diff_lo": 0.0, "diff_hi": 0.0, "in_set": True}
    block = {"score": "s", "rows": [row], "agreement": {"adapt": ["slow"]}, "n_set": 1, "n_readings": 1}
    sc = {"snr_i": 1.5, "pesq": float("nan"), "trend": 0.1, "n_snr": 18, "n_pesq": 0}
    result = {"choose_split": "dev", "score_split": "test", "ident_seeds": [0, 1], "seconds": 1.0,
              "held_out": [{"chosen_on": ["babble"], "scored_on": ["wind"], "label": "r", "in_sample": sc, "held_out": sc}],
              "fit": {"in_sample": sc, "test_all_tables": sc}, "preset": {"test_all_tables": sc},
              "identifiability": {"rule": "x", "eb": block, "ss": block}}
    monkeypatch.delenv("SCENESIM_THESIS_SEARCH", raising=False)
    monkeypatch.chdir(tmp_path)
    assert find_results() is None
    json_path, csv_path = write_results(result, tmp_path / "store")
    assert find_results(tmp_path / "store") == json_path
    back = load_results(json_path)
    assert back["fit"]["in_sample"]["pesq"] is None  # NaN written as null (valid JSON)
    assert "1.50" in "\n".join(protocol_lines(back))
    assert csv_path.read_text().splitlines()[0].startswith("block,rank,label,score")
    monkeypatch.setenv("SCENESIM_THESIS_SEARCH", str(tmp_path / "store"))
    assert find_results() == json_path
    assert isinstance(Score(1, 1, 1, 1, 1), Score) and json.loads(json_path.read_text())


def test_report_heads_the_fit_with_its_held_out_error_from_the_results_file(tmp_path, monkeypatch):
    """The fit's section: the held-out numbers of the results file come first (bold), the in-sample fit
    after them unbolded, then the identifiability table; without a file it says how to produce one."""
    from benchmarks.report.thesis_repro import repro_section
    from benchmarks.thesis.readings import BEST
    from benchmarks.thesis.results import write_results

    azimuth, taps, window = BEST.scene_key()
    cond = json.dumps({"far_field_method": "thesis", "azimuth_from": azimuth, "fd_taps": taps, "fd_window": window})
    rows = [{"enhancer": "eb", "noise": "babble", "snr_in_db": 0.0, "snr_i_db": 13.0, "pesq_nb_raw_out": 2.0,
             "rt60_s": 0.0, "speech_az_deg": 45.0, "noise_az_deg": 270.0, "noise_field": "point", "far_field": 1,
             "spacing_m": 0.0214, "ideal_sensors": 1, "condition_json": cond}]
    monkeypatch.delenv("SCENESIM_THESIS_SEARCH", raising=False)
    monkeypatch.chdir(tmp_path)
    text = "\n".join(repro_section(rows))
    assert "no search results found" in text and "scenesim thesis search --out thesis-search" in text
    sc = {"snr_i": 1.25, "pesq": 0.125, "trend": 0.5, "n_snr": 18, "n_pesq": 18}
    held = {"snr_i": 4.75, "pesq": 0.375, "trend": 0.5, "n_snr": 36, "n_pesq": 36}
    row = {"reading": {"adapt": "slow"}, "label": "the-best", "score": 1.0, "diff_lo": 0.0, "diff_hi": 0.0, "in_set": True}
    block = {"score": "s", "rows": [row], "agreement": {"adapt": ["slow"], "osub": ["berouti", "fixed1"]},
             "n_set": 1, "n_readings": 1}
    write_results({"data": "built-in", "choose_split": "dev", "score_split": "test", "ident_seeds": [0, 1, 2],
                   "held_out": [{"chosen_on": ["babble"], "scored_on": ["factory", "wind"], "label": "r",
                                 "in_sample": sc, "held_out": held}],
                   "fit": {"in_sample": sc, "test_all_tables": sc}, "preset": {"test_all_tables": sc},
                   "identifiability": {"rule": "paired", "eb": block, "ss": block}}, tmp_path / "thesis-search")
    text = "\n".join(repro_section(rows))
    assert "| babble | factory + wind | 1.25 dB | 0.125 | **4.75 dB** | **0.375** | r |" in text
    assert text.index("**Held-out error**") < text.index("in-sample fit") < text.index("**Identifiability.**")
    assert "mean |ΔSNR-I| **" not in text and "They agree on: adapt = slow; not identified: osub (berouti, fixed1)" in text
