r"""Compliance of a visco-elastic layer bonded to a rigid base (SPEC section 5).

Geometry and conventions: a homogeneous, isotropic, visco-elastic layer occupies 0 <= z <= h, z pointing
from the road into the tread; it is bonded to a rigid base at z = h (u = 0) and loaded at z = 0 by a normal
pressure p exp(i(k.x + w t)) without shear traction. Time convention exp(+i w t); the complex Young's modulus
E(w) has Im E >= 0 for w > 0, so the compliance has Im H <= 0 (passive layer). The response depends on |k|.

With mu = E / (2 (1 + nu)), M = E (1 - nu) / ((1 + nu)(1 - 2 nu)) (P-wave modulus),
eps_s = rho w^2 / mu, eps_p = rho w^2 / M, alpha = sqrt(k^2 - eps_p), beta = sqrt(k^2 - eps_s)
(Re >= 0) and Q = 2 k^2 - eps_s, the surface compliance H = u_z(0) / p is (SPEC 5)

    H = alpha eps_s (k^2 C_a S_b - alpha beta S_a C_b)
        / ( mu [alpha beta (Q^2 + 4 k^4) C_a C_b - k^2 (Q^2 + 4 alpha^2 beta^2) S_a S_b - 4 alpha beta k^2 Q] ),

S_a = sinh(alpha h), C_a = cosh(alpha h), likewise for beta. Evaluated literally this overflows for large kh
and is 0/0 as w -> 0 (the bracket in the numerator is O(eps), the denominator O(eps^2)).

Stable form used here
---------------------
All lengths are scaled by h: x = k h, a = alpha h, b = beta h, e_s = eps_s h^2, e_p = eps_p h^2 = r e_s with
the real constant r = mu / M = (1 - 2 nu) / (2 (1 - nu)). Let p = a b, y = a - b, t = exp(-(a + b)) (|t| <= 1).
Exact identities used:

* y = (e_s - e_p) / (a + b) = e_s (1 - r) / (a + b), so sinh(y) / e_s = shc(y) (1 - r) / (a + b) with
  shc(z) = sinh(z) / z (Taylor series for |z| < 0.1): the O(eps) smallness of y is carried analytically.
* P / e_s with P = a b - x^2:  (e_p - x^2 (1 + r)) / (a b + x^2)   if |e_s| <= x^2 (then |a b + x^2| >= x^2),
                               (a b - x^2) / e_s                  otherwise (no cancellation there).
* R = Q^2 - 4 k^2 alpha beta (the Rayleigh function), R h^4 / e_s = -4 x^2 (1 + P / e_s) + e_s, where
  1 + P / e_s = (a b + e_p - r x^2) / (a b + x^2) in the first regime.
* (Q - 2 alpha beta) h^2 / e_s = e_s (1 - r)^2 / (a + b)^2 + r,
  (Q^2 + 4 k^2 alpha beta) h^4 = (2 x^2 - e_s)^2 + 4 x^2 a b.

Writing C_a C_b, S_a S_b, C_a S_b, S_a C_b through cosh/sinh of (a + b) and y, the closed form becomes
H = alpha eps_s N / (mu D) with
D = (1/2)(p - k^2) R cosh(a+b) + (1/2)[k^2 (Q - 2p)^2 + p eps_s^2] + (p + k^2)(Q^2 + 4 p k^2) sinh^2(y/2),
N = -(1/2)[(p - k^2) sinh(a+b) + (p + k^2) sinh(y)] (dimensional p = alpha beta here).
Multiplying N and D by 2 t / eps_s and 2 t / eps_s^2 (h-scaled) gives the form actually evaluated:

    n = -(1/2) [ (P/e_s) (1 - t^2) + 2 (x^2 + p) (t sinh(y) / e_s) ]
    d = (1/2) (P/e_s) (R h^4/e_s) (1 + t^2) + t [ x^2 ((Q - 2p) h^2/e_s)^2 + p ]
        + 2 (x^2 + p) (Q^2 + 4 p x^2) h^4 (t sinh^2(y/2) / e_s^2)
    H = h a n / (mu d),

with 1 - t^2 = -expm1(-2 (a + b)); t sinh(y) / e_s = t shc(y) (1 - r) / (a + b) and
t sinh^2(y/2) / e_s^2 = t [shc(y/2) (1 - r) / (2 (a + b))]^2 when |Re y| <= 2, and otherwise
t sinh(y) = (exp(-2b) - exp(-2a)) / 2, t sinh^2(y/2) = (exp(-2b) + exp(-2a)) / 4 - t / 2 (no overflow, and
no cancellation because |cosh y| >= cosh 2 there). Every quantity is finite at e_s = 0 (for k > 0), where the
form reduces exactly to the static result H0 = 2 (1 - nu^2) / (E k) L(kh); for kh -> inf (t -> 0) it reduces
to the half-space -alpha eps_s / (mu R); for k = 0 to -alpha tanh(alpha h) / (rho w^2) = tan(w h / c_p) /
(rho c_p w). The single point k = 0, w = 0 (a + b = 0) is set to its limit h / M.
The remaining cancellation is the physical one of the static numerator (3 - 4 nu) sinh 2x - 2x for small kh and
nu -> 1/2 (a loss of roughly 1 / (2 r) ulp): measured against an mpmath evaluation of the closed form above
(40 digits plus twice the digits the literal form cancels), the largest relative error is 2e-12 over
kh in [1e-3, 500], f in [1e-3 Hz, 25.6 kHz], nu <= 0.4999, and 2e-11 at nu = 0.49999.

Implementation: a numba kernel (``_compliance_kernel``, one complex scalar evaluation per point, parallel
over points) behind the validating :func:`compliance`; ``_compliance_numpy`` is the same form in plain numpy,
kept as the test reference for the kernel.

Branches: alpha, beta are principal square roots (Re >= 0). For a passive material Im(k^2 - eps) >= 0, so both
lie in the first quadrant; the layer compliance is even in alpha and in beta, so only the half-space depends
on the branch, and there the principal branch is the one that decays (or radiates, e^{-i|alpha|z}, for lossless
media) away from the surface. A zero imaginary part with negative sign is normalised so that a lossless
propagating wave gets Im alpha > 0.

References
----------
Hayes, Keer, Herrmann & Mockros (1972), J. Biomech. 5, 541-551. doi:10.1016/0021-9290(72)90010-3
Lamb (1904), Phil. Trans. R. Soc. A 203, 1 (half-space, Rayleigh pole). doi:10.1098/rsta.1904.0013
"""

from __future__ import annotations

import cmath
import logging
import math

import numpy as np
from numba import njit, prange

from . import checks

__all__ = [
    "static_layer_factor",
    "compliance",
    "laplace_compliance",
    "static_compliance",
    "halfspace_compliance",
    "backing_force_transfer",
    "backing_kernel",
    "backing_force",
]

logger = logging.getLogger(__name__)

# |z| below which sinh(z)/z is summed as a Taylor series (next term z^12/13! < 2e-22)
_SHC_SERIES_LIMIT = 0.1
# |Re(a - b)| above which t sinh(y) and t sinh^2(y/2) are formed from exp(-2a), exp(-2b)
_EXP_FORM_LIMIT = 2.0


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
    Hayes, Keer, Herrmann & Mockros (1972), J. Biomech. 5, 541-551.
    doi:10.1016/0021-9290(72)90010-3
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


def _modulus_array(modulus):
    e = np.asarray(modulus, dtype=complex)
    if np.any(~np.isfinite(e)) or np.any(e.real <= 0) or np.any(e.imag < 0):
        raise ValueError("modulus must be finite with Re E > 0 and Im E >= 0 (passive, exp(+i w t))")
    return e


def _branch_sqrt(z):
    """Principal square root with Re >= 0; a purely imaginary root is given Im >= 0."""
    s = np.sqrt(z)
    return np.where((s.real == 0.0) & (s.imag < 0.0), -s, s)


def _shc(z):
    """sinh(z) / z for complex z, with the Taylor series near 0."""
    z = np.asarray(z, dtype=complex)
    small = np.abs(z) < _SHC_SERIES_LIMIT
    zs = np.where(small, z, 0.0)
    z2 = zs * zs
    series = 1 + z2 / 6 * (1 + z2 / 20 * (1 + z2 / 42 * (1 + z2 / 72 * (1 + z2 / 110))))
    zb = np.where(small, 1.0, z)
    with np.errstate(over="ignore", invalid="ignore"):
        direct = np.sinh(zb) / zb
    return np.where(small, series, direct)


def _moduli(modulus, nu):
    """Shear modulus mu and P-wave modulus M for Young's modulus E and Poisson's ratio nu."""
    mu = modulus / (2.0 * (1.0 + nu))
    m = modulus * (1.0 - nu) / ((1.0 + nu) * (1.0 - 2.0 * nu))
    return mu, m


def _scaled_roots(x, e_s, r):
    """(x^2, a, b, near_static, P / e_s) of the stable form (module docstring), h-scaled: a = alpha h, b = beta h
    (principal roots), near_static = |e_s| <= x^2 (where P / e_s takes its cancellation-free form).

    x = k h [-] (> 0 where e_s = 0), e_s = rho (w h)^2 / mu [-] (complex), r = mu / M [-]; arrays broadcast.
    Shared by the rigid-base compliance and the two-port of :mod:`tyreroad.belt`.
    """
    x2 = x * x
    e_p = r * e_s
    a = _branch_sqrt(x2 - e_p)
    b = _branch_sqrt(x2 - e_s)
    ab = a * b
    near_static = np.abs(e_s) <= x2
    with np.errstate(divide="ignore", invalid="ignore"):
        es_far = np.where(near_static, 1.0, e_s)
        p_over_e = np.where(near_static, (e_p - x2 * (1.0 + r)) / (ab + x2), (ab - x2) / es_far)
    return x2, a, b, near_static, p_over_e


def _compliance_numpy(x, e_s, mu, r, h):
    """Plain-numpy evaluation of the stable form (reference for the numba kernel; same formulas).

    x = k h [-], e_s = rho (w h)^2 / mu [-] (complex), mu [Pa] (complex), r = mu / M [-], h [m];
    arrays already broadcast to one shape.
    """
    e_p = r * e_s
    origin = (x == 0.0) & (e_s == 0.0)
    # the single degenerate point (a + b = 0) is replaced by a harmless value and set to h/M at the end
    x = np.where(origin, 1.0, x)
    x2, a, b, near_static, p_over_e = _scaled_roots(x, e_s, r)
    ab = a * b
    apb = a + b
    with np.errstate(divide="ignore", invalid="ignore"):
        one_plus = np.where(near_static, (ab + e_p - r * x2) / (ab + x2), 1.0 + p_over_e)
    rayleigh = -4.0 * x2 * one_plus + e_s  # R h^4 / e_s
    q_minus_2p = e_s * (1.0 - r) ** 2 / apb**2 + r  # (Q - 2 alpha beta) h^2 / e_s
    q4 = (2.0 * x2 - e_s) ** 2 + 4.0 * x2 * ab  # (Q^2 + 4 k^2 alpha beta) h^4

    t = np.exp(-apb)
    one_minus_t2 = -np.expm1(-2.0 * apb)
    y = a - b
    big = np.abs(y.real) > _EXP_FORM_LIMIT
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        e2a = np.exp(-2.0 * a)
        e2b = np.exp(-2.0 * b)
        es_safe = np.where(big, e_s, 1.0)
        t_sinh = np.where(big, 0.5 * (e2b - e2a) / es_safe, t * _shc(np.where(big, 0.0, y)) * (1.0 - r) / apb)
        half = _shc(np.where(big, 0.0, 0.5 * y)) * (1.0 - r) / (2.0 * apb)
        t_sinh2 = np.where(big, (0.25 * (e2b + e2a) - 0.5 * t) / es_safe**2, t * half * half)

    n = -0.5 * (p_over_e * one_minus_t2 + 2.0 * (x2 + ab) * t_sinh)
    d = 0.5 * p_over_e * rayleigh * (1.0 + t * t) + t * (x2 * q_minus_2p**2 + ab) + 2.0 * (x2 + ab) * q4 * t_sinh2
    out = h * a * n / (mu * d)
    return np.where(origin, h * r / mu, out)


@njit(cache=True)
def _shc_scalar(z):
    if abs(z) < _SHC_SERIES_LIMIT:
        z2 = z * z
        return 1 + z2 / 6 * (1 + z2 / 20 * (1 + z2 / 42 * (1 + z2 / 72 * (1 + z2 / 110))))
    return cmath.sinh(z) / z


@njit(cache=True)
def _sqrt_scalar(z):
    s = cmath.sqrt(z)
    if s.real == 0.0 and s.imag < 0.0:
        return -s
    return s


@njit(cache=True)
def _expm1_scalar(z):
    # e^z - 1 = expm1(u) cos v - 2 sin^2(v/2) + i e^u sin v, accurate for small |z|
    u, v = z.real, z.imag
    sh = math.sin(0.5 * v)
    return complex(math.expm1(u) * math.cos(v) - 2.0 * sh * sh, math.exp(u) * math.sin(v))


@njit(cache=True, parallel=True)
def _compliance_kernel(x, e_s, mu, r, h, out):
    """Stable-form compliance for flat arrays x [-], e_s [-], mu [Pa]; writes H [m/Pa] into out."""
    for i in prange(x.size):
        xi = x[i]
        es = e_s[i]
        if xi == 0.0 and es == 0.0:
            out[i] = h * r / mu[i]
            continue
        x2 = xi * xi
        ep = r * es
        a = _sqrt_scalar(x2 - ep)
        b = _sqrt_scalar(x2 - es)
        ab = a * b
        apb = a + b
        if abs(es) <= x2:
            p_over_e = (ep - x2 * (1.0 + r)) / (ab + x2)
            one_plus = (ab + ep - r * x2) / (ab + x2)
        else:
            p_over_e = (ab - x2) / es
            one_plus = 1.0 + p_over_e
        rayleigh = -4.0 * x2 * one_plus + es
        q_minus_2p = es * (1.0 - r) ** 2 / (apb * apb) + r
        q4 = (2.0 * x2 - es) ** 2 + 4.0 * x2 * ab
        t = cmath.exp(-apb)
        one_minus_t2 = -_expm1_scalar(-2.0 * apb)
        y = a - b
        if abs(y.real) > _EXP_FORM_LIMIT:
            e2a = cmath.exp(-2.0 * a)
            e2b = cmath.exp(-2.0 * b)
            t_sinh = 0.5 * (e2b - e2a) / es
            t_sinh2 = (0.25 * (e2b + e2a) - 0.5 * t) / (es * es)
        else:
            t_sinh = t * _shc_scalar(y) * (1.0 - r) / apb
            half = _shc_scalar(0.5 * y) * (1.0 - r) / (2.0 * apb)
            t_sinh2 = t * half * half
        n = -0.5 * (p_over_e * one_minus_t2 + 2.0 * (x2 + ab) * t_sinh)
        d = 0.5 * p_over_e * rayleigh * (1.0 + t * t) + t * (x2 * q_minus_2p**2 + ab) + 2.0 * (x2 + ab) * q4 * t_sinh2
        out[i] = h * a * n / (mu[i] * d)


def compliance(k, omega, modulus, poisson, density, thickness):
    """Dynamic surface compliance H(k, w) = u_z(0) / p of a layer bonded to a rigid base.

    Normal pressure p at the free surface z = 0, no shear traction, u = 0 at z = h; 3-D, depends on |k|.
    Evaluated in the stable form of the module docstring (full precision for kh up to >= 500, nu up to
    0.4999, w from 0 to the Nyquist frequency). All array arguments broadcast together. The work runs in a
    numba kernel parallel over points (threads: ``numba.set_num_threads``); about 1 us per point per core.

    Parameters
    ----------
    k : array_like
        Wavenumber magnitude |k| [rad/m], >= 0.
    omega : array_like
        Angular frequency [rad/s], >= 0.
    modulus : array_like
        Complex Young's modulus E(w) [Pa] (Re > 0, Im >= 0), broadcastable with ``omega``.
    poisson : float
        Poisson's ratio nu [-], 0 < nu < 0.5.
    density : float
        Density rho [kg/m^3].
    thickness : float
        Layer thickness h [m].

    Returns
    -------
    numpy.ndarray of complex
        H [m/Pa]; Im H <= 0 for w > 0 and a passive modulus. H(0, 0) = h / M.

    References
    ----------
    Hayes, Keer, Herrmann & Mockros (1972), J. Biomech. 5, 541-551.
    doi:10.1016/0021-9290(72)90010-3
    """
    nu = checks.poisson_ratio(poisson, allow_zero=False)
    rho = checks.real("density", density, positive=True)
    h = checks.real("thickness", thickness, positive=True)
    k = checks.nonnegative_array("k", k)
    omega = checks.nonnegative_array("omega", omega)
    return _evaluate(k, omega, _modulus_array(modulus), nu, h, lambda w: rho * (w * h) ** 2)


def _evaluate(k, frequency, e, nu: float, h: float, inertia):
    """The stable-form compliance over broadcast k [rad/m], frequency and E [Pa] (numba kernel).

    ``inertia(frequency)`` is rho (omega h)^2 [Pa] on the broadcast frequencies (-rho (s h)^2 in the
    Laplace domain); e_s = inertia / mu [-].
    """
    k, frequency, e = np.broadcast_arrays(k, frequency, e)
    mu, _ = _moduli(e, nu)
    r = (1.0 - 2.0 * nu) / (2.0 * (1.0 - nu))  # mu / M, real
    x = np.ascontiguousarray(k * h, dtype=float).ravel()
    e_s = np.ascontiguousarray(inertia(frequency) / mu, dtype=complex).ravel()
    mu_flat = np.ascontiguousarray(mu, dtype=complex).ravel()
    out = np.empty(x.size, dtype=complex)
    _compliance_kernel(x, e_s, mu_flat, r, h, out)
    return out.reshape(k.shape)[()]


def _laplace_frequency(s):
    """Complex Laplace frequencies s [rad/s], finite, Re s >= 0."""
    z = np.asarray(s, dtype=complex)
    if np.any(~np.isfinite(z)) or np.any(z.real < 0):
        raise ValueError("Laplace frequency s must be finite with Re s >= 0 [rad/s] (the closed right half plane)")
    return z


def _laplace_modulus_array(s, modulus_s):
    """E(s) broadcast with s, checked to be finite, Re E > 0 and passive: Re(s / sqrt(E(s))) >= 0.

    The last condition is that the complex shear and P-wave "wavenumbers" gamma = s sqrt(rho / mu(s)) (same
    argument for both, r = mu / M being real) have Re gamma >= 0: a disturbance decays into the layer
    (laplace_compliance's branch argument rests on it). It holds for every modulus that is the continuation of
    a passive one (arg E(s) between 0 and arg s).
    """
    e = np.asarray(modulus_s, dtype=complex)
    if np.any(~np.isfinite(e)) or np.any(e.real <= 0):
        raise ValueError("modulus_s must be finite with Re E(s) > 0 [Pa]")
    s_b, e_b = np.broadcast_arrays(s, e)
    root = np.sqrt(e_b)
    decay = (s_b * np.conj(root)).real
    if np.any(decay < -1e-12 * np.abs(s_b) * np.abs(root)):
        i = np.flatnonzero(decay.ravel() < -1e-12 * (np.abs(s_b) * np.abs(root)).ravel())[0]
        raise ValueError(
            f"modulus_s = {e_b.ravel()[i]:.6g} Pa at s = {s_b.ravel()[i]:.6g} rad/s is not passive: "
            "Re(s / sqrt(E(s))) < 0, a wave would grow into the layer; E(s) must be the analytic continuation "
            "of a passive modulus (Material.laplace_modulus)"
        )
    return e


def laplace_compliance(k, s, modulus_s, poisson, density, thickness):
    """Laplace-domain surface compliance H(k, s) [m/Pa] of a layer bonded to a rigid base, Re s >= 0.

    The analytic continuation of :func:`compliance` to complex frequency, H(k, i w) = compliance(k, w): the
    frequency enters the layer only through eps_s = rho w^2 / mu, so w^2 = -s^2 and E(w) -> E(s), i.e.
    e_s = -rho (s h)^2 / mu(s), evaluated by the same numba kernel (``_compliance_kernel``, complex in e_s)
    and the same stable form. A separate function rather than a complex ``omega`` in :func:`compliance`:
    that function's contract (real w >= 0, Im E >= 0, Im H <= 0) and its code path stay exactly as they were,
    and this one validates its own domain (Re s >= 0, E(s) passive in the sense below).

    Branch (``_branch_sqrt``, principal root, Re >= 0). Write gamma^2 = rho s^2 / mu(s) = -e_s / h^2; the
    roots are a = sqrt(x^2 + r (h gamma)^2), b = sqrt(x^2 + (h gamma)^2), x = kh >= 0. For a passive material
    arg E(s) lies between 0 and theta = arg s (fractional Kelvin-Voigt: between 0 and alpha theta; each Maxwell
    arm s tau / (1 + s tau): between 0 and theta), so arg gamma = theta - arg(mu) / 2 lies between theta / 2
    and theta: |arg gamma| < pi/2 for Re s > 0 (Re gamma > 0: the wave decays into the layer), and
    arg gamma^2 has the sign of Im s with |arg gamma^2| < pi. Adding x^2 >= 0 keeps the argument of the root
    in the same (upper or lower) half plane, or on the positive real axis for real s: it never reaches the
    cut of the principal root (the negative real axis) in the open right half plane. So a and b are analytic
    there, with Re a, Re b > 0 (decaying, e^{-a z / h}; the kernel's t = exp(-(a + b)) keeps |t| < 1). On
    the imaginary axis s = i w (w > 0) the argument is x^2 - e_s with Im >= 0, the limit from Re s > 0, so
    the roots are continuous onto the frequency axis and equal those of :func:`compliance`; for a lossless
    material (argument on the cut) the kernel's normalisation Im >= 0 is that same limit. The layer
    compliance is even in a and in b, so its value does not depend on the branch at all; the branch decides
    the stable form's boundedness (|t| <= 1) and the half-space limit, where Re a > 0 is decay.

    Parameters
    ----------
    k : array_like
        Wavenumber magnitude |k| [rad/m], >= 0.
    s : array_like of complex
        Laplace frequency [rad/s], finite, Re s >= 0.
    modulus_s : array_like of complex
        E(s) [Pa], the analytic continuation of the complex modulus (``Material.laplace_modulus``),
        broadcastable with ``s``; Re E > 0 and passive (Re(s / sqrt(E)) >= 0).
    poisson : float
        Poisson's ratio nu [-], 0 < nu < 0.5.
    density : float
        Density rho [kg/m^3].
    thickness : float
        Layer thickness h [m].

    Returns
    -------
    numpy.ndarray of complex
        H(k, s) [m/Pa]; H(k, conj s) = conj H(k, s); real and positive for real s >= 0
        (H(k, 0) = static compliance with E(0); H(0, 0) = h / M(0)).

    References
    ----------
    Hayes, Keer, Herrmann & Mockros (1972), J. Biomech. 5, 541-551. doi:10.1016/0021-9290(72)90010-3
    Lubich (1988), Numer. Math. 52, 129-145 (convolution quadrature: G(s) off the frequency axis).
    doi:10.1007/BF01398686
    """
    nu = checks.poisson_ratio(poisson, allow_zero=False)
    rho = checks.real("density", density, positive=True)
    h = checks.real("thickness", thickness, positive=True)
    k = checks.nonnegative_array("k", k)
    s = _laplace_frequency(s)
    # w^2 = -s^2: e_s = rho (w h)^2 / mu -> -rho (s h)^2 / mu (equal to compliance's e_s at s = i w)
    return _evaluate(k, s, _laplace_modulus_array(s, modulus_s), nu, h, lambda z: rho * -((z * h) ** 2))


def static_compliance(k, modulus, poisson, thickness):
    """Static surface compliance H0(k) = 2 (1 - nu^2) / (E k) L(kh) of a layer bonded to a rigid base.

    Parameters
    ----------
    k : array_like
        Wavenumber magnitude [rad/m], >= 0.
    modulus : array_like
        Young's modulus [Pa] (real or complex), broadcastable with ``k``.
    poisson : float
        Poisson's ratio [-], 0 < nu < 0.5.
    thickness : float
        Layer thickness h [m].

    Returns
    -------
    numpy.ndarray
        H0 [m/Pa] (complex if ``modulus`` is complex); H0(0) = h / M.

    References
    ----------
    Hayes, Keer, Herrmann & Mockros (1972), J. Biomech. 5, 541-551.
    doi:10.1016/0021-9290(72)90010-3
    """
    nu = checks.poisson_ratio(poisson, allow_zero=False)
    h = checks.real("thickness", thickness, positive=True)
    k = checks.nonnegative_array("k", k)
    e = np.asarray(modulus)
    if np.any(~np.isfinite(e)) or np.any(np.real(e) <= 0):
        raise ValueError("modulus must be finite with a positive real part")
    x = k * h
    xs = np.where(x > 0, x, 1.0)
    # L(x)/x -> (1 - 2 nu) / (2 (1 - nu)^2) as x -> 0
    l_over_x = np.where(x > 0, static_layer_factor(xs, nu) / xs, (1.0 - 2.0 * nu) / (2.0 * (1.0 - nu) ** 2))
    return (2.0 * (1.0 - nu * nu) * h / e * l_over_x)[()]


def halfspace_compliance(k, omega, modulus, poisson, density):
    """Dynamic surface compliance of a visco-elastic half-space, H = alpha eps_s / (mu (4 k^2 alpha beta - Q^2)).

    Evaluated as H = -alpha / (mu R / eps_s) with R / eps_s = -4 k^2 (1 + P/eps_s) + eps_s and P = alpha beta - k^2
    written without cancellation (module docstring), so it is exact at w = 0 (static 2 (1 - nu^2) / (E k)) and
    at k = 0 (-i / (rho c_p w)). Lossless: pole at the Rayleigh wavenumber k = w / c_R.

    Parameters
    ----------
    k : array_like
        Wavenumber magnitude [rad/m], >= 0.
    omega : array_like
        Angular frequency [rad/s], >= 0.
    modulus : array_like
        Complex Young's modulus [Pa], broadcastable with ``omega``.
    poisson : float
        Poisson's ratio [-].
    density : float
        Density [kg/m^3].

    Returns
    -------
    numpy.ndarray of complex
        H [m/Pa]; infinite at k = 0, w = 0.

    References
    ----------
    Lamb (1904), Phil. Trans. R. Soc. A 203, 1. doi:10.1098/rsta.1904.0013
    """
    nu = checks.poisson_ratio(poisson, allow_zero=False)
    rho = checks.real("density", density, positive=True)
    k = checks.nonnegative_array("k", k)
    omega = checks.nonnegative_array("omega", omega)
    e = _modulus_array(modulus)
    k, omega, e = np.broadcast_arrays(k, omega, e)
    mu, _ = _moduli(e, nu)
    r = (1.0 - 2.0 * nu) / (2.0 * (1.0 - nu))
    k2 = k * k
    eps_s = rho * omega**2 / mu
    eps_p = r * eps_s
    origin = (k == 0.0) & (eps_s == 0.0)
    k2 = np.where(origin, 1.0, k2)
    alpha = _branch_sqrt(k2 - eps_p)
    beta = _branch_sqrt(k2 - eps_s)
    ab = alpha * beta
    near_static = np.abs(eps_s) <= k2
    with np.errstate(divide="ignore", invalid="ignore"):
        one_plus = np.where(
            near_static, (ab + eps_p - r * k2) / (ab + k2), 1.0 + (ab - k2) / np.where(near_static, 1.0, eps_s)
        )
        out = -alpha / (mu * (-4.0 * k2 * one_plus + eps_s))
    return np.where(origin, complex(np.inf, 0.0), out)[()]


def backing_force_transfer(omega, modulus, poisson, density, thickness):
    """Ratio of the normal force on the rigid base to the total surface force, 1 / cos(w h / c_p(w)).

    The total surface force is the k = 0 component of the pressure; for k = 0 the layer is a 1-D
    constrained rod, u(z) ∝ sin(kappa (h - z)), kappa = w / c_p, c_p = sqrt(M / rho), so the stress at the
    base over the stress at the surface is 1 / cos(kappa h) (-> 1 at w = 0), and for small damping
    |T| peaks at the quarter-wave resonance f = c_p / (4 h). Evaluated as
    2 exp(-i theta) / (1 + exp(-2 i theta)), theta = kappa h with Im theta <= 0, which cannot overflow.

    Parameters
    ----------
    omega : array_like
        Angular frequency [rad/s], >= 0.
    modulus : array_like
        Complex Young's modulus [Pa], broadcastable with ``omega``.
    poisson, density, thickness : float
        Poisson's ratio [-], density [kg/m^3], thickness [m].

    Returns
    -------
    numpy.ndarray of complex
        Transfer ratio [-].

    Raises
    ------
    ValueError
        If T is infinite: an undamped quarter-wave resonance lies on the frequency grid.
    """
    nu = checks.poisson_ratio(poisson, allow_zero=False)
    rho = checks.real("density", density, positive=True)
    h = checks.real("thickness", thickness, positive=True)
    omega = checks.nonnegative_array("omega", omega)
    e = _modulus_array(modulus)
    _, m = _moduli(e, nu)
    c_p = np.sqrt(m / rho)
    q = np.exp(-1j * (omega * h / c_p))
    t = 2.0 * q / (1.0 + q * q)
    if not np.all(np.isfinite(t)):
        raise ValueError(
            "backing_force_transfer: T(omega) is infinite (an undamped quarter-wave resonance lies on the "
            "frequency grid); the material needs a loss factor > 0"
        )
    return t[()]


def _material_transfer(omega, material) -> np.ndarray:
    """:func:`backing_force_transfer` of a material object (modulus(omega), poisson, density, thickness)."""
    w = checks.nonnegative_array("omega", omega)
    return backing_force_transfer(w, material.modulus(w), material.poisson, material.density, material.thickness)


def backing_kernel(material, sample_rate: float, n_fft: int = 4096, n_alias: int = 32) -> np.ndarray:
    """Causal discrete impulse response c[l] from surface force samples to backing force [1].

    The force series is read as piecewise linear in time (first-order hold), so that
    backing(t_n) = sum_l c[l] F[n - l] holds exactly for such a force, with
    c[l] = integral of the continuous impulse response against the hat function around l dt.
    Its spectrum is the aliased sum C(omega) = sum_k T(omega + k omega_s) sinc^2((omega + k omega_s) dt / 2),
    evaluated for |k| <= n_alias and inverse-transformed with irfft on n_fft points. Because the
    continuous response is causal, c is causal (up to the alias truncation, logged), and
    sum_l c[l] = C(0) = T(0) = 1 exactly.

    A plain ``irfft(T)`` is not used: T does not decay towards fs/2 for a stiffening tread, so its
    band-limited impulse response has a sinc precursor at negative times that carries about 20 %
    of the static gain and would be lost in a causal convolution.

    Parameters
    ----------
    material : Material
        Provides ``modulus(omega)`` [Pa] (complex, exp(+i omega t)), ``poisson``, ``density``
        [kg/m^3], ``thickness`` [m].
    sample_rate : float
        fs [Hz].
    n_fft : int
        FFT length, >= 4096 (the period n_fft / fs must exceed the response's duration).
    n_alias : int
        Aliases summed on each side.

    Returns
    -------
    numpy.ndarray
        c[0 ... n_fft - 1] [1].
    """
    fs = checks.real("sample_rate", sample_rate, positive=True)
    n_fft = checks.integer("n_fft", n_fft, minimum=4096)
    freq = np.fft.rfftfreq(n_fft, 1.0 / fs)
    spectrum = np.zeros(freq.size, dtype=complex)
    for k in range(-n_alias, n_alias + 1):
        f_k = freq + k * fs
        t_k = _material_transfer(2 * np.pi * np.abs(f_k), material)
        t_k = np.where(f_k < 0, np.conj(t_k), t_k)
        spectrum += t_k * np.sinc(f_k / fs) ** 2
    c = np.fft.irfft(spectrum, n_fft)
    tail = c[n_fft // 2 :]
    precursor = float(np.sum(tail**2) / np.sum(c**2))
    logger.info(
        "backing kernel: n_fft = %d, c[0] = %.4f, energy in the second half (precursor/wrap-around) %.2e",
        n_fft, c[0], precursor,
    )
    return c


def backing_force(total_force, material, sample_rate: float, n_fft: int = 4096) -> np.ndarray:
    """Total force at the rigid backing of the layer [N].

    The total surface force, read as piecewise linear between samples, convolved causally with
    the k = 0 layer transfer T(omega) = 1 / cos(omega h / c_p(omega)) (:func:`backing_kernel`).
    T(0) = 1, so for a slowly varying force the backing force equals the surface force (and for
    quasi-static runs it is set equal to it).

    Parameters
    ----------
    total_force : array_like
        Surface force samples F[n] [N] at t_n = n / fs, starting from rest (F = 0 before n = 0).
    material : Material
        Layer material.
    sample_rate : float
        fs [Hz].
    n_fft : int
        Minimum FFT length (>= 4096); increased to at least twice the series length.

    Returns
    -------
    numpy.ndarray
        Backing force [N], same length as ``total_force``.
    """
    f = checks.finite_array("total_force", total_force, ndim=1)
    n_fft = checks.integer("n_fft", n_fft, minimum=4096)
    size = max(n_fft, 1 << int(math.ceil(math.log2(max(2 * f.size, 2)))))
    c = backing_kernel(material, sample_rate, size)
    return np.convolve(f, c[: f.size])[: f.size]
