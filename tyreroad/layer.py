"""Compliance of a visco-elastic layer bonded to a rigid base (SPEC section 5)."""

from __future__ import annotations

import numpy as np

__all__ = ["static_layer_factor"]


def static_layer_factor(x, poisson):
    """Static layer factor L(kh) of a layer bonded to a rigid base.

    H0(k) = 2(1 - nu^2) / (E k) * L(k h) is the static surface compliance of the layer; L -> 1
    for kh -> inf (half-space) and L ~ kh (1 - 2 nu) / (2 (1 - nu)^2) for kh -> 0 (so H0 -> h/M).

    Evaluated in a rearranged form (numerator and denominator divided by cosh 2x, and the series of
    sinh(2x) - 2x for small x) so that it neither overflows for large x nor loses precision for
    small x or nu -> 0.5.

    Parameters
    ----------
    x : array_like
        Dimensionless wavenumber k h [-], x >= 0.
    poisson : float
        Poisson's ratio nu [-].

    Returns
    -------
    numpy.ndarray
        L(x) [-].

    References
    ----------
    Hayes, Keer, Herrmann & Mockros (1972), J. Mech. Phys. Solids 20, 355.
    doi:10.1016/0022-5096(72)90013-9
    """
    x = np.asarray(x, dtype=float)
    nu = float(poisson)
    if np.any(x < 0):
        raise ValueError("static_layer_factor: x = k h must be >= 0")
    y = 2.0 * x
    a = 3.0 - 4.0 * nu
    # (3-4nu) sinh y - y = (sinh y - y) + (2 - 4nu) sinh y, with sinh y - y from its series for small y
    small = y < 0.5
    ys = np.where(small, y, 0.0)
    series = ys**3 / 6 * (1 + ys**2 / 20 * (1 + ys**2 / 42 * (1 + ys**2 / 72 * (1 + ys**2 / 110 * (1 + ys**2 / 156)))))
    with np.errstate(over="ignore", invalid="ignore"):
        sech = np.where(y < 700, 1.0 / np.cosh(np.minimum(y, 700.0)), 0.0)
        tanh = np.tanh(y)
        sinh_minus_y_over_cosh = np.where(small, series * sech, tanh - y * sech)
        num = sinh_minus_y_over_cosh + (2.0 - 4.0 * nu) * tanh
        den = a + (y**2 / 2.0 + 5.0 - 12.0 * nu + 8.0 * nu**2) * sech
    return num / den
