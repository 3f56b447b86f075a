"""The public metrics API: score processed speech, with or without a clean reference.

One call scores one mono signal; :func:`score_files` scores files or folders (folders are
paired with the reference folder by file name) and is what ``scenesim score`` runs.

Metrics (column names of :func:`score` and of the ``scenesim score`` CSV):

============================== ====================================================================
with a reference (intrusive)   ``pesq_nb_mos_lqo`` (P.862.1), ``pesq_nb_raw`` (P.862 raw, -0.5..4.5),
                               ``pesq_wb_mos_lqo`` (P.862.2), ``pesq_wb_raw`` (P.862.2 mapping
                               inverted), ``stoi``, ``estoi``, ``si_sdr_db``, ``segsnr_db``
always (non-intrusive)         ``srmr`` (reverberation: higher is drier), ``dnsmos_sig``,
                               ``dnsmos_bak``, ``dnsmos_ovrl`` (DNSMOS P.835, when the ``[dnsmos]``
                               extra is installed)
============================== ====================================================================

The intrusive metrics are :mod:`benchmarks.metrics.speech` (PESQ through the ``pesq`` package,
STOI/ESTOI through ``pystoi``), SRMR is :mod:`benchmarks.metrics.srmr` and DNSMOS is
:mod:`benchmarks.metrics.dnsmos`; all are re-exported here.  SRMR and DNSMOS are computed at
16 kHz (the signal is resampled when its rate differs: DNSMOS was trained on 16 kHz
speech and SRMR is validated at 8 and 16 kHz).  A metric that is undefined for a signal
(too short, silent, no utterance) leaves its value ``None`` and says why in ``"error"``.

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

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from benchmarks.metrics.speech import (
    pesq_raw_from_mos_lqo,
    pesq_scores,
    segmental_snr_db,
    si_sdr_db,
    stoi_scores,
)
from benchmarks.metrics.srmr import srmr
from scenesim.audio import read_audio, resample
from scenesim.errors import DataError, MetricError, ParameterError

__all__ = [
    "INTRUSIVE", "NON_INTRUSIVE", "pesq_raw_from_mos_lqo", "pesq_scores", "pesq_wb_raw_from_mos_lqo",
    "score", "score_files", "pair_files", "segmental_snr_db", "si_sdr_db", "srmr", "stoi_scores",
]

INTRUSIVE = ("pesq_nb_mos_lqo", "pesq_nb_raw", "pesq_wb_mos_lqo", "pesq_wb_raw", "stoi", "estoi",
             "si_sdr_db", "segsnr_db")
"""Columns that need a clean reference."""
NON_INTRUSIVE = ("srmr", "dnsmos_sig", "dnsmos_bak", "dnsmos_ovrl")
"""Columns computed from the processed signal alone."""

AUDIO_SUFFIXES = (".wav", ".flac")
_NON_INTRUSIVE_FS = 16000

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


def _intrusive(ref: np.ndarray, deg: np.ndarray, fs: int, errors: list[str]) -> dict:
    row: dict = dict.fromkeys(INTRUSIVE)
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
        from benchmarks.metrics.dnsmos import dnsmos_p835  # the optional [dnsmos] extra

        row.update(_attempt(errors, "dnsmos", dnsmos_p835, x16, _NON_INTRUSIVE_FS) or {})
    return row


def _mono(x, name: str) -> np.ndarray:
    arr = np.asarray(x, dtype=np.float64)
    if arr.ndim == 2 and arr.shape[0] == 1:
        arr = arr[0]
    if arr.ndim != 1 or arr.size == 0 or not np.all(np.isfinite(arr)):
        raise ParameterError(name, arr, "a finite, non-empty mono signal (n,) or (1, n)")
    return arr


def score(degraded, fs: int, reference=None, *, dnsmos: bool = True) -> dict:
    """Every metric that applies to ``degraded`` (and ``reference``, when given).

    Parameters
    ----------
    degraded : array (n,) or (1, n)
        The processed (or recorded) speech, full-scale float.
    fs : int
        Sampling rate in Hz of both signals.
    reference : array (n,), optional
        The clean speech, time aligned with ``degraded`` and of the same length.
    dnsmos : bool
        Compute DNSMOS P.835 (needs the ``[dnsmos]`` extra; about as costly as PESQ).

    Returns
    -------
    dict
        The :data:`INTRUSIVE` columns (None without a reference) and :data:`NON_INTRUSIVE`
        columns (floats, or None where undefined) and ``"error"`` ('' or the reasons).
    """
    deg = _mono(degraded, "degraded")
    fs = int(fs)
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


def _audio_files(path: Path) -> list[Path]:
    if path.is_dir():
        files = sorted(p for p in path.iterdir() if p.suffix.lower() in AUDIO_SUFFIXES and p.is_file())
        if not files:
            raise DataError(f"{path} holds no {'/'.join(AUDIO_SUFFIXES)} files")
        return files
    if not path.exists():
        raise DataError(f"no such file or folder: {path}")
    return [path]


def pair_files(degraded: Sequence, reference=None) -> list[tuple[Path, Path | None]]:
    """``(degraded file, reference file or None)`` pairs from files and folders.

    Folders contribute their ``.wav``/``.flac`` files (not recursive, sorted).  A reference
    folder is paired by file name; a single reference file pairs with a single degraded file.
    """
    degs = [f for p in degraded for f in _audio_files(Path(p))]
    if reference is None:
        return [(d, None) for d in degs]
    ref = Path(reference)
    if not ref.is_dir():
        if len(degs) != 1:
            raise DataError(
                f"--ref {ref} is one file but {len(degs)} files are to be scored: "
                "give a reference folder whose files have the same names"
            )
        return [(degs[0], _audio_files(ref)[0])]
    pairs = []
    for d in degs:
        match = ref / d.name
        if not match.is_file():
            raise DataError(f"no reference for {d}: {match} does not exist (folders pair by file name)")
        pairs.append((d, match))
    return pairs


def _check_pair(deg_path: Path, x: np.ndarray, fs: int, ref_path: Path, r: np.ndarray, fs_ref: int,
                trim: bool) -> tuple[np.ndarray, np.ndarray]:
    if fs != fs_ref:
        raise DataError(
            f"{deg_path} is {fs} Hz but its reference {ref_path} is {fs_ref} Hz: resample one to "
            f"the other's rate first (e.g. sox {deg_path} -r {fs_ref} out.wav)"
        )
    if x.shape[0] != r.shape[0]:
        raise DataError(
            f"{deg_path} has {x.shape[0]} channel(s) but {ref_path} has {r.shape[0]}: "
            "pass --channel I to score channel I of each file"
        )
    n, m = x.shape[1], r.shape[1]
    if n != m and not trim:
        raise DataError(
            f"{deg_path} has {n} samples but {ref_path} has {m} ({abs(n - m) / fs * 1000:.1f} ms "
            "apart): align them, or pass --trim to score the first min(len) samples of both"
        )
    k = min(n, m)
    return x[:, :k], r[:, :k]


def _channel(x: np.ndarray, channel: int | None, path: Path) -> np.ndarray:
    if channel is None:
        if x.shape[0] != 1:
            raise DataError(f"{path} has {x.shape[0]} channels: pass --channel I to score one of them")
        return x[0]
    if not 0 <= channel < x.shape[0]:
        raise DataError(f"{path} has {x.shape[0]} channel(s); --channel {channel} is not among them")
    return x[channel]


def score_files(degraded: Sequence, reference=None, *, channel: int | None = None,
                trim: bool = False, dnsmos: bool = True) -> list[dict]:
    """Score files or folders: one row per degraded file (see :func:`score` for the columns).

    Each row starts with ``file``, ``reference`` ('' without one), ``fs`` and ``duration_s``.
    Mismatched rates, channel counts or lengths raise :class:`DataError` naming the fix.
    """
    rows = []
    for deg_path, ref_path in pair_files(degraded, reference):
        x, fs = read_audio(deg_path)
        r = None
        if ref_path is not None:
            ref, fs_ref = read_audio(ref_path)
            x, ref = _check_pair(deg_path, x, fs, ref_path, ref, fs_ref, trim)
            r = _channel(ref, channel, ref_path)
        y = _channel(x, channel, deg_path)
        row = {"file": str(deg_path), "reference": "" if ref_path is None else str(ref_path),
               "fs": fs, "duration_s": y.size / fs}
        row.update(score(y, fs, r, dnsmos=dnsmos))
        rows.append(row)
    return rows
