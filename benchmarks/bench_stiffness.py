"""Benchmark and validation of the stiffness-spectrum stage K*(f; d0) (SPEC 11, tyreroad.stiffness).

Parts (each selectable; all by default):

``--part stage``
    The stage per study material on the default patch (config/config.yaml: the study surface, 20 x 20
    elements, the configured preloads and frequencies): surface, springs and Green's functions are
    built in memory first (not timed), then ``spectrum_from_datasets`` is timed per material (one
    warm-up call, then the median of ``--repeats``) on the dense path, and once on the matrix-free
    path; printed: seconds per material, and max |K*_fft / K*_dense - 1| (SPEC 11 check 5).
``--part large``
    A 150 x 200 patch (ISO 10844 surface of the study preset with that patch size, as
    bench_scale.py makes it) at one preload (0.1 mm) and 60 log-spaced frequencies, matrix-free:
    the quasi-static preload solve, the element FRF at the ~19k unique offsets and the Krylov solves,
    timed separately (one run).
``--part harmonic``
    SPEC 11 check 3 on the default patch: a generalised-Maxwell tread whose longest relaxation time
    is 0.1 ms, preload 0.1 mm held 20 ms, then 1 um sin(2 pi f t) at 200 Hz (10 periods), 1 kHz (20)
    and 5 kHz (50) through the full time-domain solver (long memory on); prints |F_hat/delta_hat| /
    |K*| - 1 and the phase difference, at the study's 51.2 kHz and for 5 kHz also at 102.4 kHz, and
    the time-domain kernel's own error against the element FRF at the excitation element.

Usage: python benchmarks/bench_stiffness.py [--part stage,large,harmonic] [--threads N] [--repeats 3]
       [--config config/config.yaml]

Threads: numba, scipy.fft and BLAS use ``--threads`` (default: 1 for ``stage``, as the workflow's
rule runs it, 2 for ``large`` and ``harmonic``); each part runs in its own process so that BLAS
reads its thread count before numpy loads (Snakemake sets OPENBLAS_NUM_THREADS to the job's threads
the same way). Multi-threaded BLAS on small dense solves is what a shared machine punishes most:
with 2 BLAS threads under load one 400 x 400 solve took 0.19 s instead of 4.5 ms.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MAXWELL = {
    "model": "generalized_maxwell", "E_inf": 2.5e7, "moduli": [2.0e7, 4.0e7], "relaxation_times": [1.0e-4, 3.0e-5],
    "poisson_ratio": 0.49, "density": 1100.0, "thickness": 0.01,
}


def _setup(cfg, materials):
    """Surface, springs and greens datasets of the study surface for ``materials`` (in memory)."""
    from tyreroad.greens import GreensSettings, greens_dataset
    from tyreroad.material import material_from_config
    from tyreroad.pipeline import spring_material_inputs
    from tyreroad.springs import SpringModel, element_springs, resolve_spring_modulus
    from tyreroad.surface import prepare_surface

    name = cfg["study"]["surface"]
    spec = cfg["surfaces"][name]
    surface = prepare_surface(name, spec, base_dir=ROOT)
    model = SpringModel.from_config(cfg["springs"])
    gs = GreensSettings.from_config(cfg["greens"])
    out = {}
    for m in materials:
        inputs = spring_material_inputs(m, cfg["materials"])
        springs = element_springs(surface, model, modulus=resolve_spring_modulus(model, inputs["quasi_static_modulus"]),
                                  poisson=inputs["poisson"], thickness=inputs["thickness"])
        mat = material_from_config(m, cfg["materials"])
        greens = greens_dataset(mat, (surface.sizes["ex"], surface.sizes["ey"]), float(spec["element_size"]),
                                gs.sample_rate, gs.n_lags, gs.n_fft)
        out[m] = (mat, springs, greens)
    return surface, out


def part_stage(cfg, args) -> None:
    import numpy as np

    from tyreroad.contact import SolverSettings
    from tyreroad.stiffness import SpectrumSettings, spectrum_from_datasets

    materials = cfg["study"]["materials"]
    print(f"== stage stiffness_spectrum per material, default patch ({', '.join(materials)}) ==", flush=True)
    surface, stages = _setup(cfg, materials)
    settings = SolverSettings.from_config(cfg["solver"])
    spectrum = SpectrumSettings.from_config(cfg.get("stiffness_spectrum"))
    print(f"patch {surface.sizes['ex']} x {surface.sizes['ey']}, {len(spectrum.preloads)} preloads, "
          f"{spectrum.frequencies(cfg['greens'].get('sample_rate', 51200.0)).size} frequencies")
    print("| material | dense median s | min | max | fft s | max abs(K*_fft/K*_dense - 1) | Krylov its/solve (median, max) |")
    print("|---|---|---|---|---|---|---|")
    for m in materials:
        mat, springs, greens = stages[m]

        def run(method):
            t0 = time.perf_counter()
            ds = spectrum_from_datasets(surface, springs, greens, mat, spectrum, settings, args.threads, method)
            return time.perf_counter() - t0, ds

        run("dense")  # warm-up (numba cache, imports)
        times, dense = [], None
        for _ in range(args.repeats):
            t, dense = run("dense")
            times.append(t)
        t_fft, fft = run("fft")
        kd = dense["storage_stiffness"].values + 1j * dense["loss_stiffness"].values
        kf = fft["storage_stiffness"].values + 1j * fft["loss_stiffness"].values
        its = fft["krylov_iterations"].values
        print(f"| {m} | {statistics.median(times):.2f} | {min(times):.2f} | {max(times):.2f} | {t_fft:.2f} | "
              f"{np.max(np.abs(kf / kd - 1)):.1e} | {int(np.median(its))}, {int(its.max())} |", flush=True)
    print("target: <= 10 s per material on the default patch")


def part_large(cfg, args) -> None:
    import numpy as np

    from tyreroad.contact import SolverSettings
    from tyreroad.greens import ElementFRF, offset_table_index, static_element_kernel, unique_offsets
    from tyreroad.kernel import LayerKernel
    from tyreroad.material import material_from_config
    from tyreroad.pipeline import spring_material_inputs
    from tyreroad.springs import SpringModel, SpringTable, element_springs, resolve_spring_modulus
    from tyreroad.stiffness import SpectrumSettings, stiffness_spectrum
    from tyreroad.surface import prepare_surface

    nx, ny = 150, 200
    print(f"== {nx} x {ny} patch, one preload (0.1 mm), 60 frequencies, matrix-free ==", flush=True)
    name = cfg["study"]["surface"]
    spec = dict(cfg["surfaces"][name])
    c = float(spec.get("element_size", 1e-3))
    spec["patch_elements"] = [nx, ny]
    spec["field_size"] = [max(0.1, n * c + 0.02) for n in (nx, ny)]
    spec.setdefault("patch_selection", "contact_fraction")
    t0 = time.perf_counter()
    surface = prepare_surface(f"{name}-{nx}x{ny}", spec, base_dir=ROOT)
    ref = cfg["study"]["reference_material"]
    model = SpringModel.from_config(cfg["springs"])
    inputs = spring_material_inputs(ref, cfg["materials"])
    springs = SpringTable.from_dataset(element_springs(
        surface, model, modulus=resolve_spring_modulus(model, inputs["quasi_static_modulus"]),
        poisson=inputs["poisson"], thickness=inputs["thickness"]))
    mat = material_from_config(ref, cfg["materials"])
    uniq = unique_offsets((nx, ny))
    _, _, index = offset_table_index((nx, ny))
    g_static = static_element_kernel(uniq * c, c, mat.quasi_static_modulus, mat.poisson, mat.thickness)[index]
    print(f"setup (surface, springs, static kernel; not timed): {time.perf_counter() - t0:.1f} s", flush=True)
    settings = SolverSettings.from_config(cfg["solver"])
    spectrum = SpectrumSettings(preloads=(1e-4,), n_frequencies=60, report_frequencies=(), figure_preload=1e-4)
    import logging

    logging.basicConfig(level=logging.INFO, format="   %(name)s: %(message)s")
    logging.getLogger("tyreroad.contact").setLevel(logging.WARNING)
    t0 = time.perf_counter()
    ds = stiffness_spectrum(surface["z1"].transpose("ex", "ey").values, springs, LayerKernel.quasistatic(g_static),
                            ElementFRF(mat, c), mat, float(cfg["greens"].get("sample_rate", 51200.0)), spectrum,
                            settings, args.threads)
    total = time.perf_counter() - t0
    its = ds["krylov_iterations"].values
    print(f"total {total:.1f} s ({ds.attrs['method']}); {100 * float(ds['contact_fraction'][0]):.1f} % in contact, "
          f"K_qs = {float(ds['tangent_stiffness_qs'][0]):.4g} N/m, K*(f->0)/K_qs - 1 = "
          f"{float(ds['relaxed_stiffness'][0] / ds['tangent_stiffness_qs'][0] - 1):.1e}, "
          f"Krylov iterations per frequency median {int(np.median(its))} max {int(its.max())}, "
          f"min loss stiffness {float(ds['loss_stiffness'].min()):.4g} N/m")
    print("target: <= 5 min on 2 cores")


def part_harmonic(cfg, args) -> None:
    import numpy as np

    from tyreroad.contact import SolverSettings, solve_loading
    from tyreroad.greens import element_frf, greens_dataset
    from tyreroad.loading import LoadingPreset
    from tyreroad.material import material_from_config
    from tyreroad.stiffness import SpectrumSettings, harmonic_stiffness, spectrum_from_datasets

    print("== SPEC 11 check 3: time-domain harmonic runs vs K*, Maxwell tread (longest tau 0.1 ms), "
          "d0 = 0.1 mm, 1 um ==", flush=True)
    surface, stages = _setup(cfg, [cfg["study"]["reference_material"]])
    _, springs, _ = next(iter(stages.values()))  # springs depend on E_qs, nu, h only: the same E_qs here
    mat = material_from_config("maxwell", {"maxwell": MAXWELL})
    shape = (surface.sizes["ex"], surface.sizes["ey"])
    settings = SolverSettings.from_config(cfg["solver"])
    hold, speed, d0 = 0.02, 0.1, 1e-4
    print("| f [Hz] | fs [Hz] | steps | run s | abs(K_td)/abs(K*) - 1 | phase(K_td/K*) [rad] | kernel vs FRF at the "
          "excitation element: mag, phase |")
    print("|---|---|---|---|---|---|---|")
    for fs, cases in ((51200.0, ((200.0, 10), (1000.0, 20), (5000.0, 50))), (102400.0, ((5000.0, 50),))):
        n_fft, n_lags = int(4096 * fs / 51200.0), int(256 * fs / 51200.0)
        greens = greens_dataset(mat, shape, 1e-3, fs, n_lags, n_fft)
        spectrum = SpectrumSettings(preloads=(d0,), n_frequencies=20, report_frequencies=tuple(f for f, _ in cases),
                                    figure_preload=d0)
        ks = spectrum_from_datasets(surface, springs, greens, mat, spectrum, settings)
        for f, periods in cases:
            preset = LoadingPreset("h", {"kind": "harmonic", "preload": d0, "preload_speed": speed, "relax_time": hold,
                                         "amplitude": 5e-8, "frequency": f, "periods": periods})
            t0 = time.perf_counter()
            res = solve_loading(surface, springs, greens, mat, "dynamic", preset, settings, args.threads)
            t_run = time.perf_counter() - t0
            k_td = harmonic_stiffness(res, f, d0 / speed + hold + 3 / f)
            sel = ks.sel(frequency=f).isel(preload=0)
            k_fd = complex(sel["storage_stiffness"]) + 1j * complex(sel["loss_stiffness"])
            w = 2 * np.pi * f
            g = greens["g"].sel(dx=0, dy=0).values
            g_d = np.sum(g * np.exp(-1j * w * np.arange(g.size) / fs))
            g_f = element_frf(np.zeros((1, 2)), 1e-3, [w], mat.modulus(w), mat.poisson, mat.density, mat.thickness)[0, 0]
            print(f"| {f:g} | {fs:g} | {res.force.size} | {t_run:.1f} | {abs(k_td) / abs(k_fd) - 1:+.2e} | "
                  f"{np.angle(k_td / k_fd):+.4f} | {abs(g_d) / abs(g_f) - 1:+.2e}, {np.angle(g_d / g_f):+.4f} |",
                  flush=True)
    print("targets: within 1 % in magnitude and 0.01 rad in phase")


#: Threads per part when --threads is not given: the stage as the workflow runs it (threads: 1),
#: the large patch and the time-domain runs on the 2 cores.
DEFAULT_THREADS = {"stage": 1, "large": 2, "harmonic": 2}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--part", default="stage,large,harmonic")
    parser.add_argument("--threads", type=int, default=None,
                        help="numba/FFT/BLAS threads (default: 1 for stage, 2 for large and harmonic)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--config", default=str(ROOT / "config" / "config.yaml"))
    args = parser.parse_args(argv)
    parts = args.part.split(",")
    for part in parts:
        if part not in DEFAULT_THREADS:
            sys.exit(f"--part: unknown part {part!r} (expected {', '.join(DEFAULT_THREADS)})")
    if len(parts) > 1 or "numpy" in sys.modules:
        # one subprocess per part: BLAS reads its thread count when numpy loads
        import subprocess

        for part in parts:
            threads = args.threads or DEFAULT_THREADS[part]
            cmd = [sys.executable, str(Path(__file__).resolve()), "--part", part, "--threads", str(threads),
                   "--repeats", str(args.repeats), "--config", args.config]
            subprocess.run(cmd, check=False)
        return
    args.threads = args.threads or DEFAULT_THREADS[parts[0]]
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[var] = str(args.threads)
    print(f"[{parts[0]}: {args.threads} thread(s)]", flush=True)
    import numba

    from tyreroad.config import load_config

    numba.set_num_threads(min(args.threads, numba.config.NUMBA_NUM_THREADS))
    cfg = load_config(args.config)
    {"stage": part_stage, "large": part_large, "harmonic": part_harmonic}[parts[0]](cfg, args)


if __name__ == "__main__":
    main()
