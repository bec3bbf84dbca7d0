"""Cost of ``greens.construction: radau`` against the default ``passive`` on the 20 x 20 patch, as the config runs them
(issue 23): the greens stage of each (pipeline.run_greens, once), then dynamic runs on the kernel each file gives
(LayerKernel.from_greens): ramp to 0.2 mm in 256 steps and hold (--steps in all, past the 256 kept lags, so the
tail runs), tread, linear springs of 1e4 N/m (below passive's critical stiffness, so both run), and hard contact
(1e10 N/m) on radau alone. Time per step = wall time of the run / steps, median over --repeats after a warm-up;
passive on its dense path and on solver.method auto (the study's: fft for runs longer than the kept lags).
Then both on nonlinear springs (k = 1.5 c zeta^0.5, F its trapezoid integral, per element; tangent 3e4 N/m at 0.1 mm, like the study's
saturating springs), where the tangent changes at every Newton iteration and both substrates refactor.

    PYTHONPATH=. python benchmarks/bench_radau_config.py [--steps 600] [--repeats 3] [--cache DIR]

Never fails on time; prints figures.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tyreroad import io, pipeline  # noqa: E402
from tyreroad.config import load_config  # noqa: E402
from tyreroad.contact import SolverSettings, solve_path  # noqa: E402
from tyreroad.kernel import LayerKernel  # noqa: E402
from tyreroad.material import material_from_config  # noqa: E402
from tyreroad.springs import linear_tables  # noqa: E402
from tyreroad.stability import fs2_alternation  # noqa: E402

SHAPE = (20, 20)


def greens_file(folder: Path, construction: str, config) -> tuple[Path, float]:
    path = folder / f"tread-{construction}.nc"
    if path.exists():
        return path, float("nan")
    material_cfg = pipeline.resolved_material_config("tread", config["materials"])
    t0 = time.perf_counter()
    pipeline.run_greens("tread", material_cfg, dict(config["greens"], construction=construction), list(SHAPE), 1e-3,
                        path)
    return path, time.perf_counter() - t0


def per_step(kernel, z1, k, d, t, method, repeats, tables=None):
    kt, ft = linear_tables(z1.size, k) if tables is None else tables
    times, res = [], None
    for i in range(repeats + 1):  # the first: warm-up (numba, LU, spectra)
        t0 = time.perf_counter()
        res = solve_path(z1, kt, ft, 1e-6, kernel, d, SolverSettings(method=method), time=t)
        if i:
            times.append((time.perf_counter() - t0) / d.size)
    return statistics.median(times), min(times), max(times), res


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=600)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "tyreroad-bench-radau-config",
                    help="folder of the greens files (kept between runs)")
    args = ap.parse_args(argv)
    args.cache.mkdir(parents=True, exist_ok=True)
    config = load_config(str(ROOT / "config" / "config.yaml"))
    material = material_from_config("tread", config["materials"])
    kernels = {}
    for construction in ("passive", "radau"):
        path, seconds = greens_file(args.cache, construction, config)
        ds = io.read_dataset(path)
        kernels[construction] = LayerKernel.from_greens(ds, "dynamic", material)
        print(f"greens {construction}: {'cached' if seconds != seconds else f'{seconds:.1f} s'}; "
              f"{type(kernels[construction]).__name__}, critical_stiffness {float(ds['critical_stiffness']):.4g} N/m, "
              f"fidelity {float(ds['fidelity_magnitude']):.2e} of |G_0| / {float(ds['fidelity_phase']):.2e} rad; "
              f"file {path.stat().st_size / 1e6:.1f} MB")
    z1 = np.random.default_rng(3).uniform(-4e-5, 0.0, SHAPE)
    ramp = 2e-4 * 0.5 * (1 - np.cos(np.pi * np.arange(1, 257) / 256))
    d = np.concatenate([ramp, np.full(max(args.steps - 256, 1), 2e-4)])
    t = np.arange(d.size) / float(config["greens"]["sample_rate"])
    print(f"patch {SHAPE}, {d.size} steps (ramp 256 to 0.2 mm, hold), median of {args.repeats} after a warm-up")
    rows = {}
    for label, construction, k, method in (("passive dense, 1e4 N/m", "passive", 1e4, "dense"),
                                           ("passive auto, 1e4 N/m", "passive", 1e4, "auto"),
                                           ("radau, 1e4 N/m", "radau", 1e4, "auto"),
                                           ("radau, 1e10 N/m (hard)", "radau", 1e10, "auto")):
        med, lo, hi, res = per_step(kernels[construction], z1, k, d, t, method, args.repeats)
        rows[label] = med
        print(f"  {label:26s}: {med * 1e3:7.2f} ms/step (min {lo * 1e3:.2f}, max {hi * 1e3:.2f}); F(end) "
              f"{res.force[-1]:.4f} N, contact {res.contact_count[-1]}/{z1.size}, Newton "
              f"{res.newton_iterations.mean():.2f}/step, alternation over the hold's last 20 % "
              f"{fs2_alternation(res.force[256:]):.1e}")
    print(f"radau / passive (medians, 1e4 N/m): {rows['radau, 1e4 N/m'] / rows['passive dense, 1e4 N/m']:.2f}x the "
          f"dense path, {rows['radau, 1e4 N/m'] / rows['passive auto, 1e4 N/m']:.2f}x solver.method auto")
    zeta = np.arange(401) * 1e-6  # 0 ... 0.4 mm on the 1 um grid solve_path is given
    c = 3e4 / (1.5 * math.sqrt(1e-4))
    kt = np.broadcast_to(1.5 * c * np.sqrt(zeta), (z1.size, zeta.size)).copy()
    ft = np.concatenate([[0.0], np.cumsum(0.5 * (kt[0, 1:] + kt[0, :-1]) * np.diff(zeta))])  # the tables' contract
    ft = np.broadcast_to(ft, kt.shape).copy()
    for label, construction, method in (("passive auto, nonlinear", "passive", "auto"),
                                        ("radau, nonlinear", "radau", "auto")):
        med, lo, hi, res = per_step(kernels[construction], z1, None, d, t, method, args.repeats, tables=(kt, ft))
        rows[label] = med
        print(f"  {label:26s}: {med * 1e3:7.2f} ms/step (min {lo * 1e3:.2f}, max {hi * 1e3:.2f}); F(end) "
              f"{res.force[-1]:.4f} N, contact {res.contact_count[-1]}/{z1.size}, Newton "
              f"{res.newton_iterations.mean():.2f}/step")
    print(f"radau / passive (medians, nonlinear springs): "
          f"{rows['radau, nonlinear'] / rows['passive auto, nonlinear']:.2f}x solver.method auto")


if __name__ == "__main__":
    main()
