r"""A flexible belt behind the tread layer: pre-tensioned orthotropic plate and the exact layer-on-belt coupling.

Issue 26, physics core only (no pipeline wiring, time kernel or memory model here).

Geometry and conventions are those of :mod:`tyreroad.layer`: the tread layer occupies 0 <= z <= h, z pointing
from the road into the tyre, loaded at z = 0 by a normal pressure p exp(i(k.x + w t)) without shear; time
convention exp(+i w t), complex moduli with Im >= 0, so a passive compliance has Im H <= 0. SI units.

Belt
----
The belt is a thin pre-tensioned orthotropic (Kirchhoff) plate on an elastic bed (Kropp 1989): for a normal
pressure p_b exp(i(k.x + w t)) acting on it in +z its normal displacement is w = p_b / Z with

    Z(k, w) = phi(w) [D_x kx^4 + 2 D_xy kx^2 ky^2 + D_y ky^4 + s] + T_x kx^2 + T_y ky^2 - m w^2   [Pa/m],

x circumferential, y lateral. Tensions come from the inflation pressure and are taken lossless; the loss acts on
the bending stiffness and on the bed (sidewalls + air) through phi (:meth:`BeltProperties.stiffness_factor`): by
default a causal relaxation ladder with loss factor eta at a reference frequency (Kropp 1989's constant 1 + i eta is
available as ``loss_model = 'hysteretic'``, but is not causal).

Layer on belt (the two-port)
----------------------------
Rotate the in-plane axes so that k is along x'. With the base inextensible (tangential displacement 0 at z = h,
both components; the SH part is then not excited) the layer is a linear two-port between the normal surface
displacement / force u0, F0 = p (z = 0) and the normal base displacement / force u1, F1 = sigma_zz(h) (the
force per area on the layer's face z = h, in +z): [F0, F1] = K [u0, u1] with K symmetric (reciprocity). The
belt pushes back on the layer, F1 = -Z u1. Eliminating u1,

    H_belt = u0 / p = H_rigid + tau^2 / (Z + K_b),

* H_rigid = 1 / K_00: the layer on a rigid base (:func:`tyreroad.layer.compliance`, its stable form, is used);
* tau = -K_10 H_rigid: the normal pressure transmitted to a rigid base per unit surface pressure
  (k = 0: 1 / cos(w h / c_p), :func:`tyreroad.layer.backing_force_transfer`); by reciprocity it is also the
  surface displacement per unit base displacement when the surface is traction free;
* K_b = K_11 - K_10 K_01 H_rigid: the dynamic stiffness [Pa/m] of the layer's base with the surface traction free
  (-rho h w^2 at k = 0, w -> 0: the layer rides on the belt as a mass).

Z -> inf gives H_rigid exactly (the correction is O(1/Z)); the belt sees the stiffness Z + K_b.

tau and K_b come from the P-SV boundary-value problem solved per (k, w) as a 4 x 4 linear system (numpy,
batched), in h-scaled variables x = kh, a = alpha h, b = beta h, e_s = rho (w h)^2 / mu, r = mu / M as in
:mod:`tyreroad.layer`, with u_x = i U_x, sigma_xz = i S_xz. The basis is chosen so that it is bounded and
does not degenerate:

* decaying from the surface: E(z) = exp(-a z) and the divided difference g(z) = (exp(-b z) - exp(-a z)) / (a - b)
  (-> z exp(-x z) in statics; g' = -b g + E). The P solution f1 and the combination
  f2 = (x SV - b P) / (a - b) of the SV and P solutions read, as (U_x / x, u_z, S_xz / x, sigma_zz / mu):

      f1 = (E, -a E, -2 a E, Q E),
      f2 = (b g, -x^2 g + p_d E, -Q g + (b + p_d) E, 2 x^2 b g + b (a + b) / (1 - r) E),

  Q = 2 x^2 - e_s, p_d = (ab - x^2) / (a - b) = (P / e_s)(a + b) / (1 - r), b + p_d = (2 P / e_s + 1)(a + b) / (1 - r),
  with P / e_s in layer.py's cancellation-free form; the static limit of f2 is the Papkovich solution with its
  (3 - 4 nu);
* decaying from the base: the mirror images f3, f4 of f1, f2 about z = 1/2 (functions of 1 - z; u_z and S_xz
  change sign), so every basis function is normalised (= 1 or 0) at its own boundary and no exponential grows.

Rows: S_xz(0) / x = 0, sigma_zz(0) = -p, U_x(h) / x = 0, u_z(h) = u1 (the rows divided by x stay regular at
k = 0, where the SV part decouples). Two right-hand sides: (p, u1) = (1, 0) gives H_rigid (a check against
layer.py) and tau = -sigma_zz(h); (0, 1) gives K_b = sigma_zz(h) and, by reciprocity, u0 = tau (a check).
The single point k = 0, w = 0 is set to its limits H = h / M, tau = 1, K_b = 0.
Accuracy (tests/test_belt.py, against an 80-digit propagator of the Navier equations): tau and H_rigid to about
1e-11 relative for kh in [1e-2, 500]; K_b to 1e-11 relative or about 2e-19 mu / h absolute, whichever is larger:
the static K_b ~ (kh)^4 mu / h of a thin free layer is formed from O(1) terms, so at kh = 0.01, w = 0 it is good to
2e-10 relative only, which is immaterial since the belt adds Z >= s (1 + i eta) to it.

Belt point mobility
-------------------
:func:`belt_point_mobility`: the belt alone, periodic around the circumference L (kx = 2 pi n / L) and of finite
width W with simply supported edges (ky = pi m / W, modes sin(m pi y / W)). Finite width because the belt of a
passenger-car tyre (W ~ 0.15 m) is comparable to its bending wavelengths below about 1 kHz (about 0.06 m at
1 kHz, 0.2 m at 100 Hz with the default parameters), so the cross modes shape the measured mobility there
(Kropp 1989 uses the same plate strip); a wide plate would miss them. The sum over n is done in closed form
(Z is a quadratic in kx^2: partial fractions and sum_n 1 / (kx_n^2 + c^2) = L coth(c L / 2) / (2 c)), so
only the sum over the cross modes is truncated.

References
----------
Kropp, W. (1989), Structure-borne sound on a smooth tyre, Applied Acoustics 26, 181-192 (DOI not verified here:
reference lists disagree between 10.1016/0003-682X(89)90084-7 and 10.1016/0003-682X(89)90051-0).
Larsson, K. & Kropp, W. (2002), A high-frequency three-dimensional tyre model based on two coupled elastic
layers, J. Sound Vib. 253(4), 889-908. doi:10.1006/jsvi.2001.4073
Cremer, L., Heckl, M. & Petersson, B. A. T. (2005), Structure-Borne Sound, 3rd ed., Springer (infinite-plate
point mobility 1 / (8 sqrt(B m''))).
Hayes, Keer, Herrmann & Mockros (1972), J. Biomech. 5, 541-551 (layer on rigid base). doi:10.1016/0021-9290(72)90010-3
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

import numpy as np

from . import checks
from .layer import _branch_sqrt, _modulus_array, _moduli, _scaled_roots, compliance

__all__ = [
    "BeltProperties",
    "DEFAULT_BELT",
    "belt_impedance",
    "layer_two_port",
    "layer_on_belt_compliance",
    "belt_point_mobility",
    "belt_element_frf_correction",
    "belt_element_frf_correction_ring",
]

# |a - b| below which (1 - exp(-y)) / y is summed as its Taylor series (to y^12: next term 0.25^13 / 14! = 2e-19)
_SERIES_LIMIT = 0.25


@dataclass(frozen=True)
class BeltProperties:
    """A pre-tensioned orthotropic plate on an elastic bed: the belt of a tyre (Kropp 1989).

    Z(k, w) = phi(w) [D_x kx^4 + 2 D_xy kx^2 ky^2 + D_y ky^4 + s] + T_x kx^2 + T_y ky^2 - m w^2 [Pa/m];
    x circumferential, y lateral (across the belt). phi (:meth:`stiffness_factor`) carries the loss of bending
    and bed: causal by default (``loss_model = 'causal'``), the tensions are lossless.

    Parameters
    ----------
    bending_x, bending_y, bending_xy : float
        D_x, D_y [N m] (> 0) and the effective twisting/coupling stiffness D_xy [N m] (>= 0).
    tension_x, tension_y : float
        Membrane pre-tensions T_x, T_y [N/m] (>= 0), from the inflation pressure.
    mass : float
        Mass per area m [kg/m^2] (> 0).
    bed : float
        Elastic bed stiffness s [N/m^3] (>= 0): sidewalls and enclosed air.
    loss_factor : float
        eta [-] (>= 0), on the bending stiffnesses and the bed, at ``loss_frequency``.
    circumference : float
        L [m] (> 0): period in x (used by :func:`belt_point_mobility`).
    width : float
        W [m] (> 0): simply supported width (used by :func:`belt_point_mobility`).
    loss_model : {"causal", "hysteretic"}
        ``causal`` (default): phi(w) = [1 + c sum_k Delta i w / (i w + w_k)] / Re[...](w_r), a ladder of Maxwell
        (relaxation) terms at w_k = 2 pi f_k, f_k = 1 Hz ... 1 MHz (4 per decade, Delta = ln(10) / 4): a causal,
        passive, rational stiffness with a nearly frequency-independent loss (the band-limited "constant
        hysteretic" damping). c is set so that the loss factor Im phi / Re phi is ``loss_factor`` at
        ``loss_frequency`` f_r, and phi is normalised to Re phi(w_r) = 1: the stiffnesses given are the storage
        stiffnesses at f_r. Kramers-Kronig then fixes the rest: for eta = 0.1 the loss is 0.12 at 10 Hz and 0.08 at
        5 kHz, and the storage stiffness rises from 0.76 (static) to 1.8 (5 kHz) times the nominal one.
        ``hysteretic``: phi = 1 + i eta at every frequency (Kropp 1989's form); not causal (a real kernel cannot
        hold its imaginary part at w -> 0, tyreroad.belt_kernel), kept for frequency-domain comparisons.
    loss_frequency : float
        f_r [Hz] (> 0), where ``loss_factor`` and the nominal stiffnesses hold (causal model).
    """

    bending_x: float
    bending_y: float
    bending_xy: float
    tension_x: float
    tension_y: float
    mass: float
    bed: float
    loss_factor: float
    circumference: float = 1.9
    width: float = 0.16
    loss_model: str = "causal"
    loss_frequency: float = 100.0

    def __post_init__(self):
        rules = {
            "bending_x": "positive", "bending_y": "positive", "bending_xy": "nonnegative",
            "tension_x": "nonnegative", "tension_y": "nonnegative", "mass": "positive",
            "bed": "nonnegative", "loss_factor": "nonnegative", "circumference": "positive", "width": "positive",
            "loss_frequency": "positive",
        }
        if self.loss_model not in LOSS_MODELS:
            raise ValueError(f"BeltProperties.loss_model: expected one of {list(LOSS_MODELS)}, got {self.loss_model!r}")
        for f in fields(self):
            if f.name == "loss_model":
                continue
            kind = rules[f.name]
            value = checks.real(
                f"BeltProperties.{f.name}", getattr(self, f.name),
                positive=kind == "positive", nonnegative=kind == "nonnegative",
            )
            object.__setattr__(self, f.name, value)

        if self.loss_model == "causal" and self.loss_factor > 0:
            s_r = _ladder_sum(2.0 * math.pi * self.loss_frequency)
            if not s_r.imag > self.loss_factor * s_r.real:
                raise ValueError(
                    f"BeltProperties.loss_factor = {self.loss_factor!r}: the causal loss model reaches at most "
                    f"{s_r.imag / s_r.real:.3f} at loss_frequency = {self.loss_frequency:g} Hz (its relaxation ladder "
                    "spans 1 Hz - 1 MHz); expected a smaller loss factor, or loss_model: hysteretic")

    def stiffness_factor(self, omega) -> np.ndarray:
        """phi(w) [1], the complex factor of the bending stiffnesses and the bed (see ``loss_model``).

        Parameters
        ----------
        omega : array_like
            Angular frequency [rad/s], >= 0.

        Returns
        -------
        numpy.ndarray
            Complex, omega's shape; Im >= 0 (passive), real at w = 0 for the causal model.
        """
        return self.laplace_stiffness_factor(1j * np.asarray(omega, dtype=float))

    def laplace_stiffness_factor(self, s) -> np.ndarray:
        """phi at Laplace frequencies s [rad/s] (Re s >= 0; s = i w on the frequency axis): the causal model's
        rational continuation (the hysteretic model's constant 1 + i eta, which has none, is returned as is)."""
        s = np.asarray(s, dtype=complex)
        if self.loss_model == "hysteretic" or self.loss_factor == 0.0:
            return np.full(s.shape, 1.0 + 1j * self.loss_factor, dtype=complex)[()]
        s_r = _ladder_sum(2.0 * math.pi * self.loss_frequency)
        c = self.loss_factor / (s_r.imag - self.loss_factor * s_r.real)
        return ((1.0 + c * _ladder_sum_s(s)) / (1.0 + c * s_r.real))[()]

    def scaled(self, factor: float) -> "BeltProperties":
        """The same belt with all stiffnesses (D_x, D_y, D_xy, T_x, T_y, s) multiplied by ``factor`` (> 0)."""
        c = checks.real("factor", factor, positive=True)
        return replace(
            self, bending_x=self.bending_x * c, bending_y=self.bending_y * c, bending_xy=self.bending_xy * c,
            tension_x=self.tension_x * c, tension_y=self.tension_y * c, bed=self.bed * c,
        )


#: The belt's loss models (:attr:`BeltProperties.loss_model`).
LOSS_MODELS = ("causal", "hysteretic")

#: Relaxation frequencies [Hz] of the causal loss's Maxwell ladder: 1 Hz ... 1 MHz, 4 per decade.
_LADDER_FREQUENCIES = 10.0 ** np.arange(0.0, 6.0 + 1e-9, 0.25)
_LADDER_STEP = math.log(10.0) / 4.0


def _ladder_sum(omega):
    """S(w) = Delta sum_k i w / (i w + w_k) [1], omega's shape (the relaxation ladder of the causal loss)."""
    return _ladder_sum_s(1j * np.asarray(omega, dtype=float))


def _ladder_sum_s(s):
    """S at Laplace frequencies s: Delta sum_k s / (s + w_k) [1]."""
    s = np.asarray(s, dtype=complex)[..., None]
    wk = 2.0 * math.pi * _LADDER_FREQUENCIES
    return _LADDER_STEP * np.sum(s / (s + wk), axis=-1)


# Passenger-car belt (a 195/65 R15-class tyre, the seed's tread), x circumferential, y lateral.
#
# Sources. Every value below is still an ORDER-OF-MAGNITUDE ESTIMATE whose derivation is stated; none is a published
# fitted value. Searched (session s15, 2026-11-26, the stored public-text index: web pages, documentation, public code
# repositories) for the parameter tables of Kropp (1989, Appl. Acoust. 26(3), 181-192), Larsson & Kropp (2002, JSV
# 253, 889-908), Andersson, Larsson & Kropp (2001), Andersson & Larsson (2005), Pinnington (2006, JSV 290, 101-132 and
# 133-168), Pinnington & Briscoe, Muggleton, Mace & Brennan (2003), Le Bot et al. (2017, JSV 392, 187-199; 2018,
# R. Soc. open sci. 5:180639), Kropp's thesis, Hoever's thesis (Chalmers 2014) and Hoever & Kropp (2015), and for
# open code implementing Kropp's orthotropic plate tyre model. Only abstracts and first pages could be read; no
# parameter table, and no code holding bending stiffness, tension, mass per area, bed stiffness or loss factor of a
# tyre belt, was found; Kropp (1989) itself was found only in reference lists. What the abstracts read DO say
# (frequencies only, no levels), used in tyreroad/belt_mobility.py (PUBLISHED_MOBILITY) and docs/belt.md as a check,
# not as values here:
#   * Pinnington & Briscoe, "A wave model for a pneumatic tyre belt" (J. Sound Vib., abstract): tension and the sidewall
#     control the deformation and stiffness below 100 Hz, waves propagate around the belt above; for a car tyre the
#     modal behaviour is observed to cease above about 400 Hz, where the tyre at the input appears of infinite extent.
#   * Muggleton, Mace & Brennan (2003), J. Sound Vib. 264(4), 929-950 (abstract; two-plate wave model of a tyre on a
#     rigid rim under a line force, in "reasonable agreement" with experiments on an inflated tyre on a wheel rim):
#     stiffness-like below 100 Hz, resonant 100-500 Hz, tending towards an infinite orthotropic plate above 500 Hz.
# Measured against them (tyreroad/belt_mobility.py, docs/belt.md), this belt is stiff at the bottom (its first strip
# mode n = 0, m = 1 is at about 180 Hz bare and 140 Hz with the 10 mm tread riding on it as a mass, not below 100 Hz:
# the lateral tension across the simply supported width, T_y (pi / W)^2 = 8.5e6 N/m^3, outweighs the bed
# s = 2.6e6 N/m^3) and too lightly damped at the top (its point mobility stays within a factor 1.5 of the infinite
# plate 1 / (8 sqrt(sqrt(D_x D_y) m)) only above about 1.1 kHz and within a factor 1.3 above about 1.9 kHz, not from
# 400-500 Hz; the tension, lossless here, carries much of the stiffness). Both are reasons to replace the estimates by
# a fit to a measured mobility; they are kept unchanged here because no published values were found.
DEFAULT_BELT = BeltProperties(
    # ESTIMATE. Steel-cord belt package (two steel plies + cap + carcass, ~4-5 mm of rubber-steel laminate) of
    # effective bending modulus ~0.5 GPa: D = E' t^3 / 12 ~ 3-4 N m. Cords near the circumferential direction:
    # D_x > D_y. (The earlier note "order of magnitude from Kropp (1989)" could not be checked: the paper was not
    # found.)
    bending_x=3.7,       # N m, estimate
    bending_y=2.0,       # N m, estimate (lateral bending carried by the rubber matrix and carcass)
    bending_xy=2.7,      # N m, sqrt(D_x D_y) (Huber's approximation for a laminate), estimate
    # ESTIMATE. Membrane pre-tension from the inflation pressure p0 = 2.2e5 Pa: circumferential T_x ~ p0 R with belt
    # radius R ~ 0.3 m (thin ring hoop tension), lateral T_y ~ p0 r_m with the cross-section's meridional radius
    # r_m ~ 0.1 m (both from the inflation pressure, as the abstracts above describe the tension).
    tension_x=6.6e4,     # N/m, estimate
    tension_y=2.2e4,     # N/m, estimate
    # ESTIMATE. Belt + carcass without tread, ~2.7 kg of a 8-9 kg tyre on the 1.9 m x 0.16 m band + sidewall share
    # (the tread, 1100 kg/m^3 x 10 mm = 11 kg/m^2, is the layer in front of it).
    mass=9.0,            # kg/m^2, estimate
    # ESTIMATE. Bed: chosen so that the uniform (k = 0) mode, sqrt(s / m) / 2 pi, is at 85 Hz, taken as the first radial
    # resonance of a passenger-car tyre on a fixed rim: s = m (2 pi 85)^2. The 80-100 Hz figure was not found in any
    # source read (the abstracts above only put tension/sidewall control below about 100 Hz); and on the finite strip
    # the first mode is at about 180 Hz (140 Hz with the tread), not 85 Hz (see above).
    bed=9.0 * (2.0 * math.pi * 85.0) ** 2,   # N/m^3 (= 2.57e6), estimate
    # ESTIMATE. Structural loss factor on bending and bed. The earlier note "0.05-0.2 in the tyre literature, e.g.
    # Larsson & Kropp 2002" could not be checked (only the abstract of that paper was read).
    loss_factor=0.1,
    circumference=1.9,   # m, 2 pi x 0.30 m belt radius
    width=0.16,          # m, belt width of a 195-205 mm tyre
    # The loss is causal (a relaxation ladder, BeltProperties.loss_model): eta = 0.1 and the stiffnesses above hold
    # in storage at 100 Hz, the range the estimates refer to (the first radial modes); Kramers-Kronig then makes the
    # static stiffness 0.69 and the 5 kHz stiffness 1.25 times these values (a model choice, not a measured one).
    loss_model="causal",
    loss_frequency=100.0,  # Hz
)


def belt_impedance(kx, ky, omega, belt: BeltProperties):
    """Wavenumber-frequency impedance Z(k, w) [Pa/m] of the belt: w = p_b / Z.

    Z = (1 + i eta)[D_x kx^4 + 2 D_xy kx^2 ky^2 + D_y ky^4 + s] + T_x kx^2 + T_y ky^2 - m w^2 for a normal pressure
    p_b exp(i(kx x + ky y + w t)) acting on the belt in the direction of its displacement w.

    Parameters
    ----------
    kx, ky : array_like
        Circumferential and lateral wavenumbers [rad/m] (any sign; Z is even in each).
    omega : array_like
        Angular frequency [rad/s], >= 0.
    belt : BeltProperties
        The belt.

    Returns
    -------
    numpy.ndarray of complex
        Z [Pa/m], broadcast over the arguments; Im Z >= 0 (passive).
    """
    if not isinstance(belt, BeltProperties):
        raise ValueError(f"belt: expected a BeltProperties, got {type(belt).__name__}")
    kx = checks.finite_array("kx", kx)
    ky = checks.finite_array("ky", ky)
    omega = checks.nonnegative_array("omega", omega)
    elastic, tension = belt_stiffness_terms(kx, ky, belt)
    z = belt.stiffness_factor(omega) * elastic + tension - belt.mass * omega * omega
    return np.asarray(z, dtype=complex)[()]


def belt_stiffness_terms(kx, ky, belt: BeltProperties):
    """(D_x kx^4 + 2 D_xy kx^2 ky^2 + D_y ky^4 + s, T_x kx^2 + T_y ky^2) [Pa/m]: the parts of Z that the loss factor
    phi multiplies and the lossless tension, so that Z = phi elastic + tension - m w^2."""
    kx2, ky2 = kx * kx, ky * ky
    elastic = belt.bending_x * kx2 * kx2 + 2.0 * belt.bending_xy * kx2 * ky2 + belt.bending_y * ky2 * ky2 + belt.bed
    return elastic, belt.tension_x * kx2 + belt.tension_y * ky2


def _one_minus_exp_over(y):
    """(1 - exp(-y)) / y for complex y, with its Taylor series for |y| < _SERIES_LIMIT."""
    small = np.abs(y) < _SERIES_LIMIT
    ys = np.where(small, y, 0.0)
    # sum_{j>=0} (-y)^j / (j + 1)!, Horner; terms to y^12 (|y|^13 / 14! < 1e-18 at |y| = 0.25)
    series = np.ones_like(ys)
    for j in range(13, 0, -1):
        series = 1.0 - ys / (j + 1) * series
    yb = np.where(small, 1.0, y)
    with np.errstate(over="ignore", invalid="ignore"):
        direct = -np.expm1(-yb) / yb
    return np.where(small, series, direct)


def _two_port_numpy(x, e_s, r):
    """h-scaled two-port of the layer: (H_rigid mu / h, tau, K_b h / mu, u0 of the base-driven case).

    x = kh [-] (>= 0), e_s = rho (w h)^2 / mu [-] (complex), r = mu / M [-] (real); arrays broadcast together.
    The 4 x 4 boundary-value system of the module docstring, solved batched by numpy.linalg.solve.
    """
    x, e_s = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(e_s, dtype=complex))
    shape = x.shape
    x = x.ravel().copy()
    e_s = e_s.ravel()
    origin = (x == 0.0) & (e_s == 0.0)
    x[origin] = 1.0  # harmless value; replaced by the limits at the end
    x2, a, b, _, p_over_e = _scaled_roots(x, e_s, r)
    apb = a + b
    q = 2.0 * x2 - e_s
    pd = p_over_e * apb / (1.0 - r)  # (ab - x^2) / (a - b)
    bpd = (2.0 * p_over_e + 1.0) * apb / (1.0 - r)  # b + p_d
    czz = b * apb / (1.0 - r)  # sigma_zz coefficient of E in f2
    ea = np.exp(-a)
    g1 = np.exp(-b) * _one_minus_exp_over(a - b)  # g(1) = (e^-b - e^-a) / (a - b)

    def f1(e, g):
        return np.stack([e, -a * e, -2.0 * a * e, q * e], axis=-1)

    def f2(e, g):
        return np.stack([b * g, -x2 * g + pd * e, -q * g + bpd * e, 2.0 * x2 * b * g + czz * e], axis=-1)

    one, zero = np.ones_like(ea), np.zeros_like(ea)
    mirror = np.array([1.0, -1.0, -1.0, 1.0])
    # columns: f1, f2 (decaying from z = 0), f3, f4 (their mirror images, decaying from z = h)
    at0 = np.stack([f1(one, zero), f2(one, zero), mirror * f1(ea, g1), mirror * f2(ea, g1)], axis=-1)
    at1 = np.stack([f1(ea, g1), f2(ea, g1), mirror * f1(one, zero), mirror * f2(one, zero)], axis=-1)
    # rows: S_xz(0)/x, sigma_zz(0), U_x(1)/x, u_z(1)
    mat = np.stack([at0[:, 2, :], at0[:, 3, :], at1[:, 0, :], at1[:, 1, :]], axis=1)
    scale = np.max(np.abs(mat), axis=2, keepdims=True)  # row equilibration
    mat = mat / scale
    rhs = np.zeros((x.size, 4, 2), dtype=complex)
    rhs[:, 1, 0] = -1.0  # sigma_zz(0) = -p, p = 1 (rigid base)
    rhs[:, 3, 1] = 1.0  # u_z(h) = 1, free surface
    rhs = rhs / scale
    coef = np.linalg.solve(mat, rhs)
    u0 = np.einsum("nj,njc->nc", at0[:, 1, :], coef)
    szz1 = np.einsum("nj,njc->nc", at1[:, 3, :], coef)
    h_rigid = u0[:, 0]
    tau = -szz1[:, 0]
    k_base = szz1[:, 1]
    recip = u0[:, 1]
    h_rigid[origin] = r
    tau[origin] = 1.0
    k_base[origin] = 0.0
    recip[origin] = 1.0
    return tuple(v.reshape(shape) for v in (h_rigid, tau, k_base, recip))


def layer_two_port(k, omega, modulus, poisson, density, thickness):
    """The tread layer's two-port to an inextensible base: H_rigid, tau and K_b (module docstring).

    Parameters
    ----------
    k : array_like
        Wavenumber magnitude |k| [rad/m], >= 0.
    omega : array_like
        Angular frequency [rad/s], >= 0.
    modulus : array_like
        Complex Young's modulus E(w) [Pa] (Re > 0, Im >= 0), broadcastable with ``omega``.
    poisson : float
        Poisson's ratio [-], 0 < nu < 0.5.
    density : float
        Density [kg/m^3].
    thickness : float
        Layer thickness h [m].

    Returns
    -------
    dict of numpy.ndarray (complex)
        ``h_rigid`` [m/Pa] (this solver's rigid-base compliance, a check on :func:`tyreroad.layer.compliance`),
        ``tau`` [-] (base pressure per surface pressure, rigid base), ``k_base`` [Pa/m] (base stiffness, free
        surface), ``reciprocal`` [-] (surface displacement per base displacement, free surface; equals tau).
    """
    nu = checks.poisson_ratio(poisson, allow_zero=False)
    rho = checks.real("density", density, positive=True)
    h = checks.real("thickness", thickness, positive=True)
    k = checks.nonnegative_array("k", k)
    omega = checks.nonnegative_array("omega", omega)
    e = _modulus_array(modulus)
    k, omega, e = np.broadcast_arrays(k, omega, e)
    mu, _ = _moduli(e, nu)
    r = (1.0 - 2.0 * nu) / (2.0 * (1.0 - nu))
    h_r, tau, kb, recip = _two_port_numpy(k * h, rho * (omega * h) ** 2 / mu, r)
    out = {"h_rigid": h_r * h / mu, "tau": tau, "k_base": kb * mu / h, "reciprocal": recip}
    return {key: np.asarray(v, dtype=complex)[()] for key, v in out.items()}


def layer_on_belt_compliance(kx, ky, omega, modulus, poisson, density, thickness, belt: BeltProperties):
    """Surface compliance H = u_z(0) / p [m/Pa] of the tread layer on the flexible, inextensible belt.

    H = H_rigid(|k|, w) + tau^2 / (Z(kx, ky, w) + K_b(|k|, w)) (module docstring): H_rigid from
    :func:`tyreroad.layer.compliance`, tau and K_b from :func:`layer_two_port`, Z from :func:`belt_impedance`.
    A belt whose stiffness tends to infinity gives :func:`tyreroad.layer.compliance` back (the correction is
    O(1 / Z)).

    Parameters
    ----------
    kx, ky : array_like
        Circumferential and lateral wavenumbers [rad/m].
    omega : array_like
        Angular frequency [rad/s], >= 0.
    modulus : array_like
        Complex Young's modulus E(w) of the tread [Pa] (Re > 0, Im >= 0), broadcastable with ``omega``.
    poisson : float
        Poisson's ratio of the tread [-], 0 < nu < 0.5.
    density : float
        Tread density [kg/m^3].
    thickness : float
        Tread thickness h [m].
    belt : BeltProperties
        The belt.

    Returns
    -------
    numpy.ndarray of complex
        H [m/Pa], broadcast over the arguments; Im H <= 0 for a passive tread and belt.
    """
    if not isinstance(belt, BeltProperties):
        raise ValueError(f"belt: expected a BeltProperties, got {type(belt).__name__}")
    kx = checks.finite_array("kx", kx)
    ky = checks.finite_array("ky", ky)
    omega = checks.nonnegative_array("omega", omega)
    e = _modulus_array(modulus)
    kx, ky, omega, e = np.broadcast_arrays(kx, ky, omega, e)
    k = np.hypot(kx, ky)
    h_rigid = compliance(k, omega, e, poisson, density, thickness)
    port = layer_two_port(k, omega, e, poisson, density, thickness)
    z = belt_impedance(kx, ky, omega, belt)
    return np.asarray(h_rigid + port["tau"] ** 2 / (z + port["k_base"]), dtype=complex)[()]


def _ring_sums(ky, omega, belt: BeltProperties):
    """R(ky) = sum over n in Z of 1 / Z(2 pi n / L, ky, w) [m/Pa], in closed form.

    Z = A q^2 + B q + C in q = kx^2 with A = phi D_x, B = 2 phi D_xy ky^2 + T_x,
    C = phi (D_y ky^4 + s) + T_y ky^2 - m w^2 (phi = ``belt.stiffness_factor(w)``). With the roots q_1, q_2 = -c_j^2 (Re c_j >= 0),
    1 / Z = [1 / (q + c_1^2) - 1 / (q + c_2^2)] / (A (q_1 - q_2)) and
    sum_n 1 / ((2 pi n / L)^2 + c^2) = L coth(c L / 2) / (2 c) = L (1 + e) / (2 c (1 - e)), e = exp(-c L).
    """
    one_i = belt.stiffness_factor(omega)
    ky2 = ky * ky
    a_c = one_i * belt.bending_x
    b_c = 2.0 * one_i * belt.bending_xy * ky2 + belt.tension_x
    c_c = one_i * (belt.bending_y * ky2 * ky2 + belt.bed) + belt.tension_y * ky2 - belt.mass * omega * omega
    disc = np.sqrt(b_c * b_c - 4.0 * a_c * c_c)
    # roots without cancellation: q1 = (-B - sign * disc) / 2A with the sign that avoids cancellation
    sgn = np.where((np.conj(b_c) * disc).real >= 0.0, 1.0, -1.0)
    big = -(b_c + sgn * disc) / 2.0
    q1 = big / a_c
    q2 = c_c / big
    length = belt.circumference

    def ring(qr):
        c = _branch_sqrt(-qr)
        e = np.exp(-c * length)
        return length * (1.0 + e) / (2.0 * c * (1.0 - e))

    return (ring(q1) - ring(q2)) / (a_c * (q1 - q2))


def belt_point_mobility(omega, belt: BeltProperties, y0: float | None = None, n_modes: int = 20000):
    """Point mobility Y = i w w(x0, y0) / F [m/(N s)] of the belt alone (ring of circumference L, width W).

    w(x, y) = sum_n sum_m (1 / L)(2 / W) exp(i kx_n (x - x0)) sin(ky_m y) sin(ky_m y0) / Z(kx_n, ky_m, w) F,
    kx_n = 2 pi n / L (periodic around the circumference), ky_m = m pi / W (simply supported edges, m >= 1;
    finite width: module docstring). At the driving point

        Y = i w (2 / (L W)) sum_{m=1}^{n_modes} sin^2(m pi y0 / W) R(ky_m),   R(ky) = sum_n 1 / Z(kx_n, ky, w),

    with R in closed form (``_ring_sums``), so only the cross-mode sum is truncated: its terms fall as m^-3
    (m^-2 without bending in y), the tail after n_modes modes is about 1 / (8 pi D_y K^2) in w / F,
    K = n_modes pi / W, i.e. relative to the driving-point response about k_b^2 / (pi K^2) with k_b the free
    bending wavenumber (1e-7 at 5 kHz for the default belt and 20000 modes).

    Parameters
    ----------
    omega : array_like
        Angular frequency [rad/s], >= 0.
    belt : BeltProperties
        The belt (its ``circumference`` and ``width`` are used).
    y0 : float, optional
        Lateral position of the driving point [m], 0 < y0 < W; default W / 2 (belt centre line).
    n_modes : int
        Number of cross modes summed.

    Returns
    -------
    numpy.ndarray of complex
        Y [m/(N s)] (velocity per force), Re Y >= 0 (passive).
    """
    if not isinstance(belt, BeltProperties):
        raise ValueError(f"belt: expected a BeltProperties, got {type(belt).__name__}")
    omega = checks.nonnegative_array("omega", omega)
    n_modes = checks.integer("n_modes", n_modes)
    w_width = belt.width
    y0 = 0.5 * w_width if y0 is None else checks.real("y0", y0)
    if not 0.0 < y0 < w_width:
        raise ValueError(f"y0: expected 0 < y0 < W = {w_width} m, got {y0!r}")
    m = np.arange(1, n_modes + 1, dtype=float)
    ky = m * math.pi / w_width
    weight = np.sin(ky * y0) ** 2
    flat = omega.ravel()
    out = np.empty(flat.size, dtype=complex)
    for i, w in enumerate(flat):
        out[i] = 1j * w * 2.0 / (belt.circumference * w_width) * np.sum(weight * _ring_sums(ky, w, belt))
    return out.reshape(omega.shape)[()]


# --- the belt's part of the element Green's function ---------------------------------------------------------------


def _sinc(x):
    """sin(x) / x (numpy's normalised sinc rescaled; 1 at x = 0)."""
    return np.sinc(np.asarray(x) / math.pi)


class _PolarRule:
    """Quadrature nodes of the quarter plane kx, ky > 0 in polar form: k_j (composite Gauss-Legendre) x theta_i."""

    def __init__(self, k, wk, n_theta):
        self.k = k
        self.wk = wk
        self.theta = (np.arange(n_theta) + 0.5) * (0.5 * math.pi / n_theta)  # midpoint rule (spectral: periodic)
        self.wtheta = 0.5 * math.pi / n_theta


def _gauss_panels(edges, order=8):
    """Composite Gauss-Legendre nodes and weights on the panels between consecutive ``edges``."""
    x, w = np.polynomial.legendre.leggauss(order)
    a, b = edges[:-1, None], edges[1:, None]
    half = 0.5 * (b - a)
    return ((a + b) * 0.5 + half * x).ravel(), (half * w).ravel()


def _belt_wave_band(omega, e, poisson, density, thickness, belt, k0, k_max):
    """Wavenumber bands where Re(Z + K_b) changes sign (free waves of belt + tread) and their relative width.

    Scanned on 600 log-spaced |k| x 24 directions; returns a list of (k_lo, k_hi) and the smallest relative
    half-width eta_eff = |Im D| / |d Re D / d ln k| found at a crossing (D = Z + K_b), or (None, inf) without
    crossings.
    """
    ks = np.geomspace(k0, k_max, 600)
    th = (np.arange(24) + 0.5) * (0.5 * math.pi / 24)
    port = layer_two_port(ks, omega, e, poisson, density, thickness)
    d = belt_impedance(ks[None, :] * np.cos(th)[:, None], ks[None, :] * np.sin(th)[:, None], omega, belt)
    d = d + port["k_base"][None, :]
    re = d.real
    cross = np.signbit(re[:, :-1]) != np.signbit(re[:, 1:])
    if not cross.any():
        return [], math.inf
    i_th, i_k = np.nonzero(cross)
    slope = np.abs(re[i_th, i_k + 1] - re[i_th, i_k]) / (np.log(ks[i_k + 1]) - np.log(ks[i_k]))
    eta = np.abs(d[i_th, i_k].imag) / np.maximum(slope, 1e-300)
    bands = sorted((ks[i] / 1.5, ks[i + 1] * 1.5) for i in np.unique(i_k))
    merged = [list(bands[0])]
    for lo, hi in bands[1:]:
        if lo <= merged[-1][1]:
            merged[-1][1] = max(merged[-1][1], hi)
        else:
            merged.append([lo, hi])
    return [tuple(b) for b in merged], float(np.min(eta))


def _correction_rule(omega, e, poisson, density, thickness, belt, r_max, refine, n_theta, extent=1.0):
    """The (k, theta) rule of :func:`belt_element_frf_correction` at one frequency (see there)."""
    h = thickness
    mu = e / (2.0 * (1.0 + poisson))
    k_s = float((omega * np.sqrt(density / mu)).real)
    k0 = 1e-3 / h
    bands, eta = _belt_wave_band(omega, e, poisson, density, h, belt, k0, max(40.0 / h, 2.0 * k_s + 40.0 / h))
    k_max = extent * max(40.0 / h, 1.5 * k_s + 30.0 / h, max((b[1] for b in bands), default=0.0))
    coarse = 1.0 + 0.04 / refine
    fine = 1.0 + float(np.clip(eta / 3.0, 5e-4, 0.04)) / refine
    width_cap = math.pi / (2.0 * r_max) if r_max > 0 else math.inf
    edges = [0.0, k0]
    while edges[-1] < k_max:
        k = edges[-1]
        ratio = fine if any(lo <= k <= hi for lo, hi in bands) else coarse
        edges.append(min(k * ratio, k + width_cap))
    k, wk = _gauss_panels(np.array(edges))
    if n_theta is None:
        k_eff = min(k_max, 1.5 * k_s + 30.0 / h)  # beyond it the integrand decays like exp(-2 k h)
        n_theta = int(math.ceil(refine * (32 + k_eff * r_max)))
    return _PolarRule(k, wk, n_theta)


def _element_inputs(offsets, element_size, omega, modulus, poisson, density, thickness, belt, extent):
    """The checked inputs of the element corrections: (offsets (n, 2) [m], c [m], omega (m,) [rad/s], E(omega)
    (m,) [Pa], nu, rho [kg/m^3], h [m], extent)."""
    if not isinstance(belt, BeltProperties):
        raise ValueError(f"belt: expected a BeltProperties, got {type(belt).__name__}")
    offsets = np.asarray(offsets, dtype=float).reshape(-1, 2)
    if not np.all(np.isfinite(offsets)):
        raise ValueError("offsets: expected finite values")
    c = checks.real("element_size", element_size, positive=True)
    omega = np.atleast_1d(checks.nonnegative_array("omega", omega))
    e_all = np.broadcast_to(_modulus_array(modulus), omega.shape)
    nu = checks.poisson_ratio(poisson, allow_zero=False)
    rho = checks.real("density", density, positive=True)
    h = checks.real("thickness", thickness, positive=True)
    extent = checks.real("extent", extent, positive=True)
    if extent < 1.0:
        raise ValueError(f"extent: expected >= 1, got {extent!r}")
    return offsets, c, omega, e_all, nu, rho, h, extent


def belt_element_frf_correction(offsets, element_size, omega, modulus, poisson, density, thickness,
                                belt: BeltProperties, refine: float = 1.0, n_theta: int | None = None,
                                extent: float = 1.0):
    r"""The belt's part Delta g of the element Green's function: g_belt = greens.element_frf + Delta g [m/N].

    Delta g(d, w) = 1 / (2 pi)^2 int int P(kx, ky) tau^2 / (Z(kx, ky, w) + K_b(|k|, w)) exp(i k.d) dkx dky,

    P = sinc(kx c / 2) sinc(ky c / 2): the spectrum of a unit force spread uniformly over one c x c element, with
    the displacement taken at the field element's centre -- the convention of :func:`tyreroad.greens.element_frf`
    (its remainder is transformed against P once, not P^2, and its Love term is the point displacement of the
    loaded square), so element_frf + Delta g is the element FRF of tread + belt (H_belt = H_rigid + tau^2 /
    (Z + K_b), module docstring). Time convention exp(+i w t); a passive tread + belt has Im(g + Delta g) <= 0
    at offset 0.

    Representation: the infinite plane (a): the belt taken as wide and long compared with the contact patch,
    the ring period and the simply supported width not imposed (the tread's coupling is then exact for a
    laterally infinite layer; the belt's bed makes the integrand smooth at k -> 0 and its loss broadens the
    free-wave peaks). Measured against the ring-and-strip mode sum (b), :func:`belt_element_frf_correction_ring`
    (benchmarks/belt_element_convergence.py), the plane is NOT adequate for the default belt below about 2 kHz:
    the belt's static deflection spreads over sqrt(T_x / s) ~ 0.16 m, its whole width, and its waves are long,
    so the two differ by 6-28 % of the whole element FRF at 20-200 Hz, 1.2 % at 1 kHz, 0.04 % at 5 kHz. Use (b)
    for the tyre; this function is the wide-belt limit and an independent check of (b) at high frequency.

    Quadrature: P, tau^2 / (Z + K_b) and cos(kx x) cos(ky y) are even in kx and in ky, so the integral is four
    times the quarter plane, written in polar coordinates k (kx, ky) = k (cos theta, sin theta):
    (4 / (2 pi)^2) int_0^{pi/2} dtheta int_0^inf k dk .... theta: midpoint rule with ``n_theta`` nodes (spectral:
    the theta integrand is smooth and, extended, periodic and even; default 32 + k_eff r_max, k_eff =
    1.5 k_s + 30 / h, times ``refine``). k: 8-point Gauss-Legendre panels, one on [0, k0 = 1e-3 / h], then
    geometric panels, fine (ratio 1 + eta_eff / 3, clipped to 1.0005 ... 1.04) in the bands where Re(Z + K_b)
    changes sign (the free waves of belt + tread, found by a scan over k and 24 directions, widened by 1.5 each
    side; eta_eff their smallest relative half-width in ln k: the belt's loss is on bending and bed only, the
    tension is lossless, so it can be well below eta) and coarse (ratio 1.04) elsewhere, no panel wider than
    pi / (2 r_max), up to k_max = max(40 / h, 1.5 k_s + 30 / h, the top of the wave bands) (tau decays like
    exp(-k h) beyond the tread's shear wavenumber k_s, Z grows like k^4); ``refine`` divides the ratios' excess
    (and multiplies the default n_theta), ``extent`` multiplies k_max. tau and K_b depend on |k| only and are evaluated once per k node and frequency.

    Parameters
    ----------
    offsets : array_like
        Offsets (x, y) of the field element centres [m], (n, 2); x circumferential, y lateral.
    element_size : float
        Element size c [m].
    omega : array_like
        Angular frequencies [rad/s], >= 0.
    modulus : array_like
        Complex Young's modulus of the tread E(omega) [Pa], broadcastable with ``omega``.
    poisson, density, thickness : float
        Tread Poisson's ratio [-], density [kg/m^3], thickness h [m].
    belt : BeltProperties
        The belt (its circumference and width are not used: infinite plane).
    refine : float
        Resolution factor (>= 1) for convergence checks: panel ratios' excess / refine, default n_theta x refine.
    extent : float
        Extent factor (>= 1): k_max x extent, for convergence checks.
    n_theta : int, optional
        Directions in the quarter plane (default: see above).

    Returns
    -------
    numpy.ndarray
        Complex Delta g, shape (len(omega), n) [m/N].
    """
    offsets, c, omega, e_all, nu, rho, h, extent = _element_inputs(offsets, element_size, omega, modulus, poisson,
                                                                   density, thickness, belt, extent)
    refine = checks.real("refine", refine, positive=True)
    if refine < 1.0:
        raise ValueError(f"refine: expected >= 1, got {refine!r}")
    if n_theta is not None:
        n_theta = checks.integer("n_theta", n_theta)
        if n_theta < 1:
            raise ValueError(f"n_theta: expected >= 1, got {n_theta!r}")
    ax, ay = np.abs(offsets[:, 0]), np.abs(offsets[:, 1])
    r_max = float(np.hypot(ax, ay).max(initial=0.0))
    out = np.empty((omega.size, len(offsets)), dtype=complex)
    for i, (w, e) in enumerate(zip(omega, e_all)):
        rule = _correction_rule(w, e, nu, rho, h, belt, r_max, refine, n_theta, extent)
        port = layer_two_port(rule.k, w, e, nu, rho, h)
        radial = (4.0 / (2.0 * math.pi) ** 2) * rule.wtheta * rule.wk * rule.k * port["tau"] ** 2
        # direction chunks bound the (theta, k) temporaries
        step = max(1, (1 << 20) // rule.k.size)
        acc = np.zeros(len(offsets), dtype=complex)
        for start in range(0, rule.theta.size, step):
            th = rule.theta[start:start + step, None]
            kx, ky = rule.k[None, :] * np.cos(th), rule.k[None, :] * np.sin(th)
            z = belt_impedance(kx, ky, w, belt)
            f = (radial * _sinc(0.5 * c * kx) * _sinc(0.5 * c * ky) / (z + port["k_base"])).ravel()
            if r_max == 0.0:
                acc += f.sum()
                continue
            kxf, kyf = kx.ravel(), ky.ravel()
            for j0 in range(0, len(offsets), 16):
                js = slice(j0, j0 + 16)
                phase = np.cos(np.outer(kxf, ax[js])) * np.cos(np.outer(kyf, ay[js]))
                acc[js] += f @ phase
        out[i] = acc
    return out


def ring_truncation(omega, modulus, poisson, density, thickness, extent=1.0) -> float:
    """k_max [rad/m] of the ring-and-strip mode sums: extent x max(25 / h, 1.5 k_s + 20 / h), k_s the tread's shear
    wavenumber, the largest over the given frequencies (tau decays like exp(-k h) beyond k_s, Z grows like k^4).

    The one truncation rule of :func:`belt_element_frf_correction_ring`, :func:`tyreroad.belt_fit.belt_correction_table`
    and :mod:`tyreroad.belt_vibration`.
    """
    mu = np.asarray(modulus) / (2.0 * (1.0 + poisson))
    k_s = np.asarray(omega * np.sqrt(density / mu)).real
    return float(extent * np.max(np.maximum(25.0 / thickness, 1.5 * k_s + 20.0 / thickness), initial=0.0))


def ring_modes(belt: BeltProperties, k_max: float, k_max_y: float | None = None):
    """The ring-and-strip modes of a load on the belt's centre line: kx_n = 2 pi n / L (0 <= n, |kx| <= k_max),
    ky_m = m pi / W (odd m, ky <= k_max_y, default k_max; sin(m pi / 2)^2 = 1), and the weight (n = 0 ? 1 : 2) 2 / (L W)
    of each n (the +-n pair summed as a cosine).

    Returns
    -------
    kx, ky : numpy.ndarray
        [rad/m].
    weight : numpy.ndarray
        (len(kx), 1) [1/m^2].
    """
    k_max_y = k_max if k_max_y is None else k_max_y
    n = np.arange(0, int(k_max * belt.circumference / (2.0 * math.pi)) + 1, dtype=float)
    m = np.arange(1, int(k_max_y * belt.width / math.pi) + 1, 2, dtype=float)
    weight = np.where(n == 0, 1.0, 2.0)[:, None] * (2.0 / (belt.circumference * belt.width))
    return 2.0 * math.pi * n / belt.circumference, m * math.pi / belt.width, weight


def _ring_strip_sum(offsets, element_size, omega, belt, k_max, port, k_max_y=None):
    """Ring-and-strip mode sum of the element correction at one frequency; ``port(k)`` -> (tau, K_b) arrays.

    |kx| <= k_max, ky <= k_max_y (default k_max)."""
    c = element_size
    kx, ky, weight = ring_modes(belt, k_max, k_max_y)
    kxg, kyg = np.meshgrid(kx, ky, indexing="ij")
    tau, kb = port(np.hypot(kxg, kyg))
    f = weight * _sinc(0.5 * c * kxg) * _sinc(0.5 * c * kyg) * tau**2 / (belt_impedance(kxg, kyg, omega, belt) + kb)
    ax, ay = np.abs(offsets[:, 0]), np.abs(offsets[:, 1])
    # sum_n over +-n: cos(kx dx); odd m: sin(ky (W/2 + dy)) sin(ky W/2) = cos(ky dy)
    return np.einsum("nm,nj,mj->j", f, np.cos(np.outer(kx, ax)), np.cos(np.outer(ky, ay)))


def belt_element_frf_correction_ring(offsets, element_size, omega, modulus, poisson, density, thickness,
                                     belt: BeltProperties, extent: float = 1.0):
    r"""The belt's part Delta g of the element Green's function on the ring and strip [m/N] (representation (b)).

    Delta g(d, w) = (2 / (L W)) sum_{n in Z} sum_{m odd} P(kx_n, ky_m) tau^2 / (Z(kx_n, ky_m, w) + K_b(|k|, w))
                    cos(kx_n d_x) cos(ky_m d_y),   kx_n = 2 pi n / L,  ky_m = m pi / W,

    for a loaded element on the belt's centre line y0 = W / 2: the belt periodic around its circumference L, of
    width W with simply supported edges (modes sin(ky y)); the element spectrum P = sinc(kx c / 2) sinc(ky c / 2)
    (the projection of the uniform c x c load on sin(ky y) is sin(ky y0) sinc(ky c / 2), with sin(ky y0) = +-1
    for odd m and 0 for even m), the displacement at the field element's centre y0 + d_y
    (sin(ky (y0 + d_y)) sin(ky y0) = cos(ky d_y) for odd m): element_frf's convention, so that
    :func:`tyreroad.greens.element_frf` + Delta g is the element FRF of tread + belt. The tread is coupled mode by
    mode with its infinite-layer two-port tau(|k|), K_b(|k|) (exact for a tread whose lateral edges slide on
    symmetry planes at the belt's edges; an approximation for a real tread shoulder). Off the centre line the
    response is not a function of the offset alone; this function serves a contact patch centred on the belt.

    The sum is a discrete mode sum (no peak to resolve: the loss enters each mode); it is truncated at
    |kx|, ky <= k_max = extent x max(25 / h, 1.5 k_s + 20 / h) (tau^2 decays like exp(-2 k h) beyond the tread's
    shear wavenumber k_s, Z grows like k^4: doubling k_max changes Delta g by < 1e-14 relative at 100 Hz - 5 kHz).
    Cost: about (k_max^2 L W / (4 pi^2)) two-port evaluations per frequency (2.4e5 for the default tyre).

    Why this representation (benchmarks/belt_element_convergence.py): with the default belt the static
    deflection under a point load spreads over sqrt(T_x / s) ~ 0.16 m, the belt width, and the free waves below
    ~1 kHz are longer than 0.1 m, so the infinite plane (:func:`belt_element_frf_correction`) misses the edges
    and the ring: it differs from this sum by 6-28 % of the whole element FRF at 20-200 Hz, 1.2 % at 1 kHz,
    0.04 % at 5 kHz.

    Parameters
    ----------
    offsets : array_like
        Offsets (x, y) of the field element centres from the loaded element's [m], (n, 2); x circumferential.
    element_size : float
        Element size c [m].
    omega : array_like
        Angular frequencies [rad/s], >= 0.
    modulus : array_like
        Complex Young's modulus of the tread E(omega) [Pa], broadcastable with ``omega``.
    poisson, density, thickness : float
        Tread Poisson's ratio [-], density [kg/m^3], thickness h [m].
    belt : BeltProperties
        The belt (its circumference L and width W are used).
    extent : float
        k_max factor (>= 1), for convergence checks.

    Returns
    -------
    numpy.ndarray
        Complex Delta g, shape (len(omega), n) [m/N].
    """
    offsets, c, omega, e_all, nu, rho, h, extent = _element_inputs(offsets, element_size, omega, modulus, poisson,
                                                                   density, thickness, belt, extent)
    if np.any(np.abs(offsets[:, 1]) >= 0.5 * belt.width):
        raise ValueError("offsets: lateral offsets must stay inside the belt (|y| < W / 2)")
    out = np.empty((omega.size, len(offsets)), dtype=complex)
    for i, (w, e) in enumerate(zip(omega, e_all)):
        k_max = ring_truncation(w, e, nu, rho, h, extent)

        def port(k, w=w, e=e):
            p = layer_two_port(k, w, e, nu, rho, h)
            return p["tau"], p["k_base"]

        out[i] = _ring_strip_sum(offsets, c, w, belt, k_max, port)
    return out
