"""Stochastic late tail of the hybrid image-source renderer (Lehmann & Johansson 2010 style).

The hybrid RIR is the image-source RIR up to a mixing time followed by Gaussian noise whose
expected energy per tap follows the **image-source model's own** late energy decay, per band,
and whose mics keep the diffuse-field coherence ``sinc(2 f d / c)`` (d: mic distance).

Expected energy (derived here, not Sabine/Eyring): images fill space with density 1/V, an
image at distance r in direction u has |i_d| ~ r |u_d| / L_d reflections on axis d, half on
each wall, so its energy gain is ``exp(-r sum_d kappa_d |u_d|)`` with
``kappa_d = -(ln b_d0 + ln b_dL) / L_d`` (b: wall pressure reflections of the band).  The
images in a shell of thickness c/fs, each with energy ``g^2 / (4 pi r)^2``, give the expected
squared RIR per tap::

    E[h^2](t) = c / (4 pi V fs) * <D_b(u')^2 exp(-c t sum_d kappa_d |u_d|) 1[L1 order <= N]>_u

averaged over directions u on the sphere (D_b: the source directivity at the emission
direction u', which for far images takes all 8 parity mirrors of u equally often).  This is
the ISM's asymptotic decay -- non-exponential when the axes absorb differently -- so T30/EDT of
the tail match the full ISM, which Sabine or Eyring would not (the issue's calibration gap).
The direction average uses Gauss-Legendre nodes on one octant (the exponential is
octant-symmetric; D^2 is averaged over the 8 mirrors).

Per octave (:func:`octave_gains`): the continuum is the broadband decay; an octave band holds
a finite set of modes, and low octaves a larger share of them in the coordinate planes and on
the axes (Weyl's surface and edge terms, :func:`weyl_weights`), whose directions never meet one
or two pairs of walls.  Each octave of the tail's noise therefore decays as the Weyl-weighted
mean of the octant, plane and axis averages of the same kernel (scaled by how much of the
plane/axis excess the walls keep, :func:`_coherence`).  Specular rooms, hybrid/full per-octave
T30 125 Hz .. 4 kHz, mean of seeds 0-3 (``benchmarks/studies/rooms_check.py --only hybrid``;
the corridor in ``tests/test_hybrid_octaves.py``): 14 x 2.2 x 2.8 m
corridor (alpha 0.1) 0.98 0.85 0.93 1.02 1.04 1.05, was 0.74 0.68 0.82 0.94 0.99 1.02; a
6 x 5.5 x 3 m room (RT60 1 s) 1.00 1.15 1.03 0.98 1.15 1.02, was 0.79 1.03 0.97 0.94 1.13 1.01;
6 x 5 x 3 m 0.99 1.11 0.98 1.00 1.02 1.00, was 0.78 0.99 0.92 0.96 1.00 1.00; 7 x 6 x 3 m with
octave-band absorption and air 0.93 1.02 1.00 0.98 0.89 1.04, was 0.76 0.88 0.92 0.95 0.88 1.04.
So 19 of these 24 octaves are within 10 % (15 before), the worst miss 15 % (32 % before);
**not met: 250 Hz** (-15 % in the corridor, +11..15 % in the near-cubic rooms -- the few low
modes' excitation depends on the source and mic positions, which the position-free Weyl
counts do not see) and 2 kHz in two rooms (+15 %, -11 %: present before the shaping too).

Scattered rooms (``ShoeBox(scattering=...)``, the default of calibrated rooms): the specular
images carry ``sqrt((1 - alpha)(1 - s))`` and the scattered field of :mod:`scenesim.room.scattering`
is added to the hybrid exactly as to the full model, from the room's own energy balance per
band (air applied per band afterwards, as for the full model).  Its late energy dominates,
so the hybrid's per-octave T30 (125 Hz-4 kHz) is within 0.7 % of the full model's in a
corridor and in a banded room with air (``tests/test_hybrid_scattered.py``,
``benchmarks/studies/rooms_check.py``), and the late field is diffuse, so the sinc coherence
below is the right one (tested at 250 Hz-4 kHz).  Where it is not: a purely specular room
(``scattering=None``) that is not diffuse -- a corridor, one absorptive wall -- keeps
direction-dependent decays the Gaussian tail only approximates (per octave above: 250 Hz
misses by up to 15 %) and a lateral/axial field whose coherence is not the diffuse one; use
``method="fast"`` or scattering there.

Coherence: white noise per mic is mixed per frequency by a square root of the diffuse
coherence matrix ``Gamma_ij(f) = sinc(2 f d_ij / c)`` (Habets & Gannot 2007 style), then every
mic is multiplied by the same envelope, which keeps the coherence up to the envelope's slow
modulation.  Independent noise per mic (gpuRIR's diffuse model) would give coherence ~0 where
a 2 cm pair needs ~0.99 at 500 Hz.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from scipy import fft as sfft

_N_MU = 40  # Gauss-Legendre nodes in cos(polar angle) over [0, 1]
_N_PHI = 40  # Gauss-Legendre nodes in azimuth over [0, pi/2]
_N_TIME = 96  # envelope evaluated on this many times and interpolated in log energy
_B_MIN = 0.1  # wall reflections below this (alpha > 0.99) enter the envelope as 0.1, see below
_N_PLANE = 48  # Gauss-Legendre nodes on each coordinate plane's quarter circle (octave_gains)
_N_K = 1024  # frequency nodes of the Weyl integrals (weyl_weights)
_MIN_OCTAVE_GAIN_DB = 0.5  # octaves whose gain stays within this of 0 dB are not shaped


@functools.lru_cache(maxsize=4)
def _octant_directions(n_mu: int = _N_MU, n_phi: int = _N_PHI):
    """Unit vectors (n, 3) in the first octant and quadrature weights (n,) summing to 1."""
    x_mu, w_mu = np.polynomial.legendre.leggauss(n_mu)
    x_phi, w_phi = np.polynomial.legendre.leggauss(n_phi)
    mu = 0.5 * (x_mu + 1.0)
    phi = 0.25 * np.pi * (x_phi + 1.0)
    mu, phi = np.meshgrid(mu, phi, indexing="ij")
    s = np.sqrt(1.0 - mu**2)
    u = np.stack([s * np.cos(phi), s * np.sin(phi), mu], axis=-1).reshape(-1, 3)
    w = np.outer(w_mu, w_phi).ravel()
    u.flags.writeable = False  # cached
    w = w / w.sum()
    w.flags.writeable = False
    return u, w


def _mirror_mean_d2(u, pattern, n_bands):
    """Mean over the 8 parity mirrors of ``D_b(u')^2``, shape (n_bands, n)."""
    if pattern is None:
        return np.ones((n_bands, u.shape[0]))
    axis, coef = pattern
    acc = np.zeros((coef.shape[0], u.shape[0]))
    for sx in (-1.0, 1.0):
        for sy in (-1.0, 1.0):
            for sz in (-1.0, 1.0):
                cos_t = (u * np.array([sx, sy, sz])) @ axis
                d = np.polynomial.polynomial.polyval(cos_t, coef.T)  # (n_bands, n)
                acc += d**2
    return acc / 8.0


def _kappa(dims, reflection) -> np.ndarray:
    """Per band and axis the log-energy loss per metre of travel along that axis, ``(n_bands, 3)``."""
    # The continuum breaks down for (nearly) anechoic walls: with b = 0 it keeps only the
    # measure-zero plane of directions that never meet that axis, while the lattice keeps a
    # whole 2-D sheet of images.  Clamped at b = 0.1, the level-matched tail of a room with
    # one wall at alpha = 1 keeps T30 within 3 % and EDT within 9 % of the full ISM (measured:
    # alpha 1 on the x = 0 or the floor wall, 0.1 elsewhere); an all-anechoic room gets no tail because
    # its early part holds no reflected energy to match (level_correction returns 0).
    b = np.maximum(np.abs(np.atleast_2d(reflection)), _B_MIN)
    logb = np.log(b)
    return -(logb[:, 0::2] + logb[:, 1::2]) / dims


def _decay_mean(kappa, u, w, r, d2, dims, max_order) -> np.ndarray:
    """``<D^2 exp(-r kappa . u) 1[L1 order <= N]>`` over directions ``u`` (n_dir, 3) with weights
    ``w`` (n_dir,), at distances ``r`` (n_t,): ``(n_bands, n_t)``; with ``w`` (n_dir, G) one mean
    per column, ``(n_bands, n_t, G)``."""
    # float32: numpy's float64 exp is scalar here (~6x slower than the SIMD float32 one, which
    # was 20 % of a hybrid render); the envelope needs ~1e-6 relative, float32 gives 1e-6.  The
    # slowest direction's decay is factored out in float64, so float32 underflows only terms
    # below e^-87 of the largest one.
    rate = kappa @ u.T  # (n_bands, n_dir) log-energy loss per metre
    slowest = rate.min(axis=1, keepdims=True)  # (n_bands, 1)
    excess = (rate - slowest).astype(np.float32)
    gain = np.exp(-r.astype(np.float32)[None, :, None] * excess[:, None, :])  # (n_bands, n_t, n_dir)
    if max_order is not None:
        order = r[:, None] * (u / dims).sum(axis=1)[None, :]  # (n_t, n_dir) L1 order
        gain *= (order <= max_order + 0.5)[None]
    w2 = w.reshape(w.shape[0], -1)  # (n_dir, G)
    mean = np.matmul(gain, (d2[:, :, None] * w2[None]).astype(np.float32))  # (n_bands, n_t, G)
    mean = mean * np.exp(-slowest * r[None, :])[..., None]
    return mean[..., 0] if w.ndim == 1 else mean


def expected_energy(dims_m, reflection, times_s, *, fs, c, pattern=None, max_order=None):
    """Expected ``h^2`` per tap ``(n_bands, n_times)`` of the ISM at ``times_s`` (module docstring).

    ``reflection`` (n_bands, 6) wall pressure reflections in wall order; ``pattern`` None or
    ``(axis (3,), coefficients (n_bands, K))``; ``max_order`` limits the L1 order as the ISM.
    """
    dims = np.asarray(dims_m, dtype=float)
    kappa = _kappa(dims, reflection)
    u, w = _octant_directions()
    d2 = _mirror_mean_d2(u, pattern, kappa.shape[0])  # (n_bands, n_dir)
    r = c * np.asarray(times_s, dtype=float)  # (n_t,)
    mean = _decay_mean(kappa, u, w, r, d2, dims, max_order)
    volume = float(np.prod(dims))
    return c / (4.0 * np.pi * volume * fs) * mean


@functools.lru_cache(maxsize=4)
def _plane_directions(n: int = _N_PLANE):
    """Per axis d the unit vectors on the quarter circle of the plane normal to d, ``(3, n, 3)``,
    and Gauss-Legendre weights ``(n,)`` summing to 1."""
    x, w = np.polynomial.legendre.leggauss(n)
    phi = 0.25 * np.pi * (x + 1.0)
    u = np.zeros((3, n, 3))
    for d in range(3):
        a, b = (e for e in range(3) if e != d)
        u[d, :, a], u[d, :, b] = np.cos(phi), np.sin(phi)
    u.flags.writeable = False  # cached
    w = w / w.sum()
    w.flags.writeable = False
    return u, w


def weyl_weights(dims_m, centers_hz, *, fs, c) -> np.ndarray:
    """Mode counts per octave ``(n_oct, 7)``: volume, the 3 coordinate planes, the 3 axes.

    Weyl's count of a shoebox's modes below ``f``, ``4 pi V f^3 / (3 c^3) + pi S f^2 / (4 c^2)
    + L f / (8 c)``, split by where the modes lie: oblique modes fill the octant of directions
    (first term), modes with one zero index lie in a coordinate plane (``pi A_d f^2 / (2 c^2)``
    for the plane normal to axis d, ``A_d = V / L_d``: the planes' half-counted lattice points),
    modes with two zero indices on an axis (``L_d f / (2 c)``).  Each weighted by the octave's
    power response ``W_o(f)^2`` (:func:`scenesim.room.bands.band_weights`).

    >>> n = weyl_weights((5, 4, 3), (125, 1000), fs=16000, c=343.0)
    >>> bool(n[0, 1] / n[0, 0] > n[1, 1] / n[1, 0])  # planes matter more at low frequency
    True
    """
    dims = np.asarray(dims_m, dtype=float)
    df = 0.5 * fs / _N_K
    f = (np.arange(_N_K) + 0.5) * df
    k, dk = f / c, df / c
    w2 = _power_weights(float(fs), tuple(float(v) for v in centers_hz))  # (n_oct, n_f)
    vol = float(np.prod(dims))
    volume = 4.0 * np.pi * vol * (w2 @ k**2) * dk
    planes = np.pi * (vol / dims)[None, :] * (w2 @ k)[:, None] * dk
    axes = 0.5 * dims[None, :] * w2.sum(axis=1)[:, None] * dk
    return np.column_stack([volume, planes, axes])


def _coherence(reflection) -> np.ndarray:
    """Share ``(n_bands, 7)`` of Weyl's plane and axis excess that a room with these walls keeps.

    The excess of the modes in the plane normal to axis d is the coherent sum of the images
    that differ only in their reflections on d's walls (they arrive together at grazing
    incidence): full with rigid walls, none with an anechoic one.  In between it is scaled by
    ``b_d0 b_dL`` (an interpolation between those limits, not a derivation: it keeps a room with
    one anechoic wall at the continuum's T30, 0.99-1.03 of the full ISM's in
    ``tests/test_ism_features.py``); an axis' excess needs both other axes', the product.
    """
    b = np.abs(np.atleast_2d(reflection))
    rho = b[:, 0::2] * b[:, 1::2]  # (n_bands, 3)
    axes = np.stack([rho[:, 1] * rho[:, 2], rho[:, 0] * rho[:, 2], rho[:, 0] * rho[:, 1]], axis=1)
    return np.column_stack([np.ones(b.shape[0]), rho, axes])


@functools.lru_cache(maxsize=8)
def _power_weights(fs: float, centers_hz: tuple) -> np.ndarray:
    """``W_o(f)^2`` on the midpoint grid of :func:`weyl_weights` (cached)."""
    from scenesim.room.bands import band_weights

    df = 0.5 * fs / _N_K
    w2 = band_weights((np.arange(_N_K) + 0.5) * df, centers_hz) ** 2
    w2.flags.writeable = False
    return w2


def octave_gains(dims_m, reflection, times_s, centers_hz, *, fs, c, pattern=None, max_order=None,
                 with_octant: bool = False):
    """Per-octave energy of the ISM relative to :func:`expected_energy`, ``(n_bands, n_oct, n_t)``, 1 at t = 0.

    ``with_octant``: also return the octant mean ``(n_bands, n_t)`` (:func:`expected_energy` without
    its level ``c / (4 pi V fs)``), computed on the way.

    The continuum of :func:`expected_energy` weights every direction of the octant alike, as the
    oblique modes of a high octave do.  Low octaves hold few modes, and a larger share of them
    in the coordinate planes and on the axes (:func:`weyl_weights`), whose directions meet fewer
    walls: in a corridor their slow decay sets the octave's T30 (measured in a specular
    14 x 2.2 x 2.8 m corridor, alpha 0.1: full-ISM T30 2.75 s at 125 Hz, 1.99 s at 4 kHz).  So
    each octave's energy is the Weyl-weighted mean of the octant, plane and axis averages of
    the same decay ``D^2 exp(-c t kappa . u)``, divided by the octant's, both taken relative to
    t = 0 (the ISM's early energy is white).
    """
    dims = np.asarray(dims_m, dtype=float)
    kappa = _kappa(dims, reflection)
    n_bands = kappa.shape[0]
    r = c * np.concatenate([[0.0], np.asarray(times_s, dtype=float)])
    u, w = _octant_directions()
    terms = [_decay_mean(kappa, u, w, r, _mirror_mean_d2(u, pattern, n_bands), dims, max_order)]
    # the 3 planes' quarter circles and the 3 axes in one pass: direction sets as weight columns
    pu, pw = _plane_directions()
    n_p = pw.size
    dirs = np.concatenate([pu.reshape(-1, 3), np.eye(3)])
    groups = np.zeros((dirs.shape[0], 6))
    for d in range(3):
        groups[d * n_p : (d + 1) * n_p, d] = pw
        groups[3 * n_p + d, 3 + d] = 1.0
    rest = _decay_mean(kappa, dirs, groups, r, _mirror_mean_d2(dirs, pattern, n_bands), dims, max_order)
    terms = np.concatenate([terms[0][None], np.moveaxis(rest, -1, 0)])  # (7, n_bands, n_t + 1)
    modes = np.einsum("ok,bk,kbt->bot", weyl_weights(dims, centers_hz, fs=fs, c=c), _coherence(reflection), terms)
    tiny = np.finfo(float).tiny
    rel = modes[..., 1:] / np.maximum(modes[..., :1], tiny)
    cont = terms[0, :, 1:] / np.maximum(terms[0, :, :1], tiny)
    gains = rel / np.maximum(cont, tiny)[:, None, :]
    return (gains, terms[0, :, 1:]) if with_octant else gains


def coherent_noise(mics_m, n_taps, *, fs, c, rng) -> np.ndarray:
    """Unit-variance white Gaussian noise ``(n_mics, n_taps)`` with diffuse coherence between mics.

    Per rfft bin, ``X = C Z`` with ``C C^T = Gamma(f)``, ``Gamma_ij = sinc(2 f d_ij / c)``
    (numpy's normalised sinc, i.e. sin(k d) / (k d)), C from the eigendecomposition (Gamma
    is positive semi-definite; tiny negative eigenvalues from rounding are clipped).
    """
    mics = np.atleast_2d(np.asarray(mics_m, dtype=float))
    n_mics = mics.shape[0]
    n_fft = sfft.next_fast_len(n_taps, real=True)
    z = sfft.rfft(rng.standard_normal((n_mics, n_fft)), axis=-1)
    if n_mics == 1:
        return _irfft32(z, n_fft)[:, :n_taps]
    f = sfft.rfftfreq(n_fft, 1.0 / fs)
    dist = np.linalg.norm(mics[:, None, :] - mics[None, :, :], axis=-1)
    if n_mics == 2:  # closed form: X1 = Z1, X2 = g Z1 + sqrt(1 - g^2) Z2
        g = np.sinc(2.0 * f * dist[0, 1] / c)
        x = np.stack([z[0], g * z[0] + np.sqrt(np.clip(1.0 - g * g, 0.0, None)) * z[1]])
        return _irfft32(x, n_fft)[:, :n_taps]
    gamma = np.sinc(2.0 * f[:, None, None] * dist[None] / c)  # (n_f, m, m)
    lam, vec = np.linalg.eigh(gamma)
    mix = vec * np.sqrt(np.clip(lam, 0.0, None))[:, None, :]  # (n_f, m, m)
    x = np.einsum("fij,jf->if", mix, z)
    return _irfft32(x, n_fft)[:, :n_taps]


def _irfft32(spec: np.ndarray, n_fft: int) -> np.ndarray:
    """Inverse rfft along the last axis in single precision (the noise needs no more; pocketfft's
    float64 c2r took 4x its r2c here, ~1 ms of a 20 ms hybrid render)."""
    return sfft.irfft(spec.astype(np.complex64), n_fft, axis=-1)


def level_correction(early: np.ndarray, envelope2: np.ndarray, lo: int, hi: int) -> float:
    """Energy ratio of the rendered early ISM to the expected energy over taps ``[lo, hi)``.

    Why: the rendered ISM carries less energy above the infrasonic build-up than the
    incoherent image sum ``sum a^2`` (measured 0.80-0.88 of it after a 20-500 Hz high-pass
    at RT60 1 s: the image lattice is not a Poisson process), so the tail is scaled to
    the early part it continues.  The early part's infrasonic build-up (~10x its energy at
    0.1 s) is removed by a least-squares line over the window (it varies slowly over these
    few tens of ms); white noise loses 2 of its N degrees of freedom to that, put back.
    ``early`` (n_mics, n), ``envelope2`` (n,).
    """
    e = _detrend(early[..., lo:hi])
    n = hi - lo
    expected = float(np.mean(envelope2[lo:hi])) * (1.0 - 2.0 / n)
    measured = float(np.mean(e**2))
    return measured / expected if expected > 0 else 1.0


def _detrend(x: np.ndarray) -> np.ndarray:
    """``x`` (..., n) minus its least-squares line along the last axis (``scipy.signal.detrend``'s
    "linear", in closed form: centred time, so slope and mean decouple; scipy's lstsq took ~1 ms)."""
    n = x.shape[-1]
    t = np.arange(n) - 0.5 * (n - 1)
    slope = (x @ t) / float(t @ t)
    return x - x.mean(axis=-1, keepdims=True) - slope[..., None] * t


def diffuse_tail(
    room, mics_m, *, n_taps, fs, c, reflection, pattern, max_order, rng, early=None, window=None, noise=None,
    floor=None,
) -> np.ndarray:
    """Stochastic tail ``(n_bands, n_mics, n_taps)``: coherent noise x sqrt(expected energy).

    ``noise`` ``(n_mics, n_taps)``: a :func:`coherent_noise` realisation to use instead of drawing
    one from ``rng``.

    Each octave (:data:`scenesim.room.bands.OCTAVE_CENTERS_HZ`) of the noise decays as that
    octave of the ISM (:func:`octave_gains`): the octave's share of the noise (the complementary
    filter bank, so unshaped octaves add back to the noise exactly) is multiplied by
    ``sqrt(gain) - 1`` and added.  Octaves whose shaping changes the late energy by less than
    :data:`_MIN_OCTAVE_GAIN_DB` over the first 60 dB of decay are left as they are; the late
    energy includes ``floor`` (n_bands, n_taps), the expected ``h^2`` of other late fields (the
    scattered one), which in furnished rooms drowns the specular tail's shaping.

    With ``early`` (n_bands, n_mics, n_early) and ``window = (lo, hi)`` the level of each band
    is matched to the early ISM's energy in those taps (:func:`level_correction`, the octave
    gains included in the expected energy); the decay shape stays the expected one.
    """
    from scenesim.room.bands import OCTAVE_CENTERS_HZ

    n_bands = np.atleast_2d(reflection).shape[0]
    # Envelope on a coarse grid from 1 tap on, interpolated in log energy (it is smooth).
    t_grid = np.linspace(1.0 / fs, n_taps / fs, _N_TIME)
    g, octant = octave_gains(room.dims_m, reflection, t_grid, OCTAVE_CENTERS_HZ, fs=fs, c=c, pattern=pattern,
                             max_order=max_order, with_octant=True)
    e = c / (4.0 * np.pi * float(np.prod(room.dims_m)) * fs) * octant  # = expected_energy(...)
    tiny = np.finfo(float).tiny
    live = e >= 1e-6 * e[:, :1]  # the first 60 dB of the decay
    other = 0.0 if floor is None else floor[:, np.minimum(np.round(t_grid * fs).astype(int), n_taps - 1)]
    total = np.maximum(e + other, tiny)[:, None, :]
    change = 10.0 * np.log10(np.maximum(total + e[:, None, :] * (g - 1.0), tiny) / total)
    off = np.abs(change) > _MIN_OCTAVE_GAIN_DB  # (n_bands, n_oct, n_grid)
    active = _rfft_band_weights(512, float(fs), OCTAVE_CENTERS_HZ)[:, :-1].any(axis=1)  # below Nyquist
    shaped = [o for o in np.nonzero(active)[0] if np.any(off[:, o] & live)]
    if noise is None:
        noise = coherent_noise(mics_m, n_taps, fs=fs, c=c, rng=rng)
    parts = _octave_parts(noise, fs, OCTAVE_CENTERS_HZ, shaped)
    t = np.arange(n_taps) / fs
    tail = np.empty((n_bands, noise.shape[0], n_taps))
    for band in range(n_bands):
        log_e = 0.5 * np.log(np.maximum(e[band], tiny))
        env = np.exp(np.interp(t, t_grid, log_e))  # amplitude
        level = 1.0
        if early is not None and window is not None:
            lo, hi = window
            mid = (lo + hi) / (2.0 * fs)  # the shaping's power gain at the window's centre (slow)
            power = _shaped_power([np.interp(mid, t_grid, np.sqrt(g[band, o]) - 1.0) for o in shaped], shaped, fs)
            env2 = np.zeros(hi)
            env2[lo:] = env[lo:hi] ** 2 * power
            level = math.sqrt(level_correction(early[band], env2, lo, hi))
            env *= level
        np.multiply(noise, env, out=tail[band])
        if shaped:
            # per shaped octave the amplitude env x (sqrt(gain) - 1) on the grid (smooth: 0.75 dB
            # per grid step at RT60 1 s, so linear interpolation errs by ~1e-3 of it)
            amps = level * np.exp(log_e) * (np.sqrt(g[band, shaped]) - 1.0)
            tail[band] += _modulate(parts, t_grid, amps, fs)[:, :n_taps]
    return tail


def _octave_parts(noise, fs, centers_hz, octaves) -> tuple:
    """The noise's share in each of ``octaves`` (indices) at a reduced rate: ``(n_fft, [(n_o, p_o)])``.

    ``p_o`` ``(n_mics, n_o)`` samples the octave's part of the noise (zero-phase, circular over
    ``n_fft`` taps: the noise is stationary, so the wrap-around is more of the same noise) every
    ``n_fft / n_o`` taps -- just fast enough for its band and the slow gain that will multiply
    it, which is what makes the shaping cheap (an irfft per octave at the full rate took
    a third of a hybrid render).
    """
    n_taps = noise.shape[-1]
    n_fft = sfft.next_fast_len(n_taps, real=True)
    if not octaves:
        return n_fft, []
    spec = sfft.rfft(noise, n_fft, axis=-1)
    w = _rfft_band_weights(n_fft, float(fs), tuple(centers_hz))
    out = []
    for o in octaves:
        top = int(np.nonzero(w[o] > 1e-12)[0][-1]) + 1  # bins [0, top) carry the octave (cos^2(pi/2) != 0)
        n_o = sfft.next_fast_len(2 * (top + top // 4 + 16), real=True)  # margin for the gain's spread
        if n_o >= n_fft:
            n_o, top = n_fft, spec.shape[-1]
        out.append((n_o, _irfft32(spec[:, :top] * w[o, :top], n_o) * (n_o / n_fft)))
    return n_fft, out


def _modulate(parts, t_grid, amps, fs) -> np.ndarray:
    """``sum_o p_o(t) a_o(t)`` at the full rate, ``(n_mics, n_fft)``, ``a_o`` given on ``t_grid``
    (``amps`` (n_oct, n_grid), linear in between): each product formed at its octave's reduced
    rate, the sum brought to the full rate by one zero-padded inverse FFT."""
    n_fft, low = parts
    acc = None
    for (n_o, p), amp in zip(low, amps):
        step = n_fft / n_o  # full-rate taps per reduced-rate sample
        gain = np.interp(np.arange(n_o) * step / fs, t_grid, amp).astype(np.float32)
        spec = sfft.rfft(p * gain, axis=-1) * np.float32(step)
        if acc is None:
            acc = np.zeros((p.shape[0], n_fft // 2 + 1), np.complex64)
        acc[:, : spec.shape[-1]] += spec
    return _irfft32(acc, n_fft)


@functools.lru_cache(maxsize=16)
def _rfft_band_weights(n_fft: int, fs: float, centers_hz: tuple) -> np.ndarray:
    """:func:`scenesim.room.bands.band_weights` on the rfft grid of ``n_fft`` (cached: the same
    lengths recur, and evaluating them cost ~1 ms a render)."""
    from scenesim.room.bands import band_weights

    w = band_weights(sfft.rfftfreq(n_fft, 1.0 / fs), centers_hz)
    w.flags.writeable = False
    return w


def _shaped_power(extra, octaves, fs, n_freq: int = 256) -> float:
    """Power of unit white noise after the octave shaping, ``mean_f (1 + sum_o W_o(f) x_o)^2``,
    for amplitude gains - 1 ``extra`` (one number per octave)."""
    from scenesim.room.bands import OCTAVE_CENTERS_HZ

    if not octaves:
        return 1.0
    w = _rfft_band_weights(2 * n_freq - 2, float(fs), OCTAVE_CENTERS_HZ)[list(octaves)]  # (k, n_freq)
    return float(np.mean((1.0 + np.asarray(extra) @ w) ** 2))


def crossfade(early: np.ndarray, tail: np.ndarray, n_mix: int, n_fade: int) -> np.ndarray:
    """Early part untouched before ``n_mix``; over ``n_fade`` taps a power-complementary fade
    (cos / sin amplitude: the two are uncorrelated, so energy is kept) into the tail.

    ``early`` (..., n_early) with n_early <= n_taps, ``tail`` (..., n_taps) -> (..., n_taps).
    """
    out = tail.copy()
    out[..., :n_mix] = early[..., :n_mix]
    n_early = early.shape[-1]
    hi = min(n_mix + n_fade, tail.shape[-1], n_early)
    x = (np.arange(n_mix, hi) - n_mix + 0.5) / n_fade
    out[..., n_mix:hi] = early[..., n_mix:hi] * np.cos(0.5 * np.pi * x) + tail[..., n_mix:hi] * np.sin(
        0.5 * np.pi * x
    )
    return out
