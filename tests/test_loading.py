"""Loading paths (SPEC 10): presets, cycles with long memory, hysteresis, the loading study."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import xarray as xr

from tyreroad.contact import RunRecorder, SolverSettings, loading_dataset, march
from tyreroad.hysteresis import aggregate_loading, dissipated_energy, loading_work
from tyreroad.kernel import LayerKernel
from tyreroad.report import ReportContext, hysteresis_section
from tyreroad.loading import LoadingPreset, SeparatingPath, cycle_path, harmonic_path, read_loading_table
from tyreroad.material import material_from_config
from tyreroad.memory import TailModel, fit_retardation_spectrum
from tyreroad.springs import SpringTable

from test_contact import punch_tables, realistic_kernel, realistic_z1

FS = 51200.0
TREAD = {
    "model": "fractional_kelvin_voigt", "E0": 2.5e7, "E1": 5.0e7, "alpha": 0.24, "f1": 1000.0,
    "poisson_ratio": 0.49, "density": 1100.0, "thickness": 0.01,
}
CYCLE = {"kind": "cycle", "load_speed": 0.1, "d_max": 1.0e-4, "hold_time": 2e-3, "unload_speed": 0.1}


# --------------------------------------------------------------------------------------------
# Presets and paths
# --------------------------------------------------------------------------------------------
def test_cycle_path_phases():
    t, d, release = cycle_path(FS, 0.1, 1e-4, 2e-3, 0.05)
    assert np.allclose(np.diff(t), 1 / FS)
    load = t <= 1e-3
    np.testing.assert_allclose(d[load], 0.1 * t[load], rtol=1e-12)
    hold = (t >= 1e-3) & (t <= 3e-3)
    assert np.all(d[hold] == 1e-4)
    assert t[release] > 3e-3 >= t[release - 1]
    np.testing.assert_allclose(d[release:], 1e-4 - 0.05 * (t[release:] - 3e-3), rtol=1e-12, atol=1e-18)
    assert d[-1] <= -1e-4 * (1 - 1e-9)  # the path goes on below d = 0, to -d_max at most


def test_harmonic_path_and_errors():
    t, d = harmonic_path(FS, 1e-4, 0.1, 5e-3, 1e-6, 1000.0, 3)
    start = 1e-3 + 5e-3
    osc = t >= start
    np.testing.assert_allclose(d[osc], 1e-4 + 1e-6 * np.sin(2 * np.pi * 1e3 * (t[osc] - start)), atol=1e-18)
    assert t[-1] == pytest.approx(start + 3e-3, abs=1 / FS)
    with pytest.raises(ValueError, match="amplitude"):
        harmonic_path(FS, 1e-6, 0.1, 0.0, 2e-6, 1000.0, 1)


def test_preset_validation_names_the_key(tmp_path):
    with pytest.raises(ValueError, match=r"loadings\.c\.kind"):
        LoadingPreset("c", {"kind": "spiral"})
    with pytest.raises(ValueError, match=r"loadings\.c\.hold_time: missing"):
        LoadingPreset("c", {"kind": "cycle", "load_speed": 0.1, "d_max": 1e-4, "unload_speed": 0.1})
    with pytest.raises(ValueError, match=r"loadings\.c\.preload: unknown key for kind cycle"):
        LoadingPreset("c", {**CYCLE, "preload": 1e-4})
    with pytest.raises(ValueError, match=r"loadings\.c\.load_speed"):
        LoadingPreset("c", {**CYCLE, "load_speed": -0.1})
    h = LoadingPreset("h", {"kind": "harmonic", "preload": 1e-4, "relax_time": 0.0, "amplitude": 1e-6,
                            "frequency": 100.0, "periods": 2})
    assert h.params["preload_speed"] == 0.1  # the documented default


def test_table_preset_reads_csv_and_rejects_bad_files(tmp_path):
    good = tmp_path / "path.csv"
    good.write_text("# t [s], d [m]\nt,d\n0, 0\n1e-3, 1e-4\n2e-3, 0.5e-4\n")
    preset = LoadingPreset("tab", {"kind": "table", "file": "path.csv"}, base_dir=tmp_path)
    t, d, release = preset.path("dynamic", FS, 1e-6)
    assert release is None and 2e-3 - 1 / FS < t[-1] <= 2e-3  # the samples inside the table
    np.testing.assert_allclose(d, np.interp(t, [0, 1e-3, 2e-3], [0, 1e-4, 0.5e-4]))
    t_qs, d_qs, _ = preset.path("quasistatic", FS, 1e-6)
    np.testing.assert_array_equal(d_qs, [0, 1e-4, 0.5e-4])
    bad = tmp_path / "bad.csv"
    for text, match in [
        ("0,0\n1e-3\n", "expected two columns"),
        ("0,0\n1e-3,x\n", "line 2: expected two numbers"),
        ("1e-3,0\n2e-3,1e-4\n", "start at 0 s"),
        ("0,0\n1e-3,nan\n", "NaN"),
        ("0,0\n", "at least two rows"),
    ]:
        bad.write_text(text)
        with pytest.raises(ValueError, match=match) as err:
            read_loading_table(bad)
        assert str(bad) in str(err.value)
    with pytest.raises(ValueError, match="cannot be read"):
        read_loading_table(tmp_path / "missing.csv")


def test_energy_of_a_closed_path():
    d = np.array([0.0, 1.0, 2.0, 1.0, 0.0])
    f = np.array([0.0, 2.0, 4.0, 1.0, 0.0])
    # loading work 1 + 3 = 4; unloading gives back 2.5 + 0.5 = 3
    assert loading_work(d, f) == pytest.approx(4.0)
    assert dissipated_energy(d, f) == pytest.approx(1.0)
    assert dissipated_energy(d, np.array([0.0, 2.0, 4.0, 2.0, 0.0])) == 0.0


# --------------------------------------------------------------------------------------------
# Cycles through the solver, with long memory
# --------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def cycle_problem():
    rng = np.random.default_rng(17)
    nx = ny = 20
    z1 = realistic_z1(nx, ny, rng)
    k, f, step = punch_tables(nx * ny, rng)
    kernel, g_static = realistic_kernel(nx, ny, 64)
    spectrum = fit_retardation_spectrum(material_from_config("t", {"t": TREAD}), FS / 2)
    # a creeping layer: the kept 64 lags hold 0.6 of the static compliance, the tail the rest
    kernel = 0.6 * kernel
    tail = TailModel.from_spectrum(0.4 * g_static, spectrum, FS, 64)
    return z1, SpringTable.checked(k, f, step, nx * ny), kernel, g_static, tail


def _run(problem, mode, method="dense"):
    z1, springs, kernel, g_static, tail = problem
    preset = LoadingPreset("cycle", CYCLE)
    loading = preset.loading(z1, mode, FS, 2e-6)
    settings = SolverSettings(method=method)
    layer = LayerKernel.dynamic(kernel, FS, tail) if mode == "dynamic" else LayerKernel.quasistatic(g_static)
    substrate, history = layer.collaborators(z1.shape, settings, 1, loading.n_steps)
    res = march(loading, springs, substrate, history, settings, RunRecorder(loading.n_steps, z1.shape))
    return preset, loading, res


def test_cycle_ends_when_every_element_has_separated(cycle_problem):
    preset, loading, res = _run(cycle_problem, "dynamic")
    assert isinstance(loading, SeparatingPath)
    n = res.force.size
    assert n < loading.n_steps  # ended early, not at d = -d_max
    assert res.contact_count[-1] == 0 and np.all(res.contact_count[loading.release_step:-1] > 0)
    # delayed recovery: the layer lets go before the tread surface is back at the top peak
    assert res.indentation[-1] > 0
    ds = loading_dataset(dataclasses.replace(res, backing_force=res.force), "dynamic", preset, "s", "t")
    w, work = float(ds["dissipated_energy"]), float(ds["loading_work"])
    assert 0.05 * work < w < work  # a passive, lossy tread dissipates part of the work
    assert ds.attrs["loading"] == "cycle" and "load_speed" in ds.attrs["loading_config"]


def test_quasistatic_cycle_has_no_hysteresis(cycle_problem):
    preset, loading, res = _run(cycle_problem, "quasistatic")
    assert res.time is None and res.contact_count[-1] == 0
    d = res.indentation
    up = np.argmax(d)
    # the unloading branch meets the loading branch at the same d: no rate dependence
    np.testing.assert_allclose(res.force[up:up + up + 1][::-1], res.force[: up + 1], rtol=1e-9, atol=1e-12)
    w = dissipated_energy(d, res.force)
    assert abs(w) <= 1e-6 * loading_work(d, res.force)


def test_cycle_dense_and_fft_agree_with_long_memory(cycle_problem):
    _, loading, dense = _run(cycle_problem, "dynamic", "dense")
    assert loading.n_steps > 64  # the run reaches far into the tail
    _, _, fft = _run(cycle_problem, "dynamic", "fft")
    assert fft.force.size == dense.force.size
    scale = dense.force.max()
    np.testing.assert_allclose(fft.force, dense.force, rtol=0, atol=1e-10 * scale)
    np.testing.assert_allclose(fft.element_force, dense.element_force, rtol=0, atol=1e-10 * scale)


def test_path_that_runs_out_before_separation_is_an_error(cycle_problem):
    from tyreroad.contact import ContactConvergenceError

    z1, springs, kernel, g_static, tail = cycle_problem
    t, d, release = cycle_path(FS, 0.1, 1e-4, 2e-3, 0.1)
    cut = release + 5  # still pressed into the road
    loading = SeparatingPath(z1, d[:cut], t[:cut], release)
    settings = SolverSettings()
    substrate, history = LayerKernel.dynamic(kernel, FS, tail).collaborators(z1.shape, settings, 1, cut)
    with pytest.raises(ContactConvergenceError, match="elements still in contact"):
        march(loading, springs, substrate, history, settings, RunRecorder(cut, z1.shape))


def test_loading_study_and_report_section(cycle_problem):
    runs = []
    for mode in ("quasistatic", "dynamic"):
        preset, _, res = _run(cycle_problem, mode)
        runs.append(loading_dataset(dataclasses.replace(res, backing_force=res.force), mode, preset, "s", "tread"))
    ds = aggregate_loading(runs)
    assert list(ds["mode"].values) == ["quasistatic", "dynamic"]
    w = ds["dissipated_energy"].values
    assert abs(w[0]) < 1e-6 * ds["loading_work"].values[0] and w[1] > 0
    assert ds["loss_ratio"].values[1] == pytest.approx(w[1] / ds["loading_work"].values[1])
    n_dyn = runs[1].sizes["step"]
    assert np.isfinite(ds["loop_force"].values[1, :n_dyn]).all()
    text = "\n".join(hysteresis_section(ReportContext(loading=ds)))
    assert "| tread | dynamic | cycle |" in text and f"{1e3 * w[1]:.4g}" in text
    assert isinstance(ds, xr.Dataset)
