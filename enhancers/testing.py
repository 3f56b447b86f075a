"""The conformance suite every enhancer must pass (contract.md; scikit-learn's estimator_checks).

Usage::

    from enhancers.testing import check_enhancer
    check_enhancer(MyEnhancer)            # a class (default params) or an instance

and in a plugin's own pytest suite::

    from enhancers.testing import parametrize_with_checks

    @parametrize_with_checks([MyEnhancer()])
    def test_conformance(enhancer, check):
        check(enhancer)

Each check is a plain function ``check_<name>(enhancer)`` raising
:class:`ConformanceError` (an ``AssertionError``) with a message naming the enhancer,
the check and what went wrong.  ``CHECKS`` lists them in order.

Expected failures are declared, with a reason, either on the class::

    class MyEnhancer(Enhancer):
        conformance_expected_failures = {"streaming_equals_batch": "batch uses look-ahead"}

or per call (``expected_failures={...}``).  An expected failure that fails is reported
as ``"xfail: <reason>"``.  Expected failures are strict, as scikit-learn's: one that
passes is an error (the enhancer was fixed, so its declaration must go).

Heuristic for bad parameters (``bad_params``): from each ``Params`` field's type
annotation (``X | None`` counts as ``X``), every ``float``/``int`` field must reject NaN
and a string, a ``bool`` field the string ``"yes"``, a ``str`` field the number 3.0 (a
field that takes more than strings must say so in its annotation), and a field whose
type is another ``Params`` (a chain stage) a number and a mapping with an unknown key;
a registered enhancer must reject an unknown keyword through ``make``.  Negative values
are not required to fail (many parameters, e.g. dB floors, may be negative).

Test signal (``test_signal``): 1.5 s at 16 kHz (or the first supported rate) of seeded
white noise plus a 440 Hz tone, amplitude about 0.1; channel ``k`` is the source delayed
by ``k`` samples (a plane wave along the array) plus a little independent noise.
"""

from __future__ import annotations

import dataclasses
import pickle
import typing
from collections.abc import Callable, Iterator, Mapping

import numpy as np

from enhancers.core.base import Enhancer, Params
from enhancers.core.chain import hop_of
from enhancers.core.registry import get, make, with_geometry
from scenesim.errors import ParameterError, ScenesimError

__all__ = [
    "CHECKS",
    "ConformanceError",
    "check_enhancer",
    "enhancer_checks",
    "expected_failures_of",
    "parametrize_with_checks",
    "stream",
    "test_signal",
]

TOL = 1e-9
"""Absolute tolerance for streaming == batch and replay (signals have amplitude ~0.1)."""

SILENCE_MAX = 1e-6
"""All-zero input must give output with max |y| below this."""

PRIME_BLOCK = 97
DEFAULT_HOP = 64


class ConformanceError(ScenesimError, AssertionError):
    """An enhancer failed a conformance check; the message names the check and the problem."""


def _fail(enhancer, check: str, message: str) -> typing.NoReturn:
    raise ConformanceError(f"[{getattr(enhancer, 'name', enhancer)!s}] {check}: {message}")


# -- inputs ----------------------------------------------------------------------------------
def test_fs(enhancer) -> int:
    """16000 Hz unless the enhancer's ``tags.supported_fs`` excludes it (then its first rate)."""
    supported = enhancer.tags.supported_fs
    return 16000 if supported is None or 16000 in supported else int(supported[0])


test_fs.__test__ = False  # not a pytest test


def test_signal(
    n_channels: int, fs: int = 16000, *, seconds: float = 1.5, seed: int = 0
) -> np.ndarray:
    """Deterministic ``(n_channels, n)`` test input (see module docstring)."""
    rng = np.random.default_rng(seed)
    n = max(1, int(round(seconds * fs)))
    t = np.arange(n + n_channels) / fs
    source = 0.05 * rng.standard_normal(n + n_channels) + 0.05 * np.sin(2 * np.pi * 440.0 * t)
    x = np.empty((n_channels, n))
    for k in range(n_channels):
        x[k] = source[n_channels - k : n_channels - k + n] + 0.005 * rng.standard_normal(n)
    return x


test_signal.__test__ = False


def stream(enhancer, x: np.ndarray, fs: int, block: int, state=None) -> np.ndarray:
    """Run ``x`` through ``process_block`` in blocks of ``block`` samples; concatenated output."""
    state = enhancer.init_state(fs) if state is None else state
    outs = []
    for start in range(0, x.shape[1], block):
        out, state = enhancer.process_block(x[:, start : start + block], state)
        outs.append(np.asarray(out))
    return np.concatenate(outs, axis=1)


def _fresh(enhancer):
    return type(enhancer)(enhancer.params)


def _read_only(x: np.ndarray) -> np.ndarray:
    x = np.array(x, dtype=np.float64, copy=True)
    x.setflags(write=False)
    return x


def _close(enhancer, check: str, what: str, actual, desired, tol: float = TOL) -> None:
    actual = np.asarray(actual)
    desired = np.asarray(desired)
    if actual.shape != desired.shape:
        _fail(enhancer, check, f"{what}: shape {actual.shape} != {desired.shape}")
    err = float(np.max(np.abs(actual - desired))) if actual.size else 0.0
    if not err <= tol:
        _fail(enhancer, check, f"{what}: max abs difference {err:.3g} > {tol:g}")


# -- the checks ------------------------------------------------------------------------------
def check_registered(enhancer) -> None:
    """``name`` is registered and ``make(name@version, **params)`` gives an equal object."""
    name, version = enhancer.name, enhancer.version
    if not name:
        _fail(enhancer, "registered", "class attribute 'name' is empty")
    try:
        cls = get(f"{name}@{version}")
    except ScenesimError as exc:
        _fail(enhancer, "registered", f"{name}@{version} is not registered: {exc}")
    if cls is not type(enhancer):
        _fail(enhancer, "registered", f"{name}@{version} is registered as {cls!r}, not {type(enhancer)!r}")
    again = make(f"{name}@{version}", **enhancer.params.to_dict())
    if again != enhancer:
        _fail(enhancer, "registered", f"make({name!r}, **params) gave {again!r} != {enhancer!r}")
    if make(f"{name}@{version}") != type(enhancer)():
        _fail(enhancer, "registered", "make(name) with no params differs from the class defaults")


def check_params_json(enhancer) -> None:
    """``Params`` round-trips through JSON and rebuilds an equal enhancer."""
    params = enhancer.params
    if not dataclasses.is_dataclass(params) or not params.__dataclass_params__.frozen:
        _fail(enhancer, "params_json", "Params must be a frozen dataclass")
    text = params.to_json()
    back = type(params).from_json(text)
    if back != params:
        _fail(enhancer, "params_json", f"from_json(to_json()) gave {back!r} != {params!r}")
    if back.to_json() != text:
        _fail(enhancer, "params_json", "JSON text changed when round-tripped twice")
    if type(enhancer)(back) != enhancer:
        _fail(enhancer, "params_json", "rebuilding from the round-tripped params gave a different enhancer")


def _bad_values(hint) -> list:
    args = [a for a in typing.get_args(hint) if a is not type(None)]
    base = args[0] if typing.get_origin(hint) is not None and args else hint
    if isinstance(base, type) and issubclass(base, Params):
        return [3.0, {"__no_such_param__": 1}]
    if base in (float, int):
        return [float("nan"), "not-a-number"]
    if base is bool:
        return ["yes"]
    if base is str:
        return [3.0]
    return []


def check_bad_params(enhancer) -> None:
    """Bad parameter values raise :class:`ParameterError` naming the field (heuristic in module doc)."""
    params = enhancer.params
    hints = typing.get_type_hints(type(params))
    for f in dataclasses.fields(params):
        for bad in _bad_values(hints.get(f.name, f.type)):
            try:
                type(enhancer)(dataclasses.replace(params, **{f.name: bad}))
            except ParameterError as exc:
                if f.name not in str(exc):
                    _fail(enhancer, "bad_params", f"{f.name}={bad!r} raised {exc!r} not naming {f.name!r}")
                continue
            except Exception as exc:
                _fail(enhancer, "bad_params", f"{f.name}={bad!r} raised {type(exc).__name__}, not ParameterError: {exc}")
            _fail(enhancer, "bad_params", f"{f.name}={bad!r} was accepted")
    try:
        registered = get(f"{enhancer.name}@{enhancer.version}") is type(enhancer)
    except ScenesimError:
        registered = False  # the 'registered' check reports that
    if not registered:
        return
    try:
        make(f"{enhancer.name}@{enhancer.version}", __no_such_param__=1)
    except ParameterError as exc:
        if "__no_such_param__" not in str(exc):
            _fail(enhancer, "bad_params", f"unknown keyword raised {exc!r} not naming it")
    except Exception as exc:
        _fail(enhancer, "bad_params", f"unknown keyword raised {type(exc).__name__}: {exc}")
    else:
        _fail(enhancer, "bad_params", "make(name, __no_such_param__=1) was accepted")


def _expect_input_error(enhancer, check: str, what: str, x, fs, param: str) -> None:
    try:
        enhancer.process(x, fs)
    except ParameterError as exc:
        if exc.name != param:
            _fail(enhancer, check, f"{what}: ParameterError names {exc.name!r}, expected {param!r}")
        return
    except Exception as exc:
        _fail(enhancer, check, f"{what}: raised {type(exc).__name__}, not ParameterError: {exc}")
    _fail(enhancer, check, f"{what}: accepted")


def check_rejects_nan_inf(enhancer) -> None:
    """NaN or Inf anywhere in the input raises ParameterError naming ``x``."""
    fs = test_fs(enhancer)
    x = test_signal(enhancer.tags.channels_in, fs, seconds=0.1)
    for value in (np.nan, np.inf, -np.inf):
        bad = x.copy()
        bad[-1, bad.shape[1] // 2] = value
        _expect_input_error(enhancer, "rejects_nan_inf", f"input with {value}", bad, fs, "x")


def check_rejects_bad_shape(enhancer) -> None:
    """1-D, 3-D, wrong channel count and empty (0 samples) input raise ParameterError naming ``x``."""
    fs = test_fs(enhancer)
    n_in = enhancer.tags.channels_in
    x = test_signal(n_in + 1, fs, seconds=0.1)
    cases = {
        "1-D input": x[0],
        "3-D input": x[None, :n_in],
        f"{n_in + 1} channels": x,
        "0 samples": x[:n_in, :0],
        "string data": np.full((n_in, 10), "a"),
    }
    if n_in > 1:
        cases[f"{n_in - 1} channel(s)"] = x[: n_in - 1]
    for what, bad in cases.items():
        _expect_input_error(enhancer, "rejects_bad_shape", what, bad, fs, "x")


def check_rejects_bad_fs(enhancer) -> None:
    """Non-positive, non-integral and (with ``supported_fs``) unsupported rates raise naming ``fs``."""
    fs = test_fs(enhancer)
    x = test_signal(enhancer.tags.channels_in, fs, seconds=0.1)
    bad_rates: list = [0, -16000, 16000.5, "16000", None]
    if enhancer.tags.supported_fs is not None:
        bad_rates.append(next(r for r in (12345, 7, 96001) if r not in enhancer.tags.supported_fs))
    for rate in bad_rates:
        _expect_input_error(enhancer, "rejects_bad_fs", f"fs={rate!r}", x, rate, "fs")


def check_output(enhancer) -> None:
    """Output is ``(channels_out, n)`` float64 and finite; trace values are arrays."""
    fs = test_fs(enhancer)
    x = test_signal(enhancer.tags.channels_in, fs)
    result = enhancer.process(x, fs)
    y = result.output
    if not isinstance(y, np.ndarray):
        _fail(enhancer, "output", f"output is {type(y).__name__}, not ndarray")
    if y.shape != (enhancer.tags.channels_out, x.shape[1]):
        _fail(enhancer, "output", f"shape {y.shape} != {(enhancer.tags.channels_out, x.shape[1])}")
    if y.dtype != np.float64:
        _fail(enhancer, "output", f"dtype {y.dtype} != float64")
    if not np.all(np.isfinite(y)):
        _fail(enhancer, "output", "output has NaN or Inf")
    if not np.any(y):
        _fail(enhancer, "output", "output is all zeros for a non-silent input")
    if np.shares_memory(y, x):
        _fail(enhancer, "output", "output shares memory with the input (return a new array)")
    for key, value in result.trace.items():
        if not isinstance(key, str) or not isinstance(value, np.ndarray):
            _fail(enhancer, "output", f"trace entry {key!r} is not str -> ndarray")
    # Other input dtypes are accepted and converted.
    y32 = enhancer.process(x.astype(np.float32), fs).output
    if y32.dtype != np.float64 or y32.shape != y.shape:
        _fail(enhancer, "output", "float32 input did not give a float64 output of the same shape")


def check_input_not_mutated(enhancer) -> None:
    """Read-only input works for process, replay and process_block, and is left unchanged."""
    fs = test_fs(enhancer)
    x = test_signal(enhancer.tags.channels_in, fs, seconds=0.5)
    ro = _read_only(x)
    try:
        result = enhancer.process(ro, fs)
        if enhancer.tags.replayable:
            result.replay(ro)
        if enhancer.tags.streaming:
            stream(enhancer, ro, fs, PRIME_BLOCK)
    except ValueError as exc:
        if "read-only" in str(exc):
            _fail(enhancer, "input_not_mutated", f"writes to its input: {exc}")
        raise
    if not np.array_equal(ro, x):
        _fail(enhancer, "input_not_mutated", "input changed")


def check_deterministic(enhancer) -> None:
    """Two runs (same object, then a fresh equal object) give identical output."""
    fs = test_fs(enhancer)
    x = test_signal(enhancer.tags.channels_in, fs)
    a = enhancer.process(x, fs).output
    b = enhancer.process(x, fs).output
    c = _fresh(enhancer).process(x, fs).output
    if not (np.array_equal(a, b) and np.array_equal(a, c)):
        _fail(enhancer, "deterministic", "repeated runs differ")


def check_silence(enhancer) -> None:
    """All-zero input gives finite output with max |y| < 1e-6 (no division blow-up on silence)."""
    fs = test_fs(enhancer)
    x = np.zeros((enhancer.tags.channels_in, fs))
    y = enhancer.process(x, fs).output
    if not np.all(np.isfinite(y)):
        _fail(enhancer, "silence", "NaN or Inf on silent input")
    peak = float(np.max(np.abs(y))) if y.size else 0.0
    if peak >= SILENCE_MAX:
        _fail(enhancer, "silence", f"max |y| = {peak:.3g} on silent input (>= {SILENCE_MAX:g})")
    if enhancer.tags.streaming:
        ys = stream(enhancer, x, fs, PRIME_BLOCK)
        if not np.all(np.isfinite(ys)) or np.max(np.abs(ys)) >= SILENCE_MAX:
            _fail(enhancer, "silence", "streaming output on silent input is not finite near-zero")


def check_streaming_equals_batch(enhancer) -> None:
    """Concatenated block outputs equal batch output (to 1e-9) for blocks 1, the hop and 97.

    Also ``4 hop + 1`` and 97 with an empty block before each (which must give an empty
    output).  Block size 1 runs on 0.25 s (a Python call per sample); the others on 1.5 s.
    """
    if not enhancer.tags.streaming:
        return
    fs = test_fs(enhancer)
    x = test_signal(enhancer.tags.channels_in, fs)
    y = enhancer.process(x, fs).output
    hop = hop_of(enhancer, fs) or DEFAULT_HOP
    for block in sorted({hop, PRIME_BLOCK, 4 * hop + 1}):
        _close(enhancer, "streaming_equals_batch", f"block size {block}", stream(enhancer, x, fs, block), y)
    # Empty blocks (a stream that delivers nothing this tick) give empty output, change nothing.
    state = enhancer.init_state(fs)
    outs = []
    for start in range(0, x.shape[1], PRIME_BLOCK):
        empty, state = enhancer.process_block(x[:, start:start], state)
        if np.shape(empty) != (enhancer.tags.channels_out, 0):
            _fail(enhancer, "streaming_equals_batch", f"an empty block gave output of shape {np.shape(empty)}")
        out, state = enhancer.process_block(x[:, start : start + PRIME_BLOCK], state)
        outs.append(out)
    _close(enhancer, "streaming_equals_batch", "blocks of 97 with empty blocks between", np.concatenate(outs, axis=1), y)
    short = x[:, : fs // 4]
    y_short = enhancer.process(short, fs).output
    _close(enhancer, "streaming_equals_batch", "block size 1", stream(enhancer, short, fs, 1), y_short)


def check_state_isolation(enhancer) -> None:
    """Two streams interleaved block by block equal two separate batch runs."""
    if not enhancer.tags.streaming:
        return
    fs = test_fs(enhancer)
    a = test_signal(enhancer.tags.channels_in, fs, seconds=1.0, seed=1)
    b = 0.5 * test_signal(enhancer.tags.channels_in, fs, seconds=1.0, seed=2)
    sa, sb = enhancer.init_state(fs), enhancer.init_state(fs)
    outs_a, outs_b = [], []
    for start in range(0, a.shape[1], PRIME_BLOCK):
        ya, sa = enhancer.process_block(a[:, start : start + PRIME_BLOCK], sa)
        yb, sb = enhancer.process_block(b[:, start : start + PRIME_BLOCK], sb)
        outs_a.append(ya)
        outs_b.append(yb)
    _close(enhancer, "state_isolation", "stream A", np.concatenate(outs_a, axis=1), enhancer.process(a, fs).output)
    _close(enhancer, "state_isolation", "stream B", np.concatenate(outs_b, axis=1), enhancer.process(b, fs).output)


def check_pickle(enhancer) -> None:
    """A pickle round trip gives an equal object producing identical output."""
    fs = test_fs(enhancer)
    x = test_signal(enhancer.tags.channels_in, fs, seconds=0.5)
    try:
        back = pickle.loads(pickle.dumps(enhancer))
    except Exception as exc:
        _fail(enhancer, "pickle", f"pickling failed: {type(exc).__name__}: {exc}")
    if back != enhancer:
        _fail(enhancer, "pickle", f"unpickled {back!r} != {enhancer!r}")
    if not np.array_equal(back.process(x, fs).output, enhancer.process(x, fs).output):
        _fail(enhancer, "pickle", "unpickled enhancer gives different output")
    params_back = pickle.loads(pickle.dumps(enhancer.params))
    if params_back != enhancer.params:
        _fail(enhancer, "pickle", "params do not survive pickling")


def _components(enhancer, fs: int) -> tuple[np.ndarray, np.ndarray]:
    # Two different "sources": a delayed pair (speech-like) and an independent noise pair.
    n_in = enhancer.tags.channels_in
    s = test_signal(n_in, fs, seed=3)
    rng = np.random.default_rng(4)
    v = 0.03 * rng.standard_normal(s.shape)
    return s, v


def check_replay_mixture(enhancer) -> None:
    """``result.replay(mixture)`` reproduces ``result.output`` (to 1e-9)."""
    if not enhancer.tags.replayable:
        return
    fs = test_fs(enhancer)
    s, v = _components(enhancer, fs)
    x = s + v
    result = enhancer.process(x, fs)
    _close(enhancer, "replay_mixture", "replay(mixture) vs output", result.replay(x), result.output)


def check_replay_linear(enhancer) -> None:
    """``replay(s + v) == replay(s) + replay(v)`` (to 1e-9): shadow filtering is linear."""
    if not enhancer.tags.replayable:
        return
    fs = test_fs(enhancer)
    s, v = _components(enhancer, fs)
    result = enhancer.process(s + v, fs)
    ys, yv = result.replay(s), result.replay(v)
    if ys.shape != result.output.shape:
        _fail(enhancer, "replay_linear", f"replay shape {ys.shape} != output shape {result.output.shape}")
    _close(enhancer, "replay_linear", "replay(s + v) vs replay(s) + replay(v)", result.replay(s + v), ys + yv)


def check_replay_rejects_bad_component(enhancer) -> None:
    """Replay of a component with the wrong length, channel count, or NaN raises ParameterError."""
    if not enhancer.tags.replayable:
        return
    fs = test_fs(enhancer)
    s, v = _components(enhancer, fs)
    result = enhancer.process(s + v, fs)
    n_in, n = s.shape
    nan = s.copy()
    nan[0, n // 2] = np.nan
    cases = {
        "a shorter component": s[:, : n // 2],
        f"{n_in + 1} channels": np.zeros((n_in + 1, n)),
        "NaN in the component": nan,
    }
    for what, bad in cases.items():
        try:
            result.replay(bad)
        except ParameterError:
            continue
        except Exception as exc:
            _fail(enhancer, "replay_rejects_bad_component", f"{what}: raised {type(exc).__name__}, not ParameterError: {exc}")
        _fail(enhancer, "replay_rejects_bad_component", f"{what}: accepted")


def check_geometry(enhancer) -> None:
    """``needs_geometry`` enhancers take ``spacing_m``/``c_mps``; ``with_geometry`` sets them."""
    if not enhancer.tags.needs_geometry:
        if with_geometry(enhancer, spacing_m=0.03) is not enhancer:
            _fail(enhancer, "geometry", "with_geometry changed an enhancer that needs no geometry")
        return
    names = {f.name for f in dataclasses.fields(enhancer.params)}
    for key in ("spacing_m", "c_mps"):
        if key not in names:
            _fail(enhancer, "geometry", f"needs_geometry but Params has no {key!r} field")
    moved = with_geometry(enhancer, spacing_m=0.03, c_mps=340.0)
    if (moved.params.spacing_m, moved.params.c_mps) != (0.03, 340.0):
        _fail(enhancer, "geometry", "with_geometry did not set spacing_m/c_mps")
    fs = test_fs(enhancer)
    x = test_signal(enhancer.tags.channels_in, fs, seconds=0.25)
    if not np.all(np.isfinite(moved.process(x, fs).output)):
        _fail(enhancer, "geometry", "non-finite output after with_geometry")


CHECKS: dict[str, Callable[[Enhancer], None]] = {
    "registered": check_registered,
    "params_json": check_params_json,
    "bad_params": check_bad_params,
    "rejects_nan_inf": check_rejects_nan_inf,
    "rejects_bad_shape": check_rejects_bad_shape,
    "rejects_bad_fs": check_rejects_bad_fs,
    "output": check_output,
    "input_not_mutated": check_input_not_mutated,
    "deterministic": check_deterministic,
    "silence": check_silence,
    "streaming_equals_batch": check_streaming_equals_batch,
    "state_isolation": check_state_isolation,
    "pickle": check_pickle,
    "replay_mixture": check_replay_mixture,
    "replay_linear": check_replay_linear,
    "replay_rejects_bad_component": check_replay_rejects_bad_component,
    "geometry": check_geometry,
}
"""Every check by name, in the order ``check_enhancer`` runs them."""


# -- runners ---------------------------------------------------------------------------------
def _instance(obj):
    return obj() if isinstance(obj, type) else obj


def expected_failures_of(obj, extra: Mapping[str, str] | None = None) -> dict[str, str]:
    """Declared expected failures: the class's ``conformance_expected_failures`` plus ``extra``."""
    declared = dict(getattr(obj, "conformance_expected_failures", None) or {})
    declared.update(extra or {})
    unknown = sorted(set(declared) - set(CHECKS))
    if unknown:
        raise ParameterError("expected_failures", unknown, "check names among " + ", ".join(CHECKS))
    return declared


def enhancer_checks(obj) -> Iterator[tuple[str, Callable[[], None]]]:
    """Yield ``(check_name, run)`` pairs for ``obj`` (class or instance); ``run()`` runs that check."""
    enhancer = _instance(obj)
    for name, check in CHECKS.items():
        yield name, (lambda check=check: check(enhancer))


def check_enhancer(obj, *, expected_failures: Mapping[str, str] | None = None) -> dict[str, str]:
    """Run every check on ``obj`` (an enhancer class or instance).

    Returns ``{check: "passed" | "xfail: <reason>"}``; raises :class:`ConformanceError`
    listing every unexpected failure and every declared failure that passed (strict xfail).
    """
    expected = expected_failures_of(obj, expected_failures)
    report: dict[str, str] = {}
    failures = []
    for name, run in enhancer_checks(obj):
        try:
            run()
        except Exception as exc:
            if name in expected:
                report[name] = f"xfail: {expected[name]}"
            else:
                failures.append(f"{name}: {type(exc).__name__}: {exc}")
                report[name] = "failed"
        else:
            if name in expected:
                failures.append(f"{name}: passes but is declared an expected failure "
                                f"({expected[name]!r}); remove the declaration")
                report[name] = "xpass"
            else:
                report[name] = "passed"
    if failures:
        raise ConformanceError(
            f"{getattr(obj, 'name', obj)!s} failed {len(failures)} conformance check(s):\n  "
            + "\n  ".join(failures)
        )
    return report


def parametrize_with_checks(objs, *, expected_failures: Mapping[str, str] | None = None):
    """A ``pytest.mark.parametrize("enhancer, check", ...)`` over every object x check.

    Declared expected failures become strict ``xfail`` marks with their reasons.
    """
    import pytest  # only needed when used inside a test suite

    params = []
    for obj in objs:
        inst = _instance(obj)
        expected = expected_failures_of(inst, expected_failures)
        for name, check in CHECKS.items():
            # strict: a check that starts passing fails the suite until the declaration is dropped
            marks = [pytest.mark.xfail(reason=expected[name], strict=True)] if name in expected else []
            params.append(pytest.param(inst, check, id=f"{inst.name}-{name}", marks=marks))
    return pytest.mark.parametrize("enhancer, check", params)
