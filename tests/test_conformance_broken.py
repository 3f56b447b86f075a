"""The conformance suite against deliberately broken enhancers: each check must catch its bug.

As scikit-learn tests ``check_estimator`` with estimators that break one rule each
(issue 11).  Every broken class below derives from the toy ``Gain`` (which passes every
check but ``registered``) and breaks one rule; the matching check must raise
:class:`ConformanceError`, and ``check_enhancer`` with that failure declared reports it as
a strict xfail.  ``test_parametrize_broken`` runs them through ``parametrize_with_checks``
with strict xfail marks: if a check stopped catching its bug, that test would XPASS and fail.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest
from _toy_enhancers import Gain

from enhancers.core.base import Params, Result, Tags
from enhancers.testing import CHECKS, ConformanceError, check_enhancer, parametrize_with_checks
from scenesim.validate import check_finite_number, check_signal

NOT_REGISTERED = {"registered": "test class, deliberately not registered"}


class StreamingDiffers(Gain):
    """process_block applies 0.9 x the batch gain."""

    name = "broken-streaming"

    def _process_block(self, block, state):
        return 0.9 * self.params.gain * block, state


class NonlinearReplay(Gain):
    """replay(c) scales c by its own RMS: exact on the mixture, not additive over components."""

    name = "broken-replay"

    def _process(self, x, fs):
        g = self.params.gain
        ref = float(np.sqrt(np.mean(x**2)))

        def replay(c):
            c = check_signal(c, name="component", n_channels=1, min_samples=0)
            if c.shape != x.shape:
                from scenesim.errors import ParameterError

                raise ParameterError("component", c, f"shape {x.shape}")
            return g * c * float(np.sqrt(np.mean(c**2))) / ref

        return Result(output=g * x, _replay=replay)


class MutatesInput(Gain):
    """Scales its input in place and returns a copy."""

    name = "broken-mutates"

    def _process(self, x, fs):
        x *= self.params.gain  # the bug: x may be the caller's array
        return Result(output=x.copy(), _replay=lambda c: self.params.gain * check_signal(c, n_channels=1))


class NonDeterministic(Gain):
    """Adds unseeded dither (the bug the project's 'explicit seeds' rule exists for)."""

    name = "broken-random"

    def _process(self, x, fs):
        dither = 1e-6 * np.random.default_rng().standard_normal(x.shape)
        y = self.params.gain * x + dither
        return Result(output=y, _replay=lambda c: self.params.gain * check_signal(c, n_channels=1) + dither)


class NanOnSilence(Gain):
    """Normalises by the input's RMS without a floor: 0/0 on silence."""

    name = "broken-silence"

    def _process(self, x, fs):
        with np.errstate(invalid="ignore", divide="ignore"):
            rms = np.sqrt(np.mean(x**2))
            y = self.params.gain * x * (rms / rms)
        return Result(output=y)

    def _process_block(self, block, state):
        with np.errstate(invalid="ignore", divide="ignore"):
            rms = np.sqrt(np.mean(block**2)) if block.size else 1.0
            return self.params.gain * block * (rms / rms), state


class NanOnSilenceBatchOnly(NanOnSilence):
    """As NanOnSilence, but its streaming path is fine: only the batch part of the check sees it."""

    name = "broken-silence-batch"

    def _process_block(self, block, state):
        return self.params.gain * block, state


class UnvalidatedParams(Gain):
    """Params without __post_init__: NaN and strings are accepted."""

    name = "broken-params"

    @dataclass(frozen=True)
    class Params(Params):
        gain: float = 0.5


class SharedState(Gain):
    """A one-sample delay whose state is one array shared by every stream."""

    name = "broken-shared-state"
    _shared = np.zeros((1, 1))

    @property
    def tags(self) -> Tags:
        return Tags(channels_in=1, channels_out=1, streaming=True, latency_samples=1)

    def _process(self, x, fs):
        def shift(c):
            c = check_signal(c, n_channels=1, min_samples=0)
            return np.concatenate([np.zeros((1, 1)), c], axis=1)[:, : c.shape[1]]

        return Result(output=shift(x), _replay=shift)

    def _init_state(self, fs):
        SharedState._shared[:] = 0.0  # "fresh" -- but the same object for every stream
        return SharedState._shared

    def _process_block(self, block, state):
        ext = np.concatenate([state, block], axis=1)
        n = block.shape[1]
        state[:] = ext[:, n:]  # updated in place: the other stream sees it
        return ext[:, :n].copy(), state


class SecondStreamReadsTheFirst(SharedState):
    """The first stream is private; every later stream reads the first one's history.

    Stream A is then exactly right and only stream B is wrong: the state-isolation check
    must compare both streams (regression: a check of stream A alone passed this).
    """

    name = "broken-second-stream"

    def _init_state(self, fs):
        primary = getattr(self, "_primary", None)
        if primary is None:
            self._primary = primary = {"prev": np.zeros((1, 1))}
            return primary
        return {"alias": primary}

    def _process_block(self, block, state):
        own = "prev" in state
        prev = state["prev"] if own else state["alias"]["prev"]
        ext = np.concatenate([prev, block], axis=1)
        n = block.shape[1]
        if own:
            state["prev"] = ext[:, n:]
        return ext[:, :n].copy(), state


class NotPicklable(Gain):
    """Holds a lambda (e.g. a callback) that pickle cannot serialise."""

    name = "broken-pickle"

    def __init__(self, params=None, **kwargs):
        super().__init__(params, **kwargs)
        self._callback = lambda y: y

    def __reduce__(self):
        return (NotPicklable, (), {"_callback": self._callback})


class WrongOutputShape(Gain):
    """Returns the one output channel twice."""

    name = "broken-shape"

    def _process(self, x, fs):
        y = self.params.gain * x
        return Result(output=np.vstack([y, y]), _replay=lambda c: self.params.gain * check_signal(c, n_channels=1))


BROKEN = {
    "silence (batch)": NanOnSilenceBatchOnly,
    "streaming_equals_batch": StreamingDiffers,
    "replay_linear": NonlinearReplay,
    "input_not_mutated": MutatesInput,
    "deterministic": NonDeterministic,
    "silence": NanOnSilence,
    "bad_params": UnvalidatedParams,
    "state_isolation": SharedState,
    "state_isolation (second stream)": SecondStreamReadsTheFirst,
    "pickle": NotPicklable,
    "output": WrongOutputShape,
}


def _check_name(key: str) -> str:
    return key.split(" (")[0]  # "silence (batch)" -> "silence"


@pytest.mark.parametrize("check", list(BROKEN))
def test_the_unbroken_base_passes_every_check_it_is_used_for(check):
    CHECKS[_check_name(check)](Gain())  # so each failure below is the break, not the toy


@pytest.mark.parametrize("check", list(BROKEN))
def test_each_check_catches_its_broken_enhancer(check):
    enhancer = BROKEN[check]()
    check = _check_name(check)
    with pytest.raises(ConformanceError, match=rf"\b{check}\b"):
        CHECKS[check](enhancer)
    with pytest.raises(ConformanceError, match=rf"failed \d+ conformance check\(s\):(.|\n)*\b{check}: "):
        check_enhancer(enhancer, expected_failures=NOT_REGISTERED)
    report = check_enhancer(enhancer, expected_failures={**NOT_REGISTERED, **_failing(enhancer)})
    assert report[check].startswith("xfail: ")


def _failing(enhancer) -> dict[str, str]:
    """Every check this broken enhancer fails (some bugs trip more than one check)."""
    out = {}
    for name, run in CHECKS.items():
        try:
            run(enhancer)
        except Exception:
            out[name] = "deliberately broken"
    return out


def _declared(target: str, cls):
    """``cls`` declaring its one bug (and not being registered) as expected failures."""
    failures = {_check_name(target): f"deliberately broken: {cls.__doc__.strip()}", **NOT_REGISTERED}
    return type(cls.__name__ + "Declared", (cls,), {"conformance_expected_failures": failures})()


def _own_check_only(mark):
    """parametrize_with_checks' parameters reduced to each broken enhancer's own check."""
    def own(param) -> bool:
        enhancer, check = param.values
        target = next(k for k, cls in BROKEN.items() if type(enhancer).__mro__[1] is cls)
        return check is CHECKS[_check_name(target)]

    return pytest.mark.parametrize(mark.args[0], [p for p in mark.args[1] if own(p)])


@_own_check_only(parametrize_with_checks([_declared(t, cls) for t, cls in BROKEN.items()]))
def test_parametrize_broken(enhancer, check):
    """Each broken enhancer's own check under parametrize_with_checks' strict xfail mark.

    The check raises -> xfail.  Were it to stop catching the bug, the test would XPASS and,
    strict, fail the suite.  (Other checks are left out: some bugs trip several.)
    """
    check(enhancer)


def test_gain_params_reject_nan_so_the_bad_params_break_is_the_missing_validation():
    with pytest.raises(ValueError):
        Gain(Gain.Params(gain=float("nan")))
    assert check_finite_number("gain", 0.5) == 0.5
