"""Convergence of the belt's element Green's function correction (issue 26), and the plane against the ring.

Prints (1) Delta g(0, f) of the tread preset on DEFAULT_BELT at 100 Hz, 1 kHz, 5 kHz for the default rule and
its refinements: resolution (``refine``: panel ratios' excess / refine, directions x refine), extent (``extent``:
k_max x extent), fewer directions, and the rule without its free-wave bands (coarse panels everywhere); the
deviations are relative to |Delta g(0, f)| of the finest rule. (2) The infinite-plane representation against the
ring-and-strip mode sum (kx = 2 pi n / L, ky = m pi / W, simply supported edges, load on the centre line),
tread + belt coupled per mode with the same tau, K_b: the image effects of the ring period and the edges.

Run: OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python benchmarks/belt_element_convergence.py
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import yaml

from tyreroad import belt as belt_mod
from tyreroad.belt import (DEFAULT_BELT, belt_element_frf_correction, belt_element_frf_correction_ring,
                           belt_impedance, layer_two_port)
from tyreroad.material import material_from_config

ROOT = Path(__file__).resolve().parents[1]
C = 1e-3


def correction(mat, f, **kw):
    w = 2 * np.pi * np.atleast_1d(f)
    return belt_element_frf_correction([[0.0, 0.0], [5 * C, 0.0]], C, w, mat.modulus(w), mat.poisson, mat.density,
                                       mat.thickness, DEFAULT_BELT, **kw)


def ring_strip(mat, f, k_max=4000.0):
    """Delta g(0, f) on the ring of circumference L, width W, simply supported, load at y0 = W / 2."""
    b = DEFAULT_BELT
    w = 2 * np.pi * f
    e = mat.modulus(w)
    n = np.arange(0, int(k_max * b.circumference / (2 * np.pi)) + 1)
    m = np.arange(1, int(k_max * b.width / np.pi) + 1, 2)  # sin^2(m pi / 2) = 1 for odd m, 0 for even
    kx, ky = np.meshgrid(2 * np.pi * n / b.circumference, m * np.pi / b.width, indexing="ij")
    k = np.hypot(kx, ky)
    port = layer_two_port(k, w, e, mat.poisson, mat.density, mat.thickness)
    p = np.sinc(kx * C / (2 * np.pi)) * np.sinc(ky * C / (2 * np.pi))
    term = p * port["tau"] ** 2 / (belt_impedance(kx, ky, w, b) + port["k_base"])
    weight = np.where(n == 0, 1.0, 2.0)[:, None]  # +-n
    return 2.0 / (b.circumference * b.width) * np.sum(weight * term)


def main():
    mats = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())["materials"]
    tread = material_from_config("tread", mats)
    freqs = [100.0, 1000.0, 5000.0]
    rules = [
        ("default", {}),
        ("refine 2", {"refine": 2.0}),
        ("refine 4", {"refine": 4.0}),
        ("extent 2", {"extent": 2.0}),
        ("extent 4", {"extent": 4.0}),
        ("n_theta 8", {"n_theta": 8}),
        ("n_theta 16", {"n_theta": 16}),
    ]
    values, times = {}, {}
    for name, kw in rules:
        t0 = time.perf_counter()
        values[name] = correction(tread, freqs, **kw)
        times[name] = time.perf_counter() - t0
    # the rule without its free-wave bands: coarse geometric panels (ratio 1.04) everywhere
    saved = belt_mod._belt_wave_band
    belt_mod._belt_wave_band = lambda *a, **k: ([], math.inf)
    try:
        t0 = time.perf_counter()
        values["no wave bands"] = correction(tread, freqs)
        times["no wave bands"] = time.perf_counter() - t0
    finally:
        belt_mod._belt_wave_band = saved
    ref = values["refine 4"]
    print("Delta g(0, f) [m/N], tread preset on DEFAULT_BELT, c = 1 mm")
    print("  " + "  ".join(f"{f:7.0f} Hz: {ref[i, 0].real:+.10e} {ref[i, 0].imag:+.10e}j" for i, f in enumerate(freqs)))
    print()
    print(f"{'rule':<16}" + "".join(f"{'|dg-ref|/|ref| ' + str(int(f)) + ' Hz':>26}" for f in freqs)
          + f"{'offset (5c,0), 1 kHz':>24}{'time [s]':>10}")
    for name in values:
        dev = np.abs(values[name] - ref) / np.abs(ref[:, :1])
        print(f"{name:<16}" + "".join(f"{dev[i, 0]:>26.2e}" for i in range(len(freqs)))
              + f"{dev[1, 1]:>24.2e}{times[name]:>10.2f}")
    print()
    print("ring + strip (b), belt_element_frf_correction_ring: truncation k_max x extent")
    ring = {}
    for x in (1.0, 2.0):
        w = 2 * np.pi * np.array(freqs)
        t0 = time.perf_counter()
        ring[x] = belt_element_frf_correction_ring([[0.0, 0.0], [5 * C, 0.0]], C, w, tread.modulus(w), tread.poisson,
                                                   tread.density, tread.thickness, DEFAULT_BELT, extent=x)
        times[x] = time.perf_counter() - t0
    print("  " + "  ".join(f"{f:7.0f} Hz: {ring[2.0][i, 0].real:+.10e} {ring[2.0][i, 0].imag:+.10e}j"
                           for i, f in enumerate(freqs)))
    for x in (1.0, 2.0):
        dev = np.abs(ring[x] - ring[2.0]) / np.abs(ring[2.0][:, :1])
        print(f"{'extent ' + str(x):<16}" + "".join(f"{dev[i, 0]:>26.2e}" for i in range(len(freqs)))
              + f"{dev[1, 1]:>24.2e}{times[x]:>10.2f}")
    print()
    print("infinite plane (a) against ring + simply supported strip (b), Delta g(0, f), load on the centre line")
    print(f"{'f [Hz]':>8}{'plane':>36}{'ring+strip':>36}{'|a-b|/|a|':>12}{'|a-b|/|g_total|':>18}")
    from tyreroad.greens import element_frf
    for f in [20.0, 57.0, 100.0, 200.0, 500.0, 1000.0, 2000.0, 5000.0]:
        a = correction(tread, f)[0, 0]
        b = ring_strip(tread, f)  # the sum written out here again
        lib = belt_element_frf_correction_ring([[0.0, 0.0]], C, 2 * np.pi * f, tread.modulus(2 * np.pi * f),
                                               tread.poisson, tread.density, tread.thickness, DEFAULT_BELT)[0, 0]
        assert abs(lib / b - 1) < 1e-12, (lib, b)
        w = 2 * np.pi * f
        g = element_frf([[0.0, 0.0]], C, w, tread.modulus(w), tread.poisson, tread.density, tread.thickness)[0, 0]
        print(f"{f:>8.0f}{a.real:>+18.6e}{a.imag:>+17.6e}j{b.real:>+18.6e}{b.imag:>+17.6e}j"
              f"{abs(a - b) / abs(a):>12.2e}{abs(a - b) / abs(g + a):>18.2e}")


if __name__ == "__main__":
    main()
