"""Cost of a dynamic step on a patterned tread (issue 27, tyreroad.pattern_dynamic), on the pattern study's patch.

Reads a modes file (results/greens/pattern-modes/{pattern}.nc, rule pattern_modes) and marches a ramp to 0.2 mm in
200 steps plus a hold (--steps in all, past the 256 kept lags so the creep tail runs) on the pattern surface's
85 x 40 patch with linear springs of 1e4 and 1e6 N/m (every block element in contact; stiffer springs on a flat
punch over whole 20 mm blocks do not converge at the first impact: see docs/pattern.md), tread. Prints the time per step (median over --repeats), the substrate's
factorisations, the history's memory, the fs/2 alternation of the hold and the kernel's build time.

    PYTHONPATH=. python benchmarks/bench_pattern_dynamic.py [--pattern block20] [--steps 600] [--repeats 3]

Never fails on time; prints figures.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tyreroad import io  # noqa: E402
from tyreroad.config import load_config  # noqa: E402
from tyreroad.contact import SolverSettings, run_loading_path  # noqa: E402
from tyreroad.loading import IndentationPath  # noqa: E402
from tyreroad.material import material_from_config  # noqa: E402
from tyreroad.pattern import groove_springs  # noqa: E402
from tyreroad.pattern_dynamic import PatternStageHistory, kernel_from_modes  # noqa: E402
from tyreroad.springs import SpringTable, linear_tables  # noqa: E402
from tyreroad.stability import fs2_alternation  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pattern", default="block20")
    ap.add_argument("--steps", type=int, default=600)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    cfg = load_config(ROOT / "config/config.yaml")
    path = ROOT / f"results/greens/pattern-modes/{args.pattern}.nc"
    if not path.exists():
        raise SystemExit(f"{path}: missing; run `snakemake -j1 {path.relative_to(ROOT)}` first")
    modes = io.read_dataset(path)
    material = material_from_config("tread", cfg["materials"])
    spec = cfg["surfaces"][cfg["pattern"]["surface"]]
    shape = tuple(spec["patch_elements"])
    fs = float(cfg["greens"]["sample_rate"])
    t0 = time.perf_counter()
    kernel = kernel_from_modes(modes, material, shape, tuple(cfg["pattern"]["patch_origin"]), fs,
                               int(cfg["greens"]["n_lags"]))
    t_build = time.perf_counter() - t0
    layout = kernel.layout
    history = PatternStageHistory(layout, kernel.form, kernel.weights)
    print(f"pattern {args.pattern}: {kernel.form.n_modes} modes, block {layout.geometry.block_elements}, "
          f"{len(layout.blocks)} blocks on the {shape} patch ({layout.whole_blocks()} whole); kernel built in "
          f"{t_build:.2f} s; kept-lag history {history.nbytes / 1e6:.1f} MB")
    z1 = np.zeros(shape)
    n_ramp = 200
    d = np.r_[np.linspace(0.0, 2e-4, n_ramp), np.full(max(args.steps - n_ramp, 0), 2e-4)]
    settings = SolverSettings(d_max=2e-4, method="dense")
    for k in (1e4, 1e6):
        kt, ft = linear_tables(z1.size, k)
        springs = groove_springs(SpringTable.checked(kt, ft, 1e-6, z1.size), layout.grooved)
        times = []
        for _ in range(args.repeats):
            t0 = time.perf_counter()
            res = run_loading_path(IndentationPath(z1, d, np.arange(d.size) / fs), springs, kernel, settings)
            times.append(time.perf_counter() - t0)
        med = statistics.median(times)
        print(f"  springs {k:.0e} N/m: {d.size} steps, median {med:.2f} s = {1e3 * med / d.size:.2f} ms/step "
              f"(runs {', '.join(f'{t:.2f}' for t in times)} s); F(end) {res.force[-1]:.2f} N, hold's fs/2 "
              f"alternation {fs2_alternation(res.force):.1e}")


if __name__ == "__main__":
    main()
