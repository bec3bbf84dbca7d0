"""The road's input lines in rolling passes: how much of the fs/2 alternation is the elements entering.

On a flat road the only input of a rolling pass is rows of elements entering the contact at
v / element size; its force carries lines at k v / element size (aliased into [0, fs/2]). This script fits
them (k = 1 ... 8, with a quadratic trend) to the steady part of each dynamic pass and prints their
amplitudes over the mean force, beside the raw fourth-difference alternation and the one without the lines
(:func:`tyreroad.rolling.dataset.alternation_without_input_lines`); for a quasi-static pass it fits the lines in
x_c (period: one element). Comparing the same pass run with different kernels or sample rates tells the
model's own lines from the march's.

Usage::

    python benchmarks/flat_road_lines.py RESULTS_DIR [RESULTS_DIR ...]

Measured 2026-11-26 (session 21) on a 150 x 8 flat strip (``surfaces.flat-strip: {generator: flat,
patch_elements: [150, 8]}``, ``rolling: {surfaces: [flat-strip], materials: [tread], speeds: [10],
quasistatic_speeds: [5], load: 200}``), tread, 10 m/s, three runs of ``snakemake -j2 rolling``:

=========================== ======== ============ ======== ======== ======== =========
run                          raw       without lines 10 kHz   20 kHz   30 kHz   fs [kHz]
=========================== ======== ============ ======== ======== ======== =========
passive (default)            2.08e-4   1.17e-5      1.58e-3  2.79e-4  1.10e-4  51.2
radau (every spring)         2.00e-4   1.11e-5      1.28e-3  2.81e-4  1.24e-4  51.2
passive, sample_rate 102400  7.01e-5   3.93e-5      1.29e-3  3.03e-4  1.32e-4  102.4
quasi-static (x_c lines)     -         -            6.6e-4   3.2e-5   1.2e-5   -
=========================== ======== ============ ======== ======== ======== =========

(102.4 kHz: ``greens: {sample_rate: 102400, n_lags: 512, n_fft: 8192}``; radau: ``greens.construction: radau``
with ``belt.study: false``.) The 20 kHz line is the same within 10 % for every kernel and both sample rates:
the model's response, which the raw fourth difference reads at 0.79 of its size at 51.2 kHz.
"""

from __future__ import annotations

import argparse
import glob
import os

import numpy as np
import xarray as xr

from tyreroad.rolling.dataset import alternation_without_input_lines, input_line_frequencies
from tyreroad.stability import fs2_alternation

HARMONICS = 8


def _fit_lines(signal: np.ndarray, phase_per_sample: np.ndarray) -> np.ndarray:
    """Amplitudes of cos/sin at each phase rate (rad per sample), with a quadratic trend, by least squares."""
    n = np.arange(signal.size, dtype=float)
    u = n / max(n[-1], 1.0)
    columns = []
    for w in phase_per_sample:
        columns += [np.cos(w * n), np.sin(w * n)]
    basis = np.stack(columns + [np.ones_like(u), u, u * u], axis=1)
    c, *_ = np.linalg.lstsq(basis, signal, rcond=None)
    return np.hypot(c[0:2 * len(phase_per_sample):2], c[1:2 * len(phase_per_sample):2])


def dynamic_lines(path: str) -> str:
    ds = xr.open_dataset(path)
    steady = ds["steady"].values.astype(bool)
    force = ds["force"].values[steady]
    mean = float(force.mean())
    dt = float(ds["time"].values[1] - ds["time"].values[0])
    fs = 1.0 / dt
    element = float(ds["element_x"].values[1] - ds["element_x"].values[0])
    rate = float(ds.attrs["speed"]) / element
    aliased = input_line_frequencies(rate, fs, HARMONICS)
    amps = _fit_lines(force, 2 * np.pi * aliased / fs) / mean
    raw = fs2_alternation(force, window=np.ones(force.size, bool))
    removed = alternation_without_input_lines(force, rate, fs)
    lines = " ".join(f"{k + 1}:{f / 1e3:.1f}k {a:.2e}" for k, (f, a) in enumerate(zip(aliased, amps)))
    return (f"{path}: fs {fs / 1e3:.1f} kHz, v/dx {rate / 1e3:.3g} kHz, mean {mean:.2f} N, raw {raw:.3g}, "
            f"without lines {removed:.3g}\n    lines (over the mean force) {lines}")


def quasistatic_lines(path: str) -> str:
    ds = xr.open_dataset(path)
    steady = ds["steady"].values.astype(bool)
    force, x = ds["force"].values[steady], ds["x_c"].values[steady]
    element = float(ds["element_x"].values[1] - ds["element_x"].values[0])
    step = float(x[1] - x[0])
    amps = _fit_lines(force, 2 * np.pi * step / element * np.arange(1, 5)) / float(force.mean())
    return f"{path}: quasi-static lines in x_c (k / element) " + " ".join(f"{k + 1}: {a:.2e}" for k, a in enumerate(amps))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("results", nargs="+", help="results directories of rolling runs (results_dir)")
    args = parser.parse_args()
    for res in args.results:
        files = sorted(glob.glob(os.path.join(res, "rolling", "*", "*", "*.nc")))
        if not files:
            raise SystemExit(f"{res}: no rolling passes under {res}/rolling/<surface>/<material>/")
        for path in files:
            name = os.path.basename(path)
            print(dynamic_lines(path) if name.startswith("dynamic") else quasistatic_lines(path))


if __name__ == "__main__":
    main()
