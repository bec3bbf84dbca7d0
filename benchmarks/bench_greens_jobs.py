"""The greens stage as Snakemake runs it (issue 23's "greens stage <= 2x"): the `greens` job with the default
(``passive``) construction against the same job with today's (``fold``) kernel, per material.

Each job runs through ``snakemake`` (the rule's script in its own Python process, imports and file writing
included) into a temporary results directory, the two constructions interleaved, ``--repeats`` times; the
wall time is the job's own Snakemake benchmark record (``benchmarks/greens/<material>.tsv``, column ``s``),
which leaves out Snakemake's planning. Prints per material the medians, the individual runs and their ratio,
and the stage's (the sum over the materials' jobs).
`bench_greens_stage.py` times the stage in-process (no interpreter start-up), the stricter ratio.

``--stage`` times the stage as the README's ``snakemake -j2`` runs it instead: one Snakemake invocation that makes
every listed material's greens file on ``--cores`` cores, wall clock from the command's start to its end (planning,
the jobs packed onto the cores, start-up and file writing included), the two constructions interleaved.

    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_greens_jobs.py [--materials tread tread-eta0.5]
        [--repeats 3] [--stage [--cores 2]]

Never fails on timing; prints figures.
"""

from __future__ import annotations

import argparse
import csv
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]


def job_seconds(results: Path, material: str) -> float:
    with open(results / "benchmarks" / "greens" / f"{material}.tsv") as fh:
        return float(next(csv.DictReader(fh, delimiter="\t"))["s"])


def _snakemake(tmp: Path, construction: str, materials, greens: dict, cores: int) -> Path:
    """Make ``materials``' greens files with ``construction`` in one Snakemake run; the results directory."""
    results = tmp / construction
    overlay = tmp / f"{construction}.yaml"
    overlay.write_text(yaml.safe_dump({"results_dir": str(results),
                                       "greens": {**greens, "construction": construction}}))
    targets = [str(results / "greens" / f"{material}.nc") for material in materials]
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-m", "snakemake", f"-j{cores}", "--nolock", "--quiet", "all",
                           "--forcerun", "greens", "--configfile", str(ROOT / "config" / "config.yaml"), str(overlay),
                           "--", *targets], cwd=ROOT, env=env, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"snakemake greens {materials} ({construction}) failed:\n{done.stderr[-4000:]}")
    return results


def run_job(tmp: Path, construction: str, material: str, greens: dict) -> float:
    """One material's greens job: the wall time of its Snakemake benchmark record [s]."""
    return job_seconds(_snakemake(tmp, construction, [material], greens, 1), material)


def run_stage(tmp: Path, construction: str, materials, greens: dict, cores: int) -> tuple[float, float]:
    """Every material's greens job in one ``snakemake -j<cores>``: (the command's wall clock, the jobs' summed
    benchmark records) [s]."""
    start = time.perf_counter()
    results = _snakemake(tmp, construction, materials, greens, cores)
    return time.perf_counter() - start, sum(job_seconds(results, m) for m in materials)


def stage_main(args, greens: dict) -> None:
    print(f"the stage in one `snakemake -j{args.cores}` per construction: {', '.join(args.materials)}")
    times = {"fold": [], "passive": []}
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(args.repeats):
            for construction in times:
                times[construction].append(run_stage(Path(tmp), construction, args.materials, greens, args.cores))
                wall, jobs = times[construction][-1]
                print(f"  {construction:8s} wall {wall:6.2f} s (jobs summed {jobs:6.2f} s)", flush=True)
    wall = {c: statistics.median(w for w, _ in v) for c, v in times.items()}
    jobs = {c: statistics.median(j for _, j in v) for c, v in times.items()}
    print(f"the stage's wall clock (medians of {args.repeats}): passive {wall['passive']:.2f} s, fold "
          f"{wall['fold']:.2f} s, ratio {wall['passive'] / wall['fold']:.2f}; its jobs summed: passive "
          f"{jobs['passive']:.2f} s, fold {jobs['fold']:.2f} s, ratio {jobs['passive'] / jobs['fold']:.2f}")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--materials", nargs="+", default=["tread", "tread-eta0.5", "tread-eta1.5", "tread-rho0.5",
                                                            "tread-rho2"])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--stage", action="store_true",
                        help="time the whole stage in one Snakemake run per construction (its wall clock)")
    parser.add_argument("--cores", type=int, default=2, help="Snakemake's -j for --stage (the README's: 2)")
    args = parser.parse_args(argv)
    greens = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())["greens"]
    if args.stage:
        return stage_main(args, greens)
    print(f"tree {ROOT}; greens {greens}; {args.repeats} runs per construction, interleaved")
    ratios, totals = [], {"fold": 0.0, "passive": 0.0}
    with tempfile.TemporaryDirectory() as tmp:
        for material in args.materials:
            times = {"fold": [], "passive": []}
            for _ in range(args.repeats):
                for construction in times:
                    times[construction].append(run_job(Path(tmp), construction, material, greens))
            med = {c: statistics.median(v) for c, v in times.items()}
            ratios.append(med["passive"] / med["fold"])
            for c in totals:
                totals[c] += med[c]
            print(f"{material:14s} passive {med['passive']:6.2f} s ("
                  + ", ".join(f"{v:.2f}" for v in times["passive"]) + f")  fold {med['fold']:6.2f} s ("
                  + ", ".join(f"{v:.2f}" for v in times["fold"]) + f")  ratio {ratios[-1]:.2f}", flush=True)
    print(f"ratio over the materials: median {statistics.median(ratios):.2f}, largest {max(ratios):.2f}")
    # the stage as the study runs it: one greens job per material, so its cost is their sum
    print(f"the stage (these materials' jobs together, sums of the medians): passive {totals['passive']:.2f} s, fold "
          f"{totals['fold']:.2f} s, ratio {totals['passive'] / totals['fold']:.2f}")


if __name__ == "__main__":
    main()
