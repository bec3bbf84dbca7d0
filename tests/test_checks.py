"""Tests of tyreroad.checks: what each argument check accepts, what it refuses, and that the error names
the argument (config key path) and the offending value."""

from __future__ import annotations

import fractions
import math
import re

import numpy as np
import pytest

from tyreroad import checks


def refused(func, *args, match: str, **kwargs) -> str:
    """Call ``func`` expecting a ValueError whose text matches ``match``; return the text."""
    with pytest.raises(ValueError, match=match) as err:
        func(*args, **kwargs)
    return str(err.value)


# --------------------------------------------------------------------------------------------
# real
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "value, expected",
    [
        (2, 2.0),
        (-3.25, -3.25),
        (0.0, 0.0),
        (1e-300, 1e-300),
        (np.float64(2.5), 2.5),
        (np.float32(0.5), 0.5),
        (np.int64(-7), -7.0),
        (np.uint8(200), 200.0),
        (fractions.Fraction(3, 4), 0.75),
    ],
)
def test_real_accepts_python_and_numpy_numbers(value, expected):
    x = checks.real("solver.tolerance", value)
    assert type(x) is float
    assert x == expected


@pytest.mark.parametrize("value", [True, False, np.True_, np.False_])
def test_real_refuses_bool(value):
    """True is not a modulus, whether it is Python's bool or numpy's."""
    text = refused(checks.real, "materials.tread.modulus", value, match="expected a number")
    assert text == f"materials.tread.modulus: expected a number, got {value!r}"


@pytest.mark.parametrize("value", [None, [1.0], (1.0,), {"a": 1}, 1 + 2j, np.complex128(1.0)])
def test_real_refuses_non_numbers(value):
    text = refused(checks.real, "greens.sample_rate", value, match="expected a number")
    assert text == f"greens.sample_rate: expected a number, got {value!r}"


def test_real_refuses_text_with_the_yaml_hint():
    text = refused(checks.real, "materials.tread.e0", "1.0e5", match="expected a number")
    assert text.startswith("materials.tread.e0: expected a number, got '1.0e5'")
    assert "YAML 1.1" in text and "1.0e+5" in text


@pytest.mark.parametrize("value", [math.nan, np.float64(np.nan), np.float32(np.nan)])
@pytest.mark.parametrize("finite", [True, False])
def test_real_refuses_nan_even_when_infinity_is_allowed(value, finite):
    text = refused(checks.real, "x.y", value, finite=finite, match="expected a finite number")
    assert text == f"x.y: expected a finite number, got {value!r}"


@pytest.mark.parametrize("value", [math.inf, -math.inf, np.float32(np.inf)])
def test_real_infinity_only_when_allowed(value):
    refused(checks.real, "d_max", value, match=re.escape(f"d_max: expected a finite number, got {value!r}"))
    assert checks.real("d_max", value, finite=False) == float(value)


@pytest.mark.parametrize("value", [0.0, -0.0, -1e-300, -5, -math.inf])
def test_real_positive(value):
    text = refused(checks.real, "layer.thickness", value, positive=True, finite=False, match="> 0")
    assert text == f"layer.thickness: expected a finite number > 0, got {value!r}"


def test_real_positive_and_nonnegative_accept_their_bounds():
    assert checks.real("h", 1e-300, positive=True) == 1e-300
    assert checks.real("h", 0.0, nonnegative=True) == 0.0
    assert checks.real("h", -0.0, nonnegative=True) == 0.0  # -0.0 >= 0
    assert checks.real("h", math.inf, positive=True, finite=False) == math.inf


@pytest.mark.parametrize("value", [-1e-300, -2, np.float64(-0.5)])
def test_real_nonnegative(value):
    text = refused(checks.real, "loading.start", value, nonnegative=True, match=">= 0")
    assert text == f"loading.start: expected a finite number >= 0, got {value!r}"


# --------------------------------------------------------------------------------------------
# integer
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "value, expected",
    [(1, 1), (256, 256), (np.int64(5), 5), (np.uint16(7), 7), (4.0, 4), (np.float64(12.0), 12), (1e6, 1_000_000)],
)
def test_integer_accepts_integers_and_integral_floats(value, expected):
    n = checks.integer("greens.n_lags", value)
    assert type(n) is int
    assert n == expected


@pytest.mark.parametrize("value", [True, False, np.True_, 4.5, 1e-3, math.nan, math.inf, "5", None, 2 + 0j, [3]])
def test_integer_refuses_non_integers(value):
    text = refused(checks.integer, "greens.n_lags", value, match="expected an integer")
    assert text == f"greens.n_lags: expected an integer >= 1, got {value!r}"


def test_integer_minimum():
    assert checks.integer("threads", 0, minimum=0) == 0
    assert checks.integer("offset", -3, minimum=-3) == -3
    assert refused(checks.integer, "threads", 0, match=">= 1") == "threads: expected an integer >= 1, got 0"
    assert refused(checks.integer, "n", 4, minimum=5, match=">= 5") == "n: expected an integer >= 5, got 4"
    assert refused(checks.integer, "n", -1.0, minimum=0, match=">= 0") == "n: expected an integer >= 0, got -1"


# --------------------------------------------------------------------------------------------
# poisson_ratio
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("value", [0, 0.0, 0.3, 0.49, 0.4999, np.float64(0.25)])
def test_poisson_ratio_accepts_the_default_interval(value):
    nu = checks.poisson_ratio(value)
    assert type(nu) is float
    assert nu == float(value)


@pytest.mark.parametrize(
    "value, kwargs, interval",
    [
        (0.5, {}, "[0, 0.5)"),
        (-0.01, {}, "[0, 0.5)"),
        (0.0, {"allow_zero": False}, "(0, 0.5)"),
        (0.5, {"allow_zero": False}, "(0, 0.5)"),
        (0.5000001, {"allow_half": True}, "[0, 0.5]"),
        (-1e-12, {"allow_half": True}, "[0, 0.5]"),
        (0.0, {"allow_zero": False, "allow_half": True}, "(0, 0.5]"),
    ],
)
def test_poisson_ratio_refuses_outside_its_interval(value, kwargs, interval):
    text = refused(checks.poisson_ratio, value, "materials.tread.poisson", match="Poisson ratio", **kwargs)
    assert text == f"materials.tread.poisson: expected a Poisson ratio in {interval}, got {value!r}"


def test_poisson_ratio_bounds_when_selected():
    assert checks.poisson_ratio(0.5, allow_half=True) == 0.5
    assert checks.poisson_ratio(1e-9, allow_zero=False) == 1e-9


def test_poisson_ratio_refuses_non_numbers_with_the_default_name():
    assert refused(checks.poisson_ratio, True, match="number") == "poisson: expected a number, got True"
    assert refused(checks.poisson_ratio, math.nan, match="finite") == "poisson: expected a finite number, got nan"
    assert refused(checks.poisson_ratio, math.inf, match="finite") == "poisson: expected a finite number, got inf"


# --------------------------------------------------------------------------------------------
# finite_array and nonnegative_array
# --------------------------------------------------------------------------------------------
def test_finite_array_converts_to_float():
    arr = checks.finite_array("z1", [[1, 2], [3, -4]])
    assert arr.dtype == np.float64
    np.testing.assert_array_equal(arr, [[1.0, 2.0], [3.0, -4.0]])
    assert checks.finite_array("z1", np.arange(6, dtype=np.int32).reshape(2, 3), ndim=2).dtype == np.float64
    assert checks.finite_array("g", 2.5, ndim=0) == 2.5
    assert checks.finite_array("g", np.zeros((0, 3)), ndim=2).shape == (0, 3)


@pytest.mark.parametrize("value, ndim, shape", [([1.0, 2.0, 3.0], 2, "(3,)"), (np.zeros((2, 3)), 1, "(2, 3)"),
                                                (1.0, 1, "()"), (np.zeros((1, 1, 1)), 2, "(1, 1, 1)")])
def test_finite_array_ndim(value, ndim, shape):
    text = refused(checks.finite_array, "surface.height", value, ndim=ndim, match="-D array")
    assert text == f"surface.height: expected a {ndim}-D array, got shape {shape}"


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_finite_array_refuses_nan_and_inf(bad):
    value = np.ones((3, 4))
    value[2, 1] = bad
    text = refused(checks.finite_array, "surface.height", value, match="NaN or infinite")
    assert text == "surface.height: contains NaN or infinite values"
    # the shape is checked first, and an ndim that fits does not hide the bad value
    refused(checks.finite_array, "surface.height", value, ndim=1, match="expected a 1-D array")
    refused(checks.finite_array, "surface.height", value, ndim=2, match="NaN or infinite")


def test_nonnegative_array():
    arr = checks.nonnegative_array("springs.stiffness", [0, 1e8, -0.0])
    assert arr.dtype == np.float64
    np.testing.assert_array_equal(arr, [0.0, 1e8, 0.0])
    assert checks.nonnegative_array("k", np.empty(0)).size == 0
    for bad in (-1e-300, np.nan, np.inf, -np.inf):
        value = np.array([[1.0, 2.0], [3.0, bad]])
        text = refused(checks.nonnegative_array, "springs.stiffness", value, match="expected finite values >= 0")
        assert text == "springs.stiffness: expected finite values >= 0"
