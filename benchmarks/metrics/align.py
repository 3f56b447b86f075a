"""Time alignment of a processed signal with its clean reference, and the delay a file declares.

Intrusive metrics (SI-SDR, segmental SNR, STOI) compare sample ``n`` of the processed signal
``y`` with sample ``n`` of the reference ``s``; an enhancer's latency ``L`` shifts ``y`` by
``L`` samples and, uncorrected, turns a good output into a bad score.  A pair is aligned by
one integer lag ``L`` (samples): ``y[n + L]`` is paired with ``s[n]`` and both are cut to
their overlap.  ``L > 0`` means the processed signal lags the reference, ``L < 0`` that it
leads.  The lag comes from, in order:

1. ``"declared"``: the delay ``scenesim enhance`` recorded in the file (:func:`enhance_comment`,
   read back by :func:`declared_delay`) -- 0 for its default latency-compensated output, the
   enhancer's latency with ``--keep-latency``;
2. ``"xcorr"``: the lag ``|L| <= max_lag_s * fs`` maximising ``|sum_n y[n + L] s[n]|``
   (:func:`benchmarks.metrics.speech.estimate_lag`, one zero-padded FFT);
3. ``"none"``: alignment off, ``L = 0``.

Length rule: without ``trim`` the two signals may differ in length only by what the lag
explains -- after the shift the two remainders differ by at most ``|L|`` samples (the
delayed signal's missing or extra tail).  A larger difference raises :class:`DataError`
naming both lengths; with ``trim`` the overlap is scored whatever the lengths.

The declared delay lives in the audio file's ``comment`` text field (WAV ``LIST/INFO ICMT``,
FLAC Vorbis comment) as one JSON object with the key ``"scenesim_enhance"``.  Embedded
rather than in a sidecar file, it travels with the audio when files are copied or renamed
into system folders, and a tool that rewrites the audio without it loses the declaration
rather than leaving a stale one beside the file (scoring then falls back to the
cross-correlation).  libsndfile drops a WAV comment longer than 2040 characters silently,
so :func:`enhance_comment` shortens the record (parameters out) to fit.

Example
-------
>>> import numpy as np
>>> s = np.random.default_rng(0).standard_normal(1000)
>>> y = np.concatenate([np.zeros(7), s])[:1000]          # 7 samples late, same length
>>> a = align_pair(y, s, fs=16000)
>>> a.lag, a.source, a.degraded.size, bool(np.array_equal(a.degraded, s[:993]))
(7, 'xcorr', 993, True)
>>> align_pair(s, s, fs=16000, declared=0).source
'declared'
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from benchmarks.metrics.speech import estimate_lag
from scenesim.errors import DataError, ParameterError

__all__ = ["Aligned", "DEFAULT_MAX_LAG_S", "COMMENT_LIMIT", "MAX_LAG_LIMIT_S", "align_pair",
           "declared_delay", "enhance_comment", "read_enhance_record", "shift_pair"]

#: Default bound of the cross-correlation search (s): an enhancer's latency (dfn3: 42 ms,
#: eb-robust-ss: 32 ms at 16 kHz) plus a recording chain's buffering fit well inside.
DEFAULT_MAX_LAG_S = 0.5
#: The largest bound accepted: beyond it a lag is a different take, not a delay.
MAX_LAG_LIMIT_S = 10.0
#: The longest WAV comment libsndfile writes (longer ones are dropped without a word).
COMMENT_LIMIT = 2040
_KEY = "scenesim_enhance"


@dataclass(frozen=True)
class Aligned:
    """A pair after alignment: ``degraded[n]`` = input ``y[n + lag]`` pairs with ``reference[n]``."""

    degraded: np.ndarray
    reference: np.ndarray
    lag: int
    source: str  # "declared", "xcorr" or "none"


def shift_pair(degraded: np.ndarray, reference: np.ndarray, lag: int) -> tuple[np.ndarray, np.ndarray]:
    """``(y[L:], s)`` for ``L >= 0`` or ``(y, s[-L:])`` for ``L < 0``, cut to their overlap (views).

    >>> y, s = shift_pair(np.arange(6), np.arange(10, 14), -2)
    >>> y.tolist(), s.tolist()
    ([0, 1], [12, 13])
    """
    lag = int(lag)
    y = degraded[lag:] if lag >= 0 else degraded
    s = reference if lag >= 0 else reference[-lag:]
    n = min(y.size, s.size)
    return y[:n], s[:n]


def _check_lengths(n_deg: int, n_ref: int, lag: int, trim: bool) -> None:
    rest_deg, rest_ref = n_deg - max(lag, 0), n_ref - max(-lag, 0)
    if min(rest_deg, rest_ref) <= 0:
        raise DataError(f"no overlap after a lag of {lag} samples ({n_deg} and {n_ref} samples)")
    if not trim and abs(rest_deg - rest_ref) > abs(lag):
        raise DataError(
            f"{n_deg} samples against the reference's {n_ref} (lag {lag}): they differ by more than "
            f"the lag explains; pass --trim to score the overlap"
        )


def align_pair(degraded, reference, *, fs: int, declared: int | None = None,
               max_lag_s: float = DEFAULT_MAX_LAG_S, trim: bool = False, align: bool = True) -> Aligned:
    """Align a processed signal ``(n,)`` with its reference ``(m,)`` (see the module docstring).

    Parameters
    ----------
    degraded, reference : array (n,), (m,)
        Mono signals at ``fs`` Hz.
    fs : int
        Sampling rate (Hz), to turn ``max_lag_s`` into samples.
    declared : int, optional
        The delay (samples) the file declares; used as the lag when given.
    max_lag_s : float
        Bound of the cross-correlation search, seconds (0 < max_lag_s <= 10).
    trim : bool
        Score the overlap whatever the lengths (else the length rule applies).
    align : bool
        False: lag 0 (the pair is compared as given).

    Returns
    -------
    Aligned
        The two cut signals (views), the lag in samples and where it came from.
    """
    y = np.asarray(degraded)
    s = np.asarray(reference)
    if not align:
        lag, source = 0, "none"
    elif declared is not None:
        lag, source = int(declared), "declared"
    else:
        if not 0 < max_lag_s <= MAX_LAG_LIMIT_S:
            raise ParameterError("max_lag_s", max_lag_s, f"a bound in (0, {MAX_LAG_LIMIT_S:g}] s")
        lag, source = estimate_lag(y, s, max_lag=int(round(max_lag_s * fs))), "xcorr"
    _check_lengths(y.size, s.size, lag, trim)
    y_a, s_a = shift_pair(y, s, lag)
    return Aligned(y_a, s_a, lag, source)


# -- the record scenesim enhance writes into its output ----------------------------------


def enhance_comment(*, enhancer: str, params: dict, latency_samples: int, removed: bool, fs: int,
                    scenesim_version: str) -> str:
    """The JSON text ``scenesim enhance`` stores in its output's ``comment`` field.

    ``delay_samples`` is what the file still holds (0 when the latency was removed);
    ``latency_removed_samples`` what was taken off.  Parameters are left out (and
    ``params_omitted`` set) when the record would pass :data:`COMMENT_LIMIT` characters.

    >>> text = enhance_comment(enhancer="ss@1", params={}, latency_samples=255, removed=True,
    ...                        fs=16000, scenesim_version="0")
    >>> json.loads(text)["scenesim_enhance"]["delay_samples"]
    0
    """
    record = {"enhancer": enhancer, "params": params, "fs": int(fs),
              "latency_samples": int(latency_samples),
              "latency_removed_samples": int(latency_samples) if removed else 0,
              "delay_samples": 0 if removed else int(latency_samples), "scenesim": scenesim_version}
    text = json.dumps({_KEY: record}, separators=(",", ":"), default=str)
    if len(text) > COMMENT_LIMIT:
        record = {**record, "params": None, "params_omitted": True}
        text = json.dumps({_KEY: record}, separators=(",", ":"))
    return text


def read_enhance_record(path) -> dict | None:
    """The record :func:`enhance_comment` wrote into ``path``, or None (no or foreign comment)."""
    import soundfile as sf

    try:
        with sf.SoundFile(str(Path(path))) as f:
            text = f.comment or ""
    except (sf.LibsndfileError, RuntimeError, OSError):
        return None
    try:
        record = json.loads(text).get(_KEY) if text.startswith("{") else None
    except (ValueError, AttributeError):
        return None
    return record if isinstance(record, dict) else None


def declared_delay(path, fs: int) -> int | None:
    """The delay (samples at ``fs``) ``path`` declares, or None.

    A record written at another rate (the file was resampled since) or holding no integer
    delay declares nothing: the caller falls back to the cross-correlation.
    """
    record = read_enhance_record(path)
    if not record or record.get("fs") != int(fs):
        return None
    delay = record.get("delay_samples")
    return delay if isinstance(delay, int) and not isinstance(delay, bool) and delay >= 0 else None
