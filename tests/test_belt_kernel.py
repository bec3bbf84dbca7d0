"""Tests of tyreroad.belt_kernel and tyreroad.belt_fit: the belt's part of the march kernel as a discrete pole-residue memory.

References independent of the code under test: tyreroad.belt.belt_element_frf_correction_ring (the ring sum, per
offset, with the two-port solved per mode), tyreroad.greens.element_frf, and a plain-numpy direct convolution with
the explicit long impulse response.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
import yaml

from tyreroad.belt import DEFAULT_BELT, belt_element_frf_correction_ring
from tyreroad.belt_fit import _ring_grid, belt_correction_table, fit_belt_kernel
from tyreroad.belt_kernel import (
    BeltHistory,
    BeltKernel,
    BeltMemory,
    _belt_update,
    _belt_update_numpy,
    belt_offsets,
    belt_table_index,
)
from tyreroad.greens import element_frf
from tyreroad.history import HistorySum
from tyreroad.kernel import MemoryModel
from tyreroad.material import material_from_config

ROOT = Path(__file__).resolve().parents[1]
FS = 51200.0
L = 256
C = 1e-3
SHAPE = (3, 3)
# the fit's error on the test's 3 x 3 patch and grid over 10 Hz - 5 kHz, relative to |g_00 + Delta g_00| (measured
# 3.2e-3 on the grid, 2.5e-3 off it; 6.0e-3 at 0.37 Hz in the creep range): the belt's frequency-independent loss
# factor is not causal, so no real kernel holds Delta g much closer; the same fit of a lossless belt reaches 4e-4,
# see the module docstring
FIT_TOLERANCE = 4e-3


@pytest.fixture(scope="module")
def tread():
    mats = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())["materials"]
    return material_from_config("tread", mats)


@pytest.fixture(scope="module")
def kernel(tread):
    return fit_belt_kernel(tread, DEFAULT_BELT, SHAPE, C, FS, L, grid_ratio=1.06, pole_pairs=(16, 24))


def _table(values, shape=SHAPE):
    """(n_f, nx ny) on belt_offsets -> (n_f, 2 nx - 1, 2 ny - 1) tables."""
    return values[:, belt_table_index(shape)[2]]


def test_offsets_and_index():
    offs = belt_offsets((3, 2))
    assert offs.tolist() == [[0, 0], [0, 1], [1, 0], [1, 1], [2, 0], [2, 1]]
    dx, dy, index = belt_table_index((3, 2))
    assert index.shape == (5, 3)
    assert np.array_equal(offs[index[0, 2]], [2, 1]) and np.array_equal(offs[index[2, 1]], [0, 0])


def test_correction_table_matches_ring_sum(tread):
    # the factored projections and the interpolated two-port against the belt's own sum, offset by offset
    f = np.array([0.0, 137.0, 4321.0, 25600.0])
    table = belt_correction_table(tread, DEFAULT_BELT, (4, 3), C, f)
    omega = 2 * np.pi * f
    ref = belt_element_frf_correction_ring(belt_offsets((4, 3)) * C, C, omega, tread.modulus(omega), tread.poisson,
                                           tread.density, tread.thickness, DEFAULT_BELT)
    assert np.max(np.abs(table - ref) / np.abs(ref[:, :1])) < 1e-10
    # orthotropic belt: not symmetric in x <-> y (why belt_offsets, not greens.unique_offsets)
    assert abs(table[0, 6] - table[0, 2]) > 5e-4 * abs(table[0, 0])  # (2, 0) vs (0, 2) mm: 1e-3 apart


def test_interpolated_two_port():
    mat = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())["materials"]
    tread = material_from_config("tread", mat)
    ax = np.arange(3) * C
    for f in (10.0, 5000.0):
        w = 2 * np.pi * f
        e = complex(tread.modulus(np.array([w]))[0])
        a = _ring_grid(ax, ax, C, w, e, tread.poisson, tread.density, tread.thickness, DEFAULT_BELT)
        b = _ring_grid(ax, ax, C, w, e, tread.poisson, tread.density, tread.thickness, DEFAULT_BELT, interpolate=False)
        assert np.max(np.abs(a - b)) < 1e-10 * abs(b[0, 0])


def test_lags_and_memory_reproduce_the_model(kernel):
    f = np.array([0.0, 3.7, 140.0, 999.0, 12345.0, 25600.0])
    lags = kernel.lags(L)
    assert lags.dtype == float and lags.shape == kernel.table_shape + (L,)
    z = np.exp(-2j * np.pi * f[:, None] / FS * np.arange(L)[None, :])
    total = np.einsum("fl,xyl->fxy", z, lags) + kernel.memory(L).frequency_response(f, FS)
    ref = kernel.frequency_response(f, FS)
    assert np.max(np.abs(total - ref)) < 1e-12 * np.max(np.abs(ref))
    mem = kernel.memory(L)
    assert isinstance(mem, MemoryModel) and mem.delay == L
    with pytest.raises(ValueError, match="fs = 51200"):
        kernel.frequency_response(f, 44100.0)


@pytest.mark.parametrize("method, shape, n_steps", [("dense", SHAPE, 4000), ("fft", SHAPE, 1500),
                                                   ("dense", (2, 3), 1500)])
def test_history_matches_direct_convolution(kernel, method, shape, n_steps):
    # against the direct convolution with the explicit impulse response (lags L ... n_steps - 1 from the poles);
    # a (2, 3) patch crops the kernel's 3 x 3 tables
    rng = np.random.default_rng(3)
    nx, ny = shape
    long = kernel.lags(n_steps)[3 - nx: 2 + nx, 3 - ny: 2 + ny]  # (2 nx - 1, 2 ny - 1, n)
    long[:, :, :L] = 0.0  # the memory's part only
    forces = rng.random((n_steps, nx * ny)) * (rng.random((n_steps, nx * ny)) < 0.7)
    forces[:, 0] = 1.0  # a steady load on one element: the ring-down and the creep are exercised
    hist = kernel.memory(L).history(shape, method)
    ex, ey = np.divmod(np.arange(nx * ny), ny)
    mats = long[ex[:, None] - ex[None, :] + nx - 1, ey[:, None] - ey[None, :] + ny - 1]  # (M, M, n)
    ref = np.zeros((n_steps, nx * ny))
    for e in range(nx * ny):
        for m in range(nx * ny):
            ref[:, e] += np.convolve(mats[e, m], forces[:, m])[:n_steps]
    got = np.empty_like(ref)
    for n in range(n_steps):
        got[n] = hist.displacement(n)
        hist.record(n, forces[n])
    assert np.max(np.abs(got - ref)) < 1e-12 * np.max(np.abs(ref))
    assert np.max(np.abs(ref[-1])) > 0.1 * np.max(np.abs(ref))  # the memory still acts at the end


def test_history_protocol_and_steps(kernel):
    hist = kernel.memory(L).history(SHAPE, "dense")
    both = HistorySum([hist])
    assert np.all(both.displacement(0) == 0.0)
    both.record(0, np.ones(9))
    with pytest.raises(ValueError, match="next step"):
        hist.displacement(5)
    with pytest.raises(ValueError, match="NaN"):
        hist.record(1, np.full(9, np.nan))
    with pytest.raises(ValueError, match="method"):
        kernel.memory(L).history(SHAPE, "sparse")
    assert isinstance(hist, BeltHistory) and hist.nbytes > 0


def test_numba_update_matches_numpy():
    rng = np.random.default_rng(0)
    n_p, m, r = 7, 13, 3
    poles = 0.9 * np.exp(1j * rng.uniform(0, np.pi, n_p))
    s = rng.normal(size=(n_p, m)) + 1j * rng.normal(size=(n_p, m))
    k_re, k_im = rng.normal(size=(n_p, r)), rng.normal(size=(n_p, r))
    f = rng.normal(size=m)
    s_re, s_im = s.real.copy(), s.imag.copy()
    out = np.empty((m, r))
    _belt_update(s_re, s_im, poles.real.copy(), poles.imag.copy(), f, k_re, k_im, out)
    ref = _belt_update_numpy(s, poles, f, k_re, k_im)
    assert np.allclose(s_re + 1j * s_im, s, rtol=0, atol=1e-14)
    assert np.allclose(out, ref, rtol=0, atol=1e-13)


def test_fit_fidelity_off_grid(kernel, tread):
    d = kernel.diagnostics
    assert d["max_error_band"] < FIT_TOLERANCE and d["phase_error_band"] < FIT_TOLERANCE
    # frequencies the fit never saw, against the belt's own ring sum and the element FRF
    f = np.array([0.0037, 0.37, 12.3, 141.0, 333.3, 777.0, 2345.6, 4999.0, 17777.0])
    omega = 2 * np.pi * f
    e = tread.modulus(omega)
    offs = belt_offsets(SHAPE) * C
    exact = belt_element_frf_correction_ring(offs, C, omega, e, tread.poisson, tread.density, tread.thickness,
                                             DEFAULT_BELT)
    g00 = element_frf(np.zeros((1, 2)), C, omega, e, tread.poisson, tread.density, tread.thickness)[:, 0]
    model = kernel.frequency_response(f, FS)
    err = np.abs(model - _table(exact)) / np.abs(g00 + exact[:, 0])[:, None, None]
    assert err[f >= 10].max() < FIT_TOLERANCE
    assert err.max() < 2 * FIT_TOLERANCE  # down to 3.7 mHz: the creep range (fitted from f_min = 1e-4 Hz)
    # the sum rule: G_b(z = 1) is Re Delta g(0) (E(omega -> 0))
    dc = belt_correction_table(tread, DEFAULT_BELT, SHAPE, C, [0.0])
    assert np.max(np.abs(kernel.frequency_response([0.0], FS)[0] - _table(dc.real)[0])) < 1e-4 * abs(dc[0, 0])


def test_causal_belt_fits_below_1e3(tread):
    # the same belt without its (non-causal, frequency-independent) loss: only the tread damps it, Delta g is causal
    # and the fit holds it to 4.0e-4 of |g_00| over 10 Hz - 5 kHz and 4e-5 below 10 Hz (measured); at fs / 2 a real
    # kernel cannot hold |Im Delta g| = 4.4e-4
    lossless = replace(DEFAULT_BELT, loss_factor=0.0)
    k = fit_belt_kernel(tread, lossless, (2, 2), C, FS, L, grid_ratio=1.08, pole_pairs=(32,))
    d = k.diagnostics
    assert d["max_error_band"] < 6e-4 and d["phase_error_band"] < 6e-4
    assert d["max_error_below_f_low"] < 1e-4 and d["max_error_f_low_to_10_hz"] < 1e-4
    assert d["max_error"] < 8e-4 and d["imag_at_zero"] == 0.0 and d["passivity_min"] > 0.0


def test_passivity(kernel, tread):
    f = np.linspace(1.0, FS / 2, 1500)
    omega = 2 * np.pi * f
    g00 = element_frf(np.zeros((1, 2)), C, omega, tread.modulus(omega), tread.poisson, tread.density,
                      tread.thickness)[:, 0]
    nx, ny = SHAPE
    total = g00 + kernel.frequency_response(f, FS)[:, nx - 1, ny - 1]
    assert np.all(-total.imag >= 0.0)
    assert kernel.diagnostics["passivity_min"] >= 0.0
    assert np.all(np.abs(kernel.poles) < 1.0)


def test_static_table(kernel, tread):
    offs = belt_offsets(SHAPE) * C
    ref = belt_element_frf_correction_ring(offs, C, 0.0, tread.quasi_static_modulus, tread.poisson, tread.density,
                                           tread.thickness, DEFAULT_BELT)[0]
    assert np.max(np.abs(kernel.static - _table(ref[None].real)[0])) < 1e-13 * abs(ref[0])
    # the hysteretic belt's imaginary part at omega = 0 (not causal) is reported, not silently kept
    assert kernel.diagnostics["static_imag"] == pytest.approx(np.max(np.abs(ref.imag)), rel=1e-10)


def test_stiff_belt_gives_the_rigid_kernel(tread):
    stiff = DEFAULT_BELT.scaled(1e12)
    omega = 2 * np.pi * np.array([0.0, 100.0, 5000.0])
    g00 = abs(element_frf(np.zeros((1, 2)), C, 0.0, tread.modulus(0.0), tread.poisson, tread.density,
                          tread.thickness)[0, 0])
    table = belt_correction_table(tread, stiff, SHAPE, C, omega / (2 * np.pi))
    assert np.max(np.abs(table)) < 1e-10 * g00
    k = fit_belt_kernel(tread, stiff, SHAPE, C, FS, L, grid_ratio=1.5, pole_pairs=(2,))
    assert np.max(np.abs(k.lags(L))) < 1e-10 * g00
    assert np.max(np.abs(k.memory(L).frequency_response([0.0, 100.0], FS))) < 1e-10 * g00
    assert np.max(np.abs(k.static)) < 1e-10 * g00


def test_bad_input(tread):
    with pytest.raises(ValueError, match="BeltProperties"):
        belt_correction_table(tread, {"bending_x": 3.7}, SHAPE, C, [10.0])
    with pytest.raises(ValueError, match="shape"):
        belt_correction_table(tread, DEFAULT_BELT, (3,), C, [10.0])
    with pytest.raises(ValueError, match="shape"):
        fit_belt_kernel(tread, DEFAULT_BELT, (0, 3), C, FS, L)
    with pytest.raises(ValueError, match="inside the belt"):
        belt_correction_table(tread, DEFAULT_BELT, (3, 200), C, [10.0])
    with pytest.raises(ValueError, match="material"):
        fit_belt_kernel("tread", DEFAULT_BELT, SHAPE, C, FS, L)
    with pytest.raises(ValueError, match="grid_ratio"):
        fit_belt_kernel(tread, DEFAULT_BELT, SHAPE, C, FS, L, grid_ratio=1.0)
    with pytest.raises(ValueError, match="frequencies"):
        belt_correction_table(tread, DEFAULT_BELT, SHAPE, C, [-1.0])
    bad = dict(poles=np.array([1.2 + 0j]), residues=np.zeros((1, 3, 3), complex), direct=np.zeros((3, 3)),
               static=np.zeros((3, 3)), sample_rate=FS, element_size=C)
    with pytest.raises(ValueError, match="unit circle"):
        BeltKernel(**bad)
    with pytest.raises(ValueError, match="conjugate"):
        BeltKernel(**{**bad, "poles": np.array([0.5 + 0.1j])})
    with pytest.raises(ValueError, match="BeltKernel"):
        BeltMemory("kernel", 256)


def test_round_trip(kernel, tmp_path):
    ds = xr.Dataset(kernel.variables())
    for name in ds.data_vars:
        assert "units" in ds[name].attrs and "long_name" in ds[name].attrs
    path = tmp_path / "belt.nc"
    ds.to_netcdf(path)
    with xr.open_dataset(path) as stored:
        back = BeltKernel.from_dataset(stored.load())
    for name in ("poles", "residues", "direct", "static"):
        assert np.array_equal(getattr(back, name), getattr(kernel, name))
    assert back.sample_rate == kernel.sample_rate and back.element_size == kernel.element_size
    assert back.diagnostics == kernel.diagnostics
    with pytest.raises(ValueError, match="belt_pole_real"):
        BeltKernel.from_dataset(xr.Dataset())
