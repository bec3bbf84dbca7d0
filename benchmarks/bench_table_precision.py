"""Benchmark: what float32 spring tables cost (config ``springs.table_precision``).

For each patch size (default: the default study's 20 x 20 patch, and 150 x 200 elements built as
``bench_scale.py`` builds it) this prepares, once per size in ``--workdir`` (kept between runs):

1. the surface (``prepare_surface`` of the study preset; 150 x 200 with the field grown around
   the patch), its z1 written to ``surface.nc``,
2. ``element_springs`` of the reference material (model of the config, ``single_punch`` by
   default) with ``table_precision`` float64 and float32, written as the springs stage writes
   them (``springs_float64.nc``, ``springs_float32.nc``: area, stiffness, force),
3. ``greens_dataset`` of the reference material at that size (``greens.nc``).

Then every run executes in its own fresh process (so its peak RSS ``ru_maxrss`` is its own), reads
the three files with :func:`tyreroad.io.read_dataset` as a contact job does, and solves with
:func:`tyreroad.contact.solve_run`, the contact stage's own function: quasi-static (static kernel,
the config's ``quasistatic_step``, K(d) from the tangent of each state) and dynamic (the
time-domain kernel with its tail, ``--acceleration`` 500 m/s^2), 1 thread as the rule runs it.
Variants:

``float64``
    the default tables.
``float32``
    the float32 springs file; the solver keeps k float32 and F as float64 anchors every 16
    points (:class:`tyreroad.springs.SpringTable`).
``naive32``
    the design not taken, for comparison: the float32 k and F tables of the same file used
    directly by the plain interpolation kernel (F rounded to float32 at every grid point, so F
    jumps by up to 6e-8 F there and k is no longer exactly dF/dzeta).

Also timed: one evaluation of all springs (``SpringTable.evaluate_into``, what each Newton
iteration calls) for each variant, median and min of 20 x ``--repeats`` calls (the min is the
figure least moved by other jobs on shared cores).

Each run is first warmed up untimed on a 4 x 4 corner (numba compile or cache load), then
timed ``--repeats`` times (median). Printed per size and mode: steps, run time, Newton
iterations (total, max per step), the largest converged residual, the memory of the solver's
spring tables and of the springs dataset, the process's peak RSS, and against float64 the
largest relative differences of the total force F(d) and of K(d) (quasi-static: the tangent
stiffness; dynamic: dF/dd by central differences), over the steps with F > 1e-3 max F.

Usage: python benchmarks/bench_table_precision.py [--sizes 20x20,150x200] [--repeats 3]
       [--variants float64,float32,naive32] [--acceleration 500] [--workdir DIR] [--config ...]
Never fails on time.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))

MODES = ("quasistatic", "dynamic")


def _max_rss_gib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20


def child_prep(args) -> dict:
    from bench_scale import _surface_spec

    from tyreroad import io
    from tyreroad.config import load_config
    from tyreroad.greens import GreensSettings, greens_dataset
    from tyreroad.material import material_from_config
    from tyreroad.pipeline import spring_material_inputs
    from tyreroad.springs import SpringModel, element_springs, resolve_spring_modulus
    from tyreroad.surface import prepare_surface

    cfg = load_config(args.config)
    wd = Path(args.workdir)
    name = cfg["study"]["surface"]
    spec = dict(cfg["surfaces"][name])
    element_size = float(spec.get("element_size", 1e-3))
    if [args.nx, args.ny] != list(spec.get("patch_elements", [20, 20])):
        name, spec = _surface_spec(cfg, args.nx, args.ny, element_size)
    t0 = time.perf_counter()
    surface = prepare_surface(name, spec, base_dir=ROOT)
    out = {"surface_s": time.perf_counter() - t0}
    surface[["z1"]].to_netcdf(wd / "surface.nc")
    ref = cfg["study"]["reference_material"]
    inputs = spring_material_inputs(ref, cfg["materials"])
    for precision in ("float64", "float32"):
        model = SpringModel.from_config({**cfg["springs"], "table_precision": precision})
        t0 = time.perf_counter()
        ds = element_springs(surface, model, modulus=resolve_spring_modulus(model, inputs["quasi_static_modulus"]),
                             poisson=inputs["poisson"], thickness=inputs["thickness"])
        out[f"springs_{precision}_s"] = time.perf_counter() - t0
        io.write_dataset(ds, wd / f"springs_{precision}.nc", {"springs": dict(cfg["springs"])},
                         stage="element_springs")
        del ds
    material = material_from_config(ref, cfg["materials"])
    gs = GreensSettings.from_config(cfg["greens"])
    t0 = time.perf_counter()
    greens = greens_dataset(material, n_elements=(args.nx, args.ny), element_size=element_size,
                            sample_rate=gs.sample_rate, n_lags=gs.n_lags, n_fft=gs.n_fft)
    out["greens_s"] = time.perf_counter() - t0
    io.write_dataset(greens, wd / "greens.nc", {"greens": dict(cfg["greens"])}, stage="greens")
    out["max_rss_gib"] = _max_rss_gib()
    return out


def _naive_solver(contact, SpringTable):
    """solve_run with the float32 k and F tables used as they are (the design not taken)."""
    import math

    import numpy as np

    from tyreroad.kernel import LayerKernel
    from tyreroad.loading import IndentationPath, constant_acceleration_path, uniform_indentation_grid

    def run(surface, springs, greens, material, mode, acceleration, settings, threads=1):
        z1 = surface["z1"].transpose("ex", "ey").values
        raw = SpringTable.from_dataset(springs)
        n = raw.stiffness.shape[-1]
        table = SpringTable(raw.zeta_step, np.ascontiguousarray(raw.stiffness.reshape(-1, n)),
                            np.ascontiguousarray(raw.force.reshape(-1, n)))
        assert table.stiffness.dtype == np.float32 and table.force.dtype == np.float32
        assert math.prod(z1.shape) == table.n_springs
        kernel = LayerKernel.from_greens(greens, mode, material)
        if mode == "dynamic":
            t, d = constant_acceleration_path(kernel.sample_rate, acceleration, settings.d_max)
        else:
            t, d = None, uniform_indentation_grid(settings.d_max, settings.quasistatic_step)
        return contact.run_loading_path(IndentationPath(z1, d, t), table, kernel, settings, threads)

    return run


def _naive_jumps(springs, g_self: float, tolerance: float, d_max: float) -> dict:
    """Jumps of a float32 F table at the grid points zeta_j <= d_max: |F_j - F_{j-1} - trapezoid| [N].

    Returned: the largest jump of the compression, dF / k [m], and of the Newton residual,
    g_self dF [m] (g_self = G0 of the element on itself), and the fraction of grid points
    whose residual jump exceeds 2 x the tolerance (a root landing there cannot converge).
    Compressions stay below d_max in a run, so only these grid points matter.
    """
    import numpy as np

    step = float(springs["zeta"].values[1])
    n = int(round(d_max / step)) + 1
    k = springs["stiffness"].values.reshape(-1, springs.sizes["zeta"])[:, :n]
    f = springs["force"].values.reshape(-1, springs.sizes["zeta"])[:, :n]
    dz_max = r_max = 0.0
    over = total = 0
    for start in range(0, k.shape[0], 1000):
        kk = k[start:start + 1000].astype(float)
        ff = f[start:start + 1000].astype(float)
        jump = np.abs(ff[:, 1:] - ff[:, :-1] - 0.5 * step * (kk[:, 1:] + kk[:, :-1]))
        dz_max = max(dz_max, float(np.max(jump / np.maximum(kk[:, 1:], 1e-300))))
        r_max = max(r_max, g_self * float(jump.max()))
        over += int(np.count_nonzero(g_self * jump > 2 * tolerance))
        total += jump.size
    return {"jump_zeta_max_m": dz_max, "jump_residual_max_m": r_max, "jump_over_tol_fraction": over / total}


def child_run(args) -> dict:
    import numpy as np

    import tyreroad.contact as contact
    from tyreroad import io
    from tyreroad.config import load_config
    from tyreroad.material import material_from_config
    from tyreroad.springs import SpringTable

    cfg = load_config(args.config)
    wd = Path(args.workdir)
    material = material_from_config(cfg["study"]["reference_material"], cfg["materials"])
    settings = contact.SolverSettings.from_config(cfg["solver"])
    file = "springs_float64.nc" if args.variant == "float64" else "springs_float32.nc"
    surface = io.read_dataset(wd / "surface.nc")
    springs = io.read_dataset(wd / file)
    greens = io.read_dataset(wd / "greens.nc")
    rss_loaded = _max_rss_gib()
    solve = _naive_solver(contact, SpringTable) if args.variant == "naive32" else contact.solve_run
    accel = args.acceleration if args.mode == "dynamic" else 0.0

    corner = dict(ex=slice(0, 4), ey=slice(0, 4))
    g_corner = greens.isel(dx=slice(None), dy=slice(None))
    t0 = time.perf_counter()
    try:
        solve(surface.isel(**corner), springs.isel(**corner), g_corner, material, args.mode, accel, settings, 1)
    except Exception as exc:  # noqa: BLE001 - a failing warm-up is reported with the run
        print(f"warm-up: {type(exc).__name__}: {exc}", file=sys.stderr)
    t_warm = time.perf_counter() - t0

    times, result, error = [], None, None
    for _ in range(args.repeats):
        t0 = time.perf_counter()
        try:
            result = solve(surface, springs, greens, material, args.mode, accel, settings, 1)
        except Exception as exc:  # noqa: BLE001 - the naive tables may fail to converge
            error = f"{type(exc).__name__}: {str(exc)[:300]}"
            break
        times.append(time.perf_counter() - t0)
    rss = _max_rss_gib()
    out = {"variant": args.variant, "mode": args.mode, "warmup_s": t_warm, "max_rss_loaded_gib": rss_loaded,
           "max_rss_gib": rss, "springs_dataset_mib": springs.nbytes / 2**20, "error": error}
    if args.variant == "naive32":
        out["table_mib"] = (springs["stiffness"].nbytes + springs["force"].nbytes) / 2**20
        out.update(_naive_jumps(springs, float(greens["g_static"].sel(dx=0, dy=0)), settings.tolerance,
                                settings.d_max))
    else:
        table = SpringTable.from_dataset(springs)
        out["table_mib"] = SpringTable.checked(table.stiffness, table.force, table.zeta_step,
                                               table.n_springs).nbytes / 2**20
    if result is None:
        return out
    d = result.indentation
    f = result.force
    if result.tangent_stiffness is not None:
        k = result.tangent_stiffness
    else:
        k = np.gradient(f, d)
    np.save(wd / f"run_{args.mode}_{args.variant}.npy", np.stack([d, f, k]))
    its = np.asarray(result.newton_iterations)
    out.update({
        "steps": int(f.size), "run_s": float(np.median(times)), "run_min_s": float(min(times)),
        "newton_total": int(its.sum()), "newton_max": int(its.max()),
        "residual_max": float(np.max(result.residual)), "final_force_n": float(f[-1]),
    })
    return out


def child_micro(args) -> dict:
    """Time of one spring evaluation of every element (SpringTable.evaluate_into, one Newton iteration's)."""
    import numpy as np

    from tyreroad import io
    from tyreroad.springs import SpringTable

    wd = Path(args.workdir)
    out = {}
    rng = np.random.default_rng(1)
    for variant in ("float64", "float32", "naive32"):
        ds = io.read_dataset(wd / ("springs_float64.nc" if variant == "float64" else "springs_float32.nc"))
        raw = SpringTable.from_dataset(ds)
        m, n = raw.n_springs, raw.stiffness.shape[-1]
        if variant == "naive32":
            table = SpringTable(raw.zeta_step, raw.stiffness.reshape(m, n), raw.force.reshape(m, n))
        else:
            table = SpringTable.checked(raw.stiffness, raw.force, raw.zeta_step, m)
        zeta = rng.uniform(-1e-4, 2.5e-4, m)
        f, k = np.empty(m), np.empty(m)
        table.evaluate_into(zeta, f, k)  # compile / cache load
        times = []
        for _ in range(args.repeats * 20):
            t0 = time.perf_counter()
            table.evaluate_into(zeta, f, k)
            times.append(time.perf_counter() - t0)
        out[variant] = float(np.median(times))
        out[variant + "_min"] = float(np.min(times))
    return out


def _spawn(kind: str, args, workdir: Path, nx: int, ny: int, **extra) -> dict | None:
    tag = "_".join(str(v) for v in extra.values())
    out = workdir / f"{kind}{'_' + tag if tag else ''}.json"
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", kind, "--workdir", str(workdir),
           "--nx", str(nx), "--ny", str(ny), "--config", args.config, "--repeats", str(args.repeats),
           "--acceleration", str(args.acceleration), "--result", str(out)]
    for key, value in extra.items():
        cmd += [f"--{key}", str(value)]
    env = dict(os.environ)
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
        env[var] = "1"
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if proc.returncode != 0 or not out.exists():
        print(f"  !! {kind} {extra} {nx}x{ny} failed (exit {proc.returncode}); stderr tail:")
        print("     " + "\n     ".join(proc.stderr.strip().splitlines()[-20:]), flush=True)
        return None
    res = json.loads(out.read_text())
    res["process_wall_s"] = time.perf_counter() - t0
    return res


def _differences(wd: Path, mode: str, variant: str) -> tuple[float, float]:
    """Max relative |F - F64| / F64 and |K - K64| / K64 over the steps with F64 > 1e-3 max F64."""
    import numpy as np

    ref, other = (wd / f"run_{mode}_float64.npy"), (wd / f"run_{mode}_{variant}.npy")
    if not (ref.exists() and other.exists()):
        return float("nan"), float("nan")
    d0, f0, k0 = np.load(ref)
    d1, f1, k1 = np.load(other)
    if d0.shape != d1.shape:
        return float("nan"), float("nan")
    loaded = f0 > 1e-3 * f0.max()
    return (float(np.max(np.abs(f1 - f0)[loaded] / f0[loaded])),
            float(np.max(np.abs(k1 - k0)[loaded] / np.abs(k0[loaded]))))


def _print_jumps(res: dict) -> None:
    if "jump_zeta_max_m" in res:
        print(f"         naive32 F jumps at grid points zeta <= d_max: compression <= {res['jump_zeta_max_m']:.1e} m, "
              f"Newton residual <= {res['jump_residual_max_m']:.1e} m; "
              f"{100 * res['jump_over_tol_fraction']:.2f} % of grid points jump by more than 2 x tolerance", flush=True)


def bench_size(nx: int, ny: int, args) -> None:
    wd = Path(args.workdir) / f"{nx}x{ny}"
    wd.mkdir(parents=True, exist_ok=True)
    print(f"\n=== {nx} x {ny} elements ===", flush=True)
    if not all((wd / f).exists() for f in ("surface.nc", "springs_float64.nc", "springs_float32.nc", "greens.nc")):
        prep = _spawn("prep", args, wd, nx, ny)
        if prep is None:
            return
        print(f"prepared in {wd}: surface {prep['surface_s']:.1f} s, springs float64 {prep['springs_float64_s']:.2f} s,"
              f" float32 {prep['springs_float32_s']:.2f} s, greens {prep['greens_s']:.1f} s", flush=True)
    else:
        print(f"inputs cached in {wd}")
    sizes = {p: (wd / f"springs_{p}.nc").stat().st_size / 2**20 for p in ("float64", "float32")}
    print(f"springs file: float64 {sizes['float64']:.1f} MiB, float32 {sizes['float32']:.1f} MiB (compressed)")
    micro = _spawn("micro", args, wd, nx, ny)
    if micro is not None:
        print("one evaluation of all springs (evaluate_into, zeta uniform in -0.1 ... 0.25 mm), median (min): "
              + ", ".join(f"{v} {1e6 * micro[v]:.0f} ({1e6 * micro[v + '_min']:.0f}) us"
                          for v in ("float64", "float32", "naive32")), flush=True)
    variants = args.variants.split(",")
    for mode in MODES:
        print(f"-- {mode}" + (f" {args.acceleration:g} m/s^2" if mode == "dynamic" else ""))
        print(f"{'variant':<8s} {'steps':>5s} {'run s':>7s} {'min':>7s} {'Newton':>7s} {'max/st':>6s} "
              f"{'max |R| m':>9s} {'tables MiB':>10s} {'springs ds MiB':>14s} {'RSS loaded':>10s} {'peak RSS':>9s} "
              f"{'max dF/F':>9s} {'max dK/K':>9s}")
        for variant in variants:
            res = _spawn("run", args, wd, nx, ny, mode=mode, variant=variant)
            if res is None:
                continue
            if res.get("error"):
                print(f"{variant:<8s} FAILED: {res['error']}  (tables {res['table_mib']:.1f} MiB, "
                      f"peak RSS {res['max_rss_gib']:.2f} GiB)", flush=True)
                _print_jumps(res)
                continue
            df, dk = _differences(wd, mode, variant) if variant != "float64" else (0.0, 0.0)
            print(f"{variant:<8s} {res['steps']:5d} {res['run_s']:7.2f} {res['run_min_s']:7.2f} {res['newton_total']:7d} "
                  f"{res['newton_max']:6d} {res['residual_max']:9.1e} {res['table_mib']:10.1f} "
                  f"{res['springs_dataset_mib']:14.1f} {res['max_rss_loaded_gib']:8.2f} G {res['max_rss_gib']:7.2f} G "
                  f"{df:9.1e} {dk:9.1e}", flush=True)
            _print_jumps(res)


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--sizes", default="20x20,150x200")
    p.add_argument("--variants", default="float64,float32,naive32")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--acceleration", type=float, default=500.0)
    p.add_argument("--config", default=str(ROOT / "config" / "config.yaml"))
    p.add_argument("--workdir", default=str(Path(tempfile.gettempdir()) / "tyreroad_bench_table_precision"))
    p.add_argument("--child", choices=("prep", "run", "micro"))
    p.add_argument("--nx", type=int)
    p.add_argument("--ny", type=int)
    p.add_argument("--mode", choices=MODES)
    p.add_argument("--variant")
    p.add_argument("--result")
    args = p.parse_args(argv)
    if args.child:
        res = {"prep": child_prep, "run": child_run, "micro": child_micro}[args.child](args)
        Path(args.result).write_text(json.dumps(res))
        return
    load = os.getloadavg()
    print(f"bench_table_precision: sizes {args.sizes}, variants {args.variants}, repeats {args.repeats}, "
          f"1 thread; load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")
    for size in args.sizes.split(","):
        nx, ny = (int(v) for v in size.lower().split("x"))
        bench_size(nx, ny, args)
    load = os.getloadavg()
    print(f"\nload average at the end: {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")


if __name__ == "__main__":
    main()
