"""tyreroad.greens: element Green's functions, time-domain kernels and the quasi-static kernel."""

import numpy as np
import pytest
import scipy.special as sp

from tyreroad import greens, io, layer
from tyreroad.material import FractionalKelvinVoigt, GeneralizedMaxwell, Material
from tyreroad.reference import love

C = 1.0e-3  # element size [m]
E = 10.0e6  # static modulus [Pa]
NU = 0.49


def _tread(loss_scale=1.0, thickness=0.01, model=None):
    model = model or FractionalKelvinVoigt(E0=22e6, E1=44e6, alpha=0.24, f1=1000.0)
    return Material(name="tread", poisson=NU, density=1100.0, thickness=thickness, model=model, loss_scale=loss_scale)


def _matrix(table, nx, ny):
    """Dense influence matrix A[e, m] = g[e - m] of an nx x ny patch from a table over -(n-1)..(n-1)."""
    i, j = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    i, j = i.ravel(), j.ravel()
    return table[i[:, None] - i[None, :] + nx - 1, j[:, None] - j[None, :] + ny - 1]


# ---------------------------------------------------------------------------------------------- settings


def test_settings_from_config_and_validation():
    s = greens.GreensSettings.from_config({"sample_rate": 51200.0, "n_lags": 256, "n_fft": 4096})
    assert (s.sample_rate, s.n_lags, s.n_fft) == (51200.0, 256, 4096)
    f = s.frequencies
    assert f.size == 2049 and f[1] == pytest.approx(12.5) and f[-1] == pytest.approx(25600.0)
    with pytest.raises(ValueError, match="n_fft"):
        greens.GreensSettings(51200.0, 256, 2048)
    with pytest.raises(ValueError, match="power of two"):
        greens.GreensSettings(51200.0, 256, 6000)
    with pytest.raises(ValueError, match="n_lags"):
        greens.GreensSettings(51200.0, 4000, 4096)
    with pytest.raises(ValueError, match="sample_rate"):
        greens.GreensSettings(-1.0, 256, 4096)
    with pytest.raises(ValueError, match="unknown key"):
        greens.GreensSettings.from_config({"sample_rate": 1.0, "n_lags": 2, "n_fft": 4096, "lags": 3})
    # missing keys take the paper's sampling, as in the schema
    assert greens.GreensSettings.from_config({"n_lags": 64}) == greens.GreensSettings(51200.0, 64, 4096)


# ---------------------------------------------------------------------------------------------- building blocks


def test_square_load_harmonics_reconstruct_the_spectrum():
    kc = np.array([0.0, 0.5, 5.0, 37.0])
    coeffs, count = greens.square_load_harmonics(kc)
    theta = np.linspace(0.0, 2 * np.pi, 61)
    rebuilt = coeffs @ np.cos(4 * np.outer(np.arange(coeffs.shape[1]), theta))
    exact = np.sinc(np.outer(kc, np.cos(theta)) / (2 * np.pi)) * np.sinc(np.outer(kc, np.sin(theta)) / (2 * np.pi))
    np.testing.assert_allclose(rebuilt, exact, atol=1e-12)
    assert coeffs[0, 0] == 1.0 and count[0] == 1
    assert count[-1] > count[2] > 1  # more harmonics at larger k c


def test_bessel_weight_kernel_matches_numpy_reference():
    quad = greens.wavenumber_quadrature(C, 0.01, k_wave=2000.0, relative_width=0.05, r_max=0.02)
    offsets = np.array([[0, 0], [1, 0], [1, 1], [3, 2], [14, 14], [19, 5], [0.3, 0.1]]) * C
    w = greens.bessel_weights(quad, offsets, C)
    coeffs, _ = greens.square_load_harmonics(quad.nodes * C)
    r = np.hypot(offsets[:, 0], offsets[:, 1])
    phi = np.arctan2(offsets[:, 1], offsets[:, 0])
    ref = np.zeros_like(w)
    for n in range(coeffs.shape[1]):
        ref += coeffs[:, n : n + 1] * sp.jv(4 * n, np.outer(quad.nodes, r)) * np.cos(4 * n * phi)
    ref *= (quad.weights * quad.nodes / (2 * np.pi))[:, None]
    assert np.abs(w - ref).max() <= 1e-11 * np.abs(ref).max()


def test_tail_coefficient_is_the_halfspace_asymptote():
    omega = 2 * np.pi * 20e3
    for nu in (0.3, 0.49):
        e = 30e6 * (1 + 0.2j)
        eps_s = 1100.0 * omega**2 * 2 * (1 + nu) / e
        k = 300 * np.sqrt(abs(eps_s))
        rem = layer.halfspace_compliance(k, omega, e, nu, 1100.0) - 2 * (1 - nu**2) / (e * k)
        assert rem / (eps_s / (e * k**3)) == pytest.approx(greens._tail_coefficient(nu), rel=1e-3)


def test_offset_table_index_symmetries():
    dx, dy, index = greens.offset_table_index((3, 4))
    assert list(dx) == [-2, -1, 0, 1, 2] and list(dy) == [-3, -2, -1, 0, 1, 2, 3]
    np.testing.assert_array_equal(index, index[::-1, :])
    np.testing.assert_array_equal(index, index[:, ::-1])
    sq = greens.offset_table_index((4, 4))[2]
    np.testing.assert_array_equal(sq, sq.T)
    uniq = greens.unique_offsets((3, 4))
    assert np.all(uniq[:, 0] >= uniq[:, 1]) and len(uniq) == len(np.unique(index))


def test_frf_is_symmetric_in_the_offset():
    m = _tread()
    omega = 2 * np.pi * np.array([0.0, 5000.0, 20000.0])
    offsets = np.array([[2, 1], [1, 2], [-2, 1], [-1, -2], [2, -1]]) * C
    g = greens.element_frf(offsets, C, omega, m.modulus(omega), NU, m.density, m.thickness)
    np.testing.assert_allclose(g, g[:, :1] * np.ones((1, 5)), rtol=1e-12)


# ---------------------------------------------------------------------------------------------- static kernel


def test_halfspace_limit_equals_love():
    offsets = np.array([[0, 0], [1, 0], [1, 1], [3, 2]]) * C
    for nu in (0.3, NU):
        lv = (1 - nu**2) / E * love.rectangle_potential(offsets[:, 0], offsets[:, 1], C, C) / (np.pi * C * C)
        assert lv[0] == pytest.approx(1.12220 * (1 - nu**2) / (E * C), rel=1e-5)
        g = greens.static_element_kernel(offsets, C, E, nu, thickness=10.0)
        np.testing.assert_allclose(g / lv, 1.0, atol=2e-3)
        # same through the dynamic pipeline (layer.compliance, tail term) at omega -> 0
        gd = greens.element_frf(offsets, C, [0.0, 1e-3], [E, E], nu, 1100.0, thickness=10.0)
        np.testing.assert_allclose(gd.real / lv, 1.0, atol=2e-3)
        assert np.abs(gd.imag).max() < 1e-9 * lv[0]


def test_static_kernel_changes_sign_between_5_and_10_mm():
    offsets = np.stack([np.arange(16), np.zeros(16)], axis=1) * C
    g = greens.static_element_kernel(offsets, C, E, NU, thickness=0.01)
    assert np.all(g[:6] > 0)  # up to 5 mm the surface is pushed in
    assert np.all(g[10:] < 0)  # by 10 mm it bulges out (near-incompressible layer)
    assert np.count_nonzero(np.diff(np.sign(g))) == 1


def test_rigid_square_punch_stiffness():
    n = 20
    uniq = greens.unique_offsets((n, n))
    g = greens.static_element_kernel(uniq * C, C, E, NU, thickness=0.01)
    table = g[greens.offset_table_index((n, n))[2]]
    forces = np.linalg.solve(_matrix(table, n, n), np.ones(n * n))  # unit indentation
    assert forces.sum() / E == pytest.approx(0.117, rel=0.02)


def test_static_kernel_converges_under_refinement():
    offsets = np.array([[0, 0], [1, 0], [4, 3], [12, 7], [19, 19]]) * C
    g1 = greens.static_element_kernel(offsets, C, E, NU, 0.01)
    g2 = greens.static_element_kernel(offsets, C, E, NU, 0.01, refine=2.0)
    assert np.abs(g1 - g2).max() < 1e-9 * g2[0]


def test_static_kernel_agrees_with_padded_fft():
    """2-D FFT of H0(k) sinc sinc on a zero-padded periodic grid (no Love split), Richardson-extrapolated
    in the grid step (the FFT's truncation error of the square load's spectrum falls as step^2)."""
    h = 3e-3  # the layer kernel decays within a few h, so a 48 mm period keeps images away
    period = 0.048
    offsets = np.array([[0, 0], [1, 0], [2, 1], [5, 0]])
    values = {}
    for m in (8, 16):
        step = C / m
        n = int(round(period / step))
        kx = 2 * np.pi * np.fft.fftfreq(n, step)
        h0 = layer.static_compliance(np.hypot(kx[:, None], kx[None, :]), E, NU, h)
        p = np.sinc(kx * C / (2 * np.pi))
        field = np.fft.ifft2(h0 * p[:, None] * p[None, :]).real / step**2
        values[m] = field[offsets[:, 0] * m, offsets[:, 1] * m]
    fft = (4 * values[16] - values[8]) / 3
    g = greens.static_element_kernel(offsets * C, C, E, NU, h)
    np.testing.assert_allclose(fft, g, rtol=1e-3)
    assert np.abs(fft - g).max() < 2e-4 * g[0]


# ---------------------------------------------------------------------------------------------- dynamic kernel


def test_dynamic_frf_converges_under_refinement_lightly_damped():
    m = _tread(loss_scale=0.5)
    omega = 2 * np.pi * np.array([1000.0, 4000.0, 9000.0, 17000.0, 25600.0])
    offsets = np.array([[0, 0], [1, 0], [5, 2], [19, 19]]) * C
    args = (C, omega, m.modulus(omega), NU, m.density, m.thickness)
    g1 = greens.element_frf(offsets, *args)
    g2 = greens.element_frf(offsets, *args, refine=2.0)
    assert np.abs(g1 - g2).max() < 1e-7 * np.abs(g2[:, 0]).min()
    assert np.all(g1[:, 0].imag < 0)  # passive


def test_zero_frequency_frf_equals_static_kernel():
    offsets = np.array([[0, 0], [1, 0], [3, 3], [9, 2]]) * C
    static = greens.static_element_kernel(offsets, C, E, NU, 0.01)
    omega = np.array([0.0, 2 * np.pi * 1e-3])
    g = greens.element_frf(offsets, C, omega, [E, E], NU, 1100.0, 0.01)
    np.testing.assert_allclose(g.real, np.tile(static, (2, 1)), rtol=1e-6, atol=1e-7 * static[0])
    assert np.abs(g[0].imag).max() == 0.0


@pytest.fixture(scope="module")
def small_dataset():
    return greens.greens_dataset(_tread(), (3, 4), C, sample_rate=51200.0, n_lags=256, n_fft=4096)


def test_dataset_sum_rule_symmetry_and_metadata(small_dataset, tmp_path):
    m = _tread()
    ds = small_dataset
    assert ds.g.dims == ("dx", "dy", "lag") and ds.g.shape == (5, 7, 256)
    assert ds.frequency.size == 2049
    g = ds.g.values
    np.testing.assert_array_equal(g, g[::-1, :, :])
    np.testing.assert_array_equal(g, g[:, ::-1, :])
    np.testing.assert_array_equal(g[:, 1:6], np.swapaxes(g[:, 1:6], 0, 1))  # x <-> y within |d| <= 2
    gs = ds.g_static.values
    np.testing.assert_array_equal(gs, gs[::-1, ::-1])
    # sum rule: the full inverse transform of the stored FRF sums to g(omega=0), which with the
    # zero-frequency quasi-static modulus is the independently computed static kernel
    frf = ds.frf_real.values + 1j * ds.frf_imag.values
    full = np.fft.irfft(frf, n=4096)
    g0 = float(ds.g_static.sel(dx=0, dy=0))
    assert full.sum() == pytest.approx(g0, rel=1e-6)
    # the kept lags are the transform less the creep it folded back from beyond n_fft, with the
    # discarded precursor replaced by a causal correction of the same sum on the first lags
    # (greens.precursor_correction); lags taps ... L-1 differ only by the folded creep
    taps = ds.attrs["precursor_taps"]
    assert taps == greens.PRECURSOR_TAPS and ds.attrs["precursor_folded"] == 1
    kept = ds.g.sel(dx=0, dy=0).values
    fold = full[:256] - kept
    wrapped = float(ds.wrapped_creep_fraction) * full.sum()
    assert fold.sum() + float(ds.precursor_sum_fraction) * full.sum() == pytest.approx(wrapped, rel=1e-9)
    assert np.all(fold[taps:] > 0)
    assert np.all(np.diff(fold[taps:]) < 0)  # the folded creep decays smoothly over the kept lags
    assert -0.03 < float(ds.precursor_sum_fraction) < 0  # the Nyquist ringing before t = 0 sums negative
    assert float(ds.kept_fraction) == pytest.approx(kept.sum() / g0, rel=1e-6)
    assert 0.3 < float(ds.kept_fraction) < 1.0
    # sum rule with the tail, at every offset
    total = ds.g.sum("lag") + ds.tail_compliance
    np.testing.assert_allclose(total.values, ds.g_static.values, rtol=1e-6)
    assert 0.0 <= float(ds.precursor_energy_fraction) < 0.1
    assert np.all(ds.frf_imag.values[1:] < 0)  # passive
    np.testing.assert_allclose(ds.storage_modulus.values, m.modulus(2 * np.pi * ds.frequency.values).real)
    assert ds.attrs["n_fft"] == 4096 and ds.attrs["element_size"] == C
    path = io.write_dataset(ds, tmp_path / "greens" / "tread.nc", {"greens": {"n_fft": 4096}})
    back = io.read_dataset(path)
    np.testing.assert_array_equal(back.g.values, g)


def _constrained_least_squares_reference(n_precursor, taps, band, n_points=20001):
    """The precursor fit by brute force: a trapezoid-weighted least-squares fit on a fine frequency
    grid, the two constraints eliminated through a null-space basis (numpy only)."""
    omega = np.linspace(0.0, 2 * np.pi * band, n_points)
    weight = np.full(n_points, omega[1])
    weight[[0, -1]] /= 2
    a = np.exp(-1j * np.outer(omega, np.arange(taps))) * np.sqrt(weight)[:, None]
    b = np.exp(1j * np.outer(omega, np.arange(1, n_precursor + 1))) * np.sqrt(weight)[:, None]
    a, b = np.vstack([a.real, a.imag]), np.vstack([b.real, b.imag])
    constraints = np.vstack([np.ones(taps), (-1.0) ** np.arange(taps)])
    particular = np.linalg.lstsq(constraints, np.ones((2, n_precursor)), rcond=None)[0]
    null = np.linalg.svd(constraints)[2][2:].T
    free = np.linalg.lstsq(a @ null, b - a @ particular, rcond=None)[0]
    return particular + null @ free


def test_precursor_correction_constraints_and_brute_force_fit():
    m = greens.precursor_correction(64, taps=5, band=0.15)
    assert m.shape == (5, 64)
    # DC gain and the Nyquist response of the lag-0 sum are kept for every precursor
    np.testing.assert_allclose(m.sum(axis=0), 1.0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(((-1.0) ** np.arange(5)) @ m, 1.0, rtol=0, atol=1e-12)
    reference = _constrained_least_squares_reference(64, 5, 0.15)
    np.testing.assert_allclose(m, reference, rtol=0, atol=1e-6 * np.abs(reference).max())
    # fewer than three taps leave no freedom beyond the DC gain: the plain sum on lag 0
    np.testing.assert_array_equal(greens.precursor_correction(8, taps=2), np.vstack([np.ones(8), np.zeros(8)]))
    with pytest.raises(ValueError, match="band"):
        greens.precursor_correction(8, band=0.5)


def test_precursor_correction_of_a_creeping_tread_sample_by_sample(small_dataset):
    """The corrected first lags of the default (creeping) tread against the correction rebuilt sample
    by sample: p_k = g[n_fft - k] less the causal creep at that sample (its own increment and what
    wrapped onto it), k = 1 ... n_fft/2, so the precursor and the creep are aligned in time."""
    from tyreroad.memory import fit_retardation_spectrum, wrapped_creep

    ds = small_dataset
    fs, n_fft = ds.attrs["sample_rate"], ds.attrs["n_fft"]
    taps = ds.attrs["precursor_taps"]
    full = np.fft.irfft(ds.frf_real.values + 1j * ds.frf_imag.values, n=n_fft)
    g_zero = full.sum()
    creep = fit_retardation_spectrum(_tread(), fs / 2)
    precursor = np.empty(n_fft // 2)
    for k in range(1, n_fft // 2 + 1):
        n = n_fft - k
        increment = (creep.creep((n + 0.5) / fs) - creep.creep((n - 0.5) / fs)) / creep.relaxed_compliance
        wrapped = wrapped_creep(creep, n_fft, 1, fs, first=n)[0]
        precursor[k - 1] = full[n] - g_zero * (increment + wrapped)
    correction = greens.precursor_correction(n_fft // 2, taps) @ precursor
    wrapped_kept = wrapped_creep(creep, n_fft, taps, fs) * g_zero
    kept = ds.g.sel(dx=0, dy=0).values[:taps]
    np.testing.assert_allclose(kept, full[:taps] - wrapped_kept + correction, rtol=0, atol=1e-9 * g_zero)
    assert correction.sum() == pytest.approx(float(ds.precursor_sum_fraction) * g_zero, rel=1e-9)


def test_causal_kernel_matches_the_frf_in_the_analysis_band():
    """DTFT of the kept lags against the element FRF up to fs/10 (5 kHz): within 0.5 % at the
    excitation element and 1 % at the neighbours (measured 0.43 % and 0.61-0.73 %); the lag-0 sum
    of the precursor alone was 3 % and 5 % off, mostly in phase (the precursor's missing time
    advance). A generalised-Maxwell tread (relaxation times <= 0.1 ms) is used because its kernel has
    decayed within the kept 5 ms, so the kept lags alone must reproduce the FRF."""
    m = Material(name="maxwell", model=GeneralizedMaxwell(E_inf=2.5e7, moduli=(2.0e7, 4.0e7),
                                                          relaxation_times=(1.0e-4, 3.0e-5)),
                 poisson=NU, density=1100.0, thickness=0.01)
    fs, n_fft, n_lags = 51200.0, 4096, 256
    ds = greens.greens_dataset(m, (4, 4), C, fs, n_lags, n_fft)
    assert ds.attrs["precursor_folded"] == 1
    assert abs(float(ds.tail_compliance.sel(dx=0, dy=0))) < 1e-3 * float(ds.g_static.sel(dx=0, dy=0))
    omega = 2 * np.pi * np.linspace(0.0, 5000.0, 101)
    offsets = np.array([[0, 0], [1, 0], [1, 1], [3, 2]])
    frf = greens.element_frf(offsets * C, C, omega, m.modulus(omega), NU, m.density, m.thickness)
    phase = np.exp(-1j * np.outer(omega / fs, np.arange(n_lags)))
    for j, (ox, oy) in enumerate(offsets):
        error = np.abs(phase @ ds.g.sel(dx=ox, dy=oy).values / frf[:, j] - 1).max()
        assert error < (0.005 if j == 0 else 0.01), ((ox, oy), error)


def test_rayleigh_arrival_in_thick_lightly_damped_layer():
    # h = 0.2 m: base reflections (P round trip 2h/c_p ~ 1.3 ms) arrive after the surface wave at 30 mm
    model = FractionalKelvinVoigt(E0=5e6, E1=5e6, alpha=0.13, f1=5000.0)  # eta ~ 0.1 near 5 kHz
    m = _tread(thickness=0.2, model=model)
    fs, n_fft = 25600.0, 2048
    omega = 2 * np.pi * np.arange(n_fft // 2 + 1) * fs / n_fft
    offsets = np.array([[20, 0], [30, 0]]) * C
    frf = greens.element_frf(offsets, C, omega, m.modulus(omega), NU, m.density, m.thickness)
    g = greens.time_kernel(frf, n_fft, n_fft // 2).kernel
    mu = m.modulus(2 * np.pi * 5000.0) / (2 * (1 + NU))
    c_rayleigh = 0.9541 / np.real(np.sqrt(m.density / mu))  # SPEC: c_R / c_s = 0.9541 at nu = 0.49
    for j, r in enumerate(offsets[:, 0]):
        t_peak = np.argmax(np.abs(g[:, j])) / fs
        assert t_peak == pytest.approx(r / c_rayleigh, rel=0.15)


def test_bad_input_raises():
    with pytest.raises(ValueError, match="n_elements"):
        greens.unique_offsets((0, 3))
    with pytest.raises(ValueError, match="modulus"):
        greens.element_frf([[0, 0]], C, [1.0], [-1e6], NU, 1100.0, 0.01)
    with pytest.raises(ValueError, match="thickness"):
        greens.static_element_kernel([[0, 0]], C, E, NU, 0.0)
    with pytest.raises(ValueError, match="frequencies"):
        greens.time_kernel(np.ones(10), 4096, 256)


def test_figures_2_and_3_are_written(small_dataset, tmp_path):
    from tyreroad.plots.greens import plot_frf, plot_materials

    other = small_dataset.copy()
    other.attrs["material"] = "tread-eta0.5"
    for plot, name in ((plot_materials, "fig2.png"), (plot_frf, "fig3.png")):
        path = plot([small_dataset, other], tmp_path / name)
        data = path.read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 20_000
    with pytest.raises(ValueError, match="frf_real"):
        plot_frf([small_dataset.drop_vars("frf_real")], tmp_path / "bad.png")
    with pytest.raises(ValueError, match="no datasets"):
        plot_materials([], tmp_path / "bad.png")


# ---------------------------------------------------------------------------------------------- Laplace domain
# g(x, y, s) at complex s, Re s >= 0 (convolution quadrature, issue 23)

_GM = GeneralizedMaxwell(20e6, (8e6, 15e6, 12e6, 25e6, 30e6), (3e-2, 2e-3, 3.3e-4, 4e-5, 6e-6))
LAPLACE_MODELS = {"fractional": FractionalKelvinVoigt(E0=22e6, E1=44e6, alpha=0.24, f1=1000.0), "maxwell": _GM}
LAPLACE_OFFSETS = np.array([[0, 0], [1, 0], [5, 2], [19, 19]]) * C


@pytest.mark.parametrize("name", LAPLACE_MODELS)
def test_element_laplace_on_the_frequency_axis_is_the_frf(name):
    m = _tread(model=LAPLACE_MODELS[name])
    omega = 2 * np.pi * np.array([0.0, 10.0, 1000.0, 5000.0, 17000.0, 25600.0])
    args = (m.poisson, m.density, m.thickness)
    frf = greens.element_frf(LAPLACE_OFFSETS, C, omega, m.modulus(omega), *args)
    # same E: the same k rule and the same arithmetic (measured bit-identical)
    same = greens.element_laplace(LAPLACE_OFFSETS, C, 1j * omega, m.modulus(omega), *args)
    assert np.max(np.abs(same - frf) / np.abs(frf)) < 1e-14
    cont = greens.element_laplace(LAPLACE_OFFSETS, C, 1j * omega, m.laplace_modulus(1j * omega), *args)
    assert np.max(np.abs(cont - frf) / np.abs(frf)) < 1e-12


@pytest.mark.parametrize("name", LAPLACE_MODELS)
def test_element_laplace_is_analytic(name):
    """Cauchy-Riemann by central differences at the excitation element and its neighbour.

    The five s of each check go in one call, so they share one k rule (the function is analytic for a
    fixed rule); measured worst mismatch 2.3e-8."""
    m = _tread(model=LAPLACE_MODELS[name])
    worst = 0.0
    for mag in (1e2, 1e3, 1e4, 1e5):
        for arg in (0.0, 30.0, 60.0, 85.0):
            s0 = mag * np.exp(1j * np.deg2rad(arg))
            d = 1e-4 * mag
            s = np.array([s0 + d, s0 - d, s0 + 1j * d, s0 - 1j * d, s0])
            g = greens.element_laplace(
                LAPLACE_OFFSETS[:2], C, s, m.laplace_modulus(s), m.poisson, m.density, m.thickness
            )
            along_re = (g[0] - g[1]) / (2 * d)
            along_im = (g[2] - g[3]) / (2j * d)
            scale = np.maximum(np.abs(along_re), np.abs(g[4]) / mag)
            worst = max(worst, float(np.max(np.abs(along_re - along_im) / scale)))
    assert worst < 1e-6


@pytest.mark.parametrize("name", LAPLACE_MODELS)
def test_element_laplace_passive_reflection_and_refinement(name):
    m = _tread(model=LAPLACE_MODELS[name])
    args = (m.poisson, m.density, m.thickness)
    s = np.outer([1e2, 1e3, 1e4, 1e5], np.exp(1j * np.deg2rad([0.0, 30.0, 60.0, 85.0]))).ravel()
    g = greens.element_laplace(LAPLACE_OFFSETS, C, s, m.laplace_modulus(s), *args)
    gc = greens.element_laplace(LAPLACE_OFFSETS, C, np.conj(s), m.laplace_modulus(np.conj(s)), *args)
    np.testing.assert_allclose(gc, np.conj(g), rtol=1e-13, atol=1e-13 * np.abs(g[:, 0]).min())
    # passive: the mobility s g is positive real; on this grid g itself has Re g > 0 too (measured
    # Re g / |g| >= 0.89), which passivity alone does not imply (on the axis the layer is mass-like near fs/2)
    assert np.all((s * g[:, 0]).real > 0)
    assert np.all(g[:, 0].real > 0)
    assert np.all(g[s.imag == 0].imag == 0)
    # the k rule chosen off the axis (|s| scales, damping floor) is converged: measured 1.1e-8
    s = np.array([1e3 * np.exp(0.7j), 1e4 * np.exp(1.2j), 1e5 * np.exp(1.45j), 1e5, 3e5 * np.exp(0.3j)])
    g1 = greens.element_laplace(LAPLACE_OFFSETS, C, s, m.laplace_modulus(s), *args)
    g2 = greens.element_laplace(LAPLACE_OFFSETS, C, s, m.laplace_modulus(s), *args, refine=2.0)
    assert np.abs(g1 - g2).max() < 1e-7 * np.abs(g2[:, 0]).min()


@pytest.mark.parametrize("name", LAPLACE_MODELS)
def test_element_laplace_static_limit(name):
    m = _tread(model=LAPLACE_MODELS[name])
    e0 = float(m.laplace_modulus(0.0).real)
    static = greens.static_element_kernel(LAPLACE_OFFSETS, C, e0, m.poisson, m.thickness)
    s = np.array([0.0, 1e-2, 1.0])
    e = m.laplace_modulus(s)
    g = greens.element_laplace(LAPLACE_OFFSETS, C, s, e, m.poisson, m.density, m.thickness)
    # s = 0: the static kernel with E(0) (measured 2e-16 of the self-compliance)
    assert np.abs(g[0] - static).max() < 1e-6 * static[0]
    # s -> 0: inertia vanishes like s^2 and the correspondence principle remains, g = g_static E(0) / E(s)
    # (measured 1.6e-10 at s = 1 rad/s; the fractional tread's E(s) itself approaches E0 only like s^0.24)
    np.testing.assert_allclose(g, static[None, :] * e0 / e[:, None], rtol=0, atol=1e-6 * static[0])


def test_element_laplace_rejects_bad_input():
    m = _tread()
    args = (m.poisson, m.density, m.thickness)
    with pytest.raises(ValueError, match="Re s >= 0"):
        greens.element_laplace(LAPLACE_OFFSETS, C, -1.0, 3e7, *args)
    with pytest.raises(ValueError, match="not passive"):
        greens.element_laplace(LAPLACE_OFFSETS, C, 1e3j, 3e7 * (1 - 1j), *args)
    with pytest.raises(ValueError, match="loss_scale"):
        _tread(loss_scale=0.5).laplace_modulus(1e3j)
