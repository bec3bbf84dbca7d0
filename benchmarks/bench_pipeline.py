"""Benchmark: in-process time of every pipeline stage for the default study (config/config.yaml).

Stages, run in memory on the study surface and the reference material (nothing is written):

* ``prepare_surface``: the study surface preset (one repeat; the ISO 10844 generator is ~3 s),
* ``element_springs``: the reference material's springs (median of 5),
* ``greens_dataset``: the reference material's Green's functions for the study patch; the first
  call is reported separately (numba compilation, or loading numba's on-disk cache), then the
  median of 3,
* ``contact``: one :func:`tyreroad.contact.solve_run` per mode/acceleration of the study (dynamic
  50/250/500 m/s^2 and quasi-static) for the reference material, one warm-up each and then the
  median of 5; the dynamic runs include the backing-force convolution, as in the workflow.

For every stage the table gives median, min and max wall time [s]; for contact also steps,
time per step and Newton iterations. The issue's targets are printed beside the numbers:
springs < 5 s, greens <= 20 s, one dynamic 20 x 20 run to 0.25 mm at 500 m/s^2 <= 5 s warm.
Nothing here fails on time.

Usage: python benchmarks/bench_pipeline.py [--config config/config.yaml] [--threads 1]
       [--cold-numba]

``--threads`` is passed to the contact solver (the workflow's contact rule uses 1 thread).
``--cold-numba`` points numba's cache at an empty temporary directory, so that first calls
include the full compilation instead of loading the project's cache.
"""

from __future__ import annotations

import argparse
import atexit
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _times(fn, repeats: int) -> tuple[list[float], object]:
    """Wall times [s] of ``repeats`` calls of ``fn`` and the last return value."""
    times, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return times, out


def _row(stage: str, times, extra: str = "", target: str = "") -> str:
    import numpy as np

    t = np.asarray(times, dtype=float)
    cells = f"{stage:<34s} {np.median(t):8.3f} {t.min():8.3f} {t.max():8.3f} {t.size:4d}"
    return f"{cells}  {extra:<44s} {target}"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", default=str(ROOT / "config" / "config.yaml"))
    parser.add_argument("--threads", type=int, default=1, help="numba/FFT threads of the contact solver")
    parser.add_argument("--cold-numba", action="store_true", help="compile numba kernels into an empty cache")
    args = parser.parse_args(argv)
    if args.cold_numba:
        # must be set before numba is imported (tyreroad imports it)
        cache = tempfile.mkdtemp(prefix="tyreroad-numba-")
        os.environ["NUMBA_CACHE_DIR"] = cache
        atexit.register(shutil.rmtree, cache, ignore_errors=True)

    import numpy as np

    from tyreroad.config import load_config
    from tyreroad.contact import SolverSettings, solve_run
    from tyreroad.greens import GreensSettings, greens_dataset
    from tyreroad.material import material_from_config
    from tyreroad.pipeline import spring_material_inputs
    from tyreroad.springs import SpringModel, element_springs, resolve_spring_modulus
    from tyreroad.surface import prepare_surface

    cfg = load_config(args.config)
    study = cfg["study"]
    surface_name, ref = study["surface"], study["reference_material"]
    spec = cfg["surfaces"][surface_name]
    load = os.getloadavg()
    print(f"bench_pipeline: {args.config}, surface {surface_name!r}, material {ref!r}, "
          f"{os.cpu_count()} CPUs, contact threads {args.threads}, load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}, "
          f"numba cache {'cold (' + os.environ['NUMBA_CACHE_DIR'] + ')' if args.cold_numba else 'project (warm if built)'}")
    header = f"{'stage':<34s} {'median':>8s} {'min':>8s} {'max':>8s} {'n':>4s}  {'details':<44s} target"
    print(header)
    print("-" * len(header))

    # --- surface -----------------------------------------------------------------------------
    times, surface = _times(lambda: prepare_surface(surface_name, spec, base_dir=ROOT), 1)
    nx, ny = (int(v) for v in spec["patch_elements"])
    print(_row("prepare_surface", times, f"{nx} x {ny} elements, {surface.sizes['x']} x {surface.sizes['y']} samples"),
          flush=True)

    # --- springs -----------------------------------------------------------------------------
    model = SpringModel.from_config(cfg["springs"])
    inputs = spring_material_inputs(ref, cfg["materials"])
    modulus = resolve_spring_modulus(model, inputs["quasi_static_modulus"])

    def springs_call():
        return element_springs(surface, model, modulus=modulus, poisson=inputs["poisson"],
                               thickness=inputs["thickness"])

    first, springs = _times(springs_call, 1)
    times, springs = _times(springs_call, 5)
    t = float(np.median(times))
    print(_row("element_springs", times, f"{model.model}, {springs.sizes['zeta']} grid points; first {first[0]:.3f} s",
               f"< 5 s: {'met' if t < 5 else 'MISSED'}"), flush=True)

    # --- greens ------------------------------------------------------------------------------
    material = material_from_config(ref, cfg["materials"])
    gs = GreensSettings.from_config(cfg["greens"])

    def greens_call():
        return greens_dataset(material, n_elements=(nx, ny), element_size=float(surface.attrs["element_size"]),
                              sample_rate=gs.sample_rate, n_lags=gs.n_lags, n_fft=gs.n_fft)

    first, greens = _times(greens_call, 1)
    print(_row("greens_dataset (first call)", first, "incl. numba compile / cache load",
               f"<= 20 s: {'met' if first[0] <= 20 else 'MISSED'}"), flush=True)
    times, greens = _times(greens_call, 3)
    t = float(np.median(times))
    print(_row("greens_dataset", times, f"{nx} x {ny}, {gs.n_lags} lags, n_fft {gs.n_fft}",
               f"<= 20 s: {'met' if t <= 20 else 'MISSED'}"), flush=True)

    # --- contact -----------------------------------------------------------------------------
    settings = SolverSettings.from_config(cfg["solver"])
    runs = [("dynamic", float(a)) for a in study["accelerations"]] + [("quasistatic", 0.0)]
    method = settings.resolved_method(nx * ny)
    for mode, accel in runs:
        def contact_call(mode=mode, accel=accel):
            return solve_run(surface, springs, greens, material, mode, accel, settings, threads=args.threads)

        warm, result = _times(contact_call, 1)
        times, result = _times(contact_call, 5)
        steps = result.force.size
        its = np.asarray(result.newton_iterations)
        t = float(np.median(times))
        label = f"contact {mode} {accel:g} m/s2" if mode == "dynamic" else "contact quasistatic"
        extra = (f"{steps} steps, {1e3 * t / steps:.1f} ms/step, Newton {its.sum()} "
                 f"({np.median(its):.0f}/step, max {its.max()}); warm-up {warm[0]:.2f} s")
        target = ""
        if mode == "dynamic" and accel == 500.0 and settings.d_max == 2.5e-4 and (nx, ny) == (20, 20):
            target = f"<= 5 s warm: {'met' if t <= 5 else 'MISSED'}"
        print(_row(label, times, extra, target), flush=True)
    print(f"contact method: {method} ({settings.method!r} for {nx * ny} elements), d_max {settings.d_max:g} m, "
          f"tolerance {settings.tolerance:g} m; final force of the last run {result.force[-1]:.3f} N")


if __name__ == "__main__":
    sys.exit(main())
