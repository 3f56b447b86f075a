"""ITU-T G.160 Appendix II noise-reduction measures: SNRI, TNLR and DSN (3GPP TS 26.077 alike).

The recommendation characterises a noise reduction (NR) by three numbers computed on short
frames of the clean speech ``s``, the noisy input ``d = s + n`` and the processed output ``y``:

* **SNRI** -- signal-to-noise ratio improvement: ``SNR_out - SNR_in``, where each SNR is the
  mean *log* power of the speech-active frames minus the mean log power of the noise-only
  frames (Paajanen & Mattila 2001 replaced frame powers by their logarithms; G.160 adopted
  that form).  A black box's speech power in a speech frame is not observable, so it is
  estimated as the frame's power minus the mean noise power of the noise-only frames.
* **TNLR** -- total noise level reduction: the mean log power of the noise-only frames of the
  output minus that of the input (negative = the noise is reduced).
* **DSN** -- ``SNRI + TNLR`` (= SNRI - NPLR, the noise power level reduction as a positive
  number): ``0`` when the SNR gain is all noise reduction; negative when the speech is
  attenuated, positive when it is amplified (or the noise reduction is larger in speech than
  in pauses).

Frames are ``FRAME_S`` (10 ms) long, non-overlapping.  Speech activity comes from the clean
speech, as in the recommendation (its test signals are built from known clean speech), by
ITU-T P.56 method B (:func:`scenesim.scene.mixing.p56_activity`: the envelope against the
threshold the active level was found at, with P.56's 0.2 s hangover): a frame is *speech* when
at least half its samples are active and its clean speech is not exactly zero (the envelope
decays for ~0.1 s after a word), *noise-only* when no sample within the hangover (0.2 s) of
it, on either side, is active -- P.56's hangover after activity, and the same span before an
onset, where the envelope's smoothers lag the speech (a departure from P.56, which has no
look-ahead: without it the first frame of a word would count as noise).  Frames in the hangover are neither, so the decaying end of a word never
counts as noise.

One footing for every system (issue 32): the headline columns :data:`G160_COLUMNS` are the
recommendation's own estimate, from the mixture and the output only
(:func:`g160_measures_blackbox`: the speech level by noise-power subtraction), for white and
black boxes alike.  Where the system is replayable the exact values from its known speech and
noise parts (:func:`g160_measures`, no estimation) are extra columns,
:data:`G160_EXACT_COLUMNS`; their difference is the estimate's error on that row.

Target ranges (:data:`G160_TARGETS`) are the recommendation's guidelines, stated for its own
test conditions (car and street noise at 6, 12 and 18 dB input SNR, averages over them).

What could not be verified here (the search corpus holds only the recommendation's summary and
the abstract of Paajanen & Mattila, not the text of Appendix II or Amendment 2): the exact frame
length and VAD thresholds, whether SNRI is averaged over speech-level classes (high / medium /
low) before the difference, how frames with a non-positive estimated speech power are treated
(here: left out), the high-SNR correction of Amendment 2 (the speech power estimate is biased
when the output SNR exceeds ~25 dB -- the white-box mode has no such bias), and the exact target
values (recalled: SNRI >= 4 dB, TNLR <= -5 dB, -4 dB <= DSN <= 3 dB).  The test vectors of
Amendment 2 were not available to check against.
"""

from __future__ import annotations

import numpy as np

from scenesim.errors import MetricError, ParameterError

__all__ = [
    "G160Undefined",
    "FRAME_S",
    "G160_COLUMNS",
    "G160_DEFINITION",
    "G160_EXACT_COLUMNS",
    "G160_TARGETS",
    "SPEECH_SHARE",
    "frame_activity",
    "g160_measures",
    "g160_measures_blackbox",
]

#: Frame length in seconds (10 ms, non-overlapping).
FRAME_S = 0.010
#: A frame is a speech frame when at least this share of its samples is P.56-active.
SPEECH_SHARE = 0.5
#: Fewer speech or noise-only frames than this: the measures are undefined (G160Undefined).
MIN_FRAMES = 10


class G160Undefined(MetricError):
    """The signal has too few speech or noise-only frames for G.160 (e.g. no speech pauses):
    the measures are undefined, which is not an error of the system under test."""
#: Columns :func:`g160_measures` fills (fixed names, issue 16).
G160_COLUMNS = ("g160_snri_db", "g160_tnlr_db", "g160_dsn_db")
#: Version of the definition of :data:`G160_COLUMNS` (part of every sweep's version,
#: :mod:`benchmarks.run.versioning`): 1 exact parts for white boxes and a level-gated activity;
#: 2 the recommendation's estimate for every system with P.56 activity (issue 32).
G160_DEFINITION = 2
#: The exact white-box values of the same three measures (replayable systems only).
G160_EXACT_COLUMNS = ("g160_snri_exact_db", "g160_tnlr_exact_db", "g160_dsn_exact_db")
#: The recommendation's target ranges (lo, hi) in dB, None for an open end (see module text).
G160_TARGETS = {"g160_snri_db": (4.0, None), "g160_tnlr_db": (None, -5.0), "g160_dsn_db": (-4.0, 3.0)}

_TINY = 1e-30


def _frames(x, fs: int) -> np.ndarray:
    """Mean square of each full ``FRAME_S`` frame of the 1-D signal ``x``; shape (n_frames,)."""
    x = np.asarray(x, dtype=np.float64)
    if x.ndim != 1:
        raise ParameterError("signal", x, "a 1-D signal")
    n = max(1, int(round(FRAME_S * fs)))
    k = x.size // n
    return np.mean(np.square(x[: k * n].reshape(k, n)), axis=1)


def frame_activity(clean, fs: int) -> tuple[np.ndarray, np.ndarray]:
    """``(speech, pause)`` boolean masks over the ``FRAME_S`` frames of the clean speech ``clean``
    (P.56 method B activity with its hangover, see the module docstring).

    >>> fs = 8000
    >>> tone = np.sin(2 * np.pi * 500 * np.arange(fs) / fs)  # 1 s tone, then 1 s of silence
    >>> speech, pause = frame_activity(np.concatenate([tone, np.zeros(fs)]), fs)
    >>> int(speech.sum()), int(pause.sum())
    (98, 70)

    Speech: frames 2 to 99 (the envelope's two 30 ms smoothers cross the threshold ~18 ms
    after the onset; the decay after 1 s has no clean speech).  Noise-only: 1.30 s to 2 s (the
    envelope decays below the threshold at ~1.08 s, then the 0.2 s hangover); the two frames
    before the envelope's crossing are within 0.2 s of it, so not noise-only.
    """
    from numpy.lib.stride_tricks import sliding_window_view

    from scenesim.scene.mixing import P56_HANGOVER_S, p56_activity

    clean = np.asarray(clean, dtype=np.float64)
    if clean.ndim != 1:
        raise ParameterError("clean", clean, "a 1-D signal")
    if not np.any(clean != 0.0):
        raise MetricError("G.160: the clean speech is silent")
    active, held = p56_activity(clean, fs)
    n = max(1, int(round(FRAME_S * fs)))
    k = clean.size // n
    share = active[: k * n].reshape(k, n).mean(axis=1)
    h = int(round(P56_HANGOVER_S / FRAME_S))
    touched = np.concatenate([held[: k * n].reshape(k, n).any(axis=1), np.zeros(h, dtype=bool)])
    near = sliding_window_view(touched, h + 1).any(axis=1)  # held now or within h frames ahead
    return (share >= SPEECH_SHARE) & (_frames(clean, fs) > 0.0), ~near


def _log_mean(p: np.ndarray) -> float:
    return float(np.mean(10.0 * np.log10(np.maximum(p, _TINY))))


def _check(speech: np.ndarray, pause: np.ndarray) -> None:
    if speech.sum() < MIN_FRAMES or pause.sum() < MIN_FRAMES:
        raise G160Undefined(
            f"G.160: {int(speech.sum())} speech and {int(pause.sum())} noise-only frames "
            f"(need {MIN_FRAMES} of each)"
        )


def _result(snr_in: float, snr_out: float, noise_in: float, noise_out: float) -> dict[str, float]:
    snri = snr_out - snr_in
    tnlr = noise_out - noise_in
    return {"g160_snri_db": snri, "g160_tnlr_db": tnlr, "g160_dsn_db": snri + tnlr}


def g160_measures(clean, s_in, n_in, s_out, n_out, fs: int) -> dict[str, float]:
    """SNRI, TNLR and DSN (dB) from known speech and noise parts (white boxes).

    ``clean`` gives the frame activity; ``s_in, n_in`` are the speech and noise at the input,
    ``s_out, n_out`` the (latency-aligned) speech and noise of the output: all 1-D, one length.
    Speech level = mean dB power of ``s`` over speech frames; noise level = mean dB power of
    ``n`` over noise-only frames.

    >>> fs = 8000
    >>> t = np.arange(2 * fs) / fs
    >>> s = np.where(t < 1.0, np.sin(2 * np.pi * 500 * t), 0.0)   # speech in the first second
    >>> n = 0.1 * np.sin(2 * np.pi * 1000 * t)                    # 20 dB below it, every frame
    >>> m = g160_measures(s, s, n, 0.5 * s, 0.5 * n, fs)          # a 6 dB loss on both
    >>> [round(m[k], 2) + 0.0 for k in G160_COLUMNS]                    # SNRI 0, TNLR -6.02, DSN -6.02
    [0.0, -6.02, -6.02]
    """
    speech, pause = frame_activity(clean, fs)
    _check(speech, pause)
    fr = {k: _frames(v, fs) for k, v in (("si", s_in), ("ni", n_in), ("so", s_out), ("no", n_out))}
    noise_in, noise_out = _log_mean(fr["ni"][pause]), _log_mean(fr["no"][pause])
    snr_in = _log_mean(fr["si"][speech]) - noise_in
    snr_out = _log_mean(fr["so"][speech]) - noise_out
    return _result(snr_in, snr_out, noise_in, noise_out)


def _estimated_snr(p_frames: np.ndarray, speech: np.ndarray, pause: np.ndarray) -> tuple[float, float]:
    """``(snr_db, noise_level_db)`` of one signal from its frame powers, speech by subtraction."""
    noise_mean = float(np.mean(p_frames[pause]))
    est = p_frames[speech] - noise_mean
    est = est[est > 0.0]  # frames whose estimate is not positive say nothing about the speech
    if est.size < MIN_FRAMES:
        raise G160Undefined("G.160: the speech is not above the noise in enough frames to estimate it")
    noise_level = _log_mean(p_frames[pause])
    return _log_mean(est) - noise_level, noise_level


def g160_measures_blackbox(clean, mixture, output, fs: int) -> dict[str, float]:
    """SNRI, TNLR and DSN (dB) from the mixture and the output only (black boxes).

    The speech power of a speech frame is its power minus the mean power of the noise-only
    frames of the same signal; ``clean`` only marks which frames are which.

    >>> fs = 8000
    >>> t = np.arange(2 * fs) / fs
    >>> s = np.where(t < 1.0, np.sin(2 * np.pi * 500 * t), 0.0)
    >>> n = 0.1 * np.sin(2 * np.pi * 1000 * t)
    >>> m = g160_measures_blackbox(s, s + n, 0.5 * (s + n), fs)   # a fixed gain: no SNR change
    >>> [round(m[k], 2) + 0.0 for k in G160_COLUMNS]
    [0.0, -6.02, -6.02]
    """
    speech, pause = frame_activity(clean, fs)
    _check(speech, pause)
    snr_in, noise_in = _estimated_snr(_frames(mixture, fs), speech, pause)
    snr_out, noise_out = _estimated_snr(_frames(output, fs), speech, pause)
    return _result(snr_in, snr_out, noise_in, noise_out)
