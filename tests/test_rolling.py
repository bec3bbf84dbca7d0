"""Rolling contact (SPEC 12): the rolling loading, work and pressure centre, slow limit, paths, spectra."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tyreroad.contact import SolverSettings
from tyreroad.greens import greens_dataset, offset_table_index, static_element_kernel, unique_offsets
from tyreroad.material import material_from_config
from tyreroad.kernel import LayerKernel
from tyreroad.report import ReportContext, rolling_section
from tyreroad.report.sections import rolling_spring_comparison_section
from tyreroad.rolling import (
    RollingPass,
    RollingSettings,
    aggregate_rolling,
    band_levels,
    pass_positions,
    rolling_dataset,
    solve_rolling,
    static_indentation,
    steady_mask,
    third_octave_centres,
)
from tyreroad.springs import SpringTable
from tyreroad.surface import prepare_surface

from test_contact import punch_tables, realistic_z1

FS = 51200.0
C = 1e-3
TREAD = {
    "model": "fractional_kelvin_voigt", "E0": 2.5e7, "E1": 5.0e7, "alpha": 0.24, "f1": 1000.0,
    "poisson_ratio": 0.49, "density": 1100.0, "thickness": 0.01,
}
# generalised Maxwell whose longest relaxation time is 0.1 ms (the slow-limit check)
FAST_MAXWELL = {
    "model": "generalized_maxwell", "E_inf": 2.5e7, "moduli": [1.0e7, 1.0e7], "relaxation_times": [1.0e-4, 2.0e-5],
    "poisson_ratio": 0.49, "density": 1100.0, "thickness": 0.01,
}


def _material(cfg):
    return material_from_config("m", {"m": cfg})


def _static_kernel(shape, material):
    """The layer's static kernel g_static[dx, dy] for a patch of ``shape`` elements (time sampled at FS)."""
    dx, dy, index = offset_table_index(shape)
    g = static_element_kernel(unique_offsets(shape) * C, C, material.quasi_static_modulus, material.poisson,
                              material.thickness)
    return LayerKernel(g[index][:, :, None], True, FS, element_size=C)


def _flat_springs(shape, material, stiffness=None):
    """Linear springs; default the punch of a flat element (whole area at once): k = 2 E* a, a = c / sqrt(pi)."""
    e_star = material.quasi_static_modulus / (1 - material.poisson**2)
    step, n = 1e-6, 1001
    k = np.full((shape[0] * shape[1], n), 2 * e_star * C / math.sqrt(math.pi) if stiffness is None else stiffness)
    f = k * (np.arange(n) * step)[None, :]
    return SpringTable.checked(k, f, step, shape[0] * shape[1])


def _flat_strip(nx, ny):
    ds = prepare_surface("flat", {"generator": "flat", "patch_elements": [nx, ny]})
    return ds["z1"].values, ds["element_x"].values


@pytest.fixture(scope="module")
def tread_greens():
    """Time-domain greens of the default tread for strips up to 60 x 10 (with its long-memory tail)."""
    return greens_dataset(_material(TREAD), (60, 10), C, FS, 256, 4096)


def _kernels(ds):
    """(dynamic kernel with its tail, static kernel) of a greens dataset."""
    return LayerKernel.from_greens(ds, "dynamic"), LayerKernel.from_greens(ds, "quasistatic")


# --------------------------------------------------------------------------------------------
# The loading and the pass
# --------------------------------------------------------------------------------------------
def test_rolling_pass_free_compression_is_the_belt_parabola():
    rng = np.random.default_rng(3)
    z1 = rng.normal(0, 1e-4, (5, 3))
    ex = (np.arange(5) + 0.5) * C
    loading = RollingPass(z1, ex, 0.3, 2e-4, [1.0e-3, 2.5e-3], time=[0.0, 1e-4], speed=15.0)
    z2 = z1.max() - 2e-4 + (ex[:, None] - 2.5e-3) ** 2 / 0.6
    np.testing.assert_allclose(loading.free_compression(1), (z1 - z2).ravel(), atol=1e-18)
    np.testing.assert_allclose(loading.undeformed_surface(1), np.repeat(z2[:, 0] - z1.max(), 3), atol=1e-18)
    np.testing.assert_array_equal(loading.rest_compression(), loading.free_compression(0))
    assert loading.describe(1) == "x_c = 2.500000e-03 m"
    assert list(loading.prescribed()) == ["x_c"]
    with pytest.raises(ValueError, match="element_x"):
        RollingPass(z1, ex[:4], 0.3, 2e-4, [0.0])


def test_pass_positions_dynamic_and_quasistatic():
    t, x = pass_positions("dynamic", 20.0, -0.01, 0.04, FS, 1e-4)
    np.testing.assert_allclose(np.diff(t), 1 / FS)
    np.testing.assert_allclose(x, -0.01 + 20.0 * t, atol=1e-15)
    assert x[-1] >= 0.04 > x[-2]
    t5, x5 = pass_positions("quasistatic", 5.0, -0.01, 0.04, FS, 1e-4)
    t30, x30 = pass_positions("quasistatic", 30.0, -0.01, 0.04, FS, 1e-4)
    np.testing.assert_array_equal(x5, x30)  # the same x_c for every speed
    np.testing.assert_allclose(t5, 6.0 * t30, rtol=1e-12)
    assert x5.size == 501


def test_settings_validation():
    with pytest.raises(ValueError, match="exactly one of rolling.load"):
        RollingSettings(load=500.0, d0=1e-4)
    with pytest.raises(ValueError, match="x_start < x_end"):
        RollingSettings(x_start=0.1, x_end=0.0)
    s = RollingSettings.from_config({"radius": 0.25, "load": None, "d0": 2e-4, "pass": [-0.02, 0.2]})
    assert (s.radius, s.d0, s.x_start, s.x_end) == (0.25, 2e-4, -0.02, 0.2)


def test_pass_that_starts_in_contact_is_an_error():
    mat = _material(TREAD)
    z1, ex = _flat_strip(12, 3)
    springs = _flat_springs(z1.shape, mat)
    gs = _static_kernel(z1.shape, mat)
    settings = RollingSettings(load=None, d0=5e-5, x_start=0.004, x_end=0.05)
    with pytest.raises(ValueError, match="rolling.pass: the contact is on the strip at x_start"):
        solve_rolling(z1, ex, springs, gs, gs, 5.0, settings, SolverSettings())


# --------------------------------------------------------------------------------------------
# Must-show 1: flat road, quasi-static: W = 0 and a symmetric pressure
# --------------------------------------------------------------------------------------------
def test_flat_quasistatic_pass_does_no_work_and_centres_the_pressure():
    mat = _material(TREAD)
    z1, ex = _flat_strip(40, 6)
    springs = _flat_springs(z1.shape, mat)
    gs = _static_kernel(z1.shape, mat)
    settings = RollingSettings(load=150.0, quasistatic_step=5e-5, steady_entry=0.0)  # no memory: steady once on
    res, info = solve_rolling(z1, ex, springs, gs, gs, 10.0, settings, SolverSettings())
    ds = rolling_dataset(res, info, "quasistatic", 10.0, settings, None, "flat", "tread")
    w, w_in = float(ds["work"]), float(ds["work_in"])
    assert w_in > 0
    assert abs(w) <= 1e-3 * w_in, (w, w_in)
    steady = ds["steady"].values.astype(bool)
    assert steady.sum() > 100
    offset = ds["pressure_centre"].values[steady] - ds["x_c"].values[steady]
    assert np.max(np.abs(offset)) <= 0.5e-3
    # the load is carried at the strip's centre: d0 solves F = 150 N there
    mid = np.argmin(np.abs(res.x_c - 0.5 * (ex[0] + ex[-1])))
    assert res.force[mid] == pytest.approx(150.0, rel=2e-3)
    assert res.force[0] == 0 and res.force[-1] == 0


# --------------------------------------------------------------------------------------------
# Must-show 2: flat road, dynamic, default tread: W > 0, pressure centre ahead, steady force
# --------------------------------------------------------------------------------------------
def test_flat_dynamic_pass_loses_energy_with_the_pressure_ahead(tread_greens):
    mat = _material(TREAD)
    z1, ex = _flat_strip(60, 6)
    springs = _flat_springs(z1.shape, mat)
    g, gs = _kernels(tread_greens)
    settings = RollingSettings(load=None, d0=5e-5)
    res, info = solve_rolling(z1, ex, springs, g, gs, 6.0, settings, SolverSettings())
    assert res.force.size > 256  # a long run: the tail is in use
    ds = rolling_dataset(res, info, "dynamic", 6.0, settings, None, "flat", "tread")
    assert float(ds["work"]) > 0.05 * float(ds["work_in"])
    steady = ds["steady"].values.astype(bool)
    assert steady.sum() > 20 and ds["x_c"].values[steady][0] > 0.03  # x_c - a >= 3 h onto the strip
    ahead = ds["pressure_centre"].values[steady] - ds["x_c"].values[steady]
    assert np.all(ahead > 0.05e-3)  # ahead of x_c in the rolling direction (+x)
    f = ds["force"].values[steady]
    assert np.max(np.abs(f - f.mean())) / f.mean() <= 0.005
    # the steady loss force (mean power / v) and W / dx agree for a flat strip
    assert float(ds["steady_loss_force"]) == pytest.approx(float(ds["rolling_loss_force"]), rel=0.1)


def test_dynamic_pass_at_the_wheel_load(tread_greens):
    """Issue 24: a dynamic pass with a wheel load carries that load as its steady mean force (to the load
    tolerance): the relaxed static d0 is too deep for a dynamic tread, so d0 comes down pass by pass; the
    file records the static start, the passes and the remaining error; the coefficient is the steady one."""
    mat = _material(TREAD)
    z1, ex = _flat_strip(60, 6)
    springs = _flat_springs(z1.shape, mat)
    g, gs = _kernels(tread_greens)
    settings = RollingSettings(load=60.0, load_tolerance=0.005)
    res, info = solve_rolling(z1, ex, springs, g, gs, 6.0, settings, SolverSettings())
    ds = rolling_dataset(res, info, "dynamic", 6.0, settings, None, "flat", "tread")
    assert abs(float(ds["steady_force"]) / 60.0 - 1) <= 0.005
    assert ds.attrs["load_passes"] >= 2 and abs(ds.attrs["load_error"]) <= 0.005
    assert float(ds["d0"]) < 0.9 * ds.attrs["static_d0"]  # the dynamic tread is stiffer than relaxed
    agg = aggregate_rolling([ds])
    assert float(agg["rolling_loss_coefficient"][0]) == pytest.approx(
        float(ds["steady_loss_force"]) / float(ds["steady_force"]), rel=1e-12)
    # the same static start, at a quasi-static pass: already at the load (a flat road centres the contact)
    qs, qs_info = solve_rolling(z1, ex, springs, gs, gs, 6.0, RollingSettings(load=60.0, quasistatic_step=2e-4),
                                SolverSettings())
    assert qs_info["load_passes"] == 1 and qs_info["d0"] == qs_info["static_d0"] == ds.attrs["static_d0"]


# --------------------------------------------------------------------------------------------
# Must-show 3: slow limit
# --------------------------------------------------------------------------------------------
def test_slow_rolling_tends_to_the_relaxed_quasistatic_result():
    """Linear bedding springs of 1e4 N/m (springs model ``linear``): with the full flat-punch stiffness
    (3.7e4 N/m) this lightly damped Maxwell layer makes the time march chatter at fs / 2 (a stability
    limit of the discrete kernel with stiff springs, not physics; the default tread does not)."""
    mat = _material(FAST_MAXWELL)
    shape = (20, 6)
    greens = greens_dataset(mat, shape, C, FS, 256, 4096)
    z1, ex = _flat_strip(*shape)
    springs = _flat_springs(shape, mat, stiffness=1.0e4)
    g, gs = _kernels(greens)
    assert greens.attrs["quasi_static_modulus"] == 2.5e7  # the relaxed modulus E_inf
    v = 1.0
    settings = RollingSettings(load=None, d0=5e-5, quasistatic_step=v / FS)
    dyn, _ = solve_rolling(z1, ex, springs, g, gs, v, settings, SolverSettings())
    qs, _ = solve_rolling(z1, ex, springs, gs, gs, v, settings, SolverSettings())
    assert dyn.force.size == qs.force.size > 1000
    np.testing.assert_allclose(dyn.x_c, qs.x_c, rtol=0, atol=1e-12)
    err = np.max(np.abs(dyn.force - qs.force)) / qs.force.max()
    assert err <= 0.01, err
    assert err > 1e-5  # a rate effect, just small


# --------------------------------------------------------------------------------------------
# Must-show 4: rough road, quasi-static: no rate effect
# --------------------------------------------------------------------------------------------
def test_rough_quasistatic_force_does_not_depend_on_speed():
    rng = np.random.default_rng(5)
    shape = (30, 8)
    mat = _material(TREAD)
    z1 = realistic_z1(*shape, rng)
    ex = (np.arange(shape[0]) + 0.5) * C
    k, f, step = punch_tables(z1.size, rng)
    springs = SpringTable.checked(k, f, step, z1.size)
    gs = _static_kernel(shape, mat)
    # a 30 mm strip has no steady part for a contact ~27 mm long: the pass runs at a given d0, not at a load
    settings = RollingSettings(load=None, d0=3.0e-4)
    runs = [solve_rolling(z1, ex, springs, gs, gs, v, settings, SolverSettings())
            for v in (5.0, 30.0)]
    (slow, i5), (fast, i30) = runs
    assert i5["d0"] == i30["d0"]
    np.testing.assert_array_equal(slow.x_c, fast.x_c)
    assert np.max(np.abs(slow.force - fast.force)) <= 1e-9 * slow.force.max()
    np.testing.assert_allclose(slow.time, 6.0 * fast.time, rtol=1e-12)
    assert slow.force.max() > 50.0 and np.ptp(slow.contact_count) > 10


# --------------------------------------------------------------------------------------------
# Must-show 5: dense and FFT paths agree
# --------------------------------------------------------------------------------------------
def test_dense_and_fft_rolling_agree(tread_greens):
    rng = np.random.default_rng(11)
    shape = (30, 10)
    z1 = realistic_z1(*shape, rng)
    ex = (np.arange(shape[0]) + 0.5) * C
    k, f, step = punch_tables(z1.size, rng)
    springs = SpringTable.checked(k, f, step, z1.size)
    g, gs = _kernels(tread_greens)
    settings = RollingSettings(load=None, d0=6e-5)
    out = {}
    for method in ("dense", "fft"):
        out[method], _ = solve_rolling(z1, ex, springs, g, gs, 8.0, settings, SolverSettings(method=method))
    dense, fft = out["dense"], out["fft"]
    assert dense.force.size > 256
    assert np.max(np.abs(dense.force - fft.force)) <= 1e-10 * dense.force.max()
    np.testing.assert_allclose(fft.snapshot_force, dense.snapshot_force, rtol=0, atol=1e-10 * dense.force.max())


# --------------------------------------------------------------------------------------------
# Spectra and aggregation
# --------------------------------------------------------------------------------------------
def test_third_octave_centres_and_band_level_of_a_tone():
    centres = third_octave_centres(100.0, 5000.0)
    assert centres.size == 18
    assert centres[0] == pytest.approx(100.0) and centres[-1] == pytest.approx(5011.9, rel=1e-4)
    dt = 1 / FS
    t = np.arange(4096) * dt
    amp = 3.0
    x = 500.0 + amp * np.sin(2 * np.pi * 1000.0 * t)
    levels = band_levels(x, dt, centres)
    i = int(np.argmin(np.abs(centres - 1000.0)))
    # the tone's mean square A^2/2, within the Hann window's scalloping of a fraction of a dB
    assert levels[i] == pytest.approx(10 * math.log10(amp**2 / 2), abs=0.3)
    assert np.nanmax(np.delete(levels, i)) < levels[i] - 20
    short = band_levels(x[:200], dt, centres)  # 3.9 ms: bands below 2 / T are not resolved
    assert np.isnan(short[0]) and np.isfinite(short[i])


def test_aggregate_and_report_section():
    mat = _material(TREAD)
    z1, ex = _flat_strip(24, 4)
    springs = _flat_springs(z1.shape, mat)
    gs = _static_kernel(z1.shape, mat)
    settings = RollingSettings(load=None, d0=5e-5, quasistatic_step=2.5e-5, steady_entry=0.0)
    runs = []
    for v in (5.0, 20.0):
        res, info = solve_rolling(z1, ex, springs, gs, gs, v, settings, SolverSettings())
        runs.append(rolling_dataset(res, info, "quasistatic", v, settings, None, "flat", "tread"))
    agg = aggregate_rolling(runs)
    from tyreroad.io import check_metadata

    for ds in (agg, *runs):
        check_metadata(ds)  # units and long_name on every variable (write_dataset's contract)
    # a level in dB is dimensionless for CF (UDUNITS-2 has no dB): its reference is stated apart
    assert agg["band_level"].attrs["units"] == "1" and agg["band_level"].attrs["reference_value"] == 1.0
    assert agg["band_level"].attrs["reference_value_units"] == "N"
    assert agg.sizes["case"] == 2 and agg.sizes["band"] == 18
    np.testing.assert_array_equal(agg["force_curve"].values[0], agg["force_curve"].values[1])
    # a quasi-static pass on a flat road does no net work (SPEC 12): W is only the trapezoid rule's residue
    # (a small part of the work the belt puts in while the contact grows, 0.2 mJ at d0 = 0.05 mm); the same
    # at both speeds
    w, w_in = agg["work"].values, agg["work_in"].values
    assert np.all(w_in > 1e-4)
    assert np.all(np.abs(w) <= 1e-4 * w_in)
    assert w[0] == w[1]
    np.testing.assert_array_equal(agg["rolling_loss_force"].values, w / agg.attrs["strip_length"])
    assert np.all(steady_mask(runs[0]["x_c"].values, info, 2, 0.0) == runs[0]["steady"].values.astype(bool))
    # a dynamic pass whose force alternates step by step (fs/2 chatter) is flagged, never reported as physics
    chat = runs[1].copy(deep=True)
    chat.attrs["mode"] = "dynamic"
    chat["force"] = chat["force"] + 5.0 * (-1.0) ** np.arange(chat.sizes["step"])
    chat["steady"] = chat["steady"].copy(data=(runs[1]["force"].values > 0).astype(np.int8))
    flagged = aggregate_rolling([runs[0], chat])
    assert float(flagged["chatter"][1]) > 2 * 0.05 and float(flagged["chatter"][0]) == 0.0
    assert "Not trustworthy: tread at 20 m/s" in "\n".join(rolling_section(ReportContext(rolling=flagged)))
    text = "\n".join(rolling_section(ReportContext(rolling=agg)))
    assert "| tread | quasistatic | 5 |" in text and "| tread | quasistatic | 20 |" in text
    assert "differs by at most 0.0e+00 of its peak" in text
    from tyreroad.report import build_rolling_report

    md = build_rolling_report(agg, figures=["figures/fig11_rolling_force.png", "figures/fig14_contact_map.png"])
    assert "![fig14_contact_map](figures/fig14_contact_map.png)" in md
    assert md.index("## Figures") < md.index("## Config")
    # what the passes ran on travels into rolling.nc when they agree, and is flagged when they do not
    tagged = [r.copy() for r in runs]
    for r in tagged:
        r.attrs.update(spring_rheology="qlv", kernel_construction="radau")
    assert aggregate_rolling(tagged).attrs["spring_rheology"] == "qlv"
    tagged[0].attrs["spring_rheology"] = "elastic"
    assert aggregate_rolling(tagged).attrs["spring_rheology"] == "mixed: elastic, qlv"
    # the QLV-springs comparison (issue 24): matched pass by pass, the ratio of the steady loss forces
    qlv = agg.copy(deep=True)
    qlv.attrs["spring_rheology"] = "qlv"
    qlv["steady_loss_force"] = qlv["steady_loss_force"] * 1.5 + 1e-3
    qlv["mode"] = ("case", np.array(["dynamic", "quasistatic"]))
    agg2 = agg.copy()
    agg2["mode"] = qlv["mode"]
    section = "\n".join(rolling_spring_comparison_section(
        ReportContext(rolling=qlv, rolling_reference=agg2, rolling_reference_label="results-elastic")))
    ratio = (1.5 * float(agg["steady_loss_force"][0]) + 1e-3) / float(agg["steady_loss_force"][0])
    assert "springs are `qlv`, those of `results-elastic` `elastic (not recorded)`" in section
    assert f"| tread | dynamic | 5 |" in section and f"| {ratio:.3f} |" in section
    assert f"{ratio:.3f}-{ratio:.3f} times" in section  # only the dynamic pass counts in the summary
    missing = rolling_spring_comparison_section(ReportContext(rolling=qlv, rolling_reference_label="results-elastic"))
    assert any("`results-elastic/rolling.nc` is missing" in line for line in missing)
    other = agg2.copy()
    other.attrs["strip_length"] = 0.3
    assert any(line.startswith("Not compared") for line in rolling_spring_comparison_section(
        ReportContext(rolling=qlv, rolling_reference=other, rolling_reference_label="r")))
    assert rolling_spring_comparison_section(ReportContext(rolling=qlv)) == []  # no spring_comparison: no section


def test_static_indentation_carries_the_load():
    mat = _material(TREAD)
    z1, ex = _flat_strip(20, 4)
    springs = _flat_springs(z1.shape, mat)
    gs = _static_kernel(z1.shape, mat)
    d0 = static_indentation(z1, ex, springs, gs, 0.3, 60.0, 0.01, SolverSettings())
    loading = RollingPass(z1, ex, 0.3, d0, [0.01])
    from tyreroad.rolling import _march

    res = _march(loading, springs, gs, SolverSettings(), 1)
    assert res.force[0] == pytest.approx(60.0, rel=1e-9)
    with pytest.raises(ValueError, match="rolling.load"):
        static_indentation(z1, ex, springs, gs, 0.3, 1e9, 0.01, SolverSettings())


# --------------------------------------------------------------------------------------------
# Config: planning-time checks of the rolling section
# --------------------------------------------------------------------------------------------
def test_rolling_config_checks_name_the_key():
    from pathlib import Path

    from tyreroad import config as CFG

    root = Path(__file__).resolve().parents[1]
    base = CFG.load_config(root / "config" / "config.yaml")
    schema = root / "workflow" / "schemas" / "config.schema.yaml"
    CFG.validate_schema(base, schema)
    CFG.check_config(base, base_dir=root)
    flat = CFG.load_config(root / "config" / "config.yaml", root / "config" / "rolling-flat.yaml")
    CFG.validate_schema(flat, schema)
    CFG.check_config(flat, base_dir=root)
    bad = [
        ({"surfaces": ["nowhere"]}, r"rolling.surfaces\[0\] = 'nowhere': not a preset"),
        ({"materials": ["tread", "rubber-x"]}, r"rolling.materials\[1\] = 'rubber-x'"),
        ({"d0": 2e-4}, "exactly one of rolling.load"),
        ({"pass": [0.1, -0.01]}, "x_start < x_end"),
        ({"reference_material": "tread-rho2", "materials": ["tread"]}, "rolling.reference_material"),
    ]
    for change, match in bad:
        cfg = CFG.merge(base, {"rolling": change})
        with pytest.raises(CFG.ConfigError, match=match):
            CFG.check_config(cfg, base_dir=root)
    with pytest.raises(CFG.ConfigError, match="rolling.radius"):
        CFG.validate_schema(CFG.merge(base, {"rolling": {"radius": -1.0}}), schema)
    with pytest.raises(CFG.ConfigError, match="speed label '20.0'"):
        CFG.check_job(base, "x.nc", {"surface": "iso10844-strip", "material": "tread", "mode": "dynamic", "speed": "20.0"})
    CFG.check_job(base, "x.nc", {"surface": "iso10844-strip", "material": "tread", "mode": "dynamic", "speed": "20"})


def test_flat_generator_and_strip_patch():
    ds = prepare_surface("flat", {"generator": "flat", "patch_elements": [12, 3], "field_size": [0.02, 0.01]})
    assert ds["z1"].shape == (12, 3) and float(np.abs(ds["z1"]).max()) == 0.0
    assert np.isnan(float(ds["skewness"])) and float(ds["rms_height"]) == 0.0
    assert ds.attrs["patch_selection"] == "centre"
    with pytest.raises(ValueError, match=r"surfaces.flat.seed_x: unknown key"):
        prepare_surface("flat", {"generator": "flat", "seed_x": 1})


def test_contact_holes_count_force_free_elements_inside_a_rows_contact():
    """A flat-road contact with one force-free element inside a row (the gap an fs/2 alternation opens) and
    one outside every row's contact: one hole. Snapshots off the steady part are not judged."""
    import xarray as xr

    from tyreroad.rolling.dataset import contact_holes

    forces = np.zeros((2, 8, 3))
    forces[0, 2:7, :] = 1.0
    forces[0, 4, 1] = 0.0  # inside row 1's contact: a hole
    forces[1, 1:7, 0] = 1.0
    forces[1, 3:5, 0] = 0.0  # two holes, but this snapshot is off the steady part
    run = xr.Dataset({"element_force": (("snapshot", "ex", "ey"), forces),
                      "snapshot_step": ("snapshot", [5, 1]),
                      "steady": ("step", np.array([0, 0, 1, 1, 1, 1, 1, 0], np.int8))})
    assert contact_holes(run) == 1
    run["steady"][:] = 1
    assert contact_holes(run) == 2


def test_rolling_report_judges_alternation_against_the_mean_force_and_flat_road_holes():
    """The flat-road 5 m/s failure the kernel issue measured: its chatter over the fluctuation looks like the
    correct 20 m/s pass, but the alternation over the mean force (and the contact's hole) flags it."""
    import xarray as xr

    from tyreroad.report.claims import THRESHOLDS
    from tyreroad.report.sections import _rolling_stability_lines, _untrustworthy_rolling_cases

    n = 4
    study = xr.Dataset({
        "material": ("case", ["tread"] * n), "mode": ("case", ["dynamic"] * 3 + ["quasistatic"]),
        "speed": ("case", [5.0, 10.0, 20.0, 5.0]), "chatter": ("case", [0.0, 0.0, 0.0, 0.0]),
        "fs2_alternation": ("case", [3.7e-2, 5e-5, 2e-5, np.nan]),
        "margin_critical_stiffness": ("case", [1.2e5, 1.2e5, 1.2e5, np.nan]),
        "max_spring_stiffness": ("case", [4e4, 4e4, 4e4, np.nan]),
        "contact_holes": ("case", [0, 2, 0, 0]), "flat_road": ("case", [1, 1, 1, 1]),
        "element_rate": ("case", [5e3, 1e4, 1.2e4, 5e3]), "sample_rate": ("case", [51200.0] * n),
        "centre_offset": ("case", [1e-4, 2e-4, 3e-4, 0.0]), "steady_loss_force": ("case", [1.0, 1.2, 1.3, 0.0]),
    })
    assert _untrustworthy_rolling_cases(study, THRESHOLDS) == [0, 1]
    text = "\n".join(_rolling_stability_lines(study, THRESHOLDS))
    assert "| tread | 5 | 1.2e+05 | 4e+04 | 3.70e-02 | nan | nan | nan | 0 | fails |" in text
    assert "| tread | 10 | 1.2e+05 | 4e+04 | 5.00e-05 | nan | nan | nan | 2 | fails |" in text
    assert "| tread | 20 | 1.2e+05 | 4e+04 | 2.00e-05 | nan | nan | nan | 0 | holds |" in text
    assert "0.100, 0.200, 0.300 mm (monotone)" in text and "1, 1.2, 1.3 N (monotone)" in text
    # on a rough road, a pass whose texture input reaches past fs/4 is reported, not judged
    rough = study.assign(flat_road=("case", [0, 0, 0, 0]), element_rate=("case", [5e3, 1e4, 2e4, 5e3]),
                         sample_rate=("case", [51200.0] * n), fs2_alternation=("case", [3.7e-2, 5e-5, 2e-4, np.nan]))
    assert _untrustworthy_rolling_cases(rough, THRESHOLDS) == [0]
    assert "| tread | 20 | 1.2e+05 | 4e+04 | 2.00e-04 | nan | nan | nan | (rough road) | not judged (input near fs/2) |" in "\n".join(
        _rolling_stability_lines(rough, THRESHOLDS))
    # springs stiffer than the certified margin (tread-eta0.5 on the default strip) are marked in the table
    past = rough.assign(margin_critical_stiffness=("case", [6.05e4, 6.05e4, 6.05e4, np.nan]),
                        max_spring_stiffness=("case", [6.8e4, 6.8e4, 6.8e4, np.nan]))
    assert "| tread | 10 | 6.05e+04 | 6.8e+04 (past k_crit) | 5.00e-05 |" in "\n".join(
        _rolling_stability_lines(past, THRESHOLDS))


def test_alternation_without_input_lines_removes_the_element_ripple_not_an_instability():
    """The flat road at 10 m/s: element rows enter at 10 kHz; the lines at 10, 20 and 30 (aliased to 21.2) kHz
    read 1.9e-4 by the fourth difference and nothing once fitted out, while an fs/2 alternation of 1e-3 is
    kept whole, and so is a line in the top band (24 kHz input: it cannot be told from an instability)."""
    from tyreroad.rolling.dataset import alternation_without_input_lines
    from tyreroad.stability import fs2_alternation

    fs, n = 51200.0, np.arange(3000)
    ripple = 500.0 * (1 + 1.8e-3 * np.sin(2 * np.pi * 1e4 * n / fs + 0.3) + 1.5e-4 * np.sin(2 * np.pi * 2e4 * n / fs + 1)
                      + 1.5e-4 * np.cos(2 * np.pi * 3e4 * n / fs))
    whole = np.ones(n.size, bool)
    assert fs2_alternation(ripple, window=whole) == pytest.approx(1.87e-4, rel=0.01)
    assert alternation_without_input_lines(ripple, 1e4, fs) < 1e-12
    unstable = ripple + 0.5 * (-1.0) ** n
    assert alternation_without_input_lines(unstable, 1e4, fs) == pytest.approx(1e-3, rel=1e-3)
    top = 500.0 * (1 + 1e-3 * np.cos(2 * np.pi * 2.4e4 * n / fs))
    assert alternation_without_input_lines(top, 2.4e4, fs) == pytest.approx(fs2_alternation(top, window=whole),
                                                                            rel=1e-3)
    assert np.isnan(alternation_without_input_lines(ripple[:20], 1e4, fs))
    # a rough road's force (large, broadband, low-frequency): removing lines never raises the measure (a fit
    # to the force itself leaked the texture into the lines near fs/2 and read 30x the raw value)
    rough = 500.0 + np.cumsum(np.random.default_rng(3).normal(0.0, 1.0, n.size)) + ripple - 500.0
    assert alternation_without_input_lines(rough, 5e3, fs) <= fs2_alternation(rough, window=whole)


def test_rolling_report_names_the_cause_of_each_failing_pass():
    """The verdict reads the alternation without the road's input lines: the flat road at 10 m/s (raw 1.92e-4,
    1.8e-5 without its element-entry lines) holds. A failing pass stays out of the range whatever its cause, but
    the report says which it is: a march instability (top band past the limit, or growing), a steady alternation
    left after the lines are out, an input line in the top band, chatter, or holes; a record without the
    line-free column is judged by the raw value and its steady ripple named."""
    import xarray as xr

    from tyreroad.report.claims import THRESHOLDS
    from tyreroad.report.sections import ReportContext, _rolling_failure_cause, rolling_section

    n = 5
    study = xr.Dataset({
        "material": ("case", ["tread"] * n), "mode": ("case", ["dynamic"] * n),
        "speed": ("case", [10.0, 5.0, 6.0, 7.0, 8.0]), "chatter": ("case", [0.0, 0.0, 0.0, 0.5, 0.0]),
        "fs2_alternation": ("case", [1.92e-4, 3.7e-2, 2e-4, 1e-6, 1e-6]),
        "fs2_band_amplitude": ("case", [3.4e-6, 3.6e-2, 2e-6, 1e-7, 1e-7]),
        "alternation_growth": ("case", [1.0, 1.0, 1.5, 1.0, 1.0]),
        "alternation_input_removed": ("case", [1.8e-5, 3.7e-2, 2e-4, 1e-6, 1e-6]),
        "contact_holes": ("case", [0, 0, 0, 0, 3]), "flat_road": ("case", [1, 1, 1, 0, 1]),
        "element_rate": ("case", [1e4, 4.5e3, 4.5e3, 7e3, 8e3]), "sample_rate": ("case", [51200.0] * n),
    })
    from tyreroad.report.sections import _untrustworthy_rolling_cases

    assert _untrustworthy_rolling_cases(study, THRESHOLDS) == [1, 2, 3, 4]
    causes = [_rolling_failure_cause(study, i, THRESHOLDS) for i in range(n)]
    assert causes[0] == "see the stability table"  # holds: nothing to explain
    # the same record without the line-free column: judged by the raw value, its steady ripple named
    raw = study.drop_vars("alternation_input_removed")
    assert _untrustworthy_rolling_cases(raw, THRESHOLDS) == [0, 1, 2, 3, 4]
    ripple = _rolling_failure_cause(raw, 0, THRESHOLDS)
    assert ripple.startswith("fs/2 alternation 1.92e-04 (limit 1e-04), but its top band is 3.4e-06 and it does "
                             "not grow (1.00)") and "entering the contact at v / element size = 10 kHz" in ripple
    assert ripple.endswith("not a march instability")
    # past the limit even without the lines, steady and outside the top band: not explained, not excused
    rest = study.isel(case=[0]).assign(alternation_input_removed=("case", [1.5e-4]))
    assert _untrustworthy_rolling_cases(rest, THRESHOLDS) == [0]
    assert _rolling_failure_cause(rest, 0, THRESHOLDS).startswith(
        "fs/2 alternation 1.92e-04, 1.50e-04 without the road's input lines (limit 1e-04), but its top band is "
        "3.4e-06 and it does not grow (1.00): a steady alternation the record does not explain")
    assert causes[1].endswith("top band 0.036, growth 1.00: a march instability")
    assert causes[2].endswith("growth 1.50: a march instability")  # small top band, but growing
    assert causes[3].startswith("chatter 0.5 of the fluctuation (limit 0.05)")
    assert causes[4] == "3 force-free elements inside a row of the flat road's contact"
    # 12.5 m/s on 1 mm: the input's second line is at 25 kHz, in the top band: not called an instability outright
    line = study.isel(case=[0]).assign(element_rate=("case", [1.25e4]), fs2_band_amplitude=("case", [2.5e-4]),
                                       alternation_input_removed=("case", [2e-4]))
    assert _rolling_failure_cause(line, 0, THRESHOLDS).endswith(
        "either a march instability or the road input's line 2 x v / element size = 25 kHz, which aliases into the "
        "top band, where the record cannot tell them apart")
    text = "\n".join(rolling_section(ReportContext(rolling=study.assign(
        d0=("case", [1e-4] * n), steady_force=("case", [500.0] * n), rolling_loss_force=("case", [1.0] * n),
        rolling_loss_coefficient=("case", [2e-3] * n), steady_loss_force=("case", [1.0] * n),
        centre_offset=("case", [1e-3] * n), fluctuation_rms=("case", [1.0] * n),
        strongest_band=("case", [1e3] * n), band_level=(("case", "band"), np.zeros((n, 2)))).assign_attrs(
        radius=0.3, surface="flat", strip_length=0.15))))
    assert "- tread at 10 m/s:" not in text and "- tread at 7 m/s: chatter 0.5" in text
    assert "| tread | 10 | " in text and "1.92e-04 | 1.80e-05 |" in text and "| holds |" in text


def test_top_band_amplitude_tells_an_instability_from_the_element_ripple():
    """A stationary ripple at the element rate (10 kHz at 10 m/s over 1 mm elements) has no top-band
    component and does not grow; a growing fs/2 alternation has both."""
    from tyreroad.rolling.dataset import fs2_band_amplitude

    fs, n = 51200.0, np.arange(600)
    ripple = 500.0 * (1 + 1.5e-3 * np.sin(2 * np.pi * 1e4 * n / fs))
    band, growth = fs2_band_amplitude(ripple)
    assert band < 1e-5 and growth == pytest.approx(1.0, abs=0.05)
    alternation = 500.0 * (1 + 1e-4 * (-1.0) ** n * 1.005 ** n)
    band, growth = fs2_band_amplitude(alternation)
    assert band > 1e-3 and growth > 5.0


def test_recorder_keeps_the_contact_extent_of_every_step():
    """The span of the engaged elements (force or tangent stiffness > 0) along x and y, per step; the largest
    along x over the pass and its step."""
    from types import SimpleNamespace

    from tyreroad.rolling.geometry import RollingPass
    from tyreroad.rolling.recorder import RollingRecorder

    z1 = np.zeros((8, 3))
    loading = RollingPass(z1, np.arange(8) * 1e-3, 0.3, 1e-4, np.array([0.0, 1e-3, 2e-3]))
    rec = RollingRecorder(loading, [])
    for n, (force_at, stiff_at) in enumerate([([], []), ([(2, 1), (4, 0)], []), ([(1, 2)], [(6, 0)])]):
        f, k = np.zeros(z1.size), np.zeros(z1.size)
        for ix, iy in force_at:
            f[ix * 3 + iy] = 1.0
        for ix, iy in stiff_at:
            k[ix * 3 + iy] = 1e4
        rec.store(n, SimpleNamespace(force=f, stiffness=k, newton_iterations=1, krylov_iterations=0, residual=0.0), None)
    result = rec.result(loading)
    assert result.contact_extent.tolist() == [[0, 0], [3, 2], [6, 3]]
    assert result.largest_contact_extent() == ((6, 3), 2)
