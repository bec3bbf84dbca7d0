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

import numba
import numpy as np
import xarray as xr
import yaml

from . import checks
from .history import History
from .hysteresis import dissipated_energy, loading_work
from .influence import Tangent
from .kernel import LayerKernel
from .log import Progress
from .loading import IndentationPath, Loading, LoadingPreset, constant_acceleration_path, uniform_indentation_grid
from .newton import StepConvergenceError, Substrate, solve_step
from .solver import SolverSettings
from .springs import SpringTable
from .qlv import springs_for_run
from .stability import StabilityRecord, stability_record

logger = logging.getLogger(__name__)

__all__ = [
    "MODES",
    "SolverSettings",
    "ContactConvergenceError",
    "ContactResult",
    "RunRecorder",
    "march",
    "run_loading_path",
    "solve_path",
    "solve_dynamic",
    "solve_quasistatic",
    "solve_run",
    "solve_loading",
    "PreloadStates",
    "preload_states",
    "linear_range",
    "check_harmonic_amplitude",
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
        Quasi-static runs (static kernel): dF/dd of each solved state [N/m], shape (n),
        1^T [G0|C + diag(1/k)]^-1 1 over the contact set (the substrate's ``tangent``); exact between
        contact-set changes, so coarse indentation steps keep K(d) exact. None otherwise.
    max_spring_stiffness : numpy.ndarray or None
        The stiffest tangent spring k_e of each step [N/m], shape (n,).
    stability : tyreroad.stability.StabilityRecord or None
        Dynamic runs from the stage datasets: the kernel's fs/2 limit and the alternation.
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
    max_spring_stiffness: np.ndarray | None = None
    stability: StabilityRecord | None = None

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
    tangent : bool
        Keep the quasi-static tangent dF/dd of every step (``tangent_stiffness``; runs on a static
        kernel, whose march linearises every solved state).
    """

    def __init__(self, n_steps: int, shape: tuple[int, int], tangent: bool = False):
        n_elem = shape[0] * shape[1]
        self.shape = shape
        self.wants_tangent = bool(tangent)
        self.tangent_stiffness = np.zeros(n_steps) if tangent else None
        self.force = np.zeros((n_steps, n_elem))
        self.compression = np.zeros((n_steps, n_elem))
        self.displacement = np.zeros((n_steps, n_elem))
        self.contact_count = np.zeros(n_steps, dtype=np.int64)
        self.newton_iterations = np.zeros(n_steps, dtype=np.int64)
        self.krylov_iterations = np.zeros(n_steps, dtype=np.int64)
        self.residual = np.zeros(n_steps)
        self.max_spring_stiffness = np.zeros(n_steps)

    def store(self, n: int, step, displacement: np.ndarray, tangent: Tangent | None = None) -> None:
        """Record the converged ``step`` (a :class:`tyreroad.newton.StepResult`) of step n, and its
        tangent where the march linearised it."""
        self.force[n] = step.force
        self.compression[n] = step.zeta
        self.displacement[n] = displacement
        self.contact_count[n] = np.count_nonzero(step.force)
        self.newton_iterations[n] = step.newton_iterations
        self.krylov_iterations[n] = step.krylov_iterations
        self.residual[n] = step.residual
        self.max_spring_stiffness[n] = float(np.max(step.stiffness, initial=0.0))
        if self.tangent_stiffness is not None:
            if tangent is None:
                raise ValueError(f"RunRecorder.store: step {n} has no tangent, but the recorder keeps one per step")
            self.tangent_stiffness[n] = tangent.stiffness

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
            max_spring_stiffness=self.max_spring_stiffness[:n],
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
    w[n] = h[n] + G0 F[n]; the history records F[n]. Where the recorder keeps tangents (a run on a
    static kernel: every step a static state) the substrate's tangent of each solved state goes to
    the recorder and, as the predictor of its first Newton step, to the next step.

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
        Where the steps go: ``wants_tangent`` (bool: linearise every solved state with
        ``substrate.tangent``), ``store(n, step, w, tangent)`` and ``result(loading[, n])``.

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
    progress = Progress(n_steps)  # elapsed and time left on each line; a line at least every minute
    tangent = None
    # springs with a force history (QLV, tyreroad.qlv.MarchSprings) start at rest and commit each step
    start, commit = getattr(springs, "start", None), getattr(springs, "commit", None)
    if start is not None:
        start()
    for n in range(n_steps):
        h = history.displacement(n)
        b = loading.free_compression(n) - h
        try:
            step = solve_step(b, zeta, springs, substrate, settings.tolerance, settings.max_iterations,
                              shift=b - b_prev, predictor=tangent)
        except StepConvergenceError as err:
            raise ContactConvergenceError(f"contact step {n} ({loading.describe(n)}): {err}") from err
        b_prev, zeta = b, step.zeta
        history.record(n, step.force)
        if commit is not None:
            commit(step.zeta)
        w = h + substrate.instant(step.force)
        tangent = substrate.tangent(step.stiffness) if recorder.wants_tangent else None
        recorder.store(n, step, w, tangent)
        finished = loading.done(n, step.force)
        if finished or n % report_every == 0 or n == n_steps - 1 or progress.due():
            logger.info(
                "step %d/%d: %s, F = %.5e N, %d elements in contact, %d Newton / %d Krylov iterations%s; %s",
                n, n_steps - 1, loading.describe(n), step.force.sum(), recorder.contact_count[n],
                step.newton_iterations, step.krylov_iterations, ", path complete" if finished else "",
                progress.status(n + 1),
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
    """The numba thread count of a run (the one place that sets it, process-wide)."""
    threads = checks.integer("threads", threads)
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))


def _max_spring_stiffness(springs) -> float:
    """The stiffest tangent a spring set can reach [N/m]: its tables' maximum (beyond the table k stays at
    its last value), or ``springs.max_stiffness`` for another springs object (inf if it has neither)."""
    explicit = getattr(springs, "max_stiffness", None)
    if explicit is not None:
        return float(explicit)
    table = getattr(springs, "stiffness", None)
    return float(np.max(table)) if table is not None else math.inf


def run_loading_path(loading: Loading, springs, kernel: LayerKernel, settings: SolverSettings, threads: int = 1,
                     recorder=None):
    """Assemble the collaborators for a loading on a patch and march (the entry point of every run).

    Parameters
    ----------
    loading : Loading
        The prescribed motion; ``loading.shape`` is the patch (nx, ny).
    springs : SpringTable
        One spring per element (or any object with the springs protocol of :mod:`tyreroad.newton`).
    kernel : tyreroad.kernel.LayerKernel
        The layer: its substrate, history and memory (:meth:`LayerKernel.collaborators`); a static
        kernel makes every step a static state whose tangent dF/dd is kept.
    settings : SolverSettings
        Method, tolerance, iteration limit, long memory.
    threads : int
        numba threads and FFT workers.
    recorder : optional
        What keeps the steps (``wants_tangent``, ``store(n, step, w, tangent)`` and
        ``result(loading[, n])``); default a :class:`RunRecorder`, which for a static kernel also
        stores the tangent stiffness dF/dd.

    Returns
    -------
    The recorder's result (a :class:`ContactResult` for the default recorder).
    """
    if not isinstance(settings, SolverSettings):
        raise TypeError(f"settings: expected SolverSettings, got {type(settings).__name__}")
    if not isinstance(kernel, LayerKernel):
        raise TypeError(f"kernel: expected a LayerKernel (tyreroad.kernel), got {type(kernel).__name__}")
    _set_threads(threads)
    for_kernel = getattr(springs, "for_kernel", None)
    if for_kernel is not None:  # viscoelastic (QLV) springs: their march form at the kernel's time step
        springs = for_kernel(kernel)
    if not kernel.static:
        kernel.check_springs(_max_spring_stiffness(springs), settings.stability)
    substrate, history = kernel.collaborators(loading.shape, settings, threads, loading.n_steps)
    if recorder is None:
        recorder = RunRecorder(loading.n_steps, loading.shape, tangent=kernel.static)
    loading, springs, recorder = kernel.march_view(loading, springs, recorder)
    return march(loading, springs, substrate, history, settings, recorder)


def solve_path(
    z1,
    stiffness,
    force,
    zeta_step: float,
    kernel: LayerKernel,
    indentation,
    settings: SolverSettings,
    time=None,
    threads: int = 1,
) -> ContactResult:
    """Solve the contact of a flat tread surface along a prescribed indentation path.

    Step n of a dynamic kernel uses its lags 1 ... L-1 (and its memory) for the history, i.e. the
    indentations are taken as sampled at the kernel's sample rate; on a static kernel the steps
    are independent static states, linked only through the warm start.

    Parameters
    ----------
    z1 : array_like
        Road matching heights z1[ex, ey] [m].
    stiffness, force : array_like
        Spring tables on zeta_j = j * zeta_step: k [N/m] and F [N], shape (nx, ny, n_zeta) or
        (nx * ny, n_zeta).
    zeta_step : float
        Spring table step [m].
    kernel : tyreroad.kernel.LayerKernel
        The layer's kernel (:meth:`LayerKernel.dynamic`, :meth:`LayerKernel.quasistatic`).
    indentation : array_like
        d_n [m], one per step (any order: loading, holding, unloading).
    settings : SolverSettings
        Tolerance and iteration limit.
    time : array_like, optional
        t_n [s], stored in the result.
    threads : int
        numba threads and FFT workers.

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
    return run_loading_path(loading, springs, kernel, settings, threads)


def solve_dynamic(z1, stiffness, force, zeta_step: float, kernel, sample_rate: float, acceleration: float,
                  settings: SolverSettings, threads: int = 1, tail=None) -> ContactResult:
    """:func:`solve_path` of the seed's loading d(t) = a t^2 / 2 on a dynamic kernel given as arrays.

    ``kernel`` is g[dx, dy, lag] [m/N] sampled at ``sample_rate`` [Hz], ``tail`` its memory model
    (:class:`tyreroad.memory.TailModel`) for runs longer than the kept lags; the run goes from
    t = 0 to the first step with d >= ``settings.d_max`` at ``acceleration`` [m/s^2].
    """
    time, d = constant_acceleration_path(sample_rate, acceleration, settings.d_max)
    logger.info("dynamic run: a = %g m/s^2, fs = %g Hz, %d steps", acceleration, sample_rate, d.size)
    layer = LayerKernel.dynamic(kernel, sample_rate, tail)
    return solve_path(z1, stiffness, force, zeta_step, layer, d, settings, time=time, threads=threads)


def solve_quasistatic(z1, stiffness, force, zeta_step: float, kernel_static, settings: SolverSettings,
                      indentation=None) -> ContactResult:
    """:func:`solve_path` on the static kernel g_static[dx, dy] [m/N] given as an array.

    ``indentation`` [m] defaults to the uniform grid of ``settings.quasistatic_step`` up to
    ``settings.d_max``; the result has ``time = None`` and the tangent dF/dd of every state.
    """
    d = uniform_indentation_grid(settings.d_max, settings.quasistatic_step) if indentation is None else indentation
    logger.info("quasi-static run: %d steps", np.size(d))
    return solve_path(z1, stiffness, force, zeta_step, LayerKernel.quasistatic(kernel_static), d, settings)


def _stage_run(surface: xr.Dataset, springs: xr.Dataset, greens: xr.Dataset, material, mode: str, make_loading,
               settings: SolverSettings, threads: int) -> ContactResult:
    """One run from the stage datasets; ``make_loading(z1, kernel)`` gives its loading."""
    if mode not in MODES:
        raise ValueError(f"mode: expected one of {MODES}, got {mode!r}")
    kernel = LayerKernel.from_greens(greens, mode, material)
    kernel.check_element_size(surface.attrs.get("element_size"))
    z1 = surface["z1"].transpose("ex", "ey").values
    table = SpringTable.from_dataset(springs)
    loading = make_loading(z1, kernel)
    springs_table = springs_for_run(springs, SpringTable.checked(table.stiffness, table.force, table.zeta_step,
                                                                 z1.size))
    if "hard_stiffness" in springs.attrs and "g_static" in greens:  # springs.model: hard
        k_hard, g_self = float(springs.attrs["hard_stiffness"]), float(greens["g_static"].sel(dx=0, dy=0))
        logger.info("hard contact: penalty springs of %.3g N/m, compliance 1/k = %.3g m/N = %.3g of the layer's static "
                    "self-compliance g(0) = %.4g m/N (the penalty's relative force error)", k_hard, 1.0 / k_hard,
                    1.0 / (k_hard * g_self), g_self)
    result = run_loading_path(loading, springs_table, kernel, settings, threads)
    stability = None if kernel.static else stability_record(kernel, loading.shape, result.max_spring_stiffness,
                                                            result.force, threads)
    return dataclasses.replace(result, backing_force=kernel.backing_force(result.force), stability=stability)


@dataclass(frozen=True)
class PreloadStates:
    """Quasi-static (relaxed) contact states at the preloads.

    Attributes
    ----------
    preload : numpy.ndarray
        d0 [m], shape (P,).
    compression : numpy.ndarray
        zeta_e [m], shape (P, nx, ny).
    spring_stiffness : numpy.ndarray
        k_e(zeta_e) [N/m], shape (P, nx, ny) (0 outside the contact set).
    force : numpy.ndarray
        Total force F(d0) [N], shape (P,).
    tangent_stiffness : numpy.ndarray
        dF/dd of the quasi-static curve at d0 [N/m], shape (P,).
    contact_count : numpy.ndarray
        Elements in contact, shape (P,).
    """

    preload: np.ndarray
    compression: np.ndarray
    spring_stiffness: np.ndarray
    force: np.ndarray
    tangent_stiffness: np.ndarray
    contact_count: np.ndarray


def preload_states(z1, springs, relaxed: LayerKernel, preloads, settings: SolverSettings,
                   threads: int = 1) -> PreloadStates:
    """Solve the quasi-static contact up to each preload (the relaxed preload states).

    The indentation path is the uniform grid of ``settings.quasistatic_step`` up to the largest
    preload with the preloads inserted (warm starts); each preload's state is read from the step
    at that preload.

    Parameters
    ----------
    z1 : array_like
        Road matching heights z1[ex, ey] [m].
    springs : tyreroad.springs.SpringTable
        Spring tables, shape (nx, ny, n_zeta) or (M, n_zeta).
    relaxed : tyreroad.kernel.LayerKernel
        The static kernel of the relaxed layer (g_static).
    preloads : sequence of float
        d0 [m], increasing.
    settings : tyreroad.solver.SolverSettings
        Tolerance, iteration limit, indentation step and method.
    threads : int
        numba threads and FFT workers.

    Returns
    -------
    PreloadStates
    """
    if not relaxed.static:
        raise ValueError(f"{relaxed.name}: the relaxed preload state needs the static kernel, got a dynamic one")
    z1 = np.asarray(z1, dtype=float)
    pre = np.asarray(preloads, dtype=float)
    grid = uniform_indentation_grid(float(pre[-1]), settings.quasistatic_step)
    path = np.unique(np.concatenate([grid[grid < pre[-1]], pre]))
    result = solve_path(z1, springs.stiffness, springs.force, springs.zeta_step, relaxed, path, settings,
                        threads=threads)
    steps = np.searchsorted(path, pre)
    zeta = result.compression[steps]
    _, k = springs.evaluate(zeta.reshape((pre.size,) + springs.stiffness.shape[:-1]))
    k = k.reshape(zeta.shape)
    return PreloadStates(
        preload=pre,
        compression=zeta,
        spring_stiffness=k,
        force=result.force[steps],
        tangent_stiffness=np.asarray(result.tangent_stiffness)[steps],
        contact_count=result.contact_count[steps],
    )


def linear_range(z1, springs: SpringTable, relaxed: LayerKernel, preload: float, settings: SolverSettings,
                 threads: int = 1) -> tuple[float, float]:
    """The small-amplitude range of the relaxed preload state at d0 (the state K*(f; d0) linearises):
    (smallest compression of a spring in contact, smallest open gap) [m] (inf where there is none).

    A harmonic indentation about d0 stays linear -- no element closes or opens, so K* describes it --
    only while its amplitude is below both. The state is the stiffness spectrum's
    (:func:`preload_states`).
    """
    zeta = preload_states(z1, springs, relaxed, (float(preload),), settings, threads).compression[0].ravel()
    touching, open_gap = zeta[zeta > 0.0], -zeta[zeta < 0.0]
    return (float(touching.min()) if touching.size else math.inf,
            float(open_gap.min()) if open_gap.size else math.inf)


def check_harmonic_amplitude(preset: LoadingPreset, z1, springs: SpringTable, relaxed: LayerKernel,
                             settings: SolverSettings, threads: int = 1) -> None:
    """Refuse a ``harmonic`` loading preset whose amplitude leaves the linear range of its preload state.

    Raises
    ------
    ValueError
        Naming ``loadings.<name>.amplitude``, the amplitude, and both limits of :func:`linear_range`.
    """
    if preset.kind != "harmonic":
        return
    amplitude, d0 = float(preset.params["amplitude"]), float(preset.params["preload"])
    compression, gap = linear_range(z1, springs, relaxed, d0, settings, threads)
    logger.info("harmonic %s: amplitude %.3g m; at d0 = %.4g m the smallest compression in contact is %.3g m, the "
                "smallest open gap %.3g m", preset.name, amplitude, d0, compression, gap)
    if amplitude >= min(compression, gap):
        raise ValueError(
            f"loadings.{preset.name}.amplitude = {amplitude:.3g} m: beyond the linear range of its preload state "
            f"(relaxed, d0 = {d0:.4g} m): the smallest compression of a spring in contact is {compression:.3g} m and "
            f"the smallest open gap {gap:.3g} m; expected an amplitude below both (larger ones open and close "
            "contacts, and the run is no longer the small-amplitude K* of stiffness_spectrum)"
        )


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
    quasi-static runs the static kernel (their backing force is the surface force). A ``harmonic``
    preset is first checked against the linear range of its preload state
    (:func:`check_harmonic_amplitude`).

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
    if preset.kind == "harmonic":
        relaxed = LayerKernel.from_greens(greens, "quasistatic")
        check_harmonic_amplitude(preset, surface["z1"].transpose("ex", "ey").values,
                                 SpringTable.from_dataset(springs), relaxed, settings, threads)

    def make_loading(z1, kernel):
        loading = preset.loading(z1, mode, kernel.sample_rate, settings.quasistatic_step)
        logger.info("%s run of loading %s (%s): %d steps", mode, preset.name, preset.kind, loading.n_steps)
        return loading

    return _stage_run(surface, springs, greens, material, mode, make_loading, settings, threads)


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
    """One run of the seed's study from the stage datasets (surface, springs, greens; docs/data_contracts.md).

    Dynamic: d(t) = a t^2 / 2 at the greens file's sample rate up to ``settings.d_max``, with the
    backing force (:func:`tyreroad.layer.backing_force`); quasi-static: the uniform indentation grid
    of ``settings.quasistatic_step`` (acceleration 0), whose backing force is the surface force.

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
    if mode == "quasistatic" and acceleration != 0:
        raise ValueError(f"acceleration: quasi-static runs use 0 m/s^2, got {acceleration!r}")

    def make_loading(z1, kernel):
        if kernel.static:
            d, time = uniform_indentation_grid(settings.d_max, settings.quasistatic_step), None
            logger.info("quasi-static run: %d steps", d.size)
        else:
            time, d = constant_acceleration_path(kernel.sample_rate, acceleration, settings.d_max)
            logger.info("dynamic run: a = %g m/s^2, fs = %g Hz, %d steps", acceleration, kernel.sample_rate, d.size)
        return IndentationPath(z1, d, time)

    return _stage_run(surface, springs, greens, material, mode, make_loading, settings, threads)


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
    if result.stability is not None:
        data_vars.update(result.stability.variables())
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
