"""Chain: composition, params (nested, JSON, CLI strings), geometry forwarding, streaming, replay.

Oracle: the stages applied one after another by hand (toy stages with exact outputs).
"""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from _toy_enhancers import Delay, Gain, SumGeo

from enhancers.core import registry
from enhancers.core.chain import Chain, EbSs, chain_class
from enhancers.core.registry import make, register, unregister, with_geometry
from enhancers.testing import check_enhancer, stream
from scenesim.errors import ParameterError

FS = 16000
STAGES = [("geo", "toy-sumgeo"), ("delay", "toy-delay"), ("gain", "toy-gain")]


@pytest.fixture(scope="module", autouse=True)
def toys():
    for cls in (Gain, Delay, SumGeo):
        register(cls.name, cls)
    yield
    for cls in (Gain, Delay, SumGeo):
        unregister(cls.name)


@pytest.fixture
def toy_chain():
    return chain_class("toy-chain", STAGES)


def _by_hand(x, spacing_m=0.0214, delay=3, gain=0.5):
    y = spacing_m / 0.0214 * (x[0] + x[1])
    y = np.concatenate([np.zeros(delay), y])[: x.shape[1]]
    return gain * y[None, :]


def test_output_is_composition(rng, toy_chain):
    x = rng.standard_normal((2, 300))
    e = toy_chain()
    result = e.process(x, FS)
    np.testing.assert_allclose(result.output, _by_hand(x), rtol=0, atol=1e-15)
    assert set(result.trace) == {"delay.delay", "gain.gain"}
    np.testing.assert_allclose(result.replay(2 * x), 2 * result.output, rtol=0, atol=1e-15)


def test_tags_combine(toy_chain):
    tags = toy_chain(delay={"delay": 5}).tags
    assert (tags.channels_in, tags.channels_out) == (2, 1)
    assert tags.latency_samples == 5 and tags.streaming and tags.needs_geometry


def test_stage_override_nested_and_json(rng, toy_chain):
    e = toy_chain(gain={"gain": 2.0}, delay={"delay": 1})
    assert e.params.gain.gain == 2.0 and e.params.delay.delay == 1
    x = rng.standard_normal((2, 100))
    np.testing.assert_allclose(e.process(x, FS).output, _by_hand(x, delay=1, gain=2.0), atol=1e-15)
    text = e.params.to_json()
    assert '"gain": {"gain": 2.0}' in text and "spacing_m" not in text.split('"geo"')[1].split("}")[0]
    assert type(e.params).from_json(text) == e.params
    assert toy_chain(type(e.params).from_json(text)) == e


def test_geometry_forwarded_and_owned_by_chain(rng, toy_chain):
    e = toy_chain(spacing_m=0.0428)
    assert e.params.geo.spacing_m == 0.0428
    x = rng.standard_normal((2, 50))
    np.testing.assert_allclose(e.process(x, FS).output, _by_hand(x, spacing_m=0.0428), atol=1e-15)
    moved = with_geometry(toy_chain(), spacing_m=0.0107, c_mps=340.0)
    assert (moved.params.geo.spacing_m, moved.params.geo.c_mps) == (0.0107, 340.0)
    with pytest.raises(ParameterError, match="geo.spacing_m"):
        toy_chain(geo={"spacing_m": 0.05})
    assert toy_chain(geo={"spacing_m": 0.0214}) == toy_chain()  # agreeing value is fine


@pytest.mark.parametrize(
    "overrides, name",
    [({"gain": {"gain": float("nan")}}, "gain.gain"), ({"gain": 3.0}, "gain"),
     ({"delay": {"nope": 1}}, "delay.nope"), ({"spacing_m": -1.0}, "spacing_m")],
)
def test_bad_stage_params_name_the_stage(toy_chain, overrides, name):
    with pytest.raises(ParameterError, match=name):
        toy_chain(**overrides)


def test_channel_mismatch_is_clear():
    cls = chain_class("toy-bad", [("gain", "toy-gain"), ("geo", "toy-sumgeo")])
    with pytest.raises(ParameterError, match="'gain' gives 1 channel.*'geo' takes 2"):
        cls()


def test_coerce_strings(toy_chain):
    values = toy_chain.Params.coerce_strings({"gain.gain": "2.5", "delay.delay": "4", "spacing_m": "0.03"})
    assert values == {"gain": {"gain": 2.5}, "delay": {"delay": 4}, "spacing_m": 0.03}
    assert toy_chain(**values).params.geo.spacing_m == 0.03
    with pytest.raises(ParameterError, match="nope.x"):
        toy_chain.Params.coerce_strings({"nope.x": "1"})
    with pytest.raises(ParameterError, match="gain.gain"):
        toy_chain.Params.coerce_strings({"gain.gain": "loud"})


def test_streaming_state_is_tuple_and_matches_batch(rng, toy_chain):
    e = toy_chain()
    x = rng.standard_normal((2, 200))
    state = e.init_state(FS)
    assert isinstance(state, tuple) and len(state) == 3
    np.testing.assert_allclose(stream(e, x, FS, 7), e.process(x, FS).output, rtol=0, atol=1e-15)


def test_runtime_chain_pickles_and_is_conformant(toy_chain):
    e = toy_chain(gain={"gain": 0.25})
    back = pickle.loads(pickle.dumps(e))
    assert back == e and type(back) is toy_chain
    register("toy-chain", toy_chain)
    try:
        assert make("toy-chain", gain={"gain": 0.25}) == e
        assert set(check_enhancer(e).values()) == {"passed"}
    finally:
        unregister("toy-chain")


def test_stage_defaults_replace_the_stages_registry_defaults():
    """``stage_defaults``: ``eb-robust-blind-ss``'s ss stage defaults to its averaged gain; a stage dict's omitted
    keys take those (not plain ss's), and an explicit key wins.  A prefix the chain does not have is a one-line
    parameter error."""
    from enhancers.beam.presets import EB_ROBUST_BLIND_SS
    from enhancers.core.chain import Chain

    ss = make("eb-robust-blind-ss").params.ss
    assert ss == make("ss", **EB_ROBUST_BLIND_SS).params != make("ss").params
    one = make("eb-robust-blind-ss", ss={"gain_bins": 1}).params.ss
    assert (one.gain_bins, one.gain_smooth, one.power_bins) == (1, 0.55, 2)

    class Bad(Chain):
        name, version, summary = "toy-bad", "1", "toy"
        stages = (("ss", "ss"),)
        stage_defaults = {"eb": {"mu": 0.1}}

    with pytest.raises(ParameterError, match="stage_defaults"):
        Bad()


def test_chain_class_is_cached_and_validates():
    assert chain_class("toy-c", ["toy-gain", "toy-delay"]) is chain_class("toy-c", ["toy-gain", "toy-delay"])
    assert chain_class("toy-c", ["toy-gain"]).stages == (("toy_gain", "toy-gain"),)
    with pytest.raises(ParameterError, match="stages"):
        chain_class("toy-d", ["toy-gain", "toy-gain"])
    with pytest.raises(ParameterError, match="stages"):
        chain_class("toy-e", [])


def test_eb_ss_is_registered_chain_of_eb_then_ss(rng):
    """EB-SS output equals SS applied to EB's output (composition oracle)."""
    assert registry.get("eb-ss") is EbSs and issubclass(EbSs, Chain)
    e = make("eb-ss")
    x = 0.1 * rng.standard_normal((2, FS // 2))
    y_eb = make("eb").process(x, FS).output
    y = make("ss").process(y_eb, FS).output
    np.testing.assert_allclose(e.process(x, FS).output, y, rtol=0, atol=1e-12)
    assert e.tags.needs_geometry
    assert e.spec["stages"] == {"eb": f"eb@{make('eb').version}", "ss": f"ss@{make('ss').version}"}
    assert e.tags.latency_samples == make("eb").tags.latency_samples + make("ss").tags.latency_samples


def test_eb_ss_overrides_and_geometry():
    e = make("eb-ss", ss={"alpha": 0.9}, spacing_m=0.03)
    assert e.params.ss.alpha == 0.9
    assert e.params.eb.spacing_m == 0.03
    assert type(e.params).from_json(e.params.to_json()) == e.params


def test_hop_is_lcm_of_stage_hops():
    """The streaming check uses the chain's hop: lcm of the stages' declared hops."""
    import math

    from enhancers.core.chain import hop_of

    e = make("eb-ss")
    hops = [hop_of(s, FS) for s in e.stage_enhancers]
    assert e.hop == math.lcm(*[h for h in hops if h]) and hop_of(e, FS) == e.hop
    assert chain_class("toy-nohop", ["toy-gain", "toy-delay"])().hop is None
