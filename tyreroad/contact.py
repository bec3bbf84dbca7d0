"""Time-domain contact between the rigid rough road and the tread layer (SPEC section 6).

Each road element e carries a nonlinear contact spring with compression

    zeta_e[n] = z1_e - z2_e[n] - w_e[n],

and the layer surface displacement is the discrete convolution of the spring forces with the
element Green's function table g[dx, dy, lag] (seed Eq. 3-4):

    w_e[n] = sum_m g_{e-m}[0] F_m[n] + h_e[n],   h_e[n] = sum_{l>=1} sum_m g_{e-m}[l] F_m[n-l].

The history h is known at step n, so each step solves the M nonlinear equations
R(zeta) = zeta - b + G0 F(zeta) = 0, b = z1 - z2[n] - h[n], by Newton's method.

The time march (:func:`march`) is a loop over named collaborators, each replaceable on its own:

* a **loading** (:mod:`tyreroad.loading`) gives the free compression z1 - z2[n] of every spring;
* **histories** (:mod:`tyreroad.history`) give h[n] and record the converged forces;
* a **substrate** (:mod:`tyreroad.newton`) applies G0 and solves the Newton corrections;
* the **springs** (:class:`tyreroad.springs.SpringTable`) give F(zeta) and k(zeta);
* :func:`tyreroad.newton.solve_step` is the one Newton driver;
* a :class:`RunRecorder` keeps what the result file holds.

Dynamic runs prescribe d(t) = a t^2 / 2 at t_n = n / fs (the seed's loading). Quasi-static runs
use the same march with the one-lag kernel g = [g_static] on a uniform indentation grid. Two
paths assemble the collaborators (``solver.method``): ``dense`` (offset-table history over the
loaded elements, dense G0 and a direct solve of the loaded block; the reference) and ``fft``
(FFT history and matrix-free Newton-Krylov, :mod:`tyreroad.convolution`); both agree to round-off.

The force at the rigid backing is the total surface force filtered by the k = 0 (uniform load)
transfer of the layer (:func:`tyreroad.layer.backing_force`).

References
----------
Winroth, Andersson & Kropp (2014), Importance of tread inertia and damping on the tyre/road
contact stiffness, J. Sound Vib. 333(21), 5378-5385 (see :data:`tyreroad.SEED_REFERENCE`).
"""

from __future__ import annotations

import dataclasses
import logging
import math
from dataclasses import dataclass
from typing import Sequence

import numba
import numpy as np
import xarray as xr

from . import checks
from .convolution import OffsetConvolution, check_offset_kernel
from .history import DenseHistory, FFTHistory, History, HistorySum, TailHistory
from .layer import backing_force
from .memory import TailModel
from .loading import IndentationPath, Loading, LoadingPreset, constant_acceleration_path, uniform_indentation_grid
from .newton import DenseSubstrate, FFTSubstrate, StepConvergenceError, Substrate, solve_step
from .solver import FFT_THRESHOLD, SolverSettings
from .springs import SpringTable

logger = logging.getLogger(__name__)

__all__ = [
    "MODES",
    "SolverSettings",
    "ContactConvergenceError",
    "ContactResult",
    "RunRecorder",
    "march",
    "build_collaborators",
    "run_loading_path",
    "dynamic_indentation",
    "quasistatic_indentation",
    "solve_path",
    "solve_dynamic",
    "solve_quasistatic",
    "solve_run",
    "solve_loading",
    "contact_dataset",
    "loading_dataset",
]

#: Run modes, the ``{mode}`` wildcard of the contact files.
MODES = ("dynamic", "quasistatic")

class ContactConvergenceError(RuntimeError):
    """A contact step whose Newton iteration did not reach the tolerance."""


@dataclass(frozen=True)
class ContactResult:
    """Step series of one contact run, keyed by step (and by time where the loading has one).

    Attributes
    ----------
    time : numpy.ndarray or None
        t_n [s], shape (n,); None for a sequence of static states (quasi-static runs).
    prescribed : dict
        The loading's prescribed motion as it is, {name: (values, units, long_name)}, values with
        the step as first axis (``indentation`` d[n] [m] for a flat tread surface).
    force : numpy.ndarray
        Total surface force sum_e F_e [N], shape (n,).
    element_force : numpy.ndarray
        F_e [N], shape (n, nx, ny).
    compression : numpy.ndarray
        Spring compression zeta_e [m] (negative: gap), shape (n, nx, ny).
    displacement : numpy.ndarray
        Layer surface displacement w_e = h_e + (G0 F)_e [m], shape (n, nx, ny).
    contact_count : numpy.ndarray
        Number of elements with F_e > 0, shape (n,).
    newton_iterations, krylov_iterations : numpy.ndarray
        Newton corrections and Krylov products of each step, shape (n,).
    residual : numpy.ndarray
        Final max_e |R_e| of each step [m], shape (n,).
    backing_force : numpy.ndarray or None
        Total force at the rigid backing [N], shape (n,), when computed (:func:`solve_run`).
    tangent_stiffness : numpy.ndarray or None
        Quasi-static runs (one-lag kernel): dF/dd of each solved state [N/m], shape (n),
        1^T [G0|C + diag(1/k)]^-1 1 over the contact set (:class:`tyreroad.stiffness.TangentStiffness`);
        exact between contact-set changes, so coarse indentation steps keep K(d) exact. None otherwise.
    """

    time: np.ndarray | None
    prescribed: dict
    force: np.ndarray
    element_force: np.ndarray
    compression: np.ndarray
    displacement: np.ndarray
    contact_count: np.ndarray
    newton_iterations: np.ndarray
    krylov_iterations: np.ndarray
    residual: np.ndarray
    backing_force: np.ndarray | None = None
    tangent_stiffness: np.ndarray | None = None

    @property
    def indentation(self) -> np.ndarray:
        """d[n] [m] of a flat-surface loading (KeyError for loadings without one)."""
        return self.prescribed["indentation"][0]


class RunRecorder:
    """Keeps every step's forces, compressions and displacements for the result.

    Parameters
    ----------
    n_steps : int
        Steps of the run.
    shape : tuple of int
        Patch (nx, ny).
    tangent : callable, optional
        k_e of a converged state -> dF/dd [N/m] (quasi-static runs:
        :class:`tyreroad.stiffness.TangentStiffness`); stored per step as ``tangent_stiffness``.
    """

    def __init__(self, n_steps: int, shape: tuple[int, int], tangent=None):
        n_elem = shape[0] * shape[1]
        self.shape = shape
        self.tangent = tangent
        self.tangent_stiffness = None if tangent is None else np.zeros(n_steps)
        self.force = np.zeros((n_steps, n_elem))
        self.compression = np.zeros((n_steps, n_elem))
        self.displacement = np.zeros((n_steps, n_elem))
        self.contact_count = np.zeros(n_steps, dtype=np.int64)
        self.newton_iterations = np.zeros(n_steps, dtype=np.int64)
        self.krylov_iterations = np.zeros(n_steps, dtype=np.int64)
        self.residual = np.zeros(n_steps)

    def store(self, n: int, step, displacement: np.ndarray) -> None:
        """Record the converged ``step`` (a :class:`tyreroad.newton.StepResult`) of step n."""
        self.force[n] = step.force
        self.compression[n] = step.zeta
        self.displacement[n] = displacement
        self.contact_count[n] = np.count_nonzero(step.force)
        self.newton_iterations[n] = step.newton_iterations
        self.krylov_iterations[n] = step.krylov_iterations
        self.residual[n] = step.residual
        if self.tangent is not None:
            self.tangent_stiffness[n] = self.tangent(step.stiffness)

    def result(self, loading: Loading, n_steps: int | None = None) -> ContactResult:
        """The :class:`ContactResult` of the first ``n_steps`` recorded steps (default all)."""
        n = self.force.shape[0] if n_steps is None else n_steps
        shape3 = (n,) + tuple(self.shape)
        prescribed = {k: (v[:n], units, name) for k, (v, units, name) in loading.prescribed().items()}
        return ContactResult(
            time=None if loading.time is None else np.asarray(loading.time, dtype=float)[:n],
            prescribed=prescribed,
            force=self.force[:n].sum(axis=1),
            element_force=self.force[:n].reshape(shape3),
            compression=self.compression[:n].reshape(shape3),
            displacement=self.displacement[:n].reshape(shape3),
            contact_count=self.contact_count[:n],
            newton_iterations=self.newton_iterations[:n],
            krylov_iterations=self.krylov_iterations[:n],
            residual=self.residual[:n],
            tangent_stiffness=None if self.tangent_stiffness is None else self.tangent_stiffness[:n],
        )


# --------------------------------------------------------------------------------------------
# The time march
# --------------------------------------------------------------------------------------------
def march(
    loading: Loading,
    springs: SpringTable,
    substrate: Substrate,
    history: History,
    settings: SolverSettings,
    recorder: RunRecorder,
) -> ContactResult:
    """Solve the contact step by step along a loading.

    Step n: b = free_compression(n) - h[n]; Newton from the previous solution shifted by the
    change of b (warm start; before step 0 the previous solution is the loading's rest state);
    w[n] = h[n] + G0 F[n]; the history records F[n].

    Parameters
    ----------
    loading : Loading
        Prescribed motion (:mod:`tyreroad.loading`).
    springs : SpringTable
        One spring per element, (M, n_zeta) tables.
    substrate : Substrate
        G0 and the Newton linear solve (:mod:`tyreroad.newton`).
    history : History
        Displacement from the earlier steps (:mod:`tyreroad.history`; a :class:`HistorySum` for several).
    settings : SolverSettings
        Tolerance and iteration limit.
    recorder : RunRecorder
        Where the steps go.

    Returns
    -------
    ContactResult

    Raises
    ------
    ContactConvergenceError
        Naming the step, the loading's position (e.g. d) and the residual; or, for a loading that
        must end early (a cycle: once every element has separated), that its path ran out first.
    """
    n_steps = loading.n_steps
    zeta = loading.rest_compression()
    b_prev = zeta.copy()
    report_every = max(1, n_steps // 10)
    for n in range(n_steps):
        h = history.displacement(n)
        b = loading.free_compression(n) - h
        try:
            step = solve_step(b, zeta, springs, substrate, settings.tolerance, settings.max_iterations, shift=b - b_prev)
        except StepConvergenceError as err:
            raise ContactConvergenceError(f"contact step {n} ({loading.describe(n)}): {err}") from err
        b_prev, zeta = b, step.zeta
        history.record(n, step.force)
        recorder.store(n, step, h + substrate.instant(step.force))
        finished = loading.done(n, step.force)
        if finished or n % report_every == 0 or n == n_steps - 1:
            logger.info(
                "step %d/%d: %s, F = %.5e N, %d elements in contact, %d Newton / %d Krylov iterations%s",
                n, n_steps - 1, loading.describe(n), step.force.sum(), recorder.contact_count[n],
                step.newton_iterations, step.krylov_iterations, ", path complete" if finished else "",
            )
        if finished:
            return recorder.result(loading, n + 1)
    message = loading.unfinished(n_steps - 1)
    if message is not None:
        raise ContactConvergenceError(f"contact run ended without completing its loading path: {message}")
    return recorder.result(loading)


# --------------------------------------------------------------------------------------------
# Assembling a run
# --------------------------------------------------------------------------------------------
def _set_threads(threads: int) -> None:
    threads = checks.integer("threads", threads)
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))


def build_collaborators(
    kernel, shape, settings: SolverSettings, threads: int = 1, n_steps: int | None = None, tail=None
) -> tuple[Substrate, History]:
    """The substrate (G0, Newton linear solve) and history (kept lags, and the tail) of ``settings.method``.

    Parameters
    ----------
    kernel : array_like
        g[dx, dy, lag] [m/N], offsets -(nx-1) ... nx-1 (a larger centred table is cropped).
    shape : tuple of int
        Patch (nx, ny).
    settings : SolverSettings
        ``method`` picks dense or FFT; ``preconditioner_block`` and ``tolerance`` the FFT solver.
    threads : int
        FFT workers and numba threads.
    n_steps : int, optional
        Steps of the run; a run longer than the kept lags of a dynamic (multi-lag) kernel needs
        the tail.
    tail : tyreroad.memory.TailModel, optional
        The kernel beyond its kept lags; used when the run is longer than the kept lags and
        ``settings.long_memory`` is on.

    Returns
    -------
    substrate, history

    Raises
    ------
    ValueError
        If the run needs more memory than the kernel provides (no tail, or long memory off).
    """
    nx, ny = shape
    g = check_offset_kernel(kernel, nx, ny)
    n_lags = g.shape[2]
    method = settings.resolved_method(nx * ny, n_steps, n_lags)
    needs_tail = n_lags > 1 and n_steps is not None and n_steps > n_lags
    if needs_tail and (tail is None or not settings.long_memory):
        why = "solver.long_memory is off" if tail is not None else "the kernel has no tail (a greens file without one)"
        raise ValueError(
            f"the run needs {n_steps} steps of memory but the kernel keeps greens.n_lags = {n_lags} lags and "
            f"{why}: switch solver.long_memory on (with a greens file from this version), or raise greens.n_lags "
            f"to >= {n_steps}"
        )
    if method == "fft":
        conv = OffsetConvolution(g, shape, workers=threads)
        logger.info("FFT/Newton-Krylov path: %d x %d elements, %d lags, padded grid %s", nx, ny, n_lags, conv.padded)
        substrate = FFTSubstrate(conv, settings.tolerance, block=settings.preconditioner_block,
                                 eta_max=settings.krylov_forcing)
        history = FFTHistory(conv)
    else:
        substrate, history = DenseSubstrate(g[:, :, 0]), DenseHistory(g, shape)
    if needs_tail:
        if tail.delay != n_lags:
            raise ValueError(f"tail: starts at lag {tail.delay}, but the kernel keeps {n_lags} lags")
        logger.info("long memory: tail from lag %d, %d retardation terms", tail.delay, tail.weights.size)
        history = HistorySum([history, TailHistory(tail, shape, method, workers=threads)])
    return substrate, history


def solve_path(
    z1,
    stiffness,
    force,
    zeta_step: float,
    kernel,
    indentation,
    settings: SolverSettings,
    time=None,
    threads: int = 1,
    extra_histories: Sequence[History] = (),
    tail=None,
) -> ContactResult:
    """Solve the contact of a flat tread surface along a prescribed indentation path.

    Step n uses lags 1 ... L-1 of ``kernel`` for the history, i.e. the indentations are
    assumed to be sampled at the kernel's sample rate (for a one-lag kernel the steps are
    independent static problems, linked only through the warm start).

    Parameters
    ----------
    z1 : array_like
        Road matching heights z1[ex, ey] [m].
    stiffness, force : array_like
        Spring tables on zeta_j = j * zeta_step: k [N/m] and F [N], shape (nx, ny, n_zeta) or
        (nx * ny, n_zeta).
    zeta_step : float
        Spring table step [m].
    kernel : array_like
        g[dx, dy, lag] [m/N], offsets -(nx-1) ... nx-1 (a larger centred table is cropped).
    indentation : array_like
        d_n [m], one per step (any order: loading, holding, unloading).
    settings : SolverSettings
        Tolerance and iteration limit.
    time : array_like, optional
        t_n [s], stored in the result.
    threads : int
        numba threads and FFT workers.
    extra_histories : sequence of History
        Further history terms added to the kept lags.
    tail : tyreroad.memory.TailModel, optional
        The kernel beyond its kept lags (SPEC 9): needed by runs longer than the kept lags.

    Returns
    -------
    ContactResult

    Raises
    ------
    ContactConvergenceError
        Naming the step, d and the residual, if a step does not converge.
    """
    loading = IndentationPath(z1, indentation, time)
    springs = SpringTable.checked(stiffness, force, zeta_step, math.prod(loading.shape))
    return run_loading_path(loading, springs, kernel, settings, threads, tail, extra_histories)


def run_loading_path(loading, springs, kernel, settings: SolverSettings, threads: int = 1, tail=None,
                     extra_histories: Sequence[History] = (), recorder=None):
    """Assemble the collaborators for a loading on a patch and march (the entry point of every run).

    Parameters
    ----------
    loading : Loading
        The prescribed motion; ``loading.shape`` is the patch (nx, ny).
    springs : SpringTable
        One spring per element (or any object with the springs protocol of :mod:`tyreroad.newton`).
    kernel : array_like
        g[dx, dy, lag] [m/N]; a one-lag kernel is the quasi-static case.
    settings : SolverSettings
        Method, tolerance, iteration limit, long memory.
    threads : int
        numba threads and FFT workers.
    tail : tyreroad.memory.TailModel, optional
        The kernel beyond its kept lags.
    extra_histories : sequence of History
        Further history terms.
    recorder : optional
        What keeps the steps (``store(n, step, w)`` and ``result(loading[, n])``); default a
        :class:`RunRecorder`, which for a one-lag kernel also stores the tangent stiffness dF/dd.

    Returns
    -------
    The recorder's result (a :class:`ContactResult` for the default recorder).
    """
    if not isinstance(settings, SolverSettings):
        raise TypeError(f"settings: expected SolverSettings, got {type(settings).__name__}")
    _set_threads(threads)
    shape = loading.shape
    substrate, history = build_collaborators(kernel, shape, settings, threads, loading.n_steps, tail)
    if extra_histories:
        history = HistorySum([history, *extra_histories])
    if recorder is None:
        tangent = None
        if np.shape(kernel)[2] == 1 and not extra_histories:
            # a one-lag kernel: every step is a static state, whose tangent dF/dd is stored; the
            # FFT substrate solves it with its own preconditioned CG and keeps dzeta/dd as the
            # next step's predictor
            if getattr(substrate, "use_cg", False):
                tangent = substrate.tangent_stiffness
            else:
                from .stiffness import TangentStiffness

                tangent = TangentStiffness(np.asarray(kernel)[:, :, 0], shape,
                                           settings.resolved_method(shape[0] * shape[1]), workers=threads)
        recorder = RunRecorder(loading.n_steps, shape, tangent)
    return march(loading, springs, substrate, history, settings, recorder)


def dynamic_indentation(sample_rate: float, acceleration: float, d_max: float) -> tuple[np.ndarray, np.ndarray]:
    """t_n = n / fs and d_n = a t_n^2 / 2 until d reaches d_max (:func:`tyreroad.loading.constant_acceleration_path`)."""
    return constant_acceleration_path(sample_rate, acceleration, d_max)


def quasistatic_indentation(settings: SolverSettings) -> np.ndarray:
    """Uniform indentation grid 0, dd, 2 dd, ... up to the first point >= d_max [m]."""
    return uniform_indentation_grid(settings.d_max, settings.quasistatic_step)


def solve_dynamic(
    z1,
    stiffness,
    force,
    zeta_step: float,
    kernel,
    sample_rate: float,
    acceleration: float,
    settings: SolverSettings,
    threads: int = 1,
    tail=None,
) -> ContactResult:
    """Dynamic indentation d(t) = a t^2 / 2 with the time-domain kernel (seed Eq. 3-4).

    Parameters
    ----------
    z1 : array_like
        Road matching heights z1[ex, ey] [m].
    stiffness, force : array_like
        Spring tables k [N/m] and F [N] on zeta_j = j * zeta_step.
    zeta_step : float
        Spring table step [m].
    kernel : array_like
        Time-domain Green's function table g[dx, dy, lag] [m/N] sampled at ``sample_rate``.
    sample_rate : float
        fs [Hz]; t_n = n / fs.
    acceleration : float
        Indentation acceleration a [m/s^2].
    settings : SolverSettings
        Tolerance, iteration limit and d_max.
    threads : int
        numba threads for the history sum.
    tail : tyreroad.memory.TailModel, optional
        The kernel beyond its kept lags, for runs longer than them (slow accelerations).

    Returns
    -------
    ContactResult
        From t = 0 to the first step with d >= settings.d_max.
    """
    time, d = dynamic_indentation(sample_rate, acceleration, settings.d_max)
    logger.info("dynamic run: a = %g m/s^2, fs = %g Hz, %d steps", acceleration, sample_rate, d.size)
    return solve_path(z1, stiffness, force, zeta_step, kernel, d, settings, time=time, threads=threads, tail=tail)


def solve_quasistatic(
    z1,
    stiffness,
    force,
    zeta_step: float,
    kernel_static,
    settings: SolverSettings,
    indentation=None,
) -> ContactResult:
    """Quasi-static indentation with the static kernel (the solver with g = [g_static]).

    Parameters
    ----------
    z1 : array_like
        Road matching heights z1[ex, ey] [m].
    stiffness, force : array_like
        Spring tables k [N/m] and F [N] on zeta_j = j * zeta_step.
    zeta_step : float
        Spring table step [m].
    kernel_static : array_like
        g_static[dx, dy] [m/N].
    settings : SolverSettings
        Tolerance, iteration limit, d_max and the indentation step.
    indentation : array_like, optional
        Indentations to solve at [m]; default the uniform grid of :func:`quasistatic_indentation`.

    Returns
    -------
    ContactResult
        With ``time = None``.
    """
    gs = np.asarray(kernel_static, dtype=float)
    if gs.ndim != 2:
        raise ValueError(f"kernel_static: expected g_static[dx, dy], got shape {gs.shape}")
    d = quasistatic_indentation(settings) if indentation is None else indentation
    logger.info("quasi-static run: %d steps", np.size(d))
    return solve_path(z1, stiffness, force, zeta_step, gs[:, :, None], d, settings)


def _stage_inputs(surface: xr.Dataset, springs: xr.Dataset, greens: xr.Dataset, mode: str):
    """Road heights z1[ex, ey] and the spring tables of the stage datasets, checked against each other."""
    if mode not in MODES:
        raise ValueError(f"mode: expected one of {MODES}, got {mode!r}")
    z1 = surface["z1"].transpose("ex", "ey").values
    table = SpringTable.from_dataset(springs)
    c_surface, c_greens = surface.attrs.get("element_size"), greens.attrs.get("element_size")
    if c_surface is not None and c_greens is not None and not math.isclose(float(c_surface), float(c_greens), rel_tol=1e-9):
        raise ValueError(f"element_size differs: surface {c_surface} m, greens {c_greens} m")
    return z1, table


def _backing(result: ContactResult, greens: xr.Dataset, material) -> np.ndarray:
    """Backing force of a dynamic run at the greens file's sample rate."""
    n_fft = int(float(greens.attrs.get("n_fft", 4096)))
    return backing_force(result.force, material, float(greens.attrs["sample_rate"]), max(n_fft, 4096))


def solve_loading(
    surface: xr.Dataset,
    springs: xr.Dataset,
    greens: xr.Dataset,
    material,
    mode: str,
    preset: LoadingPreset,
    settings: SolverSettings,
    threads: int = 1,
) -> ContactResult:
    """One run of a loading preset (cycle, harmonic, table, ...; SPEC 10) from the stage datasets.

    Dynamic runs use the time-domain kernel with its long-memory tail and get the backing force;
    quasi-static runs the static kernel (their backing force is the surface force).

    Parameters
    ----------
    surface, springs, greens : xarray.Dataset
        Contents of the surface, springs and greens files.
    material : Material
        The layer material.
    mode : {"dynamic", "quasistatic"}
        Run type.
    preset : tyreroad.loading.LoadingPreset
        The loading path.
    settings : SolverSettings
        Solver settings (``quasistatic_step`` samples quasi-static cycles).
    threads : int
        numba threads and FFT workers.

    Returns
    -------
    ContactResult
    """
    z1, table = _stage_inputs(surface, springs, greens, mode)
    loading = preset.loading(z1, mode, float(greens.attrs["sample_rate"]), settings.quasistatic_step)
    springs_table = SpringTable.checked(table.stiffness, table.force, table.zeta_step, z1.size)
    logger.info("%s run of loading %s (%s): %d steps", mode, preset.name, preset.kind, loading.n_steps)
    if mode == "dynamic":
        kernel = greens["g"].transpose("dx", "dy", "lag").values
        result = run_loading_path(loading, springs_table, kernel, settings, threads, TailModel.from_greens(greens))
        return dataclasses.replace(result, backing_force=_backing(result, greens, material))
    kernel = greens["g_static"].transpose("dx", "dy").values[:, :, None]
    result = run_loading_path(loading, springs_table, kernel, settings, threads, None)
    return dataclasses.replace(result, backing_force=result.force.copy())


def solve_run(
    surface: xr.Dataset,
    springs: xr.Dataset,
    greens: xr.Dataset,
    material,
    mode: str,
    acceleration: float,
    settings: SolverSettings,
    threads: int = 1,
) -> ContactResult:
    """One contact run from the stage datasets (surface, springs, greens; docs/data_contracts.md).

    Dynamic runs also get the backing force (:func:`tyreroad.layer.backing_force` with the greens file's
    ``sample_rate`` and ``n_fft``); for quasi-static runs it equals the surface force.

    Parameters
    ----------
    surface, springs, greens : xarray.Dataset
        Contents of the surface, springs and greens files.
    material : Material
        The layer material (modulus(omega), poisson, density, thickness).
    mode : {"dynamic", "quasistatic"}
        Run type.
    acceleration : float
        a [m/s^2]; must be 0 for quasi-static runs.
    settings : SolverSettings
        Solver settings.
    threads : int
        numba threads.

    Returns
    -------
    ContactResult
    """
    z1, table = _stage_inputs(surface, springs, greens, mode)
    stiffness, force, step = table.stiffness, table.force, table.zeta_step
    if mode == "dynamic":
        fs = float(greens.attrs["sample_rate"])
        kernel = greens["g"].transpose("dx", "dy", "lag").values
        result = solve_dynamic(
            z1, stiffness, force, step, kernel, fs, acceleration, settings, threads, tail=TailModel.from_greens(greens)
        )
        backing = _backing(result, greens, material)
    else:
        if acceleration != 0:
            raise ValueError(f"acceleration: quasi-static runs use 0 m/s^2, got {acceleration!r}")
        kernel = greens["g_static"].transpose("dx", "dy").values
        result = solve_quasistatic(z1, stiffness, force, step, kernel, settings)
        backing = result.force.copy()
    return dataclasses.replace(result, backing_force=backing)


# --------------------------------------------------------------------------------------------
# Dataset
# --------------------------------------------------------------------------------------------
def _result_dataset(result: ContactResult, attrs: dict) -> xr.Dataset:
    """The step series of a run as a dataset (shared by seed and loading runs)."""
    backing = result.force if result.backing_force is None else result.backing_force
    n, nx, ny = result.element_force.shape
    coords = {"step": ("step", np.arange(n), {"units": "1", "long_name": "step index"})}
    # the prescribed motion as it is: a series per step becomes a coordinate, a field a variable
    prescribed_fields = {}
    for name, (values, units, long_name) in result.prescribed.items():
        values = np.asarray(values)
        dims = ("step",) if values.ndim == 1 else ("step", "ex", "ey")
        target = coords if values.ndim == 1 else prescribed_fields
        target[name] = (dims, values, {"units": units, "long_name": long_name})
    coords["ex"] = ("ex", np.arange(nx), {"units": "1", "long_name": "element index along x"})
    coords["ey"] = ("ey", np.arange(ny), {"units": "1", "long_name": "element index along y"})
    if result.time is not None:
        coords["time"] = ("step", result.time, {"units": "s", "long_name": "time since first contact"})
    grid = ("step", "ex", "ey")
    data_vars = {
        "force": ("step", result.force, {"units": "N", "long_name": "total contact force at the layer surface"}),
        "backing_force": ("step", np.asarray(backing, dtype=float),
                          {"units": "N", "long_name": "total force at the rigid backing of the layer"}),
        "contact_count": ("step", result.contact_count, {"units": "1", "long_name": "number of elements in contact"}),
        "element_force": (grid, result.element_force, {"units": "N", "long_name": "contact spring force per element"}),
        "compression": (grid, result.compression,
                        {"units": "m", "long_name": "spring compression zeta (negative: gap)"}),
        "displacement": (grid, result.displacement,
                         {"units": "m", "long_name": "layer surface displacement w (into the layer)"}),
        "newton_iterations": ("step", result.newton_iterations, {"units": "1", "long_name": "Newton iterations"}),
        "krylov_iterations": ("step", result.krylov_iterations,
                              {"units": "1", "long_name": "Krylov matrix-vector products (0: direct solve)"}),
        "residual": ("step", result.residual, {"units": "m", "long_name": "final max-norm Newton residual"}),
    }
    if result.tangent_stiffness is not None:
        data_vars["tangent_stiffness"] = (
            "step", np.asarray(result.tangent_stiffness, dtype=float),
            {"units": "N/m", "long_name": "quasi-static tangent stiffness dF/dd of the solved state, "
             "1^T [G0|C + diag(1/k)]^-1 1 over the contact set"})
    data_vars.update(prescribed_fields)
    return xr.Dataset(data_vars, coords=coords, attrs=attrs)


def contact_dataset(
    result: ContactResult,
    mode: str,
    acceleration: float,
    surface_name: str,
    material_name: str,
) -> xr.Dataset:
    """The contact file's dataset (docs/data_contracts.md "Contact dataset").

    Parameters
    ----------
    result : ContactResult
        A run; dynamic runs must carry ``backing_force`` (as :func:`solve_run` returns them).
        For quasi-static runs a missing backing force is the surface force.
    mode : {"dynamic", "quasistatic"}
        Run type.
    acceleration : float
        a [m/s^2]; 0 for quasi-static runs.
    surface_name, material_name : str
        Preset names recorded as attributes.

    Returns
    -------
    xarray.Dataset
    """
    if mode not in MODES:
        raise ValueError(f"mode: expected one of {MODES}, got {mode!r}")
    acceleration = float(acceleration)
    if mode == "quasistatic" and acceleration != 0.0:
        raise ValueError(f"acceleration: quasi-static runs use 0 m/s^2, got {acceleration!r}")
    if mode == "dynamic" and (result.time is None or result.backing_force is None):
        raise ValueError("contact_dataset: a dynamic result needs time and backing_force")
    attrs = {"mode": mode, "acceleration": acceleration, "material": material_name, "surface": surface_name}
    return _result_dataset(result, attrs)


def loading_dataset(
    result: ContactResult, mode: str, preset: LoadingPreset, surface_name: str, material_name: str
) -> xr.Dataset:
    """The file of a loading-preset run (docs/data_contracts.md "Loading dataset").

    The step series of :func:`contact_dataset`, the preset (kind and its config as YAML) in the
    attributes, and for paths that return to separation (cycles) the hysteresis: dissipated
    energy W = closed integral of F dd [J] and the work done while loading [J].
    """
    import yaml

    from .hysteresis import dissipated_energy, loading_work

    if mode not in MODES:
        raise ValueError(f"mode: expected one of {MODES}, got {mode!r}")
    attrs = {"mode": mode, "loading": preset.name, "loading_kind": preset.kind,
             "loading_config": yaml.safe_dump(preset.config, sort_keys=True),
             "material": material_name, "surface": surface_name}
    ds = _result_dataset(result, attrs)
    if preset.separates:
        d, f = result.indentation, result.force
        ds["dissipated_energy"] = ((), dissipated_energy(d, f),
                                   {"units": "J", "long_name": "dissipated energy W, closed integral of F dd"})
        ds["loading_work"] = ((), loading_work(d, f),
                              {"units": "J", "long_name": "work done on the tread while d increases"})
    return ds
