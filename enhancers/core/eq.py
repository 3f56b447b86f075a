"""Per-bin look-direction equaliser of a first-order differential output, with a noise-aware option.

The differential output ``Y = cF - beta cB`` (algorithms.md section 5) of a plane wave from
the look direction (theta = 0) is ``2 j P e^{-j w T} sin(w T)`` whatever beta is (``cB`` has
its null there), so the exact look-direction equaliser of bin ``k`` (``w = 2 pi k / N``,
``T`` in samples) is ``1 / |2 sin(w T)|``.  It boosts +6 dB per octave downwards (and,
with ``T fs ~ 1``, towards Nyquist, where ``sin(w T) -> 0`` again).

Spatially white noise (sensor self-noise, wind), independent and of equal PSD ``s`` at
both mics, leaves ``cF - beta cB = X1 (1 + beta e^{-jwT}) - X2 (e^{-jwT} + beta)`` with PSD
``s N(beta, w)``, ``N = 2 (1 + beta^2 + 2 beta cos(w T))``.  Relative to the look
direction that is ``N / (4 sin^2(w T))`` per bin: no equaliser changes this ratio, but the
equaliser decides how much each bin weighs in the broadband output.  The options:

* ``max_gain_db`` (always): ``G <= 10^(max_gain_db / 20)``, a cap on the boost.
* ``noise_gain_db`` (the noise-aware option; None = off): ``G^2 N(beta, w) <= 10^(noise_gain_db/10)``,
  i.e. **the output PSD of spatially white sensor noise never exceeds the single-mic
  sensor-noise PSD times ``10^(noise_gain_db/10)`` in any bin, for any beta** (a white-noise-gain
  constraint).  Where it binds, the look response is ``|2 sin(w T)| sqrt(10^(nb/10) / N)``
  instead of 1 (a gentle high-pass, and a roll-off near Nyquist).
* ``highpass_hz`` (0 = off): times the magnitude of a 2nd-order Butterworth high-pass,
  ``(f/fh)^2 / sqrt(1 + (f/fh)^4)``, applied zero-phase per bin.

Measured broadband amplification of spatially white noise re a white look-direction plane
wave (ideal cardioid, 256-point bins at 16 kHz, the exact inverse capped at 25 dB):
14.4 dB; with ``noise_gain_db`` = 12 / 9 / 6 dB: 6.0 / 4.6 / 3.2 dB (computed from the formulas
above; the benchmark ``benchmarks/studies/robust_eb.py`` measures it on the running enhancer).
"""

from __future__ import annotations

import numpy as np

__all__ = ["look_eq_gain", "white_noise_factor"]


def white_noise_factor(beta, omega_t) -> np.ndarray:
    """``N(beta, w) = 2 (1 + beta^2 + 2 beta cos(w T))``: output PSD of ``cF - beta cB`` per unit
    spatially white input PSD; ``omega_t = w T`` (rad), broadcast against ``beta``."""
    beta = np.asarray(beta, dtype=float)
    return 2.0 * (1.0 + beta * beta + 2.0 * beta * np.cos(omega_t))


def look_eq_gain(
    beta, *, omega: np.ndarray, delay_samples: float, freqs_hz: np.ndarray, max_gain_db: float,
    noise_gain_db: float | None = None, highpass_hz: float = 0.0,
) -> np.ndarray:
    """Real per-bin equaliser gain ``G`` for the differential output ``cF - beta cB``.

    Parameters
    ----------
    beta : array (..., K)
        Per-bin beta (any leading shape, e.g. ``(F, K)``); only used by ``noise_gain_db``.
    omega : array (K,)
        ``2 pi k / N`` (rad/sample).
    delay_samples : float
        ``T fs``.
    freqs_hz : array (K,)
        Bin frequencies (Hz), for the high-pass.
    max_gain_db, noise_gain_db, highpass_hz : see the module docstring.

    Returns
    -------
    ndarray, the broadcast shape of ``beta`` and ``(K,)``.

    Examples
    --------
    >>> import numpy as np
    >>> w = 2 * np.pi * np.arange(129) / 256
    >>> g = look_eq_gain(np.zeros(129), omega=w, delay_samples=1.0, freqs_hz=w / (2 * np.pi) * 16000,
    ...                  max_gain_db=25.0, noise_gain_db=9.0)
    >>> bool(np.all(g**2 * 2 <= 10**0.9 + 1e-9))
    True
    """
    wt = omega * delay_samples
    look = np.abs(2.0 * np.sin(wt))
    g = 1.0 / np.maximum(look, 10.0 ** (-max_gain_db / 20.0))
    g = np.broadcast_to(g, np.broadcast_shapes(np.shape(beta), g.shape))
    if noise_gain_db is not None:
        bound = 10.0 ** (noise_gain_db / 10.0)
        g = np.minimum(g, np.sqrt(bound / np.maximum(white_noise_factor(beta, wt), 1e-30)))
    if highpass_hz > 0:
        r = (np.asarray(freqs_hz, dtype=float) / highpass_hz) ** 2
        g = g * (r / np.sqrt(1.0 + r * r))
    return np.array(g, dtype=float)
