"""FFT/Newton-Krylov path against the dense reference path on the study's own cases.

Re-solves every contact run of results/ (made by `snakemake -j2` with the default, dense,
path for the 20 x 20 patch) with ``solver.method = "fft"`` and prints the largest relative
difference of the total and element forces, and the time of both paths.

    python benchmarks/compare_paths.py [results]
"""

import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

from tyreroad import io
from tyreroad.config import load_config
from tyreroad.contact import SolverSettings, solve_run
from tyreroad.material import material_from_config


def main(results: Path) -> None:
    config = load_config("config/config.yaml")
    study = config["study"]
    dense_settings = SolverSettings.from_config(config["solver"])
    fft_settings = dataclasses.replace(dense_settings, method="fft")
    surface = io.read_dataset(results / "surface" / f"{study['surface']}.nc")
    worst = 0.0
    print(f"{'case':34s} {'max rel dF total':>17s} {'max rel dF_e':>13s} {'t dense [s]':>12s} {'t fft [s]':>10s}")
    for name in study["materials"]:
        material = material_from_config(name, config["materials"])
        springs = io.read_dataset(results / "springs" / study["surface"] / f"{name}.nc")
        greens = io.read_dataset(results / "greens" / f"{name}.nc")
        runs = [("quasistatic", 0.0)] + [("dynamic", float(a)) for a in study["accelerations"]]
        for mode, accel in runs:
            kwargs = dict(surface=surface, springs=springs, greens=greens, material=material, mode=mode, acceleration=accel)
            t0 = time.perf_counter()
            dense = solve_run(settings=dense_settings, **kwargs)
            t1 = time.perf_counter()
            fft = solve_run(settings=fft_settings, **kwargs)
            t2 = time.perf_counter()
            scale = np.abs(dense.force).max()
            d_total = np.max(np.abs(fft.force - dense.force)) / scale
            d_elem = np.max(np.abs(fft.element_force - dense.element_force)) / scale
            worst = max(worst, d_total, d_elem)
            print(f"{name + '/' + mode + '/' + format(accel, 'g'):34s} {d_total:17.2e} {d_elem:13.2e} {t1 - t0:12.2f} {t2 - t1:10.2f}")
    print(f"worst relative difference (normalised by the run's largest total force): {worst:.2e} (target 1e-10)")


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "results"))
