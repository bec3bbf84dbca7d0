"""Rolling contact: a slick tyre rolling over the road strip (SPEC section 12).

A cylinder of radius R (a slick tyre without crown, its belt rigid, the axle at a fixed height)
rolls without slip at speed v along x over a road strip of nx x ny elements. In the road frame
the tread material in contact does not move sideways; its undeformed surface follows the belt,

    z2_e(t) = z_top - d0 + (x_e - x_c(t))^2 / (2 R),      x_c(t) = x_0 + v t,

(the parabolic approximation of the circle), so the free compression of spring e at step n is
z1_e - z2_e[n] = gap0_e + d0 - (x_e - x_c[n])^2 / (2 R), gap0 = z1 - z_top, z_top = max z1. This
is a :class:`RollingPass`, a loading of :mod:`tyreroad.loading`'s protocol: the march loop, the
Newton driver and the histories (kept lags and the long-memory tail) are those of
:mod:`tyreroad.contact`, unchanged.

Assumptions (stated as SPEC 12 asks):

* The layer keeps the Green's functions of a flat, laterally infinite layer. This is valid when
  the tread thickness h is small against the contact length 2a and both are small against R
  (default: h = 10 mm, 2a ~ 20 mm, R = 300 mm; the first inequality is only marginal, so the
  layer's curvature and the finite belt are neglected, not resolved).
* The tread layer is fixed in the road frame while in contact (no slip, no sideways motion).
* d0 (the axle height) is constant over the pass: it is set from a wheel load through a
  quasi-static solve with the contact centred on the strip (:func:`static_indentation`), or given.

Quantities of a pass (:func:`rolling_dataset`):

* total force F(t), contact count, pressure centre x_p = sum F_e x_e / F;
* the belt power P = sum_e F_e (-dz2_e/dt) = (v / R) sum_e F_e (x_e - x_c) (the force's moment
  about x_c, times v / R), and the work W = int P dt over the pass from first to last contact
  (trapezoid rule at the steps). Every road element passes under the whole contact once in a
  pass, so the rolled distance of the rolling-loss force W / dx is the strip length dx = nx c
  (not the distance from first to last contact, which adds the entry and exit);
* the steady part: x_c with the contact half-length a = sqrt(2 R d0) plus a margin of
  ``steady_margin`` elements fully on the strip; mean force, mean belt power / v (the steady
  rolling-loss force, a cross-check of W / dx);
* element forces at chosen instants (x_c at given fractions of the strip length);
* the 1/3-octave spectrum of the force fluctuation over the steady part (:func:`band_levels`).

Quasi-static passes solve static states at x_c on a grid of ``quasistatic_step`` that does not
depend on the speed (the speed only labels their time axis t = (x_c - x_0) / v), so that two speeds
give the same F(x_c): a quasi-static pass has no rate effect.

References
----------
Winroth, Andersson & Kropp (2014), J. Sound Vib. 333(21), 5378-5385 (the contact model).
ANSI S1.11 / IEC 61260: base-10 one-third-octave band centres f_c = 1000 * 10^(k/10) Hz.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np
import xarray as xr

from . import checks
from .contact import MODES, SolverSettings, run_loading_path
from .memory import TailModel
from .springs import SpringTable

logger = logging.getLogger(__name__)

__all__ = [
    "RollingSettings",
    "RollingPass",
    "RollingRecorder",
    "RollingResult",
    "contact_half_length",
    "pass_limits",
    "pass_positions",
    "static_indentation",
    "solve_rolling",
    "solve_rolling_run",
    "belt_power",
    "pass_work",
    "steady_mask",
    "rolling_dataset",
    "third_octave_centres",
    "band_levels",
    "aggregate_rolling",
    "rolling_section",
]


# --------------------------------------------------------------------------------------------
# Settings (config section ``rolling``)
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class RollingSettings:
    """What a rolling pass needs of the config section ``rolling`` (SI units).

    Parameters
    ----------
    radius : float
        Tyre radius R [m] (default 0.3).
    load : float or None
        Wheel load on the strip [N] (default 500 for the 20 mm wide strip); sets d0 by a
        quasi-static solve. Exactly one of ``load`` and ``d0`` is given.
    d0 : float or None
        Indentation of the belt below the highest road peak at x_c [m].
    x_start, x_end : float or None
        Pass: first and last contact centre x_c [m] from the strip's start; None: the contact
        half-length a = sqrt(2 R d0) plus ``entry_margin`` elements outside the strip.
    quasistatic_step : float
        x_c step of quasi-static passes [m] (default 1e-4).
    steady_margin : int
        Elements beyond the contact half-length that the contact must be inside the strip for
        the steady part (default 2).
    steady_entry : float
        Distance [m] the contact's rear (x_c - a) must have travelled onto the strip before the
        steady part begins (default 0.03, 3 h of the default tread): the layer spreads the
        memory of earlier forces over a few thicknesses, and before that the strip behind the
        contact is shorter than the memory's reach (the force still drifts by ~0.5 %).
    entry_margin : int
        Elements beyond a before the strip starts and after it ends of the automatic pass (default 3).
    snapshots : tuple of float
        x_c of the stored element force maps, as fractions of the strip length (default 0.25, 0.5, 0.75).
    band_limits : tuple of float
        Lowest and highest 1/3-octave band centres of the force spectrum [Hz] (default 100, 5000).
    """

    radius: float = 0.3
    load: float | None = 500.0
    d0: float | None = None
    x_start: float | None = None
    x_end: float | None = None
    quasistatic_step: float = 1.0e-4
    steady_margin: int = 2
    steady_entry: float = 0.03
    entry_margin: int = 3
    snapshots: tuple[float, ...] = (0.25, 0.5, 0.75)
    band_limits: tuple[float, float] = (100.0, 5000.0)

    def __post_init__(self) -> None:
        checks.real("rolling.radius", self.radius, positive=True)
        if (self.load is None) == (self.d0 is None):
            raise ValueError("rolling: give exactly one of rolling.load [N] and rolling.d0 [m] (the other null)")
        if self.load is not None:
            checks.real("rolling.load", self.load, positive=True)
        if self.d0 is not None:
            checks.real("rolling.d0", self.d0, positive=True)
        checks.real("rolling.quasistatic_step", self.quasistatic_step, positive=True)
        checks.integer("rolling.steady_margin", self.steady_margin, minimum=0)
        checks.real("rolling.steady_entry", self.steady_entry, nonnegative=True)
        checks.integer("rolling.entry_margin", self.entry_margin, minimum=0)
        if (self.x_start is None) != (self.x_end is None):
            raise ValueError("rolling.pass: give both x_start and x_end [m], or neither (automatic pass)")
        if self.x_start is not None and not self.x_start < self.x_end:
            raise ValueError(f"rolling.pass: expected x_start < x_end [m], got [{self.x_start}, {self.x_end}]")
        if not self.snapshots or any(not 0.0 <= s <= 1.0 for s in self.snapshots):
            raise ValueError(f"rolling.snapshots: expected fractions of the strip length in [0, 1], got {self.snapshots}")
        lo, hi = self.band_limits
        if not 0 < lo <= hi:
            raise ValueError(f"rolling.band_limits: expected 0 < low <= high [Hz], got {list(self.band_limits)}")

    @classmethod
    def from_config(cls, section: Mapping[str, Any] | None) -> "RollingSettings":
        """Build from the ``rolling`` config section (its study keys surface/materials/speeds are ignored)."""
        s = dict(section or {})
        pass_ = s.get("pass") or [None, None]
        return cls(
            radius=float(s.get("radius", 0.3)),
            load=None if s.get("load", 500.0) is None else float(s.get("load", 500.0)),
            d0=None if s.get("d0") is None else float(s["d0"]),
            x_start=None if pass_[0] is None else float(pass_[0]),
            x_end=None if pass_[1] is None else float(pass_[1]),
            quasistatic_step=float(s.get("quasistatic_step", 1e-4)),
            steady_margin=int(s.get("steady_margin", 2)),
            steady_entry=float(s.get("steady_entry", 0.03)),
            entry_margin=int(s.get("entry_margin", 3)),
            snapshots=tuple(float(v) for v in s.get("snapshots", (0.25, 0.5, 0.75))),
            band_limits=tuple(float(v) for v in s.get("band_limits", (100.0, 5000.0))),
        )


def contact_half_length(radius: float, d0: float) -> float:
    """Geometric contact half-length a = sqrt(2 R d0) [m] of the belt on the highest peaks."""
    return math.sqrt(2.0 * radius * d0)


def pass_limits(settings: RollingSettings, d0: float, element_x: np.ndarray, element_size: float) -> tuple[float, float]:
    """(x_start, x_end) [m] of the pass: the configured ones, or a + entry_margin elements outside the strip."""
    if settings.x_start is not None:
        return float(settings.x_start), float(settings.x_end)
    a = contact_half_length(settings.radius, d0)
    reach = a + settings.entry_margin * element_size
    return float(element_x[0] - reach), float(element_x[-1] + reach)


def pass_positions(mode: str, speed: float, x_start: float, x_end: float, sample_rate: float,
                   quasistatic_step: float) -> tuple[np.ndarray, np.ndarray]:
    """(t [s], x_c [m]) of a pass.

    Dynamic: t_n = n / fs, x_c = x_start + v t_n up to the first x_c >= x_end. Quasi-static: x_c on
    the grid x_start + k * quasistatic_step (independent of v) up to the first >= x_end, and
    t = (x_c - x_start) / v.
    """
    v = checks.real("speed", speed, positive=True)
    length = x_end - x_start
    if mode == "dynamic":
        dx = v / checks.real("sample_rate", sample_rate, positive=True)
    elif mode == "quasistatic":
        dx = checks.real("quasistatic_step", quasistatic_step, positive=True)
    else:
        raise ValueError(f"mode: expected one of {MODES}, got {mode!r}")
    n_last = math.ceil(length / dx * (1.0 - 1e-12))
    k = np.arange(n_last + 1)
    x_c = x_start + k * dx
    time = k / sample_rate if mode == "dynamic" else (x_c - x_start) / v
    return time, x_c


# --------------------------------------------------------------------------------------------
# The loading
# --------------------------------------------------------------------------------------------
class RollingPass:
    """The belt of a rolling tyre as a loading (:mod:`tyreroad.loading` protocol).

    Free compression of spring e at step n: gap0_e + d0 - (x_e - x_c[n])^2 / (2 R), the road
    height above the undeformed tread surface z2_e[n] = z_top - d0 + (x_e - x_c[n])^2 / (2 R).

    Parameters
    ----------
    z1 : array_like
        Road matching heights z1[ex, ey] [m].
    element_x : array_like
        x of the element centres [m], shape (nx,).
    radius : float
        Tyre radius R [m].
    d0 : float
        Indentation of the belt below the highest peak [m].
    x_c : array_like
        Contact centre x_c[n] [m], one per step.
    time : array_like, optional
        t_n [s].
    speed : float, optional
        v [m/s] (for the belt's velocity dz2/dt); None for static states without a time axis.
    """

    def __init__(self, z1, element_x, radius: float, d0: float, x_c, time=None, speed: float | None = None):
        z1 = checks.finite_array("z1", z1, ndim=2)
        if z1.size == 0:
            raise ValueError("z1: expected a finite 2-D array of element heights [m], got an empty array")
        self.shape = z1.shape
        ex = checks.finite_array("element_x", element_x, ndim=1)
        if ex.size != z1.shape[0]:
            raise ValueError(f"element_x: expected {z1.shape[0]} values (one per element along x), got {ex.size}")
        self.radius = checks.real("radius", radius, positive=True)
        self.d0 = checks.real("d0", d0, positive=True)
        self.x_c = checks.finite_array("x_c", x_c, ndim=1)
        if self.x_c.size == 0:
            raise ValueError("x_c: expected at least one step [m]")
        self.n_steps = self.x_c.size
        if time is not None:
            time = checks.finite_array("time", time, ndim=1)
            if time.size != self.n_steps:
                raise ValueError(f"time: expected {self.n_steps} values (one per step), got {time.size}")
        self.time = time
        self.speed = None if speed is None else checks.real("speed", speed, positive=True)
        self.element_x = ex
        # per element, flattened like z1.ravel(): x of its column
        self._x = np.repeat(ex, z1.shape[1])
        self._base = z1.ravel() - z1.max() + self.d0

    def undeformed_surface(self, n: int) -> np.ndarray:
        """z2_e[n] - z_top [m], shape (M,): the tread surface below the highest peak."""
        return -self.d0 + (self._x - self.x_c[n]) ** 2 / (2.0 * self.radius)

    def free_compression(self, n: int) -> np.ndarray:
        """z1_e - z2_e[n] [m], shape (M,)."""
        return self._base - (self._x - self.x_c[n]) ** 2 / (2.0 * self.radius)

    def rest_compression(self) -> np.ndarray:
        """The free compression at the first x_c (the pass starts out of contact)."""
        return self.free_compression(0)

    def describe(self, n: int) -> str:
        """``x_c = ... m`` of step n."""
        return f"x_c = {self.x_c[n]:.6e} m"

    def prescribed(self) -> dict[str, tuple[np.ndarray, str, str]]:
        """The contact centre x_c[n] (the z2 field follows from it, :meth:`undeformed_surface`)."""
        return {"x_c": (self.x_c.copy(), "m", "contact centre x_c (the belt's lowest point)")}

    def done(self, n: int, force: np.ndarray) -> bool:
        """A pass runs to its last step."""
        return False

    def unfinished(self, n: int) -> str | None:
        """Nothing is required of the last step (the run checks that the contact has left the strip)."""
        return None

    def lever(self, n: int) -> np.ndarray:
        """x_e - x_c[n] [m], shape (M,)."""
        return self._x - self.x_c[n]


# --------------------------------------------------------------------------------------------
# Recording a pass
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class RollingResult:
    """Step series of one rolling pass.

    Attributes
    ----------
    time, x_c : numpy.ndarray
        t_n [s] and the contact centre [m], shape (n,).
    force : numpy.ndarray
        Total contact force [N].
    contact_count : numpy.ndarray
        Elements with F_e > 0.
    moment : numpy.ndarray
        sum_e F_e (x_e - x_c) [N m]; the belt power is v / R times it.
    pressure_centre : numpy.ndarray
        sum_e F_e x_e / F [m] (NaN without contact).
    snapshot_step : numpy.ndarray
        Steps of the stored element force maps.
    snapshot_force : numpy.ndarray
        F_e at those steps [N], shape (n_snapshots, nx, ny).
    newton_iterations, krylov_iterations : numpy.ndarray
        Per step.
    residual : numpy.ndarray
        Final max|R| per step [m].
    """

    time: np.ndarray
    x_c: np.ndarray
    force: np.ndarray
    contact_count: np.ndarray
    moment: np.ndarray
    pressure_centre: np.ndarray
    snapshot_step: np.ndarray
    snapshot_force: np.ndarray
    newton_iterations: np.ndarray
    krylov_iterations: np.ndarray
    residual: np.ndarray


class RollingRecorder:
    """Keeps the totals of every step and the element forces at a few steps only.

    A pass of 150 x 20 elements over ~1800 steps would hold ~130 MB per field if every step's
    element fields were kept; the march only needs an object with ``store`` and ``result``
    (and ``contact_count`` for its log).

    Parameters
    ----------
    loading : RollingPass
        The pass (its lever arms x_e - x_c).
    snapshot_steps : sequence of int
        Steps whose element forces are kept.
    """

    def __init__(self, loading: RollingPass, snapshot_steps: Sequence[int]):
        n = loading.n_steps
        self.loading = loading
        self.shape = loading.shape
        self.force = np.zeros(n)
        self.moment = np.zeros(n)
        self.first_moment = np.zeros(n)
        self.contact_count = np.zeros(n, dtype=np.int64)
        self.newton_iterations = np.zeros(n, dtype=np.int64)
        self.krylov_iterations = np.zeros(n, dtype=np.int64)
        self.residual = np.zeros(n)
        self.snapshot_steps = np.asarray(sorted(set(int(s) for s in snapshot_steps)), dtype=np.int64)
        self.snapshots = np.zeros((self.snapshot_steps.size, loading.shape[0] * loading.shape[1]))

    def store(self, n: int, step, displacement: np.ndarray) -> None:
        """Record the converged ``step`` (a :class:`tyreroad.newton.StepResult`) of step n."""
        f = step.force
        lever = self.loading.lever(n)
        self.force[n] = f.sum()
        self.moment[n] = f @ lever
        self.contact_count[n] = np.count_nonzero(f)
        self.newton_iterations[n] = step.newton_iterations
        self.krylov_iterations[n] = step.krylov_iterations
        self.residual[n] = step.residual
        where = np.flatnonzero(self.snapshot_steps == n)
        if where.size:
            self.snapshots[where[0]] = f

    def result(self, loading: RollingPass, n_steps: int | None = None) -> RollingResult:
        n = self.force.size if n_steps is None else n_steps
        with np.errstate(invalid="ignore", divide="ignore"):
            centre = np.where(self.force[:n] > 0, loading.x_c[:n] + self.moment[:n] / self.force[:n], np.nan)
        keep = self.snapshot_steps < n
        return RollingResult(
            time=np.asarray(loading.time, dtype=float)[:n] if loading.time is not None else np.full(n, np.nan),
            x_c=loading.x_c[:n].copy(),
            force=self.force[:n].copy(),
            contact_count=self.contact_count[:n].copy(),
            moment=self.moment[:n].copy(),
            pressure_centre=centre,
            snapshot_step=self.snapshot_steps[keep],
            snapshot_force=self.snapshots[keep].reshape((-1,) + tuple(self.shape)),
            newton_iterations=self.newton_iterations[:n].copy(),
            krylov_iterations=self.krylov_iterations[:n].copy(),
            residual=self.residual[:n].copy(),
        )


# --------------------------------------------------------------------------------------------
# Solving
# --------------------------------------------------------------------------------------------
def _march(loading: RollingPass, springs: SpringTable, kernel: np.ndarray, settings: SolverSettings,
           threads: int, tail, snapshot_steps=()) -> RollingResult:
    return run_loading_path(loading, springs, kernel, settings, threads, tail,
                            recorder=RollingRecorder(loading, snapshot_steps))


def static_indentation(z1, element_x, springs: SpringTable, kernel_static, radius: float, load: float,
                       x_c: float, settings: SolverSettings, threads: int = 1) -> float:
    """d0 [m] at which the quasi-static contact centred at x_c carries ``load`` [N].

    F(d0) is continuous and increasing; it is bracketed by doubling from 10 um and solved by
    Brent's method to 1e-13 m (each evaluation one static solve with the static kernel).

    Raises
    ------
    ValueError
        If the load needs an indentation beyond the spring tables.
    """
    from scipy.optimize import brentq

    load = checks.real("rolling.load", load, positive=True)
    gs = np.asarray(kernel_static, dtype=float)[:, :, None]
    # a two-point (linear) table extends exactly beyond its grid: bound the search by 1 mm then
    zeta_max = max(springs.zeta_step * (springs.stiffness.shape[-1] - 1), 1e-3)

    def force(d0):
        if d0 <= 0.0:
            return -load
        res = _march(RollingPass(z1, element_x, radius, d0, [x_c]), springs, gs, settings, threads, None)
        return float(res.force[0]) - load

    hi = 1e-5
    while force(hi) <= 0:
        hi *= 2.0
        if hi > zeta_max:
            raise ValueError(f"rolling.load = {load:g} N: not reached at d0 = {hi:g} m; expected a load the strip "
                             "can carry within the spring tables")
    d0 = brentq(force, 0.0, hi, xtol=1e-13, rtol=1e-12)
    logger.info("rolling: d0 = %.6e m carries %.6g N at x_c = %.4g m", d0, load, x_c)
    return float(d0)


def solve_rolling(
    z1,
    element_x,
    springs: SpringTable,
    kernel,
    kernel_static,
    mode: str,
    speed: float,
    settings: RollingSettings,
    solver: SolverSettings,
    sample_rate: float,
    threads: int = 1,
    tail: TailModel | None = None,
    d0: float | None = None,
) -> tuple[RollingResult, dict[str, float]]:
    """One rolling pass over the strip (SPEC 12), dynamic or quasi-static.

    Parameters
    ----------
    z1 : array_like
        Road matching heights z1[ex, ey] [m].
    element_x : array_like
        x of the element centres [m].
    springs : SpringTable
        One spring per element.
    kernel : array_like
        g[dx, dy, lag] [m/N] (dynamic runs).
    kernel_static : array_like
        g_static[dx, dy] [m/N] (quasi-static runs and the d0 solve).
    mode : {"dynamic", "quasistatic"}
        Run type.
    speed : float
        v [m/s].
    settings : RollingSettings
        Radius, load or d0, pass, quasi-static step, snapshots.
    solver : SolverSettings
        Newton tolerance, method (dense / FFT), long memory.
    sample_rate : float
        fs of the kernel [Hz]: the time step of dynamic runs.
    threads : int
        numba threads and FFT workers.
    tail : TailModel, optional
        The kernel beyond its kept lags (every dynamic pass is longer than 256 steps).
    d0 : float, optional
        The indentation, if already known (overrides the settings' load / d0).

    Returns
    -------
    result : RollingResult
    info : dict
        ``d0``, ``x_start``, ``x_end``, ``half_length``, ``strip_length``, ``element_size``.

    Raises
    ------
    ValueError
        If the pass starts or ends with the contact on the strip.
    tyreroad.contact.ContactConvergenceError
        If a step does not converge.
    """
    z1 = np.asarray(z1, dtype=float)
    ex = np.asarray(element_x, dtype=float)
    if mode not in MODES:
        raise ValueError(f"mode: expected one of {MODES}, got {mode!r}")
    c = float(ex[1] - ex[0]) if ex.size > 1 else 2.0 * float(ex[0])
    gs = np.asarray(kernel_static, dtype=float)
    if d0 is None:
        d0 = settings.d0
    if d0 is None:
        centre = 0.5 * (ex[0] + ex[-1])
        d0 = static_indentation(z1, ex, springs, gs, settings.radius, settings.load, centre, solver, threads)
    x_start, x_end = pass_limits(settings, d0, ex, c)
    time, x_c = pass_positions(mode, speed, x_start, x_end, sample_rate, settings.quasistatic_step)
    loading = RollingPass(z1, ex, settings.radius, d0, x_c, time, speed)
    for n, where in ((0, "x_start"), (loading.n_steps - 1, "x_end")):
        if loading.free_compression(n).max() > 0:
            raise ValueError(f"rolling.pass: the contact is on the strip at {where} = {x_c[n]:.6g} m (d0 = {d0:.4g} m, "
                             f"a = {contact_half_length(settings.radius, d0):.4g} m); expected a pass that starts "
                             "before the contact enters the strip and ends after it has left")
    length = ex[-1] - ex[0] + c
    targets = ex[0] - 0.5 * c + np.asarray(settings.snapshots) * length
    snaps = [int(np.argmin(np.abs(x_c - t))) for t in targets]
    logger.info("%s rolling pass at %g m/s: d0 = %.4e m, x_c from %.4g to %.4g m, %d steps", mode, speed, d0,
                x_start, x_end, loading.n_steps)
    if mode == "dynamic":
        k = np.asarray(kernel, dtype=float)
        result = _march(loading, springs, k, solver, threads, tail, snaps)
    else:
        result = _march(loading, springs, gs[:, :, None], solver, threads, None, snaps)
    if result.force[-1] > 0:
        raise ValueError(f"rolling.pass: the contact has not left the strip at x_end = {x_end:.6g} m "
                         f"({result.contact_count[-1]} elements still in contact); lengthen the pass")
    info = {"d0": float(d0), "x_start": x_start, "x_end": x_end, "strip_length": float(length),
            "half_length": contact_half_length(settings.radius, d0), "element_size": c}
    return result, info


def solve_rolling_run(surface: xr.Dataset, springs: xr.Dataset, greens: xr.Dataset, mode: str, speed: float,
                      settings: RollingSettings, solver: SolverSettings, threads: int = 1,
                      d0: float | None = None) -> tuple[RollingResult, dict[str, float]]:
    """:func:`solve_rolling` from the stage datasets (surface strip, its springs, the greens file)."""
    from .contact import _stage_inputs

    z1, table = _stage_inputs(surface, springs, greens, mode)
    ex = surface["element_x"].values
    spring_table = SpringTable.checked(table.stiffness, table.force, table.zeta_step, z1.size)
    kernel = greens["g"].transpose("dx", "dy", "lag").values if mode == "dynamic" else None
    g_static = greens["g_static"].transpose("dx", "dy").values
    tail = TailModel.from_greens(greens) if mode == "dynamic" else None
    return solve_rolling(z1, ex, spring_table, kernel, g_static, mode, speed, settings, solver,
                         float(greens.attrs["sample_rate"]), threads, tail, d0)


# --------------------------------------------------------------------------------------------
# Work, steady part, spectra
# --------------------------------------------------------------------------------------------
def belt_power(result: RollingResult, speed: float, radius: float) -> np.ndarray:
    """P = sum_e F_e (-dz2_e/dt) = (v / R) sum_e F_e (x_e - x_c) [W]."""
    return speed / radius * result.moment


def pass_work(result: RollingResult, speed: float, radius: float) -> tuple[float, float]:
    """(W, W_in) [J]: the belt's work over the pass and its positive part (trapezoid rule in time).

    In terms of x_c, W = int sum_e F_e (x_e - x_c) / R dx_c does not depend on v for a
    quasi-static pass; W_in (the work while the power is positive, i.e. mainly while the
    contact grows) scales the round-off and discretisation of W.
    """
    m = result.moment / radius
    dx = np.diff(result.x_c)
    w = float(np.sum(0.5 * (m[1:] + m[:-1]) * dx))
    mp = np.maximum(m, 0.0)
    w_in = float(np.sum(0.5 * (mp[1:] + mp[:-1]) * dx))
    return w, w_in


def steady_mask(x_c: np.ndarray, info: Mapping[str, float], margin: int, entry: float = 0.0) -> np.ndarray:
    """Steps of the steady part: the contact (half-length a plus ``margin`` elements) lies on the
    strip, and its rear has travelled ``entry`` [m] onto it (:class:`RollingSettings`)."""
    c = info["element_size"]
    reach = info["half_length"] + margin * c
    lo = info.get("strip_start", 0.0) + max(reach, info["half_length"] + entry)
    hi = info.get("strip_start", 0.0) + info["strip_length"] - reach
    return (x_c >= lo) & (x_c <= hi)


def third_octave_centres(lo: float, hi: float) -> np.ndarray:
    """Base-10 1/3-octave band centres 1000 * 10^(k/10) Hz from lo to hi (inclusive, to 1 %)."""
    k = np.arange(math.floor(10 * math.log10(lo / 1000.0) - 0.05), math.ceil(10 * math.log10(hi / 1000.0) + 0.05) + 1)
    f = 1000.0 * 10.0 ** (k / 10.0)
    return f[(f >= lo * 0.99) & (f <= hi * 1.01)]


def band_levels(signal: np.ndarray, dt: float, centres: np.ndarray, reference: float = 1.0) -> np.ndarray:
    """1/3-octave band levels of a signal's fluctuation, 10 log10(P_band / ref^2) [dB re ``reference``].

    The mean is removed, a Hann window applied (its power restored by the factor 8/3), and the
    one-sided periodogram summed over the bins inside each band [f_c 10^-0.05, f_c 10^0.05), so
    that the band powers add up to the mean square of the fluctuation. Bands whose centre lies
    below 2 / T (fewer than two periods in the record) are NaN: the record does not resolve them.
    """
    x = np.asarray(signal, dtype=float)
    n = x.size
    out = np.full(len(centres), np.nan)
    if n < 8:
        return out
    x = (x - x.mean()) * np.hanning(n)
    spec = np.fft.rfft(x)
    power = np.abs(spec) ** 2 / n**2 * (8.0 / 3.0)
    power[1:] *= 2.0
    if n % 2 == 0:
        power[-1] /= 2.0
    freq = np.fft.rfftfreq(n, dt)
    duration = n * dt
    for i, fc in enumerate(centres):
        if fc < 2.0 / duration or fc * 10**0.05 > 0.5 / dt:
            continue
        band = (freq >= fc * 10**-0.05) & (freq < fc * 10**0.05)
        if not band.any():
            continue  # no frequency bin inside the band: not resolved
        p = power[band].sum()
        out[i] = 10.0 * math.log10(p / reference**2) if p > 0 else -np.inf
    return out


# --------------------------------------------------------------------------------------------
# Dataset of a pass
# --------------------------------------------------------------------------------------------
def rolling_dataset(result: RollingResult, info: Mapping[str, float], mode: str, speed: float,
                    settings: RollingSettings, surface: xr.Dataset | None, surface_name: str,
                    material_name: str) -> xr.Dataset:
    """The file of one rolling pass (docs/data_contracts.md "Rolling run dataset").

    Step series (t, x_c, force, contact count, pressure centre, belt power, Newton counts), the
    element forces at the snapshot steps, and the pass's scalars: d0, the work W and its positive
    part, the rolled distance (strip length), the rolling-loss force W / dx, the steady part's mean
    force and mean power / v.
    """
    n = result.force.size
    nx, ny = result.snapshot_force.shape[1:] if result.snapshot_force.size else (0, 0)
    power = belt_power(result, speed, settings.radius)
    w, w_in = pass_work(result, speed, settings.radius)
    steady = steady_mask(result.x_c, info, settings.steady_margin, settings.steady_entry)
    dx_roll = info["strip_length"]
    mean_force = float(result.force[steady].mean()) if steady.any() else float("nan")
    steady_loss = float(power[steady].mean() / speed) if steady.any() else float("nan")

    def a(units, long_name, **extra):
        return {"units": units, "long_name": long_name, **extra}

    coords = {
        "step": ("step", np.arange(n), a("1", "step index")),
        "time": ("step", result.time, a("s", "time since the start of the pass")),
        "x_c": ("step", result.x_c, a("m", "contact centre x_c (the belt's lowest point) from the strip start")),
        "snapshot": ("snapshot", np.arange(result.snapshot_step.size), a("1", "snapshot index")),
        "ex": ("ex", np.arange(nx), a("1", "element index along x")),
        "ey": ("ey", np.arange(ny), a("1", "element index along y")),
    }
    data = {
        "force": ("step", result.force, a("N", "total contact force")),
        "contact_count": ("step", result.contact_count, a("1", "number of elements in contact")),
        "pressure_centre": ("step", result.pressure_centre, a("m", "pressure centre sum F_e x_e / F (NaN without contact)")),
        "belt_power": ("step", power, a("W", "power the belt puts into the tread, sum F_e (-dz2_e/dt)")),
        "steady": ("step", steady.astype(np.int8), a("1", "1 where the contact lies fully on the strip (steady part)")),
        "newton_iterations": ("step", result.newton_iterations, a("1", "Newton iterations")),
        "krylov_iterations": ("step", result.krylov_iterations, a("1", "Krylov products (0: direct solve)")),
        "residual": ("step", result.residual, a("m", "final max-norm Newton residual")),
        "snapshot_step": ("snapshot", result.snapshot_step, a("1", "step of the element force map")),
        "snapshot_x_c": ("snapshot", result.x_c[result.snapshot_step], a("m", "x_c of the element force map")),
        "element_force": (("snapshot", "ex", "ey"), result.snapshot_force, a("N", "contact spring force per element")),
        "d0": ((), info["d0"], a("m", "indentation of the belt below the highest road peak")),
        "work": ((), w, a("J", "work of the belt on the tread over the pass, W = int sum F_e (-dz2_e/dt) dt")),
        "work_in": ((), w_in, a("J", "positive part of the belt's work (while the belt power is positive)")),
        "rolled_distance": ((), dx_roll, a("m", "rolled distance of the loss force: the strip length")),
        "rolling_loss_force": ((), w / dx_roll, a("N", "rolling-loss force W / dx")),
        "steady_force": ((), mean_force, a("N", "mean total force over the steady part")),
        "steady_loss_force": ((), steady_loss, a("N", "mean belt power over v in the steady part")),
    }
    if surface is not None and "element_x" in surface:
        data["element_x"] = ("ex", surface["element_x"].values, a("m", "x of element centres"))
        data["element_y"] = ("ey", surface["element_y"].values, a("m", "y of element centres"))
        data["z1"] = (("ex", "ey"), surface["z1"].transpose("ex", "ey").values, a("m", "element matching height"))
    attrs = {"mode": mode, "speed": float(speed), "radius": settings.radius, "material": material_name,
             "surface": surface_name, "x_start": info["x_start"], "x_end": info["x_end"],
             "half_length": info["half_length"], "element_size": info["element_size"],
             "load": float("nan") if settings.load is None else float(settings.load),
             "steady_margin": settings.steady_margin, "steady_entry": settings.steady_entry}
    return xr.Dataset(data, coords=coords, attrs=attrs)


# --------------------------------------------------------------------------------------------
# Aggregation: results/rolling.nc
# --------------------------------------------------------------------------------------------
def aggregate_rolling(runs: Sequence[xr.Dataset], band_limits=(100.0, 5000.0)) -> xr.Dataset:
    """Per case (material, mode, speed): steady force, rolling-loss force and coefficient, band levels.

    F(x_c) of every run is interpolated onto one x_c grid (that of the first quasi-static run,
    else the first run) for the figures.
    """
    if not runs:
        raise ValueError("aggregate_rolling: no rolling runs")
    centres = third_octave_centres(*band_limits)
    ref = next((r for r in runs if r.attrs["mode"] == "quasistatic"), runs[0])
    x_grid = ref["x_c"].values
    rows = []
    for r in runs:
        steady = r["steady"].values.astype(bool)
        f = r["force"].values
        t = r["time"].values
        dt = float(np.median(np.diff(t))) if t.size > 1 else float("nan")
        fluct = f[steady]
        levels = band_levels(fluct, dt, centres) if steady.sum() > 8 else np.full(centres.size, np.nan)
        finite = np.isfinite(levels)
        strongest = float(centres[finite][np.argmax(levels[finite])]) if finite.any() else float("nan")
        # fs/2 chatter of the time march (a period-2 alternation, amplitude = |second difference| / 4):
        # a numerical instability of the discrete kernel with stiff springs, never physics
        chatter = (float(np.sqrt(np.mean((0.25 * np.diff(fluct, 2)) ** 2))) / max(float(np.std(fluct)), 1e-300)
                   if r.attrs["mode"] == "dynamic" and fluct.size > 2 else 0.0)
        mean_f = float(r["steady_force"])
        loss = float(r["rolling_loss_force"])
        rows.append({
            "material": r.attrs["material"], "mode": r.attrs["mode"], "speed": float(r.attrs["speed"]),
            "steady_force": mean_f, "rolling_loss_force": loss, "steady_loss_force": float(r["steady_loss_force"]),
            "rolling_loss_coefficient": loss / mean_f if mean_f > 0 else float("nan"),
            "work": float(r["work"]), "work_in": float(r["work_in"]), "d0": float(r["d0"]),
            "fluctuation_rms": float(np.std(fluct)) if fluct.size else float("nan"),
            "band_level": levels, "strongest_band": strongest, "chatter": chatter,
            "curve": np.interp(x_grid, r["x_c"].values, f, left=0.0, right=0.0),
            "centre_offset": float(np.nanmean(r["pressure_centre"].values[steady] - r["x_c"].values[steady]))
            if steady.any() else float("nan"),
        })

    def a(units, long_name):
        return {"units": units, "long_name": long_name}

    scal = {
        "steady_force": ("N", "mean total force over the steady part"),
        "rolling_loss_force": ("N", "rolling-loss force W / dx (dx = strip length)"),
        "steady_loss_force": ("N", "mean belt power / v over the steady part"),
        "rolling_loss_coefficient": ("1", "rolling-loss force over the steady mean force"),
        "work": ("J", "work of the belt over the pass"),
        "work_in": ("J", "positive part of the belt's work"),
        "d0": ("m", "belt indentation below the highest road peak"),
        "fluctuation_rms": ("N", "rms of the force fluctuation over the steady part"),
        "strongest_band": ("Hz", "centre of the 1/3-octave band with the highest force level"),
        "centre_offset": ("m", "mean pressure centre minus x_c over the steady part (> 0: ahead)"),
        "chatter": ("1", "rms of the fs/2 alternation of the force over the rms fluctuation (> 0.05: the time "
                         "march chattered, the case is not trustworthy)"),
    }
    data = {k: ("case", np.array([row[k] for row in rows]), a(*v)) for k, v in scal.items()}
    data["band_level"] = (("case", "band"), np.array([row["band_level"] for row in rows]),
                          a("dB re 1 N", "1/3-octave level of the force fluctuation over the steady part"))
    data["force_curve"] = (("case", "position"), np.array([row["curve"] for row in rows]),
                           a("N", "total force against x_c"))
    coords = {
        "case": ("case", np.arange(len(rows)), a("1", "case index")),
        "material": ("case", [row["material"] for row in rows], {"units": "1", "long_name": "material preset"}),
        "mode": ("case", [row["mode"] for row in rows], {"units": "1", "long_name": "run mode"}),
        "speed": ("case", np.array([row["speed"] for row in rows]), a("m/s", "rolling speed")),
        "band": ("band", centres, a("Hz", "1/3-octave band centre frequency")),
        "position": ("position", x_grid, a("m", "contact centre x_c")),
    }
    attrs = {"radius": float(ref.attrs["radius"]), "surface": str(ref.attrs["surface"]),
             "strip_length": float(ref["rolled_distance"])}
    return xr.Dataset(data, coords=coords, attrs=attrs)


#: Chatter measure (rms fs/2 alternation over the rms force fluctuation) above which a case is flagged.
CHATTER_LIMIT = 0.05


def rolling_section(study: xr.Dataset) -> list[str]:
    """Markdown lines of the report's section on rolling: the table per material and speed, and what it means
    (for ``extra_sections`` of :func:`tyreroad.report.build_report`, or on its own page)."""
    lines = ["## Rolling contact (SPEC 12)", "",
             f"A slick tyre of radius {study.attrs['radius']:g} m rolls over the road strip {study.attrs['surface']} "
             f"({study.attrs['strip_length'] * 1e3:.0f} mm long) at a fixed axle height (d0 from the wheel load). Rolling-loss force W/dx with dx = strip length; "
             "coefficient = W/dx over the steady mean force. Band levels of the force fluctuation over the steady "
             "part (dB re 1 N).", "",
             "| material | mode | v [m/s] | d0 [mm] | mean F [N] | W/dx [N] | coefficient | steady P/v [N] | "
             "centre - x_c [mm] | rms dF [N] | strongest band [Hz] | level [dB] |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for i in range(study.sizes["case"]):
        s = study.isel(case=i)
        lv = s["band_level"].values
        top = float(np.nanmax(lv)) if np.isfinite(lv).any() else float("nan")
        flag = " (fs/2 chatter)" if "chatter" in s and float(s["chatter"]) > CHATTER_LIMIT else ""
        lines.append(
            f"| {s['material'].item()}{flag} | {s['mode'].item()} | {float(s['speed']):g} | {1e3 * float(s['d0']):.4f} | "
            f"{float(s['steady_force']):.1f} | {float(s['rolling_loss_force']):.4g} | "
            f"{float(s['rolling_loss_coefficient']):.3e} | {float(s['steady_loss_force']):.4g} | "
            f"{1e3 * float(s['centre_offset']):.3f} | {float(s['fluctuation_rms']):.3g} | "
            f"{float(s['strongest_band']):.0f} | {top:.1f} |")
    bad = [i for i in range(study.sizes["case"]) if "chatter" in study and float(study["chatter"][i]) > CHATTER_LIMIT]
    if bad:
        names = ", ".join(f"{study['material'].values[i]} at {float(study['speed'][i]):g} m/s" for i in bad)
        lines += ["", f"**Not trustworthy: {names}.** The force alternates from step to step (fs/2 chatter, growing "
                  "along the pass): the time march with the discrete kernel is unstable for this material and speed "
                  "with these springs (a numerical limit of the solver, not physics); these cases are left out of "
                  "the range below."]
    dyn = study.where((study["mode"] == "dynamic") & (study["chatter"] <= CHATTER_LIMIT if "chatter" in study
                                                       else study["mode"] == "dynamic"), drop=True)
    if dyn.sizes.get("case", 0):
        coef = dyn["rolling_loss_coefficient"].values
        sensible = np.all((coef > 1e-4) & (coef < 5e-2))
        strongest = sorted({float(v) for v in dyn["strongest_band"].values if np.isfinite(v)})
        lines += ["", f"Strongest 1/3-octave bands of the dynamic force: {', '.join(f'{v:.0f}' for v in strongest)} Hz "
                  f"(v / f = {', '.join(f'{1e3 * float(sp) / float(fb):.0f}' for sp, fb in zip(dyn['speed'].values, dyn['strongest_band'].values))} mm: "
                  "a band that moves with the speed at a fixed wavelength is excited by the road texture)."]
        lines += ["", f"Dynamic rolling-loss coefficients span {np.nanmin(coef):.2e} to {np.nanmax(coef):.2e}; "
                  f"tread hysteresis is expected of the order of 1e-3 to 1e-2: "
                  f"{'in that range' if sensible else 'OUTSIDE that range (check the material and d0)'}."]
    qs = study.where(study["mode"] == "quasistatic", drop=True)
    for material in dict.fromkeys(qs["material"].values.astype(str)) if qs.sizes.get("case", 0) else []:
        curves = qs["force_curve"].values[qs["material"].values.astype(str) == material]
        if len(curves) > 1:
            diff = np.max(np.abs(curves - curves[0])) / np.max(np.abs(curves[0]))
            lines += ["", f"Quasi-static passes of {material} at {len(curves)} speeds: F(x_c) differs by at most "
                      f"{diff:.1e} of its peak (no rate effect)."]
    return lines + [""]
