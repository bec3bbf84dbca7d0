"""Argument checks shared by the numerical modules: one wording for every "expected ..., got ..." error.

Every public function of tyreroad validates its input before any work starts, and names the
argument (or the config key path, e.g. ``solver.tolerance``) in the message. These helpers keep
that wording and the bool-is-not-a-number rule in one place.
"""

from __future__ import annotations

import math
import numbers
from typing import Any

import numpy as np

__all__ = ["real", "integer", "poisson_ratio", "finite_array", "nonnegative_array"]

_YAML_HINT = " (YAML 1.1 reads a mantissa-exponent without sign, e.g. 1.0e5, as text: write 1.0e+5)"


def real(name: str, value: Any, *, positive: bool = False, nonnegative: bool = False, finite: bool = True) -> float:
    """``value`` as a float, or a ValueError naming ``name``.

    Parameters
    ----------
    name : str
        Argument name or config key path used in the message.
    value : Any
        A real number (bool is refused: ``True`` is not a modulus).
    positive, nonnegative : bool
        Require > 0 or >= 0.
    finite : bool
        Refuse inf and NaN (default).
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        hint = _YAML_HINT if isinstance(value, str) else ""
        raise ValueError(f"{name}: expected a number, got {value!r}{hint}")
    x = float(value)
    if math.isnan(x) or (finite and not math.isfinite(x)):
        raise ValueError(f"{name}: expected a finite number, got {value!r}")
    if positive and not x > 0:
        raise ValueError(f"{name}: expected a finite number > 0, got {value!r}")
    if nonnegative and not x >= 0:
        raise ValueError(f"{name}: expected a finite number >= 0, got {value!r}")
    return x


def integer(name: str, value: Any, minimum: int = 1) -> int:
    """``value`` as an int >= ``minimum`` (a float with an integral value is accepted)."""
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < minimum:
        raise ValueError(f"{name}: expected an integer >= {minimum}, got {value!r}")
    return int(value)


def poisson_ratio(value: Any, name: str = "poisson", *, allow_zero: bool = True, allow_half: bool = False) -> float:
    """Poisson's ratio in [0, 0.5) (bounds selectable) [1]."""
    nu = real(name, value)
    low_ok = nu >= 0.0 if allow_zero else nu > 0.0
    high_ok = nu <= 0.5 if allow_half else nu < 0.5
    if not (low_ok and high_ok):
        interval = ("[" if allow_zero else "(") + "0, 0.5" + ("]" if allow_half else ")")
        raise ValueError(f"{name}: expected a Poisson ratio in {interval}, got {value!r}")
    return nu


def finite_array(name: str, value: Any, ndim: int | None = None) -> np.ndarray:
    """``value`` as a float array with only finite entries (and ``ndim`` dimensions if given)."""
    arr = np.asarray(value, dtype=float)
    if ndim is not None and arr.ndim != ndim:
        raise ValueError(f"{name}: expected a {ndim}-D array, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: contains NaN or infinite values")
    return arr


def nonnegative_array(name: str, value: Any) -> np.ndarray:
    """``value`` as a float array, finite and >= 0 everywhere."""
    arr = np.asarray(value, dtype=float)
    if np.any(~np.isfinite(arr)) or np.any(arr < 0):
        raise ValueError(f"{name}: expected finite values >= 0")
    return arr


def whole_multiple(name: str, value: Any, step: float, *, allow_zero: bool = False, rtol: float = 1e-9) -> int:
    """``value`` [m] as a whole number of ``step`` [m] (e.g. elements of a tread pattern), or a ValueError naming
    ``name``, the value and what was expected (>= 1 step, or >= 0 with ``allow_zero``)."""
    v = float(value)
    n = round(v / step) if math.isfinite(v) else 0
    if not math.isfinite(v) or abs(n * step - v) > rtol * max(abs(v), step) or n < (0 if allow_zero else 1):
        what = "a non-negative" if allow_zero else "a positive"
        raise ValueError(f"{name} = {value!r} m: expected {what} whole multiple of the element size {step:g} m")
    return int(n)
