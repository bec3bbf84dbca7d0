"""Time-domain contact between the rigid rough road and the tread layer (SPEC section 6).

Each road element e carries a nonlinear contact spring with compression

    zeta_e[n] = z1_e - z2[n] - w_e[n],       z2[n] = max_e z1_e - d[n],

and the layer surface displacement is the discrete convolution of the spring forces with the
element Green's function table g[dx, dy, lag] (seed Eq. 3-4):

    w_e[n] = sum_m g_{e-m}[0] F_m[n] + h_e[n],   h_e[n] = sum_{l=1}^{L-1} sum_m g_{e-m}[l] F_m[n-l].

The history h is known at step n, so each step solves the M nonlinear equations

    R(zeta) = zeta - b + G0 F(zeta) = 0,          b = z1 - z2[n] - h[n],

by Newton's method with J = I + G0 diag(k(zeta)), warm started from the previous step and
safeguarded by step halving whenever the max-norm of the residual does not decrease.

Dynamic runs prescribe d(t) = a t^2 / 2 at t_n = n / fs. Quasi-static runs use the same solver
with the one-lag kernel g = [g_static] on a uniform indentation grid 0, dd, 2 dd, ... .

The history sum uses the translation invariance of the layer (one offset table instead of
M x M matrices per lag) and loops only over elements that carried force at the lagged step
(:func:`_history_sum`); :func:`dense_history_sum` is the plain dense reference used in tests.
The Newton direction (:func:`_newton_direction`) and the history sum are kept in small,
isolated functions so that an FFT history or a matrix-free Newton-Krylov solve can be added
next to them.

The force at the rigid backing is the total surface force filtered by the k = 0 (uniform load)
transfer of the layer, T(omega) = 1 / cos(omega h / c_p(omega)) (:func:`backing_force`).

References
----------
Winroth, Andersson & Kropp (2014), Importance of tread inertia and damping on the tyre/road
contact stiffness, J. Sound Vib. 333, 5378-5385. doi:10.1016/j.jsv.2014.05.046
"""

from __future__ import annotations

import dataclasses
import logging
import math
from dataclasses import dataclass
from typing import Any, Mapping

import numba
import numpy as np
import xarray as xr
from numba import njit, prange

from .convolution import check_offset_kernel

logger = logging.getLogger(__name__)

__all__ = [
    "SolverSettings",
    "ContactConvergenceError",
    "ContactResult",
    "evaluate_springs",
    "dense_history_sum",
    "dynamic_indentation",
    "quasistatic_indentation",
    "solve_path",
    "solve_dynamic",
    "solve_quasistatic",
    "solve_run",
    "layer_transfer_k0",
    "backing_kernel",
    "backing_force",
    "contact_dataset",
]

#: Step halvings tried per Newton iteration before the full (non-monotone) step is taken.
_MAX_HALVINGS = 30

MODES = ("dynamic", "quasistatic")


# --------------------------------------------------------------------------------------------
# Settings and errors
# --------------------------------------------------------------------------------------------
#: Patches with more elements than this use the FFT / Newton-Krylov path when ``method="auto"``:
#: the paper's 20 x 20 patch keeps the exact dense path.
FFT_THRESHOLD = 400


class ContactConvergenceError(RuntimeError):
    """A contact step whose Newton iteration did not reach the tolerance."""


def _config_float(key: str, value: Any, positive: bool = True) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"solver.{key}: expected a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value) or (positive and value <= 0):
        raise ValueError(f"solver.{key}: expected a finite number > 0, got {value!r}")
    return value


@dataclass(frozen=True)
class SolverSettings:
    """Contact solver settings (config section ``solver``).

    Parameters
    ----------
    tolerance : float
        Newton convergence criterion on max_e |R_e| [m] (default 1e-12).
    max_iterations : int
        Newton iterations allowed per step before the run stops with an error (default 50).
    d_max : float
        Final indentation of a run [m] (default 2.5e-4).
    quasistatic_step : float
        Indentation step of quasi-static runs [m] (default 1e-6).
    method : {"auto", "dense", "fft"}
        History sum and step solver. ``dense``: offset-table history and a direct solve of the
        Jacobian of the loaded elements (exact, the reference; O(M^2 L) per step). ``fft``: 2-D FFT
        history sums and a matrix-free Newton-Krylov solve (:mod:`tyreroad.convolution`;
        O(M log M L) per step). ``auto`` (default) uses ``fft`` above ``FFT_THRESHOLD`` elements.
    preconditioner_block : int
        Tile edge [elements] of the block-Jacobi preconditioner of the ``fft`` path (default 4).
    """

    tolerance: float = 1e-12
    max_iterations: int = 50
    d_max: float = 2.5e-4
    quasistatic_step: float = 1e-6
    method: str = "auto"
    preconditioner_block: int = 4

    def resolved_method(self, n_elements: int) -> str:
        """``dense`` or ``fft`` for a patch of ``n_elements`` elements."""
        if self.method == "auto":
            return "fft" if n_elements > FFT_THRESHOLD else "dense"
        return self.method

    def __post_init__(self) -> None:
        if self.method not in ("auto", "dense", "fft"):
            raise ValueError(f"solver.method: expected 'auto', 'dense' or 'fft', got {self.method!r}")
        pb = self.preconditioner_block
        if isinstance(pb, bool) or not isinstance(pb, (int, np.integer)) or pb < 1:
            raise ValueError(f"solver.preconditioner_block: expected an integer >= 1, got {pb!r}")
        _config_float("tolerance", self.tolerance)
        _config_float("d_max", self.d_max)
        _config_float("quasistatic_step", self.quasistatic_step)
        it = self.max_iterations
        if isinstance(it, bool) or not isinstance(it, (int, np.integer)) or it < 1:
            raise ValueError(f"solver.max_iterations: expected an integer >= 1, got {it!r}")
        if self.quasistatic_step > self.d_max:
            raise ValueError(
                f"solver.quasistatic_step: expected <= solver.d_max = {self.d_max:g} m, "
                f"got {self.quasistatic_step:g} m"
            )

    @classmethod
    def from_config(cls, section: Mapping[str, Any] | None) -> "SolverSettings":
        """Build from the ``solver`` config section; missing keys take the defaults.

        Raises
        ------
        ValueError
            Naming ``solver.<key>`` for unknown keys and for values of the wrong type or range.
        """
        section = dict(section or {})
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(section) - known)
        if unknown:
            raise ValueError(
                f"solver.{unknown[0]}: unknown key (expected one of {', '.join(sorted(known))})"
            )
        values = {}
        for key in ("tolerance", "d_max", "quasistatic_step"):
            if key in section:
                values[key] = _config_float(key, section[key])
        for key in ("max_iterations", "preconditioner_block"):
            if key in section:
                it = section[key]
                if isinstance(it, float) and it.is_integer():
                    it = int(it)
                values[key] = it
        if "method" in section:
            values["method"] = section["method"]
        return cls(**values)


@dataclass(frozen=True)
class ContactResult:
    """Time (or indentation) series of one contact run.

    Attributes
    ----------
    time : numpy.ndarray or None
        t_n [s], shape (n,); None for quasi-static runs.
    indentation : numpy.ndarray
        d_n [m], shape (n,).
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
    newton_iterations : numpy.ndarray
        Newton iterations of each step, shape (n,).
    residual : numpy.ndarray
        Final max_e |R_e| of each step [m], shape (n,).
    backing_force : numpy.ndarray or None
        Total force at the rigid backing [N], shape (n,), when computed (:func:`solve_run`).
    """

    time: np.ndarray | None
    indentation: np.ndarray
    force: np.ndarray
    element_force: np.ndarray
    compression: np.ndarray
    displacement: np.ndarray
    contact_count: np.ndarray
    newton_iterations: np.ndarray
    residual: np.ndarray
    backing_force: np.ndarray | None = None


# --------------------------------------------------------------------------------------------
# Spring tables (interpolation contract of docs/data_contracts.md, shared with tyreroad.springs.evaluate)
# --------------------------------------------------------------------------------------------
@njit(cache=True)
def _spring_eval(zeta, stiffness, force, zeta_step, f_out, k_out):  # pragma: no cover - numba
    """F and k of every element's spring at its compression (contract of docs/data_contracts.md)."""
    n_elem, n_zeta = stiffness.shape
    last = n_zeta - 1
    zeta_last = last * zeta_step
    for m in range(n_elem):
        z = zeta[m]
        if z <= 0.0:
            f_out[m] = 0.0
            k_out[m] = 0.0
        elif z >= zeta_last:
            k = stiffness[m, last]
            k_out[m] = k
            f_out[m] = force[m, last] + k * (z - zeta_last)
        else:
            u = z / zeta_step
            j = int(u)
            if j > last - 1:
                j = last - 1
            t = u - j
            k0 = stiffness[m, j]
            slope = stiffness[m, j + 1] - k0
            k_out[m] = k0 + slope * t
            f_out[m] = force[m, j] + zeta_step * t * (k0 + 0.5 * slope * t)


def _check_spring_tables(stiffness, force, zeta_step, n_elem: int) -> tuple[np.ndarray, np.ndarray, float]:
    """Validate spring tables; return C-contiguous (M, n_zeta) copies and the step."""
    step = float(zeta_step)
    if not math.isfinite(step) or step <= 0:
        raise ValueError(f"zeta_step: expected a finite number > 0 [m], got {zeta_step!r}")
    k_tab = np.asarray(stiffness, dtype=float)
    f_tab = np.asarray(force, dtype=float)
    if k_tab.shape != f_tab.shape:
        raise ValueError(f"spring tables: stiffness {k_tab.shape} and force {f_tab.shape} differ in shape")
    if k_tab.ndim == 3:
        k_tab = k_tab.reshape(-1, k_tab.shape[-1])
        f_tab = f_tab.reshape(-1, f_tab.shape[-1])
    if k_tab.ndim != 2 or k_tab.shape[0] != n_elem or k_tab.shape[1] < 2:
        raise ValueError(
            f"spring tables: expected shape ({n_elem}, n_zeta) or (nx, ny, n_zeta) with n_zeta >= 2, "
            f"got {np.shape(stiffness)}"
        )
    if not (np.all(np.isfinite(k_tab)) and np.all(np.isfinite(f_tab))):
        raise ValueError("spring tables: stiffness/force contain NaN or infinite values")
    if np.any(k_tab < 0):
        raise ValueError("spring tables: stiffness must be >= 0 [N/m]")
    # F must be the integral of the piecewise-linear k, or Newton's Jacobian would not be dF/dzeta.
    expected = np.zeros_like(k_tab)
    np.cumsum(0.5 * step * (k_tab[:, 1:] + k_tab[:, :-1]), axis=1, out=expected[:, 1:])
    scale = max(float(np.max(np.abs(expected))), np.finfo(float).tiny)
    mismatch = float(np.max(np.abs(f_tab - expected)))
    if mismatch > 1e-9 * scale:
        raise ValueError(
            "spring tables: force is not the cumulative trapezoid of stiffness on the zeta grid "
            f"(max mismatch {mismatch:.3e} N, {mismatch / scale:.2e} of the largest force)"
        )
    return np.ascontiguousarray(k_tab), np.ascontiguousarray(f_tab), step


def evaluate_springs(zeta, stiffness, force, zeta_step) -> tuple[np.ndarray, np.ndarray]:
    """Spring force and stiffness of every element (numba implementation of the contract).

    Parameters
    ----------
    zeta : array_like
        Compression of each element [m], shape (M,).
    stiffness : array_like
        k on the grid zeta_j = j * zeta_step [N/m], shape (M, n_zeta) or (nx, ny, n_zeta).
    force : array_like
        F on the same grid [N]: the cumulative trapezoid of ``stiffness``.
    zeta_step : float
        Grid step [m].

    Returns
    -------
    force, stiffness : numpy.ndarray
        F(zeta) [N] and k(zeta) = dF/dzeta [N/m], shape (M,): zero for zeta <= 0, k piecewise
        linear on the grid with F its exact integral, k constant and F linear beyond the grid.
    """
    z = np.ascontiguousarray(np.asarray(zeta, dtype=float).ravel())
    if np.any(np.isnan(z)):
        raise ValueError("evaluate_springs: zeta contains NaN")
    k_tab, f_tab, step = _check_spring_tables(stiffness, force, zeta_step, z.size)
    f_out = np.empty_like(z)
    k_out = np.empty_like(z)
    _spring_eval(z, k_tab, f_tab, step, f_out, k_out)
    return f_out, k_out


# --------------------------------------------------------------------------------------------
# Kernel handling and history sums
# --------------------------------------------------------------------------------------------
def _offset_indices(nx: int, ny: int) -> tuple[np.ndarray, np.ndarray]:
    """Table indices (dx + nx - 1, dy + ny - 1) of e - m for all element pairs (C order)."""
    ex, ey = np.divmod(np.arange(nx * ny), ny)
    return ex[:, None] - ex[None, :] + nx - 1, ey[:, None] - ey[None, :] + ny - 1


def _lag_matrix(kernel: np.ndarray, lag: int) -> np.ndarray:
    """Dense M x M influence matrix of one lag: G[e, m] = g[e - m, lag] [m/N]."""
    nx, ny = (kernel.shape[0] + 1) // 2, (kernel.shape[1] + 1) // 2
    ix, iy = _offset_indices(nx, ny)
    return np.ascontiguousarray(kernel[ix, iy, lag])


def dense_history_sum(kernel, force_history, n: int) -> np.ndarray:
    """History term h[n] = sum_{l=1}^{L-1} G_l F[n-l] with dense M x M matrices (reference).

    Parameters
    ----------
    kernel : array_like
        g[dx, dy, lag] [m/N], shape (2 nx - 1, 2 ny - 1, L).
    force_history : array_like
        F[s, ex, ey] [N] for steps s = 0 ... >= n - 1 (forces before step 0 are zero).
    n : int
        Current step.

    Returns
    -------
    numpy.ndarray
        h[n] [m], shape (nx, ny).
    """
    f = np.asarray(force_history, dtype=float)
    if f.ndim != 3:
        raise ValueError(f"force_history: expected F[step, ex, ey], got shape {f.shape}")
    nx, ny = f.shape[1:]
    g = check_offset_kernel(kernel, nx, ny)
    h = np.zeros(nx * ny)
    for lag in range(1, min(g.shape[2] - 1, n) + 1):
        h += _lag_matrix(g, lag) @ f[n - lag].ravel()
    return h.reshape(nx, ny)


@njit(cache=True, parallel=True)
def _history_sum(kern_t, f_hist, nz_idx, nz_cnt, n, nx, ny, out):  # pragma: no cover - numba
    """h[n] from the offset table kern_t[lag, dx, dy], visiting only loaded elements.

    ``nz_idx[s, :nz_cnt[s]]`` lists the flat indices of elements with F != 0 at step s.
    Rows ex are independent, so they run in parallel without races.
    """
    n_lag = kern_t.shape[0]
    lmax = min(n_lag - 1, n)
    for ex in prange(nx):
        for ey in range(ny):
            out[ex * ny + ey] = 0.0
        for lag in range(1, lmax + 1):
            s = n - lag
            for q in range(nz_cnt[s]):
                m = nz_idx[s, q]
                mx = m // ny
                my = m - mx * ny
                f = f_hist[s, m]
                row = ex - mx + nx - 1
                off = ny - 1 - my
                for ey in range(ny):
                    out[ex * ny + ey] += kern_t[lag, row, ey + off] * f


# --------------------------------------------------------------------------------------------
# Newton solve of one step
# --------------------------------------------------------------------------------------------
def _residual(zeta, b, g0, k_tab, f_tab, step, f_out, k_out) -> np.ndarray:
    """R = zeta - b + G0 F(zeta); fills f_out, k_out with F(zeta), k(zeta)."""
    _spring_eval(zeta, k_tab, f_tab, step, f_out, k_out)
    active = np.flatnonzero(f_out)
    return (zeta - b) + g0[:, active] @ f_out[active]


@njit(cache=True)
def _jacobian_block_solve(g0, active, ka, rhs):  # pragma: no cover - numba
    """Solve (I + G0[A, A] diag(k_A)) x = rhs by Gaussian elimination with partial pivoting.

    Done in numba rather than LAPACK so that the small dense solve does not spawn BLAS threads
    that oversubscribe the cores shared with other pipeline jobs. Returns (x, ok); ok is False
    for an exactly singular pivot.
    """
    n = active.size
    a = np.empty((n, n))
    for i in range(n):
        gi = active[i]
        for j in range(n):
            a[i, j] = g0[gi, active[j]] * ka[j]
        a[i, i] += 1.0
    x = rhs.copy()
    for col in range(n):
        piv = col
        amax = abs(a[col, col])
        for r in range(col + 1, n):
            if abs(a[r, col]) > amax:
                amax = abs(a[r, col])
                piv = r
        if amax == 0.0:
            return x, False
        if piv != col:
            for c in range(n):
                tmp = a[col, c]
                a[col, c] = a[piv, c]
                a[piv, c] = tmp
            tmp = x[col]
            x[col] = x[piv]
            x[piv] = tmp
        inv = 1.0 / a[col, col]
        for r in range(col + 1, n):
            fct = a[r, col] * inv
            if fct != 0.0:
                for c in range(col + 1, n):
                    a[r, c] -= fct * a[col, c]
                x[r] -= fct * x[col]
    for r in range(n - 1, -1, -1):
        acc = x[r]
        for c in range(r + 1, n):
            acc -= a[r, c] * x[c]
        x[r] = acc / a[r, r]
    return x, True


def _newton_direction(g0: np.ndarray, k: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Solve (I + G0 diag(k)) delta = -R.

    Columns of elements with k = 0 are unit vectors, so only the block of loaded elements A is
    factorised: (I + G_AA K_A) delta_A = -R_A, then delta_I = -R_I - G_IA K_A delta_A.
    """
    active = np.flatnonzero(k)
    if active.size == 0:
        return -r
    ka = k[active]
    delta_a, ok = _jacobian_block_solve(g0, active, ka, -r[active])
    if not ok:
        raise ContactConvergenceError("Newton Jacobian I + G0 diag(k) is singular")
    delta = -r - g0[:, active] @ (ka * delta_a)
    delta[active] = delta_a
    return delta


def _solve_step(b, zeta0, g0, k_tab, f_tab, step, settings: SolverSettings, n: int, d: float):
    """Newton iteration with step halving for one step; returns (zeta, F, k, iterations, |R|)."""
    n_elem = b.size
    f = np.empty(n_elem)
    k = np.empty(n_elem)
    f_try = np.empty(n_elem)
    k_try = np.empty(n_elem)
    zeta = zeta0.copy()
    r = _residual(zeta, b, g0, k_tab, f_tab, step, f, k)
    rnorm = float(np.max(np.abs(r)))
    iterations = 0
    while rnorm > settings.tolerance:
        if iterations >= settings.max_iterations:
            raise ContactConvergenceError(
                f"contact step {n} (d = {d:.6e} m): Newton did not converge in "
                f"{settings.max_iterations} iterations, residual max|R| = {rnorm:.3e} m "
                f"> tolerance {settings.tolerance:.1e} m"
            )
        delta = _newton_direction(g0, k, r)
        lam = 1.0
        for _ in range(_MAX_HALVINGS + 1):
            zeta_try = zeta + lam * delta
            r_try = _residual(zeta_try, b, g0, k_tab, f_tab, step, f_try, k_try)
            rnorm_try = float(np.max(np.abs(r_try)))
            if rnorm_try < rnorm:
                break
            lam *= 0.5
        else:
            # At a kink of F (an element entering contact) no halving may reduce the max-norm;
            # the full step keeps the iteration moving and max_iterations still bounds it.
            logger.debug("step %d: no residual decrease in %d halvings, full Newton step", n, _MAX_HALVINGS)
            zeta_try = zeta + delta
            r_try = _residual(zeta_try, b, g0, k_tab, f_tab, step, f_try, k_try)
            rnorm_try = float(np.max(np.abs(r_try)))
        zeta, r, rnorm = zeta_try, r_try, rnorm_try
        f, f_try = f_try, f
        k, k_try = k_try, k
        iterations += 1
    if iterations > 0 and rnorm > 0.0:
        # One more (quadratically convergent) correction once |R| <= tol: the iterate otherwise
        # stops anywhere below tol, which leaves a force error ~ K_patch * tol (1e-6 relative in
        # quasi-static runs); polished, runs are reproducible to round-off whatever the path.
        zeta_try = zeta + _newton_direction(g0, k, r)
        r_try = _residual(zeta_try, b, g0, k_tab, f_tab, step, f_try, k_try)
        rnorm_try = float(np.max(np.abs(r_try)))
        if rnorm_try <= rnorm:
            zeta, rnorm, f, k = zeta_try, rnorm_try, f_try, k_try
            iterations += 1
    return zeta, f, k, iterations, rnorm


# --------------------------------------------------------------------------------------------
# Runs
# --------------------------------------------------------------------------------------------
def dynamic_indentation(sample_rate: float, acceleration: float, d_max: float) -> tuple[np.ndarray, np.ndarray]:
    """Time steps t_n = n / fs and indentations d_n = a t_n^2 / 2 until d reaches d_max.

    Returns
    -------
    time : numpy.ndarray
        [s], from 0 to the first step with d >= d_max.
    indentation : numpy.ndarray
        [m].
    """
    fs = _config_float("sample_rate", sample_rate)
    a = _config_float("acceleration", acceleration)
    n_last = math.ceil(fs * math.sqrt(2.0 * d_max / a) * (1.0 - 1e-12))
    time = np.arange(n_last + 1) / fs
    return time, 0.5 * a * time**2


def quasistatic_indentation(settings: SolverSettings) -> np.ndarray:
    """Uniform indentation grid 0, dd, 2 dd, ... up to the first point >= d_max [m]."""
    n_last = math.ceil(settings.d_max / settings.quasistatic_step * (1.0 - 1e-12))
    return np.arange(n_last + 1) * settings.quasistatic_step


def _set_threads(threads: int) -> None:
    if isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or threads < 1:
        raise ValueError(f"threads: expected an integer >= 1, got {threads!r}")
    numba.set_num_threads(min(int(threads), numba.config.NUMBA_NUM_THREADS))


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
) -> ContactResult:
    """Solve the contact along a prescribed indentation history (the common solver).

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
        d_n [m], one per step.
    settings : SolverSettings
        Tolerance and iteration limit.
    time : array_like, optional
        t_n [s], stored in the result.
    threads : int
        numba threads for the history sum.

    Returns
    -------
    ContactResult

    Raises
    ------
    ContactConvergenceError
        Naming the step, d and the residual, if a step does not converge.
    """
    z1 = np.asarray(z1, dtype=float)
    if z1.ndim != 2 or z1.size == 0 or not np.all(np.isfinite(z1)):
        raise ValueError(f"z1: expected a finite 2-D array of element heights [m], got shape {z1.shape}")
    nx, ny = z1.shape
    n_elem = nx * ny
    k_tab, f_tab, step = _check_spring_tables(stiffness, force, zeta_step, n_elem)
    g = check_offset_kernel(kernel, nx, ny)
    d = np.asarray(indentation, dtype=float)
    if d.ndim != 1 or d.size == 0 or not np.all(np.isfinite(d)):
        raise ValueError("indentation: expected a finite 1-D array [m]")
    if not isinstance(settings, SolverSettings):
        raise TypeError(f"settings: expected SolverSettings, got {type(settings).__name__}")
    _set_threads(threads)

    gap0 = z1.ravel() - z1.max()
    if settings.resolved_method(n_elem) == "fft":
        operations = _fft_operations(k_tab, f_tab, step, g, settings, (nx, ny), threads)
    else:
        operations = _dense_operations(k_tab, f_tab, step, g, settings, (nx, ny), d.size)
    return _march(gap0, d, time, (nx, ny), *operations)


def _march(gap0, d, time, shape, history, solve, lag0) -> ContactResult:
    """The time-stepping loop shared by the dense and the FFT paths.

    Parameters
    ----------
    gap0 : numpy.ndarray
        z1 - max z1 per element [m]: relative heights, so that z1 - z2 = gap0 + d has no
        cancellation of absolute heights.
    d, time : numpy.ndarray
        Indentations [m] and times [s] (or None) of the steps.
    shape : tuple of int
        (nx, ny).
    history : callable
        ``history(n, f_hist) -> h`` [m], the displacement from lags 1 ... L-1 of the forces
        f_hist[:n] of the earlier steps.
    solve : callable
        ``solve(n, d_n, b, zeta0) -> (zeta, f, iterations, residual, detail)``: the Newton solve
        of step n (indentation d_n) of zeta - b + G0 F(zeta) = 0 from ``zeta0``; raises
        ContactConvergenceError naming n, d_n and the residual.
    lag0 : callable
        ``lag0(n, f) -> G0 f`` [m]; called once per step with the step's converged forces.
    """
    nx, ny = shape
    n_steps, n_elem = d.size, gap0.size
    f_hist = np.zeros((n_steps, n_elem))
    zeta_hist = np.zeros((n_steps, n_elem))
    w_hist = np.zeros((n_steps, n_elem))
    contact_count = np.zeros(n_steps, dtype=np.int64)
    iterations = np.zeros(n_steps, dtype=np.int64)
    residual = np.zeros(n_steps)

    zeta = gap0.copy()
    b_prev = gap0.copy()
    report_every = max(1, n_steps // 10)
    for n in range(n_steps):
        h = history(n, f_hist)
        b = (gap0 + d[n]) - h
        # warm start: previous solution shifted by the change of the free compression
        zeta, f, it, res, detail = solve(n, d[n], b, zeta + (b - b_prev))
        b_prev = b
        f_hist[n] = f
        zeta_hist[n] = zeta
        w_hist[n] = h + lag0(n, f)
        contact_count[n] = np.count_nonzero(f)
        iterations[n] = it
        residual[n] = res
        if n % report_every == 0 or n == n_steps - 1:
            logger.info(
                "step %d/%d: d = %.4e m, F = %.5e N, %d elements in contact, %s",
                n, n_steps - 1, d[n], f.sum(), contact_count[n], detail,
            )

    shape3 = (n_steps, nx, ny)
    return ContactResult(
        time=None if time is None else np.asarray(time, dtype=float),
        indentation=d.copy(),
        force=f_hist.sum(axis=1),
        element_force=f_hist.reshape(shape3),
        compression=zeta_hist.reshape(shape3),
        displacement=w_hist.reshape(shape3),
        contact_count=contact_count,
        newton_iterations=iterations,
        residual=residual,
    )


def _dense_operations(k_tab, f_tab, step, g, settings: SolverSettings, shape, n_steps):
    """History, step solve and lag-0 product of the dense reference path (O(M^2 L) per step).

    The history sum runs over the offset table and only over the elements that carried force
    (recorded by ``lag0``); the step is a direct Newton solve on the loaded elements.
    """
    nx, ny = shape
    n_elem = nx * ny
    n_lag = g.shape[2]
    g0 = _lag_matrix(g, 0)
    kern_t = np.ascontiguousarray(np.moveaxis(g, 2, 0))
    nz_idx = np.zeros((n_steps, n_elem), dtype=np.int64)
    nz_cnt = np.zeros(n_steps, dtype=np.int64)
    h = np.zeros(n_elem)

    def history(n, f_hist):
        if n_lag > 1 and n > 0:
            _history_sum(kern_t, f_hist, nz_idx, nz_cnt, n, nx, ny, h)
        return h.copy()

    def solve(n, d_n, b, zeta0):
        zeta, f, _, it, res = _solve_step(b, zeta0, g0, k_tab, f_tab, step, settings, n, d_n)
        return zeta, f, it, res, f"{it} Newton iterations"

    def lag0(n, f):
        loaded = np.flatnonzero(f)
        nz_idx[n, : loaded.size] = loaded
        nz_cnt[n] = loaded.size
        return g0[:, loaded] @ f[loaded]

    return history, solve, lag0


def _fft_operations(k_tab, f_tab, step, g, settings: SolverSettings, shape, threads: int):
    """History, step solve and lag-0 product by FFT and matrix-free Newton-Krylov.

    Same equations as the dense path; the M x M lag matrices are never formed, so the memory is
    O(M L) and the cost per step O(M log M L).
    """
    from .convolution import (
        BlockJacobiPreconditioner,
        KrylovConvergenceError,
        OffsetConvolution,
        solve_step_newton_krylov,
    )

    nx, ny = shape
    n_elem = nx * ny
    conv = OffsetConvolution(g, shape, workers=max(1, int(threads)))
    accumulator = conv.history_accumulator()
    precond = BlockJacobiPreconditioner(conv, settings.preconditioner_block)
    f_buf = np.empty(n_elem)
    k_buf = np.empty(n_elem)
    logger.info("FFT/Newton-Krylov path: %d x %d elements, %d lags, padded grid %s", nx, ny, g.shape[2], conv.padded)

    def spring(zeta):
        _spring_eval(np.ascontiguousarray(zeta, dtype=float).ravel(), k_tab, f_tab, step, f_buf, k_buf)
        return f_buf.copy(), k_buf.copy()

    def history(n, f_hist):
        return accumulator.history().ravel()

    def solve(n, d_n, b, zeta0):
        try:
            sol = solve_step_newton_krylov(
                b, zeta0, spring, conv, settings.tolerance, settings.max_iterations, preconditioner=precond
            )
        except KrylovConvergenceError as err:
            raise ContactConvergenceError(
                f"contact step {n} did not converge (d = {d_n:.6e} m): {err}"
            ) from err
        if not sol.residual <= settings.tolerance:
            raise ContactConvergenceError(
                f"contact step {n} did not converge (d = {d_n:.6e} m): "
                f"max|R| = {sol.residual:.3e} m > tolerance {settings.tolerance:.1e} m "
                f"after {sol.newton_iterations} Newton iterations"
            )
        detail = f"{sol.newton_iterations} Newton / {sol.krylov_iterations} Krylov iterations"
        return (
            np.asarray(sol.zeta, dtype=float).ravel(), np.asarray(sol.force, dtype=float).ravel(),
            sol.newton_iterations, sol.residual, detail,
        )

    def lag0(n, f):
        forces = f.reshape(nx, ny)
        accumulator.push(forces)
        return conv.apply_lag(forces, 0).ravel()

    return history, solve, lag0


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

    Returns
    -------
    ContactResult
        From t = 0 to the first step with d >= settings.d_max.
    """
    time, d = dynamic_indentation(sample_rate, acceleration, settings.d_max)
    logger.info("dynamic run: a = %g m/s^2, fs = %g Hz, %d steps", acceleration, sample_rate, d.size)
    return solve_path(z1, stiffness, force, zeta_step, kernel, d, settings, time=time, threads=threads)


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

    Dynamic runs also get the backing force (:func:`backing_force` with the greens file's
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
    if mode not in MODES:
        raise ValueError(f"mode: expected one of {MODES}, got {mode!r}")
    z1 = surface["z1"].transpose("ex", "ey").values
    zeta = springs["zeta"].values
    if zeta.size < 2 or zeta[0] != 0.0 or not np.allclose(np.diff(zeta), zeta[1] - zeta[0], rtol=1e-9, atol=0):
        raise ValueError("springs dataset: zeta must be a uniform grid starting at 0")
    stiffness = springs["stiffness"].transpose("ex", "ey", "zeta").values
    force = springs["force"].transpose("ex", "ey", "zeta").values
    c_surface, c_greens = surface.attrs.get("element_size"), greens.attrs.get("element_size")
    if c_surface is not None and c_greens is not None and not math.isclose(float(c_surface), float(c_greens), rel_tol=1e-9):
        raise ValueError(f"element_size differs: surface {c_surface} m, greens {c_greens} m")
    if mode == "dynamic":
        fs = float(greens.attrs["sample_rate"])
        kernel = greens["g"].transpose("dx", "dy", "lag").values
        result = solve_dynamic(z1, stiffness, force, zeta[1], kernel, fs, acceleration, settings, threads)
        n_fft = int(float(greens.attrs.get("n_fft", 4096)))
        backing = backing_force(result.force, material, fs, max(n_fft, 4096))
    else:
        if acceleration != 0:
            raise ValueError(f"acceleration: quasi-static runs use 0 m/s^2, got {acceleration!r}")
        kernel = greens["g_static"].transpose("dx", "dy").values
        result = solve_quasistatic(z1, stiffness, force, zeta[1], kernel, settings)
        backing = result.force.copy()
    return dataclasses.replace(result, backing_force=backing)


# --------------------------------------------------------------------------------------------
# Force at the rigid backing
# --------------------------------------------------------------------------------------------
def layer_transfer_k0(omega, material) -> np.ndarray:
    """k = 0 transfer of the layer from surface force to backing force, T(omega) [1].

    T = 1 / cos(omega h / c_p), c_p = sqrt(M(omega) / rho), M = E (1 - nu) / ((1 + nu)(1 - 2 nu)):
    the one-dimensional P-wave layer of thickness h on a rigid base, loaded by a uniform surface
    pressure. T(0) = 1 (statically the base carries the surface force), and for small damping
    |T| peaks at the quarter-wave resonance f = c_p / (4 h). Evaluated as
    2 exp(-i theta) / (1 + exp(-2 i theta)) with Im theta <= 0, which cannot overflow.

    Parameters
    ----------
    omega : array_like
        Angular frequency [rad/s], >= 0.
    material : Material
        Provides ``modulus(omega)`` [Pa] (complex, exp(+i omega t)), ``poisson``, ``density``
        [kg/m^3], ``thickness`` [m].

    Returns
    -------
    numpy.ndarray
        Complex T(omega) [1].
    """
    w = np.asarray(omega, dtype=float)
    if np.any(~np.isfinite(w)) or np.any(w < 0):
        raise ValueError("layer_transfer_k0: omega must be finite and >= 0 [rad/s]")
    nu, rho, h = float(material.poisson), float(material.density), float(material.thickness)
    e = np.asarray(material.modulus(w), dtype=complex)
    p_modulus = e * (1 - nu) / ((1 + nu) * (1 - 2 * nu))
    c_p = np.sqrt(p_modulus / rho)
    theta = w * h / c_p
    q = np.exp(-1j * theta)
    t = 2.0 * q / (1.0 + q * q)
    if not np.all(np.isfinite(t)):
        raise ValueError(
            "layer_transfer_k0: T(omega) is infinite (an undamped quarter-wave resonance lies on the "
            "frequency grid); the material needs a loss factor > 0"
        )
    return t


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
        Layer material (see :func:`layer_transfer_k0`).
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
    fs = _config_float("sample_rate", sample_rate)
    if isinstance(n_fft, bool) or not isinstance(n_fft, (int, np.integer)) or n_fft < 4096:
        raise ValueError(f"n_fft: expected an integer >= 4096, got {n_fft!r}")
    freq = np.fft.rfftfreq(int(n_fft), 1.0 / fs)
    spectrum = np.zeros(freq.size, dtype=complex)
    for k in range(-n_alias, n_alias + 1):
        f_k = freq + k * fs
        t_k = layer_transfer_k0(2 * np.pi * np.abs(f_k), material)
        t_k = np.where(f_k < 0, np.conj(t_k), t_k)
        spectrum += t_k * np.sinc(f_k / fs) ** 2
    c = np.fft.irfft(spectrum, int(n_fft))
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
    f = np.asarray(total_force, dtype=float)
    if f.ndim != 1 or not np.all(np.isfinite(f)):
        raise ValueError("total_force: expected a finite 1-D array [N]")
    if isinstance(n_fft, bool) or not isinstance(n_fft, (int, np.integer)) or n_fft < 4096:
        raise ValueError(f"n_fft: expected an integer >= 4096, got {n_fft!r}")
    size = max(int(n_fft), 1 << int(math.ceil(math.log2(max(2 * f.size, 2)))))
    c = backing_kernel(material, sample_rate, size)
    return np.convolve(f, c[: f.size])[: f.size]


# --------------------------------------------------------------------------------------------
# Dataset
# --------------------------------------------------------------------------------------------
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
    backing = result.force if result.backing_force is None else result.backing_force
    n, nx, ny = result.element_force.shape
    coords = {
        "step": ("step", np.arange(n), {"units": "1", "long_name": "step index"}),
        "indentation": ("step", result.indentation, {"units": "m", "long_name": "indentation d"}),
        "ex": ("ex", np.arange(nx), {"units": "1", "long_name": "element index along x"}),
        "ey": ("ey", np.arange(ny), {"units": "1", "long_name": "element index along y"}),
    }
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
        "residual": ("step", result.residual, {"units": "m", "long_name": "final max-norm Newton residual"}),
    }
    return xr.Dataset(
        data_vars,
        coords=coords,
        attrs={"mode": mode, "acceleration": acceleration, "material": material_name, "surface": surface_name},
    )
