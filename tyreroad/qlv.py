r"""Viscoelastic contact springs: quasi-linear viscoelasticity (Fung) of the element springs (issue 24).

The element springs (:mod:`tyreroad.springs`) are made of the tread's own rubber, but their tables
use one modulus, the springs' modulus E_s (by default the quasi-static modulus E_qs = E(omega -> 0)),
at every frequency: the springs are elastic. Config ``springs.rheology: qlv`` lets the spring force
relax with the tread's modulus instead, by Fung's quasi-linear viscoelasticity, the standard
viscoelastic form of a nonlinear spring:

    F_e(t) = int_{-inf}^{t} R(t - tau) dF_el(zeta_e(tau)),        R(t) = E(t) / E_s,

with F_el the elastic table force (:class:`tyreroad.springs.SpringTable`) and E(t) the tread's
relaxation modulus. Linearised about any state, a small harmonic compression sees the spring
stiffness

    k_e(f) = k_e(zeta_e) E(f) / E_s                                          (correspondence principle),

which :func:`tyreroad.stiffness.stiffness_spectrum` uses for K*(f; d0) (with the material's exact
E(f), not the fit below).

Relaxation function
-------------------
R(t) = R_inf + sum_k r_k exp(-t / tau_k), R_inf = E(0) / E_s, r_k >= 0, is fitted to the complex
modulus ratio E(omega) / E_s = R_inf + sum_k r_k i omega tau_k / (1 + i omega tau_k) by
non-negative least squares (relative error, Re and Im jointly) with log-spaced tau_k, 8 per decade,
from 10 / (2 pi f_lo) down to 0.1 / (2 pi f_hi), f_lo = 1e-7 Hz, f_hi = :data:`FIT_MAX_FREQUENCY`
(1 MHz, 20 x the default fs: a march step never resolves more). The largest relative error over
the band is recorded (:attr:`RelaxationFunction.fit_error`; the default tread: see the springs
file's ``relaxation_fit_error``). A fractional tread has no glassy limit (|E| grows as f^alpha): the
series holds it up to f_hi and stays at its value there above. The fit lives in the springs file
(variables ``relaxation_weight[relaxation_term]``, ``relaxation_time[relaxation_term]``, attributes
``spring_rheology = 'qlv'``, ``relaxed_ratio``, ``relaxation_fit_error``); elastic springs files
hold none of it and are unchanged.

Only springs whose modulus is the relaxed modulus E(0) (``springs.modulus: quasi_static`` with the
material's ``quasi_static_modulus: zero_frequency``, the defaults) are accepted: then R_inf = 1, a
fully relaxed QLV spring *is* the elastic table, and every quasi-static state (the static kernel's
runs, the relaxed preload states of K*, the rolling load search) is exactly the elastic one.

The march: a recursive filter per element
-----------------------------------------
Between steps F_el is taken piecewise linear in time (as the creep tail does for the layer), which
makes the convolution exact for each exponential: with the increment dF_n = F_el,n - F_el,n-1 and
Delta = 1/fs, e_k = exp(-Delta / tau_k), beta_k = (tau_k / Delta)(1 - e_k),

    h_k,n = e_k h_k,n-1 + r_k beta_k dF_n,        F_n = R_inf F_el,n + sum_k h_k,n
          = a F_el(zeta_n) + H_n,                 a = R_inf + sum_k r_k beta_k,
                                                  H_n = sum_k (e_k h_k,n-1 - r_k beta_k F_el,n-1).

Inside the Newton iteration of a step the spring is F = a F_el(zeta) + H (H known from the
history), tangent a k_el(zeta): :class:`MarchSprings` wraps the elastic table with that, and the
march commits each converged step (h_k and F_el,n) with :meth:`MarchSprings.commit`; newton.py is
unchanged.

Separation and unloading. F_el = 0 for zeta <= 0, and the relaxed history then gives F <= 0
(integrating by parts, F(t) = int F_el(tau) R'(t - tau) d tau <= 0 for R decreasing and F_el >= 0):
QLV would pull on the road. The contact cannot adhere, so the spring force is clipped,

    F = max(a F_el(zeta) + H, 0),   k = a k_el(zeta) where F > 0, else 0,   F = 0 for zeta <= 0,

and the history keeps being driven by F_el(zeta) (what the asperity's compression would produce),
unclipped. During fast unloading a spring still in geometric contact (zeta > 0) can therefore carry
no force, as a rubber surface that recovers slower than the road moves away would. This is the
standard QLV with a unilateral clip, stated here as a modelling choice, not derived.

References
----------
Fung, Y. C. (1993). Biomechanics: Mechanical Properties of Living Tissues, 2nd ed., ch. 7
(quasi-linear viscoelasticity). Springer. doi:10.1007/978-1-4757-2257-4
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np
import xarray as xr
from scipy.optimize import nnls

from . import checks
from .springs import SpringTable

logger = logging.getLogger(__name__)

__all__ = [
    "RHEOLOGIES",
    "FIT_MAX_FREQUENCY",
    "RelaxationFunction",
    "fit_relaxation",
    "check_relaxed_modulus",
    "relaxation_variables",
    "ViscoelasticSprings",
    "MarchSprings",
    "StageMarchSprings",
    "springs_for_run",
]

#: Values of config ``springs.rheology``.
RHEOLOGIES = ("elastic", "qlv")
#: Relaxation times per decade of the fit.
TERMS_PER_DECADE = 8
#: Lowest frequency of the fit [Hz].
LOWEST_FIT_FREQUENCY = 1e-7
#: Highest frequency of the fit [Hz] (20 x the default fs of 51.2 kHz).
FIT_MAX_FREQUENCY = 1e6


@dataclass(frozen=True)
class RelaxationFunction:
    """R(t) = R_inf + sum_k r_k exp(-t / tau_k), the springs' relaxation function E(t) / E_s.

    Attributes
    ----------
    relaxed : float
        R_inf = E(0) / E_s [-].
    weights : numpy.ndarray
        r_k [-], >= 0.
    times : numpy.ndarray
        tau_k [s], > 0.
    fit_error : float
        Largest |R*_fit - E/E_s| / |E/E_s| over the fit band [-] (0 for an exact series).
    """

    relaxed: float
    weights: np.ndarray
    times: np.ndarray
    fit_error: float = 0.0

    def relaxation(self, t) -> np.ndarray:
        """R(t) [-] at times t [s] (>= 0)."""
        t = np.asarray(t, dtype=float)
        return self.relaxed + np.sum(self.weights * np.exp(-t[..., None] / self.times), axis=-1)

    def complex_ratio(self, omega) -> np.ndarray:
        """R*(omega) = R_inf + sum_k r_k i omega tau_k / (1 + i omega tau_k) [-] (E*(omega) / E_s of the fit)."""
        w = np.asarray(omega, dtype=float)
        iwt = 1j * w[..., None] * self.times
        return self.relaxed + np.sum(self.weights * iwt / (1.0 + iwt), axis=-1)

    def step_coefficients(self, dt: float) -> tuple[float, np.ndarray, np.ndarray]:
        """(a, e_k, r_k beta_k) of the march at time step ``dt`` [s] (module docstring)."""
        dt = checks.real("dt", dt, positive=True)
        x = dt / self.times
        decay = np.exp(-x)
        beta = -np.expm1(-x) / x
        gain = self.weights * beta
        return float(self.relaxed + gain.sum()), decay, gain


def fit_relaxation(modulus, spring_modulus: float, max_frequency: float = FIT_MAX_FREQUENCY,
                   name: str = "material") -> RelaxationFunction:
    """Fit E(omega) / E_s with a non-negative relaxation (Prony) series (module docstring).

    Parameters
    ----------
    modulus : callable
        omega [rad/s] -> complex E [Pa] (e.g. ``Material.modulus``).
    spring_modulus : float
        E_s [Pa], the springs' table modulus.
    max_frequency : float
        Upper end of the fit band [Hz].
    name : str
        For the log.

    Returns
    -------
    RelaxationFunction
    """
    e_s = checks.real("spring_modulus", spring_modulus, positive=True)
    f_max = checks.real("max_frequency", max_frequency, positive=True)
    e0 = float(np.real(modulus(np.array([0.0]))[0]))
    relaxed = e0 / e_s
    decades = math.log10(f_max / LOWEST_FIT_FREQUENCY)
    n_terms = int(math.ceil(decades * TERMS_PER_DECADE)) + 1 + 2 * TERMS_PER_DECADE
    times = np.logspace(math.log10(10 / (2 * np.pi * LOWEST_FIT_FREQUENCY)), math.log10(0.1 / (2 * np.pi * f_max)),
                        n_terms)
    freq = np.logspace(math.log10(LOWEST_FIT_FREQUENCY), math.log10(f_max), 4 * n_terms)
    omega = 2 * np.pi * freq
    target = np.asarray(modulus(omega), dtype=complex) / e_s
    weight = 1.0 / np.abs(target)
    iwt = 1j * omega[:, None] * times
    basis = iwt / (1.0 + iwt)
    rows = np.concatenate([basis.real * weight[:, None], basis.imag * weight[:, None]])
    rhs = np.concatenate([(target.real - relaxed) * weight, target.imag * weight])
    scale = np.linalg.norm(rows, axis=0)
    coef, _ = nnls(rows / scale, rhs, maxiter=50 * rows.shape[1])
    coef = coef / scale
    fit = RelaxationFunction(relaxed, coef, times, 0.0)
    error = float(np.max(np.abs(fit.complex_ratio(omega) - target) * weight))
    logger.info("relaxation fit %s: %d relaxation times %.1e ... %.1e s, R_inf = %.6f, R(0) = %.4f, max relative "
                "error of E(f)/E_s over %.0e ... %.0e Hz %.1e", name, n_terms, times[0], times[-1], relaxed,
                relaxed + coef.sum(), LOWEST_FIT_FREQUENCY, f_max, error)
    if error > 0.02:
        logger.warning("relaxation fit %s: max relative error %.1e: the material is not causal (e.g. a loss-scaled "
                       "variant); its springs relax with the nearest causal relaxation", name, error)
    return RelaxationFunction(relaxed, coef, times, error)


def check_relaxed_modulus(modulus_at_zero: float, spring_modulus: float, name: str = "material") -> None:
    """Refuse QLV springs whose table modulus is not the relaxed modulus E(0) (module docstring)."""
    if not math.isclose(float(modulus_at_zero), float(spring_modulus), rel_tol=1e-12):
        raise ValueError(
            f"springs.rheology = 'qlv' for material {name!r}: the springs' modulus E_s = {spring_modulus:.6g} Pa is "
            f"not the relaxed modulus E(0) = {modulus_at_zero:.6g} Pa; QLV springs need E_s = E(0) (springs.modulus: "
            "quasi_static and materials.<name>.quasi_static_modulus: zero_frequency), so that a relaxed spring is "
            "the elastic table"
        )


def relaxation_variables(relaxation: RelaxationFunction) -> tuple[dict, dict]:
    """(data variables, attributes) that record a relaxation function in a springs dataset."""
    dims = ("relaxation_term",)
    data = {
        "relaxation_weight": (dims, np.asarray(relaxation.weights, dtype=float),
                              {"units": "1", "long_name": "QLV relaxation weight r_k of R(t) = R_inf + sum r_k "
                               "exp(-t/tau_k), R = E(t)/E_s"}),
        "relaxation_time": (dims, np.asarray(relaxation.times, dtype=float),
                            {"units": "s", "long_name": "QLV relaxation time tau_k"}),
    }
    attrs = {"spring_rheology": "qlv", "relaxed_ratio": float(relaxation.relaxed),
             "relaxation_fit_error": float(relaxation.fit_error)}
    return data, attrs


def _relaxation_from_dataset(ds: xr.Dataset) -> RelaxationFunction:
    for key in ("relaxation_weight", "relaxation_time"):
        if key not in ds:
            raise KeyError(f"springs dataset: spring_rheology is 'qlv' but it has no variable {key!r}")
    return RelaxationFunction(float(ds.attrs["relaxed_ratio"]), ds["relaxation_weight"].values.astype(float),
                              ds["relaxation_time"].values.astype(float), float(ds.attrs.get("relaxation_fit_error",
                                                                                             0.0)))


class ViscoelasticSprings:
    """QLV springs: an elastic table and the relaxation function R(t) (module docstring).

    Reads like the table it wraps (``zeta_step``, ``stiffness``, ``force``, ``evaluate``: the *elastic*
    F_el and k_el, which are also the relaxed springs), so that the quasi-static solves use it as they
    are. The march asks :meth:`for_kernel` for the springs of a run: the elastic table on a static
    kernel (relaxed, R_inf = 1), a :class:`MarchSprings` at the kernel's time step on a dynamic one.

    Parameters
    ----------
    table : tyreroad.springs.SpringTable
        Elastic tables (any leading shape).
    relaxation : RelaxationFunction
        R(t); R_inf must be 1.
    spring_modulus : float
        E_s [Pa] (k_e(f) = k_e E(f) / E_s in K*).
    """

    rheology = "qlv"

    def __init__(self, table: SpringTable, relaxation: RelaxationFunction, spring_modulus: float):
        if not isinstance(table, SpringTable):
            raise TypeError(f"table: expected a SpringTable, got {type(table).__name__}")
        if not math.isclose(relaxation.relaxed, 1.0, rel_tol=1e-12):
            raise ValueError(f"QLV springs: R_inf = E(0)/E_s = {relaxation.relaxed:.12g}, expected 1 "
                             "(see tyreroad.qlv.check_relaxed_modulus)")
        self.table = table
        self.relaxation = relaxation
        self.spring_modulus = checks.real("spring_modulus", spring_modulus, positive=True)

    @property
    def zeta_step(self) -> float:
        return self.table.zeta_step

    @property
    def stiffness(self) -> np.ndarray:
        return self.table.stiffness

    @property
    def force(self) -> np.ndarray:
        return self.table.force

    @property
    def n_springs(self) -> int:
        return self.table.n_springs

    def evaluate(self, zeta):
        """Elastic (relaxed) F_el and k_el at ``zeta`` (:meth:`SpringTable.evaluate`)."""
        return self.table.evaluate(zeta)

    def frequency_factor(self, material, frequency) -> np.ndarray:
        """E(2 pi f) / E_s [-] of the material at ``frequency`` [Hz]: k_e(f) = k_e(zeta) times this."""
        f = np.asarray(frequency, dtype=float)
        return np.asarray(material.modulus(2.0 * np.pi * f), dtype=complex) / self.spring_modulus

    def for_kernel(self, kernel):
        """The springs of a march on ``kernel``: the elastic (relaxed) table on a static kernel, else
        :class:`MarchSprings` at dt = 1 / fs."""
        table = self.table
        if table.stiffness.ndim != 2:
            table = SpringTable.checked(table.stiffness, table.force, table.zeta_step, table.n_springs)
        if kernel.static:
            return table
        return MarchSprings(table, self.relaxation, 1.0 / float(kernel.sample_rate))


class _RecursiveSprings:
    """What the single- and multi-stage QLV march springs share: the per-element history (h, F_el,
    the offsets H), its reset, its advance by a converged step, and the clip at separation."""

    @property
    def zeta_step(self) -> float:
        return self.table.zeta_step

    def start(self) -> None:
        """Rest: no force history."""
        self.h[:] = 0.0
        self.f_el[:] = 0.0
        self.offset[:] = 0.0

    def evaluate(self, zeta):
        z = np.ascontiguousarray(np.asarray(zeta, dtype=float).ravel())
        f, k = np.empty(z.size), np.empty(z.size)
        self.evaluate_into(z, f, k)
        return f, k

    @staticmethod
    def _clip(zeta: np.ndarray, force_out: np.ndarray, stiffness_out: np.ndarray) -> None:
        """A spring never pulls: no force and no tangent where open or where the history would pull."""
        off = (zeta <= 0.0) | (force_out <= 0.0)
        force_out[off] = 0.0
        stiffness_out[off] = 0.0

    def _advance(self, zeta) -> None:
        """The history (h, F_el) by a converged step ending at compressions ``zeta`` [m], shape (M,)."""
        self.table.evaluate_into(np.ascontiguousarray(np.asarray(zeta, dtype=float)), self._f, self._k)
        increment = self._f - self.f_el
        self.h *= self.decay
        self.h += increment[:, None] * self.gain
        self.f_el[:] = self._f


class MarchSprings(_RecursiveSprings):
    """QLV springs of one march at a fixed time step: F = max(a F_el(zeta) + H, 0) (module docstring).

    The springs protocol of :func:`tyreroad.newton.solve_step` (``evaluate_into``,
    ``contact_stiffness``) plus the march hooks ``start()`` (rest: no history) and ``commit(zeta)``
    (a converged step).
    """

    def __init__(self, table: SpringTable, relaxation: RelaxationFunction, dt: float):
        self.table = table
        self.relaxation = relaxation
        self.dt = float(dt)
        self.a, self.decay, self.gain = relaxation.step_coefficients(dt)
        self._gain_sum = float(self.gain.sum())
        m = table.n_springs
        self.h = np.zeros((m, self.decay.size))
        self.f_el = np.zeros(m)
        self.offset = np.zeros(m)
        self._f, self._k = np.empty(m), np.empty(m)

    @property
    def stiffness(self) -> np.ndarray:
        return self.table.stiffness

    @property
    def n_springs(self) -> int:
        return self.table.n_springs

    @property
    def max_stiffness(self) -> float:
        """The stiffest tangent within a march step, a max k_el [N/m] (what the kernel's margin must hold:
        ``tyreroad.kernel.LayerKernel.check_springs``)."""
        return float(self.a * np.max(self.table.stiffness))

    def evaluate_into(self, zeta: np.ndarray, force_out: np.ndarray, stiffness_out: np.ndarray) -> None:
        """F = max(a F_el(zeta) + H, 0) and its tangent a k_el (0 where clipped or zeta <= 0)."""
        self.table.evaluate_into(zeta, force_out, stiffness_out)
        force_out *= self.a
        force_out += self.offset
        stiffness_out *= self.a
        self._clip(zeta, force_out, stiffness_out)

    def contact_stiffness(self) -> np.ndarray:
        """a k_el(0+) of every spring [N/m] (the Newton unknown's scaling at first contact)."""
        return self.a * np.asarray(self.table.contact_stiffness(), dtype=float)

    def commit(self, zeta: np.ndarray) -> None:
        """Advance the history by the converged step's compressions ``zeta`` [m], shape (M,)."""
        self._advance(zeta)
        self.offset = self.h @ self.decay - self._gain_sum * self.f_el

    def for_stages(self, fractions) -> "StageMarchSprings":
        """These springs in a march with several unknowns per element and step at t_(n-1) + c_i dt (the Radau
        IIA-3 stage kernel, :func:`tyreroad.stage.stage_springs`)."""
        return StageMarchSprings(self.table, self.relaxation, self.dt, fractions)


class StageMarchSprings(_RecursiveSprings):
    """QLV springs of a stage march (:class:`tyreroad.stage.StageKernel`): the unknowns of step n are the stage
    compressions at t_(n-1) + c_i dt, stage-major (index i M + e), c_S = 1.

    F_el is taken linear in time from t_(n-1) to each stage time (as :class:`MarchSprings` takes it over a
    step), so stage i is the single-step recursion over delta_i = c_i dt from the committed state at t_(n-1):

        F_i = max(a_i F_el(zeta_i) + H_i, 0),   (a_i, e_ik, g_ik) = step_coefficients(c_i dt),
        H_i = sum_k (e_ik h_k,n-1 - g_ik F_el,n-1);

    the step commits the last stage (c_S = 1: exactly :meth:`MarchSprings.commit`). The in-step stiffness a_i k_el
    differs between the stages (a_1 > a_S: less relaxation within the shorter interval), so these springs are
    outside the stage kernel's stability argument (springs equal at the stages; :mod:`tyreroad.stage`); their
    stability is measured (tests/test_radau_config.py), not proven.
    """

    def __init__(self, table: SpringTable, relaxation: RelaxationFunction, dt: float, fractions):
        self.table = table
        self.relaxation = relaxation
        self.dt = float(dt)
        self.fractions = np.asarray(fractions, dtype=float)
        if self.fractions.ndim != 1 or not math.isclose(self.fractions[-1], 1.0, rel_tol=1e-14):
            raise ValueError(f"stage fractions must end at 1 (the step's end), got {self.fractions}")
        coefficients = [relaxation.step_coefficients(c * self.dt) for c in self.fractions]
        self.a_stage = np.array([c[0] for c in coefficients])
        self.decay_stage = np.stack([c[1] for c in coefficients])  # (S, K)
        self.gain_stage = np.stack([c[2] for c in coefficients])
        self.decay, self.gain = self.decay_stage[-1], self.gain_stage[-1]
        m = table.n_springs
        self.m = m
        self.h = np.zeros((m, self.decay.size))
        self.f_el = np.zeros(m)
        self.offset = np.zeros(self.fractions.size * m)
        self._f, self._k = np.empty(m), np.empty(m)

    @property
    def n_springs(self) -> int:
        return self.fractions.size * self.m

    @property
    def max_stiffness(self) -> float:
        """The stiffest tangent within a step, max_i a_i max k_el [N/m]."""
        return float(self.a_stage.max() * np.max(self.table.stiffness))

    def evaluate_into(self, zeta: np.ndarray, force_out: np.ndarray, stiffness_out: np.ndarray) -> None:
        m = self.m
        for i, a in enumerate(self.a_stage):
            part = slice(i * m, (i + 1) * m)
            f, k = force_out[part], stiffness_out[part]
            self.table.evaluate_into(np.ascontiguousarray(zeta[part]), self._f, self._k)
            np.multiply(self._f, a, out=f)
            f += self.offset[part]
            np.multiply(self._k, a, out=k)
        self._clip(zeta, force_out, stiffness_out)

    def contact_stiffness(self) -> np.ndarray:
        k0 = np.asarray(self.table.contact_stiffness(), dtype=float)
        return np.concatenate([a * k0 for a in self.a_stage])

    def commit(self, zeta: np.ndarray) -> None:
        """Advance the history by the converged step's last stage (t_n) and set every stage's H for the next."""
        self._advance(np.asarray(zeta, dtype=float)[-self.m:])
        m = self.m
        for i in range(self.fractions.size):
            self.offset[i * m:(i + 1) * m] = self.h @ self.decay_stage[i] - self.gain_stage[i].sum() * self.f_el


def springs_for_run(springs_ds: xr.Dataset, table: SpringTable):
    """``table`` as it is for an elastic springs file, a :class:`ViscoelasticSprings` for a QLV one."""
    rheology = springs_ds.attrs.get("spring_rheology", "elastic")
    if rheology == "elastic":
        return table
    if rheology != "qlv":
        raise ValueError(f"springs dataset: spring_rheology {rheology!r}; expected one of {RHEOLOGIES}")
    return ViscoelasticSprings(table, _relaxation_from_dataset(springs_ds), float(springs_ds.attrs["spring_modulus"]))
