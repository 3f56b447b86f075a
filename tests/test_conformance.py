"""Every registered enhancer x every conformance check (enhancers.testing.CHECKS).

The parametrization is built from ``enhancers.available()`` at collection time without
importing any algorithm module, so a new registration (built-in or plugin) is checked
automatically.  Expected failures an enhancer class declares in
``conformance_expected_failures`` (with a reason) become xfail, not skips.
"""

from __future__ import annotations

import pytest

from enhancers.beam.baselines import Passthrough
from enhancers.core.registry import EnhancerNotInstalled, available, make
from enhancers.testing import (
    CHECKS,
    ConformanceError,
    check_enhancer,
    expected_failures_of,
    parametrize_with_checks,
)
from scenesim.errors import ParameterError

NAMES = [n for n in available() if "[" not in n]  # "name[dist]" rows are refused plugins


@pytest.fixture(scope="module")
def instances():
    """One default instance per name, made once per module (made lazily, per test)."""
    return {}


@pytest.mark.parametrize("check_name", list(CHECKS))
@pytest.mark.parametrize("name", NAMES)
def test_conformance(name, check_name, instances):
    if name not in instances:
        try:
            instances[name] = make(name)
        except EnhancerNotInstalled as exc:  # a peer behind an optional extra
            pytest.skip(str(exc))
    enhancer = instances[name]
    expected = expected_failures_of(enhancer)
    try:
        CHECKS[check_name](enhancer)
    except ConformanceError:
        if check_name in expected:
            pytest.xfail(expected[check_name])
        raise
    if check_name in expected:  # strict: a fixed enhancer must drop its declaration
        pytest.fail(f"[XPASS(strict)] {name}: {check_name} passes but is declared an expected failure")


def test_builtins_are_all_parametrized():
    assert {"eb", "ss", "eb-ss", "ss-ms2001", "cardioid", "hypercardioid", "passthrough", "das"} <= set(NAMES)


class Unregistered(Passthrough):
    """Conforms in every way but is not registered."""

    name = "toy-unregistered"


class DeclaresFailure(Unregistered):
    conformance_expected_failures = {
        "registered": "a test class, deliberately not registered",
        "pickle": "declared but passes: reported as xpass",
    }


def test_check_enhancer_reports_expected_failures():
    report = check_enhancer(Unregistered, expected_failures={"registered": "a test class, deliberately not registered"})
    assert report["registered"] == "xfail: a test class, deliberately not registered"
    assert {v for k, v in report.items() if k != "registered"} == {"passed"}


def test_expected_failure_that_passes_is_an_error():
    # Strict xfail (issue 11): 'pickle' passes, so declaring it as an expected failure fails.
    with pytest.raises(ConformanceError, match=r"pickle: passes but is declared an expected failure"):
        check_enhancer(DeclaresFailure)


def test_check_enhancer_raises_with_clear_message():
    with pytest.raises(ConformanceError, match=r"registered: .*toy-unregistered@1 is not registered"):
        check_enhancer(Unregistered)
    # The same declaration works per call.
    report = check_enhancer(Unregistered(), expected_failures={"registered": "test"})
    assert report["registered"] == "xfail: test"


def test_unknown_expected_failure_name_is_rejected():
    with pytest.raises(ParameterError, match="expected_failures"):
        check_enhancer(Unregistered, expected_failures={"no_such_check": "typo"})


@parametrize_with_checks([Unregistered()], expected_failures={"registered": "not registered"})
def test_parametrize_with_checks_api(enhancer, check):
    check(enhancer)
