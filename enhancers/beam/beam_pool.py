"""Pooled adaptation of the sub-band beamformer's beta and DAS mix weight (issue 16 part 3, opt-in).

Why pool.  ``eb-subband`` learns one beta and one DAS mix weight per STFT bin.  The talker (off
the look direction) leaks into the backward cardioid ``cB`` and into ``D = Yd - Yo``, so the cells a
per-bin estimate learns from carry speech x noise cross terms; they flip sign between two runs on
``s + n`` and ``s - n`` and move the talker's path (``speech_jitter_db``).  Their error on an
estimate pooled over ``K`` cells goes as ``sqrt(sum rho) / K`` (``rho`` = talker / noise power per
cell): one parameter fitted over a whole band pools ~100 times more cells per frame than one per bin.

* Direction model (:func:`direction_beta_step`): every bin's beta is the closed form (eq. 1 of
  :mod:`enhancers.beam.subband_eb`) of ONE rear direction per band, ``beta_k = B(c, w_k T)`` with
  ``c = cos theta`` in ``[-1, 0]`` (theta in [90, 180] deg): a rear plane wave is nulled at every
  frequency by one number.  ``c`` follows a normalised gradient of ``sum_k |Y_k|^2`` over the
  band's cells (NLMS with regressor ``x_k = cB_k dB/dc``), the numerator over the cells the gate
  does not freeze, the normaliser over all the band's cells of the *same* frame (no smoothed
  powers: a loud talker frame shrinks its own step and nothing carries into later frames).
* Pooled DAS weight (:func:`pooled_mix_step`): ``alpha`` per band, least squares from one-pole
  averages of the band's *unfrozen* cells only (a per-bin smoothing would mix frozen talker cells
  of neighbouring bins in), shrunk towards the prior ``alpha0`` while few cells were learned.

Measured (``python -m benchmarks.studies.calibration_jitter [--data-dir ../shared/data] --seeds 2 --snrs 15 20 25
--skip-mismatch --decompose --pooled``, i.e. ``beta_model="direction"``, ``mu=0.015``, ``beta_norm="learned"``,
``mix_bands_hz=(1000, 4000)``, ``mix_ramp_cells=300``; eb-robust's jitter with only beta (+EQ) / only alpha
swapped between the ``s + n`` and ``s - n`` runs, worst over the 6 rows per noise, babble / factory /
factory-hall / wind; load ~5 on 2 cores):

* beta, shared data: -14.8 / -18.3 / -16.9 / -17.2 dB (default) -> -22.9 / -31.9 / -21.7 / -55.0 (medians
  -19.0..-19.9 -> -35.1 / -41.7 / -33.9 / -71.3); built-in: -20.6 / -20.0 / -12.2 / -19.0 -> -31.8 / -30.7 /
  -14.0 / -58.1.
* alpha, shared: -9.4 / -26.6 / -16.8 / -16.4 -> -23.9 / -27.2 / -17.0 / -17.3 (medians -31.8 / -31.8 / -20.3
  / -22.2 -> -38.6 / -37.0 / -31.2 / -36.0); built-in -38.4 / -39.3 / -23.1 / -22.0 -> -46.2 / -45.0 / -28.1 /
  -23.3.  Without the ramp (``mix_ramp_cells=0``) the hall's worst is -11.1 (start-up, 0-1 kHz).
* eb-robust-ss mean SNR-I (shared) 4.16 / 9.56 / 2.18 / 8.95 -> 4.43 / 9.04 / 1.96 / 8.87 dB; built-in
  5.40 / 9.83 / 1.67 / 8.32 -> 4.98 / 9.20 / 1.59 / 7.52 (without the ramp 5.28 / 9.49 / 1.67 / 9.06: the
  prior 0.5 held in wind's low band costs 1.5 dB there).
* with ``eq_bound_beta=0`` too (the EQ no longer follows beta): beta worst -28.1 / -37.6 / -30.0 / -65.8
  (shared), -35.7 / -41.1 / -17.9 / -96.2 (built-in); SNR-I 4.65 / 9.23 / 2.48 / 8.87 (shared), 5.18 / 9.52 /
  2.10 / 7.52 (built-in).
* issue 12's scenes (``benchmarks.studies.robust_eb``, 2 seeds): ideal / 1 dB-5 deg SNR-I at 135 deg 35.5 /
  32.9 dB (default 28.3 / 28.3), 240 deg 35.9 / 28.0 (26.5 / 26.0), diffuse 3.3 / 3.2, wind 8.6 / 8.2: better
  than the default with or without the mismatch, but one direction cannot absorb what the calibration
  leaves of the mismatch, so the loss re its own deeper ideal null is 2.6 / 8.0 dB at 135 / 240 deg.
* What the direction model gives up: a per-bin freedom the data may need.  Bins near Nyquist of a
  fractional-delay plane wave (``scenesim.scene.freefield.plane_wave``'s default) are not eq. 1, so white
  noise from 135 deg there is nulled by 21.7 dB broadband (per bin 32.1; with exact delays both >= 33 dB);
  and below ~500 Hz of a real phone (self-noise, unequal high-pass corners) the best beta is not the
  plane wave's either (factory SNR-I -0.5 dB).
"""

from __future__ import annotations

import numpy as np

TINY = 1e-30

__all__ = ["band_onehot", "beta_from_cos", "dbeta_dcos", "direction_beta_step", "pooled_mix_step"]


def beta_from_cos(c, omega_t) -> np.ndarray:
    """Eq. 1 of :mod:`enhancers.beam.subband_eb`: ``sin(wT(1 + c)/2) / sin(wT(1 - c)/2)``, 0 where ``wT = 0``.

    ``c`` = cos of the rear direction (broadcast with ``omega_t``, rad).

    >>> round(float(beta_from_cos(-0.5, 0.01)), 4)   # low frequency: (1 + c) / (1 - c) = 1/3
    0.3333
    """
    wt = np.asarray(omega_t, dtype=float)
    b = np.sin(wt * (1 - np.asarray(c)) / 2)
    return np.sin(wt * (1 + np.asarray(c)) / 2) / np.where(b == 0, np.inf, b)


def dbeta_dcos(c, omega_t) -> np.ndarray:
    """``d beta_from_cos / dc = (wT / 2) sin(wT) / sin^2(wT(1 - c)/2)`` (closed form), 0 where ``wT = 0``.

    >>> round(float(dbeta_dcos(-0.5, 0.001)), 3)     # low frequency: 2 / (1 - c)^2
    0.889
    """
    wt = np.asarray(omega_t, dtype=float)
    b = np.sin(wt * (1 - np.asarray(c)) / 2)
    return 0.5 * wt * np.sin(wt) / np.where(b == 0, np.inf, b * b)


def band_onehot(freqs_hz, edges_hz) -> np.ndarray:
    """``(K, B)`` 0/1 matrix: bin ``k`` (``freqs_hz (K,)``) belongs to band ``searchsorted(edges, f)``.

    ``edges_hz`` are the split points (``()``: one band); empty bands are dropped.

    >>> band_onehot([0.0, 500.0, 1500.0, 3000.0], (1000.0,)).tolist()
    [[1.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.0, 1.0]]
    """
    idx = np.searchsorted(np.asarray(edges_hz, dtype=float), np.asarray(freqs_hz, dtype=float), side="right")
    m = (idx[:, None] == np.arange(len(edges_hz) + 1)[None]).astype(float)
    return m[:, m.sum(axis=0) > 0]


def direction_beta_step(cF, cB, p1, learn, c0, *, omega_t, onehot, mu: float, eps: float, den0=None,
                        norm_lam: float | None = None):
    """One rear direction per band, NLMS on ``sum_k |cF_k - B(c, w_k T)_k cB_k|^2`` once per frame.

    ``c += mu sum_learned Re(Y_k conj(x_k)) / den`` with ``x_k = cB_k dB/dc``, clipped to ``[-1, 0]``.
    ``norm_lam`` None: ``den`` = the frame's ``sum_k |x_k|^2 + eps p1_k (dB/dc)^2`` over ALL the band's
    cells (a frame whose cells are mostly frozen takes a small step).  ``norm_lam`` set: ``den`` is a
    one-pole average of that sum over the *learned* cells only, scaled to the whole band (a frame with a
    fraction ``f`` learned moves it by ``(1 - norm_lam) f``; the first learned frame sets it): the
    talker's power in frozen cells neither shrinks the step nor carries into later frames.

    Parameters
    ----------
    cF, cB : complex (F, K), forward/backward cardioids.
    p1 : (F, K) front-mic power ``|X1|^2`` (the regulariser, relative ``eps``).
    learn : bool (F, K) or None, the cells whose gradient counts (None: all).
    c0 : (B,) cos of each band's direction before the first frame; den0 : (B,) the averaged normaliser
        (``norm_lam`` set; None or 0: not yet set).
    omega_t : (K,) ``w_k T`` (rad); onehot : (K, B) from :func:`band_onehot`.
    mu : step per frame (the fraction of the frame's least-squares step).

    Returns ``(betas (F, K) applied to each frame, cs (F, B), c after the last frame (B,), den (B,))``.

    >>> import numpy as np
    >>> wt = np.linspace(0.0, 1.5, 9); oh = band_onehot(wt, ()); cB = np.ones((400, 9)) + 0j
    >>> cF = beta_from_cos(-0.5, wt) * cB                           # a plane wave from 120 deg
    >>> _, cs, c, _ = direction_beta_step(cF, cB, np.ones((400, 9)), None, np.array([-1.0]),
    ...                                    omega_t=wt, onehot=oh, mu=0.1, eps=0.0)
    >>> round(float(c[0]), 4)
    -0.5
    """
    band, size = onehot.argmax(axis=1), onehot.sum(axis=0)
    F = cF.shape[0]
    betas, cs = np.empty(cF.shape), np.empty((F, onehot.shape[1]))
    c = np.asarray(c0, dtype=float).copy()
    den = np.zeros(onehot.shape[1]) if den0 is None else np.asarray(den0, dtype=float).copy()
    for i in range(F):  # beta depends on c nonlinearly: loop over frames, vectorised over bins
        ck = c[band]
        beta, d = beta_from_cos(ck, omega_t), dbeta_dcos(ck, omega_t)
        betas[i], cs[i] = beta, c
        y, x = cF[i] - beta * cB[i], cB[i] * d
        g = y.real * x.real + y.imag * x.imag
        q = x.real**2 + x.imag**2 + eps * p1[i] * d * d
        if learn is not None:
            g = np.where(learn[i], g, 0.0)
        if norm_lam is None:
            step = mu / ((q @ onehot) + TINY)
        else:
            w = np.ones(q.shape) if learn is None else learn[i].astype(float)
            f, ql = (w @ onehot) / size, (q * w) @ onehot
            den = np.where((den <= 0) & (f > 0), ql / np.maximum(f, TINY), den + (1.0 - norm_lam) * (ql - f * den))
            step = mu / (den + TINY)
        c = np.clip(c + step * (g @ onehot), -1.0, 0.0)
    return betas, cs, c, den


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
