"""The default study's cost by stage, from its jobs' own benchmark files, against the same study with
today's (``fold``) kernel construction.

Every job of the study writes ``{results_dir}/benchmarks/<rule>/.../*.tsv`` (Snakemake's ``benchmark:``,
wall seconds ``s`` and ``cpu_time``). The kernel construction changes only the greens jobs (the time
march's step is identical: same lags, tail and history), so the study with ``fold`` costs the same jobs
with each greens job at the ``fold`` stage's time, which this script measures on one material
(``tyreroad.pipeline.run_greens`` into a temporary directory, median of ``--repeats``).

    PYTHONPATH=. python benchmarks/study_cost.py [--results results] [--repeats 3]

Prints per-rule sums and the ratio (CPU seconds summed over jobs, which does not depend on how
Snakemake packed them onto the cores). Never fails on time.
"""

from __future__ import annotations

import argparse
import csv
import statistics
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tyreroad.pipeline import run_greens  # noqa: E402


def job_times(results: Path) -> dict[str, list[tuple[float, float]]]:
    """(wall s, cpu s) of every job, by rule (the first directory under benchmarks/)."""
    by_rule: dict[str, list[tuple[float, float]]] = defaultdict(list)
    root = results / "benchmarks"
    for tsv in sorted(root.rglob("*.tsv")):
        rule = tsv.relative_to(root).parts[0]
        if len(tsv.relative_to(root).parts) == 1:
            rule = tsv.stem
        with tsv.open() as fh:
            rows = list(csv.DictReader(fh, delimiter="\t"))
        if rows:
            last = rows[-1]
            by_rule[rule].append((float(last["s"]), float(last.get("cpu_time") or "nan")))
    return by_rule


def fold_greens_seconds(config: dict, material: str, repeats: int) -> float:
    """Median wall time of one ``fold`` greens stage of ``material`` on the study patch [s]."""
    greens = dict(config["greens"], construction="fold")
    patch = config["surfaces"][config["study"]["surface"]]["patch_elements"]
    times = []
    for _ in range(repeats):
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            run_greens(material, config["materials"][material], greens, patch, 1e-3, Path(tmp) / "g.nc")
            times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--results", default="results")
    ap.add_argument("--config", default="config/config.yaml")
    ap.add_argument("--material", default="tread")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--exclude", nargs="*", default=["rolling", "sensitivity"],
                    help="benchmark folders of named targets outside the default study")
    args = ap.parse_args(argv)
    by_rule = {rule: jobs for rule, jobs in job_times(Path(args.results)).items() if rule not in args.exclude}
    total_wall = sum(w for jobs in by_rule.values() for w, _ in jobs)
    total_cpu = sum(c for jobs in by_rule.values() for _, c in jobs)
    print(f"{args.results}: {sum(len(j) for j in by_rule.values())} jobs with benchmark files")
    print(f"{'rule':28s} {'jobs':>5s} {'wall s':>9s} {'cpu s':>9s}")
    for rule, jobs in sorted(by_rule.items(), key=lambda kv: -sum(w for w, _ in kv[1])):
        print(f"{rule:28s} {len(jobs):5d} {sum(w for w, _ in jobs):9.1f} {sum(c for _, c in jobs):9.1f}")
    print(f"{'total':28s} {'':5s} {total_wall:9.1f} {total_cpu:9.1f}")
    config = yaml.safe_load(Path(args.config).read_text())
    fold = fold_greens_seconds(config, args.material, args.repeats)
    greens_jobs = by_rule.get("greens", [])  # the seed construction's greens (constructions/) has no correction
    greens_wall = sum(w for w, _ in greens_jobs)
    with_fold = total_wall - greens_wall + fold * len(greens_jobs)
    print(f"fold greens stage ({args.material}, median of {args.repeats}): {fold:.1f} s; "
          f"the study's {len(greens_jobs)} greens jobs took {greens_wall:.1f} s "
          f"(median {statistics.median([w for w, _ in greens_jobs]) if greens_jobs else float('nan'):.1f} s)")
    print(f"summed job wall time: {total_wall:.1f} s with the configured construction, {with_fold:.1f} s with "
          f"fold greens jobs: ratio {total_wall / with_fold:.2f}")


if __name__ == "__main__":
    main()
