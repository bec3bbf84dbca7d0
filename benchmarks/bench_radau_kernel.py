"""The Radau IIA-3 stage kernel (issue 23) against today's kernel: cost per step, fidelity, stability margin.

* cost per step on the 20 x 20 patch: today's kernel (256 lags + creep tail; dense and FFT paths) on soft
  springs (1e4 N/m, below its k_crit ~ 2.4e4 N/m, so that it runs) and the stage kernel on 1e4 and 1e10 N/m, over a
  ramp-and-hold of --steps steps (long memory on);
* the 150 x 200 full ring: the history sum per step (the part that scales with the lags) of today's
  FFTHistory (256 lags) and of the stage FFT history, measured on --ring-lags lags, plus the difference of its
  lag sum alone at 256 and at --ring-lags lags timed on a tenth of the frequency bins and scaled
  (LABELLED AS AN ESTIMATE: the stage kernel has no matrix-free substrate yet, so no full step is run there);
* fidelity over 10 Hz - 5 kHz of the march's own transfer function (kept lags + tail, read at the step's end
  for a force sampled at the stages) and of the full symbol, against the exact element FRF: excitation element
  and worst offset of the patch;
* the stability margin over theta in (0, pi], (a) the issue's criterion: springs equal at the three stages
  (S = I_3 x diag(k_e)) commute with the eigenvectors V of Delta, so I + S^(1/2) G(Delta / h) S^(1/2) is
  nonsingular iff each I + S^(1/2) G(d_k / h) S^(1/2) is (d_k the eigenvalues of Delta(e^{-i theta})), which the
  single-stage margin p(G(d_k / h)) > 0 guarantees (tyreroad.cq's p: max_phi lambda_min Re(e^{i phi} G)):
  p(theta) = min_k p(G(d_k / h)) of the full symbol, and for the march's own kernel (kept lags + tail) the
  same of the diagonal blocks of (V^-1 x I) S_own (V x I), with the size of its off-diagonal blocks (the
  truncation's coupling); (b) the stricter criterion for springs that differ between stages,
  max_phi lambda_min Herm(e^{i phi} B^(1/2) S_own B^(-1/2)) (B = diag(b) x I), which a layer with inertia
  need not meet (its compliance is not positive real).

    PYTHONPATH=. python benchmarks/bench_radau_kernel.py [--steps 600] [--margin-shape 8 8] [--no-ring]

Never fails on time; prints figures.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import scipy.optimize

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tyreroad import radau  # noqa: E402
from tyreroad.contact import SolverSettings, solve_path  # noqa: E402
from tyreroad.convolution import OffsetConvolution  # noqa: E402
from tyreroad.cq import _element_laplace_fn, exact_frf, fidelity, unique_entries  # noqa: E402
from tyreroad.greens import greens_dataset, unique_offsets  # noqa: E402
from tyreroad.history import FFTHistory  # noqa: E402
from tyreroad.influence import offset_matrix  # noqa: E402
from tyreroad.kernel import LayerKernel  # noqa: E402
from tyreroad.material import material_from_config  # noqa: E402
from tyreroad.springs import linear_tables  # noqa: E402
from tyreroad.stage import StageFFTHistory, StageKernel, _stage_accumulate  # noqa: E402

FS = 51200.0
C = 1e-3
TREAD = material_from_config("tread", {"tread": {
    "model": "fractional_kelvin_voigt", "E0": 2.5e7, "E1": 5.0e7, "alpha": 0.24, "f1": 1000.0,
    "poisson_ratio": 0.49, "density": 1100.0, "thickness": 0.01}})
FREQS = np.geomspace(10.0, 5000.0, 160)


def per_step(kernel, z1, k, steps, method):
    ramp = 2e-4 * 0.5 * (1 - np.cos(np.pi * np.arange(1, 257) / 256))
    d = np.concatenate([ramp, np.full(max(steps - 256, 1), 2e-4)])
    kt, ft = linear_tables(z1.size, k)
    t0 = time.perf_counter()
    res = solve_path(z1, kt, ft, 1e-6, kernel, d, SolverSettings(method=method), time=np.arange(d.size) / FS)
    return (time.perf_counter() - t0) / d.size, res


def creep_check(material, n_lags=256, n_ref=4096):
    """Step response of the step's end value to a unit force held at every stage from t = 0 (1 x 1 patch):
    kept lags + tail against 4096 directly computed block weights; max difference over the 4096 steps
    relative to G(0), and where."""
    kernel = StageKernel.from_material(material, (1, 1), C, FS, n_lags)
    fn = _element_laplace_fn(material, unique_offsets((1, 1)) * C, C)
    ref = radau.radau_weights(fn, n_ref, 1 / FS)[:, 2, :, 0].sum(axis=1).cumsum()
    kept = kernel.stage_lags[0, 0, :, 2, :].sum(axis=1)
    tail = kernel.stage_tail
    beyond = tail.block_weights(np.arange(n_lags, n_ref))[:, 2, :].sum(axis=1) * tail.shape_table[0, 0, 2]
    own = np.concatenate([kept, beyond]).cumsum()
    g0 = float(kernel.static_table[0, 0])
    err = np.abs(own - ref) / g0
    i = int(np.argmax(err))
    return float(err.max()), i, float(abs(ref[-1] - own[-1]) / g0), float(abs(ref[-1] / g0 - 1))


def hist_bytes(shape, n_lags=256):
    """Table spectra + ring of the stage FFT history [B] (real spectra on the padded rfft grid)."""
    import scipy.fft
    px = scipy.fft.next_fast_len(2 * shape[0] - 1, real=True)
    py = scipy.fft.next_fast_len(2 * shape[1] - 1, real=True) // 2 + 1
    return px * py * (n_lags - 1) * 3 * (3 + 2 * 2) * 8


def even_table(rng, shape, extra):
    nx, ny = shape
    t = rng.standard_normal((2 * nx - 1, 2 * ny - 1) + extra)
    return t + t[::-1] + t[:, ::-1] + t[::-1, ::-1]


def time_history(hist, m, steps, rng):
    f = rng.standard_normal(m)
    for n in range(3):  # warm-up
        hist.displacement(n)
        hist.record(n, f)
    t0 = time.perf_counter()
    for n in range(3, 3 + steps):
        hist.displacement(n)
        hist.record(n, f)
    return (time.perf_counter() - t0) / steps


def margin(symbol, theta, weighted):
    """p(theta) of the block symbols S (n, 3 M, 3 M) (stage-major)."""
    m3 = symbol.shape[1]
    w = np.repeat(np.sqrt(radau.RADAU_B), m3 // 3)
    out = np.empty(theta.size)
    for i in range(theta.size):
        s = symbol[i] * (w[:, None] / w[None, :]) if weighted else symbol[i]

        def lam(phi):
            h = np.exp(1j * phi) * s
            return float(np.linalg.eigvalsh(0.5 * (h + h.conj().T))[0])

        phis = np.linspace(-np.pi / 2, np.pi / 2, 9)
        vals = [lam(p) for p in phis]
        b = int(np.argmax(vals))
        step = phis[1] - phis[0]
        res = scipy.optimize.minimize_scalar(lambda p: -lam(p), bounds=(max(phis[b] - step, -np.pi / 2),
                                             min(phis[b] + step, np.pi / 2)), method="bounded")
        out[i] = max(max(vals), -res.fun)
    return out


def single_margin(g):
    """max_phi lambda_min Re(e^{i phi} G) of a complex symmetric G (M x M) [m/N] (tyreroad.cq's p)."""
    def lam(phi):
        h = np.exp(1j * phi) * g
        return float(np.linalg.eigvalsh(0.5 * (h + h.conj().T))[0])

    phis = np.linspace(-np.pi / 2, np.pi / 2, 9)
    vals = [lam(p) for p in phis]
    b = int(np.argmax(vals))
    step = phis[1] - phis[0]
    res = scipy.optimize.minimize_scalar(lambda p: -lam(p), bounds=(max(phis[b] - step, -np.pi / 2),
                                         min(phis[b] + step, np.pi / 2)), method="bounded")
    return max(max(vals), -res.fun)


def eigen_margins(kernel, material, theta, shape):
    """(a) of the module docstring: p(theta) of the full symbol and of the own kernel's eigen-blocks, and the
    own kernel's largest off-diagonal eigen-block (2-norm) over its smallest diagonal one."""
    m = shape[0] * shape[1]
    lam, vec = np.linalg.eig(radau.radau_delta(np.exp(-1j * theta)))
    fn = _element_laplace_fn(material, unique_offsets(shape) * C, C)
    s = (lam * FS).ravel()
    g = fn(s.real.clip(min=0.0) + 1j * s.imag)  # (n * 3, n_offsets); Re s >= 0 up to rounding near theta = 0
    from tyreroad.greens import offset_table_index
    _, _, index = offset_table_index(shape)
    full = np.array([single_margin(offset_matrix(t[index])) for t in g]).reshape(theta.size, 3).min(axis=1)
    own_p, coupling = np.empty(theta.size), np.empty(theta.size)
    blocks = block_matrices(kernel, theta, shape)
    for t in range(theta.size):
        big_v = np.kron(vec[t], np.eye(m))
        big_vi = np.kron(np.linalg.inv(vec[t]), np.eye(m))
        tr = big_vi @ blocks[t] @ big_v
        diag = [tr[k * m:(k + 1) * m, k * m:(k + 1) * m] for k in range(3)]
        own_p[t] = min(single_margin(0.5 * (d + d.T)) for d in diag)
        off = max(np.linalg.norm(tr[i * m:(i + 1) * m, j * m:(j + 1) * m], 2)
                  for i in range(3) for j in range(3) if i != j)
        coupling[t] = off / min(np.linalg.norm(d, 2) for d in diag)
    return full, own_p, coupling


def block_matrices(kernel, theta, shape):
    sym = kernel.block_symbol(theta, shape)  # (n, 3, 3, x, y)
    m = shape[0] * shape[1]
    out = np.empty((theta.size, 3 * m, 3 * m), dtype=complex)
    for i in range(3):
        for j in range(3):
            for t in range(theta.size):
                out[t, i * m:(i + 1) * m, j * m:(j + 1) * m] = offset_matrix(sym[t, i, j])
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=600)
    ap.add_argument("--ring-lags", type=int, default=16)
    ap.add_argument("--margin-shape", nargs=2, type=int, default=[8, 8])
    ap.add_argument("--n-theta", type=int, default=400)
    ap.add_argument("--no-ring", action="store_true")
    ap.add_argument("--only-cost", action="store_true", help="the 20 x 20 cost per step only")
    args = ap.parse_args(argv)
    shape = (20, 20)
    rng = np.random.default_rng(3)
    z1 = rng.uniform(-4e-5, 0.0, shape)

    t0 = time.perf_counter()
    stage = StageKernel.from_material(TREAD, shape, C, FS, 256)
    t_stage = time.perf_counter() - t0
    t0 = time.perf_counter()
    today = LayerKernel.from_greens(greens_dataset(TREAD, shape, C, FS, 256, 4096), "dynamic")
    t_today = time.perf_counter() - t0
    print(f"build 20 x 20, 256 lags: stage kernel {t_stage:.1f} s, today's greens + kernel {t_today:.1f} s")

    # ---- cost per step, 20 x 20
    print(f"\ncost per step, 20 x 20, {args.steps} steps (ramp 256 + hold), 1 process, 1 thread")
    costs = {}
    for method in ("dense", "fft"):
        costs[method], _ = per_step(today, z1, 1e4, args.steps, method)
        print(f"  today's kernel, {method} path, k = 1e4 N/m: {costs[method] * 1e3:.2f} ms/step")
    c_today = min(costs.values())
    print(f"  (ratios below: against today's faster path, {min(costs, key=costs.get)})")
    for k in (1e4, 1e10):
        c, res = per_step(stage, z1, k, args.steps, "auto")
        print(f"  stage kernel,   k = {k:.0e} N/m: {c * 1e3:.2f} ms/step = {c / c_today:.1f} x today's "
              f"(Newton {res.newton_iterations.mean():.2f}/step)")

    if args.only_cost:
        return

    # ---- 150 x 200: the history per step (estimate)
    if not args.no_ring:
        ring = (150, 200)
        m = ring[0] * ring[1]
        print(f"\n150 x 200 full ring, history sum per step (ESTIMATE: the stage history measured on "
              f"{args.ring_lags} lags, its lag sum alone at 256 lags on a tenth of the bins; no full stage step: no "
              "matrix-free stage substrate)")
        g = even_table(rng, ring, (256,))
        h_today = time_history(FFTHistory(OffsetConvolution(g, ring, workers=1)), m, 20, rng)
        del g
        print(f"  today's FFTHistory, 256 lags: {h_today * 1e3:.1f} ms/step (measured)")
        gl = even_table(rng, ring, (args.ring_lags, 3, 3))
        hist = StageFFTHistory(gl, ring)
        small = time_history(hist, 3 * m, 20, rng)
        bins = hist._bins
        del hist, gl
        print(f"  stage FFT history, {args.ring_lags} lags: {small * 1e3:.1f} ms/step (measured)")
        # the lag sum alone, on a tenth of the bins, at 16 lags and at 256 (flops linear in the bins)
        part = bins // 10
        acc = np.empty((part, 3, 2))
        lag_sum = {}
        for lags in (args.ring_lags, 256):
            g = rng.standard_normal((part, 3, 3 * (lags - 1)))
            ring_re = rng.standard_normal((part, 2 * 3 * (lags - 1)))
            ring_im = rng.standard_normal((part, 2 * 3 * (lags - 1)))
            _stage_accumulate(g, ring_re, ring_im, 0, 3 * (lags - 1), acc)
            t0 = time.perf_counter()
            for _ in range(10):
                _stage_accumulate(g, ring_re, ring_im, 0, 3 * (lags - 1), acc)
            lag_sum[lags] = (time.perf_counter() - t0) / 10 * bins / part
            del g, ring_re, ring_im
        scaled = small + lag_sum[256] - lag_sum[args.ring_lags]
        print(f"  its lag sum alone (a tenth of the bins, scaled): {lag_sum[args.ring_lags] * 1e3:.1f} ms at "
              f"{args.ring_lags} lags, {lag_sum[256] * 1e3:.1f} ms at 256")
        print(f"  stage FFT history at 256 lags: {scaled * 1e3:.0f} ms/step = {scaled / h_today:.1f} x today's "
              f"(ESTIMATE); table spectra + ring would take {hist_bytes(ring) / 1e9:.1f} GB at 256 lags "
              f"(today's: {hist_bytes(ring) / 21 * 3 / 1e9:.1f} GB)")

    # ---- fidelity, 20 x 20
    print("\nfidelity, 10 Hz - 5 kHz, 20 x 20 (magnitude / phase [rad]; excitation element, worst offset)")
    exact = exact_frf(TREAD, shape, C, FREQS)
    own = unique_entries(stage.own_frequency_response(FREQS, shape), shape)
    fn = _element_laplace_fn(TREAD, unique_offsets(shape) * C, C)
    full = radau.stage_transfer(radau.radau_symbol(fn, 2 * np.pi * FREQS / FS, 1 / FS), FREQS, FS)
    today_own = unique_entries(today.own_frequency_response(FREQS, shape), shape)
    for name, resp in (("stage kernel (256 lags + tail)", own), ("Radau full symbol", full),
                       ("today's kernel (256 lags + tail)", today_own)):
        fid = fidelity(resp, exact)
        absolute = float((np.abs(resp - exact) / np.abs(exact[:, :1])).max())
        print(f"  {name}: {fid['excitation'][0]:.1e} / {fid['excitation'][1]:.1e} at the excitation element, "
              f"{fid['worst'][0]:.1e} / {fid['worst'][1]:.1e} worst offset "
              f"{tuple(unique_offsets(shape)[fid['worst_offset'][0]])}; max |K - G| / |G_00| over all offsets "
              f"{absolute:.1e}")
    cut = stage.truncation(TREAD, (4, 4))
    print(f"  cut off beyond the kept lags + tail (sum over lags 256-1023 of max |W_rem|, / W_0[3,3] at offset 0): "
          f"{cut['excitation']:.1e} excitation, {cut['worst']:.1e} worst offset; max |W_255| / W_0 = "
          f"{cut['last_kept']:.1e}")

    err, at, end, relaxed = creep_check(TREAD)
    print(f"  held unit force, 1 x 1 patch: kept 256 lags + tail vs 4096 direct weights: max error {err:.1e} of G(0) "
          f"(at step {at}), {end:.1e} at step 4095 (80 ms; the step response is then {1 - relaxed:.3f} of G(0))")

    # ---- margin
    ms = tuple(args.margin_shape)
    theta = np.linspace(np.pi / args.n_theta, np.pi, args.n_theta)
    small = StageKernel.from_material(TREAD, ms, C, FS, 256)
    t0 = time.perf_counter()
    full, own_p, coupling = eigen_margins(small, TREAD, theta, ms)
    for name, p in (("full symbol", full), ("own kernel (256 lags + tail), eigen-blocks", own_p)):
        i = int(np.argmin(p))
        print(f"\nmargin (a), {ms}, equal springs at the stages, {theta.size} theta in (0, pi], {name}: min p = "
              f"{p[i]:.3e} m/N at theta = {theta[i] / np.pi:.4f} pi; p(pi) = {p[-1]:.3e} m/N")
    print(f"  own kernel's eigen-block coupling (off-diagonal / diagonal, 2-norm): max {coupling.max():.1e} "
          f"({time.perf_counter() - t0:.0f} s)")
    mats = block_matrices(small, theta, ms)
    p = margin(mats, theta, True)
    i = int(np.argmin(p))
    print(f"margin (b), springs differing between stages, B-weighted: min p = {p[i]:.3e} m/N at theta = "
          f"{theta[i] / np.pi:.4f} pi; p(pi) = {p[-1]:.3e} m/N (negative: not guaranteed by construction)")

if __name__ == "__main__":
    main()
