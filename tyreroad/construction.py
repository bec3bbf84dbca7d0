r"""The default march kernel (issue 23): today's faithful kernel plus a spring-safe correction of the excitation element.

Construction
------------
1. The greens stage's kernel as today (:func:`tyreroad.greens.greens_dataset`; optionally with an
   ``frf_map``): element FRF, inverse FFT, 256 kept lags, wrapped creep removed, causal precursor
   correction, creep tail. For the default tread it follows the element FRF to 0.33 % / 0.003 rad at the
   excitation element, but its transfer function over the patch, G_d(e^{i theta}) = sum_l g_l e^{-i l theta}
   + tail, is indefinite at z = -1 (the sampled compliance is mass-like at fs / 2: lambda_min G_d(-1) =
   -4.2e-5 m/N on 20 x 20, 22 x |g_00(-1)|): the march has a root on |z| = 1 for springs >= 2.37e4 N/m.
2. A causal FIR Delta(z) = sum_{l < n_taps} c_l z^{-l} added to the *excitation element only* (offset
   (0, 0), lags 0 ... n_taps - 1). On every patch it is Delta I, so it shifts lambda_min Herm(e^{i phi} G_d)
   by exactly Re(e^{i phi} Delta) for every phi. The taps solve a linear programme over a theta grid
   (maximise the slack t, capped, with a small sum |c| penalty):

   * fidelity: |Delta(e^{i theta})| <= ``fidelity_budget`` |G_d,00| for f <= ``band`` (inscribed octagon)
     and sum c_l = 0 (the DC gain, hence the static compliance and the creep tail, unchanged);
   * spring safety: h(theta, phi_theta) + cos(phi_theta) / k_target + Re(e^{i phi_theta} Delta) >= t,
     with h(theta, phi) = lambda_min Herm(e^{i phi} G_d(e^{i theta})) of the patch (eigenvalues, on a phi
     grid). At t >= 0 no spring set 0 <= S <= k_target puts a root of the march on |z| = 1 at the grid
     points (the bound of :mod:`tyreroad.cq`: v^H e^{i phi}(I + S^1/2 G_d S^1/2) v has real part
     >= cos phi |v|^2 + lambda_min |S^1/2 v|^2 > 0). phi_theta is re-chosen as the best for the
     corrected kernel and the LP solved again until it no longer changes (phi = 0 at z = -1).

   With k_target = inf the same LP asks p(theta) > 0 (every spring). For today's tread kernel that is
   infeasible (the LP's best is min p = -4.6e-6 m/N; see benchmarks/README): a causal correction that is
   real and large at z = -1 has a positive imaginary part (anti-dissipative) below it, and the fidelity
   band pins it down below 5 kHz. k_target = 1.2e5 N/m (3 x the default springs' 3.96e4) is feasible.
   (Measured alternative: on the FRF/BDF2 blend at 0.3 fs as base, p > 0 is also infeasible, best min p
   -6.5e-7 m/N, and k_target 2e5 needs a smaller correction, max |Delta| / |G_00| 1.6 above 5 kHz instead
   of 18; but that base already misses the FRF by 1.5 % at near offsets (|G| >= 1 % |G_00|), so it is not
   the default.)

Cost: the design needs lambda_min of the M x M patch matrices on its theta x phi grid. They are solved on
the exact reflection (and, square patch, x <-> y) blocks of the patch matrix (:mod:`tyreroad.symmetry`;
20 x 20: blocks 55, 45, 100, 55, 45 instead of 400), and the greens stage checks every theta of the margin's
grid above 5 kHz (``n_dense``: ~1064 theta x 8 phi), so that a target met on the grid is met by the margin,
which then reuses these eigenvalues (:meth:`Correction.margin_support`). Only the LP's own rows need the
eigenvalues themselves (tread: 622 of 1064 theta); elsewhere the circulant bound, or failing it a Cholesky
factorisation at one phase (:func:`patch_certify`), proves the slack, and the proof is handed to the margin as
a lower bound. At a row, one block per phase is eigen-solved (the one smallest at the previous row) and the
others are proven above it by a Cholesky factorisation (:func:`_blocks_lambda_min`). The LP is one HiGHS model
(``highspy``) kept across its cutting-plane rounds, targets and phase re-picks, each solve starting from the
last optimal basis, with the fidelity rows added once a solution violates them (:class:`_CuttingPlaneLP`).
The correction is the same identity shift on every patch, so taps designed on a 20 x 20 patch may be applied
to a larger one (measured tread, k(fs/2) of the 20 x 20 taps: 1.24e5 N/m on 20 x 20, 1.06e5 on 40 x 40; today's
2.37e4 / 2.29e4).

Whatever the correction adds is reported (:class:`Correction`): the taps, sum |c|, sum c, max |Delta| /
|G_d,00| in the band and above it, Delta(-1), the base and corrected grid margins, LP rounds.

A patch-independent (Toeplitz symbol) certificate is given by :func:`symbol_support`: exact for the patch
and all its sub-patches, but conservative where the table truncates a wave field that has not decayed
(shear wavelength ~15 mm at 9 kHz): for the tread 20 x 20 table it is negative in 0.32-0.44 pi (-3.5e-5
m/N) where the patch itself has p > 0, and no excitation-element correction within the fidelity budget
can make it positive (LP: best -2.1 |g_00|); it is reported, not designed for.
"""

from __future__ import annotations

import functools
import logging
import math
import os
import sys
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg
import xarray as xr

logger = logging.getLogger(__name__)

__all__ = ["Correction", "transfer_tables", "symbol_support", "patch_support", "patch_certify", "circulant_lower_bound",
           "design_correction",
           "apply_correction", "correct_greens", "default_kernel", "DEFAULT_K_TARGET"]

#: Springs up to this [N/m] are designed safe (3 x the default saturated element spring 3.96e4 N/m).
DEFAULT_K_TARGET = 1.2e5


def transfer_tables(lags: np.ndarray, tail_compliance: np.ndarray | None, weights, decays, n_grid: int):
    """G_d(e^{i theta}) of a kernel (kept lags + creep tail) on theta_k = pi k / n_grid, k = 0 ... n_grid.

    Parameters
    ----------
    lags : numpy.ndarray
        (X, Y, L) offset tables of the kept lags [m/N].
    tail_compliance, weights, decays
        The tail (:class:`tyreroad.memory.TailModel`): R (X, Y) [m/N], weight_k, decay_k; None: no tail.
    n_grid : int
        Intervals on [0, pi].

    Returns
    -------
    theta : numpy.ndarray (n_grid + 1,) [rad]
    tables : numpy.ndarray (n_grid + 1, X, Y) complex [m/N]
    """
    n_lags = lags.shape[2]
    spec = np.fft.rfft(lags, n=2 * n_grid, axis=-1)  # sum_l g_l e^{-i l theta}, theta = 2 pi k / (2 n_grid)
    theta = np.pi * np.arange(n_grid + 1) / n_grid
    if tail_compliance is not None:  # in place, in the FFT's layout (a 20 x 20 patch's tables are 100 MB)
        z = np.exp(-1j * theta)
        c = z**n_lags * np.sum(np.asarray(weights) / (1.0 - np.asarray(decays) * z[:, None]), axis=1)
        for i, row in enumerate(np.asarray(tail_compliance, dtype=float)):
            spec[i] += row[:, None] * c[None, :]
    return theta, np.moveaxis(spec, -1, 0)


def _pad_sizes(n: int) -> tuple[int, ...]:
    # circulant sizes >= 2 n - 1 (each embeds the patch's Toeplitz matrix exactly); the best bound is kept
    return (2 * n - 1, 2 * n, 2 * n + 8, 1 << max(3, math.ceil(math.log2(3 * n))))


def symbol_support(tables: np.ndarray, n_phi: int = 361, pads=None):
    """Certified support function of the numerical range of a patch's offset matrices, from circulant embeddings.

    For a circulant of size px x py >= (2 nx - 1) x (2 ny - 1) whose first column is the offset table (dx
    taken mod px, dy mod py), the patch's two-level Toeplitz matrix is a principal submatrix, and the
    circulant's eigenvalues are the table's symbol A(kappa) = sum_d T(d) e^{-i kappa.d} on the grid
    kappa = 2 pi (m / px, n / py). Hence for every phi and every patch (and sub-patch) of the table,

        lambda_min Herm(e^{i phi} G_d) >= h(phi) = min_grid Re(e^{i phi} A(kappa)),

    exactly (no sampling error). Each circulant size gives a valid bound; the largest is kept.

    Parameters
    ----------
    tables : numpy.ndarray
        (n, 2 nx - 1, 2 ny - 1) complex offset tables, symmetric in dx and dy.
    n_phi : int
        phi grid on [-pi/2, pi/2].
    pads : sequence of (int, int), optional
        Circulant sizes (each >= 2 n - 1 per axis); default four per axis (see :func:`_pad_sizes`).

    Returns
    -------
    phi : numpy.ndarray (n_phi,) [rad]
    h : numpy.ndarray (n, n_phi) [m/N], a lower bound of lambda_min Herm(e^{i phi} G_d) of the patch.
    """
    nx, ny = (tables.shape[1] + 1) // 2, (tables.shape[2] + 1) // 2
    phi = np.linspace(-np.pi / 2, np.pi / 2, n_phi)
    return phi, circulant_lower_bound(tables, (nx, ny), phi,
                                      pads if pads is not None else list(zip(_pad_sizes(nx), _pad_sizes(ny))))


def patch_support(tables: np.ndarray, shape, phi: np.ndarray, symmetry: bool = True, strip: bool = False) -> np.ndarray:
    """lambda_min Herm(e^{i phi} G_d) of the patch's M x M matrices (M = nx ny), per table and phi.

    Parameters
    ----------
    tables : numpy.ndarray
        (n, 2 nx - 1, 2 ny - 1) complex offset tables [m/N].
    shape : (int, int)
        Patch (nx, ny) (the tables are cropped to it).
    phi : numpy.ndarray
        Angles [rad].
    symmetry : bool
        Solve on the four reflection blocks of the patch matrices (:mod:`tyreroad.symmetry`) when the tables
        are even in dx and dy (the same eigenvalues); False: the patch matrices themselves (the reference).
    strip : bool
        The strip bound instead (:func:`tyreroad.symmetry.strip_symbol_blocks`, even tables): a certified lower
        bound of the patch's value, exact across the short axis, for long patches whose reflection blocks are
        too large to eigen-solve at every theta (a rolling strip, 150 x 20: blocks of 750).

    Returns
    -------
    numpy.ndarray (n, len(phi)) [m/N]
    """
    from .symmetry import strip_lambda_min, strip_symbol_blocks

    out = np.empty((tables.shape[0], len(phi)))
    crop = _crop(tables, shape, strip)
    if strip:
        parts = strip_symbol_blocks(crop, shape)
        for j, f in enumerate(phi):
            out[:, j] = strip_lambda_min(parts, f)
        return out
    # the four reflection blocks (tyreroad.symmetry) carry the patch matrix's spectrum exactly, at 1/16 of the work
    likeliest = np.zeros(len(phi), dtype=int)  # per phase, the block that was smallest at the last table
    for k, pairs in _patch_matrices(crop, shape, symmetry):
        if len(pairs) > 1 and max(b.shape[0] for b, _ in pairs) > _BATCHED_BLOCK:
            out[k] = _blocks_lambda_min(pairs, phi, likeliest)
        else:
            out[k] = np.min([_lambda_min_on_phases(b, c, phi) for b, c in pairs], axis=0)
    return out


def _blocks_lambda_min(pairs, phi: np.ndarray, likeliest: np.ndarray) -> np.ndarray:
    """min over the blocks of lambda_min(cos phi b - sin phi c), for every phi [same units as b, c].

    Only one block per phase is eigen-solved: the one that was smallest at the previous table (``likeliest``,
    updated in place; on a theta grid the smallest block changes rarely). Every other block is proven to lie
    above that value by a Cholesky factorisation of (block - value I) (a third of an eigen-solve's work, no
    reduction to tridiagonal form; all phases of a block in one batched call), and eigen-solved only where the
    factorisation fails. The minimum is an eigen-solved one either way (20 x 20 tread design: 3x fewer flops
    than solving all five blocks).
    """
    from .margin import _shifted_pd

    cos, sin = np.cos(phi), np.sin(phi)
    value = np.empty(len(phi))
    for j in range(len(phi)):
        b, c = pairs[int(likeliest[j])]
        value[j] = _lambda_min_on_phases(b, c, phi[j:j + 1])[0]
    first = likeliest.copy()
    for i, (b, c) in enumerate(pairs):
        rest = np.flatnonzero(first != i)
        if not rest.size:
            continue
        stack = cos[rest, None, None] * b[None] - sin[rest, None, None] * c[None]
        stack[:, np.arange(b.shape[0]), np.arange(b.shape[0])] -= value[rest, None]
        try:
            np.linalg.cholesky(stack)  # every phase above the value: the usual case, one call
            continue
        except np.linalg.LinAlgError:
            pass
        for j in rest:  # some phase is not: find which, and eigen-solve the block there
            if not _shifted_pd([b], [c], float(phi[j]), -value[j]):  # below the value (or equal to rounding)
                v = _lambda_min_on_phases(b, c, phi[j:j + 1])[0]
                if v < value[j]:
                    value[j], likeliest[j] = v, i
    return value


def _crop(tables: np.ndarray, shape, strip: bool) -> np.ndarray:
    """The (n, 2 nx - 1, 2 ny - 1) centre of a stack of offset tables; for the strip bound, checked even in dx
    and dy (its folds assume it)."""
    from .symmetry import is_reflection_even

    nx, ny = shape
    cx, cy = (tables.shape[1] - 1) // 2, (tables.shape[2] - 1) // 2
    crop = tables[:, cx - (nx - 1): cx + nx, cy - (ny - 1): cy + ny]
    if strip and not is_reflection_even(crop):
        raise ValueError(f"the strip bound needs offset tables even in dx and dy; these ({shape} patch) are not")
    return crop


#: Tables whose reflection blocks are built in one sparse product (a chunk small enough to stay in cache: the
#: blocks of all ~600 rows of a 20 x 20 design at once are 200 MB, whose first touch cost more than the product).
_BLOCK_CHUNK = 16


def _patch_matrices(crop: np.ndarray, shape, symmetry: bool):
    """(k, [(Re, Im) of each block]) per cropped table k: the patch matrix's reflection blocks
    (:mod:`tyreroad.symmetry`) when the tables are even and ``symmetry``, else the patch matrix itself."""
    from .influence import offset_matrix
    from .symmetry import patch_blocks

    blocks = patch_blocks(crop, shape) if symmetry else None
    if blocks is None:
        for k in range(crop.shape[0]):
            a = offset_matrix(crop[k])
            yield k, [(a.real.copy(), a.imag.copy())]
        return
    for start in range(0, crop.shape[0], _BLOCK_CHUNK):
        part = crop[start:start + _BLOCK_CHUNK]
        b_all = blocks.blocks(np.ascontiguousarray(part.real))
        c_all = blocks.blocks(np.ascontiguousarray(part.imag))
        for k in range(part.shape[0]):
            yield start + k, [(b[k], c[k]) for b, c in zip(b_all, c_all)]


def patch_certify(tables: np.ndarray, shape, phi: np.ndarray, shift: np.ndarray, symmetry: bool = True,
                  strip: bool = False) -> np.ndarray:
    """The first of a few (phase, shift) pairs per table at which Herm(e^{i phi} G_d) + shift I is positive definite
    on the patch (Cholesky), or -1.

    Success at (phi, shift) proves lambda_min Herm(e^{i phi} G_d) > -shift: a certified lower bound, at a fraction
    of an eigen-solve's cost (one factorisation per block, no reduction to tridiagonal form); failure proves
    nothing. The patch's blocks are built once per table for all its pairs.

    Parameters
    ----------
    tables : numpy.ndarray
        (n, 2 nx - 1, 2 ny - 1) complex offset tables [m/N] (larger tables are cropped).
    shape : (int, int)
        Patch (nx, ny).
    phi, shift : numpy.ndarray
        (n, n_try) phases [rad] and shifts [m/N] per table, tried in order (NaN shift: skipped).
    symmetry, strip : bool
        As :func:`patch_support` (``strip``: the strip bound's matrices, so success bounds the patch's value too).

    Returns
    -------
    numpy.ndarray (n,) of int
        The index of the first pair that succeeded, -1 if none.
    """
    from .margin import _shifted_pd
    from .symmetry import strip_symbol_blocks

    phi, shift = np.atleast_2d(phi), np.atleast_2d(shift)
    crop = _crop(tables, shape, strip)
    out = np.full(crop.shape[0], -1)
    if strip:
        parts = strip_symbol_blocks(crop, shape)
        matrices = ((k, [(b[k], c[k]) for b, c in parts]) for k in range(crop.shape[0]))
        positive = _stacks_positive_definite  # the strip bound's blocks come as a stack per wave number
    else:
        matrices = _patch_matrices(crop, shape, symmetry)
        positive = _shifted_pd  # the margin's own certificate, block by block
    for k, pairs in matrices:
        bs, cs = [b for b, _ in pairs], [c for _, c in pairs]
        for t in range(phi.shape[1]):
            if math.isfinite(shift[k, t]) and positive(bs, cs, float(phi[k, t]), float(shift[k, t])):
                out[k] = t
                break
    return out


def _stacks_positive_definite(bs, cs, phi: float, shift: float) -> bool:
    """Herm(e^{i phi} G) + shift I positive definite for every matrix of the stacks (..., m, m) in bs, cs (Re,
    Im), by one batched Cholesky per stack."""
    cp, sp = math.cos(phi), math.sin(phi)
    for b, c in zip(bs, cs):
        m = cp * b - sp * c
        m += shift * np.eye(m.shape[-1])
        try:
            np.linalg.cholesky(m)
        except np.linalg.LinAlgError:
            return False
    return True


#: Blocks up to this size are solved for all phases in one batched LAPACK call (per-call overhead dominates
#: there); larger ones one phase at a time for the smallest eigenvalue alone (measured crossover ~30).
_BATCHED_BLOCK = 24


def _lambda_min_on_phases(b: np.ndarray, c: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """lambda_min(cos phi b - sin phi c) for every phi [same units as b, c]."""
    if b.shape[0] <= _BATCHED_BLOCK:
        stack = np.cos(phi)[:, None, None] * b[None] - np.sin(phi)[:, None, None] * c[None]
        return np.linalg.eigvalsh(stack)[:, 0]
    # the smallest eigenvalue alone (LAPACK evr): 3x cheaper than the whole spectrum on 400 x 400; called directly,
    # as scipy.linalg.eigh(..., subset_by_index=[0, 0]) does, without its per-call checks and workspace query (a
    # fifth of the greens stage's eigen-solve time on 20 x 20)
    syevr, lwork = _smallest_eigenvalue_driver(b.shape[0])
    out = np.empty(len(phi))
    for i, f in enumerate(phi):
        w, _, m, _, info = syevr(math.cos(f) * b - math.sin(f) * c, compute_v=0, range="I", il=1, iu=1, lower=1,
                                 overwrite_a=1, **lwork)
        if info != 0 or m != 1:
            raise np.linalg.LinAlgError(f"LAPACK dsyevr: info {info}, {m} eigenvalues (expected 1)")
        out[i] = w[0]
    return out


@functools.lru_cache(maxsize=16)
def _smallest_eigenvalue_driver(n: int):
    """LAPACK dsyevr and its workspace sizes for n x n (queried once per size)."""
    syevr, syevr_lwork = scipy.linalg.get_lapack_funcs(("syevr", "syevr_lwork"), dtype=np.float64)
    lwork, liwork, info = syevr_lwork(n, lower=1)
    if info != 0:
        raise np.linalg.LinAlgError(f"LAPACK dsyevr_lwork: info {info}")
    return syevr, {"lwork": int(lwork), "liwork": int(liwork)}


def circulant_lower_bound(tables: np.ndarray, shape, phi: np.ndarray, pads=None) -> np.ndarray:
    """A certified lower bound of :func:`patch_support`: lambda_min Herm(e^{i phi} G_d) of the patch's matrices.

    The patch's two-level Toeplitz matrix is a principal submatrix of every circulant of size >= 2 n - 1 per axis
    whose first column is the cropped table (see :func:`symbol_support`), so lambda_min of the patch is at least
    the circulant's, min over the DFT grid of Re(e^{i phi} A). The largest bound over the circulant sizes is kept.

    Parameters
    ----------
    tables : numpy.ndarray
        (n, X, Y) complex offset tables [m/N], X, Y >= 2 nx - 1, 2 ny - 1.
    shape : (int, int)
        Patch (nx, ny).
    phi : numpy.ndarray
        Angles [rad].
    pads : sequence of (int, int), optional
        Circulant sizes (each >= 2 n - 1 per axis); default: the tightest and the widest of :func:`_pad_sizes`.

    Returns
    -------
    numpy.ndarray (n, len(phi)) [m/N]
    """
    nx, ny = shape
    if pads is None:
        pads = list(zip(_pad_sizes(nx), _pad_sizes(ny)))[::3]
    cx, cy = (tables.shape[1] - 1) // 2, (tables.shape[2] - 1) // 2
    crop = tables[:, cx - (nx - 1): cx + nx, cy - (ny - 1): cy + ny]
    ix0, iy0 = np.arange(-(nx - 1), nx), np.arange(-(ny - 1), ny)
    out = np.full((tables.shape[0], len(phi)), -np.inf)
    cos, sin = np.cos(phi), np.sin(phi)
    for px, py in pads:
        if px < 2 * nx - 1 or py < 2 * ny - 1:
            raise ValueError(f"circulant {px} x {py} smaller than the table {2 * nx - 1} x {2 * ny - 1}")
        for start in range(0, tables.shape[0], 128):
            part = crop[start:start + 128]
            buf = np.zeros((part.shape[0], px, py), dtype=complex)
            buf[:, (ix0 % px)[:, None], (iy0 % py)[None, :]] = part
            a = np.fft.fft2(buf, axes=(1, 2)).reshape(part.shape[0], -1)
            for j in range(len(phi)):
                np.maximum(out[start:start + 128, j], (cos[j] * a.real - sin[j] * a.imag).min(axis=1),
                           out=out[start:start + 128, j])
    return out


@dataclass
class Correction:
    """A causal FIR correction of the excitation element's lags and what it changes (numbers reported).

    Attributes
    ----------
    taps : numpy.ndarray
        c_0 ... c_{n_taps - 1} [m/N], added to g[0, 0, 0 ... n_taps - 1].
    sum_abs, dc : float
        sum |c_l| and sum c_l [m/N] (dc = 0 to rounding: static compliance and tail unchanged).
    in_band, above_band : float
        max |Delta| / |G_d,00| for f <= band and above it [1].
    at_nyquist : float
        Delta(-1) [m/N].
    k_target : float
        The springs designed safe [N/m] (inf: every spring).
    slack : float
        The LP's min over the grid of h + cos phi / k_target + Re(e^{i phi} Delta) [m/N] (>= 0: met on the grid);
        at the points a Cholesky factorisation certified instead of an eigen-solve, the certified lower bound
        of it (there the slack asked: half the nearest solved point's, at least 1e-3 ``margin``).
    base_min_p, min_p : float
        Min over theta of p = max_phi h (+ Re e^{i phi} Delta) of the base and corrected kernel [m/N], over the
        checked points whose lambda_min was solved (the coarse grid and every point the circulant bound did
        not clear); ``theta_min`` where (corrected) [rad].
    lp_rounds : int
    n_theta, n_phi : int
        Design grid.
    seconds : float
    band : float
        [Hz].
    notes : list of str
    theta, phi, support : numpy.ndarray or None
        The checked points known on the patch [rad] and lambda_min Herm(e^{i phi} G_d) of the *base* kernel there
        (n_theta, n_phi) [m/N]: the corrected kernel's is support + Re(e^{i phi} Delta(theta)) exactly (Delta I
        on the patch), which :func:`tyreroad.margin.patch_margin` reuses on the patch ``shape``.
    exact : numpy.ndarray or None
        (n_theta,) bool: True where ``support`` is the eigenvalues themselves; False where it is a certified
        lower bound (a Cholesky certificate at one phase, the circulant bound at the others).
    scale : numpy.ndarray or None
        (n_theta,) the largest |Re| or |Im| entry of the *corrected* kernel's transfer table, cropped to the
        patch, at the checked points [m/N] (the margin's tolerance scale there; :func:`tyreroad.margin.patch_margin`).
    shape : (int, int) or None
        The patch designed on.
    """

    taps: np.ndarray
    sum_abs: float
    dc: float
    in_band: float
    above_band: float
    at_nyquist: float
    k_target: float
    slack: float
    base_min_p: float
    min_p: float
    theta_min: float
    lp_rounds: int
    n_theta: int
    n_phi: int
    seconds: float
    band: float
    notes: list = field(default_factory=list)
    theta: np.ndarray | None = field(default=None, repr=False)
    phi: np.ndarray | None = field(default=None, repr=False)
    support: np.ndarray | None = field(default=None, repr=False)
    exact: np.ndarray | None = field(default=None, repr=False)
    shape: tuple | None = None
    scale: np.ndarray | None = field(default=None, repr=False)

    def margin_support(self):
        """(theta [rad], phi [rad], lambda_min Herm(e^{i phi} G_d) [m/N], exact, scale [m/N] or None) of the
        *corrected* kernel on the checked grid (:func:`tyreroad.margin.patch_margin`'s ``support``; ``exact``
        False: a certified lower bound), or None without a stored support."""
        if self.support is None:
            return None
        delta = _fir(self.taps.size, self.theta) @ self.taps
        exact = np.ones(self.theta.size, dtype=bool) if self.exact is None else self.exact
        return (self.theta, self.phi, self.support + (np.exp(1j * self.phi)[None, :] * delta[:, None]).real, exact,
                self.scale)

    def summary(self) -> str:
        return (f"spring-safe correction: {self.taps.size} taps on the excitation element, sum|c| {self.sum_abs:.3g} m/N "
                f"(sum {self.dc:.1e}), |Delta|/|G00| <= {self.in_band:.2e} up to {self.band:.0f} Hz, <= {self.above_band:.3g} "
                f"above, Delta(-1) {self.at_nyquist:.3g} m/N; k_target {self.k_target:.3g} N/m, slack {self.slack:.3g} m/N; "
                f"grid min p {self.base_min_p:.3g} -> {self.min_p:.3g} m/N (at {self.theta_min / np.pi:.4f} pi); "
                f"{self.lp_rounds} LP rounds, {self.n_theta} theta x {self.n_phi} phi, {self.seconds:.1f} s")


def _fir(n_taps: int, theta: np.ndarray) -> np.ndarray:
    return np.exp(-1j * np.outer(theta, np.arange(n_taps)))


@functools.lru_cache(maxsize=1)
def _silence_highs_banner() -> None:
    """Make the process's first HiGHS model with the C-level stdout on /dev/null: HiGHS prints its version and
    licence banner to stdout when its first model is made, before any option can be set, and every greens job
    would print it into the user's terminal. Only that construction is redirected (and only once)."""
    import highspy

    sys.stdout.flush()
    saved = os.dup(1)
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        highspy.Highs()
    finally:
        os.dup2(saved, 1)
        os.close(saved)
        os.close(devnull)


class _CuttingPlaneLP:
    """The design's linear programme, kept in one HiGHS model across its cutting-plane rounds (warm starts).

    Variables: the taps c (free), u >= |c| and t <= 1 (all scaled by ``scale``); maximise t - 1e-3 sum u.
    Rows: |c| <= u and sum c = 0, passed once; the fidelity octagon Re(e^{i psi} Delta(f)) <= radius(f), of which
    only every ``fidelity_stride``-th frequency is passed at first and any other (f, psi) row joins once a
    solution violates it (checked after every solve, re-solved until none is: the optimum is then the whole
    LP's, since it satisfies rows of which it solved a relaxation); and the spring-safety rows, keyed by (theta
    row, phase): a round asks one phase per theta row, and the rows it does not ask stay in the model as free
    rows (no bound), so that a later round asking the same pair again re-binds it instead of adding it.
    Each solve starts from the last optimal basis (dual simplex: added cuts and moved bounds keep it dual
    feasible). The optimum is the same LP's as a cold :func:`scipy.optimize.linprog` of every row
    (tests/test_margin.py compares them).

    Parameters
    ----------
    e : numpy.ndarray
        (n_theta, n_taps) complex FIR matrix e^{-i l theta} of the checked theta rows.
    fidelity : numpy.ndarray
        (n_f, n_taps) complex FIR matrix of the fidelity band's frequencies.
    radius : numpy.ndarray
        (n_f,) the octagon's inscribed radius per frequency (scaled).
    fidelity_stride : int
        Every how many fidelity frequencies are passed before the first solve.
    """

    #: rows violated by more than this (scaled units: HiGHS's own primal feasibility tolerance) join the LP
    FEASIBILITY = 1e-7

    def __init__(self, e: np.ndarray, fidelity: np.ndarray, radius: np.ndarray, fidelity_stride: int = 4):
        import highspy

        self._e = e
        n = e.shape[1]
        self.n_taps = n
        _silence_highs_banner()
        self._h = highspy.Highs()
        h = self._h
        h.setOptionValue("output_flag", False)
        inf = highspy.kHighsInf
        self._inf = inf
        cost = np.r_[np.zeros(n), 1e-3 * np.ones(n), -1.0]
        lower = np.r_[np.full(n, -inf), np.zeros(n), -inf]
        upper = np.r_[np.full(n, inf), np.full(n, inf), 1.0]
        h.addVars(2 * n + 1, lower, upper)
        h.changeColsCost(2 * n + 1, np.arange(2 * n + 1, dtype=np.int32), cost)
        eye, zero = np.eye(n), np.zeros((n, 1))
        fixed = np.vstack([np.hstack([eye, -eye, zero]), np.hstack([-eye, -eye, zero]),
                           np.r_[np.ones(n), np.zeros(n + 1)][None, :]])
        self._add_rows(fixed, np.r_[np.full(2 * n, -inf), 0.0], np.zeros(2 * n + 1))
        # the octagon's rows, (psi, f) flattened, as coefficients of c; which of them are in the model
        self._fid_a = np.vstack([(np.exp(1j * psi) * fidelity).real for psi in np.arange(8) * np.pi / 4])
        self._fid_b = np.tile(np.asarray(radius, dtype=float), 8)
        self._fid_in = np.zeros(self._fid_b.size, dtype=bool)
        first = np.tile(np.arange(fidelity.shape[0]) % max(int(fidelity_stride), 1) == 0, 8)
        self._add_fidelity(np.flatnonzero(first))
        self._rows = {}  # (theta row, phase index) -> model row
        self.solves = 0

    def _add_rows(self, a: np.ndarray, lower: np.ndarray, upper: np.ndarray):
        nz = a != 0.0
        starts = np.r_[0, np.cumsum(nz.sum(axis=1))[:-1]].astype(np.int32)
        idx = np.nonzero(nz)[1].astype(np.int32)
        first = self._h.getNumRow()
        self._h.addRows(a.shape[0], lower, upper, idx.size, starts, idx, a[nz])
        return np.arange(first, first + a.shape[0])

    def _add_fidelity(self, which: np.ndarray):
        n = self.n_taps
        a = np.hstack([self._fid_a[which], np.zeros((which.size, n + 1))])
        self._add_rows(a, np.full(which.size, -self._inf), self._fid_b[which])
        self._fid_in[which] = True

    def solve(self, rows_on: np.ndarray, phases: np.ndarray, phi: np.ndarray, rhs: np.ndarray):
        """Solve with the spring-safety rows (theta row rows_on[i] at phase phases[i], right-hand side rhs[i]).

        Returns
        -------
        (status, message, x) : (int, str, numpy.ndarray or None)
            status 0: optimal, x = (c, u, t) scaled; otherwise HiGHS's model status and no x.
        """
        import highspy

        n = self.n_taps
        keys = list(zip(rows_on.tolist(), phases.tolist()))
        new = [i for i, key in enumerate(keys) if key not in self._rows]
        if new:
            r, j = rows_on[new], phases[new]
            stab = (np.exp(1j * phi[j])[:, None] * self._e[r]).real
            a = np.hstack([-stab, np.zeros((len(new), n)), np.ones((len(new), 1))])
            for key, row in zip((keys[i] for i in new), self._add_rows(a, np.full(len(new), -self._inf), rhs[new])):
                self._rows[key] = row
        wanted = dict(zip(keys, rhs.tolist()))
        index = np.fromiter(self._rows.values(), dtype=np.int32, count=len(self._rows))
        upper = np.array([wanted.get(key, self._inf) for key in self._rows])
        self._h.changeRowsBounds(index.size, index, np.full(index.size, -self._inf), upper)
        while True:
            cold = self.solves == 0
            if cold:
                # from scratch the primal simplex without presolve is faster on these dense LPs (measured cold:
                # 256 taps 1.37 s against the dual's 2.39 s, 128 taps 0.14 against 0.19 s); after that each solve
                # starts from the last basis, which added rows and moved bounds leave dual feasible: dual simplex
                self._h.setOptionValue("simplex_strategy", 4)
                self._h.setOptionValue("presolve", "off")
            self._h.run()
            if cold:
                self._h.setOptionValue("simplex_strategy", 1)
                self._h.setOptionValue("presolve", "choose")
            self.solves += 1
            status = self._h.getModelStatus()
            if status != highspy.HighsModelStatus.kOptimal:
                return 1, self._h.modelStatusToString(status), None
            x = np.asarray(self._h.getSolution().col_value)
            out = np.flatnonzero(~self._fid_in)
            violated = out[self._fid_a[out] @ x[:n] > self._fid_b[out] + self.FEASIBILITY]
            if not violated.size:
                return 0, "optimal", x
            self._add_fidelity(violated)


def design_correction(lags: np.ndarray, tail_compliance=None, weights=(), decays=(), shape=None,
                      sample_rate: float = 51200.0, band: float = 5000.0, fidelity_budget: float = 4e-3,
                      k_target: float = DEFAULT_K_TARGET, margin: float = 3e-7, n_taps: int = 128,
                      n_theta: int = 512, n_phi: int = 16, max_rounds: int = 12, symmetry: bool = True,
                      n_dense: int | None = None, longer_taps: int | None = None,
                      extra_transfer=None, strip: bool = False) -> Correction:
    """Design the spring-safe correction of a kernel's excitation element (see the module docstring).

    Parameters
    ----------
    lags : numpy.ndarray
        (2 nx - 1, 2 ny - 1, L) offset tables of the kept lags [m/N] (the greens file's ``g``).
    tail_compliance, weights, decays
        The creep tail (:class:`tyreroad.memory.TailModel` residual_compliance, weights, decays); None: none.
    shape : (int, int), optional
        Patch the margin is designed on (default: the table's own, ((X + 1) / 2, (Y + 1) / 2)).
    sample_rate : float
        [Hz].
    band : float
        Upper end of the faithful band [Hz].
    fidelity_budget : float
        Largest |Delta| / |G_d,00| allowed up to ``band`` [1], on top of the base kernel's own error.
    k_target : float or sequence of float
        Springs designed safe [N/m] (inf: p > 0, every spring); a sequence: tried in turn (one eigen-solve
        pass for all) until the LP meets one on the checked grid, the last kept whatever it reaches.
    margin : float
        Slack asked beyond that [m/N] (the LP's t is capped there).
    n_taps : int
        Correction taps (<= L).
    n_theta, n_phi : int
        theta points above ``band`` (plus 48 in it) and phi points on [-pi/12, pi/2].
    max_rounds : int
        LP rounds (phi re-chosen between rounds).
    symmetry : bool
        Eigen-solve the reflection blocks of the patch matrices (:func:`patch_support`; the same values).
    strip : bool
        Design on the strip bound of a long patch (:func:`patch_support` ``strip``: a lower bound of the patch's
        lambda_min, so a target met on it is met by the patch).
    longer_taps : int, optional
        If the first target is missed, the next target up from the one met is designed once more with this
        many taps (<= L), reusing the eigenvalues solved; kept if it meets it (low-loss variants: a longer FIR
        reaches a stiffer target within the same fidelity budget).
    n_dense : int, optional
        Also check every theta = pi k / n_dense above ``band`` (a divisor of 4096; 1024: the grid of
        :func:`tyreroad.margin.patch_margin`): the LP starts on the coarse grid and adds every checked point
        its solution violates (cutting planes), so that ``slack >= 0`` holds on the margin's whole grid, not
        only at the coarse points (between them the dense margin found dips below k_target).
    extra_transfer : callable, optional
        theta (n,) [rad] -> complex (n, X, Y) tables [m/N] added to the kept lags' and the tail's transfer
        function: a memory beyond the kept lags other than the creep tail (a flexible belt's recursive filters,
        :class:`tyreroad.belt_kernel.BeltMemory`), so that the design sees the whole kernel the march runs.

    Returns
    -------
    Correction
        ``slack >= 0``: met on the grid (verify densely with :func:`tyreroad.cq.kernel_margin`); otherwise
        the best found (``notes``).
    """
    t0 = time.perf_counter()
    n_taps = min(int(n_taps), lags.shape[2])
    if shape is None:
        shape = ((lags.shape[0] + 1) // 2, (lags.shape[1] + 1) // 2)
    targets = [float(k) for k in np.atleast_1d(k_target)]
    cx, cy = (lags.shape[0] - 1) // 2, (lags.shape[1] - 1) // 2
    n_grid = 4096
    theta_all, tables = transfer_tables(lags, tail_compliance, weights, decays, n_grid)
    if extra_transfer is not None:
        tables = tables + np.asarray(extra_transfer(theta_all))[:, : lags.shape[0], : lags.shape[1]]
    g00 = np.abs(tables[:, cx, cy])
    t_band = 2 * np.pi * band / sample_rate
    coarse = np.unique(np.round(np.r_[np.linspace(0.0, t_band, 48), np.linspace(t_band, np.pi, n_theta)]
                                * n_grid / np.pi).astype(int))
    if n_dense:
        if n_grid % int(n_dense):
            raise ValueError(f"n_dense must divide {n_grid}, got {n_dense}")
        step = n_grid // int(n_dense)
        dense = np.arange(0, n_grid + 1, step)
        sel = np.union1d(coarse, dense[theta_all[dense] >= t_band])
    else:
        sel = coarse
    theta = theta_all[sel]
    start_rows = np.flatnonzero(np.isin(sel, coarse))  # the LP starts on the coarse grid, adds violated points
    phi = np.linspace(-np.pi / 12, np.pi / 2, n_phi)
    j0 = int(np.argmin(np.abs(phi)))
    # lambda_min on the patch's matrices, solved lazily: on the coarse rows the LP starts from, and at any
    # other checked point only where the certified circulant lower bound (:func:`circulant_lower_bound`) cannot
    # clear the slack by itself (same verdicts and rows as solving every point; a fraction of the eigen-solves)
    checked_tables = tables[sel]
    h = np.full((theta.size, phi.size), np.nan)
    # the start rows are eigen-solved before anything reads their bound: it is needed at the other rows only
    lower = np.full((theta.size, phi.size), -np.inf)
    later = np.setdiff1d(np.arange(theta.size), start_rows)
    lower[later] = circulant_lower_bound(checked_tables[later], shape, phi)

    def solve(rows):
        rows = rows[np.isnan(h[rows, 0])]
        if rows.size:
            h[rows] = patch_support(checked_tables[rows], shape, phi, symmetry=symmetry, strip=strip)

    def known(values):
        return np.where(np.isnan(values), lower, values)

    tiny = 1e-3 * max(margin, 1e-300)
    raised = np.zeros(theta.size, dtype=bool)  # rows whose lower bound a Cholesky certificate raised

    def certify(rows, allowance, delta):
        """Raise ``lower`` where a Cholesky factorisation proves the slack > 0 at one phase, on rows whose
        lambda_min is not solved: at the phase best at the nearest solved row, asking half of that row's slack
        (so that later rounds' small changes of Delta stay cleared), then ``tiny``; then at the bound's best."""
        rows = rows[np.isnan(h[rows, 0])]
        solved = np.flatnonzero(~np.isnan(h[:, 0]))
        if not rows.size or not solved.size:
            return
        rot = (np.exp(1j * phi)[None, :] * delta[:, None]).real + allowance
        v_all, j_all = best(known(h) + allowance, delta)  # at the solved rows, their own best phase and slack
        v_solved, j_solved = v_all[solved], j_all[solved]
        pos = np.clip(np.searchsorted(solved, rows), 1, solved.size) - 1
        after = np.minimum(pos + 1, solved.size - 1)
        pos = np.where(np.abs(solved[after] - rows) < np.abs(solved[pos] - rows), after, pos)
        j_bound = j_all[rows]  # at the unsolved rows, the bound's best phase
        near = j_solved[pos]
        if theta[-1] == np.pi:  # G_d(-1) is real: best() reads phi = 0 there
            near[rows == theta.size - 1] = j0
        cand = np.stack([near, near, j_bound], axis=1)
        want = np.stack([np.maximum(0.5 * v_solved[pos], tiny), np.full(rows.size, tiny), np.full(rows.size, tiny)],
                        axis=1)
        shift = np.take_along_axis(rot[rows], cand, axis=1) - want  # lambda_min > want - rot: slack > want there
        shift[:, 1][want[:, 0] == tiny] = np.nan  # the same pair as the first
        shift[:, 2][j_bound == near] = np.nan  # the same pair as the second
        got = patch_certify(checked_tables[rows], shape, phi[cand], shift, symmetry=symmetry, strip=strip)
        ok = got >= 0
        r, jj = rows[ok], cand[ok, got[ok]]
        lower[r, jj] = np.maximum(lower[r, jj], want[ok, got[ok]] - rot[r, jj])
        raised[r] = True

    solve(start_rows)
    fid = np.flatnonzero(theta_all <= t_band * 1.02)[::4]

    def best(values, delta):
        v = values + (np.exp(1j * phi)[None, :] * delta[:, None]).real
        j = v.argmax(axis=1)
        if theta[-1] == np.pi:
            j[-1] = j0  # G_d(-1) is real: phi = 0 there
        return v[np.arange(v.shape[0]), j], j

    scale = max(margin, 1e-300)
    radius = fidelity_budget * g00[fid] * math.cos(math.pi / 8) / scale
    rounds, notes = 0, []

    carried = []  # a missed target's LP rows and the phases of its last solution there

    def attempt(targets, n_taps):
        """The targets in turn with ``n_taps`` taps, on the eigenvalues solved so far: ((slack, taps), target)."""
        nonlocal rounds
        e = _fir(n_taps, theta)
        # one model for every target and round of this tap count: each solve starts from the last basis
        lp = _CuttingPlaneLP(e, _fir(n_taps, theta_all[fid]), radius)
        for target in targets:
            allowance = (np.cos(phi) / target if math.isfinite(target) else np.zeros(phi.size))[None, :]
            _, jsel = best(known(h) + allowance, np.zeros(theta.size))
            rows_on = start_rows.copy()
            if carried:
                # a target after a missed one (a softer one, or the same with more taps) starts from the points
                # the missed one had to add and the phases its last solution chose there, instead of finding
                # them again round by round
                rows_on = np.union1d(rows_on, carried[0])
                jsel[carried[0]] = carried[1][carried[0]]
            found, last_t = None, None
            for _ in range(max_rounds):
                status, message, x = lp.solve(rows_on, jsel[rows_on], phi,
                                              (h[rows_on, jsel[rows_on]] + allowance[0, jsel[rows_on]]) / scale)
                rounds += 1
                if status != 0:
                    notes.append(f"LP round {rounds}: {message}")
                    break
                taps = x[:n_taps] * scale
                delta = e @ taps
                slack, _ = best(known(h) + allowance, delta)
                # where the circulant bound does not clear a point, a Cholesky factorisation at one phase may;
                # the rest are solved: their own eigenvalues decide (violated points join the LP with them)
                certify(np.flatnonzero(slack < 0), allowance, delta)
                slack, _ = best(known(h) + allowance, delta)
                solve(np.flatnonzero(slack < 0))
                slack, jnew = best(known(h) + allowance, delta)
                if found is None or slack.min() > found[0]:
                    found = (float(slack.min()), taps)
                # met on the whole checked grid: done (further rounds only re-pick phases where the LP's rows
                # already hold, which on small patches cycled to max_rounds without changing the verdict)
                if found[0] >= 0:
                    break
                # cutting planes: every checked point the solution violates joins the LP (at its best phase)
                violated = np.setdiff1d(np.flatnonzero(slack < 0), rows_on)
                if violated.size == 0 and np.array_equal(jnew[rows_on], jsel[rows_on]):
                    break
                # a target the LP misses even on its own rows, with no new rows and the optimum t (< 0) moving by
                # under 1 %, is not met by more phase re-picks: the next (softer) target is tried
                t_opt = float(x[-1])
                if (target != targets[-1] and violated.size == 0 and t_opt < 0 and last_t is not None
                        and abs(t_opt - last_t) < 0.01 * abs(t_opt)):
                    break
                last_t = t_opt
                rows_on = np.union1d(rows_on, violated)
                carried[:] = [rows_on, jnew]
                jsel = jnew
            if found is None:
                solve(np.arange(theta.size))
                found = (float(best(h + allowance, np.zeros(theta.size))[0].min()), np.zeros(n_taps))
                notes.append("no correction found: the base kernel is returned")
            if found[0] >= 0:
                break
            notes.append(f"k_target {target:.3g} N/m not met on the grid (slack {found[0]:.3g} m/N)")
        return found, target

    found, target = attempt(targets, n_taps)
    met = targets.index(target) if found[0] >= 0 else len(targets)
    longer = min(int(longer_taps or 0), lags.shape[2])
    if met > 0 and longer > n_taps:
        # the next target up once more with a longer FIR, on the eigenvalues already solved (same fidelity budget)
        kept_notes = len(notes)
        more, up = attempt([targets[met - 1]], longer)
        logger.info("design_correction: %d taps for k_target %.3g N/m: %s", longer, up,
                    "met" if more[0] >= 0 else f"not met (slack {more[0]:.3g} m/N)")
        if more[0] >= 0:
            found, target = more, up
        else:
            del notes[kept_notes:]  # the shorter design stands, with its own notes
    slack, taps = found
    delta_all = _fir(taps.size, theta_all) @ taps
    # the support handed on: the rows solved exactly and those a Cholesky certified (lower bounds there: the
    # circulant bound at the other phases); the reported grid minima are over the exact rows alone
    solved = ~np.isnan(h[:, 0])
    kept = solved | raised
    # the corrected kernel's entry scale at the kept points, on the patch's crop (the margin's tolerance there;
    # not `scale`, the LP's, which attempt() reads)
    from .margin import _entry_scale

    crop = _crop(checked_tables[kept], shape, False).copy()
    ccx, ccy = (crop.shape[1] - 1) // 2, (crop.shape[2] - 1) // 2
    crop[:, ccx, ccy] += _fir(taps.size, theta[kept]) @ taps
    entry_scale = _entry_scale(crop)
    del crop
    theta, support, exact = theta[kept], known(h)[kept], solved[kept]
    e = _fir(taps.size, theta[exact])
    base_p, _ = best(support[exact], np.zeros(e.shape[0]))
    p, _ = best(support[exact], e @ taps)
    i = int(np.argmin(p))
    ratio = np.abs(delta_all) / g00
    in_band = theta_all <= t_band
    corr = Correction(
        taps=taps, sum_abs=float(np.abs(taps).sum()), dc=float(taps.sum()), in_band=float(ratio[in_band].max()),
        above_band=float(ratio[~in_band].max()), at_nyquist=float(delta_all[-1].real), k_target=float(target),
        slack=slack, base_min_p=float(base_p.min()), min_p=float(p[i]), theta_min=float(theta[exact][i]),
        lp_rounds=rounds, n_theta=int(sel.size), n_phi=int(n_phi), seconds=time.perf_counter() - t0,
        band=float(band), notes=notes, theta=theta, phi=phi, support=support, exact=exact,
        shape=tuple(int(v) for v in shape), scale=entry_scale,
    )
    logger.info("%s", corr.summary())
    for note in notes:
        logger.warning("design_correction: %s", note)
    return corr


def apply_correction(lags: np.ndarray, correction: Correction) -> np.ndarray:
    """The kept lags with the correction added to the excitation element (a copy), (X, Y, L) [m/N]."""
    out = np.array(lags, dtype=float, copy=True)
    cx, cy = (out.shape[0] - 1) // 2, (out.shape[1] - 1) // 2
    out[cx, cy, : correction.taps.size] += correction.taps
    return out


def correct_greens(ds: xr.Dataset, **options) -> tuple[xr.Dataset, Correction]:
    """The greens stage's post-fold step: design the correction for a greens dataset and apply it.

    Parameters
    ----------
    ds : xarray.Dataset
        :func:`tyreroad.greens.greens_dataset` output (``g``, ``tail_compliance``, retardation spectrum).
    **options
        :func:`design_correction` keywords.

    Returns
    -------
    (xarray.Dataset, Correction)
        A copy with ``g`` corrected, ``spring_correction[lag]`` (the taps, m/N) and attrs
        ``spring_correction_*`` (the reported numbers of :class:`Correction`); ``tail_compliance``
        unchanged (sum c = 0).
    """
    from .kernel import LayerKernel

    from .kernel import MemorySum
    from .memory import TailModel

    kernel = LayerKernel.from_greens(ds, "dynamic")
    lags = kernel.lags
    fs = float(ds.attrs["sample_rate"])
    models = kernel.memory.models if isinstance(kernel.memory, MemorySum) else (kernel.memory,)
    mem = next((m for m in models if isinstance(m, TailModel)), None)
    others = [m for m in models if m is not None and m is not mem]
    extra = None
    if others:  # e.g. a flexible belt's filters: the design must see the whole memory
        def extra(theta):
            return sum(m.frequency_response(theta * fs / (2.0 * np.pi), fs) for m in others)
    corr = design_correction(lags, None if mem is None else mem.residual_compliance,
                             () if mem is None else mem.weights, () if mem is None else mem.decays,
                             sample_rate=fs, extra_transfer=extra, **options)
    out = ds.copy()
    g = apply_correction(ds["g"].transpose("dx", "dy", "lag").values, corr)
    out["g"] = (("dx", "dy", "lag"), g, dict(ds["g"].attrs))
    taps = np.zeros(ds.sizes["lag"])
    taps[: corr.taps.size] = corr.taps
    out["spring_correction"] = ("lag", taps, {"units": "m/N", "long_name": "causal FIR added to g at the excitation "
                                              "element (tyreroad.construction.design_correction), sum 0"})
    out.attrs.update({
        "spring_correction_taps": int(corr.taps.size), "spring_correction_sum_abs": corr.sum_abs,
        "spring_correction_in_band": corr.in_band, "spring_correction_band": corr.band,
        "spring_correction_above_band": corr.above_band, "spring_correction_at_nyquist": corr.at_nyquist,
        "spring_correction_k_target": corr.k_target, "spring_correction_slack": corr.slack,
        "spring_correction_base_min_p": corr.base_min_p, "spring_correction_min_p": corr.min_p,
    })
    return out, corr


def default_kernel(material, shape, element_size: float, sample_rate: float, n_lags: int = 256, n_fft: int = 4096,
                   frf_map=None, **options) -> tuple[xr.Dataset, Correction]:
    """The default greens dataset: :func:`tyreroad.greens.greens_dataset` (today's fold) + :func:`correct_greens`.

    What the greens stage stores: ``greens_dataset(material, shape, c, fs, n_lags, n_fft)`` followed by the
    excitation element's spring-safe FIR (same 256 lags + tail, same cost per step).

    Parameters
    ----------
    material : tyreroad.material.Material
    shape : (int, int)
        Patch (nx, ny) [elements].
    element_size : float
        [m].
    sample_rate : float
        [Hz].
    n_lags, n_fft : int
        Kept lags; transform length.
    frf_map : callable, optional
        Passed to greens_dataset (None: the FRF itself, the default).
    **options
        :func:`design_correction` keywords (band [Hz], fidelity_budget, k_target [N/m], margin [m/N],
        n_taps, n_theta, n_phi).

    Returns
    -------
    (xarray.Dataset, Correction)
    """
    from .greens import greens_dataset

    ds = greens_dataset(material, shape, element_size, sample_rate, n_lags, n_fft, frf_map=frf_map)
    return correct_greens(ds, shape=tuple(shape), **options)
