"""Issue 23's must-show at full size: load to 0.2 mm and hold 100 ms (5120 steps at 51.2 kHz) on a 20 x 20 patch,
linear springs of 1e6, 1e8 and 1e10 N/m, with the Radau IIA-3 stage kernel and with today's kernel.

Prints per run: the fs/2 alternation over the hold's last 20 % (tyreroad.stability.fs2_alternation; the issue
asks <= 1e-6), the force at the end of the ramp and of the hold, the contact count, Newton iterations, wall time.
Today's kernel runs the same path until it fails (or --today-steps steps: it chatters at 1e6 N/m).

    PYTHONPATH=. python benchmarks/radau_hold.py [--shape 20 20] [--hold 5120] [--today-steps 1500]

Never fails; prints figures.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tyreroad.contact import SolverSettings, solve_path  # noqa: E402
from tyreroad.greens import greens_dataset  # noqa: E402
from tyreroad.kernel import LayerKernel  # noqa: E402
from tyreroad.material import material_from_config  # noqa: E402
from tyreroad.springs import linear_tables  # noqa: E402
from tyreroad.stability import fs2_alternation, nyquist_critical_stiffness  # noqa: E402
from tyreroad.stage import StageKernel  # noqa: E402

FS = 51200.0
C = 1e-3
TREAD = material_from_config("tread", {"tread": {
    "model": "fractional_kelvin_voigt", "E0": 2.5e7, "E1": 5.0e7, "alpha": 0.24, "f1": 1000.0,
    "poisson_ratio": 0.49, "density": 1100.0, "thickness": 0.01}})


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shape", nargs=2, type=int, default=[20, 20])
    ap.add_argument("--hold", type=int, default=5120)
    ap.add_argument("--ramp", type=int, default=256)
    ap.add_argument("--depth", type=float, default=2e-4)
    ap.add_argument("--roughness", type=float, default=4e-5, help="road heights uniform in [-r, 0] [m]")
    ap.add_argument("--stiffness", nargs="+", type=float, default=[1e6, 1e8, 1e10])
    ap.add_argument("--today-steps", type=int, default=1500, help="steps of today's kernel (0: skip it)")
    args = ap.parse_args(argv)
    shape = tuple(args.shape)
    z1 = np.random.default_rng(3).uniform(-args.roughness, 0.0, shape)
    ramp = args.depth * 0.5 * (1 - np.cos(np.pi * np.arange(1, args.ramp + 1) / args.ramp))
    d = np.concatenate([ramp, np.full(args.hold, args.depth)])
    t = np.arange(d.size) / FS
    print(f"patch {shape}, ramp {args.ramp} steps to {args.depth * 1e3:.3f} mm, hold {args.hold} steps "
          f"({args.hold / FS * 1e3:.1f} ms), fs {FS:.0f} Hz")
    t0 = time.perf_counter()
    kernel = StageKernel.from_material(TREAD, shape, C, FS, 256)
    print(f"Radau IIA-3 kernel: {time.perf_counter() - t0:.1f} s to build; {kernel.stage_tail.describe()}")
    for k in args.stiffness:
        kt, ft = linear_tables(z1.size, k)
        t0 = time.perf_counter()
        res = solve_path(z1, kt, ft, 1e-6, kernel, d, SolverSettings(), time=t)
        wall = time.perf_counter() - t0
        hold = res.force[args.ramp:]
        print(f"  stage k = {k:.0e} N/m: alternation {fs2_alternation(hold):.2e}; F(end of ramp) "
              f"{res.force[args.ramp - 1]:.4f} N, F(end of hold) {res.force[-1]:.4f} N; contact "
              f"{res.contact_count[-1]}/{z1.size}; Newton {res.newton_iterations.mean():.2f}/step (max "
              f"{res.newton_iterations.max()}); max residual {res.residual.max():.1e} m; {wall:.1f} s "
              f"({wall / d.size * 1e3:.1f} ms/step)")
    if args.today_steps:
        t0 = time.perf_counter()
        today = LayerKernel.from_greens(greens_dataset(TREAD, shape, C, FS, 256, 4096), "dynamic")
        k_crit, lam = nyquist_critical_stiffness(today, shape)
        print(f"today's kernel: {time.perf_counter() - t0:.1f} s to build; k_crit(fs/2) = {k_crit:.3e} N/m")
        n = min(args.today_steps, d.size)
        for k in args.stiffness:
            kt, ft = linear_tables(z1.size, k)
            t0 = time.perf_counter()
            try:
                res = solve_path(z1, kt, ft, 1e-6, today, d[:n], SolverSettings(method="dense"), time=t[:n])
                print(f"  today k = {k:.0e} N/m, {n} steps: alternation {fs2_alternation(res.force[args.ramp:]):.2e}; "
                      f"{time.perf_counter() - t0:.1f} s")
            except Exception as err:  # noqa: BLE001 - a figure, not a failure
                print(f"  today k = {k:.0e} N/m: {type(err).__name__}: {str(err)[:160]}")


if __name__ == "__main__":
    main()
