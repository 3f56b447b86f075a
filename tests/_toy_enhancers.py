"""Small, obviously-correct enhancers used by the registry/chain/conformance tests.

``Gain``: 1 channel in/out, ``y = gain * x`` (streaming, replay exact).
``Delay``: 1 channel in/out, ``y[n] = x[n - delay]`` (declares ``delay`` as latency).
``SumGeo``: 2 channels in, 1 out, needs geometry (``y = x0 + x1`` scaled by spacing),
only to check that geometry is forwarded through a chain.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from enhancers.core.base import Enhancer, Params, Result, Tags
from scenesim.validate import check_finite_number, check_int, check_positive, check_signal


class Gain(Enhancer):
    name = "toy-gain"
    version = "1"
    summary = "Scales its one channel"

    @dataclass(frozen=True)
    class Params(Params):
        gain: float = 0.5

        def __post_init__(self):
            check_finite_number("gain", self.gain)

    @property
    def tags(self) -> Tags:
        return Tags(channels_in=1, channels_out=1, streaming=True)

    def _process(self, x, fs):
        g = self.params.gain
        gain_trace = np.full(x.shape[1], g)

        def replay(c):
            return g * check_signal(c, name="component", n_channels=1, min_samples=0)

        return Result(output=g * x, trace={"gain": gain_trace}, _replay=replay)

    def _init_state(self, fs):
        return None

    def _process_block(self, block, state):
        return self.params.gain * block, state


class Delay(Enhancer):
    name = "toy-delay"
    version = "1"
    summary = "Delays its one channel by whole samples"

    @dataclass(frozen=True)
    class Params(Params):
        delay: int = 3

        def __post_init__(self):
            check_int("delay", self.delay, minimum=0)

    @property
    def tags(self) -> Tags:
        return Tags(channels_in=1, channels_out=1, streaming=True, latency_samples=self.params.delay)

    def _shift(self, x):
        d = self.params.delay
        return np.concatenate([np.zeros((1, d)), x], axis=1)[:, : x.shape[1]]

    def _process(self, x, fs):
        return Result(output=self._shift(x), trace={"delay": np.array([self.params.delay])},
                      _replay=lambda c: self._shift(check_signal(c, n_channels=1, min_samples=0)))

    def _init_state(self, fs):
        return np.zeros((1, self.params.delay))

    def _process_block(self, block, state):
        ext = np.concatenate([state, block], axis=1)
        n = block.shape[1]
        return ext[:, :n].copy(), ext[:, n:].copy()


class SumGeo(Enhancer):
    name = "toy-sumgeo"
    version = "2"
    summary = "Sums two channels, weighted by spacing (geometry forwarding test)"

    @dataclass(frozen=True)
    class Params(Params):
        spacing_m: float = 0.0214
        c_mps: float = 343.0

        def __post_init__(self):
            check_positive("spacing_m", self.spacing_m)
            check_positive("c_mps", self.c_mps)

    @property
    def tags(self) -> Tags:
        return Tags(channels_in=2, channels_out=1, needs_geometry=True, streaming=True)

    def _w(self):
        return self.params.spacing_m / 0.0214

    def _process(self, x, fs):
        w = self._w()
        return Result(output=w * (x[0:1] + x[1:2]),
                      _replay=lambda c: w * (c[0:1] + c[1:2]))

    def _init_state(self, fs):
        return None

    def _process_block(self, block, state):
        return self._w() * (block[0:1] + block[1:2]), state
