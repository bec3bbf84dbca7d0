"""Running a rolling pass: the static indentation d0 and the march over the strip (SPEC 12).

The march loop, the Newton driver and the histories (kept lags and the long-memory tail) are those
of :mod:`tyreroad.contact` (:func:`tyreroad.contact.run_loading_path`), unchanged.
"""

from __future__ import annotations

import dataclasses
import logging

import numpy as np
import xarray as xr
from scipy.optimize import brentq

from .. import checks
from ..contact import MODES, run_loading_path
from ..kernel import LayerKernel
from ..qlv import springs_for_run
from ..solver import SolverSettings
from ..springs import SpringTable
from ..stability import stability_record
from .analysis import steady_mask
from .geometry import RollingPass, contact_half_length, pass_limits, pass_positions
from .recorder import RollingRecorder, RollingResult
from .settings import RollingSettings

logger = logging.getLogger(__name__)

__all__ = ["static_indentation", "solve_rolling", "solve_rolling_run"]


def _march(loading: RollingPass, springs: SpringTable, kernel: LayerKernel, settings: SolverSettings,
           threads: int, snapshot_steps=(), record_forces: bool = False) -> RollingResult:
    return run_loading_path(loading, springs, kernel, settings, threads,
                            recorder=RollingRecorder(loading, snapshot_steps, record_forces=record_forces))


def static_indentation(z1, element_x, springs: SpringTable, relaxed: LayerKernel, radius: float, load: float,
                       x_c: float, settings: SolverSettings, threads: int = 1) -> float:
    """d0 [m] at which the quasi-static contact centred at x_c carries ``load`` [N].

    F(d0) is continuous and increasing; it is bracketed by doubling from 10 um and solved by
    Brent's method to 1e-13 m (each evaluation one static solve with the static kernel).

    Raises
    ------
    ValueError
        If the load needs an indentation beyond the spring tables.
    """
    load = checks.real("rolling.load", load, positive=True)
    if not relaxed.static:
        raise ValueError(f"{relaxed.name}: the static indentation d0 needs the static kernel, got a dynamic one")
    # a two-point (linear) table extends exactly beyond its grid: bound the search by 1 mm then; d0 also carries the
    # structure's deflection under the load (a flexible belt's: ~2.5 mm at 500 N), at most the largest static
    # compliance times the load
    n_table = springs.stiffness.shape[-1]
    zeta_end = springs.zeta_step * (n_table - 1)
    zeta_max = max(zeta_end, 1e-3)
    table_force = np.asarray(getattr(springs, "force", np.zeros((1, 1))))
    if table_force.ndim == 2 and zeta_end > 0:
        # what every spring carries at zeta_max (a two-point table is linear and extends exactly)
        capacity = float(table_force[:, -1].sum()) * (zeta_max / zeta_end if n_table == 2 else 1.0)
        if load > capacity:
            raise ValueError(f"rolling.load = {load:g} N: more than the springs carry at {zeta_max:g} m, the end of "
                             f"their tables ({capacity:.4g} N); expected a load the strip can carry within the spring "
                             "tables")
    zeta_max += load * max(float(np.asarray(relaxed.lags).max()), 0.0)

    def force(d0):
        if d0 <= 0.0:
            return -load
        res = _march(RollingPass(z1, element_x, radius, d0, [x_c]), springs, relaxed, settings, threads)
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
    kernel: LayerKernel,
    relaxed: LayerKernel,
    speed: float,
    settings: RollingSettings,
    solver: SolverSettings,
    threads: int = 1,
    d0: float | None = None,
    record_forces: bool = False,
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
    kernel : tyreroad.kernel.LayerKernel
        The pass's kernel: a dynamic one (time step 1 / its sample rate, with its memory: every
        dynamic pass is longer than the kept lags) or a static one (a quasi-static pass).
    relaxed : tyreroad.kernel.LayerKernel
        The static kernel of the d0 solve.
    speed : float
        v [m/s].
    settings : RollingSettings
        Radius, load or d0, pass, quasi-static step, snapshots.
    solver : SolverSettings
        Newton tolerance, method (dense / FFT), long memory.
    threads : int
        numba threads and FFT workers.
    d0 : float, optional
        The indentation, if already known (overrides the settings' load / d0).
    record_forces : bool
        Keep every step's element forces (``RollingResult.element_force``; e.g. for the belt's vibration,
        :mod:`tyreroad.belt_vibration`).

    With ``settings.load`` (and no d0) the pass is at the wheel load: d0 starts from the quasi-static
    indentation that carries the load with the contact centred on the strip, and is corrected pass
    by pass until the mean force over the steady part is the load to ``settings.load_tolerance``
    (a dynamic tread carries far more than its relaxed load at the same d0).

    Returns
    -------
    result : RollingResult
        The last pass.
    info : dict
        ``d0``, ``x_start``, ``x_end``, ``half_length``, ``strip_length``, ``element_size``;
        ``static_d0`` (the quasi-static start), ``load_passes`` and ``load_error`` (steady mean force
        / load - 1 of the last pass); NaN / 0 for a given d0.

    Raises
    ------
    ValueError
        If the pass starts or ends with the contact on the strip.
    tyreroad.contact.ContactConvergenceError
        If a step does not converge.
    """
    z1 = np.asarray(z1, dtype=float)
    ex = np.asarray(element_x, dtype=float)
    c = float(ex[1] - ex[0]) if ex.size > 1 else 2.0 * float(ex[0])
    if d0 is None:
        d0 = settings.d0
    if d0 is not None:
        result, info = _one_pass(z1, ex, c, springs, kernel, float(d0), speed, settings, solver, threads,
                                 record_forces)
        return result, {**info, "static_d0": float("nan"), "load_passes": 0, "load_error": float("nan")}
    centre = 0.5 * (ex[0] + ex[-1])
    static_d0 = static_indentation(z1, ex, springs, relaxed, settings.radius, settings.load, centre, solver, threads)
    return _pass_at_load(z1, ex, c, springs, kernel, static_d0, speed, settings, solver, threads, record_forces)


#: Passes allowed to bring the steady mean force to the wheel load.
MAX_LOAD_PASSES = 8


def _pass_at_load(z1, ex, c, springs, kernel, static_d0, speed, settings, solver, threads, record_forces=False):
    """Passes at d0 from the static indentation on, until the steady mean force is the load (secant on d0).

    The first correction scales d0 by (load / F)^(2/3) (a Hertzian contact's F ~ d^1.5); later ones
    follow the secant of the last two passes.
    """
    load, d = float(settings.load), static_d0
    tried: list[tuple[float, float]] = []
    while True:
        result, info = _one_pass(z1, ex, c, springs, kernel, d, speed, settings, solver, threads, record_forces)
        steady = steady_mask(result.x_c, info, settings.steady_margin, settings.steady_entry)
        if not steady.any():
            raise ValueError(f"rolling: the pass at d0 = {d:.4g} m has no steady part, so its mean force cannot be "
                             "set to rolling.load; lengthen the strip or lower rolling.steady_entry")
        force = float(result.force[steady].mean())
        tried.append((d, force))
        error = force / load - 1.0
        logger.info("rolling at the load: pass %d at d0 = %.6e m carries a steady mean force of %.5g N (%+.3f %% of "
                    "%g N)", len(tried), d, force, 100 * error, load)
        if abs(error) <= settings.load_tolerance:
            return result, {**info, "static_d0": float(static_d0), "load_passes": len(tried), "load_error": error}
        if len(tried) >= MAX_LOAD_PASSES:
            raise ValueError(f"rolling.load = {load:g} N: after {len(tried)} passes the steady mean force is {force:.5g} N "
                             f"({100 * error:+.2f} %, d0 = {d:.6g} m), outside rolling.load_tolerance = "
                             f"{settings.load_tolerance:g}")
        (d1, f1), (d2, f2) = (tried[-2] if len(tried) > 1 else (0.0, 0.0)), tried[-1]
        slope = (f2 - f1) / (d2 - d1) if len(tried) > 1 and d2 != d1 else 0.0
        d = d2 + (load - f2) / slope if slope > 0 else d2 * (load / f2) ** (2.0 / 3.0)


def _one_pass(z1, ex, c, springs, kernel, d0, speed, settings, solver, threads, record_forces=False):
    """One pass at the indentation d0 [m]: (result, info)."""
    mode = "quasistatic" if kernel.static else "dynamic"
    x_start, x_end = pass_limits(settings, d0, ex, c)
    time, x_c = pass_positions(mode, speed, x_start, x_end, kernel.sample_rate, settings.quasistatic_step)
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
    result = _march(loading, springs, kernel, solver, threads, snaps, record_forces)
    if result.force[-1] > 0:
        raise ValueError(f"rolling.pass: the contact has not left the strip at x_end = {x_end:.6g} m "
                         f"({result.contact_count[-1]} elements still in contact); lengthen the pass")
    info = {"d0": float(d0), "x_start": x_start, "x_end": x_end, "strip_length": float(length),
            "half_length": contact_half_length(settings.radius, d0), "element_size": c}
    return result, info


def solve_rolling_run(surface: xr.Dataset, springs: xr.Dataset, greens: xr.Dataset, mode: str, speed: float,
                      settings: RollingSettings, solver: SolverSettings, threads: int = 1,
                      d0: float | None = None, record_forces: bool = False) -> tuple[RollingResult, dict[str, float]]:
    """:func:`solve_rolling` from the stage datasets (surface strip, its springs, the greens file)."""
    if mode not in MODES:
        raise ValueError(f"mode: expected one of {MODES}, got {mode!r}")
    kernel = LayerKernel.from_greens(greens, mode)
    relaxed = kernel if kernel.static else LayerKernel.from_greens(greens, "quasistatic")
    kernel.check_element_size(surface.attrs.get("element_size"))
    z1 = surface["z1"].transpose("ex", "ey").values
    ex = surface["element_x"].values
    table = SpringTable.from_dataset(springs)
    spring_table = springs_for_run(springs, SpringTable.checked(table.stiffness, table.force, table.zeta_step, z1.size))
    result, info = solve_rolling(z1, ex, spring_table, kernel, relaxed, speed, settings, solver, threads, d0,
                                 record_forces)
    if not kernel.static:
        steady = steady_mask(result.x_c, info, settings.steady_margin, settings.steady_entry)
        record = stability_record(kernel, z1.shape, result.max_spring_stiffness, result.force, threads, steady)
        result = dataclasses.replace(result, stability=record)
        # a margin computed on a contact window (a rolling strip's kernel) holds only while the contact fits in it
        extent, n = result.largest_contact_extent()
        kernel.check_contact_extent(extent, solver.stability, f" at step {n} (x_c = {result.x_c[n]:.6g} m)")
    return result, info
