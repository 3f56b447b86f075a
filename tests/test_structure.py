"""Structure items of issue 11: one copy of each helper, no swallowed exceptions, the cache split."""

from __future__ import annotations

import ast
import inspect

import numpy as np
import pytest

import scenesim.memo
import scenesim.room.cache
from benchmarks.excinfo import exc_text
from benchmarks.metrics import evaluate
from benchmarks.run import runner
from enhancers.core.chain import hop_of
from scenesim.scene.mixing import noise_gain_for_snr, noise_gain_from_powers


class _HopRaises:
    def hop(self, fs):
        raise RuntimeError("no hop at this rate")


class _HopCallable:
    def hop(self, fs):
        return fs // 125


def test_hop_of_lets_a_failing_hop_raise():
    with pytest.raises(RuntimeError, match="no hop at this rate"):
        hop_of(_HopRaises(), 16000)
    assert hop_of(_HopRaises()) is None  # without fs the callable is not called
    assert hop_of(_HopCallable(), 16000) == 128


def _boom():
    raise ValueError("bad value")


def test_exc_text_is_one_line_with_the_innermost_frame():
    try:
        _boom()
    except ValueError as exc:
        text = exc_text(exc)
    line = inspect.getsourcelines(_boom)[1] + 1
    assert text == f"ValueError: bad value (at test_structure.py:{line} in _boom)"
    assert exc_text(KeyError("k")) == "KeyError: 'k'"  # never raised: no frame


def test_runner_and_evaluate_share_one_exc_text():
    assert runner._exc_text is exc_text and evaluate._exc_text is exc_text


def test_noise_gain_formula_is_written_once_and_correct(rng):
    # Closed form: g = sqrt(Ps / (Pn 10^(snr/10))); 1e-12 relative.
    assert noise_gain_from_powers(1.0, 4.0, 0.0) == pytest.approx(0.5, rel=1e-12)
    assert noise_gain_from_powers(2.0, 1.0, 10.0) == pytest.approx(np.sqrt(0.2), rel=1e-12)
    s, n = rng.standard_normal(4000), 3.0 * rng.standard_normal(4000)
    g = noise_gain_for_snr(s, n, 5.0)
    assert 10 * np.log10(np.mean(s**2) / np.mean((g * n) ** 2)) == pytest.approx(5.0, abs=1e-9)
    # Scene.mix calls the same function instead of repeating the formula.
    import scenesim.scene.compose

    assert "noise_gain_from_powers" in inspect.getsource(scenesim.scene.compose.SceneImages.mix)


def test_cache_is_split_into_a_generic_memoiser_and_the_ism_cache():
    imported = set()
    for node in ast.walk(ast.parse(inspect.getsource(scenesim.memo))):
        if isinstance(node, ast.ImportFrom):
            imported.add(node.module)
        elif isinstance(node, ast.Import):
            imported.update(a.name for a in node.names)
    assert not {m for m in imported if m and m.startswith("scenesim.") and m != "scenesim.errors"}
    assert not hasattr(scenesim.memo, "cached_rir") and not hasattr(scenesim.memo, "rir_key")
    # The old public names still work through scenesim.room.cache.
    assert scenesim.room.cache.cached_array is scenesim.memo.cached_array
    assert scenesim.room.cache.stable_hash is scenesim.memo.stable_hash
