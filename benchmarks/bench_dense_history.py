"""Benchmark: the dense path's history sum (``tyreroad.history._history_sum``) against its previous loop order.

The dense path (patches up to ``FFT_THRESHOLD`` = 400 elements, runs within the kept lags: the default
study's 20 x 20 contact runs) sums h_e[n] = sum_{l >= 1} sum_m g_{e-m}[l] F_m[n - l] over the loaded
elements m directly. Before session 24 the target rows were the outermost (parallel) loop, each row
re-deriving every (lag, source) pair and then running a short loop over its ny targets; now each
thread takes a band of rows and the innermost loop runs over a contiguous window of the lag's table.
Both give the same bits (every target sums lags, then sources, in ascending order), which this script
checks before timing.

For each patch (nx = ny = 5, 10, 20), a ring of 255 force fields with a fraction ``--loaded`` of the elements
loaded, and 1 and 2 numba threads: the median time per call of both loop orders and their ratio.
Nothing here fails on time.

Usage: python benchmarks/bench_dense_history.py [--sizes 5 10 20] [--loaded 1.0 0.3] [--repeats 7]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numba
import numpy as np
from numba import njit, prange

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tyreroad.history import DenseHistory, _history_sum  # noqa: E402


@njit(parallel=True)
def _rows_outermost(kern_t, f_ring, nz_idx, nz_cnt, n, nx, ny, out):  # the loop order before session 24
    n_lag = kern_t.shape[0]
    depth = f_ring.shape[0]
    lmax = min(n_lag - 1, n)
    for ex in prange(nx):
        for ey in range(ny):
            out[ex * ny + ey] = 0.0
        for lag in range(1, lmax + 1):
            slot = (n - lag) % depth
            for q in range(nz_cnt[slot]):
                m = nz_idx[slot, q]
                mx = m // ny
                my = m - mx * ny
                f = f_ring[slot, m]
                row = ex - mx + nx - 1
                off = ny - 1 - my
                for ey in range(ny):
                    out[ex * ny + ey] += kern_t[lag, row, ey + off] * f


def _median_seconds(fn, args, repeats: int) -> float:
    fn(*args)  # compile / warm up
    calls = 1
    while True:  # calls per sample: at least ~20 ms
        t = time.perf_counter()
        for _ in range(calls):
            fn(*args)
        if time.perf_counter() - t > 0.02:
            break
        calls *= 2
    samples = []
    for _ in range(repeats):
        t = time.perf_counter()
        for _ in range(calls):
            fn(*args)
        samples.append((time.perf_counter() - t) / calls)
    return statistics.median(samples)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[5, 10, 20])
    parser.add_argument("--loaded", type=float, nargs="+", default=[1.0, 0.3])
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args(argv)
    n_lags = 256
    threads = sorted({1, min(2, numba.config.NUMBA_NUM_THREADS)})
    print(f"dense history sum, {n_lags} lags, ring of {n_lags - 1} force fields; medians of {args.repeats}")
    for n in args.sizes:
        for fraction in args.loaded:
            rng = np.random.default_rng(24)
            history = DenseHistory(rng.standard_normal((2 * n - 1, 2 * n - 1, n_lags)) * 1e-6, (n, n))
            for step in range(n_lags + 44):
                history.displacement(step)
                history.record(step, rng.random(n * n) * (rng.random(n * n) < fraction))
            call = (history._kern_t, history._f_ring, history._nz_idx, history._nz_cnt, n_lags + 44, n, n)
            new_out, old_out = np.empty(n * n), np.empty(n * n)
            _history_sum(*call, new_out, numba.get_num_threads())
            _rows_outermost(*call, old_out)
            if not np.array_equal(new_out, old_out):
                raise SystemExit(f"{n} x {n}: the two loop orders differ ({np.abs(new_out - old_out).max():.3g})")
            for t in threads:
                numba.set_num_threads(t)
                new = _median_seconds(_history_sum, call + (new_out, t), args.repeats)
                old = _median_seconds(_rows_outermost, call + (old_out,), args.repeats)
                print(f"{n:3d} x {n:<3d} loaded {fraction:4.0%}  {t} thread{'s' if t > 1 else ' '}: "
                      f"bands {new * 1e3:8.3f} ms, rows outermost {old * 1e3:8.3f} ms, ratio {old / new:5.2f}x",
                      flush=True)
        numba.set_num_threads(max(threads))


if __name__ == "__main__":
    main()
