"""Candidate march kernels (issue 23): fidelity to the element FRF and stability margin over the unit circle.

For each material (default ``tread``) at fs = 51.2 kHz, 256 lags, element 1 mm, measures

* today's kernel (``greens_dataset``: band-limited IFFT + precursor correction + creep tail);
* CQ backward Euler and CQ BDF2 (:mod:`tyreroad.cq`): the 256 kept weights alone (no tail: the CQ kernel
  would need its own, not built), and the full CQ symbol G(delta(e^{-i theta}) fs) (= infinitely many
  weights, what a CQ kernel with an exact tail would be);
* blends "FRF below f_b, BDF2 symbol above, raised-cosine crossover +-0.05 fs", then today's causal fold
  (IFFT, precursor, creep tail), for f_b in --blend (units of fs);

and prints, per candidate: fidelity over 10 Hz - 5 kHz (worst relative magnitude error / worst phase error
at the excitation element and over all offsets of the 20 x 20 patch, up to 19 elements), the stability
margin min p over theta in [0, pi] (>= 2001 points, minima refined) on 8 x 8 and 20 x 20 patches with
where, the spring bound k_crit over the circle and -1/lambda_min G_d(-1), |g_255| / |g_0|, and timings.

    PYTHONPATH=. python benchmarks/bench_kernel_candidates.py [--materials tread tread-rho0.5]
        [--blend 0.25 0.3 0.35] [--n-theta 2001] [--no-symbol]

Never fails; prints figures.
"""

from __future__ import annotations

import argparse
import logging
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tyreroad import cq  # noqa: E402
from tyreroad.config import load_config  # noqa: E402
from tyreroad.greens import greens_dataset, unique_offsets  # noqa: E402
from tyreroad.kernel import LayerKernel  # noqa: E402
from tyreroad.material import material_from_config  # noqa: E402

FS = 51200.0
C = 1e-3
N_LAGS = 256
N_FFT = 4096
BIG = (20, 20)
PATCHES = [(8, 8), (20, 20)]
FREQS = np.geomspace(10.0, 5000.0, 160)


def crop(tables, shape):
    nx, ny = shape
    cx, cy = (tables.shape[1] - 1) // 2, (tables.shape[2] - 1) // 2
    return tables[:, cx - (nx - 1): cx + nx, cy - (ny - 1): cy + ny]


def fmt_k(k):
    return "inf" if not math.isfinite(k) else f"{k:.3g}"


def margin_text(res):
    bands = res.failing_bands()
    band = ""
    if bands:
        band = " fails " + ", ".join(f"{a / np.pi:.4f}-{b / np.pi:.4f}pi" for a, b in bands[:3])
        if len(bands) > 3:
            band += f" (+{len(bands) - 3})"
    return (f"min p {res.min_p:+.3e} m/N at {res.theta_min / np.pi:.4f}pi; k_crit {fmt_k(res.k_crit)} N/m"
            + (f" at {res.theta_k / np.pi:.4f}pi" if math.isfinite(res.k_crit) else "")
            + f"; k(fs/2) {fmt_k(res.k_nyquist)}; {res.evaluations} eigs {res.seconds:.0f} s" + band)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--materials", nargs="+", default=["tread"])
    ap.add_argument("--blend", nargs="*", type=float, default=[0.25, 0.3, 0.35])
    ap.add_argument("--methods", nargs="*", default=["backward_euler", "bdf2"])
    ap.add_argument("--n-theta", type=int, default=2001)
    ap.add_argument("--no-symbol", action="store_true", help="skip the full-CQ-symbol margins (element_laplace)")
    ap.add_argument("--max-full", type=int, default=300)
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    cfg = load_config(str(ROOT / "config" / "config.yaml"))
    rows = []
    for name in args.materials:
        mat = material_from_config(name, cfg["materials"])
        print(f"\n=== {name}: fs {FS:g} Hz, {N_LAGS} lags, patch {BIG}, element {C * 1e3:g} mm ===", flush=True)
        t = time.perf_counter()
        exact = cq.exact_frf(mat, BIG, C, FREQS)
        print(f"exact element FRF, {FREQS.size} frequencies 10 Hz - 5 kHz: {time.perf_counter() - t:.1f} s", flush=True)
        kernels = []
        t = time.perf_counter()
        today = LayerKernel.from_greens(greens_dataset(mat, BIG, C, FS, N_LAGS, N_FFT), "dynamic")
        kernels.append(("today IFFT+tail", today, time.perf_counter() - t, "1x / 1x (256 lags + tail)"))
        for method in args.methods:
            t = time.perf_counter()
            k = cq.cq_kernel(mat, BIG, C, FS, N_LAGS, method)
            kernels.append((f"CQ {method} 256 lags, no tail", k, time.perf_counter() - t,
                            f"1x / 1x + a tail to build; |g255/g0| = {cq.weight_decay(k):.3g}"))
        for fb in args.blend:
            t = time.perf_counter()
            ds = greens_dataset(mat, BIG, C, FS, N_LAGS, N_FFT, frf_map=cq.blend_map(mat, C, FS, fb))
            kernels.append((f"blend FRF/BDF2 at {fb:g} fs + fold", LayerKernel.from_greens(ds, "dynamic"),
                            time.perf_counter() - t, "1x / 1x (256 lags + tail)"))
        for label, kernel, seconds, cost in kernels:
            fid = cq.fidelity(cq.unique_entries(kernel.own_frequency_response(FREQS, BIG), BIG), exact)
            resp = cq.unique_entries(kernel.own_frequency_response(FREQS, BIG), BIG)
            scaled = float(np.max(np.abs(resp - exact) / np.abs(exact[:, :1])))
            line = [f"\n[{label}] built in {seconds:.1f} s; {cost}; worst |K - G| / |G_self| {scaled:.2%}",
                    f"  fidelity: excitation {fid['excitation'][0]:.2%} / {fid['excitation'][1]:.4f} rad; "
                    f"worst offset {fid['worst'][0]:.2%} / {fid['worst'][1]:.4f} rad (unique offsets "
                    f"#{fid['worst_offset']}: {[tuple(int(v) for v in unique_offsets(BIG)[i]) for i in fid['worst_offset']]})"]
            margins = {}
            for shape in PATCHES:
                res = cq.kernel_margin(kernel, shape, n_theta=args.n_theta, max_full=args.max_full)
                margins[shape] = res
                line.append(f"  margin {shape[0]}x{shape[1]}: {margin_text(res)}")
            print("\n".join(line), flush=True)
            rows.append((name, label, fid, margins))
        if args.no_symbol:
            continue
        for method in args.methods:
            t = time.perf_counter()
            theta_f = 2 * np.pi * FREQS / FS
            sym_f = cq.cq_symbol(mat, BIG, C, FS, theta_f, method)
            fid = cq.fidelity(cq.unique_entries(sym_f, BIG), exact)
            scaled = float(np.max(np.abs(cq.unique_entries(sym_f, BIG) - exact) / np.abs(exact[:, :1])))
            cache = {}

            def big_symbol(theta, method=method, cache=cache):
                theta = np.asarray(theta, dtype=float)
                key = theta.tobytes()
                if key not in cache:
                    cache[key] = cq.cq_symbol(mat, BIG, C, FS, theta, method)
                return cache[key]

            line = [f"\n[CQ {method} full symbol (infinite lags = with an exact tail)] "
                    f"fidelity: excitation {fid['excitation'][0]:.2%} / {fid['excitation'][1]:.4f} rad; "
                    f"worst offset {fid['worst'][0]:.2%} / {fid['worst'][1]:.4f} rad "
                    f"(#{fid['worst_offset']}); worst |K - G| / |G_self| {scaled:.2%}"]
            # where is the BDF2/BE symbol within 1 % / 0.01 rad at every offset?
            ratio = cq.unique_entries(sym_f, BIG) / exact
            ok = (np.abs(np.abs(ratio) - 1) <= 0.01) & (np.abs(np.angle(ratio)) <= 0.01)
            bad_f = FREQS[~ok.all(axis=1)]
            ok_e = (np.abs(np.abs(ratio[:, 0]) - 1) <= 0.01) & (np.abs(np.angle(ratio[:, 0])) <= 0.01)
            line.append(f"  within 1 % / 0.01 rad at every offset up to {bad_f.min() if bad_f.size else FREQS[-1]:.0f} Hz;"
                        f" at the excitation element up to "
                        f"{FREQS[~ok_e].min() if (~ok_e).any() else FREQS[-1]:.0f} Hz")
            for shape in PATCHES:
                sym = big_symbol if shape == BIG else (lambda th, s=shape: crop(big_symbol(th), s))
                res = cq.stability_margin(sym, shape, n_theta=args.n_theta, max_full=min(args.max_full, 60),
                                          refine_minima=4)
                line.append(f"  margin {shape[0]}x{shape[1]}: {margin_text(res)}")
            line.append(f"  ({time.perf_counter() - t:.0f} s)")
            print("\n".join(line), flush=True)
    print("\nsummary (fidelity = magnitude / phase, 10 Hz - 5 kHz; margin on 20 x 20)")
    print(f"{'material':14s} {'kernel':38s} {'excitation':>18s} {'worst offset':>18s} {'min p [m/N]':>12s} "
          f"{'at':>8s} {'k_crit [N/m]':>12s} {'k(fs/2)':>10s}")
    for name, label, fid, margins in rows:
        r = margins[BIG]
        print(f"{name:14s} {label:38s} {fid['excitation'][0]:8.2%} / {fid['excitation'][1]:.4f} "
              f"{fid['worst'][0]:8.2%} / {fid['worst'][1]:.4f} {r.min_p:+12.3e} {r.theta_min / np.pi:7.4f}pi "
              f"{fmt_k(r.k_crit):>12s} {fmt_k(r.k_nyquist):>10s}")


if __name__ == "__main__":
    main()
