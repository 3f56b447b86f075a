"""The base enhancer contract: strict construction and params round trip (enhancers/core/base.py)."""

import dataclasses

import numpy as np
import pytest

from enhancers.core.base import Enhancer, Params, Result, Tags
from scenesim.errors import ParameterError
from scenesim.validate import check_positive


@dataclasses.dataclass(frozen=True)
class _GainParams(Params):
    gain: float = 1.0
    taps: tuple = (1.0,)

    def __post_init__(self):
        check_positive("gain", self.gain)


class _Gain(Enhancer):
    name = "test-gain"
    Params = _GainParams

    @property
    def tags(self):
        return Tags(channels_in=1)

    def _process(self, x, fs):
        g = self.params.gain
        return Result(output=g * x, _replay=lambda c: g * np.asarray(c, dtype=float))


def test_unknown_keyword_raises_parameter_error_naming_it():
    with pytest.raises(ParameterError, match="gian"):
        _Gain(gian=2.0)


def test_invalid_value_raises_parameter_error_naming_it():
    with pytest.raises(ParameterError, match="gain"):
        _Gain(gain=-1.0)


def test_params_json_round_trip_restores_tuples():
    p = _GainParams(gain=2.0, taps=(0.5, 0.25))
    assert _GainParams.from_json(p.to_json()) == p


def test_params_json_round_trip_restores_an_optional_tuple():
    """A ``tuple | None`` field whose default is None (``eb-robust``'s ``mix_bands_hz``, set by the registered
    ``eb-robust-blind``) comes back from JSON as the tuple, not the list JSON gives (which its check refuses)."""
    from enhancers.core.registry import make

    params = make("eb-robust", mix_bands_hz=(1000.0, 4000.0)).params
    assert type(params).from_json(params.to_json()) == params


def test_coerce_strings_parses_field_types_and_rejects_bad_text():
    assert _GainParams.coerce_strings({"gain": "0.5"}) == {"gain": 0.5}
    with pytest.raises(ParameterError, match="gain"):
        _GainParams.coerce_strings({"gain": "loud"})


def test_process_validates_input_before_the_algorithm_sees_it():
    e = _Gain(gain=2.0)
    with pytest.raises(ParameterError, match="x"):
        e.process(np.ones(10), fs=16000)  # 1-D
    out = e.process(np.ones((1, 10)), fs=16000)
    np.testing.assert_array_equal(out.output, 2.0 * np.ones((1, 10)))
