"""Benchmark: the real contact physics at growing patch sizes, FFT/Newton-Krylov against dense.

For each patch size (default 20x20, 40x40, 80x80 and 150x200 elements of 1 mm) this runs the
study's own stages, not a synthetic kernel:

1. ``prepare_surface``: a synthetic ISO 10844 preset (the study preset of config/config.yaml with
   ``patch_elements`` set, and ``field_size`` = max(0.1 m, patch + 10 mm margin on each side)),
   patch chosen by the study's rule (``contact_fraction``: 40-65 % of the element peaks within
   0.15 mm of the top; with the config's rolled stone tops it finds such a window at every size
   here, 150x200 included),
2. ``element_springs`` of the reference material,
3. ``greens_dataset`` of the reference material at that patch size (timed: the issue's
   "Green's-function stage time"),
4. one dynamic run at 500 m/s^2 with the config's 256 lags to d_max = 0.25 mm (53 steps at
   51.2 kHz) via :func:`tyreroad.contact.solve_run`, with ``method='fft'`` and, up to
   ``--dense-max-elements`` (default 1600, i.e. 20x20 and 40x40), with ``method='dense'``.

Stages 1+2, stage 3 and every run execute in their own fresh subprocess (sizes one after the
other), so the peak memory ``resource.getrusage(RUSAGE_SELF).ru_maxrss`` of each is its own.
Inputs pass between them as netCDF files in a temporary directory.

Time per step: the Newton driver :func:`tyreroad.newton.solve_step` (both paths, as the march
loop of :mod:`tyreroad.contact` calls it) is wrapped to record a time stamp at the start
of every step solve; the interval between two stamps is one full step (Newton solve, storing the
step, the next step's history sum). The wrapper on the FFT path also records the Krylov
(GMRES matrix-vector product) count per step. Each path is first warmed up untimed on a 4x4
corner with the same method (numba compilation or cache load), then run ``--repeats`` times
(default 3); a step's time is its median over the repeats, and the table gives the median, min,
max and mean over the steps, the median of the last 10 steps (most elements in contact) and the
setup time before the first step (input checks, kernel spectra or dense lag-0 matrix).
Note that a 500 m/s^2 run has 53 steps, so its history sums use at most 52 of the 255 past
lags; ``benchmarks/bench_convolution.py`` times a full ring with a synthetic kernel.

Printed beside the numbers (targets of issue 7; nothing here fails on time): 150x200 dynamic with
256 lags completes, median time per step <= 0.2 s on 2 cores, peak memory <= 8 GiB; at 40x40 the
FFT path >= 10x faster per step than dense; FFT and dense total forces agree to 1e-10 relative on
20x20.

Usage: python benchmarks/bench_scale.py [--sizes 20x20,40x40,80x80,150x200] [--quick]
       [--threads 2] [--repeats 3] [--dense-max-elements 1600] [--acceleration 500] [--config ...]

The dense path is off above 1600 elements by default: at 80x80 its lag-0 matrix (312 MiB) and
history fit in memory (1.3 GiB peak measured), but its step solve is a dense elimination over the
loaded elements, O(A^3): one 80x80 run took 28 min on 2 shared cores (late steps 100-150 s each).
At 150x200 the lag-0 matrix alone would need 6.9 GiB.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
ALL_SIZES = "20x20,40x40,80x80,150x200"
QUICK_SIZES = "20x20,40x40"
MARGIN = 0.01  # m, surface field beyond the patch on each side
MIN_FIELD = 0.1  # m, the generator's default field (ISO 13473-1 MPD needs 0.1 m)


def _max_rss_gib() -> float:
    """Peak resident memory of this process [GiB] (Linux reports ru_maxrss in KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20


def _config(path: str) -> dict:
    from tyreroad.config import load_config

    return load_config(path)


def _surface_spec(cfg: dict, nx: int, ny: int, element_size: float) -> tuple[str, dict]:
    study_surface = cfg["study"]["surface"]
    spec = dict(cfg["surfaces"][study_surface])
    if spec.get("generator") != "iso10844":
        raise ValueError(f"surfaces.{study_surface}.generator: bench_scale needs 'iso10844', got {spec.get('generator')!r}")
    spec["patch_elements"] = [nx, ny]
    spec["field_size"] = [max(MIN_FIELD, n * element_size + 2 * MARGIN) for n in (nx, ny)]
    spec.setdefault("patch_selection", "contact_fraction")
    return f"{study_surface}-{nx}x{ny}", spec


# ----------------------------------------------------------------------------------------------
# Child processes (one stage or one run each)
# ----------------------------------------------------------------------------------------------
def child_prep(args) -> dict:
    """Surface and springs of one patch size; writes z1 and the spring tables."""
    import xarray as xr

    from tyreroad.pipeline import spring_material_inputs
    from tyreroad.springs import SpringModel, element_springs, resolve_spring_modulus
    from tyreroad.surface import prepare_surface

    cfg = _config(args.config)
    nx, ny = args.nx, args.ny
    base_spec = cfg["surfaces"][cfg["study"]["surface"]]
    element_size = float(base_spec.get("element_size", 1e-3))
    name, spec = _surface_spec(cfg, nx, ny, element_size)
    t0 = time.perf_counter()
    surface = prepare_surface(name, spec, base_dir=ROOT)
    t_surface = time.perf_counter() - t0
    depths = surface["peak_fraction_within"]
    frac = float(depths.sel(depth=0.15e-3, method="nearest"))

    ref = cfg["study"]["reference_material"]
    model = SpringModel.from_config(cfg["springs"])
    inputs = spring_material_inputs(ref, cfg["materials"])
    t0 = time.perf_counter()
    springs = element_springs(surface, model, modulus=resolve_spring_modulus(model, inputs["quasi_static_modulus"]),
                              poisson=inputs["poisson"], thickness=inputs["thickness"])
    t_springs = time.perf_counter() - t0

    out = Path(args.workdir)
    # the run needs z1 and the spring tables only; the fine heights and areas stay behind
    xr.Dataset({"z1": surface["z1"]}, attrs=dict(surface.attrs)).to_netcdf(out / "surface.nc")
    springs[["stiffness", "force"]].to_netcdf(out / "springs.nc")
    return {
        "surface_s": t_surface,
        "springs_s": t_springs,
        "field_size": spec["field_size"],
        "rule": spec["patch_selection"],
        "fraction_015": frac,
        "element_size": element_size,
        "max_rss_gib": _max_rss_gib(),
    }


def child_greens(args) -> dict:
    """Green's functions of the reference material at this patch size (the timed stage)."""
    from tyreroad.greens import GreensSettings, greens_dataset
    from tyreroad.material import material_from_config

    cfg = _config(args.config)
    ref = cfg["study"]["reference_material"]
    material = material_from_config(ref, cfg["materials"])
    gs = GreensSettings.from_config(cfg["greens"])
    t0 = time.perf_counter()
    ds = greens_dataset(material, n_elements=(args.nx, args.ny), element_size=args.element_size,
                        sample_rate=gs.sample_rate, n_lags=gs.n_lags, n_fft=gs.n_fft)
    t_greens = time.perf_counter() - t0
    rss = _max_rss_gib()
    ds[["g"]].to_netcdf(Path(args.workdir) / "greens.nc")
    return {"greens_s": t_greens, "n_lags": gs.n_lags, "table_mib": ds["g"].nbytes / 2**20, "max_rss_gib": rss}


def child_run(args) -> dict:
    """One dynamic run with ``args.method``; step stamps through wrappers (module docstring)."""
    import numpy as np
    import xarray as xr

    import tyreroad.contact as contact
    from tyreroad.material import material_from_config

    cfg = _config(args.config)
    material = material_from_config(cfg["study"]["reference_material"], cfg["materials"])
    settings = contact.SolverSettings.from_config({**cfg["solver"], "method": args.method})
    wd = Path(args.workdir)
    with xr.open_dataset(wd / "surface.nc") as ds:
        surface = ds.load()
    with xr.open_dataset(wd / "springs.nc") as ds:
        springs = ds.load()
    with xr.open_dataset(wd / "greens.nc") as ds:
        greens = ds.load()
    rss_loaded = _max_rss_gib()

    stamps: list[float] = []
    krylov: list[int] = []
    step_solver = contact.solve_step  # the one Newton driver, as the march loop calls it

    def timed_step(*a, **k):
        stamps.append(time.perf_counter())
        sol = step_solver(*a, **k)
        krylov.append(int(sol.krylov_iterations))
        return sol

    contact.solve_step = timed_step

    # warm-up: numba compile / cache load on a 4x4 corner with the same method (same signatures)
    z1 = surface["z1"].transpose("ex", "ey").values
    zeta = springs["zeta"].values
    kern = greens["g"].transpose("dx", "dy", "lag").values
    sub = slice(0, 4)
    t0 = time.perf_counter()
    contact.solve_dynamic(z1[sub, sub], springs["stiffness"].values[sub, sub], springs["force"].values[sub, sub],
                          zeta[1], kern, float(greens.attrs["sample_rate"]), args.acceleration, settings, args.threads)
    t_warm = time.perf_counter() - t0
    stamps.clear()
    krylov.clear()

    runs, setups = [], []
    for _ in range(args.repeats):
        stamps.clear()
        krylov.clear()
        t0 = time.perf_counter()
        result = contact.solve_run(surface, springs, greens, material, "dynamic", args.acceleration, settings,
                                   threads=args.threads)
        runs.append(time.perf_counter() - t0)
        setups.append(stamps[0] - t0)
        intervals = np.diff(np.asarray(stamps))
        if len(runs) == 1:
            per_step = np.empty((args.repeats, intervals.size))
        per_step[len(runs) - 1] = intervals
    # median over repeats step by step: one noisy repeat does not move a step's time
    steps = np.median(per_step, axis=0)
    np.save(wd / f"force_{args.method}.npy", result.force)
    its = np.asarray(result.newton_iterations)
    return {
        "method": args.method,
        "steps": int(result.force.size),
        "repeats": args.repeats,
        "run_s": float(np.median(runs)),
        "run_min_s": float(min(runs)),
        "run_max_s": float(max(runs)),
        "setup_s": float(np.median(setups)),
        "warmup_s": t_warm,
        "step_mean_s": float(np.mean(steps)),
        "step_median_s": float(np.median(steps)),
        "step_min_s": float(steps.min()),
        "step_max_s": float(steps.max()),
        "step_last10_median_s": float(np.median(steps[-10:])),
        "newton_median": float(np.median(its)),
        "newton_max": int(its.max()),
        "newton_total": int(its.sum()),
        "krylov_median": float(np.median(krylov)) if krylov else None,
        "krylov_max": int(max(krylov)) if krylov else None,
        "krylov_total": int(sum(krylov)) if krylov else None,
        "final_force_n": float(result.force[-1]),
        "final_contact": float(result.contact_count[-1]) / z1.size,
        "max_rss_loaded_gib": rss_loaded,
        "max_rss_gib": _max_rss_gib(),
    }


CHILDREN = {"prep": child_prep, "greens": child_greens, "run": child_run}


# ----------------------------------------------------------------------------------------------
# Parent
# ----------------------------------------------------------------------------------------------
def _spawn(kind: str, args, workdir: Path, nx: int, ny: int, **extra) -> dict | None:
    """Run one child; returns its result dict, or None (and says why) if it failed."""
    out = workdir / f"{kind}{'_' + extra['method'] if 'method' in extra else ''}.json"
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", kind, "--workdir", str(workdir),
           "--nx", str(nx), "--ny", str(ny), "--config", args.config, "--threads", str(args.threads),
           "--acceleration", str(args.acceleration), "--repeats", str(args.repeats), "--result", str(out)]
    for key, value in extra.items():
        cmd += [f"--{key.replace('_', '-')}", str(value)]
    env = dict(os.environ)
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        env[var] = str(args.threads)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0 or not out.exists():
        print(f"  !! {kind} {extra} for {nx}x{ny} FAILED (exit {proc.returncode}, {wall:.0f} s); stderr tail:")
        print("     " + "\n     ".join(proc.stderr.strip().splitlines()[-25:]), flush=True)
        return None
    res = json.loads(out.read_text())
    res["process_wall_s"] = wall
    return res


def _fmt_ms(x: float) -> str:
    return f"{1e3 * x:8.2f}"


def bench_size(nx: int, ny: int, args) -> dict:
    import numpy as np

    m = nx * ny
    workdir = Path(tempfile.mkdtemp(prefix=f"bench_scale_{nx}x{ny}_"))
    print(f"\n=== {nx} x {ny} elements (M = {m}) ===", flush=True)
    summary: dict = {"size": f"{nx}x{ny}", "M": m}
    try:
        prep = _spawn("prep", args, workdir, nx, ny)
        if prep is None:
            return summary
        summary["prep"] = prep
        print(f"surface: field {prep['field_size'][0] * 1e3:.0f} x {prep['field_size'][1] * 1e3:.0f} mm, rule "
              f"{prep['rule']}, {100 * prep['fraction_015']:.1f} % of element peaks within 0.15 mm of the top; "
              f"prepare_surface {prep['surface_s']:.2f} s, element_springs {prep['springs_s']:.2f} s "
              f"(process peak RSS {prep['max_rss_gib']:.2f} GiB)", flush=True)
        gr = _spawn("greens", args, workdir, nx, ny, element_size=prep["element_size"])
        if gr is None:
            return summary
        summary["greens"] = gr
        print(f"greens_dataset: {gr['greens_s']:.2f} s ({gr['n_lags']} lags, g table {gr['table_mib']:.0f} MiB; "
              f"process peak RSS {gr['max_rss_gib']:.2f} GiB)", flush=True)

        methods = ["fft"] + (["dense"] if m <= args.dense_max_elements else [])
        if "dense" not in methods:
            print(f"dense path skipped: M = {m} > --dense-max-elements {args.dense_max_elements} "
                  f"(lag-0 matrix {m * m * 8 / 2**20:.0f} MiB; see README for the decision)")
        print(f"{'path':<6s} {'steps':>5s} {'ms/step med':>11s} {'min':>8s} {'max':>8s} {'last10':>8s} "
              f"{'run s':>7s} {'mean':>8s} {'setup s':>7s} {'Newton/step':>11s} {'Krylov/step':>11s} {'peak RSS':>9s} {'F_end N':>10s} {'contact':>7s}")
        for method in methods:
            res = _spawn("run", args, workdir, nx, ny, method=method)
            if res is None:
                continue
            summary[method] = res
            kry = (f"{res['krylov_median']:5.0f} ({res['krylov_max']:3d})" if res["krylov_median"] is not None
                   else f"{'-':>11s}")
            print(f"{method:<6s} {res['steps']:5d} {_fmt_ms(res['step_median_s']):>11s} {_fmt_ms(res['step_min_s'])} "
                  f"{_fmt_ms(res['step_max_s'])} {_fmt_ms(res['step_last10_median_s'])} {res['run_s']:7.2f} "
                  f"{_fmt_ms(res['step_mean_s'])} {res['setup_s']:7.2f} "
                  f"{res['newton_median']:5.0f} ({res['newton_max']:3d}) {kry} {res['max_rss_gib']:7.2f} G "
                  f"{res['final_force_n']:10.3f} {100 * res['final_contact']:6.1f}%", flush=True)
        if "fft" in summary and "dense" in summary:
            f_fft = np.load(workdir / "force_fft.npy")
            f_dense = np.load(workdir / "force_dense.npy")
            diff = np.abs(f_fft - f_dense)
            rel_global = float(diff.max() / np.abs(f_dense).max())
            loaded = f_dense > 1e-6 * np.abs(f_dense).max()
            rel_step = float(np.max(diff[loaded] / f_dense[loaded])) if loaded.any() else float("nan")
            fft, dense = summary["fft"], summary["dense"]
            ratio = dense["step_median_s"] / fft["step_median_s"]
            ratio_mean = dense["step_mean_s"] / fft["step_mean_s"]
            ratio_last = dense["step_last10_median_s"] / fft["step_last10_median_s"]
            summary["agreement"] = {"rel_global": rel_global, "rel_step": rel_step, "ratio": ratio,
                                    "ratio_mean": ratio_mean, "ratio_last10": ratio_last}
            print(f"dense/FFT time per step: {ratio:.2f}x (medians), {ratio_mean:.2f}x (means over steps), "
                  f"{ratio_last:.2f}x (last 10 steps); total force FFT vs dense: "
                  f"max|dF| / max|F| = {rel_global:.2e}, max over loaded steps of |dF|/F = {rel_step:.2e}", flush=True)
    finally:
        shutil.rmtree(workdir, ignore_errors=True)
    return summary


def _targets(results: list[dict]) -> None:
    by = {r["size"]: r for r in results}
    print("\n=== issue 7 targets ===")
    big = by.get("150x200")
    if big is None:
        print("150x200: not run (use the default sizes)")
    elif "fft" not in big:
        print("150x200 dynamic with 256 lags completes: MISSED (see the failure above)")
    else:
        f = big["fft"]
        print(f"150x200 dynamic, {big['greens']['n_lags']} lags, completes: met ({f['steps']} steps, run {f['run_s']:.1f} s)")
        print(f"150x200 median time per step {f['step_median_s']:.3f} s (min {f['step_min_s']:.3f}, max "
              f"{f['step_max_s']:.3f}) <= 0.2 s on 2 cores: {'met' if f['step_median_s'] <= 0.2 else 'MISSED'}")
        print(f"150x200 peak memory {f['max_rss_gib']:.2f} GiB (run process) <= 8 GiB: "
              f"{'met' if f['max_rss_gib'] <= 8 else 'MISSED'}; greens stage {big['greens']['max_rss_gib']:.2f} GiB, "
              f"surface+springs {big['prep']['max_rss_gib']:.2f} GiB")
    mid = by.get("40x40", {})
    if "agreement" in mid:
        a = mid["agreement"]
        r = a["ratio"]
        print(f"40x40 FFT >= 10x faster per step than dense: {r:.1f}x on median step times "
              f"({a['ratio_mean']:.1f}x on mean step times, {a['ratio_last10']:.1f}x on the last 10 steps): "
              f"{'met' if r >= 10 else 'MISSED'}")
    else:
        print("40x40 dense/FFT ratio: not measured")
    small = by.get("20x20", {})
    if "agreement" in small:
        a = small["agreement"]["rel_global"]
        print(f"20x20 FFT vs dense total force within 1e-10 relative: {a:.2e}: {'met' if a <= 1e-10 else 'MISSED'}")
    else:
        print("20x20 agreement: not measured")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default=None, help=f"comma-separated NXxNY (default {ALL_SIZES})")
    parser.add_argument("--quick", action="store_true", help=f"only {QUICK_SIZES}")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--acceleration", type=float, default=500.0, help="m/s^2")
    parser.add_argument("--repeats", type=int, default=3, help="timed runs per size and path (after a warm-up)")
    parser.add_argument("--dense-max-elements", type=int, default=1600,
                        help="run the dense path only up to this many elements")
    parser.add_argument("--config", default=str(ROOT / "config" / "config.yaml"))
    # child mode
    parser.add_argument("--child", choices=sorted(CHILDREN), help=argparse.SUPPRESS)
    parser.add_argument("--workdir", help=argparse.SUPPRESS)
    parser.add_argument("--result", help=argparse.SUPPRESS)
    parser.add_argument("--nx", type=int, help=argparse.SUPPRESS)
    parser.add_argument("--ny", type=int, help=argparse.SUPPRESS)
    parser.add_argument("--method", help=argparse.SUPPRESS)
    parser.add_argument("--element-size", type=float, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)

    if args.child:
        res = CHILDREN[args.child](args)
        Path(args.result).write_text(json.dumps(res))
        return

    if args.quick and args.sizes:
        parser.error("--quick and --sizes exclude each other")
    sizes_arg = QUICK_SIZES if args.quick else (args.sizes or ALL_SIZES)
    try:
        sizes = [tuple(int(v) for v in s.lower().split("x")) for s in sizes_arg.split(",")]
    except ValueError:
        sizes = []
    if not sizes or any(len(s) != 2 or min(s) < 4 for s in sizes):
        parser.error(f"--sizes: expected NXxNY[,NXxNY...] with NX, NY >= 4, got {sizes_arg!r}")
    if args.repeats < 1 or args.threads < 1:
        parser.error("--repeats and --threads must be >= 1")
    load = os.getloadavg()
    print(f"bench_scale: {os.cpu_count()} CPUs, threads {args.threads}, a = {args.acceleration:g} m/s^2, "
          f"sizes {sizes_arg}, dense up to {args.dense_max_elements} elements, "
          f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}", flush=True)
    results = [bench_size(nx, ny, args) for nx, ny in sizes]
    _targets(results)


if __name__ == "__main__":
    main()
