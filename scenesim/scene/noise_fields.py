"""Noise fields at a mic pair: spherically isotropic (diffuse), spatially incoherent, sensor noise.

algorithms.md section 4.

Diffuse noise (Habets & Gannot 2007, "Generating sensor signals in isotropic noise
fields"): two mutually independent noises ``N_1, N_2`` are mixed per frequency with a
factor ``C(f)`` of the target coherence matrix ``Gamma(f) = C^H C``::

    Gamma(f) = [[1, g], [g, 1]],   g(f) = sinc(2 f d / c)  (numpy convention)

We use the symmetric (eigen) factor: with ``a = sqrt((1 + g)/2)``, ``b = sqrt((1 - g)/2)``::

    X_1 = a N_1 + b N_2,     X_2 = a N_1 - b N_2,

so ``E|X_i|^2 = E|N|^2`` and ``E[X_1 X_2*] = g E|N|^2``, and both channels are treated
alike (a Cholesky factor would make channel 0 equal to ``N_1``).  The mixing is done on
the full-length real FFT (one bin per frequency, vectorized; no STFT framing): the mixing
filters are short in time (about d/c), so the circular wrap is negligible, and noise
is stationary in the statistics we target.

Sources of the independent noises (``source`` argument): generated white Gaussian noise;
a given ``(2, n)`` pair of independent channels; or a given mono recording, in which case
the second channel is the same recording circularly shifted by half its length (two
disjoint segments when the recording is at least twice as long as the output).  That
keeps a non-stationary noise (babble, wind) non-stationary; it is independent only as far
as the recording decorrelates over that shift (periodic machine noise may not).
"""

from __future__ import annotations

import numpy as np

from scenesim.errors import ParameterError
from scenesim.scene.geometry import SPEED_OF_SOUND_MPS, MicPair
from scenesim.validate import (
    check_finite_number,
    check_fs,
    check_int,
    check_positive,
    check_signal,
)


def diffuse_coherence(freqs_hz, spacing_m: float, *, c: float = SPEED_OF_SOUND_MPS) -> np.ndarray:
    """Spherically isotropic coherence ``sinc(2 f d / c)`` (numpy sinc: sin(pi x)/(pi x))."""
    return np.sinc(2.0 * np.asarray(freqs_hz, dtype=float) * spacing_m / c)


def _check_rng(rng) -> np.random.Generator:
    if not isinstance(rng, np.random.Generator):
        raise ParameterError("rng", rng, "a numpy.random.Generator (np.random.default_rng(seed))")
    return rng


def _spacing(pair_or_spacing) -> float:
    if isinstance(pair_or_spacing, MicPair):
        return pair_or_spacing.spacing_m
    return check_positive("pair_or_spacing", pair_or_spacing)


def independent_channels(
    n_samples: int, *, n_channels: int = 2, rng: np.random.Generator | None = None, source=None
) -> np.ndarray:
    """``(n_channels, n_samples)`` mutually independent noises (see the module notes).

    ``source=None`` draws white Gaussian noise of unit variance from ``rng``; a
    ``(n_channels, m)`` array is cut to ``n_samples``; a mono ``(m,)`` / ``(1, m)`` array gives
    channel k = the recording circularly shifted by ``k m / n_channels``, then cut.
    ``m < n_samples`` raises :class:`ParameterError`.
    """
    n_samples = check_int("n_samples", n_samples, minimum=1)
    n_channels = check_int("n_channels", n_channels, minimum=1)
    if source is None:
        return _check_rng(rng).standard_normal((n_channels, n_samples))
    arr = np.asarray(source)
    if arr.ndim == 1:
        arr = arr[None, :]
    arr = check_signal(arr, name="source")
    if arr.shape[1] < n_samples:
        raise ParameterError("source", arr, f"at least n_samples={n_samples} samples")
    if arr.shape[0] == n_channels:
        return arr[:, :n_samples].copy()
    if arr.shape[0] != 1:
        raise ParameterError("source", arr, f"1 or {n_channels} channels")
    m = arr.shape[1]
    shifts = (np.arange(n_channels) * m) // n_channels
    idx = (np.arange(n_samples)[None, :] + shifts[:, None]) % m
    return arr[0][idx]


def diffuse_noise(
    n_samples: int,
    pair_or_spacing,
    *,
    fs: int,
    rng: np.random.Generator | None = None,
    c: float = SPEED_OF_SOUND_MPS,
    source=None,
) -> np.ndarray:
    """Spherically isotropic noise ``(2, n_samples)`` whose pair coherence is ``sinc(2 f d / c)``.

    Parameters
    ----------
    n_samples : int
        Output length.
    pair_or_spacing : MicPair or float
        The pair (its ``spacing_m`` is used) or the spacing d in metres.
    fs : int
        Sampling rate in Hz.
    rng : numpy.random.Generator
        Needed when ``source`` is None.
    c : float
        Speed of sound in m/s.
    source : array, optional
        Independent noises to mix: ``(2, m)`` or mono ``(m,)`` (see
        :func:`independent_channels`), ``m >= n_samples``; their spectra shape the field.

    Returns
    -------
    ndarray (2, n_samples)
        Habets-Gannot mixture; each channel keeps the (average) spectrum of the sources.
    """
    d = _spacing(pair_or_spacing)
    fs = check_fs(fs)
    c = check_positive("c", c)
    noise = independent_channels(n_samples, n_channels=2, rng=rng, source=source)
    spec = np.fft.rfft(noise, axis=1)
    g = diffuse_coherence(np.fft.rfftfreq(n_samples, 1.0 / fs), d, c=c)
    a = np.sqrt(0.5 * (1.0 + g))
    b = np.sqrt(np.clip(0.5 * (1.0 - g), 0.0, None))
    mixed = np.stack([a * spec[0] + b * spec[1], a * spec[0] - b * spec[1]])
    return np.fft.irfft(mixed, n=n_samples, axis=1)


#: Corcos decay constants (UNVERIFIED, algorithms.md 4b): along and across the flow.
CORCOS_ALPHA_ALONG = 0.125
CORCOS_ALPHA_ACROSS = 0.7
#: Convection speed of the turbulence as a fraction of the wind speed.
CONVECTION_RATIO = 0.8


def corcos_coherence(
    freqs_hz,
    spacing_m: float,
    *,
    wind_speed_mps: float,
    flow_azimuth_deg: float = 0.0,
    alpha_along: float = CORCOS_ALPHA_ALONG,
    alpha_across: float = CORCOS_ALPHA_ACROSS,
    convection_ratio: float = CONVECTION_RATIO,
) -> np.ndarray:
    """Complex coherence of wind (turbulence convected past the pair), Corcos (1964) model.

    With the separation split along the flow ``dx = d |cos th|`` and across it
    ``dy = d |sin th|`` (``th = flow_azimuth_deg`` from the array axis) and the convection
    speed ``Uc = convection_ratio * wind_speed_mps``::

        gamma(f) = exp(-2 pi f (alpha_along dx + alpha_across dy) / Uc)
                   * exp(-j 2 pi f d cos(th) / Uc)

    The phase is the travel time of the frozen turbulence between the mics: a flow along
    +axis (theta = 0, towards the front mic at +d/2) passes the rear mic first, so the rear
    signal leads by ``d cos(th) / Uc`` (tests/test_harden_oracles.py measures that lag).
    Returns complex ``(n_freqs,)``.

    >>> g = corcos_coherence([100.0, 500.0], 0.0214, wind_speed_mps=5.0)
    >>> [round(float(v), 2) for v in np.abs(g)]
    [0.66, 0.12]
    """
    f = np.asarray(freqs_hz, dtype=float)
    d = check_positive("spacing_m", spacing_m)
    uc = check_positive("wind_speed_mps", wind_speed_mps) * check_positive(
        "convection_ratio", convection_ratio
    )
    th = np.deg2rad(check_finite_number("flow_azimuth_deg", flow_azimuth_deg))
    decay = check_positive("alpha_along", alpha_along, allow_zero=True) * d * abs(np.cos(th))
    decay += check_positive("alpha_across", alpha_across, allow_zero=True) * d * abs(np.sin(th))
    w = 2.0 * np.pi * f / uc
    return np.exp(-w * decay) * np.exp(-1j * w * d * np.cos(th))


def wind_noise(
    n_samples: int,
    pair_or_spacing,
    *,
    fs: int,
    wind_speed_mps: float,
    rng: np.random.Generator | None = None,
    source=None,
    **corcos,
) -> np.ndarray:
    """Two-mic wind noise ``(2, n_samples)`` with the Corcos coherence (:func:`corcos_coherence`).

    Two independent noises (``source`` as in :func:`independent_channels`: their spectrum
    is the wind spectrum) are mixed per frequency so that ``E[X_1 X_2*] = gamma(f) E|N|^2``::

        X_1 = a N_1 + b N_2,   X_2 = (a N_1 - b N_2) exp(-j arg gamma),
        a = sqrt((1 + |gamma|)/2),  b = sqrt((1 - |gamma|)/2),

    on the full-length real FFT as :func:`diffuse_noise` does.  Wind is nearly incoherent at
    speech frequencies for a 2 cm pair (``|gamma|`` ~0.12 at 500 Hz, 5 m/s along the flow).
    ``**corcos``: ``flow_azimuth_deg``, ``alpha_along``, ``alpha_across``, ``convection_ratio``.

    >>> x = wind_noise(16000, 0.0214, fs=16000, wind_speed_mps=5.0, rng=np.random.default_rng(0))
    >>> x.shape
    (2, 16000)
    """
    d = _spacing(pair_or_spacing)
    fs = check_fs(fs)
    noise = independent_channels(n_samples, n_channels=2, rng=rng, source=source)
    spec = np.fft.rfft(noise, axis=1)
    g = corcos_coherence(
        np.fft.rfftfreq(n_samples, 1.0 / fs), d, wind_speed_mps=wind_speed_mps, **corcos
    )
    mag = np.abs(g)
    a = np.sqrt(0.5 * (1.0 + mag))
    b = np.sqrt(np.clip(0.5 * (1.0 - mag), 0.0, None))
    mixed = np.stack([a * spec[0] + b * spec[1], (a * spec[0] - b * spec[1]) * np.conj(g / np.maximum(mag, 1e-300))])
    return np.fft.irfft(mixed, n=n_samples, axis=1)


def incoherent_noise(
    n_samples: int,
    *,
    n_channels: int = 2,
    rng: np.random.Generator | None = None,
    source=None,
) -> np.ndarray:
    """Spatially incoherent noise ``(n_channels, n_samples)``: independent at every mic.

    Models wind turbulence at the mics (coherence ~0 at all frequencies).  ``source`` as
    in :func:`independent_channels` (generated white Gaussian when None).
    """
    return independent_channels(n_samples, n_channels=n_channels, rng=rng, source=source)


def sensor_noise(
    n_samples: int, *, n_channels: int = 2, level_db: float, rng: np.random.Generator
) -> np.ndarray:
    """White Gaussian self-noise ``(n_channels, n_samples)`` of power ``10^(level_db/10)`` per channel.

    ``level_db`` is the power in dB relative to 1 (digital full-scale units squared).
    """
    n_samples = check_int("n_samples", n_samples, minimum=1)
    n_channels = check_int("n_channels", n_channels, minimum=1)
    level_db = check_finite_number("level_db", level_db)
    amp = 10.0 ** (level_db / 20.0)
    return amp * _check_rng(rng).standard_normal((n_channels, n_samples))
