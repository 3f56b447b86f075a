"""Synthesized noises: the fallback for every noise type a data directory lacks.

Each generator returns unit-free float64 samples normalised to RMS :data:`NOISE_RMS`
per channel; channels are drawn independently (for incoherent / diffuse fields).
All randomness comes from the ``rng`` argument, so a seed fixes the output.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.signal import butter, sosfilt

from data_recipes.artificial_voice import TALKERS, VOICE_VERSION, artificial_voice
from data_recipes.ltass import ltass_psd_db
from scenesim.errors import ParameterError
from scenesim.memo import array_key, cached_array
from scenesim.validate import check_choice, check_fs, check_int

#: RMS of every synthesized channel (-20 dBFS); the benchmark rescales to the wanted SNR.
NOISE_RMS = 0.1

#: Longest synthesized noise (s): five times the longest signal a scene takes (120 s).
MAX_NOISE_S = 600.0
#: Most channels of one synthesized noise (independent draws of a field's sources).
MAX_NOISE_CHANNELS = 64

#: Number of simultaneous talkers in synthesized babble.
BABBLE_TALKERS = 6
#: Seconds of speech per artificial talker in the built-in babble bank.
BABBLE_BANK_S = 30.0

#: Mains frequency (Hz) of the factory hum family (European grid, as in NOISEX-92 factory).
MAINS_HZ = 50.0
#: Rotation frequency (Hz) of the factory's machine: a 4-pole induction motor on a 50 Hz grid
#: (synchronous 1500 rpm) at 2 % slip = 1470 rpm = 24.5 Hz.
MACHINE_HZ = 24.5
#: Tooth count of the machine's gear: gear-mesh line at ``GEAR_TEETH * MACHINE_HZ`` (416.5 Hz).
GEAR_TEETH = 17
#: Corner frequency (Hz) above which the wind spectrum falls as f^(-7/3).
WIND_CORNER_HZ = 100.0


@dataclass(frozen=True)
class SpeechPoolItem:
    """One talker's speech offered to the babble generator.

    ``signal`` is 1-D at the requested ``fs``; ``talker`` names the talker (distinct
    names are preferred when picking the babble voices), ``label`` says where it came from.
    """

    talker: str
    label: str
    signal: np.ndarray


@dataclass(frozen=True)
class SynthesizedNoise:
    """Output of :func:`synthesize_noise`.

    Attributes
    ----------
    signal : ndarray, shape (n_channels, n_samples)
    fs : int
    noise_type : str
    components : tuple of str
        What went into it (talkers and seeds for babble, line frequencies for factory, ...).
    """

    signal: np.ndarray
    fs: int
    noise_type: str
    components: tuple[str, ...]


def synthesize_noise(
    noise_type: str,
    n_samples: int,
    *,
    fs: int,
    rng: np.random.Generator,
    speech_pool: Sequence[SpeechPoolItem] | None = None,
    n_channels: int = 1,
) -> SynthesizedNoise:
    """Synthesize ``n_samples`` of noise of a known type.

    Parameters
    ----------
    noise_type : str
        One of :data:`SYNTHESIZABLE` (see the ``_<type>`` generators for what each imitates).
    n_samples : int
        Length (samples), >= 1.
    fs : int
        Sampling rate (Hz).
    rng : numpy.random.Generator
        The only source of randomness.
    speech_pool : sequence of SpeechPoolItem, optional
        Speech to build babble from (e.g. the local speech files); default: the built-in
        artificial talkers.
    n_channels : int
        Independent channels to draw (1 or more).

    Returns
    -------
    SynthesizedNoise
        ``signal`` shaped ``(n_channels, n_samples)``, each channel at RMS :data:`NOISE_RMS`.
    """
    check_choice("noise_type", noise_type, SYNTHESIZABLE)
    fs = check_fs(fs)
    # A typo's 10**12 samples must be an error, not a MemoryError after minutes.
    n_samples = check_int("n_samples", n_samples, minimum=1, maximum=int(MAX_NOISE_S * fs))
    n_channels = check_int("n_channels", n_channels, minimum=1, maximum=MAX_NOISE_CHANNELS)
    if not isinstance(rng, np.random.Generator):
        raise ParameterError("rng", rng, "a numpy.random.Generator")
    generator = _GENERATORS[noise_type]
    channels, components = [], []
    for ch in range(n_channels):
        if noise_type == "babble":
            x, parts = generator(n_samples, fs, rng, speech_pool)
        else:
            x, parts = generator(n_samples, fs, rng)
        channels.append(_normalise(x))
        components.extend(f"ch{ch}:{p}" if n_channels > 1 else p for p in parts)
    return SynthesizedNoise(np.stack(channels), fs, noise_type, tuple(components))


def _normalise(x: np.ndarray) -> np.ndarray:
    rms = np.sqrt(np.mean(x**2))
    return x * (NOISE_RMS / max(rms, 1e-12))


def _shape_spectrum(white: np.ndarray, fs: int, gain_db: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """Filter noise in the frequency domain by the magnitude ``10**(gain_db(f)/20)`` (DC removed)."""
    spec = np.fft.rfft(white)
    f = np.fft.rfftfreq(white.size, 1.0 / fs)
    gain = np.zeros_like(f)
    gain[1:] = 10.0 ** (gain_db(f[1:]) / 20.0)
    return np.fft.irfft(spec * gain, n=white.size)


def _white(n: int, fs: int, rng: np.random.Generator):
    """White noise: Gaussian, flat power spectral density (0 dB/oct), e.g. thermal/fan hiss."""
    return rng.standard_normal(n), ("white:gaussian",)


def _pink(n: int, fs: int, rng: np.random.Generator):
    """Pink noise: PSD ~ 1/f (-3 dB/oct, equal power per octave), e.g. NOISEX-92 ``pink``.

    White Gaussian noise shaped by ``|H(f)| = f**-1/2`` in the frequency domain.
    """
    return _shape_spectrum(rng.standard_normal(n), fs, lambda f: -10.0 * np.log10(f)), ("pink:1/f",)


def _speech_shaped(n: int, fs: int, rng: np.random.Generator):
    """Speech-shaped noise: stationary Gaussian noise with the LTASS of Byrne et al. (1994).

    Its PSD is the universal long-term average speech spectrum (peak 250-500 Hz, about
    -8 dB/oct density slope above 500 Hz): the masker of ITU-T P.50-style tests.
    """
    x = _shape_spectrum(rng.standard_normal(n), fs, ltass_psd_db)
    return x, ("speech-shaped:byrne1994",)


def _wind(n: int, fs: int, rng: np.random.Generator):
    """Wind noise on a microphone: gusty, low-frequency turbulence.

    Spectrum: flat below :data:`WIND_CORNER_HZ`, then the pressure spectrum of turbulence in
    the inertial subrange, PSD ~ f^(-7/3) (-7 dB/octave; the Kolmogorov scaling of
    turbulence-turbulence pressure, George, Beuther & Arndt 1984, the shape wind-noise
    studies on unscreened microphones use), with no DC (a 2nd-order 10 Hz high-pass).
    Checked against a real recording (``shared/data/noise/wind_cc0.wav``): its slope is
    -7..-10 dB/octave from 400 Hz to 6.4 kHz; the 4th-order 120 Hz low-pass used before
    (-24 dB/octave) left almost no wind in the speech band.  Multiplied by a gust envelope
    ``exp(0.6 g(t))`` where ``g`` is unit-variance noise low-passed at 0.5 Hz (gusts of a
    few seconds).  Channels are independent; the spatial coherence of wind between two
    mics is the scene's job (:func:`scenesim.scene.noise_fields.wind_noise`, Corcos model).
    """
    slope_db_per_decade = 10.0 * 7.0 / 3.0
    x = _shape_spectrum(
        rng.standard_normal(n),
        fs,
        lambda f: -slope_db_per_decade * np.log10(np.maximum(f, WIND_CORNER_HZ) / WIND_CORNER_HZ),
    )
    x = sosfilt(butter(2, 10.0, btype="highpass", fs=fs, output="sos"), x)
    gust = _slow_noise(n, fs, rng, cutoff_hz=0.5)
    return x * np.exp(0.6 * gust), (f"wind:flat<{WIND_CORNER_HZ:g}Hz,f^-7/3 above", "wind:gusts0.5Hz")


def _slow_noise(n: int, fs: int, rng: np.random.Generator, *, cutoff_hz: float) -> np.ndarray:
    """Unit-variance Gaussian noise band-limited to ``cutoff_hz`` (drawn at 100 Hz, interpolated)."""
    rate = 100.0
    m = int(np.ceil(n / fs * rate)) + 8
    sos = butter(2, cutoff_hz, btype="lowpass", fs=rate, output="sos")
    g = sosfilt(sos, rng.standard_normal(m + 200))[200:]  # 2 s burn-in of the filter state
    g = (g - g.mean()) / max(g.std(), 1e-12)
    return np.interp(np.arange(n) / fs * rate, np.arange(m), g)


def _factory(n: int, fs: int, rng: np.random.Generator):
    """Factory floor: machinery lines, impulsive hammer hits and a pink floor.

    * Electrical hum: :data:`MAINS_HZ` and its harmonics up to 400 Hz (amplitude ~ 1/k).
    * A rotating machine at :data:`MACHINE_HZ` with harmonics up to 1 kHz (~ 1/k), plus a
      gear-mesh line at ``GEAR_TEETH * MACHINE_HZ``; its load modulates the amplitude by
      +-20 % at 0.3 Hz.
    * Hammer hits: a Poisson process (1.5 hits/s) of exponentially decaying
      (tau 10-40 ms) bursts of noise ringing at 1-4 kHz (struck metal), levels +-6 dB.
    * Pink floor (-3 dB/oct) 6 dB below the tonal part.

    The PSD therefore shows lines at 50, 100, 150 ... Hz and 24.5, 49, 73.5 ... Hz over
    a -3 dB/oct floor, with broadband transients; it imitates NOISEX-92 ``factory1``.
    """
    # Every line is a multiple of 0.5 Hz, so the tonal part repeats exactly every 2 s:
    # compute one period and tile it.
    period = int(round(2.0 * fs))
    tp = np.arange(period) / fs
    mains = np.zeros(period)
    for k in range(1, int(400 / MAINS_HZ) + 1):
        mains += np.sin(2 * np.pi * k * MAINS_HZ * tp + rng.uniform(0, 2 * np.pi)) / k
    t = np.arange(n) / fs
    load = 1.0 + 0.2 * np.sin(2 * np.pi * 0.3 * t + rng.uniform(0, 2 * np.pi))
    machine = np.zeros(period)
    for k in range(1, int(1000 / MACHINE_HZ) + 1):
        machine += np.sin(2 * np.pi * k * MACHINE_HZ * tp + rng.uniform(0, 2 * np.pi)) / k
    machine += 0.5 * np.sin(2 * np.pi * GEAR_TEETH * MACHINE_HZ * tp + rng.uniform(0, 2 * np.pi))
    reps = -(-n // period)
    tonal = np.tile(mains, reps)[:n] + 1.5 * np.tile(machine, reps)[:n] * load
    pink, _ = _pink(n, fs, rng)
    pink *= 0.5 * np.std(tonal) / max(np.std(pink), 1e-12)
    hits = np.zeros(n)
    n_hits = rng.poisson(1.5 * n / fs)
    for start in np.sort(rng.integers(0, n, size=n_hits)):
        tau = rng.uniform(0.010, 0.040)
        length = min(n - start, int(5 * tau * fs))
        ring_hz = min(rng.uniform(1000.0, 4000.0), 0.4 * fs)
        tt = np.arange(length) / fs
        burst = np.exp(-tt / tau) * (np.sin(2 * np.pi * ring_hz * tt) + 0.5 * rng.standard_normal(length))
        hits[start:start + length] += burst * 10.0 ** (rng.uniform(-6, 6) / 20.0)
    if n_hits:
        # Hits carry about as much energy as the tonal part (they dominate above 1 kHz).
        hits *= np.std(tonal) / max(np.sqrt(np.mean(hits**2)), 1e-12)
    parts = (f"factory:mains{MAINS_HZ:g}Hz", f"factory:machine{MACHINE_HZ:g}Hz",
             f"factory:gear{GEAR_TEETH * MACHINE_HZ:g}Hz", f"factory:hits{n_hits}")
    return tonal + pink + hits, parts


def _babble(n: int, fs: int, rng: np.random.Generator, pool: Sequence[SpeechPoolItem] | None):
    """Babble: :data:`BABBLE_TALKERS` talkers speaking at once, as in a cafeteria.

    Each voice is a stretch of one talker's speech (looped if short) starting at a
    random offset, scaled to a random level within +-3 dB; distinct talkers are used
    whenever the pool has enough of them.  With no pool the six built-in artificial
    talkers speak from a fixed bank of :data:`BABBLE_BANK_S` seconds each (generated once
    per process, like the single 235 s recording behind NOISEX-92 babble); the seed picks
    offsets and levels.  The long-term spectrum is that of speech, with the 4 Hz
    envelope modulation largely averaged out.
    """
    if pool is None:
        pool = _artificial_babble_bank(fs)
    x = np.zeros(n)
    parts = []
    if not pool:
        raise ParameterError("speech_pool", pool, "at least one speech item for babble")
    for item in _pick_voices(pool, rng):
        sig = np.asarray(item.signal, dtype=float)
        offset = int(rng.integers(0, max(1, sig.size)))
        reps = int(np.ceil((offset + n) / max(sig.size, 1))) + 1
        voice = np.tile(sig, reps)[offset:offset + n]
        rms = np.sqrt(np.mean(voice**2))
        gain = 10.0 ** (rng.uniform(-3, 3) / 20.0) / max(rms, 1e-12)
        x += gain * voice
        parts.append(f"{item.label}@{offset}")
    return x, tuple(parts)


#: Seed of built-in talker ``k`` in the babble bank is ``BABBLE_BANK_SEED + k``.
BABBLE_BANK_SEED = 1000


@functools.lru_cache(maxsize=4)
def _artificial_babble_bank(fs: int) -> tuple[SpeechPoolItem, ...]:
    """One :data:`BABBLE_BANK_S`-second clip per built-in talker (seed ``BABBLE_BANK_SEED`` + index).

    Deterministic and slow (~2 s), so the stacked bank ``(n_talkers, n_samples)`` also goes
    through :func:`scenesim.memo.cached_array` (on disk when ``$SCENESIM_CACHE`` is set),
    keyed by everything it depends on: ``fs``, :data:`BABBLE_BANK_S`, the talkers, their
    seeds and :data:`~data_recipes.artificial_voice.VOICE_VERSION`.
    """
    seeds = [BABBLE_BANK_SEED + k for k in range(len(TALKERS))]

    def compute() -> np.ndarray:
        return np.stack([
            artificial_voice(BABBLE_BANK_S, fs=fs, seed=seed, talker=talker)[0]
            for seed, talker in zip(seeds, TALKERS)
        ])

    key = array_key("babble-bank", VOICE_VERSION, fs=fs, duration_s=BABBLE_BANK_S, talkers=TALKERS,
                    seeds=seeds)
    voices = cached_array(key, compute)
    voices.setflags(write=False)
    return tuple(
        SpeechPoolItem(talker.name, f"artificial-voice:{talker.name}:seed={seed}", voice)
        for seed, talker, voice in zip(seeds, TALKERS, voices)
    )


def _pick_voices(pool: Sequence[SpeechPoolItem], rng: np.random.Generator) -> list[SpeechPoolItem]:
    """Choose BABBLE_TALKERS items, one per distinct talker first, then reuse talkers."""
    order = [int(i) for i in rng.permutation(len(pool))]
    chosen, seen = [], set()
    for i in order:
        if pool[i].talker not in seen:
            chosen.append(i)
            seen.add(pool[i].talker)
    rest = [i for i in order if i not in chosen] or order
    k = 0
    while len(chosen) < BABBLE_TALKERS:
        chosen.append(rest[k % len(rest)])
        k += 1
    return [pool[i] for i in chosen[:BABBLE_TALKERS]]


_GENERATORS = {
    "babble": _babble,
    "factory": _factory,
    "wind": _wind,
    "white": _white,
    "pink": _pink,
    "speech-shaped": _speech_shaped,
}
#: Noise types :func:`synthesize_noise` can make.
SYNTHESIZABLE: tuple[str, ...] = tuple(_GENERATORS)
