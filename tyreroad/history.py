"""Histories: the layer displacement at step n caused by the forces of earlier steps.

The contact solver (SPEC 6) splits the layer surface displacement at step n into the part of the
step's own forces, G_0 F[n] (solved for, see :mod:`tyreroad.newton`), and the history

    h_e[n] = sum_{l >= 1} sum_m g_{e-m}[l] F_m[n - l],

which is known before step n is solved. A *history* is any object with the protocol

    ``displacement(n) -> h``   h[n] [m], shape (M,), from the forces recorded for steps < n;
    ``record(n, force)``       the converged forces F[n] [N], shape (M,), of step n,

called in the order displacement(0), record(0, F[0]), displacement(1), record(1, F[1]), ... by the
time-marching loop (:func:`tyreroad.contact.march`). Histories add: a run can carry the kept lags
(:class:`DenseHistory` or :class:`FFTHistory`, the same sum by two algorithms) and further terms
(the long-memory tail, SPEC 9) side by side in a :class:`HistorySum`, without any change to the
march loop or the Newton driver.

Both kept-lag histories hold only the last L - 1 force fields in a ring, so their memory and cost
per step do not grow with the length of the run; lags beyond L - 1 are not part of them.
"""

from __future__ import annotations

from typing import Protocol, Sequence, runtime_checkable

import numpy as np
from numba import get_num_threads, njit, prange

from . import checks
from .convolution import OffsetConvolution, check_offset_kernel
from .influence import offset_matrix

__all__ = ["History", "DenseHistory", "FFTHistory", "TailHistory", "HistorySum"]


@runtime_checkable
class History(Protocol):
    """Displacement from past forces; see the module docstring."""

    def displacement(self, n: int) -> np.ndarray:  # pragma: no cover - protocol
        ...

    def record(self, n: int, force: np.ndarray) -> None:  # pragma: no cover - protocol
        ...


class _StepCounter:
    """Checks that steps are recorded in order 0, 1, 2, ... and displacement asked for the next one."""

    def __init__(self) -> None:
        self.recorded = 0

    def check_displacement(self, n: int, name: str) -> None:
        if n != self.recorded:
            raise ValueError(f"{name}.displacement({n}): the next step is {self.recorded} (steps go 0, 1, 2, ...)")

    def check_record(self, n: int, name: str) -> None:
        if n != self.recorded:
            raise ValueError(f"{name}.record({n}): the next step to record is {self.recorded}")
        self.recorded += 1


# --------------------------------------------------------------------------------------------
# Dense offset-table history (the reference path)
# --------------------------------------------------------------------------------------------
@njit(cache=True, parallel=True)
def _history_sum(kern_t, f_ring, nz_idx, nz_cnt, n, nx, ny, out, n_threads):  # pragma: no cover - numba
    """h[n] from the offset table kern_t[lag, dx, dy], visiting only loaded elements.

    Step s is stored in ring slot s mod D (D = ring depth = L - 1); ``nz_idx[slot, :nz_cnt[slot]]``
    lists the flat indices of the elements with F != 0 at that step. The target rows ex are split
    into one contiguous band per thread (``n_threads``: numba's current count, passed in because
    reading it here would keep the function out of numba's cache). Within a band the lags and the
    loaded elements are the outer loops and each source adds its window of the lag's table to every
    target row, so that the innermost loop runs over a contiguous ey slice and vectorises (the
    previous order, rows outermost, re-derived each source for every row: 4x slower on 20 x 20).
    Every target still sums over lags, then loaded elements, in ascending order: the order fixes the
    round-off, and the result is the same to the bit whatever the thread count.
    """
    n_lag = kern_t.shape[0]
    depth = f_ring.shape[0]
    lmax = min(n_lag - 1, n)
    n_band = max(min(n_threads, nx), 1)
    for band in prange(n_band):
        lo = band * nx // n_band
        hi = (band + 1) * nx // n_band
        acc = np.zeros((hi - lo, ny))
        for lag in range(1, lmax + 1):
            slot = (n - lag) % depth
            table = kern_t[lag]
            for q in range(nz_cnt[slot]):
                m = nz_idx[slot, q]
                mx = m // ny
                my = m - mx * ny
                f = f_ring[slot, m]
                row0 = nx - 1 - mx
                col0 = ny - 1 - my
                for ex in range(lo, hi):
                    window = table[row0 + ex, col0:col0 + ny]
                    target = acc[ex - lo]
                    for ey in range(ny):
                        target[ey] += window[ey] * f
        for ex in range(lo, hi):
            for ey in range(ny):
                out[ex * ny + ey] = acc[ex - lo, ey]


class DenseHistory:
    """Lags 1 ... L-1 of an offset table summed directly over the loaded elements.

    Cost per step O(L M_c M) (M_c elements in contact), memory O(L M); exact, the reference for
    :class:`FFTHistory`.

    Parameters
    ----------
    kernel : array_like
        g[dx, dy, lag] [m/N], offsets -(n-1) ... n-1 (a larger centred table is cropped).
    shape : tuple of int
        Patch (nx, ny) [elements].
    """

    def __init__(self, kernel, shape):
        nx, ny = (checks.integer(f"shape[{i}]", v) for i, v in enumerate(shape))
        g = check_offset_kernel(kernel, nx, ny)
        self.shape = (nx, ny)
        self.n_lags = g.shape[2]
        self._kern_t = np.ascontiguousarray(np.moveaxis(g, 2, 0))
        depth = max(self.n_lags - 1, 1)
        n_elem = nx * ny
        self._f_ring = np.zeros((depth, n_elem))
        self._nz_idx = np.zeros((depth, n_elem), dtype=np.int64)
        self._nz_cnt = np.zeros(depth, dtype=np.int64)
        self._out = np.zeros(n_elem)
        self._steps = _StepCounter()

    def displacement(self, n: int) -> np.ndarray:
        """h[n] [m], shape (M,), from lags 1 ... min(L - 1, n)."""
        self._steps.check_displacement(n, "DenseHistory")
        if self.n_lags > 1 and n > 0:
            nx, ny = self.shape
            _history_sum(self._kern_t, self._f_ring, self._nz_idx, self._nz_cnt, n, nx, ny, self._out,
                         get_num_threads())
        return self._out.copy()

    def record(self, n: int, force: np.ndarray) -> None:
        """Store F[n] [N], shape (M,), in ring slot n mod (L - 1)."""
        if not np.all(np.isfinite(force)):
            raise ValueError("DenseHistory.record: forces contain NaN or infinite values")
        self._steps.check_record(n, "DenseHistory")
        if self.n_lags > 1:
            slot = n % self._f_ring.shape[0]
            loaded = np.flatnonzero(force)
            self._f_ring[slot] = force
            self._nz_idx[slot, : loaded.size] = loaded
            self._nz_cnt[slot] = loaded.size


# --------------------------------------------------------------------------------------------
# FFT history (footprint-size patches)
# --------------------------------------------------------------------------------------------
@njit(cache=True, parallel=True, fastmath=True)
def _accumulate_real(g_re, f_re, f_im, newest, n_terms, out_re, out_im):  # pragma: no cover - numba
    """out[k] = sum_{j < n_terms} g[k, j] f[k, (newest + j) mod D] for real kernel spectra g.

    ``g[k, j]`` is the kernel spectrum of lag j + 1; the ring is written backwards, so the force
    of lag j + 1 sits j slots after the newest one and all rows stream forwards. Each row is summed
    in two contiguous runs (before and after the ring's wrap) over slices: indexing the ring with
    an offset inside one loop kept the compiler from vectorising it, which made the wrapped ring
    2x slower than a streaming read (benchmarks/bench_history_bandwidth.py). fastmath only
    reorders the sums (inputs are validated finite).
    """
    n_bins, depth = g_re.shape
    first = min(n_terms, depth - newest)
    rest = n_terms - first
    for k in prange(n_bins):
        g1 = g_re[k, :first]
        r1 = f_re[k, newest : newest + first]
        i1 = f_im[k, newest : newest + first]
        a = 0.0
        b = 0.0
        for j in range(first):
            a += g1[j] * r1[j]
            b += g1[j] * i1[j]
        g2 = g_re[k, first:n_terms]
        r2 = f_re[k, :rest]
        i2 = f_im[k, :rest]
        for j in range(rest):
            a += g2[j] * r2[j]
            b += g2[j] * i2[j]
        out_re[k] = a
        out_im[k] = b


@njit(cache=True, parallel=True, fastmath=True)
def _accumulate_complex(g_re, g_im, f_re, f_im, newest, n_terms, out_re, out_im):  # pragma: no cover - numba
    """As :func:`_accumulate_real` for complex kernel spectra g_re + i g_im."""
    n_bins, depth = g_re.shape
    first = min(n_terms, depth - newest)
    rest = n_terms - first
    for k in prange(n_bins):
        gr1 = g_re[k, :first]
        gi1 = g_im[k, :first]
        r1 = f_re[k, newest : newest + first]
        i1 = f_im[k, newest : newest + first]
        a = 0.0
        b = 0.0
        for j in range(first):
            a += gr1[j] * r1[j] - gi1[j] * i1[j]
            b += gr1[j] * i1[j] + gi1[j] * r1[j]
        gr2 = g_re[k, first:n_terms]
        gi2 = g_im[k, first:n_terms]
        r2 = f_re[k, :rest]
        i2 = f_im[k, :rest]
        for j in range(rest):
            a += gr2[j] * r2[j] - gi2[j] * i2[j]
            b += gr2[j] * i2[j] + gi2[j] * r2[j]
        out_re[k] = a
        out_im[k] = b


class FFTHistory:
    """Lags 1 ... L-1 summed in the frequency domain over a ring of past force spectra.

    h[n] = irfft2( sum_{l=1}^{L-1} G^_l F^[n - l] ): one rfft2 per step (of the recorded force),
    one irfft2 and a multiply-add over (bins x L) complex numbers (a numba kernel parallel over
    frequency bins) instead of M^2 L. Memory: the kernel spectra (held by ``conv``) and a ring of
    L - 1 force spectra.

    Parameters
    ----------
    conv : OffsetConvolution
        Kernel spectra and FFT settings.
    """

    def __init__(self, conv: OffsetConvolution):
        if not isinstance(conv, OffsetConvolution):
            raise TypeError(f"conv: expected OffsetConvolution, got {type(conv).__name__}")
        self.conv = conv
        self._depth = conv.n_lags - 1
        self._ring_re = np.zeros((conv.n_bins, self._depth))
        self._ring_im = np.zeros((conv.n_bins, self._depth))
        self._newest = 0
        self._out_re = np.empty(conv.n_bins)
        self._out_im = np.empty(conv.n_bins)
        self._steps = _StepCounter()

    @property
    def nbytes(self) -> int:
        """Memory of the ring buffer [B]."""
        return self._ring_re.nbytes + self._ring_im.nbytes

    def record(self, n: int, force: np.ndarray) -> None:
        """Append F[n] [N], shape (M,) or (nx, ny), to the ring."""
        f = self.conv.check_field(force)
        if not np.all(np.isfinite(f)):
            raise ValueError("FFTHistory.record: forces contain NaN or infinite values")
        self._steps.check_record(n, "FFTHistory")
        if self._depth > 0:
            spec = self.conv.spectrum(f).ravel()
            self._newest = (self._newest - 1) % self._depth
            self._ring_re[:, self._newest] = spec.real
            self._ring_im[:, self._newest] = spec.imag

    def displacement(self, n: int) -> np.ndarray:
        """h[n] [m], shape (M,): lags 1 ... min(L - 1, n) of the recorded forces."""
        self._steps.check_displacement(n, "FFTHistory")
        conv = self.conv
        n_terms = min(n, self._depth)
        if n_terms == 0:
            return np.zeros(conv.shape[0] * conv.shape[1])
        args = (self._ring_re, self._ring_im, self._newest, n_terms, self._out_re, self._out_im)
        g_re, g_im = conv.lag_spectra
        if conv.symmetric:
            _accumulate_real(g_re, *args)
        else:
            _accumulate_complex(g_re, g_im, *args)
        spec = (self._out_re + 1j * self._out_im).reshape(conv.spectrum_shape)
        return conv.field(spec, overwrite=True).ravel()


# --------------------------------------------------------------------------------------------
# Long-memory tail (SPEC 9)
# --------------------------------------------------------------------------------------------
@njit(cache=True, parallel=True)
def _tail_update(states, decays, weights, entering, filtered):  # pragma: no cover - numba
    """s_k <- decay_k s_k + F_entering; filtered = sum_k weight_k s_k (per element, parallel)."""
    n_terms, n_elem = states.shape
    for m in prange(n_elem):
        f = entering[m]
        acc = 0.0
        for k in range(n_terms):
            s = decays[k] * states[k, m] + f
            states[k, m] = s
            acc += weights[k] * s
        filtered[m] = acc


class TailHistory:
    """Lags L, L+1, ... of the kernel as R (x) c[l] (:class:`tyreroad.memory.TailModel`).

    h_tail[n] = sum_m R[e - m] u_m[n],  u_m[n] = sum_{l >= L} c[l] F_m[n - l]. The time filter runs
    recursively, one state per retardation term and element (s_k <- decay_k s_k + F[n - L]), fed
    by a delay line of the last L force fields; the spatial sum is one product with R (a dense
    matrix, or an FFT convolution for large patches). Cost and memory per step do not depend on
    the length of the run.

    Parameters
    ----------
    tail : TailModel
        R[dx, dy] [m/N] (offsets -(nx-1) ... nx-1, a larger centred table is cropped), weights,
        decays and the delay L.
    shape : tuple of int
        Patch (nx, ny).
    method : {"dense", "fft"}
        How the spatial sum with R is done.
    workers : int
        FFT workers (``fft`` only).
    """

    def __init__(self, tail, shape, method: str = "dense", workers: int = 1):
        nx, ny = (checks.integer(f"shape[{i}]", v) for i, v in enumerate(shape))
        r = check_offset_kernel(np.asarray(tail.residual_compliance, dtype=float)[:, :, None], nx, ny, "tail R")
        self.shape = (nx, ny)
        self.delay = checks.integer("tail delay", tail.delay)
        self._decays = np.ascontiguousarray(tail.decays, dtype=float)
        self._weights = np.ascontiguousarray(tail.weights, dtype=float)
        n_elem = nx * ny
        self._states = np.zeros((self._decays.size, n_elem))
        self._delay_line = np.zeros((self.delay, n_elem))
        self._filtered = np.zeros(n_elem)
        self._updated_for = -1
        if method == "fft":
            self._conv = OffsetConvolution(r, self.shape, workers=workers)
            self._spatial = lambda u: self._conv.apply_lag(u, 0).ravel()
        elif method == "dense":
            self._matrix = offset_matrix(r[:, :, 0])
            self._spatial = lambda u: self._matrix @ u
        else:
            raise ValueError(f"method: expected 'dense' or 'fft', got {method!r}")
        self._steps = _StepCounter()

    @property
    def nbytes(self) -> int:
        """Memory of the delay line and the filter states [B]."""
        return self._states.nbytes + self._delay_line.nbytes

    def displacement(self, n: int) -> np.ndarray:
        """h_tail[n] [m], shape (M,): zero until a force is L steps old."""
        self._steps.check_displacement(n, "TailHistory")
        if n < self.delay:
            return np.zeros(self._filtered.size)
        self._advance(n)
        return self._spatial(self._filtered)

    def _advance(self, n: int) -> None:
        """Feed F[n - L] to the filter, once per step, however often step n is asked or recorded."""
        if n >= self.delay and self._updated_for != n:
            _tail_update(self._states, self._decays, self._weights, self._delay_line[n % self.delay], self._filtered)
            self._updated_for = n

    def record(self, n: int, force: np.ndarray) -> None:
        """F[n] [N] enters the delay line (it reaches the filter at step n + L).

        The slot it takes held F[n - L], which the filter must have taken first: a step whose
        displacement was not asked for still advances the filter here.
        """
        self._steps.check_record(n, "TailHistory")
        self._advance(n)
        self._delay_line[n % self.delay] = np.ravel(force)


class HistorySum:
    """Several histories acting together: h[n] is the sum of their displacements.

    Parameters
    ----------
    histories : sequence of History
        Each gets every ``record`` call; ``displacement`` adds theirs in the given order.
    """

    def __init__(self, histories: Sequence[History]):
        self.histories = tuple(histories)
        if not self.histories:
            raise ValueError("HistorySum: expected at least one history")
        for h in self.histories:
            if not isinstance(h, History):
                raise TypeError(f"HistorySum: {type(h).__name__} has no displacement(n) / record(n, force)")

    def displacement(self, n: int) -> np.ndarray:
        """Sum of the histories' h[n] [m]."""
        total = self.histories[0].displacement(n)
        for h in self.histories[1:]:
            total = total + h.displacement(n)
        return total

    def record(self, n: int, force: np.ndarray) -> None:
        """Pass F[n] [N] to every history."""
        for h in self.histories:
            h.record(n, force)
