"""tyreroad against ContactMechanics 1.8.3 on the same hard-contact problem, forces and times in one run.

The problem (issue 18): a rigid rough road, the element peaks z1 of the project's own ISO 10844
surface (the study preset of config/config.yaml with ``patch_elements`` set to the size, patch
chosen by the study's rule), pressed into a 10 mm layer on a rigid base (E = 25 MPa, nu = 0.49)
to the five indentations d = 0.05, 0.10, ..., 0.25 mm, hard contact.

* tyreroad: the quasi-static solver (:func:`tyreroad.contact.solve_quasistatic`, FFT/Newton-Krylov
  path, default settings: tolerance 1e-12 m on max|R|) with the layer's exact square-load element
  kernel (:func:`tyreroad.greens.static_element_kernel`) and hard contact as its stiff limit:
  linear springs of 1e10 N/m kept as two-point tables (:func:`tyreroad.springs.linear_tables`).
  The five indentations are one call (each step warm-started from the previous one).
* ContactMechanics: Polonsky-Keer constrained conjugate gradients
  (``ContactMechanics.Optimization.constrained_conjugate_gradients``) on a
  ``PeriodicFFTElasticHalfSpace`` layer (``thickness``) on a grid padded 2x in x and y (the road
  1 m below the layer outside the patch), each indentation warm-started from the previous
  displacements, penetration tolerance ``--pentol`` (default 1e-10 m).

Each measurement runs in a fresh subprocess, one thread (numba, scipy.fft workers, OMP, BLAS),
alternating the two codes ``--repeats`` times; a run's time covers everything after the inputs are
read: the solver setup (tyreroad: table checks, kernel spectra, preconditioner; ContactMechanics:
the substrate and its Green's function) and the five solves. Before it, each process solves a
4 x 4 corner once (numba cache load, FFT plans); that start-up and the import time are printed
separately. Peak memory is the process's ru_maxrss, imports included. Inputs (surface and kernel,
~2 min at 300 x 400) are cached under ``--cache``.

A second part (``--stiffness-check``, on by default) shows the stiff-spring convergence of issue 18:
linear springs of 1e6, 1e8 and 1e10 N/m at 20 x 20 (dense and FFT paths, which must agree to 1e-9)
and 150 x 200 (FFT path), default settings, with Newton and Krylov counts.

    pip install ContactMechanics==1.8.3      # NOT muFFT: it replaces muGrid and breaks ContactMechanics
    python benchmarks/compare_contactmechanics.py [--sizes 150x200,300x400] [--repeats 3] [--baseline DIR]

``--baseline DIR`` times an earlier tyreroad checkout (e.g. a git worktree of the previous
release) in the same alternation (third row, with its time ratio and its force and tangent
differences from this checkout).

Prints figures and the issue-18 targets with "met"/"MISSED"; never fails on time.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
E, NU, H, C = 25e6, 0.49, 0.01, 1e-3  # Pa, -, m, m
INDENTATIONS = [5e-5, 1e-4, 1.5e-4, 2e-4, 2.5e-4]  # m
HARD = 1e10  # N/m, tyreroad's hard-contact springs (the stiff limit)


def _rss_gib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20


# ----------------------------------------------------------------------------------------------
# Children
# ----------------------------------------------------------------------------------------------
def child_prep(args) -> dict:
    """z1 of the project's surface and the static element kernel of the layer, cached as .npz."""
    import numpy as np

    from tyreroad.config import load_config
    from tyreroad.greens import offset_table_index, static_element_kernel, unique_offsets
    from tyreroad.surface import prepare_surface

    cfg = load_config(args.config)
    name = cfg["study"]["surface"]
    spec = dict(cfg["surfaces"][name])
    spec["patch_elements"] = [args.nx, args.ny]
    spec["field_size"] = [max(0.1, n * C + 0.02) for n in (args.nx, args.ny)]
    spec.setdefault("patch_selection", "contact_fraction")
    t0 = time.perf_counter()
    surface = prepare_surface(f"{name}-{args.nx}x{args.ny}", spec, base_dir=ROOT)
    t_surface = time.perf_counter() - t0
    z1 = surface["z1"].transpose("ex", "ey").values
    t0 = time.perf_counter()
    g = static_element_kernel(unique_offsets((args.nx, args.ny)) * C, C, E, NU, H)
    g_static = g[offset_table_index((args.nx, args.ny))[2]]
    t_kernel = time.perf_counter() - t0
    np.savez(args.inputs, z1=z1, g_static=g_static)
    return {"surface_s": t_surface, "kernel_s": t_kernel}


def child_tyreroad(args) -> dict:
    t0 = time.perf_counter()
    import numpy as np

    import tyreroad.newton
    from tyreroad.contact import SolverSettings, solve_quasistatic
    from tyreroad.springs import linear_tables

    t_import = time.perf_counter() - t0
    substrates = []  # to read the tangent solves' Krylov products (not in ContactResult)
    init = tyreroad.newton.FFTSubstrate.__init__

    def keep(self, *a, **kw):
        init(self, *a, **kw)
        substrates.append(self)

    tyreroad.newton.FFTSubstrate.__init__ = keep
    data = np.load(args.inputs)
    z1, g_static = data["z1"], data["g_static"]
    settings = SolverSettings(method="fft")
    t0 = time.perf_counter()
    k, f = linear_tables(16, HARD)
    solve_quasistatic(z1[:4, :4], k, f, 1e-6, g_static, settings, indentation=INDENTATIONS)
    t_start = time.perf_counter() - t0
    t0 = time.perf_counter()
    k, f = linear_tables(z1.size, HARD)
    res = solve_quasistatic(z1, k, f, 1e-6, g_static, settings, indentation=INDENTATIONS)
    t_run = time.perf_counter() - t0
    return {"import_s": t_import, "startup_s": t_start, "run_s": t_run, "force": res.force.tolist(),
            "newton": res.newton_iterations.tolist(), "krylov": res.krylov_iterations.tolist(),
            "tangent_products": getattr(substrates[-1], "tangent_products", None) if substrates else None,
            "tangent": None if res.tangent_stiffness is None else res.tangent_stiffness.tolist(),
            "contact": (res.contact_count / z1.size).tolist(), "residual": float(res.residual.max()),
            "rss_gib": _rss_gib()}


def _cm_run(z1, pentol):
    """Five indentations by Polonsky-Keer on the 2x padded periodic layer; (forces, iterations)."""
    import numpy as np
    from ContactMechanics import PeriodicFFTElasticHalfSpace
    from ContactMechanics.Optimization import constrained_conjugate_gradients

    nx, ny = z1.shape
    substrate = PeriodicFFTElasticHalfSpace((2 * nx, 2 * ny), E, physical_sizes=(2 * nx * C, 2 * ny * C),
                                            thickness=H, poisson=NU)
    heights = np.full((2 * nx, 2 * ny), -1.0)  # outside the patch the road is 1 m away
    heights[:nx, :ny] = z1 - z1.max()
    disp, forces, iterations = None, [], []
    for d in INDENTATIONS:
        res = constrained_conjugate_gradients(substrate, heights, offset=d, pentol=pentol,
                                              initial_displacements=disp, maxiter=100000)
        if not res.success:
            raise RuntimeError(f"ContactMechanics did not converge at d = {d:g} m: {res.message}")
        disp = res.x
        forces.append(float(abs(res.jac.sum())))
        iterations.append(int(res.nit))
    return forces, iterations


def child_cm(args) -> dict:
    t0 = time.perf_counter()
    import numpy as np
    import ContactMechanics  # noqa: F401  (import time)

    t_import = time.perf_counter() - t0
    z1 = np.load(args.inputs)["z1"]
    t0 = time.perf_counter()
    _cm_run(z1[:4, :4], args.pentol)
    t_start = time.perf_counter() - t0
    t0 = time.perf_counter()
    forces, iterations = _cm_run(z1, args.pentol)
    t_run = time.perf_counter() - t0
    return {"import_s": t_import, "startup_s": t_start, "run_s": t_run, "force": forces, "iterations": iterations,
            "rss_gib": _rss_gib()}


def child_stiff(args) -> dict:
    """Linear springs 1e6, 1e8, 1e10 N/m on the FFT (and, up to 20 x 20, the dense) path."""
    import numpy as np

    from tyreroad.contact import SolverSettings, solve_quasistatic
    from tyreroad.springs import linear_tables

    data = np.load(args.inputs)
    z1, g_static = data["z1"], data["g_static"]
    out = {}
    methods = ["fft", "dense"] if z1.size <= 400 else ["fft"]
    for stiffness in (1e6, 1e8, 1e10):
        k, f = linear_tables(z1.size, stiffness)
        row = {}
        for method in methods:
            t0 = time.perf_counter()
            try:
                res = solve_quasistatic(z1, k, f, 1e-6, g_static, SolverSettings(method=method),
                                        indentation=INDENTATIONS)
            except Exception as err:  # noqa: BLE001 - reported, the benchmark goes on
                row[method] = {"error": str(err)}
                continue
            row[method] = {"s": time.perf_counter() - t0, "force": res.force.tolist(),
                           "newton_max": int(res.newton_iterations.max()),
                           "krylov_max": int(res.krylov_iterations.max()), "residual": float(res.residual.max())}
        out[f"{stiffness:g}"] = row
    return out


CHILDREN = {"prep": child_prep, "tyreroad": child_tyreroad, "baseline": child_tyreroad, "cm": child_cm,
            "stiff": child_stiff}


# ----------------------------------------------------------------------------------------------
# Parent
# ----------------------------------------------------------------------------------------------
def _spawn(kind: str, args, nx: int, ny: int, inputs: Path) -> dict | None:
    result = inputs.parent / f"{kind}_{nx}x{ny}.json"
    result.unlink(missing_ok=True)
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", kind, "--nx", str(nx), "--ny", str(ny),
           "--inputs", str(inputs), "--result", str(result), "--pentol", str(args.pentol), "--config", args.config]
    env = dict(os.environ)
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
        env[var] = "1"
    if kind == "baseline":  # an earlier checkout of tyreroad, same child code
        env["PYTHONPATH"] = str(Path(args.baseline).resolve())
    elif kind in ("tyreroad", "stiff", "prep"):
        env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    proc = subprocess.run(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if proc.returncode != 0 or not result.exists():
        print(f"  !! {kind} {nx}x{ny} FAILED (exit {proc.returncode}); stderr tail:")
        print("     " + "\n     ".join(proc.stderr.strip().splitlines()[-15:]), flush=True)
        return None
    return json.loads(result.read_text())


def _inputs(args, nx: int, ny: int) -> Path:
    cache = Path(args.cache)
    cache.mkdir(parents=True, exist_ok=True)
    path = cache / f"inputs_{nx}x{ny}.npz"
    if not path.exists():
        prep = _spawn("prep", args, nx, ny, path)
        if prep is None:
            raise SystemExit(f"input preparation for {nx}x{ny} failed")
        print(f"inputs {nx}x{ny}: prepare_surface {prep['surface_s']:.1f} s, static element kernel "
              f"{prep['kernel_s']:.1f} s (cached in {path})", flush=True)
    return path


def _median(xs):
    xs = sorted(xs)
    n = len(xs)
    return xs[n // 2] if n % 2 else 0.5 * (xs[n // 2 - 1] + xs[n // 2])


def compare(args, nx: int, ny: int) -> dict:
    inputs = _inputs(args, nx, ny)
    kinds = ("cm", "tyreroad") + (("baseline",) if args.baseline else ())
    runs: dict[str, list[dict]] = {kind: [] for kind in kinds}
    for _ in range(args.repeats):
        for kind in kinds:
            res = _spawn(kind, args, nx, ny, inputs)
            if res is not None:
                runs[kind].append(res)
    if not runs["tyreroad"] or not runs["cm"]:
        return {}
    ty, cm = runs["tyreroad"], runs["cm"]
    t_ty, t_cm = _median([r["run_s"] for r in ty]), _median([r["run_s"] for r in cm])
    m_ty, m_cm = max(r["rss_gib"] for r in ty), max(r["rss_gib"] for r in cm)
    f_ty, f_cm = ty[0]["force"], cm[0]["force"]
    rel = [abs(a - b) / b for a, b in zip(f_ty, f_cm)]
    print(f"\n=== {nx} x {ny} elements, five indentations, hard contact, 1 thread, {args.repeats} repeats ===")
    print(f"{'code':<18s} {'run s med':>9s} {'min':>6s} {'max':>6s} {'start-up s':>10s} {'import s':>8s} "
          f"{'peak RSS GiB':>12s}  iterations per indentation")
    rows = [("tyreroad", ty, [f"{n}/{k}" for n, k in zip(ty[0]["newton"], ty[0]["krylov"])]),
            ("ContactMechanics", cm, [str(i) for i in cm[0]["iterations"]])]
    if runs.get("baseline"):
        bl = runs["baseline"]
        rows.append((f"tyreroad baseline", bl, [f"{n}/{k}" for n, k in zip(bl[0]["newton"], bl[0]["krylov"])]))
    for name, rs, its in rows:
        times = [r["run_s"] for r in rs]
        print(f"{name:<18s} {_median(times):9.2f} {min(times):6.2f} {max(times):6.2f} "
              f"{_median([r['startup_s'] for r in rs]):10.2f} {_median([r['import_s'] for r in rs]):8.2f} "
              f"{max(r['rss_gib'] for r in rs):12.3f}  {' '.join(its)}")
    tp = ty[0].get("tangent_products")
    print("  (tyreroad iterations: Newton/Krylov products"
          + (f", plus {tp} Krylov products of the five tangent solves K = dF/dd" if tp is not None else "")
          + "; ContactMechanics: Polonsky-Keer iterations)")
    if runs.get("baseline"):
        bl = runs["baseline"]
        t_bl = _median([r["run_s"] for r in bl])
        df = max(abs(a - b) / b for a, b in zip(ty[0]["force"], bl[0]["force"]))
        dk = (max(abs(a - b) / b for a, b in zip(ty[0]["tangent"], bl[0]["tangent"]))
              if ty[0].get("tangent") and bl[0].get("tangent") else float("nan"))
        print(f"  against the baseline ({args.baseline}): time {t_ty / t_bl:.2f}x, forces max rel diff {df:.1e}, "
              f"tangent dF/dd max rel diff {dk:.1e}")
    print(f"{'d [mm]':>8s} {'F tyreroad [N]':>15s} {'F CM [N]':>12s} {'rel diff':>9s} {'contact':>8s}")
    for d, a, b, r, c in zip(INDENTATIONS, f_ty, f_cm, rel, ty[0]["contact"]):
        print(f"{d * 1e3:8.2f} {a:15.3f} {b:12.3f} {r:9.2e} {100 * c:7.1f}%")
    print(f"tyreroad / ContactMechanics time: {t_ty / t_cm:.2f}x; memory: {m_ty / m_cm:.2f}x; "
          f"tyreroad max|R| {ty[0]['residual']:.1e} m, ContactMechanics pentol {args.pentol:g} m")
    return {"size": f"{nx}x{ny}", "t_ty": t_ty, "t_cm": t_cm, "m_ty": m_ty, "m_cm": m_cm, "rel": max(rel)}


def stiffness_check(args) -> None:
    print("\n=== stiff linear springs, default settings (issue 18, must-show 1) ===")
    print(f"{'patch':<8s} {'k [N/m]':>8s} {'path':<6s} {'s':>6s} {'F(0.25 mm) [N]':>15s} {'Newton max':>10s} "
          f"{'Krylov max':>10s} {'max|R| [m]':>10s}")
    for nx, ny in ((20, 20), (150, 200)):
        res = _spawn("stiff", args, nx, ny, _inputs(args, nx, ny))
        if res is None:
            continue
        for stiffness, row in res.items():
            for method, r in row.items():
                if "error" in r:
                    print(f"{nx}x{ny:<4d} {stiffness:>8s} {method:<6s} FAILED: {r['error']}")
                    continue
                print(f"{nx}x{ny:<4d} {stiffness:>8s} {method:<6s} {r['s']:6.2f} {r['force'][-1]:15.6f} "
                      f"{r['newton_max']:10d} {r['krylov_max']:10d} {r['residual']:10.1e}")
            if "dense" in row and "fft" in row and "error" not in row["dense"] and "error" not in row["fft"]:
                fd, ff = row["dense"]["force"], row["fft"]["force"]
                worst = max(abs(a - b) for a, b in zip(fd, ff)) / max(fd)
                print(f"{'':8s} {stiffness:>8s} dense vs FFT: max|dF| / max F = {worst:.1e} "
                      f"(target 1e-9: {'met' if worst <= 1e-9 else 'MISSED'})")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="150x200,300x400", help="comma-separated NXxNY")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--pentol", type=float, default=1e-10, help="ContactMechanics penetration tolerance [m]")
    parser.add_argument("--no-stiffness-check", dest="stiffness_check", action="store_false")
    parser.add_argument("--cache", default=str(ROOT / "results" / "benchmarks" / "compare_contactmechanics"))
    parser.add_argument("--baseline", default=None,
                        help="an earlier tyreroad checkout (its root) timed alongside, same children, alternating")
    parser.add_argument("--config", default=str(ROOT / "config" / "config.yaml"))
    parser.add_argument("--child", choices=sorted(CHILDREN), help=argparse.SUPPRESS)
    parser.add_argument("--nx", type=int, help=argparse.SUPPRESS)
    parser.add_argument("--ny", type=int, help=argparse.SUPPRESS)
    parser.add_argument("--inputs", help=argparse.SUPPRESS)
    parser.add_argument("--result", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        Path(args.result).write_text(json.dumps(CHILDREN[args.child](args)))
        return
    try:
        sizes = [tuple(int(v) for v in s.lower().split("x")) for s in args.sizes.split(",")]
    except ValueError:
        sizes = []
    if not sizes or any(len(s) != 2 or min(s) < 4 for s in sizes) or args.repeats < 1:
        parser.error(f"--sizes: expected NXxNY[,NXxNY...] with NX, NY >= 4 (got {args.sizes!r}); --repeats >= 1")
    try:
        import ContactMechanics  # noqa: F401
    except ImportError:
        parser.error("ContactMechanics is not installed: pip install ContactMechanics==1.8.3 (not muFFT)")
    load = os.getloadavg()
    print(f"compare_contactmechanics: {os.cpu_count()} CPUs, load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}, "
          f"E = {E / 1e6:g} MPa, nu = {NU}, h = {H * 1e3:g} mm, d = {', '.join(f'{d * 1e3:g}' for d in INDENTATIONS)} mm",
          flush=True)
    results = [r for r in (compare(args, nx, ny) for nx, ny in sizes) if r]
    print("\n=== issue 18 targets (must-show 3) ===")
    for r in results:
        print(f"{r['size']}: time {r['t_ty']:.2f} s vs {r['t_cm']:.2f} s padded "
              f"({'met' if r['t_ty'] <= r['t_cm'] else 'MISSED'}); peak memory {r['m_ty']:.2f} vs {r['m_cm']:.2f} GiB, "
              f"<= 2x: {'met' if r['m_ty'] <= 2 * r['m_cm'] else 'MISSED'}; forces within 2 %: "
              f"{r['rel']:.2%} ({'met' if r['rel'] <= 0.02 else 'MISSED'})")
    if args.stiffness_check:
        stiffness_check(args)


if __name__ == "__main__":
    main()
