"""DNSMOS P.835 (benchmarks.metrics.dnsmos): speechmos' procedure, pinned values, ranking, and the sweep opt-in.

Skips with a reason when the optional packages are absent (pip install -e '.[dnsmos]').
Pinned values are of speechmos 0.0.1.1's model file run by onnxruntime 1.32.0 (constraints.txt);
other versions skip the pin and say which differs.
"""

from __future__ import annotations

import importlib.util
import sqlite3
import sys
import types
from importlib import metadata

import numpy as np
import pytest

pytest.importorskip("speechmos", reason="optional extra not installed: pip install -e '.[dnsmos]'")
pytest.importorskip("onnxruntime", reason="optional extra not installed: pip install -e '.[dnsmos]'")

from benchmarks.cli.main import main  # noqa: E402
from benchmarks.metrics.dnsmos import dnsmos_p835  # noqa: E402
from data_recipes.artificial_voice import artificial_voice  # noqa: E402
from scenesim.errors import ParameterError  # noqa: E402

FS = 16000
PIN_VERSIONS = {"speechmos": "0.0.1.1", "onnxruntime": "1.32.0"}
HAS_LIBROSA = importlib.util.find_spec("librosa") is not None  # before any stand-in is registered


@pytest.fixture(scope="module")
def signals():
    """4 s of the built-in artificial voice at -26 dBFS; + white noise at 5 dB; clipped at 1/20 of its
    peak and buried in white noise at -5 dB (heavily distorted)."""
    s, _ = artificial_voice(4.0, fs=FS, seed=0)
    s = 0.05 * s / np.std(s)
    rng = np.random.default_rng(1)
    noisy = s + 0.05 * rng.standard_normal(s.size) / np.sqrt(10**0.5)
    distorted = np.clip(s * 20, -0.05, 0.05) + 0.05 * rng.standard_normal(s.size)
    return {"clean": s, "noisy": noisy, "distorted": distorted}


def _speechmos_run(x):
    """speechmos.dnsmos.run itself, with a stand-in librosa (only its P.808 features use it, and
    the P.808 score is not compared): the outside implementation our P.835 scores must equal."""
    if not HAS_LIBROSA:  # the stand-in only where the real one is absent (the P.808 test uses it)
        sys.modules.setdefault("librosa", types.ModuleType("librosa"))
    from speechmos import dnsmos as sm

    if not HAS_LIBROSA:
        sm.DNSMOS.audio_melspec = lambda self, audio, **kw: np.zeros((900, 120), dtype=np.float32)
    out = sm.run(x, FS)
    return {"dnsmos_sig": out["sig_mos"], "dnsmos_bak": out["bak_mos"], "dnsmos_ovrl": out["ovrl_mos"]}


def test_scores_equal_speechmos_own_run(signals):
    """Oracle: speechmos.dnsmos.run (its own sessions and clip procedure) to 1e-5 (float32 network)."""
    for name in ("noisy",):
        ours, theirs = dnsmos_p835(signals[name], FS), _speechmos_run(signals[name])
        for key in ours:
            assert ours[key] == pytest.approx(theirs[key], abs=1e-5), key


def test_ranks_clean_above_noisy_above_distorted(signals):
    """SIG, BAK and OVRL each rank clean > noisy (5 dB) > heavily distorted (measured OVRL 2.20 > 1.37 > 1.09)."""
    scores = {k: dnsmos_p835(v, FS) for k, v in signals.items()}
    for key in ("dnsmos_sig", "dnsmos_bak", "dnsmos_ovrl"):
        assert scores["clean"][key] > scores["noisy"][key] > scores["distorted"][key], key


def test_pinned_values_of_the_generated_pair(signals):
    """The clean/noisy pair's scores, measured with the versions in PIN_VERSIONS (to 1e-4)."""
    installed = {p: metadata.version(p) for p in PIN_VERSIONS}
    if installed != PIN_VERSIONS:
        pytest.skip(f"pinned with {PIN_VERSIONS}, installed {installed}")
    expected = {
        "clean": (2.4717284, 3.7455803, 2.2034798),
        "noisy": (1.9816475, 1.3696515, 1.3739319),
    }
    for name, values in expected.items():
        got = dnsmos_p835(signals[name], FS)
        assert [got["dnsmos_sig"], got["dnsmos_bak"], got["dnsmos_ovrl"]] == pytest.approx(values, abs=1e-4)


def test_only_16_khz_is_accepted():
    with pytest.raises(ParameterError, match="16000"):
        dnsmos_p835(np.zeros(8000), 8000)


def test_sweep_opts_in_with_the_metrics_key(tmp_path):
    """A one-condition sweep with metrics = ["dnsmos"] fills dnsmos_*_in and dnsmos_* for each
    enhancer; passthrough's output scores equal the input's (same signal, latency 0)."""
    toml = tmp_path / "dn.toml"
    toml.write_text(
        '[sweep]\nname = "dn"\n[axes]\nenhancers = ["passthrough", "ss"]\nnoise = ["babble"]\n'
        'snr_db = [5]\nseeds = [0]\n[fixed]\nfs = 16000\nduration_s = 2.0\nrt60_s = 0.0\n'
        'noise_field = "point"\nnoise_az_deg = 270\nfar_field = true\nmetrics = ["dnsmos"]\n'
    )
    out = tmp_path / "out"
    assert main(["bench", "run", str(toml), "--out", str(out), "--workers", "1", "--no-report"]) == 0
    with sqlite3.connect(out / "results.sqlite") as db:
        rows = {r[0]: r[1:] for r in db.execute(
            "SELECT enhancer, dnsmos_sig_in, dnsmos_bak_in, dnsmos_ovrl_in, dnsmos_sig, dnsmos_bak, dnsmos_ovrl, error "
            "FROM results")}
    assert set(rows) == {"passthrough", "ss"}
    assert all(v is not None for v in rows["ss"][:6])
    assert rows["passthrough"][3:6] == pytest.approx(rows["passthrough"][0:3], abs=1e-9)


def test_sweeps_without_the_key_have_no_dnsmos(tmp_path_factory):
    from tests._bench_smoke import local_smoke_run

    code, out = local_smoke_run(tmp_path_factory)
    assert code == 0
    with sqlite3.connect(out / "results.sqlite") as db:
        assert db.execute("SELECT COUNT(*) FROM results WHERE dnsmos_ovrl IS NOT NULL").fetchone()[0] == 0


# -- P.808 (issue 32: dnsmos_p808 beside P.835) -----------------------------------------------


def test_p808_equals_speechmos_run_with_librosa(signals):
    """Outside implementation: speechmos.dnsmos.run with the real librosa (its P.808 features) to
    1e-5; skipped where librosa is absent (the dev install has none: the pins below stand in)."""
    if not HAS_LIBROSA:
        pytest.skip("librosa not installed (speechmos' P.808 oracle)")
    import librosa
    from speechmos import dnsmos as sm

    from benchmarks.metrics.dnsmos import dnsmos_p808, p808_features

    seg = signals["noisy"][: 9 * FS]
    seg = np.concatenate([seg, seg])[:144160]
    theirs = sm.DNSMOS.audio_melspec(None, seg[:-160])
    assert librosa.__version__ and p808_features(seg) == pytest.approx(theirs, abs=1e-6)
    for name in ("clean", "noisy"):
        assert dnsmos_p808(signals[name], FS) == pytest.approx(float(sm.run(signals[name], FS)["p808_mos"]), abs=1e-5)


def test_p808_pinned_to_speechmos_with_librosa_0_11(signals):
    """Pins measured with speechmos.dnsmos.run (speechmos 0.0.1.1, librosa 0.11.0, onnxruntime
    1.32.0): clean 2.8085179, noisy 2.1919377, distorted 2.0577180; ours to 1e-5."""
    from benchmarks.metrics.dnsmos import dnsmos_p808

    installed = {p: metadata.version(p) for p in PIN_VERSIONS}
    if installed != PIN_VERSIONS:
        pytest.skip(f"pinned with {PIN_VERSIONS}, installed {installed}")
    expected = {"clean": 2.8085179, "noisy": 2.1919377, "distorted": 2.0577180}
    got = {name: dnsmos_p808(x, FS) for name, x in signals.items()}
    assert got == pytest.approx(expected, abs=1e-5)


def test_mel_basis_is_slaney_closed_form():
    """Closed form: each triangle peaks at its centre mel frequency with height 2 / (f_{m+2} - f_m)
    (Slaney's area normalisation); 1 kHz is mel 15 on Slaney's scale, the log part's step is
    ln(6.4) / 27."""
    from benchmarks.metrics import dnsmos as D

    assert float(D._hz_to_mel(np.array(1000.0))) == pytest.approx(15.0, abs=1e-12)
    assert float(D._hz_to_mel(np.array(6400.0))) == pytest.approx(42.0, abs=1e-12)
    basis = D._mel_basis().astype(np.float64)
    edges = D._mel_to_hz(np.linspace(0.0, D._hz_to_mel(np.array(8000.0)), 122))
    freqs = np.fft.rfftfreq(321, 1 / FS)
    heights = 2.0 / (edges[2:] - edges[:-2])
    assert np.all(basis.max(axis=1) <= heights * (1 + 1e-6))
    assert np.all(basis >= 0) and basis.shape == (120, freqs.size)


def test_requested_dnsmos_without_the_extra_is_the_install_line(monkeypatch):
    """API: score(dnsmos=True) and dnsmos_p835 raise ExtraNotInstalled (not ModuleNotFoundError)."""
    from benchmarks.metrics import dnsmos as D
    from benchmarks.metrics.scoring import score
    from scenesim.errors import ExtraNotInstalled

    monkeypatch.setattr(D, "installed", lambda: False)
    x = 0.1 * np.random.default_rng(0).standard_normal(FS)
    for call in (lambda: score(x, FS, dnsmos=True), lambda: D.dnsmos_p835(x, FS), lambda: D.dnsmos_p808(x, FS)):
        with pytest.raises(ExtraNotInstalled, match=r'pip install "scenesim\[dnsmos\]"'):
            call()
    assert score(x, FS)["dnsmos_ovrl"] is None  # the default computes it only when installed
