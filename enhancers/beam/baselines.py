"""Baselines every sweep compares against: the reference mic and a delay-and-sum pair.

* ``passthrough``: channel 0 (the front, reference mic p1) unchanged.
* ``das``: delay-and-sum steered to ``look_az_deg`` (endfire 0 deg by default),

  ``y[n] = (p1[n - L] + p2[n - (L - T fs)]) / 2``,  ``T = d cos(theta_look) / c``,

  so a plane wave from the look direction (``p2(t) = p1(t - T)``) comes out as the
  reference mic delayed by exactly ``L`` samples, the declared latency.  ``L`` is
  ``fir_taps // 2``, independent of ``fs`` so it can be a tag.  The fractional delay
  ``L - T fs`` of p2 is a Kaiser-windowed sinc (algorithms.md section 2) normalised to
  unit DC gain; when ``T fs`` is a whole number of samples the filter is an exact
  unit impulse, so the delays are exact shifts.  For a wave from 180 deg
  (``p2(t) = p1(t + T)``) the response is ``|cos(w T)|``.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from enhancers.core.base import Enhancer, Params, Result, Tags, check_component
from scenesim.errors import ParameterError
from scenesim.validate import check_finite_number, check_int, check_positive

__all__ = ["Passthrough", "DelayAndSum", "fractional_delay_fir"]


class Passthrough(Enhancer):
    """The reference mic (channel 0) unchanged: the 'no processing' row of every table."""

    name = "passthrough"
    version = "1"
    summary = "Reference mic (channel 0) unchanged"

    @dataclass(frozen=True)
    class Params(Params):
        """No parameters."""

    @functools.cached_property
    def tags(self) -> Tags:  # no parameters, so the tags never change (cached: read per block)
        return Tags(channels_in=2, channels_out=1, streaming=True, latency_samples=0)

    def _process(self, x: np.ndarray, fs: int) -> Result:
        def replay(component) -> np.ndarray:
            return check_component(component, x.shape)[0:1].copy()

        return Result(output=x[0:1].copy(), trace={}, _replay=replay)

    def _init_state(self, fs: int) -> None:
        return None

    def _process_block(self, block: np.ndarray, state):
        return block[0:1].copy(), state


def fractional_delay_fir(delay: float, n_taps: int, *, kaiser_beta: float = 8.0) -> np.ndarray:
    """Causal FIR ``(n_taps,)`` delaying by ``delay`` samples (``0 <= delay <= n_taps - 1``).

    ``h[n] = w(n - delay) sinc(n - delay)`` with a Kaiser window of length ``n_taps``
    centred on the true delay, scaled to unit DC gain.  An integer ``delay`` (to 1e-9)
    gives the exact unit impulse.
    """
    k = round(delay)
    h = np.zeros(n_taps)
    if abs(delay - k) < 1e-9:
        h[int(k)] = 1.0
        return h
    t = np.arange(n_taps) - delay
    half = n_taps / 2.0
    arg = np.clip(1.0 - (t / half) ** 2, 0.0, None)
    w = np.i0(kaiser_beta * np.sqrt(arg)) / np.i0(kaiser_beta)
    h = w * np.sinc(t)
    return h / h.sum()


class DelayAndSum(Enhancer):
    """Two-mic delay-and-sum beamformer steered to ``look_az_deg`` (see module docstring).

    Parameters (``DelayAndSum.Params``)
    ----------
    spacing_m : float
        Mic spacing d in metres (> 0); set by the runner from the scene.
    c_mps : float
        Speed of sound in m/s (> 0).
    look_az_deg : float
        Steering azimuth in degrees (0 = endfire, the front).
    fir_taps : int
        Length of the fractional-delay FIR (>= 4); latency is ``fir_taps // 2`` samples.
    """

    name = "das"
    version = "1"
    summary = "Delay-and-sum pair steered to the look direction (endfire)"

    @dataclass(frozen=True)
    class Params(Params):
        spacing_m: float = 0.0214
        c_mps: float = 343.0
        look_az_deg: float = 0.0
        fir_taps: int = 32

        def __post_init__(self):
            check_positive("spacing_m", self.spacing_m)
            check_positive("c_mps", self.c_mps)
            check_finite_number("look_az_deg", self.look_az_deg)
            check_int("fir_taps", self.fir_taps, minimum=4, maximum=4096)

    @property
    def latency(self) -> int:
        return self.params.fir_taps // 2

    @functools.cached_property
    def tags(self) -> Tags:  # params are frozen, so the tags never change (cached: read per block)
        return Tags(
            channels_in=2,
            channels_out=1,
            needs_geometry=True,
            streaming=True,
            latency_samples=self.latency,
        )

    def steering_delay_samples(self, fs: int) -> float:
        """``T fs`` with ``T = d cos(theta_look) / c`` (samples, may be fractional or negative)."""
        p = self.params
        return p.spacing_m * np.cos(np.deg2rad(p.look_az_deg)) / p.c_mps * fs

    def filters(self, fs: int) -> np.ndarray:
        """``(2, fir_taps)`` FIRs applied to p1 and p2 before averaging (the 1/2 included)."""
        n = self.params.fir_taps
        lat = self.latency
        d2 = lat - self.steering_delay_samples(fs)
        # Keep the sinc's main lobe inside the taps; beyond that the filter is not a delay.
        if not 1.0 <= d2 <= n - 2.0:
            raise ParameterError(
                "spacing_m",
                self.params.spacing_m,
                f"a spacing whose delay d/c*fs (here {lat - d2:.3g} samples at fs={fs}) "
                f"fits the FIR: |delay| <= {lat - 1} samples for fir_taps={n}",
            )
        h = np.zeros((2, n))
        h[0, lat] = 0.5
        h[1] = 0.5 * fractional_delay_fir(d2, n)
        return h

    @staticmethod
    def _filter(ext: np.ndarray, h: np.ndarray) -> np.ndarray:
        # ext holds n_taps - 1 history samples then the block; 'valid' gives one output per
        # block sample.  An empty block must give no output (np.convolve would swap its
        # arguments when ext is shorter than h).
        if ext.shape[1] < h.shape[1]:
            return np.zeros(0)
        return np.convolve(ext[0], h[0], mode="valid") + np.convolve(ext[1], h[1], mode="valid")

    def _apply(self, x: np.ndarray, h: np.ndarray) -> np.ndarray:
        n = h.shape[1]
        ext = np.concatenate([np.zeros((2, n - 1)), x], axis=1)
        return self._filter(ext, h)[None, :]

    def _process(self, x: np.ndarray, fs: int) -> Result:
        h = self.filters(fs)

        def replay(component) -> np.ndarray:
            return self._apply(check_component(component, x.shape), h)

        return Result(output=self._apply(x, h), trace={}, _replay=replay)

    def _init_state(self, fs: int) -> dict:
        h = self.filters(fs)
        return {"h": h, "history": np.zeros((2, h.shape[1] - 1))}

    def _process_block(self, block: np.ndarray, state: dict):
        import enhancers.kernels.stream as sk  # lazy: numba's import is only paid when streaming

        if 0 < block.shape[1] <= sk.MAX_BLOCK:  # compiled FIR; the history is updated in place
            hist = state["history"]
            return sk.fir_pair_block(sk.extend(hist, block), hist, state["h"])[None, :], state
        h = state["h"]
        ext = np.concatenate([state["history"], block], axis=1)
        out = self._filter(ext, h)[None, :]
        new_state = {"h": h, "history": ext[:, ext.shape[1] - (h.shape[1] - 1) :].copy()}
        return out, new_state
