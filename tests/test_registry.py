"""Registry: versioned names, lazy entries, defaults, clear errors, describe, with_geometry."""

from __future__ import annotations

import subprocess
import sys

import pytest
from _toy_enhancers import Gain, SumGeo

from enhancers.beam.baselines import DelayAndSum, Passthrough
from enhancers.core import registry
from enhancers.core.registry import (
    EnhancerNotFound,
    available,
    describe,
    get,
    make,
    register,
    unregister,
    with_geometry,
)
from scenesim.errors import ParameterError, PluginError, ScenesimError

BUILTINS = ["cardioid", "das", "eb", "eb-ss", "hypercardioid", "passthrough", "ss", "ss-ms2001"]


class Gain2(Gain):
    version = "2"


class Gain10(Gain):
    version = "10"


@pytest.fixture
def toy_names():
    """Names registered by a test are removed afterwards (the registry is process-global)."""
    names: list[str] = []
    yield names
    for name in names:
        if name in registry._REGISTRY:
            unregister(name)


def test_available_lists_builtins_sorted():
    names = available()
    assert names == sorted(names)
    assert set(BUILTINS) <= set(names)


def test_builtins_are_lazy():
    # Listing must not import any algorithm module (entries are "module:Class" strings).
    code = (
        "import sys, enhancers; enhancers.available(); "
        "print(sorted(m for m in sys.modules if m in "
        "('enhancers.beam.eb', 'enhancers.single.ss', 'enhancers.beam.baselines', 'enhancers.core.filterbank')))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_get_and_make_builtin():
    assert get("passthrough") is Passthrough
    assert make("das", spacing_m=0.03).params.spacing_m == 0.03
    assert make("das") == DelayAndSum()


def test_miss_suggests_close_name():
    with pytest.raises(EnhancerNotFound, match="Did you mean 'eb-ss'") as info:
        make("eb-sss")
    # One family for callers: a PluginError, a ScenesimError and a KeyError.
    assert isinstance(info.value, PluginError)
    assert isinstance(info.value, ScenesimError)
    assert isinstance(info.value, KeyError)
    assert "Available:" in str(info.value)


def test_versions_latest_and_specific(toy_names):
    toy_names.append("toy-gain")
    register("toy-gain", Gain)
    register("toy-gain", Gain10)
    register("toy-gain", Gain2)
    assert type(make("toy-gain")) is Gain10  # "10" > "2": numeric comparison
    assert type(make("toy-gain@1")) is Gain
    assert type(make("toy-gain@2")) is Gain2
    with pytest.raises(EnhancerNotFound, match="Registered versions: 1, 10, 2"):
        make("toy-gain@3")


def test_explicit_version_must_match_class(toy_names):
    toy_names.append("toy-lazy")
    register("toy-lazy", "_toy_enhancers:Gain", version="7")
    with pytest.raises(PluginError, match="version '7'.*version '1'"):
        make("toy-lazy")


def test_duplicate_registration_raises(toy_names):
    toy_names.append("toy-gain")
    register("toy-gain", Gain)
    with pytest.raises(PluginError, match="already registered"):
        register("toy-gain", Gain)
    with pytest.raises(PluginError, match="already registered"):
        register("eb", "somewhere:Else")


def test_default_params_then_overrides(toy_names):
    toy_names.append("toy-loud")
    register("toy-loud", Gain, gain=2.0)
    assert make("toy-loud").params.gain == 2.0
    assert make("toy-loud", gain=3.0).params.gain == 3.0
    # Registered in-process from a module outside this distribution: source is that module.
    assert registry.get_spec("toy-loud").source == "_toy_enhancers"


def test_unknown_param_is_parameter_error():
    with pytest.raises(ParameterError, match="spacing"):
        make("passthrough", spacing=1.0)


def test_bad_param_value_names_field():
    with pytest.raises(ParameterError, match="fir_taps"):
        make("das", fir_taps=2.5)


@pytest.mark.parametrize("bad", ["", "eb@", 3])
def test_bad_names(bad):
    with pytest.raises(ParameterError, match="name"):
        make(bad)


def test_register_rejects_bad_entry_points():
    with pytest.raises(ParameterError, match="entry_point"):
        register("toy-x", "no_colon_here")
    with pytest.raises(ParameterError, match="name"):
        register("toy-x@2", Gain)


def test_broken_lazy_entry_reports_module_when_used(toy_names):
    toy_names.append("toy-broken")
    register("toy-broken", "not_a_module_xyz:Thing")
    assert "toy-broken" in available()  # listing works without importing
    with pytest.raises(PluginError, match="not_a_module_xyz"):
        make("toy-broken")
    rows = {r["name"]: r for r in describe()}
    assert rows["toy-broken"]["summary"].startswith("ERROR:")
    assert rows["passthrough"]["version"] == "1"
    assert rows["passthrough"]["source"] == "scenesim"
    assert rows["das"]["tags"].needs_geometry


def test_with_geometry():
    pt = make("passthrough")
    assert with_geometry(pt, spacing_m=0.05) is pt
    das = with_geometry(make("das"), spacing_m=0.05, c_mps=340.0)
    assert (das.params.spacing_m, das.params.c_mps) == (0.05, 340.0)
    geo = with_geometry(SumGeo(), spacing_m=0.03)
    assert geo.params.spacing_m == 0.03 and geo.params.c_mps == 343.0


@pytest.mark.parametrize("name", ["eb-robust", "eb-robust-ss"])
def test_todays_robust_systems_stay_reachable_under_their_versioned_names(name):
    # contract.md: the held-out targets compare new systems against eb-robust@1 / eb-robust-ss@1, so those
    # names must resolve to the classes and defaults of version 1 even once a later version is registered.
    frozen = make(f"{name}@1")
    assert (frozen.name, frozen.version) == (name, "1")
    assert frozen.params == type(frozen).Params()  # version 1's own defaults


def test_a_parameter_of_a_system_without_parameters_says_it_has_none():
    from enhancers.core.base import unknown_parameter

    with pytest.raises(ParameterError, match=r"x=1 is invalid: expected no parameter: passthrough has none"):
        make("passthrough", x=1)
    with pytest.raises(ParameterError, match=r"alpah=1 is invalid: expected a parameter of ss: one of alpha, "):
        make("ss", alpah=1)
    assert "one of ." not in str(unknown_parameter("x", 1, ()))
