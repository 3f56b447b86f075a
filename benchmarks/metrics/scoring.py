"""The public metrics API: score processed speech, with or without a clean reference.

One call scores one mono signal; :func:`score_files` scores files or folders -- paired with
their references as :mod:`benchmarks.metrics.pairing` says, each pair time-aligned first as
:mod:`benchmarks.metrics.align` says -- and is what ``scenesim score`` runs.

Metrics (column names of :func:`score` and of the ``scenesim score`` CSV):

============================== ====================================================================
with a reference (intrusive)   ``pesq_nb_mos_lqo`` (P.862.1), ``pesq_nb_raw`` (P.862 raw, -0.5..4.5),
                               ``pesq_wb_mos_lqo`` (P.862.2), ``pesq_wb_raw`` (P.862.2 mapping
                               inverted), ``stoi``, ``estoi``, ``si_sdr_db``, ``segsnr_db``
always (non-intrusive)         ``srmr`` (reverberation: higher is drier), ``dnsmos_sig``,
                               ``dnsmos_bak``, ``dnsmos_ovrl`` (DNSMOS P.835) and ``dnsmos_p808``
                               (DNSMOS P.808), with the ``[dnsmos]`` extra
============================== ====================================================================

The intrusive metrics are :mod:`benchmarks.metrics.speech` (PESQ through the ``pesq`` package,
STOI/ESTOI through ``pystoi``), SRMR is :mod:`benchmarks.metrics.srmr` and DNSMOS is
:mod:`benchmarks.metrics.dnsmos`; all are re-exported here.  SRMR and DNSMOS are computed at
16 kHz (the signal is resampled when its rate differs: DNSMOS was trained on 16 kHz
speech and SRMR is validated at 8 and 16 kHz).  A metric that is undefined for a signal
(too short, silent, no utterance) leaves its value ``None`` and says why in ``"error"``: an
all-zero processed signal leaves every intrusive column empty with ``silent output`` (SI-SDR
would read 0 dB and segmental SNR the clamp's floor, better than many real outputs), a silent
reference every intrusive column with ``silent reference``.

DNSMOS: ``dnsmos=None`` (the default) computes it when the extra is installed; ``True``
requires it and raises :class:`~scenesim.errors.ExtraNotInstalled` (``pip install
"scenesim[dnsmos]"``) without it; ``False`` skips it.

Example
-------
>>> import numpy as np
>>> fs = 16000
>>> rng = np.random.default_rng(0)
>>> t = np.arange(2 * fs) / fs
>>> clean = 0.3 * rng.standard_normal(t.size) * (1 + np.sin(2 * np.pi * 3 * t))  # power 0.135
>>> noisy = clean + 0.1 * rng.standard_normal(t.size)                            # power 0.01
>>> row = score(noisy, fs, reference=clean, dnsmos=False)
>>> round(row["si_sdr_db"], 1)          # 10 log10(0.135 / 0.01) = 11.3 dB
11.3
>>> bool(row["pesq_wb_mos_lqo"] < row["pesq_nb_mos_lqo"] < 4.5), bool(row["srmr"] > 0), row["error"]
(True, True, '')
"""

from __future__ import annotations

import functools
import math
import multiprocessing
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass

import numpy as np

from benchmarks.metrics import dnsmos as _dnsmos
from benchmarks.metrics.align import DEFAULT_MAX_LAG_S, align_pair, declared_delay
from benchmarks.metrics.pairing import AUDIO_SUFFIXES, Pair, pair_files, read_pair_list
from benchmarks.metrics.speech import (
    SILENCE_PEAK,
    pesq_raw_from_mos_lqo,
    pesq_scores,
    segmental_snr_db,
    si_sdr_db,
    stoi_scores,
)
from benchmarks.metrics.srmr import srmr
from scenesim.audio import audio_rate, check_rate, read_audio, resample
from scenesim.errors import DataError, MetricError, ParameterError
from scenesim.validate import check_audio_fs, check_int

__all__ = [
    "AUDIO_SUFFIXES", "FILE_COLUMNS", "INTRUSIVE", "NON_INTRUSIVE", "Pair", "ScoreOptions", "pair_files",
    "pesq_raw_from_mos_lqo", "pesq_scores", "pesq_wb_raw_from_mos_lqo", "read_pair_list", "score",
    "score_files", "score_pairs", "segmental_snr_db", "si_sdr_db", "srmr", "stoi_scores",
]

INTRUSIVE = ("pesq_nb_mos_lqo", "pesq_nb_raw", "pesq_wb_mos_lqo", "pesq_wb_raw", "stoi", "estoi",
             "si_sdr_db", "segsnr_db")
"""Columns that need a clean reference."""
NON_INTRUSIVE = ("srmr", "dnsmos_sig", "dnsmos_bak", "dnsmos_ovrl", "dnsmos_p808")
"""Columns computed from the processed signal alone."""
FILE_COLUMNS = ("system", "utterance", "file", "reference", "status", "fs", "duration_s", "lag_samples",
                "lag_source")
"""Columns :func:`score_files` puts before the metrics (``status``: ``ok`` or ``failed``)."""

_NON_INTRUSIVE_FS = 16000
#: Most worker processes ``score_files`` starts (a practical bound; more only queue).
MAX_WORKERS = 64

# ITU-T P.862.2 mapping of the raw score: MOS-LQO = 0.999 + 4 / (1 + exp(-1.3669 x + 3.8224)).
_P8622_SLOPE, _P8622_OFFSET = 1.3669, 3.8224


def pesq_wb_raw_from_mos_lqo(mos_lqo: float) -> float:
    """Raw P.862 score under the wide-band MOS-LQO (the P.862.2 mapping inverted), -0.5..4.5.

    >>> y = 0.999 + 4 / (1 + math.exp(-1.3669 * 2.0 + 3.8224))
    >>> round(pesq_wb_raw_from_mos_lqo(y), 9)
    2.0
    """
    y = float(mos_lqo)
    if not math.isfinite(y):
        raise ParameterError("mos_lqo", mos_lqo, "a finite MOS-LQO score")
    lo, hi = (0.999 + 4.0 / (1.0 + math.exp(-_P8622_SLOPE * x + _P8622_OFFSET)) for x in (-0.5, 4.5))
    if y <= lo:  # the raw range's ends, MOS-LQO 1.03..4.64
        return -0.5
    if y >= hi:
        return 4.5
    return (_P8622_OFFSET - math.log(4.0 / (y - 0.999) - 1.0)) / _P8622_SLOPE


def _attempt(errors: list[str], label: str, func, *args, **kwargs):
    """``func(...)``, or None with ``label: reason`` appended to ``errors`` when undefined."""
    try:
        return func(*args, **kwargs)
    except (MetricError, ParameterError) as exc:
        errors.append(f"{label}: {exc}")
        return None


def _silent(x: np.ndarray) -> bool:
    return float(np.max(np.abs(x))) < SILENCE_PEAK


def _intrusive(ref: np.ndarray, deg: np.ndarray, fs: int, errors: list[str]) -> dict:
    row: dict = dict.fromkeys(INTRUSIVE)
    for x, what in ((ref, "silent reference"), (deg, "silent output")):
        if _silent(x):  # every intrusive score is undefined, not 0 dB or the clamp's floor
            errors.append(f"{', '.join(INTRUSIVE)}: {what}")
            return row
    p = _attempt(errors, "pesq", pesq_scores, ref, deg, fs=fs) or {}
    if p.get("nb") is not None:
        row["pesq_nb_mos_lqo"], row["pesq_nb_raw"] = p["nb"], pesq_raw_from_mos_lqo(p["nb"])
    if p.get("wb") is not None:
        row["pesq_wb_mos_lqo"], row["pesq_wb_raw"] = p["wb"], pesq_wb_raw_from_mos_lqo(p["wb"])
    row.update(_attempt(errors, "stoi", stoi_scores, ref, deg, fs=fs) or {})
    row["si_sdr_db"] = _attempt(errors, "si_sdr", si_sdr_db, ref, deg)
    row["segsnr_db"] = _attempt(errors, "segsnr", segmental_snr_db, ref, deg, fs=fs)
    return row


def _non_intrusive(deg: np.ndarray, fs: int, dnsmos: bool, errors: list[str]) -> dict:
    x16 = resample(deg[None], fs, _NON_INTRUSIVE_FS)[0] if fs != _NON_INTRUSIVE_FS else deg
    row: dict = dict.fromkeys(NON_INTRUSIVE)
    row["srmr"] = _attempt(errors, "srmr", srmr, x16, _NON_INTRUSIVE_FS)
    if dnsmos:
        row.update(_attempt(errors, "dnsmos", _dnsmos.dnsmos_p835, x16, _NON_INTRUSIVE_FS) or {})
        row["dnsmos_p808"] = _attempt(errors, "dnsmos_p808", _dnsmos.dnsmos_p808, x16, _NON_INTRUSIVE_FS)
    return row


def _want_dnsmos(dnsmos: bool | None) -> bool:
    """None: when installed; True: required (the install line when absent); False: off."""
    if dnsmos is None:
        return _dnsmos.installed()
    if dnsmos:
        _dnsmos.require()
    return bool(dnsmos)


def _mono(x, name: str) -> np.ndarray:
    arr = np.asarray(x, dtype=np.float64)
    if arr.ndim == 2 and arr.shape[0] == 1:
        arr = arr[0]
    if arr.ndim != 1 or arr.size == 0 or not np.all(np.isfinite(arr)):
        raise ParameterError(name, arr, "a finite, non-empty mono signal (n,) or (1, n)")
    return arr


def score(degraded, fs: int, reference=None, *, dnsmos: bool | None = None) -> dict:
    """Every metric that applies to ``degraded`` (and ``reference``, when given).

    Parameters
    ----------
    degraded : array (n,) or (1, n)
        The processed (or recorded) speech, full-scale float.
    fs : int
        Sampling rate in Hz of both signals.
    reference : array (n,), optional
        The clean speech, time aligned with ``degraded`` and of the same length.
    dnsmos : bool or None
        DNSMOS P.835 and P.808: None when the ``[dnsmos]`` extra is installed, True required
        (:class:`~scenesim.errors.ExtraNotInstalled` without it), False off.  About as costly
        as PESQ.

    Returns
    -------
    dict
        The :data:`INTRUSIVE` columns (None without a reference) and :data:`NON_INTRUSIVE`
        columns (floats, or None where undefined) and ``"error"`` ('' or the reasons).
    """
    deg = _mono(degraded, "degraded")
    fs = check_audio_fs(fs)
    dnsmos = _want_dnsmos(dnsmos)
    errors: list[str] = []
    row: dict = dict.fromkeys(INTRUSIVE)
    if reference is not None:
        ref = _mono(reference, "reference")
        if ref.size != deg.size:
            raise ParameterError("reference", ref, f"the degraded signal's length ({deg.size} samples)")
        row = _intrusive(ref, deg, fs, errors)
    row.update(_non_intrusive(deg, fs, dnsmos, errors))
    row["error"] = "; ".join(errors)
    return row


# -- files -------------------------------------------------------------------------------


@dataclass(frozen=True)
class ScoreOptions:
    """How :func:`score_pairs` scores each pair (picklable: worker processes receive it).

    ``channel``: the channel scored of every file (None: files must be mono); ``trim``, ``align``
    and ``max_lag_s`` (seconds): :func:`benchmarks.metrics.align.align_pair`; ``dnsmos``: bool.
    """

    channel: int | None = None
    trim: bool = False
    dnsmos: bool = False
    align: bool = True
    max_lag_s: float = DEFAULT_MAX_LAG_S


def _check_channel(path, n_channels: int, channel: int | None) -> None:
    if channel is None and n_channels > 1:
        raise DataError(
            f"{path} has {n_channels} channels: pass --channel I (I in 0..{n_channels - 1}) to score "
            "that channel of every file"
        )
    if channel is not None and not 0 <= channel < n_channels:
        kind = "mono" if n_channels == 1 else f"{n_channels} channels"
        raise ParameterError("--channel", channel, f"a channel index in 0..{n_channels - 1} ({path} is {kind})")


def _check_headers(pairs: Sequence[Pair], channel: int | None) -> None:
    """Every file's header rate held to the range of ``--fs`` and ``channel`` checked against its
    channels, before any work; unreadable files are left to fail their own rows."""
    import soundfile as sf

    seen: set = set()
    for path in (p for pair in pairs for p in (pair.degraded, pair.reference)):
        if path is None or path in seen or not path.is_file():
            continue
        seen.add(path)
        try:
            rate = audio_rate(path)
        except DataError:
            continue  # unreadable: its row says why
        check_rate(path, rate)
        try:
            channels = sf.info(str(path)).channels
        except (sf.LibsndfileError, RuntimeError):
            continue
        _check_channel(path, channels, channel)


def _empty_row(pair: Pair) -> dict:
    row = {"system": pair.system, "utterance": pair.utterance, "file": str(pair.degraded),
           "reference": "" if pair.reference is None else str(pair.reference), "status": "failed",
           "fs": None, "duration_s": None, "lag_samples": None, "lag_source": None}
    row.update(dict.fromkeys(INTRUSIVE + NON_INTRUSIVE))
    row["error"] = ""
    return row


def _load(pair: Pair, options: ScoreOptions):
    """``(processed (n,), reference (n,) or None, fs, Aligned or None)`` of one pair, aligned."""
    if pair.problem:
        raise DataError(pair.problem)
    x, fs = read_audio(pair.degraded)
    y = x[options.channel or 0]
    if pair.reference is None:
        return y, None, fs, None
    r, fs_ref = read_audio(pair.reference)
    if fs_ref != fs:
        raise DataError(
            f"{pair.degraded} is {fs} Hz but its reference {pair.reference} is {fs_ref} Hz: resample one "
            f"to the other's rate first (e.g. sox {pair.degraded} -r {fs_ref} out.wav)"
        )
    declared = declared_delay(pair.degraded, fs) if options.align else None
    a = align_pair(y, r[options.channel or 0], fs=fs, declared=declared, max_lag_s=options.max_lag_s,
                   trim=options.trim, align=options.align)
    return a.degraded, a.reference, fs, a


def _score_one(pair: Pair, options: ScoreOptions) -> dict:
    """One row: the file's columns and every metric, or status ``failed`` with the reason."""
    row = _empty_row(pair)
    try:
        y, r, fs, aligned = _load(pair, options)
    except (DataError, ParameterError) as exc:
        row["error"] = str(exc)
        return row
    row.update(status="ok", fs=fs, duration_s=y.size / fs)
    if aligned is not None:
        row.update(lag_samples=aligned.lag, lag_source=aligned.source)
    row.update(score(y, fs, r, dnsmos=options.dnsmos))
    return row


def score_pairs(pairs: Sequence[Pair], options: ScoreOptions = ScoreOptions(), *, workers: int = 1) -> list[dict]:
    """Score pairs, one row each in the pairs' order (:data:`FILE_COLUMNS`, the metrics, ``error``).

    Every file's header is checked first (rate, ``options.channel``): a rate outside
    8000-192000 Hz or a channel a file lacks raises before any scoring.  A pair that cannot be
    scored (unreadable, no reference, rates differ, lengths beyond the trim rule) gets status
    ``failed`` and the reason in ``error``; the others go on.  ``workers > 1`` scores in a
    process pool (forkserver); rows equal the serial ones (each metric is deterministic).
    """
    workers = check_int("workers", workers, minimum=1, maximum=MAX_WORKERS)
    _check_headers(pairs, options.channel)
    job = functools.partial(_score_one, options=options)
    if workers == 1 or len(pairs) < 2:
        return [job(p) for p in pairs]
    ctx = multiprocessing.get_context("forkserver")
    with ProcessPoolExecutor(max_workers=min(workers, len(pairs)), mp_context=ctx) as pool:
        return list(pool.map(job, pairs))


def score_files(degraded: Sequence = (), reference=None, *, pairs=None, channel: int | None = None,
                trim: bool = False, dnsmos: bool | None = None, align: bool = True,
                max_lag_s: float = DEFAULT_MAX_LAG_S, workers: int = 1) -> list[dict]:
    """Score files or folders against a reference file or folder, or the pairs of a list file.

    ``degraded``/``reference`` pair as :func:`benchmarks.metrics.pairing.pair_files` says;
    ``pairs`` (a list file of ``ref,deg[,system]`` lines) replaces both.  Each pair is aligned
    (:func:`benchmarks.metrics.align.align_pair`: the delay the file declares, else the
    cross-correlation within ``max_lag_s`` seconds; ``align=False``: as given) and scored by
    :func:`score`; see :func:`score_pairs` for the rows, failures and ``workers``.
    """
    use_dnsmos = _want_dnsmos(dnsmos)
    found = read_pair_list(pairs) if pairs is not None else pair_files(degraded, reference)
    options = ScoreOptions(channel=channel, trim=trim, dnsmos=use_dnsmos, align=align, max_lag_s=max_lag_s)
    return score_pairs(found, options, workers=workers)
