"""Creep compliance of the fractional Kelvin-Voigt solid (the oracle of the long-memory tests, SPEC 9).

For E(omega) = E0 + E1 (i omega / omega1)^alpha the creep compliance is

    J(t) = [1 - E_alpha(-(E0 / E1) (omega1 t)^alpha)] / E0,

E_alpha the Mittag-Leffler function. For 0 < alpha < 1, E_alpha(-x) is completely monotone and

    E_alpha(-lambda t^alpha) = (sin(alpha pi) / pi) int_0^inf exp(-r s) r^(alpha - 1)
                               / (r^(2 alpha) + 2 r^alpha cos(alpha pi) + 1) dr,   s = lambda^(1/alpha) t,

which is evaluated here by adaptive quadrature (Gorenflo, Kilbas, Mainardi & Rogosin 2014, eq. 3.7.44).
:func:`creep_by_inversion` is an independent check: J(t) = (2 / pi) int_0^inf Re[1 / E(omega)] sin(omega t)
/ omega d omega (causality of the creep rate), by QUADPACK's Fourier-integral rule.

References
----------
Gorenflo, R., Kilbas, A. A., Mainardi, F., & Rogosin, S. V. (2014). Mittag-Leffler Functions, Related
Topics and Applications. Springer. doi:10.1007/978-3-662-43930-2
Bagley, R. L., & Torvik, P. J. (1983). J. Rheol. 27, 201-210. doi:10.1122/1.549724
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import quad

__all__ = ["mittag_leffler_neg", "fractional_kv_creep", "creep_by_inversion", "fractional_kv_relaxation"]


def mittag_leffler_neg(x: float, alpha: float) -> float:
    """E_alpha(-x) for x >= 0 and 0 < alpha < 1 [1].

    With u = r s the integral becomes (sin(alpha pi) / pi) / x * int_0^inf exp(-u) u^(alpha - 1)
    / (q^2 + 2 q cos(alpha pi) + 1) du, q = (u / s)^alpha: the integrable singularity u^(alpha - 1)
    is left to QUADPACK's algebraic weight on [0, min(1, s)], the rest is smooth.
    """
    if x == 0.0:
        return 1.0
    s = x ** (1.0 / alpha)
    c, sn = math.cos(alpha * math.pi), math.sin(alpha * math.pi)

    def smooth(u):
        q = (u / s) ** alpha
        return math.exp(-u) / (q * q + 2.0 * q * c + 1.0)

    a = min(1.0, s)
    head, _ = quad(smooth, 0.0, a, weight="alg", wvar=(alpha - 1.0, 0.0), epsabs=0.0, epsrel=1e-12, limit=200)
    # [a, 60] in log u (the denominator changes on the scale u ~ s, which may be tiny), then the rest
    body, _ = quad(lambda v: smooth(math.exp(v)) * math.exp(alpha * v), math.log(a), math.log(60.0),
                   epsabs=0.0, epsrel=1e-12, limit=400)
    rest, _ = quad(lambda u: smooth(u) * u ** (alpha - 1.0), 60.0, math.inf, epsabs=0.0, epsrel=1e-12, limit=200)
    total = head + body
    return sn / math.pi * (total + rest) / x


def fractional_kv_creep(t, E0: float, E1: float, alpha: float, f1: float) -> np.ndarray:
    """J(t) [1/Pa] of E(omega) = E0 + E1 (i omega / (2 pi f1))^alpha at times t [s] (>= 0)."""
    w1 = 2 * math.pi * f1
    t = np.atleast_1d(np.asarray(t, dtype=float))
    out = np.array([(1.0 - mittag_leffler_neg((E0 / E1) * (w1 * ti) ** alpha, alpha)) / E0 for ti in t])
    return out


def fractional_kv_relaxation(t, E0: float, E1: float, alpha: float, f1: float) -> np.ndarray:
    """E_rel(t) = E0 + E1 (omega1 t)^(-alpha) / Gamma(1 - alpha) [Pa] (t > 0)."""
    w1 = 2 * math.pi * f1
    t = np.asarray(t, dtype=float)
    return E0 + E1 * (w1 * t) ** (-alpha) / math.gamma(1.0 - alpha)


def creep_by_inversion(modulus, t: float) -> float:
    """J(t) = (2/pi) int_0^inf Re[1/E(omega)] sin(omega t) / omega d omega [1/Pa] (independent check).

    ``modulus(omega)`` gives the complex E [Pa] (exp(+i omega t)) at angular frequency omega [rad/s].
    """

    def f(w):
        if w == 0.0:
            return 0.0
        return float(np.real(1.0 / modulus(np.array([w]))[0])) / w

    # near omega = 0 the integrand ~ t Re J*(0): integrate [0, a] plainly, the rest with the sine weight
    a = 1.0 / t
    head, _ = quad(lambda w: f(w) * math.sin(w * t), 0.0, a, limit=200, epsabs=0.0, epsrel=1e-12)
    tail, _ = quad(f, a, math.inf, weight="sin", wvar=t, limlst=200, limit=400)
    return 2.0 / math.pi * (head + tail)
