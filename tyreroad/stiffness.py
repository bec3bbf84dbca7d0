r"""Contact stiffness of a preloaded contact: the quasi-static tangent and the dynamic K*(f; d0) (SPEC 11).

Linearised about a solved contact state, a small indentation increment delta (the flat tread
surface moved towards the road by delta, every spring's free compression grows by delta) changes
the spring compressions by dzeta, (I + G K) dzeta = delta 1, with K = diag(k_e) the tangent
spring stiffnesses k_e = dF_e/dzeta_e and G the layer's influence matrix. The total force changes
by 1^T K dzeta, so over the contact set C (the elements with k_e > 0)

    K = 1^T [G_C + diag(1/k_e)]^-1 1.

* **Quasi-static tangent** (the substrates' ``tangent``, :mod:`tyreroad.newton`): G = G_0 = g_static,
  the state of a quasi-static run. dF/dd of the quasi-static curve, exact between contact-set
  changes, so that quasi-static runs may take coarse indentation steps while K(d) stays exact.
* **Dynamic contact stiffness** (:func:`stiffness_spectrum`): G = G_C(f), the element FRF matrix
  g(e - m, f) of the layer (:func:`tyreroad.greens.element_frf`, the same layer machinery as the
  Green's functions, not the truncated time kernel), about the **relaxed preload state**: the
  quasi-static solution at d0 with the quasi-static kernel g_static (modulus E_qs). Convention
  exp(+i omega t): F_hat = K* delta_hat, storage stiffness K' = Re K*, loss stiffness K'' = Im K*
  >= 0 for a passive layer (Im g <= 0), loss factor K''/K'. As f -> 0, G_C(f) -> g_static when
  E_qs = E(omega -> 0) (the default quasi-static modulus), so K*(f -> 0) is the quasi-static tangent.
  A tread with slow creep (the default fractional model creeps for seconds) must be held that long
  before a small harmonic oscillation about d0 sees this state; at 10 Hz the fractional tread is
  still about 60 % stiffer than its relaxed modulus, so K*(10 Hz) is well above the tangent.

* **Viscoelastic (QLV) springs** (``springs.rheology: qlv``, :mod:`tyreroad.qlv`): by the correspondence
  principle each spring is k_e(f) = k_e(zeta_e) E(f) / E_qs (the material's exact E(f)); K* is solved as
  c 1^T [c G_C + diag(1/k_e)]^-1 1 with c = E(f) / E_qs, the same value with real sqrt(k_e). The relaxed
  preload states are the elastic ones (a relaxed QLV spring is its table); the transient ones march the
  QLV springs.

Both are solved in the symmetric form A y = s, A = I + S G S, S = diag(sqrt(k_e)), K = s^T y
(unconjugated): A has eigenvalues >= 1 in the static case and stays well conditioned when an
element has just touched (k_e -> 0), where the form with 1/k_e would not. Two solvers, over the one
influence operator of the package (:class:`tyreroad.influence.OffsetInfluence`):

* dense (:func:`tyreroad.influence.contact_set_solve`): LU of A over the contact set, for patches
  up to the contact solver's FFT threshold (:data:`tyreroad.solver.FFT_THRESHOLD` elements);
* matrix-free (:func:`tyreroad.influence.contact_set_stiffness_krylov`): conjugate-orthogonal
  conjugate gradients (COCG; plain CG when G is real) on the Jacobi-scaled A, with G v by FFT
  convolution of the offset table on the padded grid of :func:`tyreroad.convolution.padded_shape`
  (exact linear convolution). A is complex symmetric (G_em = g(e - m) = g(m - e)), which is what
  COCG needs.

Choices (where the specification left one)
------------------------------------------
* The frequency grid is log-spaced from ``f_min`` to fs/2 (the greens file's sample rate) with the
  report frequencies (default 100 Hz, 1 kHz, 5 kHz) inserted, so the report reads K* there, not
  an interpolation.
* ``relaxed_stiffness`` is K*(f -> 0), from the element FRF at f = 0 with E(omega -> 0); it equals
  ``tangent_stiffness_qs`` (from g_static of the greens file and E_qs) when E_qs = E(0). Both are
  stored, so the f -> 0 check can be read from the file.
* The matrix-free solve warm-starts each frequency from the previous one's solution and stops at
  a relative residual ``krylov_tolerance`` (default 1e-12), which bounds the relative error of K*
  to about that times the condition number of the scaled A (measured: dense and matrix-free agree to
  < 1e-10 on the default patch).

References
----------
van der Vorst, H. A., & Melissen, J. B. M. (1990). A Petrov-Galerkin type method for solving Ax = b,
where A is symmetric complex. IEEE Trans. Magn. 26(2), 706-708. doi:10.1109/20.106415
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np
import xarray as xr

from . import checks
from .contact import PreloadStates, preload_states, run_loading_path, solve_path
from .influence import contact_set_solve, contact_set_stiffness_krylov
from .kernel import LayerKernel
from .loading import IndentationPath
from .qlv import springs_for_run
from .solver import SolverSettings
from .springs import SpringTable

logger = logging.getLogger(__name__)

__all__ = [
    "SpectrumSettings",
    "transient_states",
    "frequency_grid",
    "stiffness_spectrum",
    "spectrum_from_datasets",
    "first_harmonic",
    "harmonic_stiffness",
]

#: Preloads of the default study [m].
DEFAULT_PRELOADS = (5.0e-5, 1.0e-4, 1.5e-4, 2.0e-4)
#: Frequencies at which the report reads K* [Hz] (inserted into the grid).
DEFAULT_REPORT_FREQUENCIES = (100.0, 1000.0, 5000.0)

_KEYS = {"preloads", "f_min", "n_frequencies", "report_frequencies", "figure_preload",
         "krylov_tolerance", "krylov_max_iterations", "transient_speed"}


# --------------------------------------------------------------------------------------------
# settings
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SpectrumSettings:
    """What the stiffness spectrum stage computes (config section ``stiffness_spectrum``).

    Parameters
    ----------
    preloads : tuple of float
        Preload indentations d0 [m], increasing (default 0.05, 0.10, 0.15, 0.20 mm).
    f_min : float
        Lowest frequency of the log-spaced grid [Hz] (default 10); the highest is fs/2.
    n_frequencies : int
        Points of the log-spaced grid (default 61; the report frequencies come on top).
    report_frequencies : tuple of float
        Frequencies inserted into the grid, read by the report [Hz] (default 100, 1000, 5000).
    figure_preload : float or None
        The preload at which figure 9 compares the material variants [m]; one of ``preloads``
        (default: 0.1 mm when listed, else the middle preload).
    krylov_tolerance : float
        Relative residual at which the matrix-free solve stops (default 1e-12).
    krylov_max_iterations : int
        Iterations allowed per matrix-free solve before it is an error (default 3000).
    transient_speed : float
        Indentation speed [m/s] of the **transient** preload state (default 0.1 m/s: 0.1 mm in 1 ms,
        the loading time of an element under a tyre rolling at ~20 m/s): the dynamic run from contact
        to d0 at that speed, the working point of a rolling contact, beside the relaxed state.
    """

    preloads: tuple = DEFAULT_PRELOADS
    f_min: float = 10.0
    n_frequencies: int = 61
    report_frequencies: tuple = DEFAULT_REPORT_FREQUENCIES
    figure_preload: float | None = None
    krylov_tolerance: float = 1e-12
    krylov_max_iterations: int = 3000
    transient_speed: float = 0.1

    def __post_init__(self) -> None:
        where = "stiffness_spectrum"
        pre = _real_list(f"{where}.preloads", self.preloads)
        if pre.size == 0 or np.any(np.diff(pre) <= 0):
            raise ValueError(f"{where}.preloads: expected a non-empty increasing list of indentations > 0 [m], "
                             f"got {list(self.preloads)!r}")
        f_min = checks.real(f"{where}.f_min", self.f_min, positive=True)
        n = checks.integer(f"{where}.n_frequencies", self.n_frequencies, minimum=2)
        rep = _real_list(f"{where}.report_frequencies", self.report_frequencies)
        tol = checks.real(f"{where}.krylov_tolerance", self.krylov_tolerance, positive=True)
        if tol >= 1e-3:
            raise ValueError(f"{where}.krylov_tolerance: expected a relative residual < 1e-3, got {tol!r}")
        it = checks.integer(f"{where}.krylov_max_iterations", self.krylov_max_iterations)
        fig = self.figure_preload
        if fig is None:
            fig = 1.0e-4 if np.any(np.isclose(pre, 1.0e-4, rtol=1e-9, atol=0)) else float(pre[(pre.size - 1) // 2])
        fig = checks.real(f"{where}.figure_preload", fig, positive=True)
        if not np.any(np.isclose(pre, fig, rtol=1e-9, atol=0)):
            raise ValueError(f"{where}.figure_preload: expected one of the preloads {pre.tolist()} m, got {fig!r}")
        object.__setattr__(self, "preloads", tuple(pre.tolist()))
        object.__setattr__(self, "f_min", f_min)
        object.__setattr__(self, "n_frequencies", n)
        object.__setattr__(self, "report_frequencies", tuple(sorted(rep.tolist())))
        object.__setattr__(self, "figure_preload", float(pre[np.argmin(np.abs(pre - fig))]))
        object.__setattr__(self, "krylov_tolerance", tol)
        object.__setattr__(self, "krylov_max_iterations", it)
        object.__setattr__(self, "transient_speed", checks.real(f"{where}.transient_speed", self.transient_speed,
                                                               positive=True))

    @classmethod
    def from_config(cls, section: Mapping[str, Any] | None) -> "SpectrumSettings":
        """Build from the ``stiffness_spectrum`` config section; missing keys take the defaults.

        Raises
        ------
        ValueError
            Naming ``stiffness_spectrum.<key>`` for unknown keys and bad values.
        """
        section = dict(section or {})
        unknown = sorted(set(section) - _KEYS)
        if unknown:
            raise ValueError(f"stiffness_spectrum.{unknown[0]}: unknown key (expected one of {', '.join(sorted(_KEYS))})")
        for key in ("preloads", "report_frequencies"):
            if key in section:
                section[key] = tuple(_real_list(f"stiffness_spectrum.{key}", section[key]).tolist())
        return cls(**section)

    def frequencies(self, sample_rate: float) -> np.ndarray:
        """The analysis frequencies [Hz] for a kernel sampled at ``sample_rate`` (fs/2 the highest)."""
        return frequency_grid(self.f_min, 0.5 * checks.real("sample_rate", sample_rate, positive=True),
                              self.n_frequencies, self.report_frequencies)


def _real_list(name: str, value) -> np.ndarray:
    if isinstance(value, (str, bytes)) or not isinstance(value, (Sequence, np.ndarray)):
        raise ValueError(f"{name}: expected a list of numbers, got {value!r}")
    out = np.array([checks.real(f"{name}[{i}]", v, positive=True) for i, v in enumerate(value)], dtype=float)
    return out


def frequency_grid(f_min: float, f_max: float, n: int, extra: Sequence[float] = ()) -> np.ndarray:
    """``n`` log-spaced frequencies from ``f_min`` to ``f_max`` [Hz], with ``extra`` inserted (sorted, unique).

    Raises
    ------
    ValueError
        When f_min >= f_max, or an extra frequency lies outside [f_min, f_max].
    """
    f_min = checks.real("f_min", f_min, positive=True)
    f_max = checks.real("f_max", f_max, positive=True)
    n = checks.integer("n", n, minimum=2)
    if not f_min < f_max:
        raise ValueError(f"frequency grid: f_min = {f_min:g} Hz must be below f_max = fs/2 = {f_max:g} Hz")
    grid = np.geomspace(f_min, f_max, n)
    for f in extra:
        f = float(f)
        if not f_min <= f <= f_max:
            raise ValueError(f"frequency grid: report frequency {f:g} Hz outside [{f_min:g}, {f_max:g}] Hz")
    grid = np.concatenate([grid, np.asarray(extra, dtype=float)])
    grid = np.unique(grid)
    # drop grid points that coincide with an inserted frequency to round-off
    keep = np.concatenate([[True], np.diff(grid) > 1e-9 * grid[1:]])
    return grid[keep]


# --------------------------------------------------------------------------------------------
# the relaxed preload states
# --------------------------------------------------------------------------------------------
def transient_states(z1, springs, layer: LayerKernel, preloads, speed: float, settings: SolverSettings,
                     threads: int = 1) -> PreloadStates:
    """The contact states reached by loading to each preload at ``speed`` (the transient preload states).

    One dynamic run per preload, d(t_n) = d0 t_n / t_N from first contact (t_0 = 0) to d0, with
    t_N = ceil(d0 fs / v) / fs, i.e. the speed v rounded so that the last step lands on d0; the state
    is that last step's. A rolling contact loads an element for milliseconds: this is its working
    point, where the tread has had no time to relax.

    Parameters
    ----------
    z1 : array_like
        Road matching heights z1[ex, ey] [m].
    springs : tyreroad.springs.SpringTable
        Spring tables.
    layer : tyreroad.kernel.LayerKernel
        The dynamic kernel (kept lags and memory).
    preloads : sequence of float
        d0 [m].
    speed : float
        v [m/s].
    settings, threads
        As :func:`preload_states`.

    Returns
    -------
    PreloadStates
        ``tangent_stiffness`` is NaN (a dynamic state has no quasi-static tangent).
    """
    if layer.static:
        raise ValueError(f"{layer.name}: the transient preload state needs the dynamic kernel, got a static one")
    v = checks.real("transient_speed", speed, positive=True)
    z1 = np.asarray(z1, dtype=float)
    pre = np.asarray(preloads, dtype=float)
    zeta, force, count = [], [], []
    for d0 in pre:
        n = max(2, math.ceil(d0 * layer.sample_rate / v * (1.0 - 1e-12)))
        time_n = np.arange(n + 1) / layer.sample_rate
        if getattr(springs, "rheology", "elastic") == "qlv":  # the march's own QLV springs (tyreroad.qlv)
            result = run_loading_path(IndentationPath(z1, d0 * time_n / time_n[-1], time_n), springs, layer, settings,
                                      threads)
        else:
            result = solve_path(z1, springs.stiffness, springs.force, springs.zeta_step, layer,
                                d0 * time_n / time_n[-1], settings, time=time_n, threads=threads)
        zeta.append(result.compression[-1])
        force.append(result.force[-1])
        count.append(result.contact_count[-1])
        logger.info("transient state at d0 = %.3g mm (%d steps at %.4g m/s): F = %.4g N, %d elements in contact",
                    d0 * 1e3, n, d0 * layer.sample_rate / n, force[-1], count[-1])
    zeta = np.asarray(zeta)
    _, k = springs.evaluate(zeta.reshape((pre.size,) + springs.stiffness.shape[:-1]))
    return PreloadStates(preload=pre, compression=zeta, spring_stiffness=k.reshape(zeta.shape),
                         force=np.asarray(force), tangent_stiffness=np.full(pre.size, np.nan),
                         contact_count=np.asarray(count))


def _contact_set_spectrum(states: PreloadStates, influences, method: str, spectrum: "SpectrumSettings",
                          factors=None):
    """K* of every state and influence operator: values (P, F) complex, Krylov iterations (P, F).

    ``factors`` c_j (one per operator, QLV springs): spring stiffnesses c_j k_e, solved as
    K = c 1^T [c G + diag(1/k_e)]^-1 1 (the same as with G and diag(1/(c k_e))) so that the solvers'
    sqrt(k_e) stays real.
    """
    if factors is not None:
        factors = np.asarray(factors, dtype=complex)
        influences = [_ScaledInfluence(op, c) for op, c in zip(influences, factors)]
        values, iterations = _contact_set_spectrum(states, influences, method, spectrum)
        return values * factors[None, :], iterations
    n_p, n_f = states.preload.size, len(influences)
    values = np.zeros((n_p, n_f), dtype=complex)
    iterations = np.zeros((n_p, n_f), dtype=np.int64)
    k_flat = states.spring_stiffness.reshape(n_p, -1)
    if method == "dense":
        for p in range(n_p):
            active = np.flatnonzero(k_flat[p])
            if active.size == 0:
                continue
            s = np.sqrt(k_flat[p, active])
            for j in range(n_f):
                values[p, j] = contact_set_solve(influences[j].block(active), s)
        return values, iterations
    starts = [None] * n_p
    for j in range(n_f):
        op = influences[j]
        for p in range(n_p):
            start = starts[p]
            if start is not None and j == 1:
                start = start.astype(complex)
            values[p, j], iterations[p, j], starts[p] = contact_set_stiffness_krylov(
                op, states.spring_stiffness[p], op.g_self, spectrum.krylov_tolerance, spectrum.krylov_max_iterations,
                start)
    return values, iterations


class _ScaledInfluence:
    """c G of an influence operator (``block``, ``g_self`` and G v scaled by the complex factor c)."""

    def __init__(self, op, factor: complex):
        self.op = op
        self.factor = complex(factor)
        self.g_self = self.factor * op.g_self

    def block(self, active):
        return self.factor * self.op.block(active)

    def __call__(self, v):
        return self.factor * self.op(v)


# --------------------------------------------------------------------------------------------
# the spectrum
# --------------------------------------------------------------------------------------------
def stiffness_spectrum(
    z1,
    springs,
    relaxed: LayerKernel,
    response,
    material,
    sample_rate: float,
    spectrum: SpectrumSettings,
    settings: SolverSettings,
    threads: int = 1,
    method: str | None = None,
    layer: LayerKernel | None = None,
) -> xr.Dataset:
    """K*(f; d0) of a rough contact about its relaxed preload states (SPEC 11), and about its transient ones.

    Parameters
    ----------
    z1 : array_like
        Road matching heights z1[ex, ey] [m].
    springs : tyreroad.springs.SpringTable
        Element spring tables.
    relaxed : tyreroad.kernel.LayerKernel
        The static kernel of the relaxed state (the greens file's g_static).
    response : tyreroad.greens.ElementFRF or tyreroad.kernel.LayerKernel
        The layer's frequency response as influence operators G(f) on the patch
        (``frequency_influences(frequencies, shape, workers)``, real at f = 0): the material's exact
        element FRF, or a kernel's own transfer function (or a kernel's own operators).
    material : tyreroad.material.Material
        The tread material (its name and moduli are recorded; E_qs vs E(0) is checked).
    sample_rate : float
        fs of the study [Hz]; the grid ends at fs/2.
    spectrum : SpectrumSettings
        Preloads and frequencies.
    settings : tyreroad.solver.SolverSettings
        The contact solver settings (the preload solve; ``method`` picks dense or matrix-free).
    threads : int
        numba threads and FFT workers.
    method : {"dense", "fft"}, optional
        Override of ``settings.resolved_method`` (tests, benchmarks).
    layer : tyreroad.kernel.LayerKernel, optional
        The dynamic kernel: with it, K* is also computed about the transient preload states
        (:func:`transient_states` at ``spectrum.transient_speed``), the ``*_transient`` variables.

    Returns
    -------
    xarray.Dataset
        See docs/data_contracts.md "Stiffness spectrum dataset".
    """
    t0 = time.perf_counter()
    z1 = np.asarray(z1, dtype=float)
    shape = z1.shape
    n_elem = z1.size
    method = settings.resolved_method(n_elem) if method is None else method
    if method not in ("dense", "fft"):
        raise ValueError(f"method: expected 'dense' or 'fft', got {method!r}")
    element_size = getattr(response, "element_size", None) or relaxed.element_size
    if element_size is None:
        raise ValueError(f"{relaxed.name}: the stiffness spectrum records the element size; neither the relaxed "
                         "kernel nor the response has one (LayerKernel element_size)")
    freq = spectrum.frequencies(sample_rate)
    states = preload_states(z1, springs, relaxed, spectrum.preloads, settings, threads)
    t_states = time.perf_counter() - t0
    # f = 0 first: the relaxed limit, E(omega -> 0)
    influences = response.frequency_influences(np.concatenate([[0.0], freq]), shape, threads)
    t_frf = time.perf_counter() - t0 - t_states
    n_p = states.preload.size
    # QLV springs (tyreroad.qlv): k_e(f) = k_e E(f) / E_s, the correspondence principle; elastic: None
    qlv = getattr(springs, "rheology", "elastic") == "qlv"
    factors = springs.frequency_factor(material, np.concatenate([[0.0], freq])) if qlv else None
    values, iterations = _contact_set_spectrum(states, influences, method, spectrum, factors)
    transient = None
    if layer is not None:
        moving = transient_states(z1, springs, layer, spectrum.preloads, spectrum.transient_speed, settings, threads)
        transient = (moving, _contact_set_spectrum(moving, influences[1:], method, spectrum,
                                                   None if factors is None else factors[1:])[0])
    k_relaxed = values[:, 0].real
    k_star = values[:, 1:]
    elapsed = time.perf_counter() - t0
    logger.info(
        "stiffness spectrum %s: %d x %d patch, %d preloads x %d frequencies, %s; preload states %.2f s, "
        "element FRF %.2f s, solves %.2f s, total %.2f s%s",
        material.name, shape[0], shape[1], n_p, freq.size, method, t_states, t_frf, elapsed - t_states - t_frf,
        elapsed, f"; Krylov iterations per solve median {int(np.median(iterations))}, max {int(iterations.max())}"
        if method == "fft" else "",
    )
    for p in range(n_p):
        logger.info(
            "d0 = %.3g mm: %d elements in contact, F = %.4g N, K_qs = %.5g N/m, K*(f->0)/K_qs - 1 = %.2e, "
            "K'(%.4g Hz) = %.5g N/m", states.preload[p] * 1e3, states.contact_count[p], states.force[p],
            states.tangent_stiffness[p], k_relaxed[p] / states.tangent_stiffness[p] - 1, freq[0], k_star[p, 0].real,
        )
    e0 = float(np.real(material.modulus(0.0)))
    e_qs = float(material.quasi_static_modulus)
    if not math.isclose(e0, e_qs, rel_tol=1e-9):
        logger.warning("quasi-static modulus %.6g Pa differs from E(omega -> 0) = %.6g Pa: K*(f -> 0) is not the "
                       "tangent of the relaxed state", e_qs, e0)
    ds = _dataset(states, freq, k_star, k_relaxed, iterations[:, 1:], method, n_elem, material, element_size,
                  sample_rate, e0, e_qs)
    if transient is not None:
        _add_transient(ds, *transient, n_elem, spectrum.transient_speed)
    if qlv:
        ds.attrs["spring_rheology"] = "qlv"
        ds.attrs["spring_formula"] = "QLV springs: k_e(f) = k_e(zeta_e) E(f) / E_s (correspondence principle)"
    ds.attrs["report_frequencies"] = np.asarray(spectrum.report_frequencies, dtype=float)
    ds.attrs["figure_preload"] = float(spectrum.figure_preload)
    return ds


_PRELOAD_STATE = (
    "relaxed preload state: the quasi-static contact solution at the preload d0 with the quasi-static kernel "
    "g_static (modulus E_qs), i.e. after the tread has relaxed completely; K* is the small-amplitude stiffness "
    "F_hat/delta_hat of a harmonic indentation d0 + delta sin(2 pi f t) about that state (exp(+i omega t))"
)


def _dataset(states, freq, k_star, relaxed, iterations, method, n_elem, material, element_size, sample_rate,
             e0, e_qs) -> xr.Dataset:
    def attrs(units, long_name):
        return {"units": units, "long_name": long_name}

    pf = ("preload", "frequency")
    k_abs = np.abs(k_star)
    data = {
        "storage_stiffness": (pf, k_star.real, attrs("N/m", "storage contact stiffness K' = Re K*")),
        "loss_stiffness": (pf, k_star.imag, attrs("N/m", "loss contact stiffness K'' = Im K* (>= 0: passive)")),
        "loss_factor": (pf, k_star.imag / k_star.real, attrs("1", "loss factor of the contact K''/K'")),
        "stiffness_magnitude": (pf, k_abs, attrs("N/m", "magnitude |K*| of the complex contact stiffness")),
        "relaxed_stiffness": ("preload", relaxed, attrs(
            "N/m", "K*(f -> 0): the contact-set stiffness with the element FRF at f = 0 (modulus E(omega -> 0))")),
        "tangent_stiffness_qs": ("preload", states.tangent_stiffness, attrs(
            "N/m", "dF/dd of the quasi-static curve at d0 (tangent of the relaxed state, kernel g_static)")),
        "preload_force": ("preload", states.force, attrs("N", "total contact force of the relaxed state at d0")),
        "contact_fraction": ("preload", states.contact_count / n_elem, attrs(
            "1", "fraction of elements in contact at d0 (relaxed state)")),
        "contact_count": ("preload", states.contact_count, attrs("1", "elements in contact at d0 (relaxed state)")),
        "krylov_iterations": (pf, iterations, attrs(
            "1", "matrix-free solver iterations (G products) per solve; 0 for the dense solve")),
    }
    coords = {
        "preload": ("preload", states.preload, attrs("m", "preload indentation d0")),
        "frequency": ("frequency", freq, attrs("Hz", "frequency")),
    }
    return xr.Dataset(data, coords=coords, attrs={
        "material": str(material.name),
        "preload_state": _PRELOAD_STATE,
        "sign_convention": "exp(+i omega t); F_hat = K* delta_hat; Im K* >= 0 for a passive contact",
        "formula": "K* = 1^T [G_C(f) + diag(1/k_e)]^-1 1 over the contact set C of the relaxed state",
        "method": method,
        "sample_rate": float(sample_rate),
        "element_size": float(element_size),
        "quasi_static_modulus": e_qs,
        "zero_frequency_modulus": e0,
    })


def _add_transient(ds: xr.Dataset, states: PreloadStates, k_star: np.ndarray, n_elem: int, speed: float) -> None:
    """The transient state's K* and state variables in the spectrum dataset."""
    pf = ("preload", "frequency")
    where = f"transient preload state (loaded from first contact to d0 at {speed:g} m/s)"
    ds["storage_stiffness_transient"] = (pf, k_star.real, {"units": "N/m", "long_name": f"K' of the {where}"})
    ds["loss_stiffness_transient"] = (pf, k_star.imag, {"units": "N/m", "long_name": f"K'' of the {where}"})
    ds["loss_factor_transient"] = (pf, k_star.imag / k_star.real, {"units": "1", "long_name": f"K''/K' of the {where}"})
    ds["transient_force"] = ("preload", states.force, {"units": "N", "long_name": f"total contact force of the {where}"})
    ds["transient_contact_fraction"] = ("preload", states.contact_count / n_elem,
                                        {"units": "1", "long_name": f"fraction of elements in contact, {where}"})
    ds.attrs["transient_speed"] = float(speed)


def spectrum_from_datasets(surface: xr.Dataset, springs: xr.Dataset, greens: xr.Dataset, material,
                           spectrum: SpectrumSettings, settings: SolverSettings, threads: int = 1,
                           method: str | None = None) -> xr.Dataset:
    """:func:`stiffness_spectrum` from the stage datasets (surface, springs, greens of one material).

    The relaxed state uses the greens file's static kernel (that of the study's quasi-static runs);
    the element FRF is computed afresh at the analysis frequencies; fs is the greens file's.
    """
    relaxed = LayerKernel.from_greens(greens, "quasistatic", material)
    if relaxed.element_size is None:
        raise ValueError("greens dataset: no element_size attribute")
    relaxed.check_element_size(surface.attrs.get("element_size"))
    z1 = surface["z1"].transpose("ex", "ey").values
    table = springs_for_run(springs, SpringTable.from_dataset(springs))
    from .belt_stage import response_of

    # the layer's element FRF, or tread + belt's for a greens file built with the flexible belt
    return stiffness_spectrum(z1, table, relaxed, response_of(greens, material), material,
                              relaxed.sample_rate, spectrum, settings, threads, method,
                              layer=LayerKernel.from_greens(greens, "dynamic", material))


# --------------------------------------------------------------------------------------------
# time-domain check
# --------------------------------------------------------------------------------------------
def first_harmonic(time_s, signal, frequency: float, start: float = 0.0) -> complex:
    """Complex amplitude X of x(t) ~ a + b (t - start) + Re(X exp(i omega t)) by least squares over t >= start.

    Parameters
    ----------
    time_s : array_like
        t [s].
    signal : array_like
        x(t) (any unit).
    frequency : float
        f [Hz].
    start : float
        First time used [s] (after the transient).

    Returns
    -------
    complex
        X [unit of x]; exp(+i omega t) convention.
    """
    t = np.asarray(time_s, dtype=float)
    x = np.asarray(signal, dtype=float)
    f = checks.real("frequency", frequency, positive=True)
    sel = t >= start
    if np.count_nonzero(sel) < 8:
        raise ValueError(f"first_harmonic: {np.count_nonzero(sel)} samples after t = {start:g} s; need >= 8")
    t, x = t[sel], x[sel]
    w = 2 * np.pi * f
    design = np.column_stack([np.ones_like(t), t - t[0], np.cos(w * t), np.sin(w * t)])
    coef, *_ = np.linalg.lstsq(design, x, rcond=None)
    # c cos + s sin = Re((c - i s) exp(i w t))
    return complex(coef[2], -coef[3])


def harmonic_stiffness(result, frequency: float, settle: float) -> complex:
    """First-harmonic F_hat / delta_hat of a harmonic-loading run (:mod:`tyreroad.loading` kind harmonic).

    Parameters
    ----------
    result : tyreroad.contact.ContactResult
        A dynamic run with time and indentation.
    frequency : float
        The loading frequency [Hz].
    settle : float
        Time after which the response is taken as steady [s] (measured from t = 0).

    Returns
    -------
    complex
        F_hat / delta_hat [N/m].
    """
    if result.time is None:
        raise ValueError("harmonic_stiffness: the run has no time axis (a quasi-static run)")
    f_hat = first_harmonic(result.time, result.force, frequency, settle)
    d_hat = first_harmonic(result.time, result.indentation, frequency, settle)
    return f_hat / d_hat
