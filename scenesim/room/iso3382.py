"""ISO 3382-1 room-acoustic parameters of an impulse response, and their diffuse-field targets.

Definitions (``p`` the RIR, ``t = 0`` its **onset**: the known direct arrival when given, else
the first sample within 20 dB of the peak as ISO 3382-1 A.3.4 asks)::

    T30, EDT (per octave)  Schroeder curve of the octave-filtered RIR from the onset on, line
                           fit -5..-35 dB / 0..-10 dB, 60 dB / slope (:mod:`scenesim.room.rt60`)
    T_mid                  mean of the 500 Hz and 1 kHz octave T30 (ISO 3382-2 A; likewise EDT_mid)
    T_speech               mean of the 500 Hz, 1 kHz and 2 kHz octave T30 -- the quantity the
                           calibration fits (:data:`scenesim.room.bands.SPEECH_BANDS_HZ`)
    C50                    10 log10( E[0, 50 ms) / E[50 ms, inf) )                (dB)
    D50                    E[0, 50 ms) / E[0, inf)   = 1 / (1 + 10^(-C50/10))    (fraction)
    DRR (windowed)         10 log10( E[n_d - 2.5 ms, n_d + 2.5 ms] / E(n_d + 2.5 ms, inf) ),
                           n_d the direct-sound peak: what measured-RIR work reports
    DRR (exact image)      10 log10( E_direct / E_rest ) with the order-0 image as the direct
                           sound (only a simulator has it; up to ~5 dB below the windowed one,
                           which also counts the reflections of the first 2.5 ms)

Octave filters: :func:`scenesim.room.bands.octave_filter` (3rd-order Butterworth run forward and
backward: zero phase, so the filter's own ringing does not lengthen short decays).  A decay
that does not reach the end of a fit range gives NaN for that octave.

Targets (:func:`diffuse_field_parameters`): in Sabine's diffuse field a room of reverberation
time ``T`` has T30 = EDT = T in every octave; with direct energy ``D`` and reverberant energy
``R`` at distance r (``D / R = (r_c / r)^2``, ``r_c = 0.057 sqrt(V / T)``) decaying as
``exp(-13.82 t / T)`` from the direct arrival on, the energy after ``t_e`` is ``R q``,
``q = exp(-13.82 t_e / T)``, so ``C(t_e) = 10 log10((D + R (1 - q)) / (R q))``: C50 with
``t_e`` = 50 ms, the windowed DRR with ``t_e`` = 2.5 ms, and D50 from C50.  Each measured
quantity is set beside the same quantity of the target.

Range of validity of the C50 target (calibrated rooms, scattering 0.5, 12 seeded placements
each; ``python -m benchmarks.studies.rooms_check --only validity``): in a corridor, a room with
one absorptive wall and an open office (mean absorption 0.11-0.28, RT60 0.5-0.8 s) the measured
C50 sits a median 0.3-0.4 dB below the prediction (single placements -1.25..+0.70 dB).  The
reason is the model's start: it lets the reflected energy decay from full level at the direct
arrival, while the image field builds up over the first milliseconds, so the first 50 ms hold
0.56-0.73 of the reflected energy against ``1 - q`` = 0.58-0.75.  Barron & Lee's revised
theory (J. Acoust. Soc. Am. 84, 1988: reflected energy scaled by ``exp(-13.82 r / (c T))``)
lowers the late level too and so moves the prediction the other way (median miss -0.4..-0.7 dB);
it is not offered.  Below T ~ 0.1 s, where ``q < 1e-3``, C50 measures the tail more than 30 dB
down and is not a room property: in a damped car cabin (2.5 x 1.5 x 1.2 m, 0.08 s, mean
absorption 0.43) C50 ~ 37 dB sits 1.2 dB (0.2-2.2) below the target, 1.2 dB of it the 20 Hz
high-pass's ringing, and EDT, whose 10 dB span lasts 13 ms there (about the octave filters'
own response), reads +1..+25 % over T.  Compare clarity with this target only above ~0.1 s.
"""

from __future__ import annotations

import math

import numpy as np

from scenesim.errors import ParameterError
from scenesim.room.bands import OCTAVE_CENTERS_HZ, SPEECH_BANDS_HZ, check_centers, octave_filter
from scenesim.room.rt60 import measure_rt60
from scenesim.validate import check_fs, check_positive

C50_WINDOW_S = 0.05
"""Early/late split of C50 and D50 after the onset (s)."""
DRR_HALF_WINDOW_S = 0.0025
"""Half width of the direct-sound window of the windowed DRR (s)."""
TMID_BANDS_HZ = (500.0, 1000.0)
"""Octaves averaged into T_mid and EDT_mid (ISO 3382-2 A)."""
ONSET_DB = -20.0
"""ISO 3382-1 onset: first sample whose level is within this of the peak."""


def onset_sample(h) -> int:
    """First sample of ``h`` ``(n,)`` within 20 dB of its peak (ISO 3382-1's start of the RIR).

    >>> onset_sample(np.array([0.0, 0.01, 0.5, 1.0, 0.2]))
    2
    """
    e = np.asarray(h, dtype=float).reshape(-1) ** 2
    if e.size == 0 or not np.any(e > 0):
        raise ParameterError("h", "silent", "an impulse response with energy")
    return int(np.nonzero(e >= e.max() * 10.0 ** (ONSET_DB / 10.0))[0][0])


def _db_ratio(num: float, den: float) -> float:
    if den <= 0.0:
        return float("inf") if num > 0.0 else float("nan")
    return float(10.0 * math.log10(max(num, 1e-300) / den))


def clarity_db(h, fs, *, onset: int, window_s: float = C50_WINDOW_S) -> float:
    """C (dB) of ``h`` ``(n,)``: energy in ``[onset, onset + window)`` over the energy after it.

    Closed form for ``h[n] = r^(n/2)`` (energy ratio r per sample), onset 0, ``N`` window
    samples: ``10 log10((1 - r^N) / r^N)``.

    >>> r = 0.999
    >>> h = np.sqrt(r) ** np.arange(200000)
    >>> bool(abs(clarity_db(h, 1000, onset=0) - 10 * np.log10((1 - r**50) / r**50)) < 1e-9)
    True
    """
    fs = check_fs(fs)
    e = np.asarray(h, dtype=float).reshape(-1) ** 2
    cut = onset + int(round(check_positive("window_s", window_s) * fs))
    return _db_ratio(float(e[onset:cut].sum()), float(e[cut:].sum()))


def definition_d50(c50_db: float) -> float:
    """D50 (fraction of the energy in the first 50 ms) from C50: ``1 / (1 + 10^(-C50/10))``.

    >>> definition_d50(0.0)
    0.5
    """
    return float(1.0 / (1.0 + 10.0 ** (-c50_db / 10.0)))


def windowed_drr_db(h, fs, *, half_window_s: float = DRR_HALF_WINDOW_S, peak: int | None = None) -> float:
    """DRR (dB) with the direct sound the energy within ``+-half_window_s`` of the peak.

    ``h`` ``(n,)``; ``peak`` the direct-sound sample (default ``argmax |h|``).  The
    reverberant energy is everything after the window.

    >>> h = np.zeros(1000); h[100] = 1.0; h[200:] = 0.1
    >>> round(windowed_drr_db(h, 1000), 3)  # 1 / (800 * 0.01)
    -9.031
    """
    fs = check_fs(fs)
    x = np.asarray(h, dtype=float).reshape(-1)
    n_d = int(np.argmax(np.abs(x))) if peak is None else int(peak)
    w = int(round(check_positive("half_window_s", half_window_s) * fs))
    e = x**2
    return _db_ratio(float(e[max(0, n_d - w) : n_d + w + 1].sum()), float(e[n_d + w + 1 :].sum()))


def exact_drr_db(h, h_direct) -> float:
    """DRR (dB) with the exact direct path ``h_direct`` (same length or shorter) as direct sound."""
    x = np.asarray(h, dtype=float).reshape(-1)
    d = np.zeros_like(x)
    hd = np.asarray(h_direct, dtype=float).reshape(-1)[: x.size]
    d[: hd.size] = hd
    return _db_ratio(float(np.sum(d**2)), float(np.sum((x - d) ** 2)))


def _decay_time(x, fs, method: str) -> float:
    try:
        return float(measure_rt60(x, fs, method=method))
    except ParameterError:  # the decay does not reach the end of the fit range
        return float("nan")


def octave_decay_times(h, fs, *, onset: int, centers_hz=OCTAVE_CENTERS_HZ) -> dict[str, np.ndarray]:
    """``{"t30_s": (n_bands,), "edt_s": (n_bands,)}`` per octave, Schroeder curve from ``onset``.

    Octaves at or above Nyquist / sqrt(2) are NaN.
    """
    fs = check_fs(fs)
    x = np.asarray(h, dtype=float).reshape(-1)
    t30, edt = [], []
    for fc in check_centers(centers_hz):
        if fc / math.sqrt(2.0) >= 0.499 * fs:
            t30.append(float("nan"))
            edt.append(float("nan"))
            continue
        y = octave_filter(x, fs, fc)[onset:]
        t30.append(_decay_time(y, fs, "T30"))
        edt.append(_decay_time(y, fs, "EDT"))
    return {"t30_s": np.array(t30), "edt_s": np.array(edt)}


def _band_mean(values: np.ndarray, centers, pick) -> float:
    idx = [list(centers).index(float(f)) for f in pick if float(f) in centers]
    if len(idx) != len(pick):
        return float("nan")
    return float(np.mean(values[idx]))


def room_parameters(h, fs, *, h_direct=None, direct_sample: int | None = None,
                    centers_hz=OCTAVE_CENTERS_HZ) -> dict[str, object]:
    """ISO 3382-1 parameters of one RIR ``h`` ``(n,)`` (module docstring).

    Parameters
    ----------
    h : (n,) array
        The impulse response, tap 0 = emission.
    fs : int
        Sampling rate (Hz).
    h_direct : (m,) array, optional
        The exact direct path (order-0 image): adds ``drr_exact_db``; its peak is the onset.
    direct_sample : int, optional
        The direct-sound arrival sample (onset and windowed-DRR centre).  Default: the peak of
        ``h_direct`` if given, else the ISO 20 dB onset.

    Returns
    -------
    dict with ``bands_hz``, ``t30_s`` / ``edt_s`` ``(n_bands,)`` arrays (NaN where undefined),
    ``t_mid_s``, ``edt_mid_s``, ``t_speech_s``, ``edt_speech_s``, ``c50_db``, ``d50``,
    ``drr_windowed_db``, ``drr_exact_db`` (None without ``h_direct``), ``onset_sample``.

    Example
    -------
    >>> fs = 8000; t = np.arange(2 * fs) / fs
    >>> h = np.random.default_rng(0).standard_normal(t.size) * 10 ** (-3 * t / 0.5)
    >>> p = room_parameters(h, fs, centers_hz=(500, 1000))
    >>> bool(abs(p["t_mid_s"] - 0.5) < 0.05), bool(abs(p["c50_db"] - 10 * np.log10(10 ** 0.6 - 1)) < 0.5)
    (True, True)
    """
    fs = check_fs(fs)
    x = np.asarray(h, dtype=float).reshape(-1)
    if x.size < 2 or not np.all(np.isfinite(x)):
        raise ParameterError("h", getattr(x, "shape", h), "a finite impulse response (n,) with n >= 2")
    centers = check_centers(centers_hz)
    if direct_sample is None:
        direct_sample = (int(np.argmax(np.abs(np.asarray(h_direct, dtype=float).reshape(-1))))
                         if h_direct is not None else onset_sample(x))
    onset = int(np.clip(direct_sample, 0, x.size - 1))
    decay = octave_decay_times(x, fs, onset=onset, centers_hz=centers)
    c50 = clarity_db(x, fs, onset=onset)
    return {
        "bands_hz": centers,
        "t30_s": decay["t30_s"],
        "edt_s": decay["edt_s"],
        "t_mid_s": _band_mean(decay["t30_s"], centers, TMID_BANDS_HZ),
        "edt_mid_s": _band_mean(decay["edt_s"], centers, TMID_BANDS_HZ),
        "t_speech_s": _band_mean(decay["t30_s"], centers, SPEECH_BANDS_HZ),
        "edt_speech_s": _band_mean(decay["edt_s"], centers, SPEECH_BANDS_HZ),
        "c50_db": c50,
        "d50": definition_d50(c50),
        "drr_windowed_db": windowed_drr_db(x, fs, peak=onset),
        "drr_exact_db": None if h_direct is None else exact_drr_db(x, h_direct),
        "onset_sample": onset,
    }


def critical_distance_m(volume_m3: float, rt60_s: float) -> float:
    """Sabine's critical distance ``r_c = 0.057 sqrt(V / RT60)`` (m) of an omni source.

    >>> round(critical_distance_m(56.0, 0.5), 3)
    0.603
    """
    return float(0.057 * np.sqrt(check_positive("volume_m3", volume_m3) / check_positive("rt60_s", rt60_s)))


def diffuse_clarity_db(distance_m: float, critical_distance_m: float, rt60_s: float, window_s: float) -> float:
    """Diffuse-field ``C(t_e)`` (dB) at ``distance_m``: ``10 log10((D + R(1 - q)) / (R q))``.

    >>> round(diffuse_clarity_db(1.0, 1.0, 0.5, 0.05), 3)  # D = R, q = 10^(-0.6)
    8.427
    """
    dr = (critical_distance_m / distance_m) ** 2
    q = math.exp(-6.0 * math.log(10.0) * window_s / rt60_s)
    return 10.0 * math.log10((dr + 1.0 - q) / q)


def diffuse_field_parameters(rt60_s: float, distance_m: float, volume_m3: float) -> dict[str, float]:
    """The same parameters as :func:`room_parameters` in Sabine's diffuse field (module docstring).

    Returns ``t30_s = edt_s = t_mid_s = edt_mid_s = t_speech_s = rt60_s``, ``c50_db``, ``d50``,
    ``drr_windowed_db`` and ``drr_exact_db = 20 log10(r_c / r)``, plus ``critical_distance_m``.

    >>> p = diffuse_field_parameters(0.5, 0.603, 56.0)
    >>> round(p["drr_exact_db"], 2), round(p["d50"], 3)
    (0.0, 0.874)
    """
    t = check_positive("rt60_s", rt60_s)
    r = check_positive("distance_m", distance_m)
    rc = critical_distance_m(volume_m3, t)
    c50 = diffuse_clarity_db(r, rc, t, C50_WINDOW_S)
    out = dict.fromkeys(("t30_s", "edt_s", "t_mid_s", "edt_mid_s", "t_speech_s", "edt_speech_s"), t)
    out.update(c50_db=c50, d50=definition_d50(c50),
               drr_windowed_db=diffuse_clarity_db(r, rc, t, DRR_HALF_WINDOW_S),
               drr_exact_db=20.0 * math.log10(rc / r), critical_distance_m=rc)
    return out


__all__ = [
    "C50_WINDOW_S",
    "DRR_HALF_WINDOW_S",
    "ONSET_DB",
    "TMID_BANDS_HZ",
    "clarity_db",
    "critical_distance_m",
    "definition_d50",
    "diffuse_clarity_db",
    "diffuse_field_parameters",
    "exact_drr_db",
    "octave_decay_times",
    "onset_sample",
    "room_parameters",
    "windowed_drr_db",
]
