"""Long memory (SPEC 9): accuracy of the kernel tail against an explicit long kernel, and its cost per step.

Part 1 (physics, the default study's surface, springs and tread): a dynamic run at a = 5 m/s^2
(513 steps, twice the kept 256 lags) with the 256-lag kernel plus its tail, against the same run
with an explicit 4096-lag kernel (n_fft 8192, 80 ms of memory, longer than the run, so no tail
is used). Prints the largest difference of F(d) relative to the run's largest force, and over
d >= 0.05 mm relative to the local force.

Part 2 (cost, 150 x 200 elements, synthetic 256-lag kernel and the default tread's creep for the
tail): a run of 2000 steps by the FFT path with the tail, timing every step (the Newton driver is
wrapped to stamp each step's start); prints the median time per step around steps 300 and 1900,
and the ratio to the median step of a 256-lag run at its end (full history ring, no tail), and the
peak RSS of each run (each in its own subprocess).

    python benchmarks/bench_long_memory.py [--part 1|2|all] [--threads 1]

Needs the default study's results/ (surface and springs of iso10844 / tread) for part 1.
Never fails on time; prints figures.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
FS = 51200.0


def _rss_gib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20


def part1(threads: int) -> None:
    from tyreroad import io
    from tyreroad.config import load_config
    from tyreroad.contact import SolverSettings, solve_path
    from tyreroad.greens import greens_dataset
    from tyreroad.loading import constant_acceleration_path
    from tyreroad.material import material_from_config
    from tyreroad.memory import TailModel
    from tyreroad.springs import SpringTable

    cfg = load_config(ROOT / "config/config.yaml")
    material = material_from_config("tread", cfg["materials"])
    results = ROOT / "results"
    surface = io.read_dataset(results / "surface/iso10844.nc")
    table = SpringTable.from_dataset(io.read_dataset(results / "springs/iso10844/tread.nc"))
    z1 = surface["z1"].transpose("ex", "ey").values
    nx, ny = z1.shape
    t0 = time.perf_counter()
    short = greens_dataset(material, (nx, ny), 1e-3, FS, 256, 4096)
    t_short = time.perf_counter() - t0
    t0 = time.perf_counter()
    long = greens_dataset(material, (nx, ny), 1e-3, FS, 4096, 8192)
    t_long = time.perf_counter() - t0
    t, d = constant_acceleration_path(FS, 5.0, 2.5e-4)
    settings = SolverSettings(method="fft")
    kernels = {
        "256 lags + tail": (short["g"].transpose("dx", "dy", "lag").values, TailModel.from_greens(short)),
        "4096 lags, explicit": (long["g"].transpose("dx", "dy", "lag").values, None),
    }
    runs = {}
    for name, (kernel, tail) in kernels.items():
        t0 = time.perf_counter()
        runs[name] = solve_path(z1, table.stiffness, table.force, table.zeta_step, kernel, d, settings,
                                time=t, threads=threads, tail=tail)
        print(f"{name}: {d.size} steps in {time.perf_counter() - t0:.1f} s", flush=True)
    a, b = runs["256 lags + tail"].force, runs["4096 lags, explicit"].force
    rel_max = np.max(np.abs(a - b)) / np.max(np.abs(b))
    sel = d >= 0.05e-3
    rel_local = np.max(np.abs(a[sel] - b[sel]) / b[sel])
    print(f"greens: 256 lags {t_short:.1f} s, 4096 lags (n_fft 8192) {t_long:.1f} s")
    print(f"a = 5 m/s^2, {d.size} steps: F at d_max {a[-1]:.3f} N (tail) vs {b[-1]:.3f} N (4096 lags)")
    print(f"max |dF| / max F = {rel_max:.2e}; max |dF| / F over d >= 0.05 mm = {rel_local:.2e} (target 2e-3)")
    kept_256 = float(short["kept_fraction"])
    kept_4096 = float(long["kept_fraction"])
    print(f"kept fraction of g(0) at the excitation element: 256 lags {kept_256:.4f}, 4096 lags {kept_4096:.4f}")


class _Springs:
    """k = k0 (1 + zeta / zeta_s) for zeta > 0 (the springs protocol: evaluate_into)."""

    def __init__(self, m, rng):
        self.k0 = rng.uniform(1e4, 5e4, m)
        self.zs = 5e-5

    def evaluate_into(self, zeta, force_out, stiffness_out):
        z = np.maximum(zeta, 0.0)
        force_out[:] = self.k0 * (z + 0.5 * z * z / self.zs)
        stiffness_out[:] = np.where(zeta > 0, self.k0 * (1.0 + z / self.zs), 0.0)


def part2_run(n_steps: int, with_tail: bool, threads: int) -> dict:
    """One 150 x 200 run in this process; returns per-step times and the peak RSS."""
    import tyreroad.contact as contact
    from bench_convolution import synthetic_kernel
    from tyreroad.contact import RunRecorder, SolverSettings, build_collaborators, march
    from tyreroad.loading import IndentationPath
    from tyreroad.material import material_from_config
    from tyreroad.memory import TailModel, fit_retardation_spectrum
    from tyreroad.config import load_config

    nx, ny = 150, 200
    rng = np.random.default_rng(0)
    kernel = synthetic_kernel(nx, ny)
    z1 = -rng.uniform(0.0, 3e-4, (nx, ny))
    accel = 2.0 * 2.5e-4 * FS**2 / (n_steps - 1) ** 2
    time_n = np.arange(n_steps) / FS
    loading = IndentationPath(z1, 0.5 * accel * time_n**2, time_n)
    tail = None
    if with_tail:
        cfg = load_config(ROOT / "config/config.yaml")
        spectrum = fit_retardation_spectrum(material_from_config("tread", cfg["materials"]), FS / 2)
        residual = 0.7 * kernel.sum(axis=2)  # the static compliance the kept lags miss (synthetic)
        tail = TailModel.from_spectrum(residual, spectrum, FS, kernel.shape[2])
    settings = SolverSettings(method="fft", long_memory=True)
    contact._set_threads(threads)
    substrate, history = build_collaborators(kernel, (nx, ny), settings, threads, n_steps, tail)
    stamps = []
    step_solver = contact.solve_step

    def timed(*a, **k):
        stamps.append(time.perf_counter())
        return step_solver(*a, **k)

    contact.solve_step = timed
    t0 = time.perf_counter()
    res = march(loading, _Springs(nx * ny, rng), substrate, history, settings, RunRecorder(n_steps, (nx, ny)))
    stamps.append(time.perf_counter())
    return {"steps": np.diff(stamps).tolist(), "total": time.perf_counter() - t0, "rss_gib": _rss_gib(),
            "force": float(res.force[-1])}


def part2(threads: int) -> None:
    def sub(n_steps, with_tail):
        out = subprocess.run(
            [sys.executable, __file__, "--one", str(n_steps), "--tail", str(int(with_tail)), "--threads", str(threads)],
            check=True, capture_output=True, text=True, cwd=str(ROOT / "benchmarks"),
        ).stdout
        return json.loads(out.strip().splitlines()[-1])

    ref = sub(256, False)
    long = sub(2000, True)
    s_ref = np.array(ref["steps"])
    s_long = np.array(long["steps"])
    full_ring = float(np.median(s_ref[226:256]))
    at300 = float(np.median(s_long[290:310]))
    at1900 = float(np.median(s_long[1890:1910]))
    print(f"150 x 200, threads {threads}: 256-lag run (no tail), median step over steps 226-255 "
          f"(full ring): {1e3 * full_ring:.1f} ms; run {ref['total']:.1f} s, peak RSS {ref['rss_gib']:.2f} GiB")
    print(f"2000 steps with the tail: median step around 300: {1e3 * at300:.1f} ms, around 1900: "
          f"{1e3 * at1900:.1f} ms (ratio 1900/300 = {at1900 / at300:.2f}); run {long['total']:.1f} s, "
          f"peak RSS {long['rss_gib']:.2f} GiB")
    print(f"ratio to the 256-lag full-ring step: at 300 {at300 / full_ring:.2f}x, at 1900 {at1900 / full_ring:.2f}x "
          "(target <= 1.3x)")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--part", default="all", choices=["1", "2", "all"])
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--one", type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument("--tail", type=int, default=0, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.one:
        print(json.dumps(part2_run(args.one, bool(args.tail), args.threads)))
        return
    print(f"bench_long_memory: threads = {args.threads}")
    if args.part in ("1", "all"):
        part1(args.threads)
    if args.part in ("2", "all"):
        part2(args.threads)


if __name__ == "__main__":
    main()
