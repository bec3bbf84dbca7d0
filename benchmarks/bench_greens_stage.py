"""The greens stage per material (issue 23): wall time and the stored k_crit against the stiffest element spring.

Runs :func:`tyreroad.pipeline.run_greens` as the Snakemake rule does (the study's greens settings from
config/config.yaml, the largest study patch 20 x 20, 1 mm elements) ``--repeats`` times per material into a
temporary directory, and prints per material: the median and the individual wall times, the stage's phases
(from its log: element FRF, correction design, margin), k_crit (``critical_stiffness``) with its theta and
method, the stiffest element spring of the material's springs file (``--springs``, default
results/springs/iso10844 of this tree, as the study writes it; NaN when absent) and k_crit over it (issue 23 asks >= 1.5).

Set OPENBLAS_NUM_THREADS=1 (the rule runs with threads: 1). To compare with an older tree, copy this script
into that tree's benchmarks/ and run it there: it imports the package of the tree it sits in.

    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_greens_stage.py [--materials tread tread-eta0.5]
        [--repeats 3] [--shape 20 20] [--springs DIR] [--against fold|none]

``--against`` times another construction (default ``fold``, today's kernel) in the same run, interleaved with the
default one, and prints the ratio of the medians (issue 23 asks <= 2x).

Never fails on timing; prints figures.
"""

from __future__ import annotations

import argparse
import logging
import math
import re
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import xarray as xr  # noqa: E402

from tyreroad import pipeline  # noqa: E402
from tyreroad.config import load_config  # noqa: E402

PHASES = {
    "frf": re.compile(r"element_frf: done in ([\d.]+) s"),
    "design": re.compile(r"spring-safe correction: .* ([\d.]+) s$"),
    "margin": re.compile(r"stability margin .*, ([\d.]+) s\)"),
}


class _Collect(logging.Handler):
    def __init__(self):
        super().__init__(logging.INFO)
        self.lines = []

    def emit(self, record):
        self.lines.append(record.getMessage())


def phases(lines) -> dict:
    out = {}
    for name, pattern in PHASES.items():
        total = 0.0
        for line in lines:
            if name == "design" and not line.startswith("spring-safe correction"):
                continue  # the pipeline repeats the construction's line
            m = pattern.search(line)
            if m:
                total += float(m.group(1))
        out[name] = total
    return out


def stiffest_spring(springs_dir: Path, material: str) -> float:
    path = springs_dir / f"{material}.nc"
    if not path.is_file():
        return math.nan
    with xr.open_dataset(path) as ds:
        return float(ds["stiffness"].max())


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--materials", nargs="+", default=["tread", "tread-eta0.5", "tread-eta1.5", "tread-rho0.5",
                                                            "tread-rho2"])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--shape", nargs=2, type=int, default=[20, 20])
    parser.add_argument("--springs", type=Path, default=ROOT / "results" / "springs" / "iso10844")
    parser.add_argument("--against", default="fold",
                        help="construction timed in the same run, interleaved, for the ratio (issue 23: <= 2x "
                             "today's `fold`); 'none' to skip")
    args = parser.parse_args(argv)
    config = load_config(ROOT / "config" / "config.yaml")
    collect = _Collect()
    logging.getLogger("tyreroad").addHandler(collect)
    logging.getLogger("tyreroad").setLevel(logging.INFO)
    print(f"tree {ROOT}; patch {args.shape[0]} x {args.shape[1]}; greens {dict(config['greens'])}")
    totals = [0.0, 0.0]  # sums over the materials of the medians: this construction's, the other's
    with tempfile.TemporaryDirectory() as tmp:
        for material in args.materials:
            mcfg = pipeline.resolved_material_config(material, config["materials"])
            times, parts, others = [], [], []
            other = {**config["greens"], "construction": args.against}
            for r in range(args.repeats):
                if args.against != "none":  # interleaved, so that both see the same machine
                    t0 = time.perf_counter()
                    pipeline.run_greens(material, mcfg, other, args.shape, 1e-3, Path(tmp) / f"{material}-o{r}.nc")
                    others.append(time.perf_counter() - t0)
                collect.lines.clear()
                out = Path(tmp) / f"{material}-{r}.nc"
                t0 = time.perf_counter()
                pipeline.run_greens(material, mcfg, config["greens"], args.shape, 1e-3, out)
                times.append(time.perf_counter() - t0)
                parts.append(phases(collect.lines))
            with xr.open_dataset(out) as ds:
                k_crit = float(ds["critical_stiffness"])
                theta = float(ds["critical_theta"])
                method = ds["critical_stiffness"].attrs.get("method", "")
                target = ds.attrs.get("spring_correction_k_target", math.nan)
            spring = stiffest_spring(args.springs, material)
            med = {k: statistics.median(p[k] for p in parts) for k in PHASES}
            print(f"{material:18s} stage median {statistics.median(times):7.2f} s  (runs "
                  + ", ".join(f"{t:.2f}" for t in times) + ")  phases median: "
                  + ", ".join(f"{k} {v:.2f} s" for k, v in med.items()))
            totals[0] += statistics.median(times)
            if others:
                totals[1] += statistics.median(others)
                ratio = statistics.median(times) / statistics.median(others)
                print(f"{'':18s} {args.against} stage median {statistics.median(others):7.2f} s  (runs "
                      + ", ".join(f"{t:.2f}" for t in others) + f"); ratio {ratio:.2f}")
            print(f"{'':18s} k_crit {k_crit:.4g} N/m at theta {theta / math.pi:.4f} pi ({method}); design "
                  f"k_target {target:.3g} N/m; stiffest spring {spring:.4g} N/m; k_crit / spring "
                  f"{k_crit / spring:.3f} (issue 23 asks >= 1.5)")
            sys.stdout.flush()
    if args.against != "none" and len(args.materials) > 1:
        # the stage as the study runs it, one greens job per material: its cost is their sum
        print(f"the stage (these materials together, sums of the medians): {totals[0]:.2f} s, {args.against} "
              f"{totals[1]:.2f} s, ratio {totals[0] / totals[1]:.2f}")


if __name__ == "__main__":
    main()
