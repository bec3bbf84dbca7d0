"""The belt kernel of the default study: fit time, poles, errors, passivity, history cost (tyreroad.belt_kernel).

Default tread + DEFAULT_BELT, 20 x 20 patch of 1 mm elements, fs = 51.2 kHz, L = 256. Prints the figures quoted
in the module docstring of tyreroad/belt_kernel.py; never fails on timing.

    PYTHONPATH=. OPENBLAS_NUM_THREADS=1 python benchmarks/belt_kernel_fit.py [out.nc]
"""

import dataclasses
import logging
import sys
import time
from pathlib import Path

import numpy as np
import xarray as xr
import yaml

from tyreroad.belt import DEFAULT_BELT
from tyreroad.belt_fit import fit_belt_kernel
from tyreroad.belt_kernel import BeltKernel
from tyreroad.material import material_from_config

ROOT = Path(__file__).resolve().parents[1]


def main(out=None):
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(message)s")
    mats = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())["materials"]
    tread = material_from_config("tread", mats)
    shape, fs, n_lags = (20, 20), 51200.0, 256
    t0 = time.perf_counter()
    kernel = fit_belt_kernel(tread, DEFAULT_BELT, shape, 1e-3, fs, n_lags)
    print(f"fit: {time.perf_counter() - t0:.1f} s")
    print(kernel.describe())
    for key, value in kernel.diagnostics.items():
        print(f"  {key}: {value}")
    if out:
        xr.Dataset({k: v for k, v in kernel.variables().items()}).to_netcdf(out)
        with xr.open_dataset(out) as ds:
            back = BeltKernel.from_dataset(ds.load())
        print("round trip exact:", np.array_equal(back.residues, kernel.residues))
    lags = kernel.lags(n_lags)
    print(f"belt lags 0..{n_lags - 1}: lag-0 |g_00| {abs(lags[19, 19, 0]):.3e} m/N, sum {lags[19, 19].sum():.3e} m/N, "
          f"static {kernel.static[19, 19]:.3e} m/N")
    rng = np.random.default_rng(1)
    for method in ("dense", "fft"):
        hist = kernel.memory(n_lags).history(shape, method)
        times = []
        for n in range(n_lags + 400):
            t = time.perf_counter()
            hist.displacement(n)
            hist.record(n, rng.random(400))
            times.append(time.perf_counter() - t)
        steady = np.array(times[n_lags + 50:])
        print(f"BeltHistory {method} 20 x 20: median {np.median(steady) * 1e6:.0f} us/step, rank {hist.rank}, "
              f"{hist.nbytes / 1e6:.2f} MB states + delay line"
              + (f", {hist._matrix.nbytes / 1e6:.1f} MB spatial matrix" if method == "dense" else ""))
    # the same belt without its frequency-independent (non-causal) loss: what the fit reaches on causal data
    lossless = fit_belt_kernel(tread, dataclasses.replace(DEFAULT_BELT, loss_factor=0.0), shape, 1e-3, fs, n_lags)
    d = lossless.diagnostics
    print(f"lossless belt (eta = 0): {lossless.describe()}; below 1 Hz {d['max_error_below_f_low']:.1e}, "
          f"1-10 Hz {d['max_error_f_low_to_10_hz']:.1e}, above 5 kHz {d['max_error_above_5_khz']:.1e}, "
          f"at fs/2 {d['error_at_nyquist']:.1e}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else None)
