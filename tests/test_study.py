"""Study aggregation (tyreroad.study) and figures 5-8 (tyreroad.plots.study) on synthetic contact runs.

The synthetic runs follow the Contact dataset contract (docs/data_contracts.md) with a force whose stiffness
is known in closed form: F(d) = S (d - s (1 - exp(-d/s))), so K(d) = S (1 - exp(-d/s)).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import xarray as xr

import _synthetic
from tyreroad import io
from tyreroad.study import (
    EQUIVALENT_RANGE,
    StudySettings,
    aggregate,
    case_label,
    contact_stiffness,
    equivalent_modulus_scale,
    expected_cases,
    hermite_on_grid,
    interp_on_grid,
    loading_branch,
    open_study,
    saturated_stiffness,
    variant_members,
)

D_MAX = 2.5e-4
DT = 1.0 / 51200.0
N_EX, N_EY = 4, 5


def force_saturating(S, s):
    return lambda d: S * (d - s * (1.0 - np.exp(-d / s)))


def stiffness_saturating(S, s):
    return lambda d: S * (1.0 - np.exp(-d / s))


def synthetic_run(material, mode, accel, force_fn, **kw):
    """A synthetic contact run on the 4 x 5 test patch (see tests/_synthetic.py)."""
    return _synthetic.synthetic_run(material, mode, accel, force_fn, shape=(N_EX, N_EY), **kw)


def settings(materials=("ref", "other"), accelerations=(50.0, 500.0), **kw):
    study = {"surface": "synth", "reference_material": materials[0], "materials": list(materials),
             "accelerations": list(accelerations), **kw}
    return StudySettings.from_config(study, d_max=D_MAX)


S_OF = {("ref", "quasistatic", 0.0): 2.0e6, ("ref", "dynamic", 50.0): 2.3e6, ("ref", "dynamic", 500.0): 2.75e6,
        ("other", "quasistatic", 0.0): 1.0e6, ("other", "dynamic", 50.0): 1.2e6, ("other", "dynamic", 500.0): 1.4e6}
DS = 4e-5


def study_runs(st, **kw):
    return [synthetic_run(m, mode, a, force_saturating(S_OF[(m, mode, a)], DS), **kw) for m, mode, a in expected_cases(st)]


# ----------------------------------------------------------------------------------------------
# settings
# ----------------------------------------------------------------------------------------------
def test_settings_from_config_defaults_and_grid():
    st = settings(accelerations=(500, 50, 250))
    assert st.accelerations == (50.0, 250.0, 500.0)
    assert st.indentation_step == 1e-6 and st.saturation_range == (1.8e-4, 2.5e-4)
    assert st.grid.size == 251 and st.grid[-1] == pytest.approx(D_MAX, rel=1e-12)
    assert expected_cases(st)[:2] == [("ref", "quasistatic", 0.0), ("ref", "dynamic", 50.0)]
    assert len(expected_cases(st)) == 2 * 4


@pytest.mark.parametrize(
    "change, key",
    [
        ({"reference_material": "nope"}, "study.reference_material"),
        ({"indentation_step": 3e-6}, "study.indentation_step"),
        ({"indentation_step": -1e-6}, "study.indentation_step"),
        ({"saturation_range": [2e-4, 3e-4]}, "study.saturation_range"),
        ({"saturation_range": [2e-4, 1e-4]}, "study.saturation_range"),
        ({"accelerations": [50, -1]}, "study.accelerations"),
        ({"accelerations": [50, 50.0]}, "study.accelerations"),
        ({"materials": ["ref", "ref"]}, "study.materials"),
        ({"typo": 1}, "study.typo"),
    ],
)
def test_settings_errors_name_the_key(change, key):
    study = {"surface": "synth", "reference_material": "ref", "materials": ["ref"], "accelerations": [50], **change}
    with pytest.raises(ValueError, match=key.replace(".", r"\.")):
        StudySettings.from_config(study, d_max=D_MAX)


def test_settings_missing_key():
    with pytest.raises(ValueError, match=r"study\.accelerations is missing"):
        StudySettings.from_config({"surface": "s", "reference_material": "r", "materials": ["r"]}, d_max=D_MAX)


# ----------------------------------------------------------------------------------------------
# stiffness formula
# ----------------------------------------------------------------------------------------------
def test_stiffness_exact_for_quadratics_on_nonuniform_grid():
    rng = np.random.default_rng(1)
    d = np.cumsum(rng.uniform(0.2e-6, 3e-6, 40))
    f = 3.0e9 * d**2 - 2.0e5 * d + 7.0
    k = contact_stiffness(d, f)
    np.testing.assert_allclose(k, 6.0e9 * d - 2.0e5, rtol=1e-8, atol=1e-3)
    # independent implementation of the same second-order formulas
    np.testing.assert_allclose(k, np.gradient(f, d, edge_order=2), rtol=1e-10)


def test_stiffness_second_order_on_constant_acceleration_grid():
    """F = K0 d^2.5 sampled at d = a t^2/2: error falls 4x when dt halves (second order)."""
    a, k0 = 500.0, 1.0e10

    def max_error(dt):
        t = np.arange(math.ceil(math.sqrt(2 * D_MAX / a) / dt) + 1) * dt
        d = 0.5 * a * t**2
        k = contact_stiffness(d, k0 * d**2.5)
        exact = 2.5 * k0 * d**1.5
        return np.max(np.abs(k - exact)) / np.max(exact)

    e1, e2, e3 = max_error(DT), max_error(DT / 2), max_error(DT / 4)
    assert e1 < 1e-3  # the study's own sampling at 500 m/s^2
    assert 3.3 < e1 / e2 < 4.7 and 3.3 < e2 / e3 < 4.7


def test_stiffness_rejects_bad_input():
    with pytest.raises(ValueError, match="strictly increasing"):
        contact_stiffness([0.0, 1e-6, 1e-6, 2e-6], [0, 1, 2, 3])
    with pytest.raises(ValueError, match="at least 3"):
        contact_stiffness([0.0, 1e-6], [0.0, 1.0])
    with pytest.raises(ValueError, match="finite"):
        contact_stiffness([0.0, 1e-6, 2e-6], [0.0, np.nan, 1.0])


def test_saturated_stiffness_is_median_over_range():
    d = np.arange(251) * 1e-6
    k = np.where(d > 2.2e-4, 100.0, 1.0) + d  # 30 large values out of 71 in range: median stays low
    assert saturated_stiffness(d, k, (1.8e-4, 2.5e-4)) == pytest.approx(1.0 + 2.15e-4, rel=1e-12)
    with pytest.raises(ValueError, match="saturation range"):
        saturated_stiffness(d, np.full_like(d, np.nan), (1.8e-4, 2.5e-4))


# ----------------------------------------------------------------------------------------------
# aggregation
# ----------------------------------------------------------------------------------------------
def test_aggregate_grid_stiffness_and_ksat():
    st = settings()
    runs = study_runs(st, backing_scale=1.01)
    ds = aggregate(reversed(runs), st)  # order of the inputs does not matter
    assert ds.sizes == {"case": 6, "indentation": 251, "sample": max(r.sizes["step"] for r in runs)}
    assert list(ds["case"].values) == ["ref/quasistatic/0", "ref/dynamic/50", "ref/dynamic/500",
                                       "other/quasistatic/0", "other/dynamic/50", "other/dynamic/500"]
    assert list(ds["accel"].values) == [0.0, 50.0, 500.0, 0.0, 50.0, 500.0]
    d = ds["indentation"].values
    for i, (m, mode, a) in enumerate(expected_cases(st)):
        S = S_OF[(m, mode, a)]
        c = ds.isel(case=i)
        assert c["material"].item() == m and c["mode"].item() == mode
        np.testing.assert_allclose(c["force"].values, force_saturating(S, DS)(d), rtol=0, atol=2e-4 * S * D_MAX)
        np.testing.assert_allclose(c["stiffness"].values, stiffness_saturating(S, DS)(d), rtol=0, atol=3e-3 * S)
        assert float(c["saturated_stiffness"]) == pytest.approx(S * (1 - math.exp(-2.15e-4 / DS)), rel=1e-3)
        np.testing.assert_allclose(c["backing_stiffness"].values, 1.01 * c["stiffness"].values, rtol=1e-12)
        assert float(c["saturated_backing_stiffness"]) / float(c["saturated_stiffness"]) == pytest.approx(1.01, rel=1e-12)
        n = int(c["native_samples"])
        assert n == runs[i].sizes["step"]
        np.testing.assert_array_equal(c["native_indentation"].values[:n], runs[i]["indentation"].values)
        assert np.all(np.isnan(c["native_indentation"].values[n:]))
    # QS native grid coincides with the common grid: the fraction is count / elements exactly
    qs = ds.study.sel_case(material="ref", mode="quasistatic")
    expect = np.round((1 - np.exp(-d / 5e-5)) * N_EX * N_EY) / (N_EX * N_EY)
    np.testing.assert_allclose(qs["contact_fraction"].values, expect, atol=1e-12)
    assert int(ds["n_elements"]) == N_EX * N_EY
    for name in [*ds.data_vars, *ds.coords]:
        assert "units" in ds[name].attrs and "long_name" in ds[name].attrs, name
    assert "native (non-uniform) samples" in ds.attrs["stiffness_method"]


def test_aggregate_run_ending_within_one_step_of_d_max_leaves_nan_not_extrapolation():
    st = settings()
    runs = study_runs(st)
    runs[2] = synthetic_run("ref", "dynamic", 500.0, force_saturating(2.75e6, DS), overshoot=False)
    d_last = float(runs[2]["indentation"][-1])
    assert d_last < D_MAX
    ds = aggregate(runs, st)
    k = ds.study.sel_case(material="ref", mode="dynamic", accel=500)["stiffness"].values
    grid = ds["indentation"].values
    assert np.all(np.isnan(k[grid > d_last])) and np.all(np.isfinite(k[grid <= d_last]))
    assert np.isfinite(ds["saturated_stiffness"].values).all()


# ----------------------------------------------------------------------------------------------
# non-monotone indentation paths: K(d) on the initial loading branch
# ----------------------------------------------------------------------------------------------
def test_loading_branch():
    assert loading_branch(np.array([0.0, 1.0, 2.0, 3.0])) == 4
    assert loading_branch(np.array([0.0, 1.0, 2.0, 1.5, 0.5, 2.5])) == 3  # up to the first maximum
    assert loading_branch(np.array([0.0, 1.0, 2.0, 2.0, 2.0, 1.0])) == 3  # a hold ends the branch
    assert loading_branch(np.array([0.0, 0.0, 1.0])) == 1


@pytest.mark.parametrize("mode, accel", [("dynamic", 500.0), ("quasistatic", 0.0)])
def test_aggregate_load_unload_cycle_equals_its_loading_branch(mode, accel):
    st = settings()
    runs = study_runs(st)
    i = expected_cases(st).index(("ref", mode, accel))
    cycle = _synthetic.append_unloading(runs[i])
    d_path = cycle["indentation"].values
    assert np.any(np.diff(d_path) < 0) and np.any(np.diff(d_path) == 0)
    plain = aggregate(runs, st)
    runs[i] = cycle
    ds = aggregate(runs, st)
    for name in plain.data_vars:
        if name == "run_samples":
            continue
        np.testing.assert_array_equal(ds[name].values, plain[name].values, err_msg=name)
    c = ds.isel(case=i)
    assert int(c["run_samples"]) == d_path.size
    assert int(c["native_samples"]) == int(plain.isel(case=i)["native_samples"]) == loading_branch(d_path)
    assert (plain["run_samples"].values == plain["native_samples"].values).all()


def test_aggregate_cycle_whose_loading_branch_stops_short_is_an_error():
    st = settings()
    runs = study_runs(st)
    short = synthetic_run("ref", "quasistatic", 0.0, force_saturating(2.0e6, DS), d_max=2.0e-4)
    runs[0] = _synthetic.append_unloading(short)
    with pytest.raises(ValueError, match="loading branch stops at d = 0.0002 m, short of solver.d_max"):
        aggregate(runs, st)


# ----------------------------------------------------------------------------------------------
# equivalent quasi-static stiffness
# ----------------------------------------------------------------------------------------------
def test_equivalent_modulus_scale_is_the_least_squares_factor():
    d = np.arange(251) * 1e-6
    kq = 1.4e6 * (1 - np.exp(-d / DS))
    kd = 2.7e6 * (1 - np.exp(-d / 2e-5))
    s, misfit = equivalent_modulus_scale(d, kd, kq)
    sel = (d >= 5e-5 - 1e-15) & (d <= 2.5e-4 + 1e-15)
    coef = np.linalg.lstsq(kq[sel, None], kd[sel], rcond=None)[0][0]
    assert s == pytest.approx(coef, rel=1e-12)
    assert misfit == pytest.approx(np.sqrt(np.mean((kd[sel] - coef * kq[sel]) ** 2) / np.mean(kd[sel] ** 2)), rel=1e-12)
    assert 0.01 < misfit < 0.2
    assert equivalent_modulus_scale(d, 1.7 * kq, kq) == pytest.approx((1.7, 0.0), abs=1e-14)
    kd_nan = kd.copy()
    kd_nan[-10:] = np.nan  # NaN samples are left out, not propagated
    assert np.isfinite(equivalent_modulus_scale(d, kd_nan, kq)[0])
    assert EQUIVALENT_RANGE == pytest.approx((0.05e-3, 0.25e-3))
    with pytest.raises(ValueError, match="fit range"):
        equivalent_modulus_scale(d, kd, np.zeros_like(kq))


def test_aggregate_equivalent_scale_exact_for_proportional_runs():
    """K_dyn = 1.7 K_QS exactly (F quadratic in d: the differences and the interpolation are exact)."""
    st = settings()
    quad = lambda S: (lambda d: S * (0.5 * d**2 / 1e-4 + 0.2 * d))  # noqa: E731  K = S (d/1e-4 + 0.2)
    scale = {("ref", "quasistatic", 0.0): 1.0, ("ref", "dynamic", 50.0): 1.7, ("ref", "dynamic", 500.0): 1.7,
             ("other", "quasistatic", 0.0): 1.0, ("other", "dynamic", 50.0): 1.2, ("other", "dynamic", 500.0): 2.5}
    runs = [synthetic_run(m, mode, a, quad(1e6 * scale[(m, mode, a)])) for m, mode, a in expected_cases(st)]
    ds = aggregate(runs, st)
    np.testing.assert_allclose(ds["equivalent_modulus_scale"].values, [scale[k] for k in expected_cases(st)], rtol=1e-12)
    np.testing.assert_allclose(ds["equivalent_misfit"].values, 0.0, atol=1e-12)
    np.testing.assert_allclose(ds.attrs["equivalent_range_m"], [0.05e-3, 0.25e-3])


def test_interp_on_grid_nan_outside_never_extrapolates():
    grid = np.linspace(0, 1, 11)
    out = interp_on_grid(grid, np.array([0.2, 0.6]), np.array([1.0, 3.0]))
    assert np.all(np.isnan(out[:2])) and np.all(np.isnan(out[7:]))
    np.testing.assert_allclose(out[2:7], [1.0, 1.5, 2.0, 2.5, 3.0])
    # a grid point beyond the end by rounding only is kept
    assert np.isfinite(interp_on_grid(np.array([0.6 * (1 + 1e-12)]), np.array([0.2, 0.6]), np.array([1.0, 3.0])))[0]


def test_aggregate_errors():
    st = settings()
    runs = study_runs(st)
    with pytest.raises(ValueError, match=r"missing the contact run\(s\) other/dynamic/500"):
        aggregate(runs[:-1], st)
    with pytest.raises(ValueError, match="duplicate run for case 'ref/dynamic/50'"):
        aggregate(runs + [runs[1]], st)
    bad = runs[1].copy()
    bad.attrs["surface"] = "elsewhere"
    with pytest.raises(ValueError, match="differs from study.surface"):
        aggregate([bad] + runs[2:], st)
    bad = runs[1].copy()
    bad.attrs["acceleration"] = 100.0
    with pytest.raises(ValueError, match=r"acceleration 100 m/s\^2 is not in study.accelerations"):
        aggregate([bad], st)
    short = synthetic_run("ref", "quasistatic", 0.0, force_saturating(1e6, DS), d_max=2.0e-4)
    with pytest.raises(ValueError, match="short of solver.d_max"):
        aggregate([short] + runs[1:], st)


def test_aggregate_reads_files(tmp_path):
    st = settings()
    paths = []
    for run in study_runs(st):
        p = tmp_path / f"{run.attrs['material']}_{run.attrs['mode']}_{run.attrs['acceleration']:g}.nc"
        io.write_dataset(run, p, {"test": 1})
        paths.append(p)
    ds = aggregate(paths, st)
    ref = aggregate(study_runs(st), st)
    np.testing.assert_array_equal(ds["stiffness"].values, ref["stiffness"].values)


# ----------------------------------------------------------------------------------------------
# reading back and selecting
# ----------------------------------------------------------------------------------------------
def test_open_study_round_trip_and_selection(tmp_path):
    st = settings()
    ds = aggregate(study_runs(st), st)
    path = io.write_dataset(ds, tmp_path / "study.nc", {"study": {"surface": "synth"}}, stage="study")
    back = open_study(path)
    c = back.study.sel_case(material="ref", mode="dynamic", accel=500)
    assert c["case"].item() == case_label("ref", "dynamic", 500) == "ref/dynamic/500"
    np.testing.assert_array_equal(c["stiffness"].values, ds.sel(case="ref/dynamic/500")["stiffness"].values)
    assert float(c["saturated_stiffness"]) == pytest.approx(2.75e6 * (1 - math.exp(-2.15e-4 / DS)), rel=1e-3)
    assert back.study.labels(material="other") == ["other/quasistatic/0", "other/dynamic/50", "other/dynamic/500"]
    assert back.study.select(mode="dynamic", accel=50).sizes["case"] == 2
    qs = back.study.sel_case(material="other", mode="quasistatic")
    assert float(qs["accel"]) == 0.0
    assert back["stiffness"].attrs["units"] == "N/m" and back["accel"].attrs["units"] == "m/s2"
    assert back.attrs["reference_material"] == "ref"
    np.testing.assert_allclose(back.attrs["saturation_range_m"], [1.8e-4, 2.5e-4])
    with pytest.raises(KeyError, match="ref/dynamic/250"):
        back.study.sel_case(material="ref", mode="dynamic", accel=250)
    with pytest.raises(KeyError, match="accel is required"):
        back.study.sel_case(material="ref", mode="dynamic")
    other = io.write_dataset(xr.Dataset({"x": ("a", [1.0], {"units": "1", "long_name": "x"})}), tmp_path / "x.nc", {})
    with pytest.raises(ValueError, match="not a tyreroad study dataset"):
        open_study(other)


def test_variant_members_validation():
    mats = ["ref", "lo", "hi"]
    v = {"loss": [[1.5, "hi"], [1.0, "ref"], [0.5, "lo"]], "density": [[1.0, "ref"]]}
    assert variant_members(v, "loss", mats, "ref") == [(0.5, "lo"), (1.0, "ref"), (1.5, "hi")]
    assert variant_members(v, "density", mats, "ref") == [(1.0, "ref")]
    with pytest.raises(ValueError, match="not in the study"):
        variant_members({"loss": [[1.0, "ref"], [2.0, "zz"]]}, "loss", mats, "ref")
    with pytest.raises(ValueError, match="scale 1"):
        variant_members({"loss": [[0.5, "lo"]]}, "loss", mats, "ref")
    with pytest.raises(ValueError, match="'density' group"):
        variant_members({"loss": []}, "density", mats, "ref")


# ----------------------------------------------------------------------------------------------
# figures 5-8
# ----------------------------------------------------------------------------------------------
def test_study_figures_written(tmp_path):
    import matplotlib.image as mpimg

    from tyreroad.plots.study import FIGURES, plot_study_figures

    mats = ("ref", "lo", "hi")
    st = StudySettings.from_config({"surface": "synth", "reference_material": "ref", "materials": list(mats),
                                    "accelerations": [50, 250, 500]}, d_max=D_MAX)
    S = {"quasistatic": 2.0e6, 50.0: 2.3e6, 250.0: 2.5e6, 500.0: 2.75e6}
    scale = {"ref": 1.0, "lo": 1.03, "hi": 0.97}
    runs = [synthetic_run(m, mode, a, force_saturating(S[mode if mode == "quasistatic" else a] * scale[m], DS))
            for m, mode, a in expected_cases(st)]
    ds = aggregate(runs, st)
    variants = {"loss": [[0.5, "lo"], [1.0, "ref"], [1.5, "hi"]], "density": [[1.0, "ref"], [2.0, "hi"]]}
    out = {name: tmp_path / f"{name}.png" for name in FIGURES}
    written = plot_study_figures(ds, variants, out)
    assert [p.name for p in written] == [f"{n}.png" for n in FIGURES]
    for p in written:
        img = mpimg.imread(p)
        assert img.shape[0] > 500 and img.shape[1] > 800
        assert img[..., :3].std() > 0.05  # not a blank canvas
    with pytest.raises(ValueError, match="not in the study"):
        plot_study_figures(ds, {"loss": [[1.0, "ref"], [0.5, "tread-eta0.5"]], "density": [[1.0, "ref"]]}, out)
    with pytest.raises(ValueError, match="expected 4 output paths"):
        plot_study_figures(ds, variants, list(out.values())[:3])


# ----------------------------------------------------------------------------------------------
# quasi-static runs with a stored tangent (coarse quasi-static grids)
# ----------------------------------------------------------------------------------------------
def test_hermite_on_grid_exact_for_cubics_nan_outside():
    x = np.array([0.0, 1e-5, 3e-5, 4e-5])
    grid = np.linspace(-1e-6, 4.1e-5, 43)
    f, k = hermite_on_grid(grid, x, x**3 - 2e-5 * x**2, 3 * x**2 - 4e-5 * x)
    inside = (grid >= 0) & (grid <= 4e-5 + 1e-15)
    np.testing.assert_allclose(f[inside], grid[inside] ** 3 - 2e-5 * grid[inside] ** 2, rtol=0, atol=1e-28)
    np.testing.assert_allclose(k[inside], 3 * grid[inside] ** 2 - 4e-5 * grid[inside], rtol=0, atol=1e-22)
    assert np.all(np.isnan(f[~inside])) and np.all(np.isnan(k[~inside]))


def _with_tangent(run, stiffness_fn, entry):
    """A quasi-static synthetic run with the stored tangent and element compressions zeta_e = d - entry_e."""
    d = run["indentation"].values
    out = run.copy()
    out["tangent_stiffness"] = ("step", stiffness_fn(d), {"units": "N/m", "long_name": "tangent"})
    zeta = d[:, None] - entry[None, :]
    out["compression"] = (("step", "ex", "ey"), zeta.reshape(d.size, N_EX, N_EY), {"units": "m", "long_name": "zeta"})
    out["contact_count"] = ("step", np.count_nonzero(zeta > 0, axis=1), {"units": "1", "long_name": "count"})
    return out


def test_aggregate_takes_quasistatic_k_from_the_stored_tangent():
    """A 10 um quasi-static run with its tangent: K on the 1 um grid is the exact dF/dd to 2e-4 of K_sat
    (second differences of the same coarse force are off by > 1e-3), F to 3e-6 of S d_max, and the
    contact fraction moves element by element between the coarse states."""
    st = settings()
    entry = np.linspace(0.0, 2.2e-4, N_EX * N_EY) + 3.3e-6
    runs = []
    for m, mode, a in expected_cases(st):
        S = S_OF[(m, mode, a)]
        if mode == "quasistatic":
            run = synthetic_run(m, mode, a, force_saturating(S, DS), qs_step=1e-5)
            runs.append(_with_tangent(run, stiffness_saturating(S, DS), entry))
        else:
            runs.append(synthetic_run(m, mode, a, force_saturating(S, DS)))
    ds = aggregate(runs, st)
    d = ds["indentation"].values
    assert list(ds["stiffness_from_tangent"].values) == [1, 0, 0, 1, 0, 0]
    for m in ("ref", "other"):
        S = S_OF[(m, "quasistatic", 0.0)]
        qs = ds.study.sel_case(material=m, mode="quasistatic")
        np.testing.assert_allclose(qs["stiffness"].values, stiffness_saturating(S, DS)(d), rtol=0, atol=2e-4 * S)
        np.testing.assert_allclose(qs["force"].values, force_saturating(S, DS)(d), rtol=0, atol=3e-6 * S * D_MAX)
        np.testing.assert_allclose(qs["backing_stiffness"].values, qs["stiffness"].values, rtol=1e-15)
        n = int(qs["native_samples"])
        np.testing.assert_allclose(qs["native_stiffness"].values[:n], stiffness_saturating(S, DS)(d[::10]), rtol=1e-14)
        expect = np.count_nonzero(d[:, None] > entry[None, :], axis=1) / (N_EX * N_EY)
        np.testing.assert_allclose(qs["contact_fraction"].values, expect, atol=1e-12)
        fd = interp_on_grid(d, d[::10], contact_stiffness(d[::10], force_saturating(S, DS)(d[::10])))
        assert np.max(np.abs(fd - stiffness_saturating(S, DS)(d))) > 1e-3 * S
    assert "tangent" in ds.attrs["stiffness_method"]
