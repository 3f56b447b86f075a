"""Per-condition evaluation: input metrics once per mixture, then one results row per enhancer.

Data flow (algorithms.md section 8): a rendered scene (mixture, speech image, noise image,
reference) -> enhancer -> output SNR by shadow filtering (``Result.replay`` on the speech
and noise images) or, for black boxes, by phase inversion (Hagerman & Olofsson 2004) ->
PESQ / STOI / segmental SNR / SI-SDR of the latency-aligned output against the reference.

Failure policy (the contract's ``status``/``error`` columns):

* ``status = 'error'`` only when the enhancer itself failed (raised, wrong channel count,
  bad output shape or non-finite output); every output metric is then ``None`` and
  ``error`` holds ``"<ExceptionType>: <message> (at file:line in func)"``.
* ``status = 'ok'`` otherwise.  A metric that cannot be computed (PESQ on silence, too
  short for STOI, ...) is ``None`` and ``error`` lists each failure as
  ``"<metric>: <reason>"`` joined by ``"; "`` (input-metric failures included);
  ``error`` is ``None`` when everything was computed.

Neither function raises for an enhancer or metric failure: a sweep never crashes here.
"""

from __future__ import annotations

import json
import time
import warnings
from collections.abc import Mapping
from typing import Any

import numpy as np

from benchmarks.excinfo import exc_text as _exc_text
from benchmarks.metrics import speech as M
from benchmarks.metrics.reverb import (
    REVERB_INPUT_COLUMNS,
    REVERB_OUTPUT_COLUMNS,
    input_columns,
    output_columns,
)
from benchmarks.metrics.row_measures import (
    MEASURE_COLUMNS,
    attribution_columns,
    distortion_columns,
    g160_columns,
    split_columns,
)
from scenesim.errors import ParameterError

#: Columns produced by :func:`input_metrics` (SQL types for the results store).
INPUT_COLUMNS: dict[str, str] = {
    "pesq_nb_in": "REAL",
    "pesq_nb_raw_in": "REAL",
    "pesq_wb_in": "REAL",
    "stoi_in": "REAL",
    "estoi_in": "REAL",
    "segsnr_in_db": "REAL",
    "si_sdr_in_db": "REAL",
    "snr_in_db_measured": "REAL",
    "snr_in_band_db": "REAL",
    "inband_lo_hz": "REAL",
    "inband_hi_hz": "REAL",
    "self_snr_in_db": "REAL",
    **REVERB_INPUT_COLUMNS,  # from the speech parts (benchmarks.metrics.reverb), None without them
    "input_error": "TEXT",
}

#: Columns produced by :func:`evaluate_enhancer` (includes :data:`INPUT_COLUMNS` except
#: ``input_error``, which is folded into ``error``).  Condition columns (``condition_id``,
#: ``noise``, ``snr_in_db``, ``rt60_s``, angles, ``seed``, sources) are the runner's.
ROW_COLUMNS: dict[str, str] = {
    "enhancer": "TEXT",
    "status": "TEXT",
    "error": "TEXT",
    "snr_method": "TEXT",
    "snr_cross_ratio": "REAL",
    "snr_out_db": "REAL",
    "snr_i_db": "REAL",
    "snr_out_hagerman_db": "REAL",
    "snr_i_hagerman_db": "REAL",
    "snr_out_band_db": "REAL",
    "snr_i_band_db": "REAL",
    "snr_out_limit_db": "REAL",
    **{k: v for k, v in INPUT_COLUMNS.items() if k != "input_error"},
    "pesq_nb_out": "REAL",
    "pesq_nb_raw_out": "REAL",
    "pesq_wb_out": "REAL",
    "pesq_nb_i": "REAL",
    "pesq_nb_raw_i": "REAL",
    "pesq_wb_i": "REAL",
    "stoi_out": "REAL",
    "estoi_out": "REAL",
    "stoi_i": "REAL",
    "estoi_i": "REAL",
    "segsnr_out_db": "REAL",
    "segsnr_i_db": "REAL",
    "si_sdr_out_db": "REAL",
    "si_sdr_i_db": "REAL",
    "latency_samples": "INTEGER",
    "latency_est_samples": "INTEGER",
    "latency_check": "TEXT",
    "process_s": "REAL",
    "metrics_s": "REAL",
    "trace_json": "TEXT",
    **REVERB_OUTPUT_COLUMNS,
    **MEASURE_COLUMNS,  # distortion, G.160, attribution (benchmarks.metrics.row_measures)
}

#: At most this many points of each beta trajectory go into ``trace_json``.
TRACE_MAX_POINTS = 2000
#: Lag search half-width for the latency check, in seconds beyond the declared latency.
LAG_SEARCH_S = 0.032
#: ``|2 <s_out, n_out>| / P(s_out + n_out)`` above this makes the output SNR suspect.
CROSS_WARN_RATIO = 0.2
#: The band of the in-band SNR columns when the condition sets none: where speech lives
#: (a 0 dB wind whose power lies below 100 Hz is not a 0 dB condition for speech).
INBAND_HZ = (100.0, 7000.0)
#: Array gain of two mics for spatially white noise, 10 log10(2) dB: no linear 2-mic
#: processing raises the speech-to-self-noise ratio by more (white-noise gain <= M).
SELF_NOISE_ARRAY_GAIN_DB = 10.0 * np.log10(2.0)


def inband_hz(rendered) -> tuple[float, float]:
    """The band of the in-band SNR columns: the scene's ``snr_band_hz`` or :data:`INBAND_HZ`
    (its top edge capped at 7/16 of fs, 3.5 kHz at 8 kHz)."""
    band = getattr(rendered.scene, "snr_band_hz", None)
    if band is not None:
        return float(band[0]), float(band[1])
    return INBAND_HZ[0], min(INBAND_HZ[1], 7.0 * int(rendered.fs) / 16.0)


def _try(errors: list[str], label: str, func, *args, **kwargs):
    """Call a metric; on any failure record ``"label: reason"`` and return None."""
    try:
        return func(*args, **kwargs)
    except M.MetricError as exc:
        errors.append(f"{label}: {exc}")
    except Exception as exc:  # a metric bug must not crash the sweep either
        errors.append(f"{label}: {_exc_text(exc)}")
    return None


def _ref_row(rendered) -> np.ndarray:
    return np.asarray(rendered.reference, dtype=np.float64).reshape(
        -1, np.shape(rendered.reference)[-1]
    )[0]


def _quality_names(suffix: str) -> tuple[str, ...]:
    """Column names :func:`_quality` fills for ``suffix`` ("in" or "out"), in a fixed order."""
    return (f"pesq_nb_{suffix}", f"pesq_nb_raw_{suffix}", f"pesq_wb_{suffix}", f"stoi_{suffix}",
            f"estoi_{suffix}", f"segsnr_{suffix}_db", f"si_sdr_{suffix}_db")


def _quality(ref: np.ndarray, est: np.ndarray, fs: int, suffix: str, errors: list[str]) -> dict:
    """PESQ nb/wb, STOI/ESTOI, segmental SNR and SI-SDR of ``est`` against ``ref``."""
    out: dict[str, Any] = {}
    p = _try(errors, f"pesq_{suffix}", M.pesq_scores, ref, est, fs=fs) or {}
    out[f"pesq_nb_{suffix}"] = p.get("nb")
    # The raw P.862 score (the scale the thesis quotes), from the package's P.862.1 MOS-LQO.
    out[f"pesq_nb_raw_{suffix}"] = None if p.get("nb") is None else M.pesq_raw_from_mos_lqo(p["nb"])
    out[f"pesq_wb_{suffix}"] = p.get("wb")
    s = _try(errors, f"stoi_{suffix}", M.stoi_scores, ref, est, fs=fs) or {}
    out[f"stoi_{suffix}"] = s.get("stoi")
    out[f"estoi_{suffix}"] = s.get("estoi")
    out[f"segsnr_{suffix}_db"] = _try(
        errors, f"segsnr_{suffix}", M.segmental_snr_db, ref, est, fs=fs
    )
    out[f"si_sdr_{suffix}_db"] = _try(errors, f"si_sdr_{suffix}", M.si_sdr_db, ref, est)
    return out


def input_metrics(rendered, *, speech_parts=None, reference: str = "direct") -> dict[str, Any]:
    """Metrics of the unprocessed mixture at the reference mic (channel 0); once per mixture.

    Parameters
    ----------
    rendered : RenderedScene
        Needs ``mixture (2, n)``, ``speech_image (2, n)``, ``noise_image (2, n)``,
        ``reference (1, n)`` and ``fs``.

    Returns
    -------
    dict
        ``pesq_nb_in, pesq_wb_in, stoi_in, estoi_in, segsnr_in_db, si_sdr_in_db`` (mixture
        channel 0 vs reference), ``snr_in_db_measured`` (power of speech image channel 0
        over noise image channel 0, whole signal) and ``input_error`` (text or None).
        With ``speech_parts`` (:func:`scenesim.room.reverb_parts.speech_parts`) and the scene's
        ``reference``: the reverberation columns ``sinr_in_db, drr_in_db, c50_in_db, srmr_in,
        metric_target, early_window_ms`` (:mod:`benchmarks.metrics.reverb`), else None.
    """
    errors: list[str] = []
    fs = int(rendered.fs)
    ref = _ref_row(rendered)
    mix0 = np.asarray(rendered.mixture, dtype=np.float64)[0]
    row = _quality(ref, mix0[: ref.size], fs, "in", errors)
    s0 = np.asarray(rendered.speech_image, dtype=np.float64)[0]
    n0 = np.asarray(rendered.noise_image, dtype=np.float64)[0]
    row["snr_in_db_measured"] = _try(errors, "snr_in", M.snr_db, s0, n0)
    band = inband_hz(rendered)
    row["inband_lo_hz"], row["inband_hi_hz"] = band
    row["snr_in_band_db"] = _try(errors, "snr_in_band", _band_snr_db, s0, n0, int(rendered.fs), band)
    self_noise = getattr(rendered, "self_noise_image", None)
    if self_noise is not None and np.any(self_noise):
        row["self_snr_in_db"] = _try(errors, "self_snr_in", M.snr_db, s0, np.asarray(self_noise)[0])
    else:
        row["self_snr_in_db"] = None
    row.update(dict.fromkeys(REVERB_INPUT_COLUMNS))
    if speech_parts is not None:
        row.update(_try(errors, "reverb_in", input_columns, rendered, speech_parts, reference=reference) or {})
    row["input_error"] = "; ".join(errors) or None
    return row


def _band_snr_db(s, n, fs: int, band) -> float:
    """SNR in dB of ``s`` over ``n`` within ``band`` (Hz), an ideal band-pass on both."""
    return M.band_snr_db(s, n, fs=fs, band_hz=band)


def _input_band_snr(row, errors, s0, n0, m: int, fs: int, band):
    """The input's in-band SNR over its first ``m`` samples: the condition's own
    ``snr_in_band_db`` when ``m`` is the whole signal (no latency), else computed."""
    if m == s0.size and row.get("snr_in_band_db") is not None:
        return row["snr_in_band_db"]
    return _try(errors, "snr_in_band", _band_snr_db, s0[:m], n0[:m], fs, band)


_input_metrics = input_metrics  # evaluate_enhancer's keyword of the same name shadows it


def _select_channels(enhancer, rendered) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mixture, speech image and noise image as the enhancer takes them (1 or 2 channels)."""
    channels = int(enhancer.tags.channels_in)
    mix = np.asarray(rendered.mixture, dtype=np.float64)
    if channels < 1 or channels > mix.shape[0]:
        raise ParameterError(
            "channels_in", channels, f"1 or {mix.shape[0]} (the scene has {mix.shape[0]} mics)"
        )
    pick = slice(0, channels)  # a 1-channel enhancer gets the reference mic (channel 0)
    return (
        mix[pick],
        np.asarray(rendered.speech_image, dtype=np.float64)[pick],
        np.asarray(rendered.noise_image, dtype=np.float64)[pick],
    )


def _check_output(y, n_samples: int, what: str) -> np.ndarray:
    y = np.asarray(y, dtype=np.float64)
    if y.ndim != 2 or y.shape[0] < 1 or y.shape[1] != n_samples:
        raise ParameterError(what, y, f"a (n_out, {n_samples}) array")
    if not np.all(np.isfinite(y)):
        raise ParameterError(what, y, "finite values only (no NaN or Inf)")
    return y


def _components(enhancer, result, x, s, n, fs, notes: list[str]):
    """``(s_out, n_out, method)``: speech and noise parts of the output, shape (n_out, n)."""
    y = result.output
    if enhancer.tags.replayable:
        try:
            s_out = _check_output(result.replay(s), x.shape[1], "replay(speech)")
            n_out = _check_output(result.replay(n), x.shape[1], "replay(noise)")
            return s_out, n_out, "replay"
        except Exception as exc:
            notes.append(f"replay failed, used phase inversion: {_exc_text(exc)}")
    plus = s + n
    scale = max(float(np.max(np.abs(x))), M.POWER_FLOOR)
    # The scene's mixture is s + n; reuse its output unless rounding made them differ.
    if float(np.max(np.abs(plus - x))) <= 1e-12 * scale:
        y1 = y
    else:
        y1 = _check_output(enhancer.process(plus, fs).output, x.shape[1], "output(s + n)")
    y2 = _check_output(enhancer.process(s - n, fs).output, x.shape[1], "output(s - n)")
    return 0.5 * (y1 + y2), 0.5 * (y1 - y2), "phase-inversion"


def _hagerman_snr_out_db(enhancer, result, signals, fs, latency, ref, method, snr_out_db):
    """``(snr_out_db, result2)``: output SNR by phase inversion, ``y1 = f(s + n)`` (the output),
    ``y2 = f(s - n)``, and the Result of ``s - n`` (None when ``method`` already did this)."""
    if method == "phase-inversion":
        return snr_out_db, None  # already measured this way
    x, s, n, y = signals
    result2 = enhancer.process(s - n, fs)
    y2 = _check_output(result2.output, x.shape[1], "output(s - n)")
    s_al, _ = M.align(0.5 * (y[0] + y2[0]), ref, latency_samples=latency)
    n_al, _ = M.align(0.5 * (y[0] - y2[0]), ref, latency_samples=latency)
    return M.snr_db(s_al, n_al), result2


def _trace_json(trace: Mapping[str, Any], n_samples: int, fs: int) -> str | None:
    """Beta trajectories (keys ending in 'beta') as compact JSON, block-mean decimated.

    ``{"eb.beta": {"step_s": 0.005, "values": [...]}}``; a 2-D trace (frames, bins) is
    averaged over bins first.  ``step_s`` assumes the trace spans the whole signal.
    """
    out = {}
    for key, value in (trace or {}).items():
        if not str(key).endswith("beta"):
            continue
        v = np.asarray(value, dtype=np.float64)
        if v.ndim == 0 or v.size == 0:
            continue
        if v.ndim > 1:
            v = v.reshape(v.shape[0], -1).mean(axis=1)
        decim = max(1, int(np.ceil(v.size / TRACE_MAX_POINTS)))
        m = v.size // decim
        blocks = v[: m * decim].reshape(m, decim).mean(axis=1) if m else v[:1]
        step_s = n_samples / fs / v.size * decim
        out[str(key)] = {
            "step_s": step_s,
            "values": [round(float(b), 5) if np.isfinite(b) else None for b in blocks],
        }
    return json.dumps(out, separators=(",", ":")) if out else None


def _delta(a, b):
    return None if a is None or b is None else a - b


def evaluate_enhancer(
    enhancer,
    rendered,
    *,
    input_metrics: Mapping[str, Any] | None = None,
    latency_tolerance_samples: int | None = None,
    speech_parts=None,
) -> dict[str, Any]:
    """Run ``enhancer`` on one rendered scene and measure it; returns one results row (dict).

    Parameters
    ----------
    enhancer : enhancers.core.base.Enhancer
        Fed channel 0 if ``tags.channels_in == 1``, both mics if 2 (more is an error row).
    rendered : RenderedScene
        ``mixture, speech_image, noise_image (2, n)``, ``reference (1, n)``, ``fs``.
    input_metrics : mapping, optional
        The result of :func:`input_metrics` for this mixture (computed here if omitted).
        In-band SNR (``snr_*_band_db``): the same, measured in ``inband_lo_hz..inband_hi_hz``.
        ``snr_i_hagerman_db``: the SNR-I by phase inversion (Hagerman & Olofsson 2004) beside
        the replay one, for every enhancer (equal to ``snr_i_db`` for black boxes, whose only
        SNR is that); adaptive and non-linear systems make the two differ.
        ``snr_out_limit_db``: with sensor self-noise, the speech-to-self-noise ratio at the
        reference mic plus the 2-mic white-noise array gain (3 dB): the highest output SNR a
        linear two-mic system can reach; a higher ``snr_out_db`` comes from time-varying gains
        (or is an error) and the report flags it.
    speech_parts : scenesim.room.reverb_parts.SpeechParts, optional
        The direct / early / late speech images: adds the SINR / DRR / C50 / SRMR output
        columns (:mod:`benchmarks.metrics.reverb`; the input ones come in ``input_metrics``).
    latency_tolerance_samples : int, optional
        Allowed difference between the declared latency and the cross-correlation lag of
        the speech component of the output against the reference before ``latency_check``
        records a warning (default ``max(2, 0.5 ms)``).

    Returns
    -------
    dict
        The columns of :data:`ROW_COLUMNS`.  Output SNR:
        ``snr_out_db = 10 log10(P(s_out) / P(n_out))`` over the latency-aligned first output
        channel, ``s_out, n_out`` from ``Result.replay`` (``snr_method='replay'``) or phase
        inversion ``s_out = (y1 + y2)/2, n_out = (y1 - y2)/2`` with ``y1 = f(s + n),
        y2 = f(s - n)`` (``'phase-inversion'``); ``snr_i_db = snr_out_db - snr_in``, where
        ``snr_in`` is the speech/noise power ratio at the reference mic over the same
        (aligned) samples -- equal to ``snr_in_db_measured`` when the latency is 0.
        The other ``*_out`` metrics compare the first output channel with the reference
        after removing the declared latency; ``*_i`` are ``out - in``.
        ``snr_cross_ratio = 2 <s_out, n_out> / P(s_out + n_out)`` is a check on the SNR
        itself: above :data:`CROSS_WARN_RATIO` in magnitude a ``RuntimeWarning`` says that
        ``snr_out_db`` is unreliable (the runner records warnings in the row).
    """
    row: dict[str, Any] = dict.fromkeys(ROW_COLUMNS)
    row["enhancer"] = getattr(enhancer, "name", type(enhancer).__name__)
    errors: list[str] = []
    try:
        if input_metrics is None:
            input_metrics = _input_metrics(rendered)
        for key in INPUT_COLUMNS:
            if key != "input_error":
                row[key] = input_metrics.get(key)
        if input_metrics.get("input_error"):
            errors.append(str(input_metrics["input_error"]))
        fs = int(rendered.fs)
        latency = int(enhancer.tags.latency_samples)
        row["latency_samples"] = latency
        x, s, n = _select_channels(enhancer, rendered)
        t0 = time.perf_counter()
        result = enhancer.process(x, fs)
        row["process_s"] = time.perf_counter() - t0
        y = _check_output(result.output, x.shape[1], "output")
    except Exception as exc:
        row["status"] = "error"
        row["error"] = "; ".join([f"enhancer failed: {_exc_text(exc)}", *errors])
        return row

    t0 = time.perf_counter()
    row["status"] = "ok"
    try:
        _measure(
            row,
            enhancer,
            rendered,
            result,
            (x, s, n, y),
            fs,
            latency,
            tol=latency_tolerance_samples,
            errors=errors,
        )
    except Exception as exc:  # a bug in measuring must not crash the sweep
        errors.append(f"evaluation: {_exc_text(exc)}")
    if speech_parts is not None:
        try:
            row.update(output_columns(enhancer, result, rendered, speech_parts, channels=x.shape[0], latency=latency, srmr_in=row.get("srmr_in")))
        except Exception as exc:
            errors.append(f"reverb metrics: {_exc_text(exc)}")
    row["metrics_s"] = time.perf_counter() - t0
    row["error"] = "; ".join(errors) or None
    return row


def _measure(row, enhancer, rendered, result, signals, fs, latency, *, tol, errors) -> None:
    """Fill ``row`` with the output metrics (see :func:`evaluate_enhancer`).

    ``signals = (x, s, n, y)``: the enhancer's input, its speech and noise images (same
    channels) and its output.
    """
    x, s, n, y = signals
    ref = _ref_row(rendered)
    try:
        s_out, n_out, row["snr_method"] = _components(enhancer, result, x, s, n, fs, errors)
    except Exception as exc:
        errors.append(f"snr_out: {_exc_text(exc)}")
        s_out = n_out = None
    y_al, ref_al = M.align(y[0], ref, latency_samples=latency)
    if s_out is not None:
        _snr_columns(row, enhancer, rendered, result, signals, (s_out, n_out), (ref, y_al), fs, latency, errors)
    # Latency check on the speech component (cleaner than the noisy output) when we have it.
    _latency_columns(row, s_out[0] if s_out is not None else y[0], ref, fs, latency, tol, errors)
    _quality_columns(row, rendered, ref, (ref_al, y_al), fs, latency, errors)
    row["trace_json"] = _try(errors, "trace_json", _trace_json, result.trace, x.shape[1], fs)


def _snr_columns(row, enhancer, rendered, result, signals, parts, refs, fs, latency, errors) -> None:
    """Replay and Hagerman SNRs (full band and in band), the self-noise bound, the cross term and
    the issue-16 measures, from the output's speech and noise parts ``parts = (s_out, n_out)``."""
    x, s, n, y = signals
    s_out, n_out = parts
    ref, y_al = refs
    s0 = np.asarray(rendered.speech_image, dtype=np.float64)[0]
    n0 = np.asarray(rendered.noise_image, dtype=np.float64)[0]
    s_al, _ = M.align(s_out[0], ref, latency_samples=latency)
    n_al, _ = M.align(n_out[0], ref, latency_samples=latency)
    m = s_al.size
    row["snr_out_db"] = _try(errors, "snr_out", M.snr_db, s_al, n_al)
    snr_in = _try(errors, "snr_in", M.snr_db, s0[:m], n0[:m])
    row["snr_i_db"] = _delta(row["snr_out_db"], snr_in)
    band = inband_hz(rendered)
    row["snr_out_band_db"] = _try(errors, "snr_out_band", _band_snr_db, s_al, n_al, fs, band)
    band_in = _input_band_snr(row, errors, s0, n0, m, fs, band)
    row["snr_i_band_db"] = _delta(row["snr_out_band_db"], band_in)
    hag, result2 = _try(errors, "snr_hagerman", _hagerman_snr_out_db, enhancer, result, (x, s, n, y), fs, latency, ref, row["snr_method"], row["snr_out_db"]) or (None, None)
    row["snr_out_hagerman_db"] = hag
    row["snr_i_hagerman_db"] = _delta(hag, snr_in)
    self_noise = getattr(rendered, "self_noise_image", None)
    if self_noise is not None and np.any(self_noise):
        limit = _try(errors, "snr_out_limit", M.snr_db, s0[:m], np.asarray(self_noise)[0][:m])
        row["snr_out_limit_db"] = None if limit is None else limit + SELF_NOISE_ARRAY_GAIN_DB
    # Independent speech and noise stay nearly uncorrelated through a fixed or slowly
    # varying filter.  A large cross term means the components were scaled up where
    # they cancel (e.g. a gain > 1 on bins where |S + N| << |S|, |N|); their powers,
    # hence the output SNR, then describe the gain mask more than the output.
    p_y = float(np.mean((s_al + n_al) ** 2))
    cross = 2.0 * float(np.mean(s_al * n_al)) / max(p_y, M.POWER_FLOOR)
    row["snr_cross_ratio"] = cross
    _new_measures(row, errors, rendered, (result, result2), (s, n, s_out, n_out), (s_al, n_al, y_al), fs, latency)
    if abs(cross) > CROSS_WARN_RATIO:
        warnings.warn(
            f"{row['enhancer']}: speech and noise outputs ({row['snr_method']}) are "
            f"correlated: 2<s_out, n_out> = {cross:+.0%} of the output power; "
            "snr_out_db is unreliable for this row",
            RuntimeWarning,
            stacklevel=3,
        )


def _latency_columns(row, probe, ref, fs, latency, tol, errors) -> None:
    """``latency_est_samples`` and, when it misses the declared latency by more than ``tol``
    samples (default 0.5 ms), a ``latency_check`` note."""
    if tol is None:
        tol = max(2, int(round(0.5e-3 * fs)))
    lag = _try(errors, "latency_check", M.estimate_lag, probe, ref,
               max_lag=latency + max(1, int(round(LAG_SEARCH_S * fs))))
    row["latency_est_samples"] = lag
    if lag is not None and abs(lag - latency) > tol:
        row["latency_check"] = (
            f"declared latency {latency} samples but the output's speech component best "
            f"matches the reference at a lag of {lag} samples (tolerance {tol})"
        )


def _quality_columns(row, rendered, ref, aligned, fs, latency, errors) -> None:
    """PESQ, STOI, ESTOI, segmental SNR and SI-SDR of the output and their improvements."""
    ref_al, y_al = aligned
    mix0 = np.asarray(rendered.mixture, dtype=np.float64)[0]
    if latency == 0 and ref_al.size == ref.size and np.array_equal(y_al, mix0[: ref.size]):
        # The output is the unprocessed reference-mic signal (passthrough): the very signals
        # the input metrics scored, so the scores are the same.  Saves a fifth of a thesis
        # sweep's PESQ/STOI time.
        row.update(zip(_quality_names("out"), (row[k] for k in _quality_names("in"))))
    else:
        row.update(_quality(ref_al, y_al, fs, "out", errors))
    for name in ("pesq_nb", "pesq_nb_raw", "pesq_wb", "stoi", "estoi"):
        row[f"{name}_i"] = _delta(row[f"{name}_out"], row[f"{name}_in"])
    row["segsnr_i_db"] = _delta(row["segsnr_out_db"], row["segsnr_in_db"])
    row["si_sdr_i_db"] = _delta(row["si_sdr_out_db"], row["si_sdr_in_db"])


def _new_measures(row, errors, rendered, results, parts, aligned, fs, latency) -> None:
    """Distortion, G.160 and attribution columns (:mod:`benchmarks.metrics.row_measures`), each on its own.

    ``results = (result, result2)``: the row's Result and the Hagerman run's (W2; None for
    black boxes); ``parts = (s, n, s_out,
    n_out)``: speech and noise as the enhancer took them and the output's full speech and
    noise parts; ``aligned = (s_al, n_al, y_al)``.
    """
    s, n, s_out, n_out = parts
    result, result2 = results
    s_al, n_al, y_al = aligned
    m = s_al.size
    s0 = np.asarray(rendered.speech_image, dtype=np.float64)[0][:m]
    n0 = np.asarray(rendered.noise_image, dtype=np.float64)[0][:m]
    if result2 is not None and row["snr_method"] == "replay":
        row.update(_try(errors, "distortion", distortion_columns, result2, s, n, s_out, n_out, latency=latency, n_ref=_ref_row(rendered).size) or {})
    # one footing: the recommendation's estimate for every system, exact parts beside it where replayable
    mix0 = np.asarray(rendered.mixture, dtype=np.float64)[0][:m]
    exact = (s0, n0, s_al, n_al) if row["snr_method"] == "replay" else None
    row.update(_try(errors, "g160", g160_columns, s0, fs, mixture=mix0, output=y_al, parts=exact) or {})
    self_noise = getattr(rendered, "self_noise_image", None)
    self0 = None if self_noise is None else np.asarray(self_noise, dtype=np.float64)[0][:m]
    row.update(_try(errors, "attribution", attribution_columns, s0, n0, s_al, n_al, fs, snr_i_db=row["snr_i_db"], self_noise=self0) or {})
    white = result if row["snr_method"] == "replay" else None
    row.update(_try(errors, "attribution split", split_columns, white, s, n, (s_al, n_al), fs, latency=latency, snr_i_db=row["snr_i_db"]) or {})
