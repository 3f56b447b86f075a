"""Pooled least-squares weights of the sub-band beamformer: the DAS mix weight per band, and the delayed beta.

:func:`pooled_mix_step` fits ``alpha = clip((S_YD + alpha0 r) / (S_DD + r), 0, 1)`` (``r = eps S_11``) from
one-pole averages of the band means of ``Re(Yd conj(D))``, ``|D|^2`` and ``|X1|^2`` over the cells a caller's
weights let it learn (a frame with a fraction ``f`` of the band learned moves them by ``(1 - lam) f``), shrunk
towards the prior ``alpha0`` while the band has learned fewer than ``ramp_cells`` cells.  Why pool: the
talker (off the look direction) leaks into ``D = Yd - Yo``, so the cells an estimate learns from carry speech x
noise cross terms, which flip sign between runs on ``s + n`` and ``s - n``; their error on an estimate pooled
over ``K`` cells goes as ``sqrt(sum rho) / K`` (``rho`` = talker / noise power per cell).  ``eb-robust-blind``
learns its DAS weight this way in three bands (0-1, 1-4, 4-8 kHz, ``mix_bands_hz``), and its delayed beta
(``beta_model="delayed"``: ``Yd = cF``, ``D = cB``, one band per bin) is the same least squares.
:func:`beta_from_cos` is eq. 1 of :mod:`enhancers.beam.subband_eb` (the beta nulling a plane wave);
:func:`band_onehot` maps bins to bands.

Measured: in incoherent noise the pooled weight reaches the closed-form optimum 1 within 0.1 after 300 frames
(the doctest of :func:`pooled_mix_step`; tests/test_beam_pool.py); ``eb-robust-blind``'s measured jitter and
SNR-I are in :mod:`enhancers.beam.presets`.
"""

from __future__ import annotations

import numpy as np

TINY = 1e-30

__all__ = ["band_onehot", "beta_from_cos", "pooled_mix_step"]


def beta_from_cos(c, omega_t) -> np.ndarray:
    """Eq. 1 of :mod:`enhancers.beam.subband_eb`: ``sin(wT(1 + c)/2) / sin(wT(1 - c)/2)``, 0 where ``wT = 0``.

    ``c`` = cos of the rear direction (broadcast with ``omega_t``, rad).

    >>> round(float(beta_from_cos(-0.5, 0.01)), 4)   # low frequency: (1 + c) / (1 - c) = 1/3
    0.3333
    """
    wt = np.asarray(omega_t, dtype=float)
    b = np.sin(wt * (1 - np.asarray(c)) / 2)
    return np.sin(wt * (1 + np.asarray(c)) / 2) / np.where(b == 0, np.inf, b)


def band_onehot(freqs_hz, edges_hz) -> np.ndarray:
    """``(K, B)`` 0/1 matrix: bin ``k`` (``freqs_hz (K,)``) belongs to band ``searchsorted(edges, f)``.

    ``edges_hz`` are the split points (``()``: one band); empty bands are dropped.

    >>> band_onehot([0.0, 500.0, 1500.0, 3000.0], (1000.0,)).tolist()
    [[1.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.0, 1.0]]
    """
    idx = np.searchsorted(np.asarray(edges_hz, dtype=float), np.asarray(freqs_hz, dtype=float), side="right")
    m = (idx[:, None] == np.arange(len(edges_hz) + 1)[None]).astype(float)
    return m[:, m.sum(axis=0) > 0]


def pooled_mix_step(Yd, D, p1, learn, s_yd, s_dd, s_11, n, *, onehot, lam: float, eps: float, alpha0: float,
                    ramp_cells: float = 0.0):
    """DAS mix weight per band: ``alpha = clip((S_YD + alpha0 r) / (S_DD + r), 0, 1)``, ``r = eps S_11``.

    ``S_*`` are one-pole averages (``lam`` per fully learned frame) of the band's mean over its
    ``learn`` cells of ``Re(Yd conj(D))``, ``|D|^2`` and ``p1``; a frame with a fraction ``f`` of
    the band's cells learned moves them by ``(1 - lam) f`` (``f = 0``: unchanged).  The weight of a
    frame uses the averages of the frames before it.  ``ramp_cells > 0``: while the band has learned
    ``n`` cells the weight applied is ``alpha0 + min(1, n / ramp_cells) (alpha - alpha0)``.

    Shapes: ``Yd, D`` complex (F, K), ``p1`` (F, K), ``learn`` bool (F, K) or None, ``s_*`` and ``n``
    (B,), ``onehot`` (K, B), or None for one band per bin (``B = K``).  Returns ``(alphas (F, K), s_yd, s_dd, s_11, n)``.

    >>> import numpy as np
    >>> rng = np.random.default_rng(0); g = lambda: rng.standard_normal((300, 8)) + 1j * rng.standard_normal((300, 8))
    >>> Yo, N = g(), g(); Yd = Yo + N; z = np.zeros(1)               # incoherent noise: alpha* = 1
    >>> a, *_ = pooled_mix_step(Yd, Yd - Yo, np.ones((300, 8)), None, z, z, z, z, onehot=np.ones((8, 1)),
    ...                         lam=0.95, eps=0.0, alpha0=0.0)
    >>> bool(abs(a[-1, 0] - 1.0) < 0.1)
    True
    """
    w = np.ones(p1.shape) if learn is None else learn.astype(float)
    if onehot is None:  # one band per bin: the sums over a band are the cells themselves (no (K, K) products)
        band, size = np.arange(p1.shape[1]), 1.0
    else:
        band, size = onehot.argmax(axis=1), onehot.sum(axis=0)

    def pool(a):
        """The band means of ``a (F, K)``: ``(F, B)``."""
        return a if onehot is None else a @ onehot / size

    f = pool(w)
    yd = pool((Yd.real * D.real + Yd.imag * D.imag) * w)
    dd = pool((D.real**2 + D.imag**2) * w)
    pm = pool(p1 * w)
    s_yd, s_dd, s_11, n = (np.array(v, dtype=float) for v in (s_yd, s_dd, s_11, n))
    out = np.empty(f.shape)
    for i in range(p1.shape[0]):  # a time-varying one-pole per band
        reg = eps * s_11 + TINY
        a = np.clip((s_yd + alpha0 * reg) / (s_dd + reg), 0.0, 1.0)
        out[i] = a if ramp_cells <= 0 else alpha0 + np.minimum(1.0, n / ramp_cells) * (a - alpha0)
        k = (1.0 - lam) * f[i]
        s_yd += (1.0 - lam) * yd[i] - k * s_yd
        s_dd += (1.0 - lam) * dd[i] - k * s_dd
        s_11 += (1.0 - lam) * pm[i] - k * s_11
        n += f[i] * size
    return out[:, band], s_yd, s_dd, s_11, n
