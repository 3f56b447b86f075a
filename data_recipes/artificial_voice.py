"""Built-in artificial voice: speech-like signals in the spirit of ITU-T P.50.

ITU-T P.50 defines artificial voices that reproduce the time-, amplitude- and
spectral statistics of real speech without being intelligible.  This module builds
such a voice with a small source-filter (Klatt-style) synthesiser so that every
benchmark runs offline and deterministically:

* **Voiced segments**: a Rosenberg glottal-flow pulse train (opening 40 %, closing
  16 % of the period), differentiated for lip radiation (+6 dB/oct), with F0 following
  a declining intonation contour, accents and 1 % jitter / shimmer, passed through a
  cascade of four second-order formant resonators whose F1-F4 trajectories are
  interpolated between vowel targets (Peterson & Barney 1952, Hillenbrand et al. 1995).
* **Unvoiced segments**: fricatives (/s/, /sh/, /f/, /h/) and plosive bursts made of
  band-pass filtered noise.
* **Rhythm**: syllables at ~4 Hz (onset consonant + vowel), grouped into words and
  utterances of 1.5-3.5 s separated by pauses.
* **Long-term spectrum**: one fixed equaliser per talker maps the synthesiser's
  average spectrum onto the universal LTASS of Byrne et al. (1994)
  (:mod:`data_recipes.ltass`).  The equaliser is measured once on a fixed calibration
  signal (seed-independent, cached per ``(talker, fs)``), so it is a constant filter,
  not a per-clip normalisation.

Output level: RMS 0.05 (-26 dBFS) over the whole clip, pauses included.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from scipy.signal import firwin2, oaconvolve, sosfilt

from data_recipes.ltass import BYRNE_1994_CENTERS_HZ, BYRNE_1994_LEVELS_DB, band_levels_db
from scenesim.errors import ParameterError
from scenesim.validate import check_choice, check_fs, check_positive

#: Version of the generator's output.  Bump it whenever a change here (or in the LTASS
#: table it equalises to) changes the samples :func:`artificial_voice` returns: it is part
#: of the disk-cache keys of arrays built from these voices (the babble bank), so stale
#: cached files then stop matching.
VOICE_VERSION = 1

#: RMS of a generated clip (-26 dBFS, the usual active-speech level of P.56 test material).
OUTPUT_RMS = 0.05

_FRAME_S = 0.005  # control-parameter frame (formants, amplitudes): 5 ms


@dataclass(frozen=True)
class Talker:
    """One artificial talker.

    Parameters
    ----------
    name : str
        Identifier recorded in clip provenance, e.g. ``"male-1"``.
    sex : {"male", "female"}
        Selects the vowel-formant table and the LTASS equaliser.
    f0_hz : float
        Mean fundamental frequency (Hz).
    formant_scale : float
        Multiplies the vowel formant targets (vocal-tract length).
    """

    name: str
    sex: str
    f0_hz: float
    formant_scale: float

    def __post_init__(self):
        check_choice("sex", self.sex, ("male", "female"))
        check_positive("f0_hz", self.f0_hz)
        check_positive("formant_scale", self.formant_scale)


#: Six distinct talkers: P.50-like male (~110-130 Hz) and female (~200-230 Hz) voices.
TALKERS: tuple[Talker, ...] = (
    Talker("male-1", "male", 110.0, 1.00),
    Talker("female-1", "female", 215.0, 1.00),
    Talker("male-2", "male", 122.0, 0.96),
    Talker("female-2", "female", 200.0, 0.96),
    Talker("male-3", "male", 130.0, 1.04),
    Talker("female-3", "female", 230.0, 1.04),
)

# Vowel targets F1, F2, F3 (Hz), adult male / female averages (Peterson & Barney 1952).
_VOWELS_MALE = np.array(
    [[270, 2290, 3010], [390, 1990, 2550], [530, 1840, 2480], [660, 1720, 2410],
     [730, 1090, 2440], [570, 840, 2410], [440, 1020, 2240], [300, 870, 2240],
     [640, 1190, 2390], [490, 1350, 1690]], dtype=float)
_VOWELS_FEMALE = np.array(
    [[310, 2790, 3310], [430, 2480, 3070], [610, 2330, 2990], [860, 2050, 2850],
     [850, 1220, 2810], [590, 920, 2710], [470, 1160, 2680], [370, 950, 2670],
     [760, 1400, 2780], [500, 1640, 1960]], dtype=float)
_F4_HZ = {"male": 3500.0, "female": 4100.0}
_BANDWIDTHS_HZ = np.array([80.0, 100.0, 160.0, 250.0])

# Fricative noise bands (Hz): /s/, /sh/, /f/, /h/ (and a broadband plosive burst).
_FRICATIVES = {"s": (3800.0, 7600.0), "sh": (1800.0, 5000.0), "f": (1200.0, 7600.0),
               "h": (400.0, 3500.0), "burst": (500.0, 7000.0)}


def talker_by_name(name: str) -> Talker:
    """The built-in :class:`Talker` called ``name``."""
    for talker in TALKERS:
        if talker.name == name:
            return talker
    raise ParameterError("talker", name, "one of " + ", ".join(t.name for t in TALKERS))


def artificial_voice(
    duration_s: float, *, fs: int = 16000, seed: int = 0, talker: Talker | str | None = None
) -> tuple[np.ndarray, Talker]:
    """Generate ``duration_s`` seconds of artificial speech.

    Parameters
    ----------
    duration_s : float
        Length of the clip (s), > 0.
    fs : int
        Sampling rate (Hz), >= 8000.
    seed : int
        Seeds every random choice; the same seed gives the identical array.
    talker : Talker or str or None
        Who speaks; ``None`` picks one of :data:`TALKERS` from the seed.

    Returns
    -------
    x : ndarray, shape (n,)
        ``n = round(duration_s * fs)`` samples, RMS :data:`OUTPUT_RMS`, starting with a
        0.1-0.3 s pause and cut at ``n`` (possibly inside an utterance).
    talker : Talker
        The talker used.
    """
    duration_s = check_positive("duration_s", duration_s)
    fs = check_fs(fs)
    if fs < 8000:
        raise ParameterError("fs", fs, "a sampling rate >= 8000 Hz")
    rng = np.random.default_rng(seed)
    if talker is None:
        talker = TALKERS[int(rng.integers(len(TALKERS)))]
    elif isinstance(talker, str):
        talker = talker_by_name(talker)
    n = max(1, int(round(duration_s * fs)))
    raw = _synthesize_raw(n, fs, rng, talker)
    eq = _equaliser(talker, fs)
    x = oaconvolve(raw, eq, mode="full")
    delay = (len(eq) - 1) // 2
    x = x[delay:delay + n]
    rms = np.sqrt(np.mean(x**2))
    return x * (OUTPUT_RMS / max(rms, 1e-12)), talker


# --------------------------------------------------------------------------- synthesis


def _synthesize_raw(n: int, fs: int, rng: np.random.Generator, talker: Talker) -> np.ndarray:
    """Unequalised voice: control tracks at 5 ms frames, then source-filter synthesis."""
    hop = max(1, int(round(_FRAME_S * fs)))
    n_frames = n // hop + 2
    tracks = _control_tracks(n_frames, rng, talker)
    t_frames = np.arange(n_frames) * hop
    t = np.arange(n)

    # Voiced source: Rosenberg pulses driven by the phase of the F0 track.
    f0 = np.interp(t, t_frames, tracks["f0"])
    jitter = 1.0 + 0.01 * np.repeat(rng.standard_normal(n // 40 + 2), 40)[:n]
    phase = np.cumsum(f0 * jitter / fs)
    period = np.floor(phase)
    shimmer = 1.0 + 0.05 * rng.standard_normal(int(period[-1]) + 2)[period.astype(int)]
    frac = phase - period
    tp, tn = 0.40, 0.16
    flow = np.where(frac < tp, 0.5 * (1.0 - np.cos(np.pi * frac / tp)),
                    np.where(frac < tp + tn, np.cos(np.pi * (frac - tp) / (2.0 * tn)), 0.0))
    source = np.diff(flow * shimmer, prepend=0.0)  # lip radiation: first difference
    source += 0.02 * rng.standard_normal(n) * flow  # breathiness during the open phase
    voiced = source * np.interp(t, t_frames, tracks["av"])

    # Formant cascade, time-varying: each Hann-windowed 20 ms frame of the source (hop
    # 10 ms; the trajectories are smoothed over 40 ms) is filtered by that frame's
    # resonators and the outputs are overlap-added.
    formants = np.minimum(tracks["formants"], 0.45 * fs)[::2]
    out = _formant_filter(voiced, formants, 2 * hop, fs)

    # Unvoiced: one band-passed noise stream per fricative class, gated by its track.
    for name, (lo, hi) in _FRICATIVES.items():
        gate = tracks["af_" + name]
        if not np.any(gate):
            continue
        hi = min(hi, 0.45 * fs)
        lo = min(lo, 0.5 * hi)  # at 8 kHz the /s/ band folds down below Nyquist
        sos = _bandpass_sos(lo, hi, fs)
        noise = sosfilt(sos, rng.standard_normal(n))
        out += noise * np.interp(t, t_frames, gate)
    return out


def _control_tracks(n_frames: int, rng: np.random.Generator, talker: Talker) -> dict:
    """Per-frame F0, voicing amplitude, formant and frication tracks of a phrase sequence."""
    vowels = (_VOWELS_MALE if talker.sex == "male" else _VOWELS_FEMALE) * talker.formant_scale
    f4 = _F4_HZ[talker.sex] * talker.formant_scale
    f0 = np.full(n_frames, talker.f0_hz)
    av = np.zeros(n_frames)
    af = {name: np.zeros(n_frames) for name in _FRICATIVES}
    # Vowel target per frame, later smoothed into trajectories.
    target = np.tile(vowels[rng.integers(len(vowels))], (n_frames, 1))

    def frames(seconds):
        return max(1, int(round(seconds / _FRAME_S)))

    k = frames(rng.uniform(0.1, 0.3))  # leading pause
    while k < n_frames:
        # One utterance: declining F0 with accents, a few words of 1-4 syllables.
        utt_len = frames(rng.uniform(1.5, 3.5))
        end = min(n_frames, k + utt_len)
        start = k
        while k < end:
            for _ in range(int(rng.integers(1, 5))):
                if k >= end:
                    break
                k = _syllable(k, end, rng, vowels, av, af, target, f0, talker, frames)
            k += frames(rng.uniform(0.03, 0.12))  # short gap between words
        # Intonation: declination from +20 % to -15 % of the mean F0 over the utterance.
        span = np.arange(start, min(k, n_frames))
        if span.size:
            f0[span] *= np.linspace(1.20, 0.85, span.size)
        k += frames(rng.uniform(0.25, 0.6))  # pause between utterances

    # Smooth formant targets into trajectories (40 ms moving average, transitions).
    width = frames(0.04)
    kernel = np.ones(width) / width
    padded = np.pad(target, ((width, width), (0, 0)), mode="edge")
    smooth = np.stack([np.convolve(padded[:, i], kernel, mode="same") for i in range(3)], axis=1)
    smooth = smooth[width:width + n_frames]
    formants = np.column_stack([smooth, np.full(n_frames, f4)])
    # Slow F0 drift (+-3 %) on top of the contour.
    drift = np.interp(np.arange(n_frames), np.arange(0, n_frames + 40, 40),
                      0.03 * rng.standard_normal(n_frames // 40 + 2))
    tracks = {"f0": f0 * (1.0 + drift), "av": av, "formants": formants}
    tracks.update({"af_" + name: gate for name, gate in af.items()})
    return tracks


def _syllable(k, end, rng, vowels, av, af, target, f0, talker, frames) -> int:
    """Write one syllable starting at frame ``k``; return the frame after it."""
    n_frames = av.size
    # Onset: fricative (45 %), plosive closure + burst (25 %) or none.
    draw = rng.uniform()
    if draw < 0.45:
        kind = ("s", "sh", "f", "h")[int(rng.choice(4, p=(0.4, 0.15, 0.2, 0.25)))]
        length = frames(rng.uniform(0.06, 0.12))
        seg = slice(k, min(n_frames, k + length))
        size = seg.stop - seg.start
        if size > 0:
            af[kind][seg] = rng.uniform(0.3, 0.6) * np.hanning(size + 2)[1:-1]
        k += length
    elif draw < 0.70:
        k += frames(rng.uniform(0.03, 0.06))  # closure (silence)
        length = frames(0.015)
        seg = slice(k, min(n_frames, k + length))
        if seg.stop > seg.start:
            af["burst"][seg] = rng.uniform(0.4, 0.8)
        k += length
    # Nucleus: a vowel of 90-220 ms with 20 ms rise and 40 ms fall, +-4 dB stress.
    length = frames(rng.uniform(0.09, 0.22))
    stop = min(n_frames, k + length)
    if stop > k:
        size = stop - k
        env = np.ones(size)
        rise, fall = min(size, frames(0.02)), min(size, frames(0.04))
        env[:rise] = np.linspace(0.0, 1.0, rise)
        env[size - fall:] = np.minimum(env[size - fall:], np.linspace(1.0, 0.0, fall))
        gain = 10.0 ** (rng.uniform(-4.0, 4.0) / 20.0)
        av[k:stop] = gain * env
        target[k:stop] = vowels[rng.integers(len(vowels))]
        if rng.uniform() < 0.3:  # pitch accent: +20 % F0 bump on a stressed syllable
            f0[k:stop] *= 1.0 + 0.20 * np.hanning(size + 2)[1:-1]
    return stop


def _formant_filter(x: np.ndarray, formants: np.ndarray, hop: int, fs: int) -> np.ndarray:
    """Time-varying resonator cascade by windowed overlap-add (vectorized over frames).

    Frame ``k`` is ``x`` around sample ``k * hop`` under a periodic Hann window of
    length ``2 hop`` (the windows sum to one), filtered in the frequency domain by
    ``prod_i H_i(z)`` with the formants of control frame ``k`` (see
    :func:`_resonator_sos`); the FFT length leaves >= 60 ms for the resonators'
    impulse responses to decay (bandwidth >= 80 Hz: below -100 dB), so circular
    wrap-around is negligible.

    Parameters
    ----------
    x : ndarray, shape (n,)
    formants : ndarray, shape (n_frames, n_formants), Hz; ``n_frames >= n // hop + 1``
    """
    n = x.size
    length = 2 * hop
    n_blocks = -(-(length + int(0.045 * fs)) // hop)  # FFT length: a whole number of hops
    n_fft = n_blocks * hop
    window = 0.5 - 0.5 * np.cos(2.0 * np.pi * np.arange(length) / length)
    n_frames = n // hop + 1
    padded = np.concatenate([np.zeros(hop), x, np.zeros(2 * length)])
    out = np.zeros((n_frames + n_blocks + 1, hop))  # output in blocks of one hop
    r = np.exp(-np.pi * _BANDWIDTHS_HZ / fs)
    for c0 in range(0, n_frames, 512):  # chunks bound the memory of the (frames, bins) arrays
        ks = np.arange(c0, min(n_frames, c0 + 512))
        idx = ks[:, None] * hop + np.arange(length)[None, :]
        frames = padded[idx] * window
        a1 = -2.0 * r * np.cos(2.0 * np.pi * formants[ks] / fs)  # (frames, n_formants)
        # Denominator polynomial of the whole cascade (degree 2 n_formants) per frame;
        # its values on the unit circle are one real FFT.
        den = np.zeros((ks.size, 2 * a1.shape[1] + 1))
        den[:, 0] = 1.0
        for i in range(a1.shape[1]):
            prev = den.copy()
            den[:, 1:] += a1[:, i:i + 1] * prev[:, :-1]
            den[:, 2:] += r[i] ** 2 * prev[:, :-2]
        dc_gain = np.prod(1.0 + a1 + r**2, axis=1)  # unity gain at DC per resonator
        spec = np.fft.rfft(frames, n_fft) * (dc_gain[:, None] / np.fft.rfft(den, n_fft))
        y = np.fft.irfft(spec, n_fft).reshape(ks.size, n_blocks, hop)
        for blk in range(n_blocks):
            out[ks + blk] += y[:, blk]
    out = out.ravel()
    # Frame k starts at k*hop - hop; the first `hop` output samples precede x.
    return out[hop:hop + n]


def _resonator_sos(freqs_hz: np.ndarray, bws_hz: np.ndarray, fs: int) -> np.ndarray:
    """Cascade of unity-DC-gain 2nd-order resonators (Klatt 1980), shape (n_formants, 6).

    ``H(z) = (1 + a1 + a2) / (1 + a1 z^-1 + a2 z^-2)``, ``a1 = -2 r cos(2 pi F / fs)``,
    ``a2 = r**2``, ``r = exp(-pi B / fs)``.
    """
    r = np.exp(-np.pi * bws_hz / fs)
    a1 = -2.0 * r * np.cos(2.0 * np.pi * freqs_hz / fs)
    a2 = r**2
    sos = np.zeros((len(freqs_hz), 6))
    sos[:, 0] = 1.0 + a1 + a2
    sos[:, 3] = 1.0
    sos[:, 4] = a1
    sos[:, 5] = a2
    return sos


@functools.lru_cache(maxsize=64)
def _bandpass_sos(lo_hz: float, hi_hz: float, fs: int) -> np.ndarray:
    from scipy.signal import butter

    return butter(4, [lo_hz, hi_hz], btype="bandpass", fs=fs, output="sos")


@functools.lru_cache(maxsize=32)
def _equaliser(talker: Talker, fs: int) -> np.ndarray:
    """Fixed linear-phase FIR mapping the raw voice's LTASS onto Byrne et al. (1994).

    Measured once on a 16 s calibration signal of this talker (seed 12345), so the
    filter depends only on ``(talker, fs)``, never on the seed of the clip.
    Gains are the differences of 1/3-octave band levels (target minus measured,
    best-fit offset removed), limited to +-30 dB, refined over three measure-and-correct
    passes.
    """
    rng = np.random.default_rng(12345)
    calib = _synthesize_raw(int(16.0 * fs), fs, rng, talker)
    centers = BYRNE_1994_CENTERS_HZ[BYRNE_1994_CENTERS_HZ < 0.42 * fs]
    target = BYRNE_1994_LEVELS_DB[: centers.size]
    freqs = np.concatenate([[0.0], centers, [fs / 2.0]])
    n_taps = 2 * int(round(0.032 * fs)) + 1  # 64 ms: resolves the 63-200 Hz bands
    gain_db = np.zeros(centers.size)
    # A short FIR cannot realise every band gain exactly (neighbouring low bands are
    # only ~40 Hz apart), so the residual is measured and fed back three times.
    for _ in range(3):
        taps = _fir_from_band_gains(gain_db, freqs, n_taps, fs)
        residual = target - band_levels_db(oaconvolve(calib, taps, mode="same"), fs, centers,
                                           nperseg=4096)
        gain_db = np.clip(gain_db + residual - np.mean(residual), -30.0, 30.0)
    return _fir_from_band_gains(gain_db, freqs, n_taps, fs)


def _fir_from_band_gains(gain_db: np.ndarray, freqs: np.ndarray, n_taps: int, fs: int) -> np.ndarray:
    """Linear-phase FIR through the band gains (dB) at ``freqs[1:-1]``, rolled off at DC and fs/2."""
    edge_db = np.concatenate([[gain_db[0] - 20.0], gain_db, [gain_db[-1] - 10.0]])
    return firwin2(n_taps, freqs, 10.0 ** (edge_db / 20.0), fs=fs)
