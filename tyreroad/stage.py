r"""The Radau IIA-3 stage kernel: a march kernel stable for every spring from 0 to hard contact (issue 23).

Today's kernel (256 lags + creep tail, one unknown per element and step) admits an fs/2 alternation once
the springs pass k_crit ~ 2.4e4 N/m. :class:`StageKernel` is the layer's Radau IIA convolution quadrature
(:mod:`tyreroad.radau`): A-stable by construction, the eigenvalues d_k of its generating function Delta(zeta)
lie in Re s > 0 for |zeta| <= 1 (zeta != 1). Springs equal at the three stages, S = I_3 x diag(k_e), commute
with Delta's eigenvectors, so I + S^(1/2) G(Delta / h) S^(1/2) is nonsingular iff every
I + S^(1/2) G(d_k / h) S^(1/2) is, which a passive layer (mobility s G(s) positive real) guarantees for every
S >= 0. Measured on the tread (benchmarks/bench_radau_kernel.py): that margin is positive on the whole circle
for the march's own kernel (kept lags + tail), and the kernel has no fs/2 limit
(:meth:`StageKernel.nyquist_critical_stiffness` = inf). Springs that differ between the stages of a step
(a nonlinear spring, or a contact opening within a step) are not covered by this argument: the stricter
criterion (Herm(e^{i phi} B^(1/2) G(Delta / h) B^(-1/2)) > 0) does not hold for a layer with inertia, whose
compliance is not positive real. No run has shown a problem from it (every test and benchmark, contact sets
changing during ramps and holds, converges without alternation), but it is not a guarantee.

The march with stages
---------------------
Step n spans (t_{n-1}, t_n]; its unknowns are the stage forces F_{n,i} at t_{n-1} + c_i h, c = ((4 - sqrt 6)
/ 10, (4 + sqrt 6) / 10, 1). Every spring acts at every stage on its stage compression; the step's
output is the last stage (c_3 = 1, t_n). The stage system is presented to the one Newton driver
(:func:`tyreroad.newton.solve_step`) as 3 M "virtual elements", stage-major (index i M + e):

* the **loading** (:class:`StageLoading`) gives the free compression at the stage times, linear between
  the loading's samples n - 1 and n (the rest state before step 0): the loading is only known at its
  samples (exact for holds and ramps; for d = a t^2 / 2 off by a h^2 c (1 - c) / 2 <= 1e-14 m at the seed's
  rates);
* the **springs** are the patch's springs tiled three times (:func:`stage_springs`);
* the **substrate** (:class:`StageDenseSubstrate`) holds the 3 M x 3 M block matrix W_0 and solves the
  loaded block directly (LU, kept across corrections: springs loaded or unloaded since the factorisation are
  exact Woodbury columns on it, and nonlinear springs, whose stiffnesses change at every Newton iteration,
  refine on it instead of refactorising; a hold on linear springs factorises once);
* the **history** is sum_{l = 1}^{L-1} W_l F_{n-l} over all stages (:class:`StageFFTHistory`, 2-D FFT in
  space, 9 block entries per lag) plus the creep beyond the kept lags (:class:`StageTailHistory`);
* the **recorder** (:class:`StageRecorder`) keeps the last stage of every step, so a run's result has the
  shape and meaning of any other dynamic run's (forces, compressions, displacements at t_n).

The march itself (:func:`tyreroad.contact.march`) is unchanged: :meth:`StageKernel.march_view` hands it
the stacked loading, springs and recorder (:meth:`tyreroad.kernel.LayerKernel.march_view` returns them
as given, so every single-stage run is bit-identical).

Memory beyond the kept lags
---------------------------
The tread creeps for seconds. The quasi-static layer compliance scales with 1 / E(s) (nu does not depend
on frequency), so at long times

    G(s; dx, dy) ~ Q(dx, dy) / E(s),   Q = G(0) E(0),   1 / E(s) ~ J_g + sum_k J_k / (1 + s tau_k)

(the material's retardation fit, :func:`tyreroad.memory.fit_retardation_spectrum`). The kept block
weights W_0 ... W_{L-1} are the CQ weights of the exact G; lags l >= L are the exact Radau-CQ images of
the retardation terms, W_l = Q sum_k (J_k / tau_k) u_k r_k^(l-1) v_k^T (:func:`tyreroad.radau.rational_images`):
one scalar state per retardation term and element, fed by a delay line of the last L stage force fields
(cost per step independent of the run's length). What this cuts off is the CQ weights of the remainder
G(s) - R sum_k J_k / (1 + s tau_k) beyond lag L (inertia and the creep fit's error), where the spatial
factors R[dx, dy, i] (one per output stage) replace Q so that a held force relaxes to exactly G(0) at every
stage (:meth:`StageTail.with_sum_rule`, the sum rule today's tail keeps): :meth:`StageKernel.truncation`
measures it (tread, 256 lags, 72 retardation terms: 1e-6 of W_0 summed over lags 256 ... 1023; the step
response to a held force within 2e-7 of G(0) of 4096 directly computed weights over 80 ms).

Hard contact is the springs' stiff limit (linear springs of 1e10 N/m, :func:`tyreroad.springs.linear_tables`),
as everywhere in the package: the same Newton driver and dense direct solve converge on it.

Construction
------------
``StageKernel.from_material(material, shape, element_size, sample_rate, n_lags=256)`` -- a
:class:`tyreroad.kernel.LayerKernel` (``static=False``) that any run takes where a dynamic kernel goes
(:func:`tyreroad.contact.run_loading_path`, :func:`tyreroad.contact.solve_path`). Dense path only (patches
of up to :data:`DENSE_LIMIT` elements): a matrix-free stage substrate for footprint-size patches is not
built.
"""

from __future__ import annotations

import dataclasses
import functools
import logging
import math
from dataclasses import dataclass, field

import numpy as np
import scipy.fft
from numba import njit, prange
import scipy.linalg

from . import checks
from .history import HistorySum, _StepCounter
from .influence import offset_matrix
from .kernel import LayerKernel
from .layer import backing_force
from .memory import RetardationSpectrum, fit_retardation_spectrum
from .radau import RADAU_C, STAGES, radau_weights, rational_images, stage_transfer
from .solver import SolverSettings
from .springs import SpringTable

logger = logging.getLogger(__name__)

__all__ = ["DENSE_LIMIT", "STAGE_CONSTRUCTION", "STAGE_MARGIN_METHOD", "radau_greens", "stage_variables",
           "StageTail", "StageKernel", "StageLoading", "StageRecorder", "StageDenseSubstrate",
           "StageFFTHistory", "StageTailHistory", "stage_springs", "stage_table"]

#: Largest patch (elements) of the dense stage substrate (3 M x 3 M matrix: 1600 elements = 184 MB).
DENSE_LIMIT = 1600


def _crop(table: np.ndarray, shape) -> np.ndarray:
    """A centred offset table (2 n - 1, 2 m - 1, ...) cropped to a patch's offsets."""
    nx, ny = shape
    if table.shape[0] < 2 * nx - 1 or table.shape[1] < 2 * ny - 1:
        raise ValueError(f"stage kernel: the table covers a smaller patch than {tuple(shape)}")
    cx, cy = (table.shape[0] - 1) // 2, (table.shape[1] - 1) // 2
    return table[cx - (nx - 1): cx + nx, cy - (ny - 1): cy + ny]


def stage_table(weights: np.ndarray, shape) -> np.ndarray:
    """Block weights at the unique offsets (L, 3, 3, n_offsets) -> offset tables (2 nx - 1, 2 ny - 1, L, 3, 3)."""
    from .greens import offset_table_index

    _, _, index = offset_table_index(shape)
    return np.ascontiguousarray(np.moveaxis(weights[..., index], (3, 4), (0, 1)))


# --------------------------------------------------------------------------------------------
# memory beyond the kept lags
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class StageTail:
    """Lags l >= L of the stage kernel: row i of W_l is R_i[dx, dy] times that of sum_k amplitude_k u_k r_k^(l-1) v_k^T
    (the exact Radau-CQ images of the creep's retardation terms; module docstring).

    Attributes
    ----------
    shape_table : numpy.ndarray
        R[dx, dy, i] [m/N x Pa], the spatial factor of output stage i (offsets -(n-1) ... n-1): Q = G(0) E(0) for
        every stage from the creep fit, then made exact for held forces by :meth:`with_sum_rule`.
    amplitude : numpy.ndarray
        J_k / tau_k [1/(Pa s)].
    rates : numpy.ndarray
        1 / tau_k [1/s].
    u, v : numpy.ndarray
        (K, 3) each [1 and s].
    r : numpy.ndarray
        R(-h / tau_k), (K,).
    delay : int
        L.
    """

    shape_table: np.ndarray
    amplitude: np.ndarray
    rates: np.ndarray
    u: np.ndarray
    r: np.ndarray
    v: np.ndarray
    delay: int

    @classmethod
    def from_spectrum(cls, shape_table, spectrum: RetardationSpectrum, sample_rate: float, n_lags: int,
                      cutoff: float = 1e-14) -> "StageTail":
        """The images of every retardation term whose weights beyond lag L are above ``cutoff`` of the relaxed
        compliance (terms much faster than the kept lags are dropped)."""
        dt = 1.0 / float(sample_rate)
        rates = 1.0 / spectrum.times
        _, u, r, v = rational_images(rates, dt)
        amplitude = spectrum.compliances / spectrum.times
        # sum over l >= L of e_3^T W_l 1 per term: amplitude (v.1) r^(L-1) / (1 - r) (u_3 = r)
        beyond = amplitude * v.sum(axis=1) * r ** (n_lags - 1) / np.maximum(1.0 - r, 1e-300)
        keep = np.abs(beyond) > cutoff * spectrum.relaxed_compliance
        q = np.asarray(shape_table, dtype=float)
        if q.ndim == 2:
            q = np.repeat(q[:, :, None], STAGES, axis=2)
        return cls(q, amplitude[keep], rates[keep], u[keep], r[keep], v[keep], int(n_lags))

    def held_sum(self) -> np.ndarray:
        """sum_{l >= L} (block weights) 1 per unit R, (3,): the tail's share of a force held at every stage."""
        p = self.amplitude * self.r ** (self.delay - 1) / (1.0 - self.r) * self.v.sum(axis=1)
        return p @ self.u

    def with_sum_rule(self, kept_table: np.ndarray, static_table: np.ndarray) -> "StageTail":
        """The tail whose spatial factors R[dx, dy, i] make the response to a held force exact at every stage:
        sum_{l < L} (W_l 1)_i + R_i held_sum_i = G(0) at every offset (the full CQ has sum_l W_l 1 = G(0) 1, as
        Delta(1) 1 = 0; today's kernel's tail keeps the same sum rule). The creep fit alone misses it by its fit
        error: 5e-5 of the held force for a one-term Maxwell tread on 128 lags. Where the tail carries nothing
        (no slow terms) Q stays."""
        return self.with_kept_sums(kept_table.sum(axis=(2, 4)), static_table)  # (x, y, i): over lags and stages in

    def with_kept_sums(self, kept, static) -> "StageTail":
        """:meth:`with_sum_rule` from the kept weights' sums: ``kept`` [..., i] = sum_{l < L} (W_l 1)_i per output
        stage i and ``static`` [...] = G(0), over any spatial layout (offset tables, or block matrices of a patterned
        tread, :mod:`tyreroad.pattern_dynamic`)."""
        total = self.held_sum()
        if not np.all(total > 0.0):
            return self
        r = (np.asarray(static, dtype=float)[..., None] - np.asarray(kept, dtype=float)) / total
        return dataclasses.replace(self, shape_table=r)

    def block_weights(self, lags) -> np.ndarray:
        """sum_k amplitude_k u_k r_k^(l-1) v_k^T at the given lags (>= 1), (n, 3, 3) (row i times R_i for the
        kernel)."""
        lags = np.asarray(lags)
        p = self.amplitude[None, :] * self.r[None, :] ** (lags[:, None] - 1.0)
        return np.einsum("nk,ki,kj->nij", p, self.u, self.v)

    def block_symbol(self, theta) -> np.ndarray:
        """sum_{l >= L} (block weights) e^{-i theta l}, (n_theta, 3, 3) (row i times R_i for the kernel)."""
        z = np.exp(-1j * np.asarray(theta, dtype=float))
        p = self.amplitude[None, :] * self.r[None, :] ** (self.delay - 1) * z[:, None] ** self.delay / (
            1.0 - self.r[None, :] * z[:, None])
        return np.einsum("nk,ki,kj->nij", p, self.u, self.v)

    def history(self, shape) -> "StageTailHistory":
        return StageTailHistory(self, shape)

    def describe(self) -> str:
        return f"Radau-CQ creep tail from lag {self.delay}, {self.r.size} retardation terms"


# --------------------------------------------------------------------------------------------
# spatial FFT convolution of stage fields
# --------------------------------------------------------------------------------------------
class _Spatial:
    """Linear 2-D convolution of (stage) fields with even offset tables on a padded grid."""

    def __init__(self, shape):
        nx, ny = shape
        self.shape = (nx, ny)
        self.padded = (scipy.fft.next_fast_len(2 * nx - 1, real=True), scipy.fft.next_fast_len(2 * ny - 1, real=True))

    def table_spectrum(self, table: np.ndarray) -> np.ndarray:
        """rfft2 of tables (2 nx - 1, 2 ny - 1, ...) placed circularly: real for even tables, (px, py//2+1, ...)."""
        nx, ny = self.shape
        px, py = self.padded
        t = np.zeros((px, py) + table.shape[2:])
        ix = np.arange(-(nx - 1), nx) % px
        iy = np.arange(-(ny - 1), ny) % py
        t[np.ix_(ix, iy)] = table
        spec = scipy.fft.rfft2(t, axes=(0, 1))
        if np.abs(spec.imag).max() > 1e-12 * max(np.abs(spec.real).max(), 1e-300):
            raise ValueError("stage kernel: offset tables must be even in dx and dy (the layer's are)")
        return spec.real

    def spectrum(self, fields: np.ndarray) -> np.ndarray:
        """rfft2 of fields (..., nx, ny) zero-padded, (..., px, py//2+1)."""
        return scipy.fft.rfft2(fields, s=self.padded, axes=(-2, -1))

    def field(self, spec: np.ndarray) -> np.ndarray:
        nx, ny = self.shape
        return scipy.fft.irfft2(spec, s=self.padded, axes=(-2, -1))[..., :nx, :ny]


@njit(cache=True, parallel=True, fastmath=True)
def _stage_accumulate(g, ring_re, ring_im, start, n_terms, out):  # pragma: no cover - numba
    """out[k, i] = sum_{t < n_terms} g[k, i, t] (ring_re + i ring_im)[k, start + t] as (re, im) in out[k, i, :]:
    real kernel spectra, contiguous runs of the ring (the window of a step never wraps: the ring is doubled),
    parallel over frequency bins; fastmath only reorders the sums (inputs are finite)."""
    n_bins = g.shape[0]
    for k in prange(n_bins):
        r = ring_re[k, start:start + n_terms]
        q = ring_im[k, start:start + n_terms]
        for i in range(g.shape[1]):
            gi = g[k, i, :n_terms]
            a = 0.0
            b = 0.0
            for t in range(n_terms):
                a += gi[t] * r[t]
                b += gi[t] * q[t]
            out[k, i, 0] = a
            out[k, i, 1] = b


class _BlockApply:
    """v -> W v for a block offset table W[dx, dy, i, j] (stage-major vectors of 3 M), by 2-D FFT."""

    def __init__(self, table: np.ndarray, shape):
        self.shape = tuple(shape)
        self._fft = _Spatial(shape)
        self._spec = np.ascontiguousarray(np.moveaxis(self._fft.table_spectrum(table), (2, 3), (0, 1)))

    def __call__(self, v: np.ndarray) -> np.ndarray:
        nx, ny = self.shape
        spec = self._fft.spectrum(np.asarray(v, dtype=float).reshape(STAGES, nx, ny))
        return self._fft.field(np.einsum("ijxy,jxy->ixy", self._spec, spec)).reshape(-1)


class StageFFTHistory:
    """h_n = sum_{l=1}^{min(n, L-1)} W_l F_{n-l} over the stage fields, by 2-D FFT in space.

    The block tables' spectra (real: the tables are even) are held as (bins, 3, 3 (L - 1)) and a doubled
    ring of past stage spectra as (bins, 2 (L - 1) 3) (real and imaginary parts apart), so that the lags of a step are one
    contiguous window and the sum streams both (a numba kernel parallel over bins, bins x 3 x 3 L x 2 per step).

    Parameters
    ----------
    table : numpy.ndarray
        W[dx, dy, l, i, j] [m/N], offsets of the patch (2 nx - 1, 2 ny - 1, L, 3, 3).
    shape : tuple of int
        Patch (nx, ny).
    """

    def __init__(self, table: np.ndarray, shape):
        nx, ny = shape
        self.shape = (nx, ny)
        self.n_lags = table.shape[2]
        self._depth = self.n_lags - 1
        self._fft = _Spatial(shape)
        spec = self._fft.table_spectrum(table[:, :, 1:])  # (px, pyh, L-1, 3, 3)
        self._bins = spec.shape[0] * spec.shape[1]
        self._spec_shape = spec.shape[:2]
        # g[k, i, l * 3 + j]
        self._g = np.ascontiguousarray(spec.reshape(self._bins, self._depth, STAGES, STAGES)
                                       .transpose(0, 2, 1, 3).reshape(self._bins, STAGES, self._depth * STAGES))
        self._ring_re = np.zeros((self._bins, 2 * max(self._depth, 1) * STAGES))
        self._ring_im = np.zeros((self._bins, 2 * max(self._depth, 1) * STAGES))
        self._acc = np.empty((self._bins, STAGES, 2))
        self._pos = 0
        self._steps = _StepCounter()

    @property
    def nbytes(self) -> int:
        return self._g.nbytes + self._ring_re.nbytes + self._ring_im.nbytes

    def record(self, n: int, force: np.ndarray) -> None:
        """Store the stage forces F_n [N], shape (3 M,) stage-major."""
        self._steps.check_record(n, "StageFFTHistory")
        if self._depth == 0:
            return
        nx, ny = self.shape
        spec = self._fft.spectrum(np.asarray(force, dtype=float).reshape(STAGES, nx, ny))
        spec = spec.reshape(STAGES, self._bins).T  # (bins, 3)
        d = self._depth
        self._pos = (self._pos - 1) % d
        for p in (self._pos, self._pos + d):
            self._ring_re[:, p * STAGES:(p + 1) * STAGES] = spec.real
            self._ring_im[:, p * STAGES:(p + 1) * STAGES] = spec.imag

    def displacement(self, n: int) -> np.ndarray:
        """h_n [m], shape (3 M,) stage-major."""
        self._steps.check_displacement(n, "StageFFTHistory")
        nx, ny = self.shape
        terms = min(n, self._depth)
        if terms == 0:
            return np.zeros(STAGES * nx * ny)
        acc = self._acc
        _stage_accumulate(self._g, self._ring_re, self._ring_im, self._pos * STAGES, terms * STAGES, acc)  # (bins, 3, 2)
        spec = (acc[..., 0] + 1j * acc[..., 1]).T.reshape((STAGES,) + self._spec_shape)
        return self._fft.field(spec).reshape(-1)


class StageTailRecursion:
    """Lags l >= L of a stage kernel by recursion (:class:`StageTail`): per term and element one state
    s_n = r s_{n-1} + v^T F_{n-L}, and the modal field z_n = sum_k amplitude_k r_k^(L-1) u_k s_{k,n} (3, M).
    Subclasses map z_n to the displacement with the tail's spatial factors (:meth:`_spatial`): offset tables by
    FFT (:class:`StageTailHistory`) or block matrices (:class:`tyreroad.pattern_dynamic.PatternTailHistory`)."""

    def __init__(self, tail: StageTail, n_elements: int):
        self.m = int(n_elements)
        self.delay = int(tail.delay)
        self._r = tail.r[:, None]
        self._feed = np.ascontiguousarray(tail.v)  # (K, 3)
        self._out = np.ascontiguousarray((tail.amplitude * tail.r ** (self.delay - 1))[None, :] * tail.u.T)  # (3, K)
        self._states = np.zeros((tail.r.size, self.m))
        self._delay_line = np.zeros((self.delay, STAGES, self.m))
        self._updated_for = -1
        self._steps = _StepCounter()

    def _advance(self, n: int) -> None:
        if n >= self.delay and self._updated_for != n:
            self._states *= self._r
            self._states += self._feed @ self._delay_line[n % self.delay]
            self._updated_for = n

    def _spatial(self, z: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        """Stage i of the displacement [m], (3 M,) stage-major, from the modal field z (3, M)."""
        raise NotImplementedError

    def displacement(self, n: int) -> np.ndarray:
        self._steps.check_displacement(n, type(self).__name__)
        if n < self.delay or self._states.shape[0] == 0:
            return np.zeros(STAGES * self.m)
        self._advance(n)
        return self._spatial(self._out @ self._states)

    def record(self, n: int, force: np.ndarray) -> None:
        self._steps.check_record(n, type(self).__name__)
        self._advance(n)
        self._delay_line[n % self.delay] = np.asarray(force, dtype=float).reshape(STAGES, -1)


class StageTailHistory(StageTailRecursion):
    """The layer's stage tail (:class:`StageTailRecursion`): stage i of h_n = R_i (x) z_i, by 2-D FFT in space."""

    def __init__(self, tail: StageTail, shape):
        nx, ny = shape
        self.shape = (nx, ny)
        super().__init__(tail, nx * ny)
        self._fft = _Spatial(shape)
        self._q = np.moveaxis(self._fft.table_spectrum(_crop(tail.shape_table, shape)), 2, 0)  # (3, px, pyh)

    def _spatial(self, z: np.ndarray) -> np.ndarray:
        return self._fft.field(self._fft.spectrum(z.reshape((STAGES,) + self.shape)) * self._q).reshape(-1)


# --------------------------------------------------------------------------------------------
# substrate
# --------------------------------------------------------------------------------------------
class StageDenseSubstrate:
    """The stage system's instantaneous operator W_0 (3 M x 3 M, stage-major) and a direct Newton solve.

    Corrections solve J(k) delta = -r, J(k) = I + W_0 diag(k), over the whole patch (k = 0 off the loaded set:
    there the row gives delta = -r - (W_0 diag(k) delta), as the march needs). J is block triangular: only its
    loaded block is factored (LU with partial pivoting; W_0 couples the stages and is not symmetric). One
    factorisation serves many corrections:

    * springs that are loaded or unloaded, or change a lot, since the factorisation (a growing contact: new
      elements at every step of an indentation) are a low-rank change W_0[:, C] diag(dk) of J; it is solved
      exactly by the Woodbury identity, M^-1 b = y - Z S^-1 y_C with y = J_0^-1 b, Z = J_0^-1 W_0[:, C] (one
      triangular solve per new column, kept) and S = diag(1 / dk) + Z_C, up to :data:`MAX_UPDATES` columns;
    * stiffnesses that change a little (nonlinear springs: every Newton iteration) are solved by iterative
      refinement, delta <- delta + M^-1 (-r - J delta), to ||J delta + r||_2 <= :data:`REFINE_FORCING` ||r||_2
      (inexact Newton) and in the polishing correction to :data:`REFINE_TOLERANCE` ||r||_2 (near-exact, as
      the direct solve), at a few triangular solves and products instead of an O((3 M)^3) factorisation.

    The factors are renewed when the updates would exceed :data:`MAX_UPDATES` columns, or the refinement
    contracts by less than :data:`REFINE_CONTRACTION` per sweep or needs more than :data:`REFINE_SWEEPS`.
    """

    #: Relative linear residual the refinement stops at in the Newton driver's polishing correction (the direct
    #: solve's is ~1e-15), so that a converged step is the same to round-off whatever its path.
    REFINE_TOLERANCE = 1e-12
    #: ... and in the corrections before it (inexact Newton, as the FFT path's ``solver.krylov_forcing``): a
    #: correction needs no more digits than the next Newton residual keeps.
    REFINE_FORCING = 1e-6
    #: Largest residual ratio per sweep accepted (above it the factors are renewed at once).
    REFINE_CONTRACTION = 0.2
    #: Most refinement sweeps before the factors are renewed.
    REFINE_SWEEPS = 8
    #: Most Woodbury columns (stage unknowns whose spring was loaded, unloaded or changed by more than
    #: :data:`UPDATE_CHANGE` since the factorisation) before the factors are renewed: 48 columns cost 48 triangular
    #: solves, about a third of a factorisation of the 20 x 20 patch's 1200 unknowns.
    MAX_UPDATES = 48
    #: A stiffness that changed by more than this fraction of the larger of its old and new values joins the
    #: Woodbury columns instead of being left to the refinement.
    UPDATE_CHANGE = 0.5

    def __init__(self, matrix: np.ndarray, apply=None):
        self.g0 = np.ascontiguousarray(matrix, dtype=float)
        # W_0 v for whole vectors: the dense product, or (from_table) the same by FFT, 4x cheaper on 20 x 20
        self._apply = apply if apply is not None else self.g0.__matmul__
        # the Newton driver scales its unknown at first contact with it (tyreroad.newton.solve_step): stiff
        # springs crossing zeta = 0 keep a unit diagonal of dR/dx (the stages' self compliances differ by
        # less than 2: their mean)
        self.self_compliance = float(np.mean(np.diag(self.g0)))
        self._lu = None  # factors of J(k_base)'s loaded block
        self._active = None
        self._k_base = None
        self._cols = np.zeros(0, dtype=int)  # the Woodbury columns C, their dk, Z = J0^-1 W_0[:, C], LU of S
        self._dk = np.zeros(0)
        self._z = np.zeros((self.g0.shape[0], 0))
        self._s_lu = None
        self.factorisations = 0
        self.refinements = 0  # corrections solved by refinement on older factors
        self.updates = 0  # Woodbury columns added

    @classmethod
    def from_table(cls, table0: np.ndarray, shape) -> "StageDenseSubstrate":
        """From the lag-0 block table W_0[dx, dy, i, j] of the patch."""
        m = shape[0] * shape[1]
        big = np.empty((STAGES * m, STAGES * m))
        for i in range(STAGES):
            for j in range(STAGES):
                big[i * m:(i + 1) * m, j * m:(j + 1) * m] = offset_matrix(table0[:, :, i, j])
        return cls(big, _BlockApply(table0, shape))

    def instant(self, force: np.ndarray) -> np.ndarray:
        """W_0 F [m] (by FFT for a substrate from a table; gathering loaded columns costs more than zeros)."""
        return self._apply(force)

    def begin_step(self) -> None:
        """Nothing to reset."""

    def correction(self, stiffness: np.ndarray, residual: np.ndarray, polish: bool) -> tuple[np.ndarray, int]:
        k = np.asarray(stiffness, dtype=float)
        rhs = -np.asarray(residual, dtype=float)
        if not k.any():
            return rhs, 0
        if self._lu is None or not self._update(k):
            return self._refactor(k, rhs), 0
        x = self._solve(rhs)
        if not self._cols.size and np.array_equal(self._k_base, k):
            return x, 0  # the factors' own stiffnesses: the direct solve
        x = self._refine(k, rhs, x, self.REFINE_TOLERANCE if polish else self.REFINE_FORCING)
        return (x if x is not None else self._refactor(k, rhs)), 0

    def _refactor(self, k: np.ndarray, rhs: np.ndarray) -> np.ndarray:
        # J(k) is block triangular (its unloaded columns are those of I): only the loaded block is factored
        active = np.flatnonzero(k)
        jac = self.g0[np.ix_(active, active)] * k[active][None, :]
        jac[np.diag_indices_from(jac)] += 1.0
        self._lu = scipy.linalg.lu_factor(jac, overwrite_a=True, check_finite=False)
        self._active = active
        self._k_base = k.copy()
        self._cols, self._dk = np.zeros(0, dtype=int), np.zeros(0)
        self._z, self._s_lu = np.zeros((k.size, 0)), None
        self.factorisations += 1
        return self._base_solve(rhs)

    def _base_solve(self, b: np.ndarray) -> np.ndarray:
        """J(k_base)^-1 b for a vector, or the columns of an (n, c) matrix: the loaded block's LU, then the
        unloaded rows x_I = b_I - (W_0 diag(k) x)_I."""
        active, ka = self._active, self._k_base[self._active]
        xa = scipy.linalg.lu_solve(self._lu, b[active], check_finite=False)
        if b.ndim == 1:
            step = np.zeros(b.size)
            step[active] = ka * xa
            out = b - self._apply(step)
        else:
            out = b - self.g0[:, active] @ (ka[:, None] * xa)
        out[active] = xa
        return out

    def _update(self, k: np.ndarray) -> bool:
        """Bring the Woodbury columns up to ``k``: every unknown whose spring was loaded or unloaded since the
        factorisation, or changed by more than :data:`UPDATE_CHANGE`, is a column (dk = k - k_base); False if
        they would exceed :data:`MAX_UPDATES` (the caller refactors)."""
        base = self._k_base
        big = np.abs(k - base) > self.UPDATE_CHANGE * np.maximum(np.abs(k), np.abs(base))
        cols = np.union1d(self._cols, np.flatnonzero(big))
        cols = cols[k[cols] != base[cols]]
        if cols.size > self.MAX_UPDATES:
            return False
        if cols.size:
            have = np.isin(cols, self._cols)
            z = np.empty((k.size, cols.size))
            if have.any():
                z[:, have] = self._z[:, np.searchsorted(self._cols, cols[have])]
            new = cols[~have]
            if new.size:
                z[:, ~have] = self._base_solve(self.g0[:, new])
                self.updates += int(new.size)
            dk = k[cols] - base[cols]
            s = z[cols, :].copy()
            s[np.diag_indices_from(s)] += 1.0 / dk
            self._s_lu = scipy.linalg.lu_factor(s, check_finite=False)
            self._z, self._dk = z, dk
        else:
            self._z, self._dk, self._s_lu = np.zeros((k.size, 0)), np.zeros(0), None
        self._cols = cols
        return True

    def _solve(self, b: np.ndarray) -> np.ndarray:
        """M^-1 b for M = J(k_base) + W_0[:, C] diag(dk) E_C^T (Woodbury on the kept factors)."""
        y = self._base_solve(b)
        if self._cols.size:
            y -= self._z @ scipy.linalg.lu_solve(self._s_lu, y[self._cols], check_finite=False)
        return y

    def _refine(self, k: np.ndarray, rhs: np.ndarray, x: np.ndarray, tolerance: float) -> np.ndarray | None:
        """J(k) x = rhs to ||J x - rhs||_2 <= tolerance ||rhs||_2 by refinement from ``x`` (preconditioned with
        :meth:`_solve`); None if it does not converge fast enough (the caller refactors)."""
        previous = float(np.linalg.norm(rhs))
        target = tolerance * previous
        for sweep in range(self.REFINE_SWEEPS + 1):
            r = rhs - x - self._apply(k * x)
            norm = float(np.linalg.norm(r))
            if norm <= target:
                self.refinements += int(sweep > 0)
                return x
            if norm > self.REFINE_CONTRACTION * previous or sweep == self.REFINE_SWEEPS:
                return None
            previous = norm
            x = x + self._solve(r)
        return None

    def tangent(self, stiffness):
        raise NotImplementedError("the stage substrate belongs to a dynamic kernel: no quasi-static tangent")


# --------------------------------------------------------------------------------------------
# the march's view: stacked loading, springs, recorder
# --------------------------------------------------------------------------------------------
class StageLoading:
    """A loading seen at the stage times: free compression (1 - c_i) b[n-1] + c_i b[n], stage-major (3 M,)."""

    def __init__(self, loading):
        self.loading = loading
        self.n_steps = loading.n_steps
        self.shape = loading.shape
        self.time = loading.time
        self._cache = (None, None)

    def _sample(self, n: int) -> np.ndarray:
        if self._cache[0] == n:
            return self._cache[1]
        b = self.loading.rest_compression() if n < 0 else self.loading.free_compression(n)
        b = np.asarray(b, dtype=float)
        self._cache = (n, b)
        return b

    def free_compression(self, n: int) -> np.ndarray:
        prev = self._sample(n - 1)
        cur = self._sample(n)
        return np.concatenate([(1.0 - c) * prev + c * cur for c in RADAU_C])

    def rest_compression(self) -> np.ndarray:
        return np.tile(np.asarray(self.loading.rest_compression(), dtype=float), STAGES)

    def describe(self, n: int) -> str:
        return self.loading.describe(n)

    def prescribed(self):
        return self.loading.prescribed()

    def done(self, n: int, force: np.ndarray) -> bool:
        m = force.size // STAGES
        return self.loading.done(n, force[-m:])

    def unfinished(self, n: int):
        return self.loading.unfinished(n)


def stage_springs(springs: SpringTable) -> SpringTable:
    """The patch's springs tiled over the three stages (stage-major); springs with a force history (QLV,
    :class:`tyreroad.qlv.MarchSprings`) give their stage form (``for_stages``)."""
    for_stages = getattr(springs, "for_stages", None)
    if for_stages is not None:
        return for_stages(RADAU_C)

    def tile(a):
        a = np.asarray(a)
        return np.ascontiguousarray(np.tile(a.reshape(-1, a.shape[-1]), (STAGES, 1)))

    return dataclasses.replace(springs, stiffness=tile(springs.stiffness), force=tile(springs.force))


class StageRecorder:
    """Keeps the last stage (t_n) of every step in the recorder of the patch (a :class:`RunRecorder`)."""

    def __init__(self, recorder, loading):
        self.recorder = recorder
        self.loading = loading
        self.wants_tangent = False

    def store(self, n: int, step, displacement: np.ndarray, tangent=None) -> None:
        m = step.force.size // STAGES
        last = dataclasses.replace(step, zeta=step.zeta[-m:], force=step.force[-m:], stiffness=step.stiffness[-m:])
        self.recorder.store(n, last, displacement[-m:], None)

    def result(self, loading=None, n_steps: int | None = None):
        return self.recorder.result(self.loading, n_steps)

    def __getattr__(self, name):
        if name == "recorder":  # not yet set (copy, unpickling)
            raise AttributeError(name)
        return getattr(self.recorder, name)


# --------------------------------------------------------------------------------------------
# the kernel
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class StageKernel(LayerKernel):
    """The Radau IIA-3 CQ kernel of the layer (module docstring): a dynamic :class:`LayerKernel` whose march
    solves three stages per step.

    Extra attributes
    ----------------
    stage_lags : numpy.ndarray
        W[dx, dy, l, i, j] [m/N], (2 nx - 1, 2 ny - 1, L, 3, 3): the kept block weights.
    stage_tail : StageTail or None
        Lags >= L (the creep).
    static_table : numpy.ndarray
        G(0)[dx, dy] [m/N], the relaxed layer.

    ``lags`` (what :class:`LayerKernel` knows) holds sum_j W_l[3, j]: the step's end value for a force held
    constant over each step -- an honest single-stage summary, not what the march uses.
    """

    stage_lags: np.ndarray = field(default=None, repr=False)
    stage_tail: StageTail | None = field(default=None, repr=False)
    static_table: np.ndarray = field(default=None, repr=False)

    @classmethod
    def from_material(cls, material, shape, element_size: float, sample_rate: float, n_lags: int = 256,
                      response=None, spectrum: RetardationSpectrum | None = None,
                      n_fft_backing: int = 4096) -> "StageKernel":
        """The Radau IIA-3 CQ kernel of a material's layer on patches up to ``shape``.

        Parameters
        ----------
        material : tyreroad.material.Material
            laplace_modulus(s), modulus(omega), poisson, density, thickness.
        shape : tuple of int
            The largest patch (nx, ny) it serves (smaller ones are cropped).
        element_size : float
            c [m].
        sample_rate : float
            fs [Hz] (h = 1 / fs, one step = three stages).
        n_lags : int
            L, the kept block weights (default 256: their truncation is measured by :meth:`truncation`).
        response : optional
            The exact frequency response (:class:`tyreroad.greens.ElementFRF`) for K*(f), as for LayerKernel.
        spectrum : RetardationSpectrum, optional
            The creep fit (default :func:`tyreroad.memory.fit_retardation_spectrum` up to fs / 2).
        """
        # the construction's code (element FRF, offsets) is imported here, not at module level: a contact run reads
        # the stage kernel from its greens file (from_greens) and runs none of it (tyreroad.provenance)
        from .cq import _element_laplace_fn, exact_frf
        from .greens import offset_table_index, unique_offsets

        nx, ny = (checks.integer(f"shape[{i}]", v) for i, v in enumerate(shape))
        c = checks.real("element_size", element_size, positive=True)
        fs = checks.real("sample_rate", sample_rate, positive=True)
        n_lags = checks.integer("n_lags", n_lags, minimum=2)
        offsets = unique_offsets((nx, ny)) * c
        weights = radau_weights(_element_laplace_fn(material, offsets, c), n_lags, 1.0 / fs)
        table = stage_table(weights, (nx, ny))
        g_static = exact_frf(material, (nx, ny), c, [0.0])[0].real
        _, _, index = offset_table_index((nx, ny))
        static_table = g_static[index]
        if spectrum is None:
            spectrum = fit_retardation_spectrum(material, fs / 2)
        tail = StageTail.from_spectrum(static_table / spectrum.relaxed_compliance, spectrum, fs, n_lags)
        tail = tail.with_sum_rule(table, static_table)
        backing = functools.partial(backing_force, material=material, sample_rate=fs, n_fft=n_fft_backing)
        return cls.from_tables(table, fs, tail, static_table, element_size=c, response=response, backing=backing,
                               name=f"{material.name} Radau IIA-3")

    @classmethod
    def from_tables(cls, table, sample_rate: float, tail: StageTail | None, static_table, **kwargs) -> "StageKernel":
        """From block tables W[dx, dy, l, i, j], the tail and G(0)[dx, dy] (kwargs as :class:`LayerKernel`)."""
        table = np.asarray(table, dtype=float)
        if table.ndim != 5 or table.shape[3:] != (STAGES, STAGES):
            raise ValueError(f"stage kernel: expected W[dx, dy, lag, 3, 3], got shape {table.shape}")
        lags = table[:, :, :, 2, :].sum(axis=-1)
        return cls(lags, False, float(sample_rate), None, stage_lags=table, stage_tail=tail,
                   static_table=np.asarray(static_table, dtype=float), **kwargs)

    @classmethod
    def from_greens(cls, greens, material=None, response=None) -> "StageKernel":
        """The stage kernel of a greens dataset written with ``greens.construction: radau`` (:func:`radau_greens`);
        what :meth:`tyreroad.kernel.LayerKernel.from_greens` returns for a dynamic run on such a file. Marches
        bit-identically to :meth:`from_material` of the same material, patch, rate and lags.

        Raises
        ------
        ValueError
            If the dataset holds no stage kernel (another construction's file).
        """
        if "stage_weight" not in greens:
            raise ValueError(f"greens {greens.attrs.get('material', '?')}: no stage kernel (stage_weight) in a file "
                             f"of construction {greens.attrs.get('construction')!r}; expected one written with "
                             "greens.construction: radau")
        fs = float(greens.attrs["sample_rate"])
        table = greens["stage_weight"].transpose("dx", "dy", "lag", "stage_out", "stage_in").values
        static = greens["stage_static"].transpose("dx", "dy").values
        tail = None
        if "stage_tail_r" in greens:
            tail = StageTail(
                np.asarray(greens["stage_tail_shape"].transpose("dx", "dy", "stage_out").values, dtype=float),
                np.asarray(greens["stage_tail_amplitude"].values, dtype=float),
                np.asarray(greens["stage_tail_rate"].values, dtype=float),
                np.asarray(greens["stage_tail_u"].transpose("stage_term", "stage_out").values, dtype=float),
                np.asarray(greens["stage_tail_r"].values, dtype=float),
                np.asarray(greens["stage_tail_v"].transpose("stage_term", "stage_in").values, dtype=float),
                int(greens.attrs["stage_tail_delay"]),
            )
        name = str(greens.attrs.get("material", getattr(material, "name", "kernel")))
        c = greens.attrs.get("element_size")
        backing = None
        if material is not None:
            n_fft = max(int(float(greens.attrs.get("n_fft", 4096))), 4096)
            backing = functools.partial(backing_force, material=material, sample_rate=fs, n_fft=n_fft)
        k_crit = float(greens["critical_stiffness"].values) if "critical_stiffness" in greens else None
        return cls.from_tables(table, fs, tail, static, element_size=None if c is None else float(c),
                               response=response, backing=backing, name=f"{name} Radau IIA-3",
                               critical_stiffness=k_crit, construction=STAGE_CONSTRUCTION)

    # ------------------------------------------------------------------ the march
    def stage_table(self, shape) -> np.ndarray:
        """The kept block weights cropped to a patch (2 nx - 1, 2 ny - 1, L, 3, 3), checked finite."""
        t = _crop(self.stage_lags, shape)
        if not np.all(np.isfinite(t)):
            raise ValueError(f"{self.name}: block weights contain NaN or infinite values")
        return t

    def needs_memory(self, n_steps: int | None) -> bool:
        return n_steps is not None and n_steps > self.n_lags

    def collaborators(self, shape, settings: SolverSettings, workers: int = 1, n_steps: int | None = None):
        """(:class:`StageDenseSubstrate`, history of the kept block lags + the creep tail) of a patch; the march
        also needs :meth:`march_view` (run_loading_path calls both)."""
        nx, ny = shape
        if nx * ny > DENSE_LIMIT:
            raise ValueError(f"{self.name}: the stage kernel has a dense substrate only (patches up to {DENSE_LIMIT} "
                             f"elements, got {nx} x {ny}); a matrix-free stage substrate is not built")
        if settings.method == "fft":
            logger.warning("%s: solver.method = fft; the stage kernel runs its dense substrate and FFT history",
                           self.name)
        if self.needs_memory(n_steps) and (self.stage_tail is None or not settings.long_memory):
            raise ValueError(f"the run needs {n_steps} steps of memory but the stage kernel keeps {self.n_lags} lags "
                             "and " + ("solver.long_memory is off" if self.stage_tail is not None else "has no tail"))
        table = self.stage_table(shape)
        substrate = StageDenseSubstrate.from_table(table[:, :, 0], shape)
        history = StageFFTHistory(table, shape)
        if self.needs_memory(n_steps):
            logger.info("long memory: %s", self.stage_tail.describe())
            history = HistorySum([history, self.stage_tail.history(shape)])
        return substrate, history

    def march_view(self, loading, springs, recorder):
        """The stacked stage loading, the tiled springs and a recorder of the last stage."""
        return StageLoading(loading), stage_springs(springs), StageRecorder(recorder, loading)

    # ------------------------------------------------------------------ frequency domain
    def block_symbol(self, theta, shape) -> np.ndarray:
        """The march kernel's own block transfer function (kept lags + tail) at theta = omega h,
        (n_theta, 3, 3, 2 nx - 1, 2 ny - 1) complex [m/N]."""
        theta = np.asarray(theta, dtype=float)
        t = self.stage_table(shape)
        z = np.exp(-1j * theta[:, None] * np.arange(t.shape[2])[None, :])
        sym = np.einsum("fl,xylij->fijxy", z, t)
        if self.stage_tail is not None:
            q = _crop(self.stage_tail.shape_table, shape)
            sym = sym + np.einsum("fij,xyi->fijxy", self.stage_tail.block_symbol(theta), q)
        return sym

    def own_frequency_response(self, frequencies, shape) -> np.ndarray:
        """The step's end value per harmonic force sampled at the stages (:func:`tyreroad.radau.stage_transfer`)
        of the march's own kernel (kept lags + tail), offset tables (n_f, 2 nx - 1, 2 ny - 1) [m/N]."""
        f = np.asarray(frequencies, dtype=float)
        theta = 2 * np.pi * f / self.sample_rate
        return stage_transfer(self.block_symbol(theta, shape), f, self.sample_rate)

    def nyquist_critical_stiffness(self, shape, workers: int = 1) -> tuple[float, float]:
        """(k_crit [N/m], lambda [m/N]) of the stage march at fs/2 for springs equal at the three stages:
        I + k S(pi) is singular for k = -1 / lambda at a negative real eigenvalue lambda of the own block symbol
        S(pi) (3 M x 3 M, real); inf where S(pi) has none (lambda is then its smallest real eigenvalue, or nan).
        :func:`tyreroad.stability.nyquist_critical_stiffness` asks the kernel for this (the single-stage
        G_d(-1) of ``lags`` says nothing of the stage march)."""
        sym = self.block_symbol(np.array([np.pi]), shape)[0].real
        big = np.block([[offset_matrix(sym[i, j]) for j in range(STAGES)] for i in range(STAGES)])
        eig = np.linalg.eigvals(big)
        real = eig[np.abs(eig.imag) <= 1e-9 * np.abs(eig).max()].real
        if real.size == 0:
            return math.inf, math.nan
        lam = float(real.min())
        return (-1.0 / lam if lam < 0.0 else math.inf), lam

    def relaxed(self) -> LayerKernel:
        """The static kernel of the fully relaxed layer, G(0)[dx, dy]."""
        return LayerKernel(self.static_table[:, :, None], True, self.sample_rate, element_size=self.element_size,
                           response=self.response, name=f"{self.name} (relaxed)")

    def truncation(self, material, shape, factor: int = 4) -> dict:
        """What the kept lags + tail cut off: the CQ weights of the remainder G(s) - R sum_k J_k / (1 + s tau_k)
        at lags L ... factor L - 1, at the excitation element and over the patch.

        Returns dict: ``excitation`` = sum_{l >= L} max_ij |W^rem_l[i, j]| at offset 0 over |W_0[3, 3]| there;
        ``worst`` the same maximised over offsets (each over its own W_0[3, 3] at offset 0); ``last_kept``
        max |W_{L-1}| / |W_0| of the full weights at offset 0.
        """
        from .cq import _element_laplace_fn
        from .greens import offset_table_index, unique_offsets

        c = float(self.element_size)
        nx, ny = shape
        offsets = unique_offsets((nx, ny)) * c
        tail = self.stage_tail
        L = self.n_lags
        w = radau_weights(_element_laplace_fn(material, offsets, c), factor * L, 1.0 / self.sample_rate)[L:]
        # R at the unique offsets (invert the table index)
        _, _, index = offset_table_index((nx, ny))
        rc = _crop(tail.shape_table, (nx, ny))
        r_unique = np.zeros((offsets.shape[0], STAGES))
        r_unique[index.ravel()] = rc.reshape(-1, STAGES)
        images = tail.block_weights(np.arange(L, factor * L))  # (n, 3, 3)
        rem = w - images[..., None] * r_unique.T[None, :, None, :]
        centre = ((self.stage_lags.shape[0] - 1) // 2, (self.stage_lags.shape[1] - 1) // 2)
        g00 = abs(self.stage_lags[centre][0, 2, 2])
        cut = np.abs(rem).max(axis=(1, 2)).sum(axis=0)  # per offset
        full_last = np.abs(self.stage_lags[centre][L - 1]).max()
        return {"excitation": float(cut[0] / g00), "worst": float(cut.max() / g00), "last_kept": float(full_last / g00)}


# --------------------------------------------------------------------------------------------
# the greens file (greens.construction: radau)
# --------------------------------------------------------------------------------------------
#: ``greens.construction`` of the stage kernel; its greens file holds the variables of :func:`stage_variables`.
STAGE_CONSTRUCTION = "radau"
#: What ``critical_stiffness = inf`` of a stage kernel's greens file covers (its ``method`` attribute).
STAGE_MARGIN_METHOD = (
    "radau: by construction (A-stable Radau IIA-3 convolution quadrature of a passive layer), for springs equal at "
    "the three stages of a step (linear springs, hard contact included); springs that differ between the stages of "
    "a step (a nonlinear spring, a contact opening within a step) are not covered by this argument "
    "(tyreroad.stage module docstring)")

_STAGE_LABELS = {"stage_out": "output stage i", "stage_in": "input (force) stage j"}


def stage_variables(kernel: "StageKernel") -> tuple[dict, dict]:
    """(variables, coords) of a stage kernel for its greens dataset (the inverse of :meth:`StageKernel.from_greens`):
    the kept block weights, G(0) and the creep tail's recursion data, as stored float64 (a round trip is exact)."""
    c = ", ".join(f"{v:.6f}" for v in RADAU_C)
    coords = {name: (name, np.arange(STAGES), {"units": "1", "long_name": f"{label} of a step (time t_(n-1) + c h, "
                                                                             f"c = {c})"})
              for name, label in _STAGE_LABELS.items()}
    out = {
        "stage_weight": (("dx", "dy", "lag", "stage_out", "stage_in"), kernel.stage_lags, {
            "units": "m/N", "long_name": "Radau IIA-3 convolution-quadrature block weights W_l[i, j]: displacement at "
            "stage i of step n per unit force at stage j of step n - lag (the march's kept lags)"}),
        "stage_static": (("dx", "dy"), kernel.static_table, {
            "units": "m/N", "long_name": "G(0), the element FRF at omega = 0: the relaxed layer the stage kernel's "
            "tail sums to"}),
    }
    tail = kernel.stage_tail
    if tail is not None:
        out.update({
            "stage_tail_shape": (("dx", "dy", "stage_out"), tail.shape_table, {
                "units": "1/m", "long_name": "spatial factor R[dx, dy, i] (m/N x Pa) of the creep tail's block weights "
                "at output stage i, lags >= stage_tail_delay (sum rule: a held force relaxes to G(0))"}),
            "stage_tail_amplitude": ("stage_term", tail.amplitude, {
                "units": "1/(Pa s)", "long_name": "J_k / tau_k of the retardation terms the tail keeps"}),
            "stage_tail_rate": ("stage_term", tail.rates, {"units": "1/s", "long_name": "1 / tau_k"}),
            "stage_tail_u": (("stage_term", "stage_out"), tail.u, {
                "units": "1", "long_name": "u_k = (I + h A / tau_k)^-1 1 of the rational image W_l = u r^(l-1) v^T"}),
            "stage_tail_v": (("stage_term", "stage_in"), tail.v, {
                "units": "s", "long_name": "v_k^T = e_3^T W_0 of the rational image W_l = u r^(l-1) v^T"}),
            "stage_tail_r": ("stage_term", tail.r, {
                "units": "1", "long_name": "r_k = R(-h / tau_k), the Radau IIA-3 stability function: the recursion "
                "factor per step"}),
        })
    return out, coords


def radau_greens(ds, material, shape):
    """The greens stage's part for ``greens.construction: radau`` (:func:`tyreroad.pipeline.run_greens`).

    ``ds`` is the ``fold`` greens dataset of the material (its ``g`` stays: the single-stage kernel of the same
    FRF, not what a run marches); this adds the stage kernel (:func:`stage_variables`, built for the patch
    ``shape`` at the file's sample rate and kept lags), its stability margin -- ``critical_stiffness = inf``
    with the method :data:`STAGE_MARGIN_METHOD` -- and its fidelity to the element FRF
    (:func:`tyreroad.fidelity.kernel_fidelity` of the march's own transfer function, the step's end value for a
    force sampled at the stages).

    Raises
    ------
    ValueError
        If the stage kernel of a causal material misses its FRF by more than the fidelity limits (as the
        other constructions are refused), or the patch is larger than the dense stage substrate serves.
    """
    from .fidelity import kernel_fidelity

    nx, ny = (int(n) for n in shape)
    if nx * ny > DENSE_LIMIT:
        raise ValueError(f"greens {material.name}: greens.construction: radau has a dense stage substrate only "
                         f"(patches up to {DENSE_LIMIT} elements, got {nx} x {ny})")
    fs = float(ds.attrs["sample_rate"])
    n_lags = int(ds.attrs["n_lags"])
    kernel = StageKernel.from_material(material, (nx, ny), float(ds.attrs["element_size"]), fs, n_lags,
                                       n_fft_backing=max(int(ds.attrs.get("n_fft", 4096)), 4096))
    fidelity = kernel_fidelity(kernel, material, (nx, ny))
    logger.info("greens %s (radau): fidelity to the element FRF %s", material.name, fidelity.describe())
    if not fidelity.faithful and int(ds.attrs.get("causal_material", 1)):
        raise ValueError(
            f"greens {material.name}: the 'radau' kernel misses the element FRF by {fidelity.magnitude:.2%} of |G_0| "
            f"/ {fidelity.phase:.4f} rad over {fidelity.band[0]:g}-{fidelity.band[1]:g} Hz (limits 1 % / 0.01 rad, "
            "tyreroad.fidelity): refused, no file written")
    variables, coords = stage_variables(kernel)
    ds = ds.assign_coords(coords)
    ds["g"].attrs["long_name"] = ("element Green's function, discrete impulse response of the 'fold' single-stage "
                                  "kernel (a dynamic run on this file marches the Radau stage weights stage_weight)")
    margin = {
        "critical_stiffness": ((), math.inf, {
            "units": "N/m", "long_name": "stiffest element spring for which the march is stable (inf: every spring, "
            "hard contact included)", "method": STAGE_MARGIN_METHOD}),
        "critical_theta": ((), math.nan, {
            "units": "rad", "long_name": "theta = 2 pi f / fs where critical_stiffness is reached (NaN: none)"}),
    }
    # the claim of the construction, measured densely over the unit circle (issue 23): p(theta) on the patch
    theta, p_theta = stage_margin(material, (nx, ny), float(ds.attrs["element_size"]), fs)
    logger.info("greens %s (radau): stability margin p(theta) over %d points of the unit circle: min %.3e of "
                "lambda_max G(0) at theta = %.4f rad", material.name, theta.size, p_theta.min(),
                theta[int(np.argmin(p_theta))])
    if not np.all(p_theta > 0):
        raise ValueError(f"greens {material.name}: the Radau stability margin p(theta) is not positive on the whole "
                         f"unit circle (min {p_theta.min():.3e} at theta = {theta[int(np.argmin(p_theta))]:.4f} rad): "
                         "the layer is not passive there; refused, no file written")
    margin["stage_margin"] = (("margin_theta",), p_theta, {
        "units": "1", "long_name": "min over the Radau eigenvalues s = d_i(e^-i theta)/h of lambda_min Herm(e^{i arg s} "
        "G(s)) on the patch, over lambda_max G(0) (> 0: stable for every spring equal at the stages)"})
    ds = ds.assign_coords(margin_theta=("margin_theta", theta, {"units": "rad", "long_name": "theta = 2 pi f / fs"}))
    ds = ds.assign({**variables, **margin, **fidelity.variables()})
    ds.attrs["stage_margin_min"] = float(p_theta.min())
    ds.attrs["construction"] = STAGE_CONSTRUCTION
    ds.attrs["stage_tail_delay"] = int(kernel.stage_tail.delay) if kernel.stage_tail is not None else 0
    logger.info("greens %s (radau): %d kept block lags, %s; critical stiffness inf (%s)", material.name, n_lags,
                "no tail" if kernel.stage_tail is None else kernel.stage_tail.describe(), "springs equal at the stages")
    return ds


def stage_margin(material, shape, element_size: float, sample_rate: float, n_theta: int = 512) -> tuple[np.ndarray,
                                                                                                       np.ndarray]:
    """The stability margin of the Radau IIA-3 march densely over the unit circle, p(theta) [1].

    For every theta = pi k / n_theta (k = 1 ... n_theta) and every eigenvalue d_i of the Radau generating function
    Delta(e^{-i theta}), s = d_i / h lies in Re s > 0, and the march with springs equal at the stages is stable
    for every spring S >= 0 if I + S^(1/2) G(s) S^(1/2) is nonsingular there; it is if Herm(e^{i phi} G(s)) is
    positive definite for one phase phi. At phi = arg s this holds for a passive layer (s G(s) positive real);
    p(theta) is its smallest eigenvalue over the patch matrix of the layer's exact G(s) (the element Laplace
    kernel, :func:`tyreroad.greens.element_laplace`), min over the three d_i, relative to lambda_max G(0). The
    patch matrices are solved on their four reflection blocks (the same eigenvalues, :mod:`tyreroad.symmetry`).

    Returns
    -------
    theta : numpy.ndarray
        (n_theta,) [rad].
    margin : numpy.ndarray
        (n_theta,) [1]; > 0 on the whole circle: stable for every spring (the construction's claim, measured).
    """
    from .construction import patch_support
    from .greens import element_laplace, offset_table_index, unique_offsets
    from .radau import circle_laplace_points

    nx, ny = (int(n) for n in shape)
    c = float(element_size)
    theta, s = circle_laplace_points(n_theta, sample_rate)
    s = s.ravel()
    offsets = unique_offsets((nx, ny)) * c
    _, _, index = offset_table_index((nx, ny))
    values = element_laplace(offsets, c, s, material.laplace_modulus(s), material.poisson, material.density,
                             material.thickness)  # (n 3, n_offsets)
    tables = values[:, index]  # (n 3, 2 nx - 1, 2 ny - 1)
    g0 = element_laplace(offsets, c, np.array([1e-9 + 0j]), material.laplace_modulus(np.array([1e-9 + 0j])),
                         material.poisson, material.density, material.thickness)[:, index].real
    scale = float(patch_support(-g0.astype(complex), (nx, ny), np.array([0.0]))[0, 0])  # -lambda_max G(0)
    phases = np.angle(s)
    out = np.array([patch_support(tables[j:j + 1], (nx, ny), phases[j:j + 1])[0, 0] for j in range(s.size)])
    return theta, out.reshape(theta.size, 3).min(axis=1) / -scale
