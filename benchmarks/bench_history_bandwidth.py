"""Benchmark: the FFT path's history sum against the memory bandwidth of this machine.

With a full ring the dynamic step's history h[n] is, per frequency bin k of the padded grid,
sum_{l=1}^{L-1} G_l[k] F[n-l][k] (``tyreroad.history._accumulate_real`` for the layer's even
kernels). It reads the kernel spectra and the ring of force spectra once per step and does two
multiply-adds per 24 bytes read, so its speed limit is the memory bandwidth, not arithmetic.

For each patch size this prints, with 1 and 2 numba threads:

* the accumulate kernel alone (bytes it must read, median time, achieved GB/s);
* a streaming read of the same three arrays (numba, the same multiply-adds on contiguous data):
  what this machine's memory delivers to that access pattern;
* the whole ``FFTHistory.displacement`` (accumulate plus one inverse transform);
* the ratio accumulate / streaming read (1.0 = at the bandwidth).

Medians of ``--repeats`` calls, after a warm-up; nothing here fails on time. The kernel is the
synthetic 256-lag kernel of ``bench_convolution.py``; the ring holds 255 random force fields.

Usage: python benchmarks/bench_history_bandwidth.py [--sizes 150x200,300x400] [--repeats 30]
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numba
import numpy as np
from numba import njit, prange

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from bench_convolution import N_LAGS, synthetic_kernel  # noqa: E402

from tyreroad.convolution import OffsetConvolution  # noqa: E402
from tyreroad.history import FFTHistory, _accumulate_real  # noqa: E402


@njit(cache=True, parallel=True, fastmath=True)
def _stream_read(a, b, c):  # pragma: no cover - numba
    """sum(a b) and sum(a c) over contiguous rows: the accumulate's reads without the ring's wrap."""
    n_rows, n_cols = a.shape
    out = np.empty((n_rows, 2))
    for k in prange(n_rows):
        s = 0.0
        t = 0.0
        for j in range(n_cols):
            s += a[k, j] * b[k, j]
            t += a[k, j] * c[k, j]
        out[k, 0] = s
        out[k, 1] = t
    return out


def _median_time(fn, repeats: int) -> float:
    fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def run_size(nx: int, ny: int, repeats: int, threads: int) -> dict:
    rng = np.random.default_rng(7)
    kernel = synthetic_kernel(nx, ny, N_LAGS)
    conv = OffsetConvolution(kernel, (nx, ny), workers=threads)
    history = FFTHistory(conv)
    for n in range(N_LAGS):
        history.record(n, rng.random(nx * ny) * (rng.random(nx * ny) < 0.5))
    g_re, _ = conv.lag_spectra
    ring_re, ring_im = history._ring_re, history._ring_im
    n_bins, depth = g_re.shape
    out_re, out_im = np.empty(n_bins), np.empty(n_bins)
    numba.set_num_threads(threads)
    t_acc = _median_time(lambda: _accumulate_real(g_re, ring_re, ring_im, history._newest, depth, out_re, out_im),
                         repeats)
    t_stream = _median_time(lambda: _stream_read(g_re, ring_re, ring_im), repeats)
    t_disp = _median_time(lambda: history.displacement(N_LAGS), repeats)
    read = g_re.nbytes + ring_re.nbytes + ring_im.nbytes
    return {"bins": n_bins, "depth": depth, "bytes": read, "acc": t_acc, "stream": t_stream, "disp": t_disp}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", default="150x200,300x400")
    parser.add_argument("--repeats", type=int, default=30)
    args = parser.parse_args(argv)
    print(f"bench_history_bandwidth: {os.cpu_count()} CPUs, load average "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}, {N_LAGS} lags, medians of {args.repeats}")
    print("patch    threads  read MiB  accumulate ms  GB/s   stream-read ms  GB/s   accumulate/stream  "
          "displacement ms")
    for size in args.sizes.split(","):
        nx, ny = (int(v) for v in size.lower().split("x"))
        for threads in (1, 2):
            r = run_size(nx, ny, args.repeats, threads)
            gbs_acc = r["bytes"] / r["acc"] / 1e9
            gbs_stream = r["bytes"] / r["stream"] / 1e9
            print(f"{size:8s} {threads:7d} {r['bytes'] / 2**20:9.1f} {r['acc'] * 1e3:14.2f} {gbs_acc:5.2f} "
                  f"{r['stream'] * 1e3:15.2f} {gbs_stream:5.2f} {r['acc'] / r['stream']:18.2f} "
                  f"{r['disp'] * 1e3:16.2f}")


if __name__ == "__main__":
    main()
