"""The default kernel construction (issue 23): today's fold + the excitation element's spring-safe FIR.

Per material (default: the study's five) at fs = 51.2 kHz, 256 lags, n_fft 4096, 1 mm elements, 20 x 20 patch:

* fidelity of kernel + tail against the exact element FRF (:func:`tyreroad.cq.exact_frf`) over 10 Hz - 5 kHz,
  in three norms: per offset relative (|K/G| - 1, arg K/G: every offset, also where |G| is 1e-4 of
  |G_00|), per offset where |G_offset| >= 1 % |G_00| at that frequency, and |K - G| / |G_00| (the error
  relative to the excitation element's response, every offset);
* the stability margin of the corrected kernel on 20 x 20 (:func:`tyreroad.cq.kernel_margin`, dense theta,
  minima refined): min p, where, k_crit and where, k(fs/2); today's k(fs/2) for reference;
* the Toeplitz-symbol certificate (:func:`tyreroad.construction.symbol_support`) min over theta (patch-
  independent lower bound of p for the patch and its sub-patches; conservative, reported only);
* timings: today's greens stage, the construction (greens + design).

    PYTHONPATH=. python benchmarks/bench_default_kernel.py [--materials tread tread-rho0.5] [--n-theta 4001]
        [--small 8] [--big 40]

``--small``/``--big`` add tread patches: the 20 x 20 design's taps applied to the tread kernel of that patch
(the correction is a self-offset term, the same on every patch), k(fs/2) and a margin scan
(--big-theta points). Never fails; prints figures.
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

from tyreroad import construction, cq  # noqa: E402
from tyreroad.config import load_config  # noqa: E402
from tyreroad.greens import greens_dataset, unique_offsets  # noqa: E402
from tyreroad.influence import offset_matrix  # noqa: E402
from tyreroad.kernel import LayerKernel  # noqa: E402
from tyreroad.material import material_from_config  # noqa: E402

FS = 51200.0
C = 1e-3
N_LAGS = 256
N_FFT = 4096
SHAPE = (20, 20)
FREQS = np.geomspace(10.0, 5000.0, 160)
MATERIALS = ["tread", "tread-rho0.5", "tread-rho2", "tread-eta0.5", "tread-eta1.5"]


def fidelity_norms(kernel, shape, exact):
    resp = cq.unique_entries(kernel.own_frequency_response(FREQS, shape), shape)
    fid = cq.fidelity(resp, exact)
    ratio = resp / exact
    big = np.abs(exact) >= 0.01 * np.abs(exact[:, :1])
    mag_big = float(np.where(big, np.abs(np.abs(ratio) - 1), 0).max())
    ph_big = float(np.where(big, np.abs(np.angle(ratio)), 0).max())
    scaled = np.abs(resp - exact) / np.abs(exact[:, :1])
    return {"excitation": fid["excitation"], "per_offset": fid["worst"],
            "per_offset_where": [tuple(int(v) for v in unique_offsets(shape)[i]) for i in fid["worst_offset"]],
            "big": (mag_big, ph_big), "scaled": float(scaled.max()), "scaled_off": float(scaled[:, 1:].max()),
            "smallest_failing": float((np.abs(exact) / np.abs(exact[:, :1])).min(axis=0)[
                (fid["magnitude"] > 0.01) | (fid["phase"] > 0.01)].max(initial=0.0))}


def k_nyquist(kernel, shape):
    g = kernel.own_frequency_response(np.array([FS / 2]), shape)[0]
    lam = np.linalg.eigvalsh(offset_matrix(g).real)[0]
    return math.inf if lam >= 0 else -1.0 / lam


def fmt_k(k):
    return "inf" if not math.isfinite(k) else f"{k:.3g}"


def symbol_min(kernel, shape, n_grid=2048):
    mem = kernel.memory
    lags = kernel.table(shape)
    _, tables = construction.transfer_tables(lags, mem.residual_compliance[
        (mem.residual_compliance.shape[0] - 1) // 2 - (shape[0] - 1): (mem.residual_compliance.shape[0] - 1) // 2 + shape[0],
        (mem.residual_compliance.shape[1] - 1) // 2 - (shape[1] - 1): (mem.residual_compliance.shape[1] - 1) // 2 + shape[1]],
        mem.weights, mem.decays, n_grid)
    phi, h = construction.symbol_support(tables, 181, pads=[(2 * shape[0] - 1, 2 * shape[1] - 1)])
    p = h.max(axis=1)
    return float(p.min()), float(np.pi * p.argmin() / n_grid)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--materials", nargs="+", default=MATERIALS)
    ap.add_argument("--n-theta", type=int, default=4001)
    ap.add_argument("--max-full", type=int, default=300)
    ap.add_argument("--small", type=int, nargs="*", default=[8])
    ap.add_argument("--big", type=int, nargs="*", default=[])
    ap.add_argument("--big-theta", type=int, default=201)
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    cfg = load_config(str(ROOT / "config" / "config.yaml"))
    rows = []
    tread_taps = None
    for name in args.materials:
        mat = material_from_config(name, cfg["materials"])
        print(f"\n=== {name}: fs {FS:g} Hz, {N_LAGS} lags, patch {SHAPE}, element {C * 1e3:g} mm ===", flush=True)
        exact = cq.exact_frf(mat, SHAPE, C, FREQS)
        t = time.perf_counter()
        ds_today = greens_dataset(mat, SHAPE, C, FS, N_LAGS, N_FFT)
        t_today = time.perf_counter() - t
        today = LayerKernel.from_greens(ds_today, "dynamic")
        t = time.perf_counter()
        ds, corr = construction.default_kernel(mat, SHAPE, C, FS, N_LAGS, N_FFT)
        t_new = time.perf_counter() - t
        kernel = LayerKernel.from_greens(ds, "dynamic")
        if name == "tread":
            tread_taps = corr
        print(corr.summary(), flush=True)
        for note in corr.notes:
            print("  note:", note)
        out = {}
        for label, k in (("today", today), ("default", kernel)):
            f = fidelity_norms(k, SHAPE, exact)
            out[label] = f
            print(f"[{label}] fidelity 10 Hz-5 kHz: excitation {f['excitation'][0]:.2%} / {f['excitation'][1]:.4f} rad; "
                  f"per offset {f['per_offset'][0]:.2%} / {f['per_offset'][1]:.4f} at {f['per_offset_where']} "
                  f"(failing offsets have |G| >= {f['smallest_failing']:.2g} |G_00| at most); where |G| >= 1 % |G_00|: "
                  f"{f['big'][0]:.2%} / {f['big'][1]:.4f}; |K - G| / |G_00| {f['scaled']:.2%} "
                  f"(other offsets {f['scaled_off']:.2%})", flush=True)
        t = time.perf_counter()
        res = cq.kernel_margin(kernel, SHAPE, n_theta=args.n_theta, max_full=args.max_full)
        kn_today = k_nyquist(today, SHAPE)
        sym = symbol_min(kernel, SHAPE)
        print(f"[default] margin 20x20 ({args.n_theta} theta, {time.perf_counter() - t:.0f} s): min p {res.min_p:+.3e} m/N at "
              f"{res.theta_min / np.pi:.4f} pi; k_crit {fmt_k(res.k_crit)} N/m"
              + (f" at {res.theta_k / np.pi:.4f} pi" if math.isfinite(res.k_crit) else "")
              + f"; k(fs/2) {fmt_k(res.k_nyquist)} (today {fmt_k(kn_today)}); failing bands "
              f"{[(round(a / np.pi, 4), round(b / np.pi, 4)) for a, b in res.failing_bands()][:6]}; "
              f"symbol certificate min {sym[0]:+.3e} at {sym[1] / np.pi:.4f} pi", flush=True)
        print(f"time: today's greens stage {t_today:.1f} s; default construction {t_new:.1f} s "
              f"({t_new / t_today:.1f}x; design {corr.seconds:.1f} s)", flush=True)
        rows.append((name, out, res, kn_today, corr, t_today, t_new))
    if tread_taps is not None:
        mat = material_from_config("tread", cfg["materials"])
        for n in list(args.small) + list(args.big):
            shape = (n, n)
            ds = greens_dataset(mat, shape, C, FS, N_LAGS, N_FFT)
            base = LayerKernel.from_greens(ds, "dynamic")
            lags = construction.apply_correction(base.lags, tread_taps)
            k = LayerKernel.dynamic(lags, FS, base.memory, element_size=C)
            t = time.perf_counter()
            nt = args.n_theta if n <= 20 else args.big_theta
            res = cq.kernel_margin(k, shape, n_theta=nt, max_full=args.max_full if n <= 20 else 40)
            print(f"\n[tread {n}x{n}, the 20x20 taps] k(fs/2) {fmt_k(res.k_nyquist)} (today {fmt_k(k_nyquist(base, shape))}); "
                  f"{nt} theta: min p {res.min_p:+.3e} at {res.theta_min / np.pi:.4f} pi; k_crit {fmt_k(res.k_crit)}"
                  + (f" at {res.theta_k / np.pi:.4f} pi" if math.isfinite(res.k_crit) else "")
                  + f" ({time.perf_counter() - t:.0f} s)", flush=True)
    print("\nsummary (20 x 20; fidelity 10 Hz - 5 kHz magnitude / phase; N1 = |K - G| / |G_00|, N2 = per offset "
          "where |G| >= 1 % |G_00|)")
    print(f"{'material':13s} {'excitation':>16s} {'N1 worst':>9s} {'N2 worst':>17s} {'per offset':>17s} "
          f"{'min p [m/N]':>12s} {'at':>8s} {'k_crit [N/m]':>12s} {'at':>8s} {'k(fs/2)':>9s} {'today':>8s} {'time':>12s}")
    for name, out, res, kn_today, corr, t_today, t_new in rows:
        f = out["default"]
        print(f"{name:13s} {f['excitation'][0]:7.2%} / {f['excitation'][1]:.4f} {f['scaled']:8.2%} "
              f"{f['big'][0]:7.2%} / {f['big'][1]:.4f} {f['per_offset'][0]:7.2%} / {f['per_offset'][1]:.4f} "
              f"{res.min_p:+12.3e} {res.theta_min / np.pi:7.4f}pi {fmt_k(res.k_crit):>12s} "
              f"{(res.theta_k / np.pi if math.isfinite(res.k_crit) else float('nan')):7.4f}pi {fmt_k(res.k_nyquist):>9s} "
              f"{fmt_k(kn_today):>8s} {t_new:5.0f}/{t_today:.0f} s")


if __name__ == "__main__":
    main()
