"""Long memory (SPEC 9): accuracy of the kernel tail against an explicit long kernel, and its cost per step.

Part 1 (physics, the default study's surface, springs and tread): a dynamic run at a = 5 m/s^2
(513 steps, twice the kept 256 lags) with the 256-lag kernel plus its tail, against the same run
with an explicit 4096-lag kernel (n_fft 8192, 80 ms of memory, longer than the run, so no tail
is used). Prints the largest difference of F(d) relative to the run's largest force, and over
d >= 0.05 mm relative to the local force.

Part 2 (cost, 150 x 200 elements, synthetic 256-lag kernel and the default tread's creep for the
tail): ramp to 0.15 mm in 250 steps, then hold, for 2000 steps by the FFT path with the tail,
timing every step (the Newton driver is wrapped to stamp each step's start) and the tail history
alone; prints the median time per step around steps 300 and 1900 (same contact state: the hold),
the ratio to the median step of a 256-lag run without tail at its end (full ring, holding), and
the peak RSS of each run (each in its own subprocess).

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
    from tyreroad.kernel import LayerKernel
    from tyreroad.material import material_from_config
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
        "256 lags + tail": LayerKernel.from_greens(short, "dynamic"),
        "4096 lags, explicit": LayerKernel.dynamic(long["g"].transpose("dx", "dy", "lag").values, FS),
    }
    runs = {}
    for name, kernel in kernels.items():
        t0 = time.perf_counter()
        runs[name] = solve_path(z1, table.stiffness, table.force, table.zeta_step, kernel, d, settings,
                                time=t, threads=threads)
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

    def contact_stiffness(self):
        """k(0+) [N/m] of every spring (the springs protocol of tyreroad.newton)."""
        return self.k0

    def evaluate_into(self, zeta, force_out, stiffness_out):
        z = np.maximum(zeta, 0.0)
        force_out[:] = self.k0 * (z + 0.5 * z * z / self.zs)
        stiffness_out[:] = np.where(zeta > 0, self.k0 * (1.0 + z / self.zs), 0.0)


def part2_run(n_steps: int, with_tail: bool, threads: int) -> dict:
    """One 150 x 200 run in this process: ramp to 0.15 mm in 250 steps, then hold to n_steps.

    Returns per-step wall times, the tail history's own time per step, Newton/Krylov counts and
    the peak RSS.
    """
    import tyreroad.contact as contact
    import tyreroad.history as history_module
    from bench_convolution import synthetic_kernel
    from tyreroad.config import load_config
    from tyreroad.contact import RunRecorder, SolverSettings, march
    from tyreroad.kernel import LayerKernel
    from tyreroad.loading import IndentationPath
    from tyreroad.material import material_from_config
    from tyreroad.memory import TailModel, fit_retardation_spectrum

    nx, ny = 150, 200
    rng = np.random.default_rng(0)
    kernel = synthetic_kernel(nx, ny)
    z1 = -rng.uniform(0.0, 3e-4, (nx, ny))
    time_n = np.arange(n_steps) / FS
    d = np.minimum(np.arange(n_steps) / 250.0, 1.0) * 0.15e-3
    loading = IndentationPath(z1, d, time_n)
    tail = None
    if with_tail:
        cfg = load_config(ROOT / "config/config.yaml")
        spectrum = fit_retardation_spectrum(material_from_config("tread", cfg["materials"]), FS / 2)
        residual = 0.7 * kernel.sum(axis=2)  # the static compliance the kept lags miss (synthetic)
        tail = TailModel.from_spectrum(residual, spectrum, FS, kernel.shape[2])
    settings = SolverSettings(method="fft", long_memory=True)
    contact._set_threads(threads)
    substrate, history = LayerKernel.dynamic(kernel, FS, tail).collaborators((nx, ny), settings, threads, n_steps)
    stamps, tail_times = [], []
    step_solver = contact.solve_step
    tail_displacement = history_module.TailHistory.displacement

    def timed(*a, **k):
        stamps.append(time.perf_counter())
        return step_solver(*a, **k)

    def timed_tail(self, n):
        t0 = time.perf_counter()
        out = tail_displacement(self, n)
        tail_times.append(time.perf_counter() - t0)
        return out

    contact.solve_step = timed
    history_module.TailHistory.displacement = timed_tail
    t0 = time.perf_counter()
    res = march(loading, _Springs(nx * ny, rng), substrate, history, settings, RunRecorder(n_steps, (nx, ny)))
    stamps.append(time.perf_counter())
    return {"steps": np.diff(stamps).tolist(), "tail": tail_times, "total": time.perf_counter() - t0,
            "rss_gib": _rss_gib(), "newton": res.newton_iterations.tolist(), "krylov": res.krylov_iterations.tolist()}


def part2(threads: int) -> None:
    def sub(n_steps, with_tail):
        out = subprocess.run(
            [sys.executable, __file__, "--one", str(n_steps), "--tail", str(int(with_tail)), "--threads", str(threads)],
            check=True, capture_output=True, text=True, cwd=str(ROOT / "benchmarks"),
        ).stdout
        return json.loads(out.strip().splitlines()[-1])

    def window(run, lo, hi):
        steps = np.array(run["steps"][lo:hi])
        return (float(np.median(steps)), float(np.median(run["newton"][lo:hi])),
                float(np.median(run["krylov"][lo:hi])))

    ref = sub(256, False)
    long = sub(2000, True)
    full_ring = window(ref, 251, 256)  # holding after the ramp, ring full
    early = window(long, 290, 310)
    late = window(long, 1890, 1910)
    tail = np.array(long["tail"])
    tail_after = float(np.median(tail[-1700:])) if tail.size else float("nan")
    print(f"150 x 200, threads {threads}: ramp to 0.15 mm in 250 steps, then hold")
    print(f"256-lag run without tail, steps 251-255 (full ring, holding): median {1e3 * full_ring[0]:.1f} ms/step "
          f"({full_ring[1]:.0f} Newton / {full_ring[2]:.0f} Krylov); run {ref['total']:.1f} s, "
          f"peak RSS {ref['rss_gib']:.2f} GiB")
    for name, w in (("steps 290-309", early), ("steps 1890-1909", late)):
        print(f"2000 steps with the tail, {name}: median {1e3 * w[0]:.1f} ms/step ({w[1]:.0f} Newton / "
              f"{w[2]:.0f} Krylov); ratio to the 256-lag full-ring step {w[0] / full_ring[0]:.2f}x (target <= 1.3x)")
    print(f"time per step does not grow with n: steps 1890-1909 / 290-309 = {late[0] / early[0]:.2f}")
    print(f"tail history alone: median {1e3 * tail_after:.2f} ms/step once active; run {long['total']:.1f} s, "
          f"peak RSS {long['rss_gib']:.2f} GiB")


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
