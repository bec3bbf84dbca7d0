"""The greens stage as Snakemake runs it (issue 23's "greens stage <= 2x"): the `greens` job with the default
(``passive``) construction against the same job with today's (``fold``) kernel, per material.

Each job runs through ``snakemake`` (the rule's script in its own Python process, imports and file writing
included) into a temporary results directory, the two constructions interleaved, ``--repeats`` times; the
wall time is the job's own Snakemake benchmark record (``benchmarks/greens/<material>.tsv``, column ``s``),
which leaves out Snakemake's planning. Prints per material the medians, the individual runs and their ratio,
and the stage's (the sum over the materials' jobs).
`bench_greens_stage.py` times the stage in-process (no interpreter start-up), the stricter ratio.

    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_greens_jobs.py [--materials tread tread-eta0.5]
        [--repeats 3]

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
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]


def job_seconds(results: Path, material: str) -> float:
    with open(results / "benchmarks" / "greens" / f"{material}.tsv") as fh:
        return float(next(csv.DictReader(fh, delimiter="\t"))["s"])


def run_job(tmp: Path, construction: str, material: str, greens: dict) -> float:
    results = tmp / construction
    overlay = tmp / f"{construction}.yaml"
    overlay.write_text(yaml.safe_dump({"results_dir": str(results), "greens": {**greens, "construction": construction}}))
    target = results / "greens" / f"{material}.nc"
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-m", "snakemake", "-j1", "--nolock", "--quiet", "all", "--forcerun",
                           "greens", "--configfile", str(ROOT / "config" / "config.yaml"), str(overlay), "--",
                           str(target)], cwd=ROOT, env=env, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"snakemake greens {material} ({construction}) failed:\n{done.stderr[-4000:]}")
    return job_seconds(results, material)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--materials", nargs="+", default=["tread", "tread-eta0.5", "tread-eta1.5", "tread-rho0.5",
                                                            "tread-rho2"])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    greens = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())["greens"]
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
