"""Issue 23, must-show 1: load to 0.2 mm and hold 100 ms on the default 20 x 20 patch, dynamic mode.

For each kernel construction (``--constructions``, greens files built here from the default config), each
material (``--materials``) and each spring set (``default``: the study's springs file; numbers: linear
springs of that stiffness [N/m] on every element), loads at 0.1 m/s to 0.2 mm (2 ms, 102 steps), holds
100 ms (5120 steps) and prints the fs/2 alternation (rms of the fourth difference / 16) of the total force
over the hold's last 20 %, relative to the mean force there, with the kernel's critical stiffness and the
stiffest spring. A run the kernel refuses (springs past its margin, solver.stability = refuse) is printed as
refused with the message's first line — the alternative to a silent oscillation. Never fails; prints figures.

    PYTHONPATH=. python benchmarks/hold_stability.py [--constructions fold passive] [--materials tread tread-rho0.5]
        [--springs default 1e6 1e8 1e10] [--hold 0.1] [--stability refuse|warn] [--results results]
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tyreroad import io  # noqa: E402
from tyreroad.config import load_config  # noqa: E402
from tyreroad.contact import SolverSettings, solve_path  # noqa: E402
from tyreroad.greens import greens_dataset  # noqa: E402
from tyreroad.kernel import LayerKernel  # noqa: E402
from tyreroad.loading import cycle_path  # noqa: E402
from tyreroad.material import material_from_config  # noqa: E402
from tyreroad.pipeline import _judge_kernel  # noqa: E402
from tyreroad.springs import SpringTable, linear_tables  # noqa: E402
from tyreroad.stability import fs2_alternation  # noqa: E402

FS = 51200.0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--constructions", nargs="+", default=["fold"])
    ap.add_argument("--materials", nargs="+", default=["tread", "tread-rho0.5"])
    ap.add_argument("--springs", nargs="+", default=["default", "1e6", "1e8", "1e10"])
    ap.add_argument("--hold", type=float, default=0.1, help="hold time [s]")
    ap.add_argument("--d", type=float, default=2e-4, help="hold indentation [m]")
    ap.add_argument("--stability", choices=["refuse", "warn"], default="refuse",
                    help="solver.stability: warn runs past the margin (to measure what the refusal prevents)")
    ap.add_argument("--results", default=str(ROOT / "results"), help="the default study's results (surface, springs)")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING)
    cfg = load_config(ROOT / "config" / "config.yaml")
    surface_name = cfg["study"]["surface"]
    surface = io.read_dataset(Path(args.results) / "surface" / f"{surface_name}.nc")
    z1 = surface["z1"].transpose("ex", "ey").values
    shape = z1.shape
    t, d, _ = cycle_path(FS, 0.1, args.d, args.hold, 0.1)
    keep = t <= args.d / 0.1 + args.hold + 0.5 / FS
    t, d = t[keep], d[keep]
    hold_start = int(np.searchsorted(t, args.d / 0.1))
    print(f"# {surface_name} {shape[0]} x {shape[1]}: load at 0.1 m/s to {args.d * 1e3:g} mm, hold {args.hold * 1e3:g} ms "
          f"({t.size} steps); alternation over the hold's last 20 % / mean force")
    print("| construction | material | springs | k_crit [N/m] | stiffest spring [N/m] | alternation | F [N] | s |")
    print("|---|---|---|---|---|---|---|---|")
    for construction in args.constructions:
        for name in args.materials:
            mat = material_from_config(name, cfg["materials"])
            gcfg = cfg["greens"]
            ds = greens_dataset(mat, shape, float(surface.attrs.get("element_size", 1e-3)), gcfg["sample_rate"],
                                gcfg["n_lags"], gcfg["n_fft"], construction=construction)
            if construction == "passive":  # as the greens stage does (tyreroad.pipeline.run_greens)
                from tyreroad.construction import correct_greens
                from tyreroad.pipeline import PASSIVE_TARGETS

                base = ds
                for k_target in PASSIVE_TARGETS:
                    ds, correction = correct_greens(base, shape=shape, n_theta=256, n_phi=8, k_target=k_target)
                    if correction.slack >= 0:
                        break
            ds = _judge_kernel(ds, mat, shape, construction)
            kernel = LayerKernel.from_greens(ds, "dynamic", material=mat)
            for spec in args.springs:
                if spec == "default":
                    table = SpringTable.from_dataset(io.read_dataset(Path(args.results) / "springs" / surface_name
                                                                     / f"{name}.nc"))
                    k, f, step = table.stiffness, table.force, table.zeta_step
                else:
                    k, f = linear_tables(int(np.prod(shape)), float(spec))
                    step = 1e-6
                t0 = time.perf_counter()
                try:
                    run = solve_path(z1, k, f, step, kernel, d, SolverSettings(stability=args.stability), time=t)
                except ValueError as err:
                    print(f"| {construction} | {name} | {spec} | {kernel.critical_stiffness:.3g} | {float(np.max(k)):.3g} | "
                          f"refused: {str(err).splitlines()[0][:160]} | - | {time.perf_counter() - t0:.1f} |")
                    continue
                hold = run.force[hold_start:]
                alt = fs2_alternation(hold, fraction=0.2)
                print(f"| {construction} | {name} | {spec} | {kernel.critical_stiffness:.3g} | {float(np.max(k)):.3g} | "
                      f"{alt:.2e} | {hold[-1]:.2f} | {time.perf_counter() - t0:.1f} |", flush=True)


if __name__ == "__main__":
    main()
