"""Viscoelastic (QLV) contact springs (issue 24): relaxation fit, the march's recursion, K*(f) and the
one-element oracle (spring + layer, both viscoelastic, closed form in frequency)."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from tyreroad.contact import SolverSettings, run_loading_path
from tyreroad.greens import ElementFRF, element_frf, greens_dataset
from tyreroad.kernel import LayerKernel
from tyreroad.loading import IndentationPath, LoadingPreset
from tyreroad.material import material_from_config
from tyreroad.qlv import (
    MarchSprings,
    RelaxationFunction,
    ViscoelasticSprings,
    check_relaxed_modulus,
    fit_relaxation,
    relaxation_variables,
    springs_for_run,
)
from tyreroad.springs import SpringModel, SpringTable
from tyreroad.stiffness import SpectrumSettings, harmonic_stiffness, stiffness_spectrum

C = 1e-3
FS = 51200.0
TREAD = {"model": "fractional_kelvin_voigt", "E0": 2.5e7, "E1": 5.0e7, "alpha": 0.24, "f1": 1000.0,
         "poisson_ratio": 0.49, "density": 1100.0, "thickness": 0.01}
MAXWELL = {"model": "generalized_maxwell", "E_inf": 2.5e7, "moduli": [2.0e7, 4.0e7],
           "relaxation_times": [1.0e-4, 3.0e-5], "poisson_ratio": 0.49, "density": 1100.0, "thickness": 0.01}
K_C = 2.0e5  # N/m, the oracle's linear spring


def material(spec, name="m"):
    return material_from_config(name, {name: dict(spec)})


def linear_table(k=K_C, n=501, step=1e-6) -> SpringTable:
    zeta = np.arange(n) * step
    return SpringTable.checked(np.full((1, n), k), k * zeta[None, :], step, 1)


def qlv(mat, table) -> ViscoelasticSprings:
    return ViscoelasticSprings(table, fit_relaxation(mat.modulus, mat.quasi_static_modulus, name=mat.name),
                               mat.quasi_static_modulus)


def test_relaxation_fit_of_the_tread_and_a_maxwell_material():
    for spec, tol in ((TREAD, 1e-4), (MAXWELL, 1e-3)):
        mat = material(spec)
        r = fit_relaxation(mat.modulus, mat.quasi_static_modulus)
        assert r.relaxed == 1.0 and np.all(r.weights >= 0) and r.fit_error < tol
        w = 2 * np.pi * np.array([1.0, 100.0, 1e3, 1e4, 2.56e4])
        assert np.max(np.abs(r.complex_ratio(w) / (mat.modulus(w) / mat.quasi_static_modulus) - 1)) < tol
        # R(t) decreases from R(0) = 1 + sum r_k to R_inf = 1
        t = np.logspace(-8, 3, 50)
        assert np.all(np.diff(r.relaxation(t)) <= 0) and r.relaxation(1e9) == pytest.approx(1.0)


def test_march_recursion_is_exact_for_a_ramp():
    """A linear spring compressed at constant rate v: F(t) = k v int_0^t R(s) ds, to round-off."""
    rel = RelaxationFunction(1.0, np.array([0.7, 2.0]), np.array([3e-5, 2e-4]))
    springs = MarchSprings(linear_table(), rel, 1.0 / FS)
    springs.start()
    v, n = 0.05, 200
    t = np.arange(1, n + 1) / FS
    forces = []
    for tn in t:
        zeta = np.array([v * tn])
        f, _ = springs.evaluate(zeta)
        forces.append(f[0])
        springs.commit(zeta)
    exact = K_C * v * (t + np.sum(rel.weights * rel.times * -np.expm1(-t[:, None] / rel.times), axis=1))
    assert np.max(np.abs(np.array(forces) / exact - 1)) < 1e-12
    # the tangent inside a step is a k, a = R_inf + sum r_k beta_k
    _, k = springs.evaluate(np.array([v * t[-1]]))
    assert k[0] == pytest.approx(springs.a * K_C, rel=1e-14)


def test_unloading_is_clipped_and_separation_carries_no_force():
    """Fast unloading: the relaxed history would make F < 0 (adhesive); it is clipped to 0, and zeta <= 0
    gives exactly 0."""
    rel = RelaxationFunction(1.0, np.array([2.0]), np.array([1e-4]))
    springs = MarchSprings(linear_table(), rel, 1.0 / FS)
    springs.start()
    for zeta in np.linspace(0, 1e-5, 20)[1:]:
        springs.commit(np.array([zeta]))
    for _ in range(40):  # hold: the force relaxes
        springs.commit(np.array([1e-5]))
    f, k = springs.evaluate(np.array([0.5e-5]))  # half the compression at once
    assert springs.a * K_C * 0.5e-5 + springs.offset[0] < 0 and f[0] == 0 and k[0] == 0
    f, k = springs.evaluate(np.array([-1e-7]))
    assert f[0] == 0 and k[0] == 0
    springs.start()
    assert springs.offset[0] == 0 and springs.f_el[0] == 0


def test_config_key_and_relaxed_modulus_check():
    assert SpringModel.from_config({}).rheology == "elastic"
    assert SpringModel.from_config({"rheology": "qlv"}).rheology == "qlv"
    with pytest.raises(ValueError, match=r"springs\.rheology = 'visco'.*elastic, qlv"):
        SpringModel.from_config({"rheology": "visco"})
    with pytest.raises(ValueError, match="not the relaxed modulus E\\(0\\)"):
        check_relaxed_modulus(2.5e7, 3.0e7, "tread")
    check_relaxed_modulus(2.5e7, 2.5e7)


def test_springs_file_round_trip_and_static_kernel_is_the_elastic_table():
    mat = material(MAXWELL)
    table = linear_table()
    ds = xr.Dataset(attrs={"spring_modulus": mat.quasi_static_modulus})
    assert springs_for_run(ds, table) is table  # elastic files: the table itself
    data, attrs = relaxation_variables(fit_relaxation(mat.modulus, mat.quasi_static_modulus))
    ds = ds.assign(data)
    ds.attrs.update(attrs)
    springs = springs_for_run(ds, table)
    assert isinstance(springs, ViscoelasticSprings)
    assert springs.for_kernel(LayerKernel.quasistatic(np.full((1, 1), 1e-6))) is table
    march = springs.for_kernel(LayerKernel.dynamic(np.full((1, 1, 4), 1e-6), FS))
    assert isinstance(march, MarchSprings) and march.dt == 1.0 / FS


def _oracle(mat, f):
    """K* = 1 / (g_self(f) + 1 / (k_c E(f) / E_qs)): spring and layer both viscoelastic, one element."""
    w = 2 * np.pi * np.asarray(f)
    g_self = element_frf(np.zeros((1, 2)), C, w, mat.modulus(w), mat.poisson, mat.density, mat.thickness)[:, 0]
    return 1.0 / (g_self + 1.0 / (K_C * mat.modulus(w) / mat.quasi_static_modulus))


@pytest.mark.parametrize("spec", [TREAD, MAXWELL], ids=["tread", "maxwell"])
@pytest.mark.parametrize("method", ["dense", "fft"])
def test_one_element_oracle_against_k_star(spec, method):
    """Issue 24: the closed form of a viscoelastic spring on the viscoelastic layer against K*(f), < 1e-6."""
    mat = material(spec)
    spec_ = SpectrumSettings(preloads=(1e-5, 1e-4), n_frequencies=30, figure_preload=1e-4)
    greens = greens_dataset(mat, (1, 1), C, FS, 64, 4096)
    g_static = greens["g_static"].transpose("dx", "dy").values
    springs = qlv(mat, linear_table())
    ds = stiffness_spectrum(np.zeros((1, 1)), springs, LayerKernel.quasistatic(g_static), ElementFRF(mat, C), mat, FS,
                            spec_, SolverSettings(quasistatic_step=1e-5), method=method)
    f = ds["frequency"].values
    expected = _oracle(mat, f)
    k_star = ds["storage_stiffness"].values + 1j * ds["loss_stiffness"].values
    assert np.max(np.abs(k_star / expected[None, :] - 1)) < 1e-6
    assert ds.attrs["spring_rheology"] == "qlv"
    # the relaxed limit is the elastic one (R_inf = 1)
    k_qs = 1 / (1 / K_C + g_static[0, 0])
    assert np.allclose(ds["relaxed_stiffness"].values, k_qs, rtol=1e-10)
    # elastic springs: K* differs by the spring's E(f)/E_qs, stiffer and lossier with QLV
    elastic = stiffness_spectrum(np.zeros((1, 1)), linear_table(), LayerKernel.quasistatic(g_static),
                                 ElementFRF(mat, C), mat, FS, spec_, SolverSettings(quasistatic_step=1e-5),
                                 method=method)
    i = int(np.argmin(np.abs(f - 1000.0)))
    assert ds["storage_stiffness"][0, i] > elastic["storage_stiffness"][0, i]
    assert ds["loss_factor"][0, i] > elastic["loss_factor"][0, i]


@pytest.mark.parametrize("frequency, periods", [(200.0, 6), (1000.0, 10), (5000.0, 20)])
def test_one_element_harmonic_run_against_k_star(frequency, periods):
    """Issue 24: a time-domain harmonic run of the QLV spring on the layer (Maxwell tread, relaxed by a 5 ms
    hold) gives F_hat / delta_hat within 1 % (and 0.01 rad) of the closed form / K*."""
    mat = material(MAXWELL, "maxwell")
    greens = greens_dataset(mat, (1, 1), C, FS, 256, 4096)
    springs = qlv(mat, linear_table(n=1001))
    settings = SolverSettings(quasistatic_step=1e-5, method="dense")
    hold, speed, d0 = 5e-3, 0.1, 1e-4
    preset = LoadingPreset("h", {"kind": "harmonic", "preload": d0, "preload_speed": speed, "relax_time": hold,
                                 "amplitude": 1e-6, "frequency": frequency, "periods": periods})
    t, d, _ = preset.path("dynamic", FS, settings.quasistatic_step)
    res = run_loading_path(IndentationPath(np.zeros((1, 1)), d, t), springs, LayerKernel.from_greens(greens, "dynamic"),
                           settings)
    start = d0 / speed + hold
    measured = harmonic_stiffness(res, frequency, start + 2 / frequency)
    expected = complex(_oracle(mat, [frequency])[0])
    assert abs(abs(measured) / abs(expected) - 1) < 0.01
    assert abs(np.angle(measured / expected)) < 0.01
    # relaxed before the oscillation: the elastic preload force
    g_static = greens["g_static"].values.ravel()[0]
    before = np.flatnonzero(t < start)[-1]
    assert res.force[before] == pytest.approx(d0 / (1 / K_C + g_static), rel=1e-3)


def test_report_section_reads_the_elastic_study_where_it_exists(tmp_path):
    """The comparison section: K*(1 kHz) of both studies, rolling passes of both, and a plain statement of
    what is missing (no elastic study.nc here)."""
    from types import SimpleNamespace

    from tyreroad.report.spring_comparison import spring_comparison_section

    freq = np.array([100.0, 1000.0])

    def spectrum(k_storage, k_loss, rheology=None):
        ds = xr.Dataset({"storage_stiffness": (("preload", "frequency"), k_storage),
                         "loss_stiffness": (("preload", "frequency"), k_loss)},
                        coords={"preload": [1e-4], "frequency": freq},
                        attrs={"material": "tread", "figure_preload": 1e-4})
        if rheology:
            ds.attrs["spring_rheology"] = rheology
        return ds

    own, elastic = tmp_path / "results-qlv", tmp_path / "results"
    (elastic / "stiffness_spectrum" / "road").mkdir(parents=True)
    spectrum([[1e6, 1.0e6]], [[5e4, 1e5]]).to_netcdf(elastic / "stiffness_spectrum" / "road" / "tread.nc")
    for root, loss in ((own, 2.0), (elastic, 1.0)):
        (root / "rolling" / "strip" / "tread").mkdir(parents=True)
        xr.Dataset({"steady_loss_force": ((), loss), "steady_force": ((), 500.0)}).to_netcdf(
            root / "rolling" / "strip" / "tread" / "dynamic_v20.nc")
    study = xr.Dataset(attrs={"surface": "road"})
    text = "\n".join(spring_comparison_section(study, [spectrum([[1e6, 1.6e6]], [[5e4, 4.2e5]], "qlv")],
                                               SimpleNamespace(reference_material="tread"), {}, own, elastic))
    assert "study.nc` is missing" in text
    assert "| tread | 0.10 | 1.000 | 1.600 | 1.600 | 0.100 | 0.263 |" in text
    assert "| rolling/strip/tread/dynamic_v20.nc | 2.000e-03 | 4.000e-03 | 2.00 | 500.0 | — | — |" in text
    assert "This study's springs: qlv" in text


def test_a_spring_that_does_not_relax_marches_as_the_elastic_table():
    """R(t) = 1 (no relaxation terms): the QLV march gives the elastic run to the last bit, on a rough 3 x 3
    patch through contact, hold and separation (so the wrapper, the march hooks and the clip change nothing)."""
    mat = material(MAXWELL)
    greens = greens_dataset(mat, (3, 3), C, FS, 64, 4096)
    kernel = LayerKernel.from_greens(greens, "dynamic")
    rng = np.random.default_rng(2)
    z1 = -rng.uniform(0, 2e-5, size=(3, 3))
    step, n = 1e-6, 201
    k = np.linspace(1e4, 5e4, n)[None, :] * rng.uniform(0.5, 1.5, size=(9, 1))
    f = np.zeros_like(k)
    np.cumsum(0.5 * step * (k[:, 1:] + k[:, :-1]), axis=1, out=f[:, 1:])
    table = SpringTable.checked(k, f, step, 9)
    t = np.arange(300) / FS
    d = 4e-5 * np.sin(np.pi * t / t[-1])
    settings = SolverSettings(method="dense")
    elastic = run_loading_path(IndentationPath(z1, d, t), table, kernel, settings)
    still = ViscoelasticSprings(table, RelaxationFunction(1.0, np.zeros(0), np.zeros(0)), mat.quasi_static_modulus)
    qlv_run = run_loading_path(IndentationPath(z1, d, t), still, kernel, settings)
    assert elastic.contact_count.max() == 9 and elastic.contact_count[-1] == 0
    assert np.array_equal(qlv_run.element_force, elastic.element_force)
    assert np.array_equal(qlv_run.compression, elastic.compression)


@pytest.mark.parametrize("frequency, periods", [(1000.0, 10), (5000.0, 20)])
def test_patch_harmonic_run_against_k_star(frequency, periods):
    """The 6 x 6 rough patch of tests/test_stiffness.py (Maxwell tread, punch springs) with QLV springs: a harmonic
    run about the relaxed state at 0.1 mm against K* with k_e(f) = k_e E(f)/E_qs, within 1 % and 0.01 rad."""
    import test_stiffness as S

    rng = np.random.default_rng(5)
    shape = (6, 6)
    mat = S.material(S.MAXWELL, "maxwell")
    z1 = S.rough_z1(*shape, rng)
    springs = qlv(mat, S.punch_springs(36, rng))
    greens = greens_dataset(mat, shape, C, FS, 256, 4096)
    g_static = greens["g_static"].transpose("dx", "dy").values
    settings = SolverSettings(quasistatic_step=1e-5, method="dense")
    spec = SpectrumSettings(preloads=(1e-4,), n_frequencies=10, report_frequencies=(frequency,))
    ds = stiffness_spectrum(z1, springs, LayerKernel.quasistatic(g_static), ElementFRF(mat, C), mat, FS, spec, settings)
    expected = complex(S.k_star(ds.sel(frequency=frequency))[0])
    hold, speed = 5e-3, 0.1
    preset = LoadingPreset("h", {"kind": "harmonic", "preload": 1e-4, "preload_speed": speed, "relax_time": hold,
                                 "amplitude": 1e-6, "frequency": frequency, "periods": periods})
    t, d, _ = preset.path("dynamic", FS, settings.quasistatic_step)
    res = run_loading_path(IndentationPath(z1, d, t), springs, LayerKernel.from_greens(greens, "dynamic"), settings)
    measured = harmonic_stiffness(res, frequency, 1e-4 / speed + hold + 2 / frequency)
    assert abs(abs(measured) / abs(expected) - 1) < 0.01
    assert abs(np.angle(measured / expected)) < 0.01
