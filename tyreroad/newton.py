"""The Newton solve of one contact step, with a pluggable instantaneous layer response (substrate).

At step n the spring compressions zeta solve (SPEC 6)

    R(zeta) = zeta - b + G_0 F(zeta) = 0,          b = z1 - z2[n] - h[n],

with the springs' F(zeta), k(zeta) = dF/dzeta (:class:`tyreroad.springs.SpringTable`) and the
layer's instantaneous (lag-0) compliance G_0. :func:`solve_step` is the one Newton driver of the
package: warm start, J delta = -R, step halving until max|R| decreases (an error if it never
does: a growing residual is never accepted), convergence on max|R| <= tol, then one polishing
correction. What the layer contributes comes from a *substrate* object:

    ``instant(force) -> G_0 F`` [m], shape (M,);
    ``begin_step()``               called once before the Newton iterations of a step;
    ``correction(k, r, polish) -> (delta, krylov_products)``: a solution of
        (I + G_0 diag(k)) delta = -r, exact or to the substrate's own (inexact-Newton) tolerance;
    ``self_compliance`` (optional) g_00 [m/N]: if present, the Newton unknown is scaled at first
        contact (:func:`solve_step`), which stiff springs need with inexact corrections.

Hard contact is the springs' stiff limit (:func:`tyreroad.springs.linear_tables` with k of
1e10 N/m, force error ~ 1 / (k g_00) ~ 3e-6 for 1 mm elements of a 25 MPa tread), not a separate
projection solver: the same Newton driver, histories and outputs serve it.

:class:`DenseSubstrate` holds G_0 as a dense matrix and solves the Jacobian of the loaded elements
directly (the reference, and the path of the paper's 20 x 20 patch); :class:`FFTSubstrate` applies
G_0 by FFT convolution and solves matrix-free by preconditioned conjugate gradients on the
compliance form of the Jacobian (GMRES for tables that are not even; footprint-size patches).

References
----------
Eisenstat, S. C., & Walker, H. F. (1996). Choosing the forcing terms in an inexact Newton method.
SIAM J. Sci. Comput. 17(1), 16-32. doi:10.1137/0917003
Hestenes, M. R., & Stiefel, E. (1952). Methods of conjugate gradients for solving linear systems.
J. Res. Natl. Bur. Stand. 49(6), 409-436. doi:10.6028/jres.049.044
Knoll, D. A., & Keyes, D. E. (2004). Jacobian-free Newton-Krylov methods: a survey of approaches
and applications. J. Comput. Phys. 193(2), 357-397. doi:10.1016/j.jcp.2003.08.010
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numba import njit

from . import checks
from .convolution import (
    BlockJacobiPreconditioner,
    ComplianceBlockPreconditioner,
    OffsetConvolution,
    compliance_cg,
    gmres,
    pivoted_solve,
)
from .convolution import _norm
from .influence import OffsetInfluence, Tangent, contact_set_stiffness
from .springs import SpringTable

logger = logging.getLogger(__name__)

__all__ = [
    "StepConvergenceError",
    "StepResult",
    "Substrate",
    "DenseSubstrate",
    "FFTSubstrate",
    "solve_step",
]

#: Step halvings tried per Newton iteration before the step fails (a growing residual is never accepted).
_MAX_HALVINGS = 30


class StepConvergenceError(RuntimeError):
    """A step whose Newton iteration did not reach the tolerance (the caller adds step and d).

    Attributes
    ----------
    residual : float
        Final max|R| [m].
    iterations : int
        Newton iterations done.
    """

    def __init__(self, message: str, residual: float, iterations: int):
        super().__init__(message)
        self.residual = residual
        self.iterations = iterations


@dataclass(frozen=True)
class StepResult:
    """Converged state of one step.

    Attributes
    ----------
    zeta : numpy.ndarray
        Spring compressions [m], shape (M,).
    force, stiffness : numpy.ndarray
        F(zeta) [N] and k(zeta) [N/m], shape (M,).
    newton_iterations : int
        Newton corrections taken (the polishing one included).
    krylov_iterations : int
        Krylov matrix-vector products of all corrections (0 for a direct solve).
    residual : float
        Final max|R| [m].
    """

    zeta: np.ndarray
    force: np.ndarray
    stiffness: np.ndarray
    newton_iterations: int
    krylov_iterations: int
    residual: float


class Substrate(Protocol):
    """The layer's instantaneous response and the Newton linear solve; see the module docstring."""

    def instant(self, force: np.ndarray) -> np.ndarray:  # pragma: no cover - protocol
        ...

    def begin_step(self) -> None:  # pragma: no cover - protocol
        ...

    def correction(self, stiffness: np.ndarray, residual: np.ndarray, polish: bool) -> tuple[np.ndarray, int]:
        ...  # pragma: no cover - protocol

    def tangent(self, stiffness: np.ndarray) -> Tangent:  # pragma: no cover - protocol
        ...


# --------------------------------------------------------------------------------------------
# The Newton driver
# --------------------------------------------------------------------------------------------
def _residual(zeta, b, springs: SpringTable, substrate, f_out, k_out) -> np.ndarray:
    """R = zeta - b + G0 F(zeta); fills f_out, k_out with F(zeta), k(zeta)."""
    springs.evaluate_into(zeta, f_out, k_out)
    return (zeta - b) + substrate.instant(f_out)


def _stiffness_range(k: np.ndarray) -> str:
    """'spring stiffness k = a ... b N/m over n loaded springs' for error messages."""
    loaded = k[k > 0]
    if loaded.size == 0:
        return "no spring loaded"
    return f"spring stiffness k = {loaded.min():.3e} ... {loaded.max():.3e} N/m over {loaded.size} loaded springs"


def _kink_scale(springs, substrate, n_elem: int):
    """s_e = 1 + G0_ee k_e(0+) of every spring, or None where the substrate does not ask for it."""
    self_compliance = getattr(substrate, "self_compliance", None)
    if self_compliance is None:
        return None
    k0 = np.asarray(springs.contact_stiffness(), dtype=float).ravel()
    return 1.0 + self_compliance * k0


def _to_unknown(zeta, scale):
    """The Newton unknown x: zeta for a gap, s zeta in contact."""
    if scale is None:
        return zeta
    return np.where(zeta > 0.0, scale * zeta, zeta)


def _to_compression(x, scale):
    """zeta(x), the inverse of :func:`_to_unknown`."""
    if scale is None:
        return x
    return np.where(x > 0.0, x / scale, x)


def _unknown_step(delta, x, scale):
    """The step of x for a compression correction delta: dx = s delta in contact, delta elsewhere."""
    if scale is None:
        return delta
    return np.where(x > 0.0, scale * delta, delta)


def _warm_start(zeta0, shift, predictor, springs, scale, f, k):
    """The start (x, zeta) of a step's Newton iteration (see :func:`solve_step`'s ``shift``);
    f, k are work arrays."""
    predicted = None
    if shift is not None and predictor is not None and predictor.direction is not None:
        # the tangent of the start state (quasi-static runs whose solver keeps dzeta/dd)
        springs.evaluate_into(zeta0, f, k)
        predicted = predictor.predict(shift, k)
    if shift is None:
        zeta = zeta0.copy()
        return _to_unknown(zeta, scale), zeta
    if predicted is not None:
        x0 = _to_unknown(zeta0, scale)
        x = x0 + _unknown_step(predicted, x0, scale)
        return x, _to_compression(x, scale)
    if scale is None:
        zeta = zeta0 + shift
        return zeta, zeta
    # the warm start moves the scaled unknown: a spring in contact keeps nearly its force
    # (its compression changes by shift / s), the layer surface follows the indenter
    x = _to_unknown(zeta0, scale) + shift
    return x, _to_compression(x, scale)


def solve_step(b, zeta0, springs: SpringTable, substrate: Substrate, tolerance: float, max_iterations: int,
               shift=None, predictor: Tangent | None = None) -> StepResult:
    """Solve R(zeta) = zeta - b + G_0 F(zeta) = 0 by Newton's method from ``zeta0``.

    Each iteration takes the substrate's correction delta and halves the step until max|R|
    decreases. A step that raises max|R| is never accepted: if 30 halvings (a step of 1e-9 delta)
    find no decrease, the solve stops at once with an error naming the residual and the range of
    the loaded springs' stiffness (the caller adds step and d). Once max|R| <= tolerance, one
    more correction polishes the iterate: otherwise it stops anywhere below the tolerance, a force
    error ~ K_patch * tolerance; polished, runs are reproducible to round-off whatever the path.

    Scaled unknown at first contact. A substrate with a ``self_compliance`` g_00 (the FFT path)
    has Newton iterate on x = zeta for a gap and x = s zeta in contact, s = 1 + g_00 k(0+)
    (``springs.contact_stiffness()``). The correction delta of zeta is the same; it moves x by
    s delta in contact. Crossing zeta = 0 then keeps the diagonal of dR/dx at 1 instead of jumping
    from 1 to 1 + g_00 k: for stiff springs (1e10 N/m: s ~ 3e5) an unscaled step that lets a
    spring touch by e adds g_00 k e to its residual, and near contact no step length along the
    correction decreases max|R| (the line search failed at compressions of ~1e-13 m). Springs that
    stay in contact or out of it take the same steps as without the scaling. The dense path has
    no ``self_compliance`` and iterates on zeta, as before (its exact corrections converge on
    stiff springs too, and its results stay bit-identical).

    Parameters
    ----------
    b : numpy.ndarray
        Free compression z1 - z2[n] - h[n] [m], shape (M,).
    zeta0 : numpy.ndarray
        Start value [m], shape (M,) (warm start from the previous step).
    springs : SpringTable
        The M springs (validated, :meth:`SpringTable.checked`).
    substrate : Substrate
        G_0 and the linear solve.
    tolerance : float
        Convergence criterion on max|R| [m].
    max_iterations : int
        Newton iterations allowed.
    shift : numpy.ndarray, optional
        Warm start from ``zeta0`` moved by the change of b since that solution [m], shape (M,):
        zeta0 + shift, or with a scaled unknown x(zeta0) + shift; where ``predictor`` predicts
        the step (``predictor.predict(shift, k(zeta0))`` returns a compression step), zeta0 moved
        by that prediction instead. None: start at ``zeta0``.
    predictor : tyreroad.influence.Tangent, optional
        The tangent of the state ``zeta0`` (the previous quasi-static state, as the march passes
        it on): its dzeta/dd predicts a uniform shift exactly while the contact set holds.

    Returns
    -------
    StepResult

    Raises
    ------
    StepConvergenceError
        If max|R| > tolerance after ``max_iterations`` iterations, or if no step length along a
        Newton correction decreases max|R|.
    """
    n_elem = b.size
    f, k = np.empty(n_elem), np.empty(n_elem)
    f_try, k_try = np.empty(n_elem), np.empty(n_elem)
    scale = _kink_scale(springs, substrate, n_elem)
    x, zeta = _warm_start(zeta0, shift, predictor, springs, scale, f, k)
    r = _residual(zeta, b, springs, substrate, f, k)
    rnorm = float(np.max(np.abs(r)))
    iterations = krylov = 0
    substrate.begin_step()
    while rnorm > tolerance:
        if iterations >= max_iterations:
            raise StepConvergenceError(
                f"Newton did not converge in {max_iterations} iterations, residual max|R| = {rnorm:.3e} m "
                f"> tolerance {tolerance:.1e} m ({krylov} Krylov products; {_stiffness_range(k)})",
                rnorm,
                iterations,
            )
        delta, products = substrate.correction(k, r, polish=False)
        krylov += products
        dx = _unknown_step(delta, x, scale)
        lam = 1.0
        for _ in range(_MAX_HALVINGS + 1):
            x_try = x + lam * dx
            zeta_try = _to_compression(x_try, scale)
            r_try = _residual(zeta_try, b, springs, substrate, f_try, k_try)
            rnorm_try = float(np.max(np.abs(r_try)))
            if rnorm_try < rnorm:
                break
            lam *= 0.5
        else:
            # no step length along delta decreases max|R|: a growing residual is never accepted
            raise StepConvergenceError(
                f"line search: no decrease of the residual max|R| = {rnorm:.3e} m (tolerance {tolerance:.1e} m) "
                f"along Newton correction {iterations + 1} in {_MAX_HALVINGS} halvings "
                f"({krylov} Krylov products; {_stiffness_range(k)})",
                rnorm,
                iterations,
            )
        x, zeta, r, rnorm = x_try, zeta_try, r_try, rnorm_try
        f, f_try = f_try, f
        k, k_try = k_try, k
        iterations += 1
    if iterations > 0 and rnorm > 0.0:
        delta, products = substrate.correction(k, r, polish=True)
        krylov += products
        zeta_try = _to_compression(x + _unknown_step(delta, x, scale), scale)
        r_try = _residual(zeta_try, b, springs, substrate, f_try, k_try)
        rnorm_try = float(np.max(np.abs(r_try)))
        if rnorm_try <= rnorm:
            zeta, rnorm, f, k = zeta_try, rnorm_try, f_try, k_try
            iterations += 1
    return StepResult(zeta, f, k, iterations, krylov, rnorm)


# --------------------------------------------------------------------------------------------
# Dense substrate: G_0 as a matrix, direct solve on the loaded elements
# --------------------------------------------------------------------------------------------
@njit(cache=True)
def _jacobian_block_solve(g0, active, ka, rhs):  # pragma: no cover - numba
    """Solve (I + G0[A, A] diag(k_A)) x = rhs (:func:`tyreroad.convolution.pivoted_solve`).

    Returns (x, ok); ok is False for an exactly singular pivot.
    """
    n = active.size
    a = np.empty((n, n))
    for i in range(n):
        gi = active[i]
        for j in range(n):
            a[i, j] = g0[gi, active[j]] * ka[j]
        a[i, i] += 1.0
    x = np.empty((n, 1))
    x[:, 0] = rhs
    ok = pivoted_solve(a, x)
    return x[:, 0], ok


class DenseSubstrate:
    """G_0 as a dense M x M matrix; Newton corrections by a direct solve of the loaded block.

    Columns of the Jacobian J = I + G_0 diag(k) for elements with k = 0 are unit vectors, so only
    the block of loaded elements A is factorised: (I + G_AA K_A) delta_A = -R_A, then
    delta_I = -R_I - G_IA K_A delta_A. Cost O(M_A^3) per correction.

    Parameters
    ----------
    influence : OffsetInfluence or array_like
        G_0: the operator, or its table g[dx, dy, 0] [m/N] with offsets -(nx-1) ... nx-1 along
        each axis (the table's shape gives the patch).
    """

    def __init__(self, influence):
        if not isinstance(influence, OffsetInfluence):
            g = checks.finite_array("kernel_lag0", influence, ndim=2)
            influence = OffsetInfluence(g, ((g.shape[0] + 1) // 2, (g.shape[1] + 1) // 2))
        self.influence = influence
        self.g0 = influence.matrix()

    def instant(self, force: np.ndarray) -> np.ndarray:
        """G_0 F [m] over the loaded elements only."""
        active = np.flatnonzero(force)
        return self.g0[:, active] @ force[active]

    def begin_step(self) -> None:
        """Nothing to reset: every correction is exact."""

    def correction(self, stiffness: np.ndarray, residual: np.ndarray, polish: bool) -> tuple[np.ndarray, int]:
        """Exact solution of (I + G_0 diag(k)) delta = -r; no Krylov products."""
        active = np.flatnonzero(stiffness)
        if active.size == 0:
            return -residual, 0
        ka = stiffness[active]
        delta_a, ok = _jacobian_block_solve(self.g0, active, ka, -residual[active])
        if not ok:
            raise StepConvergenceError("Newton Jacobian I + G0 diag(k) is singular", float("nan"), 0)
        delta = -residual - self.g0[:, active] @ (ka * delta_a)
        delta[active] = delta_a
        return delta, 0

    def tangent(self, stiffness: np.ndarray) -> Tangent:
        """dF/dd of a solved quasi-static state by a dense solve over its contact set (no predictor)."""
        k = np.asarray(stiffness, dtype=float).ravel()
        return Tangent(float(contact_set_stiffness(self.g0, k)), k.copy())


# --------------------------------------------------------------------------------------------
# FFT substrate: matrix-free Newton-Krylov
# --------------------------------------------------------------------------------------------
class FFTSubstrate:
    """G_0 applied by FFT convolution; corrections by preconditioned conjugate gradients (matrix-free).

    The Newton correction solves J delta = -R, J = I + G_0 diag(k). Columns of elements without
    spring stiffness (k = 0: gaps) are unit vectors, so only the loaded set C is coupled: with the
    force increment u = k delta on C,

        (G_0|C + diag(1/k_C)) u = -R_C,        delta_C = u / k_C,   delta_I = -R_I - (G_0 u)_I.

    For an even lag-0 table (the layer kernel is, SPEC 5; :attr:`OffsetConvolution.lag0_even`)
    G_0 is symmetric positive definite, and so is this compliance-form matrix: it is solved by
    preconditioned conjugate gradients (one FFT product per iteration, no orthogonalisation, no
    basis to store). Its residual *is* the linear residual J delta + R on C, and is zero on the
    other elements (delta_I is exact: G_0 u is accumulated from the products, no extra FFT). Any
    other table, negative stiffnesses, or a CG breakdown use right-preconditioned GMRES on J.
    The target is

        ||J delta + R||_2 <= max(min(eta ||R||_2, theta max|R|), tolerance / 4):

    eta follows Eisenstat-Walker choice 2 (gamma = 0.9, exponent 2, safeguarded) capped at
    ``eta_max`` (config ``solver.krylov_forcing``, default 1e-6); theta max|R| (theta = 0.5) bounds
    the linear residual's max-norm by half the Newton residual's, so the linear model promises a
    max-norm decrease whatever the number of elements; the absolute floor tolerance / 4 lets the
    Newton residual reach the tolerance without over-solving earlier iterations. The polishing
    correction is solved to 1e-3 of ||R||_2.

    Preconditioner: block Jacobi on b x b tiles. CG uses the exact inverse of the compliance-form
    block over each tile's loaded elements, (G_tile + diag(1/k))^-1 = k (I + G_tile k)^-1
    (:class:`tyreroad.convolution.ComplianceBlockPreconditioner`, by Cholesky: symmetric positive
    definite), factorised again whenever k differs from the k it was built for (for linear
    springs: only when the contact set changes). GMRES uses the tile inverses of J
    (:class:`tyreroad.convolution.BlockJacobiPreconditioner`), refactorised at the first
    iteration of a step, after a solve of more than ``refresh_after`` products, and before
    polishing. The tile edge hardly matters for the stiff case (300 x 400, hard contact, five
    indentations: 290 / 261 / 248 / 243 CG products for b = 2 / 3 / 4 / 5); the iteration count is
    set by the layer's own conditioning, not by the local coupling.

    Quasi-static tangent and predictor. :meth:`tangent` solves the same system with the
    right-hand side 1 (dR/dd = -1 for a flat tread surface): v = J^-1 1 = dzeta/dd and
    K = 1^T k v = 1^T [G_0|C + diag(1/k)]^-1 1. The returned :class:`tyreroad.influence.Tangent`
    carries v, and its ``predict`` gives (d_new - d_old) v as the first step of the next
    indentation when the loading moves every free compression by the same amount: the exact
    linear prediction for an unchanged contact set (Newton then corrects the contact-set changes
    only). The march hands that tangent to the next step (:func:`solve_step`'s ``predictor``); the
    substrate keeps no state of it.

    Why the forcing is tight: with stiff springs (hard contact, k g_00 >> 1) the compressions of
    loaded springs are tiny (F / k) while the residual is not, and a spring on the verge of contact
    turns a compression error e into a residual jump ~ g_00 k e. A loose forcing (the former
    eta_max = 0.1) left errors that no step length could undo: 1e8 N/m springs failed at 20 x 20,
    5e6 N/m at 150 x 200. With eta <= 1e-6 and the Newton unknown scaled at first contact
    (:attr:`self_compliance`, :func:`solve_step`) springs of 1e6 ... 1e10 N/m converge in 4-6
    Newton iterations (~50-60 Krylov products per step at 150 x 200 and 300 x 400); looser caps
    cost more, not less (1e-2: ~2000 GMRES products per step, stalling on the late corrections).

    Parameters
    ----------
    conv : OffsetConvolution
        Kernel; its lag 0 is G_0.
    tolerance : float
        The Newton tolerance on max|R| [m] (sets the linear floor).
    block : int
        Tile edge [elements] of the block-Jacobi preconditioner (1 = Jacobi).
    eta_max : float
        Largest inexact-Newton forcing term (relative Krylov tolerance), 0 < eta_max < 1.
    max_norm_fraction : float
        theta above, 0 < theta < 1.
    krylov : {"auto", "gmres"}
        ``auto``: conjugate gradients where the lag-0 table is even, GMRES otherwise;
        ``gmres``: always GMRES.

    Attributes
    ----------
    self_compliance : float
        g_00 = G_0[e, e] [m/N]; :func:`solve_step` scales its unknown at first contact with it.
    krylov_restart, krylov_max : int
        GMRES restart length and limit on matrix-vector products per correction (both methods).
    refresh_after : int
        See above (0: refactorise at every iteration).
    influence : tyreroad.influence.OffsetInfluence
        G_0 as an operator (lag 0 of ``conv``).
    tangent_products : int
        Krylov products of all :meth:`tangent` calls.
    """

    #: Relative residual ||1 - J v||_2 / ||1_C||_2 of the tangent solve; K's error is of the order of
    #: its square (CG from zero minimises the energy norm, K = 1^T u is quadratic in the error).
    TANGENT_TOLERANCE = 1e-10

    def __init__(
        self,
        conv: OffsetConvolution,
        tolerance: float,
        block: int = 4,
        eta_max: float = 1e-6,
        krylov_restart: int = 60,
        krylov_max: int = 600,
        refresh_after: int = 8,
        max_norm_fraction: float = 0.5,
        krylov: str = "auto",
    ):
        if not isinstance(conv, OffsetConvolution):
            raise TypeError(f"conv: expected OffsetConvolution, got {type(conv).__name__}")
        self.conv = conv
        self.influence = OffsetInfluence.from_convolution(conv)
        self.tolerance = checks.real("tolerance", tolerance, positive=True)
        if not 0.0 < eta_max < 1.0:
            raise ValueError(f"eta_max: expected 0 < eta_max < 1, got {eta_max!r}")
        self.eta_max = float(eta_max)
        if not 0.0 < max_norm_fraction < 1.0:
            raise ValueError(f"max_norm_fraction: expected 0 < theta < 1, got {max_norm_fraction!r}")
        self.max_norm_fraction = float(max_norm_fraction)
        if krylov not in ("auto", "gmres"):
            raise ValueError(f"krylov: expected 'auto' or 'gmres', got {krylov!r}")
        self.use_cg = krylov == "auto" and conv.lag0_even
        self.krylov_restart = checks.integer("krylov_restart", krylov_restart)
        self.krylov_max = checks.integer("krylov_max", krylov_max)
        self.refresh_after = checks.integer("refresh_after", refresh_after, minimum=0)
        self.preconditioner = BlockJacobiPreconditioner(conv, block)
        self.compliance_preconditioner = ComplianceBlockPreconditioner(conv, block) if self.use_cg else None
        nx, ny = conv.shape
        self.self_compliance = float(conv.lag0[nx - 1, ny - 1])
        self._pre_k = None  # the k the preconditioner was factorised for (CG path)
        self._instant_cache = []  # [(F, G0 F)] of the last two distinct products
        self._fallback_logged = False
        self.tangent_products = 0
        self.begin_step()

    def instant(self, force: np.ndarray) -> np.ndarray:
        """G_0 F [m], shape (M,), by one FFT convolution (the last two results are reused)."""
        f = np.asarray(force, dtype=float).ravel()
        for f_old, w_old in self._instant_cache:
            if np.array_equal(f, f_old):
                return w_old.copy()
        w = self.conv.apply_lag(f, 0).ravel()
        self._instant_cache = [(f.copy(), w.copy())] + self._instant_cache[:1]
        return w

    def begin_step(self) -> None:
        """Reset the forcing term and ask for a fresh (GMRES) preconditioner."""
        self._eta = self.eta_max
        self._r2_prev = None
        self._gmres_products = None  # products of this step's last GMRES solve (None: rebuild its tiles)

    def _matvec(self, stiffness: np.ndarray):
        def matvec(v):
            return v + self.conv.apply_lag(stiffness * v, 0).ravel()

        return matvec

    def _psolve(self, v):
        return self.preconditioner.solve(v).ravel()

    def _refresh_cg(self, k: np.ndarray) -> bool:
        """Factorise the compliance-form tiles for k unless they already are; False if not positive definite."""
        if self._pre_k is None or not np.array_equal(k, self._pre_k):
            try:
                self.compliance_preconditioner.update(k.reshape(self.conv.shape))
            except np.linalg.LinAlgError:
                self._pre_k = None
                return False
            self._pre_k = k.copy()
        return True

    def _cg(self, k: np.ndarray, rhs: np.ndarray, atol: float):
        """:func:`tyreroad.convolution.compliance_cg` with G_0 and the tile preconditioner (None: not SPD)."""
        if not self._refresh_cg(k):
            return None

        def precondition(r, out):
            self.compliance_preconditioner.solve(r, out=out)

        return compliance_cg(lambda v: self.conv.apply_lag(v, 0).ravel(), precondition, k, rhs, atol,
                             self.krylov_max)

    def correction(self, stiffness: np.ndarray, residual: np.ndarray, polish: bool) -> tuple[np.ndarray, int]:
        """Inexact solution of (I + G_0 diag(k)) delta = -r (conjugate gradients or GMRES)."""
        r2 = _norm(residual)
        if polish:
            target = 1e-3 * r2
        else:
            if self._r2_prev is not None:
                # Eisenstat-Walker choice 2 with safeguard, from the decrease of ||R||_2
                eta_new = 0.9 * (r2 / self._r2_prev) ** 2
                if 0.9 * self._eta**2 > 0.1:
                    eta_new = max(eta_new, 0.9 * self._eta**2)
                self._eta = min(self.eta_max, eta_new)
            # ||J d + R||_2 <= theta max|R| bounds the linear residual's max-norm by theta max|R|:
            # the linear model then promises a max-norm decrease whatever the number of elements
            rinf = float(np.max(np.abs(residual)))
            target = max(min(self._eta * r2, self.max_norm_fraction * rinf), 0.25 * self.tolerance)
        solved = None
        if self.use_cg:
            if float(np.min(stiffness)) >= 0.0:
                solved = self._cg(stiffness, -residual, target)
            if solved is None and not self._fallback_logged:
                self._fallback_logged = True
                logger.warning("FFT substrate: negative spring stiffness or CG breakdown (G_0|C + diag(1/k) not "
                               "positive definite); GMRES takes such corrections (logged once)")
        if solved is not None:
            delta, _, products, linear = solved
            # the GMRES tiles (if any) belong to an older stiffness: rebuild them before any fallback
            self._gmres_products = None
        else:
            if polish or self._gmres_products is None or self._gmres_products > self.refresh_after:
                self.preconditioner.update(stiffness.reshape(self.conv.shape))
            delta, products, linear = gmres(
                self._matvec(stiffness), self._psolve, -residual, target, self.krylov_restart, self.krylov_max
            )
            if not polish:
                self._gmres_products = products
        if linear > target:
            logger.debug("Krylov solve stopped at ||J d + R|| = %.3e > target %.3e after %d products",
                         linear, target, products)
        if not polish:
            self._r2_prev = r2
        return delta, products

    def tangent(self, stiffness) -> Tangent:
        """K = dF/dd = 1^T [G_0|C + diag(1/k)]^-1 1 [N/m] of a solved quasi-static state, with dzeta/dd.

        An even lag-0 table with k >= 0 is solved by the correction's preconditioned CG, which
        also gives v = dzeta/dd (the predictor); any other table by GMRES on J v = 1 (the
        correction's fallback solver), without a predictor.

        Parameters
        ----------
        stiffness : array_like
            Tangent spring stiffnesses k_e >= 0 of the state [N/m], shape (M,) or (nx, ny).

        Returns
        -------
        tyreroad.influence.Tangent

        Raises
        ------
        RuntimeError
            If the solve does not reach :attr:`TANGENT_TOLERANCE` (or G_0 is not symmetric
            positive definite on the contact set).
        """
        k = np.asarray(stiffness, dtype=float).ravel()
        n_c = int(np.count_nonzero(k > 0.0))
        atol = self.TANGENT_TOLERANCE * math.sqrt(max(n_c, 1))
        if not self.use_cg or float(np.min(k)) < 0.0:
            # J v = 1 on the loaded set (unit columns elsewhere: v = 1 there, weighted by k = 0)
            self.preconditioner.update(k.reshape(self.conv.shape))
            self._gmres_products = None
            v, products, linear = gmres(self._matvec(k), self._psolve, np.ones(k.size), atol, self.krylov_restart,
                                        self.krylov_max)
            if linear > atol:
                raise RuntimeError(f"tangent stiffness: GMRES stopped at relative residual "
                                   f"{linear / math.sqrt(k.size):.2e} > {self.TANGENT_TOLERANCE:.0e}")
            self.tangent_products += products
            return Tangent(float(np.sum(k * v)), k.copy())
        solved = self._cg(k, np.ones(k.size), atol)
        if solved is None or solved[3] > atol:
            reached = float("nan") if solved is None else solved[3] / math.sqrt(n_c)
            raise RuntimeError(
                f"tangent stiffness: CG stopped at relative residual {reached:.2e} > {self.TANGENT_TOLERANCE:.0e} "
                f"over {n_c} loaded elements"
            )
        v, u, products, _ = solved
        self.tangent_products += products
        return Tangent(float(np.sum(u)), k.copy(), v)
