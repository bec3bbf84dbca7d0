"""One-dimensional and Rayleigh-wave oracles for the layer compliance (SPEC sections 5 and 8).

These closed forms are written literally (no rearrangement) so that they are independent checks of
:mod:`tyreroad.layer`:

* k = 0 (uniform pressure): the layer is a constrained rod bonded to a rigid base,
  H(0, w) = tan(w h / c_p) / (rho c_p w), c_p = sqrt(M / rho) (complex for a damped material);
* static, k -> 0: H = h / M;
* the Rayleigh speed ratio c_R / c_s(nu), the root in (0, 1) of the Rayleigh equation
  (2 - xi^2)^2 = 4 sqrt(1 - xi^2) sqrt(1 - xi^2 c_s^2 / c_p^2), xi = c / c_s.

References
----------
Graff (1975), Wave Motion in Elastic Solids, Oxford University Press, sections 2.1 (rods) and 6.3 (Rayleigh).
Rayleigh (1885), Proc. Lond. Math. Soc. s1-17, 4. doi:10.1112/plms/s1-17.1.4
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq

__all__ = ["pwave_modulus", "layer1d_compliance", "layer1d_static_compliance", "rayleigh_speed_ratio"]


def pwave_modulus(modulus, poisson):
    """Constrained (P-wave) modulus M = E (1 - nu) / ((1 + nu)(1 - 2 nu)) [Pa].

    Parameters
    ----------
    modulus : array_like
        Young's modulus E [Pa] (real or complex).
    poisson : float
        Poisson's ratio nu [-].
    """
    nu = float(poisson)
    return np.asarray(modulus) * (1.0 - nu) / ((1.0 + nu) * (1.0 - 2.0 * nu))


def layer1d_static_compliance(modulus, poisson, thickness):
    """Static compliance of the layer for a uniform pressure (k -> 0): h / M [m/Pa].

    Parameters
    ----------
    modulus : array_like
        Young's modulus E [Pa].
    poisson : float
        Poisson's ratio [-].
    thickness : float
        Layer thickness h [m].
    """
    return float(thickness) / pwave_modulus(modulus, poisson)


def layer1d_compliance(omega, modulus, poisson, density, thickness):
    """Compliance of the layer under uniform pressure (k = 0): tan(w h / c_p) / (rho c_p w) [m/Pa].

    u(z) = A sin(w (h - z) / c_p) satisfies u(h) = 0 and M u'' + rho w^2 u = 0; M u'(0) = -p gives the
    surface displacement above. The value at w = 0 is its limit h / M.

    Parameters
    ----------
    omega : array_like
        Angular frequency [rad/s], >= 0.
    modulus : array_like
        Complex Young's modulus E(w) [Pa], broadcastable with ``omega``.
    poisson : float
        Poisson's ratio [-].
    density : float
        Density [kg/m^3].
    thickness : float
        Layer thickness h [m].

    Returns
    -------
    numpy.ndarray of complex
        H(k = 0, w) [m/Pa].
    """
    omega = np.asarray(omega, dtype=float)
    m = pwave_modulus(np.asarray(modulus, dtype=complex), poisson)
    omega, m = np.broadcast_arrays(omega, m)
    c_p = np.sqrt(m / float(density))
    w = np.where(omega > 0, omega, 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        dyn = np.tan(w * float(thickness) / c_p) / (float(density) * c_p * w)
    return np.where(omega > 0, dyn, float(thickness) / m)


def rayleigh_speed_ratio(poisson):
    """Rayleigh wave speed over shear wave speed, c_R / c_s, for Poisson's ratio nu.

    Root xi in (0, 1) of (2 - xi^2)^2 - 4 sqrt(1 - xi^2) sqrt(1 - xi^2 (1 - 2 nu) / (2 (1 - nu))) = 0,
    solved with Brent's method to 1e-15.

    Parameters
    ----------
    poisson : float
        Poisson's ratio nu [-], 0 <= nu < 0.5 (nu = 0.5 also allowed: incompressible).

    Returns
    -------
    float
        c_R / c_s [-] (0.9194 at nu = 0.25, 0.9541 at nu = 0.49, 0.9553 at nu = 0.5).

    References
    ----------
    Rayleigh (1885), Proc. Lond. Math. Soc. s1-17, 4. doi:10.1112/plms/s1-17.1.4
    """
    nu = float(poisson)
    if not (-1.0 < nu <= 0.5):
        raise ValueError(f"rayleigh_speed_ratio: poisson must lie in (-1, 0.5], got {poisson!r}")
    s2 = (1.0 - 2.0 * nu) / (2.0 * (1.0 - nu))  # c_s^2 / c_p^2

    def rayleigh(xi):
        x2 = xi * xi
        return (2.0 - x2) ** 2 - 4.0 * np.sqrt(1.0 - x2) * np.sqrt(1.0 - x2 * s2)

    # the function is 0 at xi = 0 (trivial root) and positive at xi = 1; it is negative just above 0
    return float(brentq(rayleigh, 0.5, 1.0, xtol=1e-15, rtol=4 * np.finfo(float).eps))
