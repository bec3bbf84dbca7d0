"""Love's solution: uniform normal pressure on a rectangle of an elastic half-space.

The surface displacement of a homogeneous, isotropic elastic half-space under a normal point force
F is Boussinesq's w = (1 - nu^2) F / (pi E r). Integrating it over a rectangle carrying the uniform
pressure q gives Love's closed form (Love 1929; Johnson 1985, section 3.2),

    w(x, y) = (1 - nu^2) q / (pi E) * sum over corners (+/-) Phi(u, v),
    Phi(u, v) = u asinh(v / |u|) + v asinh(u / |v|),

with (u, v) the position of the field point relative to each corner of the loaded rectangle.
``Phi`` is the integral of 1/r over the rectangle between the field point's projection and one corner;
it is odd in u and in v, which gives the signs of the corner sum.

Anchors for a c x c square: centre w = 4 asinh(1)/pi = 1.12220 (1 - nu^2) q c / E, corner 0.56110,
mean over the square 0.94640 (the mean follows from the closed-form fourfold integral of 1/r over the
square, see :func:`rectangle_mean_displacement`).

Everything is linear in 1/E, so a complex modulus E(omega) may be passed: that is how the
element Green's function uses this module for the static half-space part of a visco-elastic layer.

References
----------
Love, A. E. H. (1929). The stress produced in a semi-infinite solid by pressure on part of the boundary.
Phil. Trans. R. Soc. A 228, 377-420. doi:10.1098/rsta.1929.0009
Johnson, K. L. (1985). Contact Mechanics. Cambridge University Press. doi:10.1017/CBO9781139171731
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "CENTRE_FACTOR",
    "CORNER_FACTOR",
    "MEAN_FACTOR",
    "rectangle_potential",
    "rectangle_displacement",
    "rectangle_mean_displacement",
    "point_load_displacement",
]

#: w at the centre of a uniformly loaded c x c square, in units of (1 - nu^2) q c / E: 4 asinh(1) / pi.
CENTRE_FACTOR = 4.0 * np.arcsinh(1.0) / np.pi
#: w at a corner of the square, same units: 2 asinh(1) / pi.
CORNER_FACTOR = 2.0 * np.arcsinh(1.0) / np.pi
#: mean w over the square, same units: [4 asinh(1) + 4 (1 - sqrt 2) / 3] / pi.
MEAN_FACTOR = (4.0 * np.arcsinh(1.0) + 4.0 * (1.0 - np.sqrt(2.0)) / 3.0) / np.pi


def _phi(u, v):
    """Integral of 1/sqrt(s^2 + t^2) over 0..u, 0..v (odd in u and in v) [m]."""
    au = np.abs(u)
    av = np.abs(v)
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = np.where(au > 0, u * np.arcsinh(v / np.where(au > 0, au, 1.0)), 0.0)
        t2 = np.where(av > 0, v * np.arcsinh(u / np.where(av > 0, av, 1.0)), 0.0)
    return t1 + t2


def rectangle_potential(x, y, a, b):
    """Integral of 1/r over an a x b rectangle centred at the origin, seen from (x, y) [m].

    Parameters
    ----------
    x, y : array_like
        Field point relative to the rectangle's centre [m] (broadcast together).
    a, b : float
        Side lengths of the rectangle along x and y [m].

    Returns
    -------
    numpy.ndarray
        The integral of 1/sqrt((x - xi)^2 + (y - eta)^2) over the rectangle [m].
    """
    a = float(a)
    b = float(b)
    if not (a > 0 and b > 0):
        raise ValueError(f"rectangle sides must be > 0, got a={a}, b={b}")
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    xp, xm = x + a / 2, x - a / 2
    yp, ym = y + b / 2, y - b / 2
    return _phi(xp, yp) - _phi(xm, yp) - _phi(xp, ym) + _phi(xm, ym)


def rectangle_displacement(x, y, a, b, pressure, modulus, poisson):
    """Normal surface displacement of a half-space under uniform pressure on an a x b rectangle.

    Parameters
    ----------
    x, y : array_like
        Field point relative to the rectangle's centre [m].
    a, b : float
        Rectangle sides along x and y [m].
    pressure : float
        Uniform normal pressure q [Pa] (positive pushes into the half-space).
    modulus : float or complex
        Young's modulus E [Pa]; complex E(omega) gives the correspondence-principle solution.
    poisson : float
        Poisson's ratio nu [-].

    Returns
    -------
    numpy.ndarray
        Displacement w [m] into the half-space (complex when ``modulus`` is).

    References
    ----------
    Love (1929), doi:10.1098/rsta.1929.0009
    """
    nu = float(poisson)
    if not -1.0 < nu <= 0.5:
        raise ValueError(f"poisson must be in (-1, 0.5], got {poisson}")
    return (1.0 - nu**2) * pressure / (np.pi * modulus) * rectangle_potential(x, y, a, b)


def rectangle_mean_displacement(a, b, pressure, modulus, poisson):
    """Mean normal displacement over a uniformly loaded a x b rectangle of a half-space.

    Uses the closed form of the fourfold integral of 1/r over the rectangle,
    4 int_0^a int_0^b (a - u)(b - v) / sqrt(u^2 + v^2) du dv
    = 2 a b^2 asinh(a/b) + 2 a^2 b asinh(b/a) + (2/3)(a^3 + b^3 - (a^2 + b^2)^(3/2)).

    Parameters
    ----------
    a, b : float
        Rectangle sides [m].
    pressure : float
        Uniform pressure q [Pa].
    modulus : float or complex
        Young's modulus E [Pa].
    poisson : float
        Poisson's ratio nu [-].

    Returns
    -------
    float or complex
        Mean displacement [m].
    """
    a = float(a)
    b = float(b)
    if not (a > 0 and b > 0):
        raise ValueError(f"rectangle sides must be > 0, got a={a}, b={b}")
    d = np.hypot(a, b)
    integral = (
        2 * a * b * b * np.arcsinh(a / b) + 2 * a * a * b * np.arcsinh(b / a) + 2.0 / 3.0 * (a**3 + b**3 - d**3)
    )
    nu = float(poisson)
    return (1.0 - nu**2) * pressure / (np.pi * modulus) * integral / (a * b)


def point_load_displacement(r, force, modulus, poisson):
    """Boussinesq: surface displacement at distance r from a normal point force [m].

    Parameters
    ----------
    r : array_like
        Distance from the load [m], > 0.
    force : float
        Normal force F [N].
    modulus : float or complex
        Young's modulus E [Pa].
    poisson : float
        Poisson's ratio nu [-].

    Returns
    -------
    numpy.ndarray
        w = (1 - nu^2) F / (pi E r) [m].
    """
    r = np.asarray(r, dtype=float)
    if np.any(r <= 0):
        raise ValueError("point_load_displacement: r must be > 0")
    nu = float(poisson)
    return (1.0 - nu**2) * force / (np.pi * modulus * r)
