"""Benchmark: FFT offset convolution + Newton-Krylov against the dense paths of the contact solver.

For patches 20x20, 40x40, 80x80 and 150x200 elements with L = 256 lags of a synthetic kernel
(local lag 0, slowly spreading and decaying later lags, m/N scale of a 10 mm tread layer) it
prints

* the time per history evaluation h[n] with a full ring (255 past force fields): FFT path vs a
  dense direct sum over the offset table (M^2 L; only where it runs in reasonable time),
* one dense Newton linear solve (M^3) vs one Newton-Krylov step,
* a real indentation run (history + Newton-Krylov + push per step) long enough to fill the ring:
  median time per step after the ring is full, Newton and Krylov iterations per step,
* Krylov iterations of one cold-started step for block-Jacobi tiles 1, 2, 4, 8, with this
  kernel and with a long-range quasi-static kernel (the hard case for GMRES),
* peak memory: tracemalloc peak of the FFT path and the process's max RSS.

Each patch size runs in its own subprocess so that max RSS belongs to that size. Timings are
medians of repeats; nothing here fails on time.

Usage: python benchmarks/bench_convolution.py [--sizes 20x20,40x40,80x80,150x200] [--threads 2]
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import time
import tracemalloc

import numpy as np

N_LAGS = 256
SAMPLE_RATE = 51200.0  # Hz
D_MAX = 2.5e-4  # m


def synthetic_kernel(nx: int, ny: int, n_lags: int = N_LAGS) -> np.ndarray:
    """g[dx, dy, lag] [m/N]: lag 0 local (1e-5 m/N self, decay length 0.7 element), later lags
    spreading (0.7 + 0.1 l elements) and decaying (e-folding 20 lags), like a damped layer."""
    dx = np.arange(-(nx - 1), nx)[:, None, None]
    dy = np.arange(-(ny - 1), ny)[None, :, None]
    lag = np.arange(n_lags)[None, None, :]
    r = np.hypot(dx, dy)
    width = 0.7 + 0.1 * lag
    amp = np.where(lag == 0, 1e-5, 0.3e-5 * np.exp(-lag / 20.0) * (0.7 / width) ** 2)
    return amp * np.exp(-r / width)


def quasistatic_kernel(nx: int, ny: int) -> np.ndarray:
    """One-lag long-range kernel 4e-5 exp(-r/10) / (1 + r) [m/N] (static layer-like)."""
    dx = np.arange(-(nx - 1), nx)[:, None, None]
    dy = np.arange(-(ny - 1), ny)[None, :, None]
    r = np.hypot(dx, dy)
    return 4e-5 * np.exp(-r / 10.0) / (1.0 + r)


class Springs:
    """k = k0 (1 + zeta / zeta_s), F = k0 (zeta + zeta^2 / (2 zeta_s)) for zeta > 0, else 0."""

    def __init__(self, shape, rng):
        self.k0 = rng.uniform(1e4, 5e4, shape)
        self.zs = 5e-5

    def __call__(self, zeta):
        z = np.maximum(zeta, 0.0)
        k0 = self.k0.reshape(np.shape(zeta))
        return k0 * (z + 0.5 * z * z / self.zs), np.where(zeta > 0, k0 * (1.0 + z / self.zs), 0.0)

    def contact_stiffness(self):
        """k(0+) [N/m] of every spring (the springs protocol of tyreroad.newton.solve_step)."""
        return self.k0.ravel()

    def evaluate_into(self, zeta, force_out, stiffness_out):
        """The springs protocol of tyreroad.newton.solve_step (flat arrays)."""
        force_out[:], stiffness_out[:] = self(zeta)


def nk_step(rhs, zeta0, springs, conv, tol=1e-12, max_iter=50, block=4, substrate=None):
    """One matrix-free Newton step through the package's driver (FFT substrate)."""
    from tyreroad.newton import FFTSubstrate, solve_step

    substrate = substrate or FFTSubstrate(conv, tol, block=block)
    return solve_step(np.ravel(rhs), np.ravel(zeta0), springs, substrate, tol, max_iter)


def _median_time(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def _dense_history_kernel():
    from numba import njit, prange

    @njit(cache=True, parallel=True)
    def _dense_history(kern, f_ring, newest, n_terms, out):  # pragma: no cover - numba
        # out[e] = sum_{j<n_terms} sum_m g[e - m, j + 1] F_m[slot(newest + j)]: M^2 L work
        nx, ny = out.shape
        depth = f_ring.shape[0]
        for ex in prange(nx):
            for ey in range(ny):
                acc = 0.0
                for j in range(n_terms):
                    s = (newest + j) % depth
                    for mx in range(nx):
                        for my in range(ny):
                            acc += kern[ex - mx + nx - 1, ey - my + ny - 1, j + 1] * f_ring[s, mx, my]
                out[ex, ey] = acc

    return _dense_history


def bench_size(nx: int, ny: int, threads: int) -> None:
    from tyreroad.convolution import OffsetConvolution
    from tyreroad.history import FFTHistory
    from tyreroad.newton import FFTSubstrate

    rng = np.random.default_rng(0)
    m = nx * ny
    print(f"\n=== patch {nx} x {ny} (M = {m}), L = {N_LAGS}, threads = {threads} ===", flush=True)
    g = synthetic_kernel(nx, ny)
    springs = Springs((nx, ny), rng)
    z1 = -rng.uniform(0.0, 3e-4, (nx, ny))

    tracemalloc.start()
    t0 = time.perf_counter()
    conv = OffsetConvolution(g, (nx, ny), workers=threads)
    t_build = time.perf_counter() - t0
    acc = FFTHistory(conv)
    print(f"FFT grid {conv.padded}, kernel spectra {conv.nbytes / 2**20:.1f} MiB, "
          f"ring {acc.nbytes / 2**20:.1f} MiB, build {t_build:.2f} s")

    # --- history with a full ring -------------------------------------------------------------
    depth = N_LAGS - 1
    f_ring = rng.uniform(0.0, 5.0, (depth, nx, ny)) * (rng.random((depth, nx, ny)) < 0.5)
    pushed = [0]

    def push():
        acc.record(pushed[0], f_ring[pushed[0] % depth])
        pushed[0] += 1

    t_push = _median_time(push, depth)
    acc.displacement(depth)  # numba compile / warm-up
    reps = 20 if m <= 6400 else 7
    t_hist = _median_time(lambda: acc.displacement(depth), reps)
    print(f"history (full ring, {depth} lags): FFT {t_hist * 1e3:.2f} ms, push {t_push * 1e3:.2f} ms")

    dense_budget = {400: 5, 1600: 3, 6400: 1}
    if m in dense_budget:
        kern = np.ascontiguousarray(g)
        # the ring above was pushed in order 0..depth-1; slot arrays of the dense sum in that order
        f_slots = np.ascontiguousarray(f_ring[::-1])
        out = np.empty((nx, ny))
        dense_history = _dense_history_kernel()
        dense_history(kern[:2, :2, :2], f_slots[:1, :1, :1], 0, 1, out[:1, :1])
        t_dense = _median_time(lambda: dense_history(kern, f_slots, 0, depth, out), dense_budget[m])
        err = np.max(np.abs(acc.displacement(depth) - out.ravel())) / np.max(np.abs(out))
        print(f"history dense direct sum (M^2 L): {t_dense * 1e3:.1f} ms -> FFT speed-up {t_dense / t_hist:.0f}x "
              f"(max rel. difference {err:.1e})")
    else:
        print("history dense direct sum: skipped (M^2 L = %.1e multiply-adds)" % (m * m * depth))

    # --- one synthetic step: Newton-Krylov vs dense Newton -------------------------------------
    acc2 = FFTHistory(conv)
    rhs = z1 + 1.5e-4
    sol = nk_step(rhs, rhs, springs, conv)
    t_nk = _median_time(lambda: nk_step(rhs, rhs, springs, conv), 3)
    print(f"cold step (d = 0.15 mm, no history, {np.mean(sol.zeta > 0) * 100:.0f} % in contact): "
          f"Newton-Krylov {t_nk * 1e3:.1f} ms, {sol.newton_iterations} Newton / {sol.krylov_iterations} Krylov, "
          f"|R| = {sol.residual:.1e} m")
    if m <= 6400:
        ex, ey = np.divmod(np.arange(m), ny)
        g0 = g[ex[:, None] - ex[None, :] + nx - 1, ey[:, None] - ey[None, :] + ny - 1, 0]
        _, k = springs(sol.zeta)
        jac = np.eye(m) + g0 * k.ravel()[None, :]
        r = rng.standard_normal(m)
        t_lu = _median_time(lambda: np.linalg.solve(jac, r), 3 if m <= 1600 else 1)
        print(f"dense Newton linear solve (M^3): {t_lu * 1e3:.1f} ms per Newton iteration "
              f"(x{sol.newton_iterations} = {t_lu * sol.newton_iterations * 1e3:.0f} ms per step)")
        del g0, jac

    for name, kernel in (("dynamic lag 0", g), ("quasi-static long-range", quasistatic_kernel(nx, ny))):
        conv_k = conv if kernel is g else OffsetConvolution(kernel, (nx, ny), workers=threads)
        counts = []
        for block in (1, 2, 4, 8):
            t0 = time.perf_counter()
            s = nk_step(rhs, rhs, springs, conv_k, block=block)
            counts.append(f"b={block}: {s.newton_iterations}N/{s.krylov_iterations}K {1e3 * (time.perf_counter() - t0):.0f} ms")
        print(f"cold step, {name}: " + "; ".join(counts))
        del conv_k

    # --- a real indentation run that fills the ring ----------------------------------------------
    n_steps = N_LAGS + 45 if m <= 6400 else N_LAGS + 20
    accel = 2.0 * D_MAX * SAMPLE_RATE**2 / (n_steps - 1) ** 2
    d = 0.5 * accel * (np.arange(n_steps) / SAMPLE_RATE) ** 2
    gap0 = (z1 - z1.max()).ravel()
    zeta = gap0.copy()
    b_prev = gap0.copy()
    substrate = FFTSubstrate(conv, 1e-12, block=4)
    step_t, step_cpu, hist_t, newton, krylov = [], [], [], [], []
    t_run = time.perf_counter()
    for n in range(n_steps):
        t0, c0 = time.perf_counter(), time.process_time()
        h = acc2.displacement(n)
        hist_t.append(time.perf_counter() - t0)
        b = gap0 + d[n] - h
        sol = nk_step(b, zeta + (b - b_prev), springs, conv, substrate=substrate)
        acc2.record(n, sol.force)
        step_t.append(time.perf_counter() - t0)
        step_cpu.append(time.process_time() - c0)
        zeta, b_prev = sol.zeta, b
        newton.append(sol.newton_iterations)
        krylov.append(sol.krylov_iterations)
    t_run = time.perf_counter() - t_run
    full = slice(N_LAGS, None)
    st = np.array(step_t[full])
    sc = np.array(step_cpu[full])
    sh = np.array(hist_t[full])
    print(f"run: {n_steps} steps to d = {d[-1] * 1e3:.3f} mm (a = {accel:.1f} m/s^2) in {t_run:.1f} s; "
          f"final contact {np.mean(zeta > 0) * 100:.0f} %, force {sol.force.sum():.1f} N")
    print(f"  per step with full ring: median {np.median(st) * 1e3:.1f} ms wall (history {np.median(sh) * 1e3:.1f} ms), "
          f"{np.median(sc) * 1e3:.1f} ms CPU (all threads), max {st.max() * 1e3:.1f} ms wall; "
          f"Newton/step median {np.median(newton[N_LAGS:]):.0f} (max {max(newton)}), "
          f"Krylov/step median {np.median(krylov[N_LAGS:]):.0f} (max {max(krylov)})")
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20  # kB -> GiB
    print(f"peak memory: tracemalloc {peak / 2**30:.2f} GiB, process max RSS {rss:.2f} GiB", flush=True)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="20x20,40x40,80x80,150x200")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--one", action="store_true", help="run the given size in this process")
    args = parser.parse_args(argv)
    sizes = [tuple(int(v) for v in s.split("x")) for s in args.sizes.split(",")]
    if args.one:
        import numba

        numba.set_num_threads(min(args.threads, numba.config.NUMBA_NUM_THREADS))
        for nx, ny in sizes:
            bench_size(nx, ny, args.threads)
        return
    print(f"bench_convolution: {os.cpu_count()} CPUs, threads = {args.threads}, load average {os.getloadavg()}")
    for nx, ny in sizes:
        subprocess.run(
            [sys.executable, __file__, "--one", "--sizes", f"{nx}x{ny}", "--threads", str(args.threads)],
            check=False,
        )


if __name__ == "__main__":
    main()
