r"""Visco-elastic tread materials: complex modulus models, presets and variants (SPEC section 5).

Time convention exp(+i w t): a passive (causal, dissipative) material has Im E(w) >= 0 for w > 0, and the
loss factor is eta(w) = Im E / Re E.

Models (config key ``model``)
-----------------------------
``fractional_kelvin_voigt``
    E(w) = E0 + E1 (i w / w1)^alpha, w1 = 2 pi f1, with the principal branch
    (i w)^alpha = w^alpha exp(i pi alpha / 2). Causal (analytic in the lower half w-plane for exp(+iwt))
    and dissipative for 0 < alpha < 1; eta grows monotonically with w. Keys E0 [Pa], E1 [Pa],
    alpha [-] (0 < alpha < 1), f1 [Hz].
``generalized_maxwell``
    Prony series E(w) = E_inf + sum_k E_k i w tau_k / (1 + i w tau_k). Keys E_inf [Pa], moduli [Pa, list],
    relaxation_times [s, list of the same length].
``table``
    Measured (f, E', eta) points, keys frequency [Hz, list, increasing], storage_modulus [Pa, list],
    loss_factor [-, list]; optional fit_tolerance [-] (default 0.02). The table is replaced by a causal
    generalised Maxwell model with fixed relaxation times (10 per decade, log-spaced, from
    1 / (2 pi f_max) / 10 to 10 / (2 pi f_min)) and non-negative moduli found by non-negative least
    squares on E' and E'' jointly, each point weighted by 1 / |E(f_j)| (relative error). The largest
    relative error |E_fit - E_table| / |E_table| over the points is logged and must not exceed
    fit_tolerance (else ValueError naming the preset). Outside the table's frequency range the
    fitted model is a causal extrapolation (constant E' and vanishing eta far outside). With fixed
    relaxation times the error of representing one Debye peak falls like the squared grid spacing
    (about 5e-4 relative at 10 per decade), which is far below the scatter of measured DMA data.
    The points may come from ``table_file`` (CSV, :func:`read_dma_table`; read when the preset is built,
    so at planning time, and inlined into the resolved preset).
    Temperature (issue 25): with ``reference_temperature`` T_ref [degC] (the master curve's) and ``shift``
    (:func:`shift_factor`: WLF ``{model: wlf, C1, C2}`` or ``{model: arrhenius, activation_energy}``) the
    preset runs at ``temperature`` T [degC] (default T_ref) as E(f; T) = b_T E_ref(f a_T): the fit's
    relaxation times are multiplied by a_T, so the shifted material is the same causal series. The vertical
    factor b_T = (T + 273.15) / (T_ref + 273.15) applies only with ``vertical_shift: true`` (default false:
    master curves are usually built and their shift factors fitted with the horizontal shift alone, applying
    b_T to such a curve counts the temperature twice, and b_T, the entropy elasticity of the rubbery state,
    is wrong in the glassy region); it scales a numeric ``quasi_static_modulus`` too. ``temperatures: [T,
    ...]`` expands (:func:`expand_temperatures`) into the variants ``<name>-T<T:g>: {base: <name>,
    temperature: T}``; a variant's own ``temperature`` wins over its base's.

Variants
--------
``loss_scale`` s (the paper's method, constant |E|):
E_s(w) = |E(w)| (1 + i s eta(w)) / sqrt(1 + s^2 eta(w)^2), so |E_s| = |E| and eta_s = s eta exactly.
That variant is not a material: holding |E| while scaling eta breaks Kramers-Kronig, and what a
time-domain run sees of it depends on how its negative-time response is cut off (issue 24).
``loss_anchor`` f_a [Hz] makes the loss variant causal by scaling the phase instead (issue 24):
E_s(w) = |E(2 pi f_a)|^(1 - s) E(w)^s (principal power), so arg E_s = s arg E (eta_s = tan(s arctan eta))
and |E_s(2 pi f_a)| = |E(2 pi f_a)|: the anchor is the frequency whose |E| is kept (0: the relaxed
modulus, E_s(0) = E(0)). E^s is analytic wherever E is, so E_s is causal; it is passive while
s arg E < pi/2 at every frequency (checked when the preset is built).
A variant may also set its own ``quasi_static_modulus`` (springs and quasi-static kernel only; E(w) and the
dynamic kernel stay the base's): claim 6's springs control. ``density_scale`` r: rho -> r rho. ``modulus_scale`` k: E -> k E at every frequency (the loss factor
unchanged; a numeric quasi_static_modulus is scaled too): the control of claim 6's sign check, which changes
the storage modulus alone (issue 24). A preset ``{base: <name>, loss_scale: s, density_scale: r}`` copies the
base preset (resolved recursively) and multiplies its scales; the scales may also be set on a root preset.

Causality (:attr:`Material.is_causal`): every material is causal except a loss variant without an anchor
(the seed's definition). Such a variant is fine for frequency-domain quantities (K*(f) about the relaxed
state), and refused for time-domain runs at planning time (:func:`causality_error`, issue 24).

Quasi-static modulus (key ``quasi_static_modulus``): ``zero_frequency`` (the default) is Re E(w -> 0) of the
(scaled) model -- E0 for the fractional model, E_inf for the Maxwell model; or a number in Pa.

Laplace domain (convolution-quadrature kernels, issue 23): ``laplace_modulus(s)`` gives E(s) [Pa] for complex
s with Re s >= 0, the analytic continuation of E(w) with E(i w) = modulus(w): fractional Kelvin-Voigt
E0 + E1 (s / w1)^alpha (principal branch, |arg s| <= pi/2), generalised Maxwell E_inf + sum_k E_k s tau_k /
(1 + s tau_k). A ``table`` preset continues through its causal generalised Maxwell fit (the fit, not the raw
points, is the material everywhere in the pipeline, on the frequency axis too). A loss-scaled variant
(loss_scale != 1) has no continuation and :meth:`Material.laplace_modulus` refuses it: |E| held constant while
eta is scaled is not the boundary value of a function analytic in Re s > 0 (it breaks Kramers-Kronig).
For both models arg E(s) lies between 0 and arg s (each term maps the right half plane into that sector), so
Re E(s) > 0 and E is real and positive for real s > 0.

Derived moduli (SPEC 1): mu = E / (2 (1 + nu)), M = E (1 - nu) / ((1 + nu)(1 - 2 nu)), E* = E / (1 - nu^2).

References
----------
Bagley & Torvik (1983), J. Rheol. 27, 201 (fractional models). doi:10.1122/1.549724
Park & Schapery (1999), Int. J. Solids Struct. 36, 1653 (Prony series fitting). doi:10.1016/S0020-7683(98)00055-9
"""

from __future__ import annotations

import copy
import logging
import math
import re
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np
from scipy.optimize import nnls

logger = logging.getLogger(__name__)

__all__ = [
    "FractionalKelvinVoigt",
    "GeneralizedMaxwell",
    "Material",
    "MODELS",
    "material_from_config",
    "path_safe",
    "causality_error",
    "shear_modulus",
    "pwave_modulus",
    "plane_strain_modulus",
    "fit_generalized_maxwell",
    "shift_factor",
    "read_dma_table",
    "temperature_variant_name",
    "expand_temperatures",
    "compound_and_temperature",
    "GAS_CONSTANT",
]

MODELS = ("fractional_kelvin_voigt", "generalized_maxwell", "table")
_MODEL_KEYS = {
    "fractional_kelvin_voigt": ("E0", "E1", "alpha", "f1"),
    "generalized_maxwell": ("E_inf", "moduli", "relaxation_times"),
    "table": ("frequency", "storage_modulus", "loss_factor"),
}
_OPTIONAL_MODEL_KEYS = {
    "table": ("fit_tolerance", "table_file", "reference_temperature", "shift", "temperature", "temperatures",
              "vertical_shift"),
}
#: A table preset gives its points either inline (these keys) or in ``table_file`` (a CSV file).
_TABLE_DATA_KEYS = ("frequency", "storage_modulus", "loss_factor")
#: Gas constant [J/(mol K)] (CODATA 2018, exact) and 0 degC [K].
GAS_CONSTANT = 8.314462618
ZERO_CELSIUS = 273.15
SHIFT_MODELS = ("wlf", "arrhenius")
_COMMON_KEYS = ("model", "poisson_ratio", "density", "thickness", "quasi_static_modulus")
_SCALE_KEYS = ("loss_scale", "density_scale", "loss_anchor", "modulus_scale")
_VARIANT_KEYS = ("base",) + _SCALE_KEYS + ("quasi_static_modulus", "temperature")
_TABLE_TERMS_PER_DECADE = 10
_TABLE_DEFAULT_FIT_TOLERANCE = 0.02
_PATH_SAFE = re.compile(r"[A-Za-z0-9][A-Za-z0-9.-]*")


def path_safe(name) -> bool:
    """True if ``name`` can be a wildcard value and a path component.

    Allowed: letters, digits, '-' and '.', starting with a letter or digit (so never '', '.', '..'),
    no '_' (Snakemake wildcard separator in file names) and no '/'.
    """
    return isinstance(name, str) and _PATH_SAFE.fullmatch(name) is not None


def shear_modulus(modulus, poisson):
    """Shear modulus mu = E / (2 (1 + nu)) [Pa]."""
    return np.asarray(modulus) / (2.0 * (1.0 + float(poisson)))


def pwave_modulus(modulus, poisson):
    """Constrained (P-wave) modulus M = E (1 - nu) / ((1 + nu)(1 - 2 nu)) [Pa]."""
    nu = float(poisson)
    return np.asarray(modulus) * (1.0 - nu) / ((1.0 + nu) * (1.0 - 2.0 * nu))


def plane_strain_modulus(modulus, poisson):
    """Plane-strain (contact) modulus E* = E / (1 - nu^2) [Pa]."""
    nu = float(poisson)
    return np.asarray(modulus) / (1.0 - nu * nu)


def _omega_array(omega):
    w = np.asarray(omega, dtype=float)
    if np.any(~np.isfinite(w)) or np.any(w < 0):
        raise ValueError("angular frequency omega must be finite and >= 0 [rad/s]")
    return w


def _laplace_array(s):
    z = np.asarray(s, dtype=complex)
    if np.any(~np.isfinite(z)) or np.any(z.real < 0):
        raise ValueError("Laplace frequency s must be finite with Re s >= 0 [rad/s] (the closed right half plane)")
    return z


@dataclass(frozen=True)
class FractionalKelvinVoigt:
    """E(w) = E0 + E1 (i w / (2 pi f1))^alpha.

    Parameters
    ----------
    E0 : float
        Relaxed (zero-frequency) modulus [Pa].
    E1 : float
        Modulus of the fractional element at w = 2 pi f1 [Pa].
    alpha : float
        Fractional order [-], 0 < alpha < 1.
    f1 : float
        Reference frequency [Hz].
    """

    E0: float
    E1: float
    alpha: float
    f1: float

    def modulus(self, omega):
        """Complex Young's modulus [Pa] at angular frequencies ``omega`` [rad/s] (>= 0)."""
        w = _omega_array(omega)
        power = (w / (2.0 * np.pi * self.f1)) ** self.alpha
        return self.E0 + self.E1 * power * np.exp(0.5j * np.pi * self.alpha)

    def laplace_modulus(self, s):
        """Young's modulus E(s) = E0 + E1 (s / w1)^alpha [Pa] at complex Laplace frequencies ``s`` [rad/s].

        The analytic continuation of :meth:`modulus`: E(i w) = modulus(w). Principal branch,
        (s / w1)^alpha = exp(alpha log(s / w1)) with |arg s| <= pi/2 (the cut of log lies on the negative
        real axis, outside the domain); E(0) = E0.

        Parameters
        ----------
        s : array_like of complex
            Laplace frequencies [rad/s], finite, Re s >= 0.

        Returns
        -------
        numpy.ndarray of complex
            E(s) [Pa]; real and > E0 for real s > 0, E(conj s) = conj E(s).
        """
        z = _laplace_array(s)
        zs = z / (2.0 * np.pi * self.f1)
        nonzero = zs != 0
        with np.errstate(divide="ignore", invalid="ignore"):
            power = np.where(nonzero, np.exp(self.alpha * np.log(np.where(nonzero, zs, 1.0))), 0.0)
        return (self.E0 + self.E1 * power)[()]


@dataclass(frozen=True)
class GeneralizedMaxwell:
    """Prony series E(w) = E_inf + sum_k E_k i w tau_k / (1 + i w tau_k).

    Parameters
    ----------
    E_inf : float
        Long-time (relaxed) modulus [Pa].
    moduli : tuple of float
        Maxwell element moduli E_k [Pa], >= 0.
    relaxation_times : tuple of float
        Relaxation times tau_k [s], > 0.
    """

    E_inf: float
    moduli: tuple
    relaxation_times: tuple

    def modulus(self, omega):
        """Complex Young's modulus [Pa] at angular frequencies ``omega`` [rad/s] (>= 0)."""
        w = _omega_array(omega)
        e = np.full(w.shape, complex(self.E_inf))
        for ek, tau in zip(self.moduli, self.relaxation_times):
            iwt = 1j * w * tau
            e = e + ek * iwt / (1.0 + iwt)
        return e

    def laplace_modulus(self, s):
        """Young's modulus E(s) = E_inf + sum_k E_k s tau_k / (1 + s tau_k) [Pa] at complex ``s`` [rad/s].

        The analytic continuation of :meth:`modulus` (i w tau -> s tau): E(i w) = modulus(w), E(0) = E_inf.

        Parameters
        ----------
        s : array_like of complex
            Laplace frequencies [rad/s], finite, Re s >= 0.

        Returns
        -------
        numpy.ndarray of complex
            E(s) [Pa]; real and >= E_inf for real s > 0, E(conj s) = conj E(s).
        """
        z = _laplace_array(s)
        e = np.full(z.shape, complex(self.E_inf))
        for ek, tau in zip(self.moduli, self.relaxation_times):
            st = z * tau
            e = e + ek * st / (1.0 + st)
        return e[()]


@dataclass(frozen=True)
class Material:
    """A tread material preset: complex modulus model, Poisson's ratio, density and layer thickness.

    Parameters
    ----------
    name : str
        Preset name (the ``{material}`` wildcard).
    poisson : float
        Poisson's ratio nu [-], frequency independent.
    density : float
        Density rho [kg/m^3] (density scaling already applied).
    thickness : float
        Layer thickness h [m].
    model : FractionalKelvinVoigt or GeneralizedMaxwell
        Unscaled modulus model.
    loss_scale : float
        Loss factor scale s [-] (1 = unchanged): at constant |E| (the seed's definition) or, with a
        ``loss_anchor``, by scaling the phase (causal).
    loss_anchor : float or None
        f_a [Hz] whose |E| a causal loss variant keeps; None: the seed's constant-|E| scaling.
    quasi_static : str or float
        ``"zero_frequency"`` or a modulus [Pa].
    config : dict
        The resolved preset (no ``base``; scales folded in) for provenance. Not part of equality.
    modulus_scale : float
        k [-]: E -> k E at every frequency (loss factor unchanged).
    temperature : float or None
        Study temperature [degC] of a ``table`` preset with a ``reference_temperature`` (None otherwise).
    shift_factor : float
        Horizontal shift factor a_T [-] already applied to ``model`` (1 at the reference temperature).
    vertical_shift_factor : float
        b_T [-] already applied to ``model`` (1 unless ``vertical_shift: true``).
    lineage : tuple of str
        Preset names from this one down to its root preset (provenance; not part of equality).
    """

    name: str
    poisson: float
    density: float
    thickness: float
    model: Any
    loss_scale: float = 1.0
    quasi_static: Any = "zero_frequency"
    loss_anchor: float | None = None
    modulus_scale: float = 1.0
    temperature: float | None = None
    shift_factor: float = 1.0
    vertical_shift_factor: float = 1.0
    config: dict = field(default_factory=dict, compare=False, hash=False, repr=False)
    lineage: tuple = field(default=(), compare=False)

    def modulus(self, omega):
        """Complex Young's modulus E(w) [Pa] for angular frequencies ``omega`` [rad/s] (>= 0).

        Im E >= 0 for w > 0 (exp(+i w t)). With loss scaling s:
        E_s = |E| (1 + i s eta) / sqrt(1 + s^2 eta^2).
        """
        e = self.model.modulus(omega)
        k = self.modulus_scale
        if self.loss_scale == 1.0:
            return k * e
        if self.loss_anchor is not None:
            return k * self._anchor_modulus() ** (1.0 - self.loss_scale) * e**self.loss_scale
        eta = e.imag / e.real
        s_eta = self.loss_scale * eta
        return k * np.abs(e) * (1.0 + 1j * s_eta) / np.sqrt(1.0 + s_eta * s_eta)

    def modulus_at(self, frequency: float) -> complex:
        """E at one frequency [Hz] as a complex scalar [Pa]: the quasi-static modulus at 0 (the FE solves and
        modal forms take one modulus per solve)."""
        f = float(frequency)
        if f == 0.0:
            return complex(self.quasi_static_modulus)
        return complex(np.ravel(self.modulus(2.0 * np.pi * f))[0])

    def undamped_frequencies(self, lam) -> np.ndarray:
        """sqrt(Re E(f) lambda) / 2 pi [Hz] of modes whose stiffness scales with E (K_1 phi = lambda M phi,
        lambda [1/(Pa s^2)]: a structure of this material with a frequency-independent Poisson's ratio), solved by
        fixed point from the quasi-static modulus; in lambda's order."""
        lam = np.asarray(lam, dtype=float)
        f = np.sqrt(float(self.quasi_static_modulus) * lam) / (2 * np.pi)
        for _ in range(30):
            f = np.sqrt(np.real(np.asarray(self.modulus(2 * np.pi * f))) * lam) / (2 * np.pi)
        return f

    @property
    def is_causal(self) -> bool:
        """False only for the seed's loss variant (loss_scale != 1 at constant |E|, no ``loss_anchor``):
        it breaks Kramers-Kronig, so a time-domain run of it depends on how its negative-time response
        is cut off (issue 24). Every model and every phase-scaled (anchored) variant is causal."""
        return self.loss_scale == 1.0 or self.loss_anchor is not None

    def _anchor_modulus(self) -> float:
        """|E(2 pi f_a)| of the unscaled model [Pa] (the modulus a causal loss variant keeps)."""
        return float(np.abs(self.model.modulus(2.0 * np.pi * float(self.loss_anchor))))

    def laplace_modulus(self, s):
        """Young's modulus E(s) [Pa] at complex Laplace frequencies ``s`` [rad/s], Re s >= 0.

        The analytic continuation of :meth:`modulus`, E(i w) = modulus(w), for convolution-quadrature
        kernels, which evaluate the layer's transfer function off the frequency axis. A ``table`` preset
        continues through its causal generalised Maxwell fit (its ``model``, which is also what
        :meth:`modulus` returns on the axis). ``density_scale`` does not enter E.

        Parameters
        ----------
        s : array_like of complex
            Laplace frequencies [rad/s], finite, Re s >= 0.

        Returns
        -------
        numpy.ndarray of complex
            E(s) [Pa].

        Raises
        ------
        ValueError
            For a loss-scaled variant (loss_scale != 1): E_s(w) = |E| (1 + i s eta) / sqrt(1 + s^2 eta^2)
            keeps |E| and scales eta, which no function analytic in Re s > 0 does (Kramers-Kronig ties
            the loss to the frequency dependence of the storage modulus), so E_s has no continuation to
            complex s. Also for a model without an analytic continuation (no ``laplace_modulus``), and for
            s outside the closed right half plane.
        """
        if self.loss_scale != 1.0 and self.loss_anchor is not None:
            continuation = getattr(self.model, "laplace_modulus", None)
            if continuation is None:
                raise ValueError(f"material {self.name!r}: its modulus model {type(self.model).__name__} has no "
                                 "laplace_modulus")
            return (self.modulus_scale * self._anchor_modulus() ** (1.0 - self.loss_scale)
                    * continuation(s) ** self.loss_scale)
        if self.loss_scale != 1.0:
            raise ValueError(
                f"material {self.name!r}: no Laplace-domain modulus E(s): loss_scale = {self.loss_scale:g} scales "
                "the loss factor at constant |E|, which is not the boundary value of a function analytic in "
                "Re s > 0 (it breaks Kramers-Kronig), so E(w) has no analytic continuation to complex s; "
                "set materials.<name>.loss_anchor (a frequency whose |E| is kept) for the causal variant"
            )
        continuation = getattr(self.model, "laplace_modulus", None)
        if continuation is None:
            raise ValueError(
                f"material {self.name!r}: its modulus model {type(self.model).__name__} gives E(w) on the "
                "frequency axis only (no laplace_modulus), so E(s) at complex s is not defined"
            )
        return self.modulus_scale * continuation(s)

    def loss_factor(self, omega):
        """Loss factor eta(w) = Im E / Re E [-]."""
        e = self.modulus(omega)
        return e.imag / e.real

    def storage_modulus(self, omega):
        """Storage modulus Re E(w) [Pa]."""
        return self.modulus(omega).real

    def shear_modulus(self, omega):
        """Complex shear modulus mu(w) = E / (2 (1 + nu)) [Pa]."""
        return shear_modulus(self.modulus(omega), self.poisson)

    def pwave_modulus(self, omega):
        """Complex P-wave (constrained) modulus M(w) = E (1 - nu) / ((1 + nu)(1 - 2 nu)) [Pa]."""
        return pwave_modulus(self.modulus(omega), self.poisson)

    def pwave_speed(self, omega):
        """Complex P-wave speed c_p(w) = sqrt(M / rho) [m/s]."""
        return np.sqrt(self.pwave_modulus(omega) / self.density)

    def shear_speed(self, omega):
        """Complex shear wave speed c_s(w) = sqrt(mu / rho) [m/s]."""
        return np.sqrt(self.shear_modulus(omega) / self.density)

    @property
    def quasi_static_modulus(self) -> float:
        """Modulus used for the quasi-static kernel and (by default) the contact springs [Pa]."""
        if self.quasi_static == "zero_frequency":
            return float(np.real(self.modulus(0.0)))
        return float(self.quasi_static) * self.modulus_scale


# ----------------------------------------------------------------------------------------------------
# table fit


def relaxation_time_grid(frequency, terms_per_decade: int) -> np.ndarray:
    """Fixed, log-spaced relaxation times [s] for a table on ``frequency`` [Hz] (increasing):
    ``terms_per_decade`` per decade from 1 / (2 pi f_max) / 10 to 10 / (2 pi f_min), at least two."""
    lo = math.log10(1.0 / (2.0 * np.pi * frequency[-1]) / 10.0)
    hi = math.log10(10.0 / (2.0 * np.pi * frequency[0]))
    return np.logspace(lo, hi, max(2, int(math.ceil((hi - lo) * terms_per_decade)) + 1))


def scaled_nnls(a: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Non-negative least squares min |a x - rhs|, x >= 0, with the columns of ``a`` scaled to unit norm
    first (keeps nnls well conditioned when the rows are already weighted to O(1))."""
    col = np.linalg.norm(a, axis=0)
    col[col == 0] = 1.0
    coef, _ = nnls(a / col, rhs, maxiter=50 * a.shape[1])
    return coef / col


def fit_generalized_maxwell(frequency, storage_modulus, loss_factor, terms_per_decade=_TABLE_TERMS_PER_DECADE):
    """Fit a causal generalised Maxwell model to (f, E', eta) points by non-negative least squares.

    Relaxation times are fixed and log-spaced (``terms_per_decade`` per decade) from 1 / (2 pi f_max) / 10 to
    10 / (2 pi f_min); E_inf and the E_k are non-negative and minimise
    sum_j (|E_fit(f_j) - E_j| / |E_j|)^2 over E' and E'' jointly.

    Parameters
    ----------
    frequency : array_like
        Frequencies [Hz], strictly increasing, > 0.
    storage_modulus : array_like
        E'(f) [Pa], > 0.
    loss_factor : array_like
        eta(f) [-], >= 0.
    terms_per_decade : int
        Number of relaxation times per decade.

    Returns
    -------
    model : GeneralizedMaxwell
        The fitted model (terms with zero modulus dropped).
    max_relative_error : float
        max_j |E_fit(f_j) - E_j| / |E_j| [-].
    rms_relative_error : float
        Root mean square of the same [-].

    References
    ----------
    Park & Schapery (1999), Int. J. Solids Struct. 36, 1653. doi:10.1016/S0020-7683(98)00055-9
    """
    f = np.asarray(frequency, dtype=float)
    e1 = np.asarray(storage_modulus, dtype=float)
    e2 = e1 * np.asarray(loss_factor, dtype=float)
    tau = relaxation_time_grid(f, terms_per_decade)
    wt = 2.0 * np.pi * f[:, None] * tau[None, :]
    weight = 1.0 / np.hypot(e1, e2)
    a_real = np.hstack([np.ones((f.size, 1)), wt**2 / (1.0 + wt**2)]) * weight[:, None]
    a_imag = np.hstack([np.zeros((f.size, 1)), wt / (1.0 + wt**2)]) * weight[:, None]
    coef = scaled_nnls(np.vstack([a_real, a_imag]), np.concatenate([e1 * weight, e2 * weight]))
    keep = coef[1:] > 0
    model = GeneralizedMaxwell(
        E_inf=float(coef[0]),
        moduli=tuple(float(v) for v in coef[1:][keep]),
        relaxation_times=tuple(float(v) for v in tau[keep]),
    )
    rel = np.abs(model.modulus(2.0 * np.pi * f) - (e1 + 1j * e2)) * weight
    return model, float(rel.max()), float(np.sqrt(np.mean(rel**2)))


# ----------------------------------------------------------------------------------------------------
# time-temperature superposition


def shift_factor(shift: Mapping[str, Any], temperature: float, reference_temperature: float) -> float:
    """Horizontal time-temperature shift factor a_T [-] of a master curve.

    The modulus at temperature T is E(f; T) = E_ref(f a_T): a_T > 1 below the reference temperature
    (the compound is stiffer and more lossy, as at a higher frequency), a_T = 1 at T = T_ref.

    Parameters
    ----------
    shift : Mapping
        ``{model: wlf, C1: [-], C2: [K]}``: log10 a_T = -C1 (T - T_ref) / (C2 + T - T_ref) (Williams, Landel &
        Ferry 1955), valid while C2 + T - T_ref > 0; or ``{model: arrhenius, activation_energy: [J/mol]}``:
        log10 a_T = E_a / (R ln 10) (1 / T - 1 / T_ref), temperatures in K.
    temperature : float
        Study temperature T [degC].
    reference_temperature : float
        Reference temperature T_ref of the master curve [degC].

    Returns
    -------
    float
        a_T [-], > 0.

    Raises
    ------
    ValueError
        Unknown shift model, or a WLF shift at C2 + T - T_ref <= 0 (the form is singular there).

    References
    ----------
    Williams, Landel & Ferry (1955), J. Am. Chem. Soc. 77, 3701. doi:10.1021/ja01619a008
    """
    t, t_ref = float(temperature), float(reference_temperature)
    model = shift.get("model")
    if model == "wlf":
        c1, c2 = float(shift["C1"]), float(shift["C2"])
        if c2 + t - t_ref <= 0:
            raise ValueError(f"WLF shift singular: C2 + T - T_ref = {c2:g} + {t:g} - {t_ref:g} = "
                             f"{c2 + t - t_ref:g} <= 0")
        return 10.0 ** (-c1 * (t - t_ref) / (c2 + t - t_ref))
    if model == "arrhenius":
        e_a = float(shift["activation_energy"])
        return math.exp(e_a / GAS_CONSTANT * (1.0 / (t + ZERO_CELSIUS) - 1.0 / (t_ref + ZERO_CELSIUS)))
    raise ValueError(f"unknown shift model {model!r}; expected one of {list(SHIFT_MODELS)}")


def _check_shift(name, shift, reference_temperature, temperatures) -> None:
    """Validate a table preset's ``shift`` block against each temperature it will be run at."""
    where = _key(name, "shift")
    if not isinstance(shift, Mapping):
        raise ValueError(f"{where} = {shift!r}: expected a mapping {{model: wlf, C1, C2}} or "
                         "{model: arrhenius, activation_energy}")
    model = shift.get("model")
    keys = {"wlf": ("C1", "C2"), "arrhenius": ("activation_energy",)}
    if model not in keys:
        raise ValueError(f"{where}.model = {model!r}: expected one of {list(SHIFT_MODELS)}")
    extra = sorted(set(shift) - {"model", *keys[model]})
    if extra:
        raise ValueError(f"{where}.{extra[0]}: unknown key for shift model {model!r}; expected {list(keys[model])}")
    for key in keys[model]:
        if key not in shift:
            raise ValueError(f"{where}.{key}: missing (required by shift model {model!r})")
    if model == "wlf":
        _number(name, "shift.C1", shift["C1"], low=0.0, expected="> 0 [-]")
        c2 = _number(name, "shift.C2", shift["C2"], low=0.0, expected="> 0 [K]")
        for key, t in temperatures:
            if c2 + t - reference_temperature <= 0:
                raise ValueError(
                    f"{key} = {t:g} degC: the WLF shift is singular there: {where}.C2 + T - "
                    f"{_key(name, 'reference_temperature')} = {c2:g} + {t:g} - {reference_temperature:g} = "
                    f"{c2 + t - reference_temperature:g} <= 0; expected T > {reference_temperature - c2:g} degC "
                    "(WLF holds from about T_g to T_g + 100 K)"
                )
    else:
        _number(name, "shift.activation_energy", shift["activation_energy"], low=0.0, expected="> 0 [J/mol]")


def temperature_variant_name(name: str, temperature: float) -> str:
    """Name of the variant of preset ``name`` at ``temperature`` [degC]: ``<name>-T<temperature:g>``.

    E.g. ``example-dma-T0``, ``example-dma-T40``, ``example-dma-T-10``, ``example-dma-T23.5`` (path safe:
    no '@' or '_', which file names and wildcards cannot carry).
    """
    return f"{name}-T{float(temperature):g}"


def expand_temperatures(materials: Mapping[str, Any]) -> dict[str, Any]:
    """The ``materials`` section with each table preset's ``temperatures: [T, ...]`` expanded into variants.

    Every T [degC] becomes the preset ``<name>-T<T:g>: {base: <name>, temperature: T}``
    (:func:`temperature_variant_name`): an ordinary ``base:`` variant, so that each temperature is its own
    material in every stage (greens, springs, contact, K*). A preset of that name already in the section
    must be exactly that variant.

    Parameters
    ----------
    materials : Mapping
        The ``materials:`` config section.

    Returns
    -------
    dict
        A new section (the input is not changed) with the variants added.

    Raises
    ------
    ValueError
        ``temperatures`` not a list of numbers, or a derived name taken by another preset.
    """
    out = dict(materials)
    for name, preset in materials.items():
        if not isinstance(preset, Mapping) or "temperatures" not in preset:
            continue
        temps = _number_list(name, "temperatures", preset["temperatures"], low=-ZERO_CELSIUS, low_open=True,
                             expected="> -273.15 [degC]", min_len=1)
        for t in temps:
            variant = temperature_variant_name(name, t)
            want = {"base": name, "temperature": t}
            have = out.get(variant)
            if have is not None and (dict(have).keys() != want.keys() or have.get("base") != name
                                     or float(have.get("temperature", math.nan)) != t):
                raise ValueError(
                    f"{_key(name, 'temperatures')}: the variant at {t:g} degC is named {variant!r}, but "
                    f"materials.{variant} is another preset ({dict(have)!r}); rename that preset"
                )
            out[variant] = want
    return out


def read_dma_table(path) -> tuple[tuple, tuple, tuple]:
    """Read a DMA master curve from a CSV file: frequency [Hz], E' [Pa] and the loss factor eta [-].

    Lines starting with '#' are comments. The first other line is the header naming the columns
    ``frequency``, ``storage_modulus`` and either ``loss_factor`` (eta = E''/E') or ``loss_modulus``
    (E'' [Pa]); other columns are ignored.

    Parameters
    ----------
    path : path-like
        The CSV file (relative to the working directory).

    Returns
    -------
    frequency, storage_modulus, loss_factor : tuple of float
        As the table preset keys of the same names (units Hz, Pa, -).

    Raises
    ------
    FileNotFoundError
        The file does not exist.
    ValueError
        Missing column, a value that is not a number, or no data row; naming the file and line.
    """
    import csv
    from pathlib import Path

    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: DMA table file not found (relative to the working directory {Path.cwd()})")
    rows = [(i + 1, line) for i, line in enumerate(path.read_text().splitlines())
            if line.strip() and not line.lstrip().startswith("#")]
    if not rows:
        raise ValueError(f"{path}: no header line (expected columns frequency, storage_modulus, loss_factor)")
    header = [c.strip() for c in next(csv.reader([rows[0][1]]))]
    loss_col = "loss_factor" if "loss_factor" in header else "loss_modulus"
    for col in ("frequency", "storage_modulus", loss_col):
        if col not in header:
            raise ValueError(f"{path}, line {rows[0][0]}: no column {col!r} in the header {header!r} (expected "
                             "frequency [Hz], storage_modulus [Pa] and loss_factor [-] or loss_modulus [Pa])")
    idx = [header.index(c) for c in ("frequency", "storage_modulus", loss_col)]
    cols: list[list[float]] = [[], [], []]
    for lineno, line in rows[1:]:
        cells = next(csv.reader([line]))
        try:
            values = [float(cells[j]) for j in idx]
        except (ValueError, IndexError):
            raise ValueError(f"{path}, line {lineno}: expected numbers in columns frequency, storage_modulus, "
                             f"{loss_col}; got {line.strip()!r}") from None
        for col, v in zip(cols, values):
            col.append(v)
    if not cols[0]:
        raise ValueError(f"{path}: no data rows")
    f, e1, loss = cols
    eta = [l / e for l, e in zip(loss, e1)] if loss_col == "loss_modulus" else loss
    return tuple(f), tuple(e1), tuple(eta)


# ----------------------------------------------------------------------------------------------------
# config


def _key(name, key):
    return f"materials.{name}.{key}"


def _number(name, key, value, *, low=None, high=None, low_open=True, high_open=True, expected=None):
    """Validate a real number (not bool) within optional bounds; errors name materials.<name>.<key>."""
    where = _key(name, key)
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{where} = {value!r}: expected a number{'' if expected is None else ' ' + expected}")
    v = float(value)
    bad = not math.isfinite(v)
    if low is not None:
        bad |= v <= low if low_open else v < low
    if high is not None:
        bad |= v >= high if high_open else v > high
    if bad:
        raise ValueError(f"{where} = {value!r}: expected {expected or 'a finite number'}")
    return v


def _number_list(name, key, value, *, low, low_open, expected, min_len=0):
    where = _key(name, key)
    if not isinstance(value, (list, tuple)):
        raise ValueError(f"{where} = {value!r}: expected a list of numbers")
    if len(value) < min_len:
        raise ValueError(f"{where}: expected at least {min_len} values, got {len(value)}")
    out = []
    for i, v in enumerate(value):
        out.append(_number(name, f"{key}[{i}]", v, low=low, low_open=low_open, expected=expected))
    return tuple(out)


def _build_model(name, cfg):
    model = cfg["model"]
    if model == "fractional_kelvin_voigt":
        return FractionalKelvinVoigt(
            E0=_number(name, "E0", cfg["E0"], low=0.0, expected="> 0 [Pa]"),
            E1=_number(name, "E1", cfg["E1"], low=0.0, expected="> 0 [Pa]"),
            alpha=_number(name, "alpha", cfg["alpha"], low=0.0, high=1.0, expected="in (0, 1)"),
            f1=_number(name, "f1", cfg["f1"], low=0.0, expected="> 0 [Hz]"),
        )
    if model == "generalized_maxwell":
        e_inf = _number(name, "E_inf", cfg["E_inf"], low=0.0, expected="> 0 [Pa]")
        moduli = _number_list(name, "moduli", cfg["moduli"], low=0.0, low_open=False, expected=">= 0 [Pa]")
        taus = _number_list(
            name, "relaxation_times", cfg["relaxation_times"], low=0.0, low_open=True, expected="> 0 [s]"
        )
        if len(moduli) != len(taus):
            raise ValueError(
                f"{_key(name, 'relaxation_times')}: expected as many values as {_key(name, 'moduli')} "
                f"({len(moduli)}), got {len(taus)}"
            )
        return GeneralizedMaxwell(E_inf=e_inf, moduli=moduli, relaxation_times=taus)
    # table
    f = _number_list(name, "frequency", cfg["frequency"], low=0.0, low_open=True, expected="> 0 [Hz]", min_len=3)
    e1 = _number_list(name, "storage_modulus", cfg["storage_modulus"], low=0.0, low_open=True, expected="> 0 [Pa]")
    eta = _number_list(name, "loss_factor", cfg["loss_factor"], low=0.0, low_open=False, expected=">= 0")
    for key, vals in (("storage_modulus", e1), ("loss_factor", eta)):
        if len(vals) != len(f):
            raise ValueError(
                f"{_key(name, key)}: expected {len(f)} values (one per {_key(name, 'frequency')}), got {len(vals)}"
            )
    if np.any(np.diff(f) <= 0):
        raise ValueError(f"{_key(name, 'frequency')} = {list(f)!r}: expected strictly increasing frequencies")
    tol = _number(
        name, "fit_tolerance", cfg.get("fit_tolerance", _TABLE_DEFAULT_FIT_TOLERANCE), low=0.0, expected="> 0"
    )
    model, err_max, err_rms = fit_generalized_maxwell(f, e1, eta)
    logger.info(
        "material %s: table of %d points (%.3g-%.3g Hz) fitted by a generalised Maxwell model with %d terms: "
        "relative error max %.3g, rms %.3g",
        name, len(f), f[0], f[-1], len(model.moduli), err_max, err_rms,
    )  # fmt: skip
    if err_max > tol:
        raise ValueError(
            f"materials.{name}: the causal (generalised Maxwell) fit of the table is poor: max relative error "
            f"{err_max:.3g} > fit_tolerance {tol:.3g} (rms {err_rms:.3g}); the table may not be causal "
            f"(Kramers-Kronig consistent) or too noisy"
        )
    return model


def _resolve(name, section, chain):
    """Return (root config dict, total loss scale, total density scale, anchor, total modulus scale, lineage)."""
    if name in chain:
        cycle = " -> ".join(chain + (name,))
        raise ValueError(f"materials.{chain[0]}: cyclic base chain {cycle}")
    if name not in section:
        if chain:
            raise ValueError(
                f"{_key(chain[-1], 'base')} = {name!r}: unknown material preset (known: {sorted(section)})"
            )
        raise ValueError(f"materials.{name}: unknown material preset (known: {sorted(section)})")
    cfg = section[name]
    if not isinstance(cfg, Mapping):
        raise ValueError(f"materials.{name} = {cfg!r}: expected a mapping")
    chain = chain + (name,)
    loss = _number(name, "loss_scale", cfg.get("loss_scale", 1.0), low=0.0, low_open=False, expected=">= 0")
    dens = _number(name, "density_scale", cfg.get("density_scale", 1.0), low=0.0, expected="> 0")
    mod = _number(name, "modulus_scale", cfg.get("modulus_scale", 1.0), low=0.0, expected="> 0")
    anchor = cfg.get("loss_anchor")
    if anchor is not None:
        anchor = _number(name, "loss_anchor", anchor, low=0.0, low_open=False,
                         expected=">= 0 [Hz] (the frequency whose |E| a causal loss variant keeps) or null")
    if "base" in cfg:
        extra = sorted(set(cfg) - set(_VARIANT_KEYS))
        if extra:
            raise ValueError(
                f"{_key(name, extra[0])}: a preset with 'base' may only set {list(_VARIANT_KEYS)}, got {extra}"
            )
        base = cfg["base"]
        if not isinstance(base, str):
            raise ValueError(f"{_key(name, 'base')} = {base!r}: expected a material preset name")
        root, l_base, d_base, a_base, m_base, lineage = _resolve(base, section, chain)
        return (root, loss * l_base, dens * d_base, (a_base if anchor is None else anchor), mod * m_base,
                (name,) + lineage)
    return cfg, loss, dens, anchor, mod, (name,)


def compound_and_temperature(name: str, materials: Mapping[str, Any]) -> tuple[str, float]:
    """The compound a material preset is and the temperature it runs at: the study's dimensions.

    A temperature variant (a preset that sets only ``base`` and ``temperature``, as
    :func:`expand_temperatures` writes them) is its base compound at another temperature; every other
    preset is a compound of its own (a loss or density variant changes the material, not its
    temperature). The temperature is the one the preset's ``table`` master curve is run at
    (:func:`material_from_config`: the nearest ``temperature`` in the base chain, else the
    ``reference_temperature``); a preset without a reference temperature has none (NaN). The table
    file is not read.

    Parameters
    ----------
    name : str
        Material preset name.
    materials : mapping
        The ``materials`` section (temperature variants expanded).

    Returns
    -------
    compound : str
        ``name``, or for a temperature variant its base's compound.
    temperature : float
        Study temperature [degC]; NaN for a preset without one.

    Raises
    ------
    ValueError
        Naming ``materials.<name>``: unknown preset or base, cyclic base chain.
    """
    root, _, _, _, _, lineage = _resolve(name, materials, ())
    compound = name
    while set(materials[compound]) <= {"base", "temperature"} and "base" in materials[compound] \
            and "temperature" in materials[compound]:
        compound = materials[compound]["base"]
    temperature = math.nan
    if root.get("model") == "table" and "reference_temperature" in root:
        temperature = root.get("temperature", root["reference_temperature"])
        for preset in lineage[:-1]:
            if "temperature" in materials[preset]:
                temperature = materials[preset]["temperature"]
                break
    return compound, float(temperature)


def _check_phase_scaling(name, model, loss_scale: float) -> None:
    """A causal loss variant E^s is passive while s arg E < pi/2 at every frequency (1e-6 ... 1e9 Hz)."""
    w = 2.0 * np.pi * np.logspace(-6, 9, 1501)
    phase = float(np.max(np.angle(model.modulus(w))))
    if loss_scale * phase >= 0.5 * np.pi:
        raise ValueError(
            f"materials.{name}.loss_scale = {loss_scale:g}: the causal (phase-scaled) variant is not passive: "
            f"s arg E reaches {loss_scale * phase:.3f} rad >= pi/2 (arg E up to {phase:.3f} rad); expected "
            f"loss_scale < {0.5 * np.pi / phase:.3g}"
        )


def _read_table_file(name, root):
    """The root table preset with its ``table_file``'s columns inlined (the resolved preset carries the data)."""
    both = [k for k in _TABLE_DATA_KEYS if k in root]
    if both:
        raise ValueError(f"{_key(name, both[0])}: given beside {_key(name, 'table_file')}; give the table either "
                         "inline (frequency, storage_modulus, loss_factor) or in the file, not both")
    path = root["table_file"]
    if not isinstance(path, str) or not path:
        raise ValueError(f"{_key(name, 'table_file')} = {path!r}: expected the path of a CSV file")
    try:
        f, e1, eta = read_dma_table(path)
    except FileNotFoundError as err:
        raise ValueError(f"{_key(name, 'table_file')} = {path!r}: {err}") from None
    except ValueError as err:
        raise ValueError(f"{_key(name, 'table_file')} = {path!r}: {err}") from None
    out = {k: v for k, v in root.items() if k != "table_file"}
    out.update(frequency=list(f), storage_modulus=list(e1), loss_factor=list(eta))
    return out


def _table_temperature(root_name, root, lineage, section) -> tuple[float | None, float, float]:
    """(T [degC] or None, a_T, b_T) of a table preset: the nearest ``temperature`` in the base chain wins."""
    t_owner, temperature = root_name, None
    for preset in lineage[:-1]:
        if "temperature" in section[preset]:
            t_owner, temperature = preset, section[preset]["temperature"]
            break
    else:
        temperature = root.get("temperature")
    t_key = _key(t_owner, "temperature") if temperature is not None else None
    has_shift, has_ref = "shift" in root, "reference_temperature" in root
    if (temperature is not None or "temperatures" in root) and not has_shift:
        key = t_key or _key(root_name, "temperatures")
        raise ValueError(f"{key}: a study temperature needs {_key(root_name, 'shift')} (the master curve's "
                         "time-temperature shift: {model: wlf, C1, C2} or {model: arrhenius, activation_energy}) "
                         f"and {_key(root_name, 'reference_temperature')} [degC]")
    if has_shift and not has_ref:
        raise ValueError(f"{_key(root_name, 'shift')}: needs {_key(root_name, 'reference_temperature')} [degC], "
                         "the temperature of the master curve")
    vertical = root.get("vertical_shift", False)
    if not isinstance(vertical, bool):
        raise ValueError(f"{_key(root_name, 'vertical_shift')} = {vertical!r}: expected true or false")
    if vertical and not has_shift:
        raise ValueError(f"{_key(root_name, 'vertical_shift')}: needs {_key(root_name, 'shift')} and "
                         f"{_key(root_name, 'reference_temperature')}")
    if not has_ref:
        return None, 1.0, 1.0
    t_ref = _number(root_name, "reference_temperature", root["reference_temperature"], low=-ZERO_CELSIUS,
                    expected="> -273.15 [degC]")
    temps = []
    if temperature is not None:
        temperature = _number(t_owner, "temperature", temperature, low=-ZERO_CELSIUS,
                              expected="> -273.15 [degC]")
        temps.append((t_key, temperature))
    if "temperatures" in root:
        values = _number_list(root_name, "temperatures", root["temperatures"], low=-ZERO_CELSIUS, low_open=True,
                              expected="> -273.15 [degC]", min_len=1)
        temps += [(f"{_key(root_name, 'temperatures')}[{i}]", t) for i, t in enumerate(values)]
    if has_shift:
        _check_shift(root_name, root["shift"], t_ref, temps)
    if temperature is None:
        return t_ref, 1.0, 1.0
    a_t = shift_factor(root["shift"], temperature, t_ref)
    b_t = (temperature + ZERO_CELSIUS) / (t_ref + ZERO_CELSIUS) if vertical else 1.0
    return temperature, a_t, b_t


def material_from_config(name, materials_section) -> Material:
    """Build a validated :class:`Material` from the ``materials`` config section.

    Parameters
    ----------
    name : str
        Preset name (must be :func:`path_safe`).
    materials_section : Mapping
        The whole ``materials:`` section (needed to resolve ``base:`` chains).

    Returns
    -------
    Material
        With ``config`` the resolved preset: the root preset's keys, ``density`` multiplied by every
        ``density_scale`` of the chain, ``loss_scale`` the product of the chain's loss scales (no ``base``,
        no ``density_scale``); ``material_from_config(name, {name: m.config})`` rebuilds an equal material.

    Raises
    ------
    ValueError
        Naming ``materials.<name>.<key>`` and the offending value: unknown preset or base, cyclic base chain,
        unknown model or key, missing key, out-of-range value (nu in (0, 0.5), density, thickness > 0, ...).
    """
    if not path_safe(name):
        raise ValueError(
            f"materials.{name}: preset name {name!r} is not path safe (letters, digits, '-', '.'; "
            "starting with a letter or digit; no '_' or '/')"
        )
    if not isinstance(materials_section, Mapping):
        raise ValueError(f"materials: expected a mapping of presets, got {type(materials_section).__name__}")
    root, loss_scale, density_scale, loss_anchor, modulus_scale, lineage = _resolve(name, materials_section, ())
    root_name = lineage[-1]
    model = root.get("model")
    if model is None:
        raise ValueError(f"{_key(root_name, 'model')}: missing; expected one of {list(MODELS)}")
    if model not in MODELS:
        raise ValueError(f"{_key(root_name, 'model')} = {model!r}: unknown model; expected one of {list(MODELS)}")
    allowed = set(_COMMON_KEYS) | set(_SCALE_KEYS) | set(_MODEL_KEYS[model]) | set(_OPTIONAL_MODEL_KEYS.get(model, ()))
    unknown = sorted(set(root) - allowed)
    if unknown:
        raise ValueError(
            f"{_key(root_name, unknown[0])}: unknown key for model {model!r}; expected keys {sorted(allowed)}"
        )
    if model != "table":
        for preset in lineage[:-1]:
            if "temperature" in materials_section[preset]:
                raise ValueError(f"{_key(preset, 'temperature')}: only a variant of a 'table' preset (a DMA master "
                                 f"curve with reference_temperature and shift) has a temperature; its root "
                                 f"materials.{root_name} is model {model!r}")
    if model == "table" and "table_file" in root:
        root = _read_table_file(root_name, root)
    for key in _COMMON_KEYS[1:4] + _MODEL_KEYS[model]:
        if key not in root:
            raise ValueError(f"{_key(root_name, key)}: missing (required by model {model!r})")
    nu = _number(root_name, "poisson_ratio", root["poisson_ratio"], low=0.0, high=0.5, expected="in (0, 0.5)")
    rho = _number(root_name, "density", root["density"], low=0.0, expected="> 0 [kg/m^3]")
    h = _number(root_name, "thickness", root["thickness"], low=0.0, expected="> 0 [m]")
    qs, qs_owner = root.get("quasi_static_modulus", "zero_frequency"), root_name
    for preset in lineage[:-1]:  # a variant's own quasi_static_modulus (the nearest in the chain) wins
        if "quasi_static_modulus" in materials_section[preset]:
            qs, qs_owner = materials_section[preset]["quasi_static_modulus"], preset
            break
    if qs != "zero_frequency":
        qs = _number(
            qs_owner, "quasi_static_modulus", qs, low=0.0, expected="'zero_frequency' or a modulus > 0 [Pa]"
        )
    built = _build_model(root_name, root)
    temperature, a_t, b_t = None, 1.0, 1.0
    if model == "table":
        temperature, a_t, b_t = _table_temperature(root_name, root, lineage, materials_section)
        if a_t != 1.0 or b_t != 1.0:  # E(w; T) = b_T E_ref(w a_T): every relaxation time times a_T
            built = GeneralizedMaxwell(
                E_inf=built.E_inf * b_t,
                moduli=tuple(b_t * e for e in built.moduli),
                relaxation_times=tuple(a_t * tau for tau in built.relaxation_times),
            )
        if qs != "zero_frequency":
            qs = qs * b_t  # the measured relaxed modulus is the reference temperature's

    resolved = copy.deepcopy(dict(root))
    resolved.pop("density_scale", None)
    resolved["density"] = rho * density_scale
    resolved["loss_scale"] = loss_scale
    if modulus_scale != 1.0:
        resolved["modulus_scale"] = modulus_scale
    else:
        resolved.pop("modulus_scale", None)
    if loss_anchor is not None:
        resolved["loss_anchor"] = loss_anchor
    resolved["quasi_static_modulus"] = qs if qs == "zero_frequency" else qs / b_t
    resolved.pop("temperatures", None)  # expanded into variants (expand_temperatures); each is its own preset
    if temperature is not None and "reference_temperature" in resolved:
        resolved["temperature"] = temperature
    material = Material(
        name=name,
        poisson=nu,
        density=rho * density_scale,
        thickness=h,
        model=built,
        loss_scale=loss_scale,
        quasi_static=qs,
        loss_anchor=loss_anchor,
        modulus_scale=modulus_scale,
        temperature=temperature,
        shift_factor=a_t,
        vertical_shift_factor=b_t,
        config=resolved,
        lineage=lineage,
    )
    if loss_anchor is not None and loss_scale > 1.0:
        _check_phase_scaling(name, built, loss_scale)
    if model == "table" and qs == "zero_frequency":
        f_low = float(root["frequency"][0]) / a_t  # the table's lowest frequency, shifted to the study temperature
        e_low = float(np.real(material.modulus(2.0 * np.pi * f_low)))
        at = "" if temperature is None else f" at {temperature:g} degC (shift factor a_T = {a_t:.4g})"
        logger.warning(
            "materials.%s: the relaxed modulus E(0) = %.4g Pa%s is an extrapolation of the table's causal fit below "
            "its lowest frequency %.4g Hz (E'(%.4g Hz) = %.4g Pa, %.1f %% above it); it sets the quasi-static kernel, "
            "the creep tail's end and, with springs.modulus: quasi_static, the contact springs. Give "
            "materials.%s.quasi_static_modulus [Pa] to set it from data.",
            name, material.quasi_static_modulus, at, f_low, f_low, e_low,
            100.0 * (e_low / material.quasi_static_modulus - 1.0), root_name,
        )
    logger.debug("material %s resolved via %s: %s", name, " -> ".join(lineage), resolved)
    return material


def causality_error(material: Material, key: str, use: str = "a time-domain run") -> str | None:
    """Why ``material`` may not reach a time-domain stage, or None when it is causal (issue 24).

    Parameters
    ----------
    material : Material
        The resolved preset.
    key : str
        The config key that sends it there (e.g. ``study.materials[1]``), named first in the message.
    use : str
        What the key would run (contact runs, loading runs, ...).

    Returns
    -------
    str or None
        One paragraph: the key, the material, why it is refused and the causal alternative
        ``materials.<name>.loss_anchor: 1000.0`` (0 keeps the relaxed modulus); None for a causal material.
    """
    if material.is_causal:
        return None
    base = material.lineage[0] if material.lineage else material.name
    return (
        f"{key} = {material.name!r}: this material scales eta at constant |E| (loss_scale {material.loss_scale:g}, the "
        f"seed's definition) and is not causal: {use} of it would depend on how its negative-time response is cut "
        f"off, so time-domain stages refuse it. Use the causal variant, materials.{base}.loss_anchor: 1000.0 (phase "
        f"scaled, |E| kept at 1 kHz; 0 keeps the relaxed modulus), or the seed variant in frequency-domain "
        f"quantities only (study.claim6.seed_variants)"
    )
