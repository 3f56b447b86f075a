"""Closed-loop RT60 calibration, checked where the loop does not look (issue 10, issue 11).

The loop measures the mean 500 Hz-2 kHz octave T30 (our Schroeder fit, zero-phase 3rd-order
Butterworth octaves) at three fixed placements.  The independent check measures other,
seeded random placements with another estimator: pyroomacoustics'
``experimental.measure_rt60`` (two-point -5/-35 dB reading of its own Schroeder curve) on
causal 4th-order Butterworth octaves.
"""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest
from scipy import signal

from scenesim.errors import ParameterError
from scenesim.room import calibration
from scenesim.room.bands import OCTAVE_CENTERS_HZ, octave_rt60, speech_rt60
from scenesim.room.cache import clear_memory_cache
from scenesim.room.calibration import (
    CALIBRATION_PLACEMENTS,
    calibrate_absorption,
    calibrate_room,
    default_calibration_positions,
)
from scenesim.room.ism import image_source_rir
from scenesim.room.render import room_rir
from scenesim.room.scattering import DEFAULT_SCATTERING
from scenesim.room.shoebox import ShoeBox

FS = 16000


def _independent_speech_t30(room, t, n_placements=4, seed=7):
    """Mean over seeded random placements of the 500/1k/2k octave T30 by pyroomacoustics."""
    pe = pytest.importorskip("pyroomacoustics.experimental")
    rng = np.random.default_rng(seed)
    d = np.asarray(room.dims_m)
    vals = []
    for _ in range(n_placements):
        src, mic = rng.uniform(0.15 * d, 0.85 * d), rng.uniform(0.15 * d, 0.85 * d)
        h = image_source_rir(room, src, mic, fs=FS, length_s=1.3 * t + 0.05)[0]
        for fc in (500, 1000, 2000):
            sos = signal.butter(4, [fc / np.sqrt(2), fc * np.sqrt(2)], btype="bandpass", fs=FS, output="sos")
            vals.append(pe.measure_rt60(signal.sosfilt(sos, h), fs=FS, decay_db=30))
    return float(np.mean(vals))


@pytest.mark.parametrize(("dims", "t"), [((6.0, 5.0, 3.0), 0.4), ((4.0, 3.5, 2.7), 0.5)])
def test_calibrated_room_decays_as_asked_at_other_placements(dims, t):
    """Independent estimator, other placements: speech-octave T30 within 6 % of the target
    (measured -2.7 % and -4.0 %; mean over 12 octave readings whose placement spread is ~+-10 %).
    The previous loop (broadband raw T30 at one placement) gives -18 % and -20 % here."""
    room = calibrate_room(dims, t)
    assert _independent_speech_t30(room, t) == pytest.approx(t, rel=0.06)


def test_loop_tolerance_at_its_own_placements_and_compat_path():
    """Oracle: the loop's stopping rule (1 %) re-measured on freshly rendered RIRs; the thin
    ShoeBox(rt60_method="calibrated") path with the same scattering gives bit-identical absorption."""
    dims, t = (5.0, 4.0, 3.0), 0.35
    room = calibrate_room(dims, t)
    vals = []
    for k in range(len(CALIBRATION_PLACEMENTS)):
        src, mic = default_calibration_positions(dims, k)
        vals.append(speech_rt60(image_source_rir(room, src, mic, fs=FS, length_s=1.2 * t + 0.05)[0], FS))
    assert np.mean(vals) == pytest.approx(t, rel=0.012)
    compat = ShoeBox(dims, rt60_s=t, rt60_method="calibrated", scattering=DEFAULT_SCATTERING)
    np.testing.assert_array_equal(compat.wall_absorption, room.wall_absorption)
    assert room.target_rt60_s == t and room.nominal_rt60_s == t


def test_profile_is_scaled_in_the_log_reflection_domain():
    """A per-wall profile keeps its shape: -ln(1 - alpha) scales by one common factor
    (1e-12 relative), and the compat ShoeBox(absorption=profile, rt60_s=...) path agrees."""
    dims, t = (6.0, 5.0, 3.0), 0.45
    profile = (0.1, 0.1, 0.2, 0.2, 0.05, 0.4)
    room = calibrate_room(dims, t, absorption=profile)
    ratio = np.log1p(-room.wall_absorption) / np.log1p(-np.asarray(profile))
    np.testing.assert_allclose(ratio, ratio[0], rtol=1e-12)
    assert abs(ratio[0] - 1.0) > 0.05  # the profile was really rescaled
    compat = ShoeBox(dims, profile, rt60_s=t, rt60_method="calibrated", scattering=DEFAULT_SCATTERING)
    np.testing.assert_array_equal(compat.wall_absorption, room.wall_absorption)


@pytest.mark.slow
def test_per_octave_calibration_within_5_percent_on_the_combined_rir():
    """Per-band targets and a per-wall profile: each octave's T30 (125 Hz..4 kHz), measured on
    the *combined* RIR (all bands through the filter bank, which the loop never renders), mean
    over the calibration placements, within 5 % of its target (measured: within 1 %)."""
    dims = (6.0, 5.0, 3.0)
    targets = np.array([0.6, 0.55, 0.5, 0.45, 0.4, 0.35, 0.3])
    profile = np.outer([1, 1, 0.8, 0.8, 0.5, 1.5], np.ones(7)) * 0.2
    room = calibrate_room(dims, targets, absorption=profile, bands_hz=OCTAVE_CENTERS_HZ)
    got = []
    for k in range(len(CALIBRATION_PLACEMENTS)):
        src, mic = default_calibration_positions(dims, k)
        h = room_rir(room, src, mic, fs=FS, length_s=1.2 * targets.max() + 0.05)[0]
        got.append(octave_rt60(h, FS, OCTAVE_CENTERS_HZ[:6]))
    np.testing.assert_allclose(np.mean(got, axis=0), targets[:6], rtol=0.05)
    # The profile's wall shape is kept within every band.
    x = -np.log1p(-room.wall_absorption)
    np.testing.assert_allclose(x / x[0], -np.log1p(-profile) / -np.log1p(-profile[0]), rtol=1e-12)


def test_memoised(monkeypatch, tmp_path):
    """A second identical request does not run the loop (memory level of cached_array).

    The disk cache points at an empty folder: a room another test (or an earlier run) stored
    there must not satisfy the first request."""
    monkeypatch.setenv("SCENESIM_CACHE", str(tmp_path))
    clear_memory_cache()
    calls = []
    real = calibration._calibrate
    monkeypatch.setattr(calibration, "_calibrate", lambda *a: calls.append(1) or real(*a))
    a = calibrate_absorption((5.0, 4.0, 3.0), 0.3)
    b = calibrate_absorption((5.0, 4.0, 3.0), 0.3)
    assert len(calls) == 1
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"dims_m": (6, 5, 3), "rt60_s": 0.05}, "rt60_s"),  # needs absorption > 1
        ({"dims_m": (6, 5, 3), "rt60_s": (0.5, 0.4)}, "rt60_s"),  # per band without bands
        ({"dims_m": (6, 5, 3), "rt60_s": 0.5, "bands_hz": (125, 250)}, "bands_hz"),  # no speech octave
        ({"dims_m": (6, 5, -3), "rt60_s": 0.5}, "dims_m"),
    ],
)
def test_bad_requests_raise(kwargs, name):
    with pytest.raises(ParameterError, match=name):
        calibrate_room(**kwargs)


def test_room_module_does_not_import_the_renderer():
    """The room <-> ISM cycle is broken: scenesim/room/shoebox.py imports neither ism, render nor
    calibration, not even inside functions (oracle: its syntax tree)."""
    tree = ast.parse(Path(calibration.__file__).with_name("shoebox.py").read_text())
    imported = {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
    imported |= {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    assert not imported & {"scenesim.room.ism", "scenesim.room.render", "scenesim.room.calibration", "scenesim.room.cache"}


def test_a_fresh_process_builds_a_calibrated_room_without_importing_the_calibrator_first():
    """Regression: ``scenesim`` loads its names lazily, so a sweep worker may build
    ``ShoeBox(rt60_method="calibrated")`` in a process that never imported
    ``scenesim.room.calibration`` (which registers the calibrator); every ``distance`` row failed."""
    import subprocess
    import sys

    code = ("import sys; from scenesim.room.shoebox import ShoeBox; "
            "assert 'scenesim.room.calibration' not in sys.modules; "
            "r = ShoeBox((5.0, 4.0, 3.0), rt60_s=0.3, rt60_method='calibrated'); "
            "print(r.rt60_method, 'scenesim.room.calibration' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["calibrated", "True"]
