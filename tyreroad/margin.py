r"""The stability margin of a march kernel over the whole unit circle, as the greens stage stores it (issue 23).

The march is stable for a spring set S = diag(k_e) >= 0 if I + S^(1/2) G_d(z) S^(1/2) is nonsingular on
|z| >= 1 (G_d the kernel's own transfer function over the patch, kept lags + memory). With

    p(theta) = max_{|phi| <= pi/2} lambda_min Herm(e^{i phi} G_d(e^{i theta}))

p > 0 at theta rules out a root there for every S >= 0 (:mod:`tyreroad.cq`); where it does not, the
smallest spring that can put a root on the circle at theta is k_safe(theta) (a lower bound, exact at
theta = pi for uniform springs). :func:`patch_margin` evaluates this densely and cheaply:

1. the circulant bound of :func:`tyreroad.stability.circulant_margin` (every theta of the grid, one
   DFT per lag): where it is above the rounding level (MARGIN_TOLERANCE of the circulant's largest
   |eigenvalue|), p > 0 is proven for every contact set of the patch;
2. on the rest of the grid, p > 0 is certified on the patch's own matrix by a Cholesky factorisation of
   Herm(e^{i phi} G_d) - tol I at a phase tracked along theta (and phi = 0, +-pi/2) — a few times cheaper
   than an eigen-solve;
3. where no phase certifies, k_safe >= K is certified on a ladder of springs K (factor 2, Cholesky of
   Re G_d + I / K), and p and k_safe are computed in full (eigen-solves, phase optimised) only where the
   ladder cannot rule out a value below the smallest k_safe found so far (branch and bound): the minimum,
   k_crit, is exact; elsewhere ``k_safe`` holds the certified lower bound.

Every factorisation and eigen-solve runs on the exact diagonal blocks of the patch matrix under the patch's
reflections (and the x <-> y swap of a square patch, :mod:`tyreroad.symmetry`): the same spectrum at a
sixteenth of the cost or less. Where the correction's design already solved this kernel's lambda_min on a
phase grid (``support``, the same patch), steps 2-3 start from those eigenvalues instead of Cholesky ladders.

The result ``critical_stiffness`` = min over theta of k_safe: no spring set with every k_e below it puts
a root of the march on |z| = 1 (inf: every spring set, hard contact included).

A patch whose reflection blocks exceed :data:`tyreroad.solver.FFT_THRESHOLD` elements (a rolling strip,
150 x 20: blocks of 750) is too large for the patch matrices at every theta. A narrow one (short side up to
:data:`STRIP_MAX_WIDTH`) gets the strip bound instead (method ``strip``, :func:`strip_symbol_blocks`): the
patch matrix wrapped circularly along its long axis only, exact across it. It is a certified lower bound of
the patch's own margin at every grid theta, and tight on a long strip (150 x 20 tread: k_crit 6.8e4 N/m
against 6.93e4 from the patch matrices on 257 theta, where the two-axis circulant bound gives 1.6e4). Wider
patches keep the circulant bound alone (conservative: its truncated-offset symbol can dip below zero where
the patch matrix does not), and say so.
"""

from __future__ import annotations

import logging
import math
import time

import numpy as np
import scipy.linalg

from .influence import offset_matrix_index
from .kernel import LayerKernel
from .solver import FFT_THRESHOLD
from .stability import MARGIN_TOLERANCE, circulant_margin, mask_bands
from .symmetry import fits, patch_blocks, strip_lambda_min, strip_symbol_blocks

logger = logging.getLogger(__name__)

__all__ = ["PatchMargin", "patch_margin", "uses_dense_margin", "uses_strip_bound", "STRIP_MAX_WIDTH"]


class PatchMargin:
    """The stability margin a greens file stores (see the module docstring).

    Attributes
    ----------
    theta : numpy.ndarray
        theta = 2 pi f / fs on [0, pi] [rad].
    p_bound : numpy.ndarray
        The circulant lower bound of p(theta) [m/N].
    k_safe : numpy.ndarray
        The spring at which a root of the march can reach |z| = 1 at theta [N/m] (inf where p > 0 is proven).
    method : str
        ``patch`` (the patch's own matrices where the bound fails) or ``circulant`` (bound only).
    certified : int
        Grid points where p > 0 was proven on the patch's matrix (step 2).
    full : int
        Grid points evaluated in full (step 3).
    seconds : float
        Wall time [s].
    """

    def __init__(self, theta, p_bound, k_safe, method, certified=0, full=0, seconds=0.0, name="kernel"):
        self.theta = np.asarray(theta, dtype=float)
        self.p_bound = np.asarray(p_bound, dtype=float)
        self.k_safe = np.asarray(k_safe, dtype=float)
        self.method = str(method)
        self.certified = int(certified)
        self.full = int(full)
        self.seconds = float(seconds)
        self.name = name

    @property
    def k_crit(self) -> float:
        """min over theta of k_safe [N/m] (inf: stable for every spring set S >= 0)."""
        return float(self.k_safe.min())

    @property
    def theta_k(self) -> float:
        """Where k_crit is reached [rad] (NaN when inf)."""
        return float(self.theta[int(np.argmin(self.k_safe))]) if math.isfinite(self.k_crit) else math.nan

    def failing_bands(self) -> list[tuple[float, float]]:
        """theta intervals [rad] where k_safe is finite."""
        return mask_bands(self.theta, np.isfinite(self.k_safe))

    def describe(self) -> str:
        how = {"patch": "patch matrices", "strip": "strip bound: exact across, wrapped along (conservative)"}.get(
            self.method, "circulant bound only (conservative)")
        if math.isfinite(self.k_crit):
            bands = ", ".join(f"{a / np.pi:.4f}-{b / np.pi:.4f} pi" for a, b in self.failing_bands()[:4])
            return (f"{self.name}: stable for springs below k_crit = {self.k_crit:.4g} N/m (theta = "
                    f"{self.theta_k / np.pi:.4f} pi; fails on {bands}; {how}, {self.theta.size} theta, "
                    f"{self.seconds:.1f} s)")
        return (f"{self.name}: stable for every spring set, hard contact included ({how}, {self.theta.size} "
                f"theta, {self.seconds:.1f} s)")

    def variables(self) -> dict:
        """Greens-dataset variables (docs/data_contracts.md "Greens dataset")."""
        return {
            "margin_p_bound": ("theta", self.p_bound, {
                "units": "m/N", "long_name": "circulant lower bound of the march's stability margin "
                "p(theta) = max_phi lambda_min Herm(exp(i phi) G_d(exp(i theta))) (> 0: no spring set puts a "
                "root on |z| = 1 there)"}),
            "margin_spring": ("theta", self.k_safe, {
                "units": "N/m", "long_name": "smallest element spring that can put a root of the time march on "
                f"|z| = 1 at theta (inf: p > 0 proven; {self.method})"}),
            "critical_stiffness": ((), self.k_crit, {
                "units": "N/m", "long_name": "min over theta of margin_spring: springs below it are stable on "
                "every contact set of the patch (inf: every spring, hard contact included)",
                "method": self.method}),
            "critical_theta": ((), self.theta_k, {
                "units": "rad", "long_name": "theta = 2 pi f / fs where critical_stiffness is reached (NaN: none)"}),
        }

    @classmethod
    def from_dataset(cls, ds) -> "PatchMargin | None":
        """The margin stored in a greens dataset, or None (a file without one)."""
        if "margin_spring" not in ds:
            return None
        return cls(ds["theta"].values, ds["margin_p_bound"].values, ds["margin_spring"].values,
                   ds["critical_stiffness"].attrs.get("method", "patch"), name=str(ds.attrs.get("material", "kernel")))


def _entry_scale(table: np.ndarray):
    """The largest |entry| of Re / Im of a cropped transfer table [m/N] (a float), or of each table of a stack
    (..., X, Y) (an array): every offset of it is an entry of the patch matrix, so MARGIN_TOLERANCE times this
    is the rounding level of its eigenvalues."""
    t = np.asarray(table)
    out = np.maximum(np.abs(t.real).max(axis=(-2, -1)), np.abs(t.imag).max(axis=(-2, -1)))
    return float(out) if out.ndim == 0 else out


def _chol_ok(matrix: np.ndarray) -> bool:
    _, info = scipy.linalg.lapack.dpotrf(matrix, lower=1, clean=0, overwrite_a=1)
    return info == 0


def _herm1(b: np.ndarray, c: np.ndarray, phi: float) -> np.ndarray:
    """Herm(e^{i phi} G_d) = cos phi Re G_d - sin phi Im G_d of one block (a new array)."""
    if phi == 0.0:
        return b.copy()
    cp, sp = math.cos(phi), math.sin(phi)
    if abs(cp) < 1e-15:
        return c * -sp
    m = b * cp
    m -= sp * c
    return m


def _herm(b, c, phi: float) -> list[np.ndarray]:
    """:func:`_herm1` of every block."""
    return [_herm1(bb, cc, phi) for bb, cc in zip(b, c)]


def _shifted_pd(b, c, phi: float, shift: float) -> bool:
    """Herm(e^{i phi} G_d) + shift I positive definite (every block), by Cholesky."""
    for bb, cc in zip(b, c):
        m = _herm1(bb, cc, phi)
        m.flat[:: m.shape[0] + 1] += shift
        if not _chol_ok(m):
            return False
    return True


def _lambda_min(matrix: np.ndarray) -> float:
    return float(scipy.linalg.eigh(matrix, eigvals_only=True, subset_by_index=[0, 0], check_finite=False)[0])


def _full(b, c, scale: float, n_phi: int = 11, with_phi: bool = False):
    """(p, k_safe) at one theta from the blocks of Re G_d = b, Im G_d = c (lists; one block: the patch
    matrix itself): a phase grid, then bounded Brent around the best."""
    return _optimise_phase(lambda phi: min(_lambda_min(m) for m in _herm(b, c, phi)), scale, n_phi, with_phi)


def _optimise_phase(f, scale: float, n_phi: int = 11, with_phi: bool = False):
    """(p, k_safe[, phi of k_safe]) at one theta from f(phi) = lambda_min Herm(e^{i phi} G_d) [m/N]: a phase grid
    of n_phi points on [-pi/2, pi/2], then bounded Brent around the best."""
    import scipy.optimize

    phis = np.linspace(-np.pi / 2, np.pi / 2, n_phi)
    values = {float(phi): f(phi) for phi in phis}
    best = max(values, key=values.get)
    step = phis[1] - phis[0]
    res = scipy.optimize.minimize_scalar(lambda phi: -f(phi), bounds=(max(best - step, -np.pi / 2),
                                         min(best + step, np.pi / 2)), method="bounded",
                                         options={"xatol": 1e-5 * step})
    values[float(res.x)] = -float(res.fun)
    p = max(values.values())
    if p > MARGIN_TOLERANCE * scale:
        return (p, math.inf, best) if with_phi else (p, math.inf)
    ks = {phi: math.cos(phi) / -v for phi, v in values.items() if v < 0}
    phi_k = max(ks, key=ks.get) if ks else 0.0
    if ks and math.cos(phi_k) > 0:
        # k_safe's own best phase: cos phi / -lambda_min peaks elsewhere than lambda_min does (the Brent above
        # refines p), so it is refined around its own best grid point; any phase's value is a certified bound
        def spring(phi):
            v = f(phi)
            return -math.cos(phi) / -v if v < 0 else -math.inf
        res = scipy.optimize.minimize_scalar(spring, bounds=(max(phi_k - step, -np.pi / 2), min(phi_k + step,
                                             np.pi / 2)), method="bounded", options={"xatol": 1e-5 * step})
        if math.isfinite(res.fun) and -float(res.fun) > ks[phi_k]:
            phi_k = float(res.x)
            ks[phi_k] = -float(res.fun)
    k = ks.get(phi_k, 0.0)
    return (p, k, phi_k) if with_phi else (p, k)


#: Springs [N/m] at which :func:`_ladder` certifies k_safe (ratio 1.15: a bound within 15 % where it is kept).
LADDER = 100.0 * 1.15 ** np.arange(165)


#: Phases [rad] at which the branch and bound's screen tries to certify k_safe > the smallest found, after those of
#: the last full solve and the ladder: a Cholesky per block at each (~0.15 ms on 20 x 20) against ~40 ms for the
#: phase-optimised eigen-solve it saves where a point's best phase is none of the first ones.
SCREEN_PHASES = tuple(float(v) for v in np.linspace(-np.pi / 2, np.pi / 2, 13)[1:-1])


def _ladder(b, c, phi: float, tol: float) -> float:
    """The largest K of :data:`LADDER` with Herm(e^{i phi} G_d) + (cos phi / K - tol) I positive definite (0 if
    none): then no spring set with every k_e <= K puts a root on |z| = 1 here (a lower bound of k_safe)."""
    lo, hi = -1, LADDER.size  # LADDER[lo] certified (or none), LADDER[hi] not (or beyond)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if _shifted_pd(b, c, phi, math.cos(phi) / LADDER[mid] - tol):
            lo = mid
        else:
            hi = mid
    return float(LADDER[lo]) if lo >= 0 else 0.0


#: Widest short side [elements] of a patch whose margin the strip bound evaluates (its blocks are half of it):
#: above, a patch too large for the patch matrices keeps the circulant bound alone.
STRIP_MAX_WIDTH = 64


def uses_dense_margin(shape, max_dense: int = FFT_THRESHOLD) -> bool:
    """True when :func:`patch_margin` can evaluate a patch of this shape on its own matrices: its largest
    reflection block (ceil(nx / 2) ceil(ny / 2) elements, even tables) is within ``max_dense`` (a square patch's
    x <-> y split makes its blocks smaller still, so this never claims more than the margin does)."""
    nx, ny = (int(v) for v in shape)
    return (-(-nx // 2)) * (-(-ny // 2)) <= max_dense


def uses_strip_bound(shape, max_dense: int = FFT_THRESHOLD) -> bool:
    """True when :func:`patch_margin` evaluates a patch of this shape on the strip bound: its largest reflection
    block is above ``max_dense`` elements and its short side at most :data:`STRIP_MAX_WIDTH` (the greens stage
    designs such a patch's correction on the same bound)."""
    nx, ny = (int(v) for v in shape)
    return not uses_dense_margin(shape, max_dense) and min(nx, ny) <= STRIP_MAX_WIDTH


def _strip_margin(kernel: LayerKernel, shape, bound, todo: np.ndarray, chunk: int, t0: float,
                  support=None) -> "PatchMargin":
    """:func:`patch_margin` of a long patch on the strip bound (:func:`strip_symbol_blocks`): the same steps,
    with eigenvalues of the symbol's blocks as the certificates (k_safe >= max_phi cos phi / (tol - lambda_min)
    where no phase proves p > 0), then branch and bound on the phase-optimised value. ``support``: the
    correction's design on the same strip bound (its eigenvalues, spot-checked, replace the first step)."""
    theta = bound.theta
    k_safe = bound.k_bound.copy()
    fs = kernel.sample_rate
    certified = full = reused = 0
    rung, scales = {}, {}
    known = _support_rows(kernel, shape, theta, todo, support, None, strip=True) if support is not None else {}
    phi = math.pi / 2
    for start in range(0, todo.size, chunk):
        idx = todo[start:start + chunk]
        tables = kernel.own_frequency_response(theta[idx] * fs / (2 * np.pi), shape)
        blocks = None
        for j, i in enumerate(idx):
            scale = _entry_scale(tables[j])
            tol = MARGIN_TOLERANCE * scale
            if i in known:
                reused += 1
                lb = _support_bound(known[i], tol)
                if lb == math.inf:
                    k_safe[i] = math.inf
                    certified += 1
                else:
                    rung[i], scales[i] = lb, scale
                continue
            if blocks is None:
                blocks = strip_symbol_blocks(tables, shape)
            mine = [(b[j], c[j]) for b, c in blocks]
            values = {}
            for trial in dict.fromkeys((phi, math.pi / 2, -math.pi / 2, 0.0, math.pi / 4)):
                values[trial] = float(strip_lambda_min(mine, trial))
                if values[trial] > tol:
                    phi = trial
                    break
            if max(values.values()) > tol:
                k_safe[i] = math.inf
                certified += 1
            else:
                rung[i] = _support_bound((np.array(list(values)), np.array(list(values.values()))), tol)
                scales[i] = scale
    best = math.inf
    for i in sorted(rung, key=rung.get):
        if rung[i] >= best:
            k_safe[i] = rung[i]  # a certified lower bound, not smaller than k_crit
            continue
        mine = [(b[0], c[0]) for b, c in strip_symbol_blocks(
            kernel.own_frequency_response(theta[i:i + 1] * fs / (2 * np.pi), shape), shape)]
        _, k_full = _optimise_phase(lambda f: float(strip_lambda_min(mine, f)), scales[i])
        k_safe[i] = max(k_full, rung[i])  # both are lower bounds of the strip's k_safe
        best = min(best, k_safe[i])
        full += 1
    out = PatchMargin(theta, bound.p_bound, k_safe, "strip", certified, full, time.perf_counter() - t0, kernel.name)
    logger.info("stability margin %s: %d theta proven by the circulant bound, %d by the strip bound, %d in full "
                "(strip bound: %d wave numbers along the long axis; %d theta from the design's eigenvalues)",
                out.describe(), theta.size - todo.size, certified, full, max(shape), reused)
    return out


def patch_margin(kernel: LayerKernel, shape, n_theta: int = 1025, chunk: int = 64, symmetry: bool = True,
                 max_dense: int = FFT_THRESHOLD, support=None) -> PatchMargin:
    """The stability margin of a dynamic kernel over an (nx, ny) patch, densely on theta in [0, pi].

    Parameters
    ----------
    kernel : LayerKernel
        A dynamic kernel (kept lags and memory).
    shape : tuple of int
        Patch (nx, ny).
    n_theta : int
        Grid points on [0, pi] (1025: spacing 0.001 pi, so a failing band narrower than that can fall
        between two points; the circulant bound runs on the same grid).
    chunk : int
        theta per transfer-function evaluation.
    symmetry : bool
        Factor and eigen-solve the reflection blocks of the patch matrices (:mod:`tyreroad.symmetry`: the
        same spectrum, 1/16 of the work; on a square patch also split by the x <-> y swap) when the kernel's
        tables are even in dx and dy; False: the patch matrices themselves (the tests' reference).
    max_dense : int
        Largest matrix (a block, or the patch matrix without ``symmetry``) factored densely; a patch whose
        largest one is bigger keeps the circulant bound alone.
    support : (theta, phi, h[, exact[, scale]]), optional
        lambda_min Herm(e^{i phi} G_d) of this kernel on this patch already computed (the correction's design,
        :meth:`tyreroad.construction.Correction.margin_support`: theta (n,), phi (m,), h (n, m) [m/N]; rows
        with ``exact`` (n,) False hold certified lower bounds of it instead; ``scale`` (n,) [m/N]: the largest
        |Re| or |Im| entry of each point's cropped transfer table, so that a point certified from the support
        needs no table of its own). At grid points it covers, p > 0
        is certified where max_phi h > tol and otherwise k_safe >= max_phi cos phi / (tol - h) replaces the
        Cholesky ladder (the same certificate from the eigenvalues, or from their lower bounds);
        it is spot-checked against this kernel's own matrices first and ignored if it does not match (a long
        patch's margin, :func:`uses_strip_bound`: against its strip bound, which the design must have used).

    Returns
    -------
    PatchMargin
    """
    t0 = time.perf_counter()
    nx, ny = shape
    bound = circulant_margin(kernel, shape, n_theta=n_theta)
    theta = bound.theta
    k_safe = bound.k_bound.copy()
    todo = np.flatnonzero(np.isfinite(bound.k_bound))  # not certified by the bound (p at rounding level too)
    fs = kernel.sample_rate
    blocks = None
    if symmetry and todo.size:
        probe = kernel.own_frequency_response(theta[todo[:1]] * fs / (2 * np.pi), shape)
        lag_blocks = patch_blocks(np.moveaxis(kernel.table(shape), -1, 0), shape)
        if lag_blocks is not None and fits(lag_blocks, probe):
            blocks = lag_blocks
    largest = max(blocks.sizes) if blocks is not None else nx * ny
    if todo.size and blocks is not None and uses_strip_bound(shape, max_dense):
        return _strip_margin(kernel, shape, bound, todo, chunk, t0, support)  # blocks: the tables are even
    if largest > max_dense:
        out = PatchMargin(theta, bound.p_bound, k_safe, "circulant", seconds=time.perf_counter() - t0,
                          name=kernel.name)
        logger.info("stability margin %s", out.describe())
        return out
    if blocks is None:
        ix, iy = offset_matrix_index(shape)
    known, known_scale, known_exact = {}, {}, set()
    if support is not None and todo.size:
        known = _support_rows(kernel, shape, theta, todo, support, blocks, scales=known_scale, exact=known_exact)
    certified = full = reused = 0
    rung, pending = {}, {}
    ladder_phi = math.pi / 4
    phi = math.pi / 2  # a lossy layer's compliance is certified by its dissipation, phi = +pi/2
    for start in range(0, todo.size, chunk):
        idx = todo[start:start + chunk]
        # a point the support covers with its scale needs no transfer table unless its bound is not enough
        fresh = np.array([i for i in idx if i not in known_scale], dtype=int)  # its keys are known's, or none
        row = {int(i): j for j, i in enumerate(fresh)}
        if fresh.size:
            tables = kernel.own_frequency_response(theta[fresh] * fs / (2 * np.pi), shape)
            use_blocks = blocks is not None and fits(blocks, tables)
            if use_blocks:
                re_tables, im_tables = np.ascontiguousarray(tables.real), np.ascontiguousarray(tables.imag)
            elif blocks is not None:  # not even after all (a kernel the probe did not show): the patch matrices
                logger.warning("stability margin %s: transfer tables not even in dx, dy; whole patch matrices",
                               kernel.name)
                ix, iy = offset_matrix_index(shape)
        for i in idx:
            j = row.get(int(i))
            scale = known_scale[i] if j is None else _entry_scale(tables[j])
            tol = MARGIN_TOLERANCE * scale
            if i in known:  # lambda_min on a phase grid already known: certified, or a lower bound of k_safe
                reused += 1
                lb = _support_bound(known[i], tol)
                if lb == math.inf:
                    k_safe[i] = math.inf
                    certified += 1
                else:
                    rung[i] = lb
                    pending[i] = (None if j is None else tables[j].copy(), None, scale)
                continue
            if use_blocks:
                b, c = blocks.blocks(re_tables[j]), blocks.blocks(im_tables[j])
            else:
                a = tables[j][ix, iy]
                b, c = [a.real.copy()], [a.imag.copy()]
            ok = False
            for trial in dict.fromkeys((phi, math.pi / 2, -math.pi / 2, 0.0)):
                if _shifted_pd(b, c, trial, -tol):
                    phi, ok = trial, True
                    break
            if ok:
                k_safe[i] = math.inf
                certified += 1
            else:
                # p <= 0 here: certify k_safe >= K on a ladder (Re G_d + I / K > 0 at phi = 0), bisected
                rung[i] = max(_ladder(b, c, trial, tol) for trial in dict.fromkeys((ladder_phi, 0.0)))
                pending[i] = (b, c, scale)

    def matrices(i):
        """A pending point's (b, c, scale); a point reused from the support gets its blocks (and, if its bound
        came with the support's scale, its table) only here, when the branch and bound needs it: most points'
        bounds already clear the smallest k_safe found."""
        item = pending[i]
        if item[1] is not None:
            return item
        table, _, scale = item
        if table is None:
            table = kernel.own_frequency_response(theta[i:i + 1] * fs / (2 * np.pi), shape)[0]
        if blocks is not None and fits(blocks, table):
            return (blocks.blocks(np.ascontiguousarray(table.real)), blocks.blocks(np.ascontiguousarray(table.imag)),
                    scale)
        a = table[offset_matrix_index(shape)]
        return [a.real.copy()], [a.imag.copy()], scale

    # full solves only where the ladder cannot exclude a spring below the smallest one found (branch and bound);
    # before one, a Cholesky at the smallest k_safe found (at the phases of the last full solve and 0) may
    # already certify k_safe >= it there
    best = math.inf
    best_phi = 0.0
    screened = 0
    order = sorted(pending, key=lambda j: rung[j])
    # the first full solve sets the bar the others are screened against: at the smallest rung among the points
    # whose rung comes from eigenvalues (the support's exact rows: the grid phases' bound, close to k_safe), not
    # among all. A support row the design certified by a Cholesky factorisation at its target has a rung near the
    # target wherever k_safe is (tread-eta1.5: rungs 1.20-1.22e5 N/m where k_safe is 2.0-2.8e5): solved first, they
    # set a high bar that the next ones fail too (17 full solves before k_crit = 1.245e5 at theta = pi, 2 after)
    first = [j for j in order if j in known_exact][:1]
    for i in first + [j for j in order if j not in first]:
        if rung[i] >= best:
            k_safe[i] = rung[i]  # a certified lower bound, not smaller than k_crit
            continue
        b, c, scale = matrices(i)
        tol = MARGIN_TOLERANCE * scale
        if math.isfinite(best) and any(_shifted_pd(b, c, trial, math.cos(trial) / best - tol)
                                       for trial in dict.fromkeys((best_phi, ladder_phi, 0.0) + SCREEN_PHASES)):
            # certified: k_safe > best here (a strict bound: the Cholesky holds with tol to spare), not k_crit
            k_safe[i] = np.nextafter(best, math.inf)
            screened += 1
            continue
        _, k_safe[i], ladder_phi = _full(b, c, scale, with_phi=True)
        if k_safe[i] < best:
            best, best_phi = k_safe[i], ladder_phi
        full += 1
    out = PatchMargin(theta, bound.p_bound, k_safe, "patch", certified, full, time.perf_counter() - t0, kernel.name)
    logger.info("stability margin %s: %d theta proven by the circulant bound, %d certified on the patch, %d "
                "certified at k_crit, %d in full (%s; %d theta from the design's eigenvalues)", out.describe(),
                theta.size - todo.size, certified, screened, full,
                f"reflection blocks {blocks.sizes}" if blocks is not None else "whole patch matrices", reused)
    return out


def _support_bound(h_row: tuple, tol: float) -> float:
    """inf where some phase certifies p > 0 (lambda_min > tol), else the largest cos phi / (tol - lambda_min)
    over the phases with cos phi > 0 (0 if none): a certified lower bound of k_safe."""
    phis, values = h_row
    if float(np.max(values)) > tol:
        return math.inf
    cos = np.cos(phis)
    ok = cos > 1e-12
    return float(np.max(cos[ok] / (tol - values[ok]))) if ok.any() else 0.0


def _support_rows(kernel, shape, theta, todo, support, blocks, checks: int = 3, strip: bool = False,
                  scales: dict | None = None, exact: set | None = None) -> dict:
    """{grid index: (phi, lambda_min or a certified lower bound of it)} of the support's rows on the margin's theta
    grid (matched to 1e-12 rad), after checking ``checks`` of its exact rows against eigen-solves of this kernel's
    own matrices (``strip``: of its strip bound's) ({} if one differs by more than 1e-3 MARGIN_TOLERANCE of the matrix scale: the certificates keep
    MARGIN_TOLERANCE in hand). ``scales``: filled with {grid index: the table's entry scale} when the support
    carries one (its fifth item, checked at the same rows to 1e-9), so that those rows need no transfer table;
    ``exact``: filled with the grid indices whose row holds eigenvalues (not lower bounds)."""
    s_theta, s_phi, s_h = (np.asarray(v, dtype=float) for v in support[:3])
    s_exact = np.asarray(support[3], dtype=bool) if len(support) > 3 else np.ones(s_theta.size, dtype=bool)
    s_scale = np.asarray(support[4], dtype=float) if len(support) > 4 and support[4] is not None else None
    pos = np.clip(np.searchsorted(s_theta, theta[todo]), 0, s_theta.size - 1)
    prev = np.clip(pos - 1, 0, s_theta.size - 1)
    pos = np.where(np.abs(s_theta[prev] - theta[todo]) < np.abs(s_theta[pos] - theta[todo]), prev, pos)
    hit = np.abs(s_theta[pos] - theta[todo]) <= 1e-12
    rows = {int(i): int(r) for i, r, h in zip(todo, pos, hit) if h}
    if not rows:
        return {}
    exact_rows = sorted(i for i, r in rows.items() if s_exact[r])  # a lower-bound row cannot be checked for equality
    sample = exact_rows[:: max(1, len(exact_rows) // checks)][:checks]
    tables = kernel.own_frequency_response(theta[sample] * kernel.sample_rate / (2 * np.pi), shape)
    for t, i in zip(tables, sample):
        scale = _entry_scale(t)
        if strip:
            mine = [(b[0], c[0]) for b, c in strip_symbol_blocks(t[None], shape)]
        elif blocks is not None:
            b, c = blocks.blocks(np.ascontiguousarray(t.real)), blocks.blocks(np.ascontiguousarray(t.imag))
        else:
            a = t[offset_matrix_index(shape)]
            b, c = [a.real.copy()], [a.imag.copy()]
        for j in (0, s_phi.size - 1):
            if strip:
                own = float(strip_lambda_min(mine, float(s_phi[j])))
            else:
                own = min(_lambda_min(m) for m in _herm(b, c, float(s_phi[j])))
            if abs(own - s_h[rows[i], j]) > 1e-3 * MARGIN_TOLERANCE * scale:  # well inside the certificates' tol
                logger.warning("stability margin %s: the given support differs from the kernel's own matrices at "
                               "theta = %.4f pi (%.3e against %.3e m/N): not used", kernel.name, theta[i] / np.pi,
                               s_h[rows[i], j], own)
                return {}
        if s_scale is not None and abs(s_scale[rows[i]] - scale) > 1e-9 * scale:
            logger.warning("stability margin %s: the given support's table scale differs from the kernel's at theta "
                           "= %.4f pi (%.6e against %.6e m/N): not used", kernel.name, theta[i] / np.pi,
                           s_scale[rows[i]], scale)
            return {}
    if scales is not None and s_scale is not None:
        scales.update({i: float(s_scale[r]) for i, r in rows.items()})
    if exact is not None:
        exact.update(i for i, r in rows.items() if s_exact[r])
    return {i: (s_phi, s_h[r]) for i, r in rows.items()}
