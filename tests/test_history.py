"""Tests of tyreroad.history: every History against a slow, plain-numpy sum written from its definition.

The references below are standalone functions over explicit loops (no package code), so that the
tests can be re-pointed when the history or memory APIs move:

    h_e[n]      = sum_{l=1}^{min(L-1, n)} sum_m g[e - m, l] F_m[n - l]          (kept lags)
    h_tail_e[n] = sum_m R[e - m] sum_{l >= L} c[l] F_m[n - l],
                  c[l] = sum_k w_k decay_k^(l - L)                              (creep tail)

Offset tables are indexed g[dx + nx - 1, dy + ny - 1, lag]. Kernels are random and, unless a test
needs the even (real-spectrum) branch, not symmetric: a transposed offset (e - m against m - e),
swapped axes, a lag off by one or a force of the wrong step changes the sum at O(1).
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from tyreroad.convolution import OffsetConvolution
from tyreroad.history import DenseHistory, FFTHistory, History, HistorySum, TailHistory
from tyreroad.memory import TailModel


# --------------------------------------------------------------------------------------------
# Plain references
# --------------------------------------------------------------------------------------------
def reference_history(g: np.ndarray, forces: np.ndarray, n: int) -> np.ndarray:
    """Kept-lag history h[n], shape (nx ny,), by explicit loops over lags, targets and sources.

    Parameters
    ----------
    g : numpy.ndarray
        g[dx + nx - 1, dy + ny - 1, lag] [m/N], shape (2 nx - 1, 2 ny - 1, L).
    forces : numpy.ndarray
        F[step, x, y] [N] for steps 0 ... >= n - 1.
    n : int
        Step.
    """
    _, nx, ny = forces.shape
    n_lags = g.shape[2]
    h = np.zeros((nx, ny))
    for lag in range(1, min(n_lags - 1, n) + 1):
        for ex, ey, mx, my in itertools.product(range(nx), range(ny), range(nx), range(ny)):
            h[ex, ey] += g[ex - mx + nx - 1, ey - my + ny - 1, lag] * forces[n - lag, mx, my]
    return h.ravel()


def reference_tail_sequence(weights, decays, delay: int, lag: int) -> float:
    """c[lag] = sum_k w_k decay_k^(lag - L) for lag >= L, else 0 [1]."""
    if lag < delay:
        return 0.0
    return float(sum(w * d ** (lag - delay) for w, d in zip(weights, decays)))


def reference_tail(r: np.ndarray, weights, decays, delay: int, forces: np.ndarray, n: int) -> np.ndarray:
    """Tail history h_tail[n], shape (nx ny,), by explicit loops over lags >= L, targets and sources.

    Parameters
    ----------
    r : numpy.ndarray
        R[dx + nx - 1, dy + ny - 1] [m/N], shape (2 nx - 1, 2 ny - 1).
    weights, decays : sequence of float
        w_k [1] and decay_k [1] of the time filter.
    delay : int
        L, the first lag of the tail.
    forces : numpy.ndarray
        F[step, x, y] [N] for steps 0 ... >= n - L.
    n : int
        Step.
    """
    _, nx, ny = forces.shape
    h = np.zeros((nx, ny))
    for lag in range(delay, n + 1):
        c = reference_tail_sequence(weights, decays, delay, lag)
        for ex, ey, mx, my in itertools.product(range(nx), range(ny), range(nx), range(ny)):
            h[ex, ey] += r[ex - mx + nx - 1, ey - my + ny - 1] * c * forces[n - lag, mx, my]
    return h.ravel()


def random_kernel(rng, nx: int, ny: int, n_lags: int, even: bool = False) -> np.ndarray:
    """Random offset table [m/N]; ``even``: even in dx and in dy (the layer kernel's symmetry)."""
    g = rng.standard_normal((2 * nx - 1, 2 * ny - 1, n_lags)) * 1e-6
    if even:
        g = g + g[::-1] + g[:, ::-1] + g[::-1, ::-1]
    return g


def sparse_forces(rng, n_steps: int, nx: int, ny: int) -> np.ndarray:
    """F[step, x, y] [N] >= 0 with about half the elements unloaded, a loaded set that changes from
    step to step, and one step without any contact (stale ring slots must not leak into the sum)."""
    f = rng.uniform(0.5, 5.0, (n_steps, nx, ny))
    f[rng.uniform(size=f.shape) < 0.5] = 0.0
    f[min(3, n_steps - 1)] = 0.0
    return f


def run(history, forces: np.ndarray) -> np.ndarray:
    """Drive ``history`` through the march's protocol; returns h[n] for n = 0 ... n_steps - 1."""
    out = []
    for n, f in enumerate(forces):
        out.append(history.displacement(n))
        history.record(n, f.ravel())
    return np.array(out)


def worst_relative(h: np.ndarray, ref: np.ndarray) -> float:
    """Largest |h - ref| over all steps and elements, relative to the largest |ref|."""
    return float(np.max(np.abs(h - ref)) / np.max(np.abs(ref)))


# --------------------------------------------------------------------------------------------
# The references themselves
# --------------------------------------------------------------------------------------------
def test_reference_history_on_a_hand_example():
    """One source, one lag: h picks g at the offset target - source, one step later."""
    nx, ny = 2, 3
    g = np.zeros((3, 5, 3))
    g[1 + 1, 2 - 2, 1] = 7.0  # dx = +1, dy = -2, lag 1
    f = np.zeros((4, nx, ny))
    f[0, 0, 2] = 2.0  # source (0, 2) at step 0
    expected = np.zeros((nx, ny))
    expected[1, 0] = 14.0  # target (1, 0): offset (1 - 0, 0 - 2)
    np.testing.assert_array_equal(reference_history(g, f, 1), expected.ravel())
    assert not np.any(reference_history(g, f, 2))  # lag 2 of the table is zero
    assert reference_tail_sequence([0.25, 0.5], [0.5, 0.1], 3, 5) == 0.25 * 0.25 + 0.5 * 0.01
    assert reference_tail_sequence([0.25, 0.5], [0.5, 0.1], 3, 2) == 0.0


# --------------------------------------------------------------------------------------------
# Kept lags: DenseHistory and FFTHistory
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("nx, ny, n_lags, even", [(3, 4, 5, False), (5, 5, 6, False), (5, 5, 6, True), (4, 3, 2, False)])
def test_dense_history_equals_plain_sum(nx, ny, n_lags, even):
    rng = np.random.default_rng(11)
    g = random_kernel(rng, nx, ny, n_lags, even)
    n_steps = 3 * n_lags + 2  # the ring of L - 1 slots wraps around several times
    forces = sparse_forces(rng, n_steps, nx, ny)
    h = run(DenseHistory(g, (nx, ny)), forces)
    ref = np.array([reference_history(g, forces, n) for n in range(n_steps)])
    assert np.all(h[0] == 0.0)
    assert worst_relative(h, ref) < 1e-12


@pytest.mark.parametrize("nx, ny", [(7, 5), (1, 6), (2, 9)])
def test_dense_history_is_the_same_to_the_bit_on_any_thread_count(nx, ny):
    """The target rows are split into one band per numba thread; every target sums in the same order
    whatever the split, so one thread and two give identical bits (and equal the plain sum)."""
    import numba

    rng = np.random.default_rng(17)
    n_lags = 9
    g = random_kernel(rng, nx, ny, n_lags)
    forces = sparse_forces(rng, 3 * n_lags, nx, ny)
    saved = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = run(DenseHistory(g, (nx, ny)), forces)
        numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
        two = run(DenseHistory(g, (nx, ny)), forces)
    finally:
        numba.set_num_threads(saved)
    np.testing.assert_array_equal(one, two)
    ref = np.array([reference_history(g, forces, n) for n in range(forces.shape[0])])
    assert worst_relative(one, ref) < 1e-12


@pytest.mark.parametrize("nx, ny, n_lags, even", [(3, 4, 5, False), (5, 5, 6, False), (5, 5, 6, True), (4, 3, 2, False)])
def test_fft_history_equals_plain_sum(nx, ny, n_lags, even):
    rng = np.random.default_rng(12)
    g = random_kernel(rng, nx, ny, n_lags, even)
    conv = OffsetConvolution(g, (nx, ny))
    assert conv.symmetric == even  # the real and the complex accumulation are both exercised
    n_steps = 3 * n_lags + 2
    forces = sparse_forces(rng, n_steps, nx, ny)
    h = run(FFTHistory(conv), forces)
    ref = np.array([reference_history(g, forces, n) for n in range(n_steps)])
    assert np.all(h[0] == 0.0)
    assert worst_relative(h, ref) < 1e-12


def test_histories_accept_a_larger_centred_table_and_2d_forces():
    rng = np.random.default_rng(13)
    nx, ny, n_lags = 3, 4, 4
    big = rng.standard_normal((2 * nx + 3, 2 * ny + 1, n_lags)) * 1e-6  # 2 extra offsets in x, 1 in y
    g = big[2:-2, 1:-1]
    forces = sparse_forces(rng, 9, nx, ny)
    ref = np.array([reference_history(g, forces, n) for n in range(9)])
    dense = DenseHistory(big, (nx, ny))
    fft = FFTHistory(OffsetConvolution(big, (nx, ny)))
    for n, f in enumerate(forces):
        np.testing.assert_allclose(dense.displacement(n), ref[n], rtol=0, atol=1e-12 * np.abs(ref).max())
        np.testing.assert_allclose(fft.displacement(n), ref[n], rtol=0, atol=1e-12 * np.abs(ref).max())
        dense.record(n, f.ravel())
        fft.record(n, f)  # (nx, ny) field


def test_single_lag_history_is_zero():
    """L = 1: no kept lag reaches a later step."""
    rng = np.random.default_rng(14)
    g = random_kernel(rng, 3, 3, 1)
    forces = rng.uniform(1, 2, (4, 3, 3))
    for history in (DenseHistory(g, (3, 3)), FFTHistory(OffsetConvolution(g, (3, 3)))):
        h = run(history, forces)
        assert h.shape == (4, 9) and np.all(h == 0.0)


# --------------------------------------------------------------------------------------------
# The protocol's step order
# --------------------------------------------------------------------------------------------
def _kept_histories():
    g = random_kernel(np.random.default_rng(15), 3, 4, 4)
    return [DenseHistory(g, (3, 4)), FFTHistory(OffsetConvolution(g, (3, 4)))]


def _tail_history():
    return TailHistory(TailModel(np.ones((5, 7)) * 1e-7, np.array([1.0]), np.array([0.5]), 2), (3, 4))


@pytest.mark.parametrize(
    "make",
    [lambda: _kept_histories()[0], lambda: _kept_histories()[1], _tail_history, lambda: HistorySum(_kept_histories())],
    ids=["dense", "fft", "tail", "sum"],
)
def test_steps_out_of_order_are_refused(make):
    f = np.ones(12)
    history = make()
    with pytest.raises(ValueError, match=r"displacement\(1\): the next step is 0"):
        history.displacement(1)
    with pytest.raises(ValueError, match=r"record\(1\): the next step to record is 0"):
        history.record(1, f)
    history.displacement(0)
    history.record(0, f)
    with pytest.raises(ValueError, match=r"record\(0\): the next step to record is 1"):
        history.record(0, f)  # a step recorded twice
    with pytest.raises(ValueError, match=r"displacement\(0\): the next step is 1"):
        history.displacement(0)  # a step asked for after it was recorded
    with pytest.raises(ValueError, match=r"displacement\(2\): the next step is 1"):
        history.displacement(2)  # a skipped step
    # the refused calls changed nothing: the run goes on in order
    history.displacement(1)
    history.record(1, f)
    history.displacement(2)


def test_fft_history_refuses_bad_forces():
    history = _kept_histories()[1]
    history.displacement(0)
    with pytest.raises(ValueError, match="NaN or infinite"):
        history.record(0, np.full(12, np.nan))
    with pytest.raises(ValueError, match=r"forces: expected shape \(3, 4\)"):
        history.record(0, np.ones(11))
    history.record(0, np.ones(12))  # the refused forces did not count as step 0


# --------------------------------------------------------------------------------------------
# The long-memory tail
# --------------------------------------------------------------------------------------------
def random_tail(rng, nx: int, ny: int, delay: int, even: bool = False) -> TailModel:
    """A TailModel built directly from arrays: random R, three retardation terms."""
    r = rng.standard_normal((2 * nx - 1, 2 * ny - 1)) * 1e-7
    if even:
        r = r + r[::-1] + r[:, ::-1] + r[::-1, ::-1]
    weights = np.array([0.5, 0.3, 0.2])
    decays = np.array([0.2, 0.7, 0.95])
    return TailModel(r, weights, decays, delay)


@pytest.mark.parametrize("method", ["dense", "fft"])
@pytest.mark.parametrize("nx, ny, delay, even", [(3, 4, 3, False), (5, 5, 4, False), (5, 5, 1, True)])
def test_tail_history_equals_plain_sum(method, nx, ny, delay, even):
    rng = np.random.default_rng(16)
    tail = random_tail(rng, nx, ny, delay, even)
    n_steps = 4 * delay + 6  # the delay line of L slots wraps several times, the filter state persists
    forces = sparse_forces(rng, n_steps, nx, ny)
    history = TailHistory(tail, (nx, ny), method)
    h = []
    for n, f in enumerate(forces):
        h.append(history.displacement(n))
        np.testing.assert_array_equal(history.displacement(n), h[-1])  # asking twice does not advance the filter
        history.record(n, f.ravel())
    h = np.array(h)
    ref = np.array([reference_tail(tail.residual_compliance, tail.weights, tail.decays, delay, forces, n)
                    for n in range(n_steps)])
    assert np.all(h[:delay] == 0.0)  # no force is L steps old yet
    assert worst_relative(h, ref) < 1e-12


def test_tail_history_crops_a_larger_table_and_refuses_a_bad_method():
    rng = np.random.default_rng(17)
    nx, ny = 3, 3
    small = random_tail(rng, nx, ny, 2)
    big_r = np.pad(small.residual_compliance, 2, constant_values=1.0)  # centred; the pad must be cropped away
    big = TailModel(big_r, small.weights, small.decays, small.delay)
    forces = sparse_forces(rng, 10, nx, ny)
    ref = np.array([reference_tail(small.residual_compliance, small.weights, small.decays, 2, forces, n)
                    for n in range(10)])
    assert worst_relative(run(TailHistory(big, (nx, ny)), forces), ref) < 1e-12
    with pytest.raises(ValueError, match="method: expected 'dense' or 'fft', got 'sparse'"):
        TailHistory(small, (nx, ny), method="sparse")


# --------------------------------------------------------------------------------------------
# HistorySum
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("kept", ["dense", "fft"])
def test_history_sum_of_kept_lags_and_tail_is_the_whole_kernel(kept):
    """Kept lags 1 ... L-1 plus the tail from L on equal one plain sum over the whole kernel
    g_full[:, :, l] = g[:, :, l] (l < L), R c[l] (l >= L)."""
    rng = np.random.default_rng(18)
    nx, ny, n_lags = 3, 4, 4
    g = random_kernel(rng, nx, ny, n_lags)
    tail = random_tail(rng, nx, ny, n_lags)
    n_steps = 15
    forces = sparse_forces(rng, n_steps, nx, ny)
    g_full = np.zeros(g.shape[:2] + (n_steps + 1,))
    g_full[:, :, :n_lags] = g
    for lag in range(n_lags, n_steps + 1):
        g_full[:, :, lag] = tail.residual_compliance * reference_tail_sequence(tail.weights, tail.decays, n_lags, lag)
    ref = np.array([reference_history(g_full, forces, n) for n in range(n_steps)])
    kept_history = DenseHistory(g, (nx, ny)) if kept == "dense" else FFTHistory(OffsetConvolution(g, (nx, ny)))
    total = HistorySum([kept_history, TailHistory(tail, (nx, ny))])
    assert isinstance(total, History)
    h = run(total, forces)
    assert worst_relative(h, ref) < 1e-12
    # the tail is not negligible here: without it the sum would be off at O(1)
    assert worst_relative(run(DenseHistory(g, (nx, ny)), forces), ref) > 0.05


def test_history_sum_adds_in_order_and_passes_every_record():
    class Probe:
        """A history that returns n times its weight and logs what it is given."""

        def __init__(self, weight):
            self.weight, self.calls = weight, []

        def displacement(self, n):
            self.calls.append(("displacement", n))
            return np.full(2, self.weight * n)

        def record(self, n, force):
            self.calls.append(("record", n, float(force[0])))

    a, b = Probe(1.0), Probe(10.0)
    total = HistorySum([a, b])
    np.testing.assert_array_equal(total.displacement(0), [0.0, 0.0])
    total.record(0, np.array([3.0, 4.0]))
    np.testing.assert_array_equal(total.displacement(1), [11.0, 11.0])
    assert a.calls == b.calls == [("displacement", 0), ("record", 0, 3.0), ("displacement", 1)]


def test_history_sum_type_check():
    class DisplacementOnly:
        def displacement(self, n):
            return np.zeros(1)

    with pytest.raises(ValueError, match="at least one history"):
        HistorySum([])
    with pytest.raises(TypeError, match=r"HistorySum: DisplacementOnly has no displacement\(n\) / record\(n, force\)"):
        HistorySum([DisplacementOnly()])
    with pytest.raises(TypeError, match="HistorySum: ndarray has no"):
        HistorySum([_kept_histories()[0], np.zeros(3)])


def test_tail_history_takes_a_step_whose_displacement_was_not_asked():
    """A step recorded without its displacement still feeds F[n - L] to the filter before its delay
    slot is overwritten: the tail then equals that of a history asked at every step."""
    rng = np.random.default_rng(41)
    shape, delay = (3, 4), 3
    r = rng.uniform(1e-7, 1e-6, (5, 7))
    tail = TailModel(r, np.array([0.5, 0.3, 0.2]), np.array([0.9, 0.6, 0.2]), delay)
    forces = rng.uniform(0.0, 10.0, (12, 12))
    asked, skipping = TailHistory(tail, shape), TailHistory(tail, shape)
    for n in range(12):
        h = asked.displacement(n)
        if n != 5:  # step 5 of the second history is recorded without asking its displacement
            assert np.array_equal(skipping.displacement(n), h)
        asked.record(n, forces[n])
        skipping.record(n, forces[n])
    np.testing.assert_allclose(skipping.displacement(12), asked.displacement(12), rtol=1e-15, atol=0)


def test_dense_history_refuses_non_finite_forces():
    hist = DenseHistory(np.ones((3, 3, 2)), (2, 2))
    with pytest.raises(ValueError, match="NaN or infinite"):
        hist.record(0, np.array([0.0, np.nan, 0.0, 0.0]))
