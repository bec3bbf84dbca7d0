"""The sensitivity sweep (tyreroad.sensitivity): settings, presets, one real point, conclusions.

The point test runs the real stages on a 6 x 6 patch (Green's functions with 64 lags) to
d_max = 0.1 mm, and checks the sweep against direct calls of the same stage functions.
"""

from __future__ import annotations

import copy
import logging
from pathlib import Path

import numpy as np
import pytest
import yaml

from tyreroad import sensitivity as S
from tyreroad.contact import SolverSettings, contact_dataset, solve_run
from tyreroad.greens import GreensSettings
from tyreroad.log import format_duration
from tyreroad.material import material_from_config
from tyreroad.pipeline import build_greens, resolved_material_config
from tyreroad.report import THRESHOLDS
from tyreroad.springs import SpringModel, element_springs, resolve_spring_modulus
from tyreroad.study import StudySettings, aggregate
from tyreroad.surface import prepare_surface

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def cfg():
    base = yaml.safe_load((ROOT / "config/config.yaml").read_text())
    overlay = yaml.safe_load((ROOT / "config/test.yaml").read_text())
    base["surfaces"]["iso10844"].update(overlay["surfaces"]["iso10844"])
    base["solver"].update(overlay["solver"])
    base["study"].update(overlay["study"])
    base["greens"].update(overlay["greens"])
    return base


# ----------------------------------------------------------------------------------------------
# settings and presets
# ----------------------------------------------------------------------------------------------
def test_settings_defaults_and_errors():
    st = S.SensitivitySettings.from_config({"points": {"a": None, "b": {"material": {"alpha": 0.1}}}})
    assert st.acceleration == 500.0 and st.target_stiffness == 2.75e6 and st.loss_scales == (0.5, 1.5)
    assert st.points["a"] == {"description": "a", "material": {}, "surface": {}, "calibrate": True}
    with pytest.raises(ValueError, match="section 'sensitivity' is missing"):
        S.SensitivitySettings.from_config(None)
    with pytest.raises(ValueError, match="sensitivity.points must be a non-empty"):
        S.SensitivitySettings.from_config({"points": {}})
    with pytest.raises(ValueError, match=r"sensitivity.points.a: unknown key\(s\) \['colour'\]"):
        S.SensitivitySettings.from_config({"points": {"a": {"colour": 1}}})
    with pytest.raises(ValueError, match="sensitivity.loss_scales"):
        S.SensitivitySettings.from_config({"points": {"a": {}}, "loss_scales": [1.5, 0.5]})
    with pytest.raises(ValueError, match="unknown key"):
        S.SensitivitySettings.from_config({"points": {"a": {}}, "speed": 1})
    with pytest.raises(ValueError, match="point name"):
        S.SensitivitySettings.from_config({"points": {"a_b": {}}})


def test_point_presets_and_modulus_scaling(cfg):
    ref = resolved_material_config("tread", cfg["materials"])
    p = S.point_material_preset(ref, {"alpha": 0.12})
    assert p["alpha"] == 0.12 and p["E0"] == ref["E0"] and ref["alpha"] == 0.24
    gm = S.point_material_preset(ref, {"model": "generalized_maxwell", "E_inf": 2.5e7, "moduli": [1e7],
                                       "relaxation_times": [1e-4]})
    assert "E0" not in gm and "alpha" not in gm and gm["density"] == ref["density"] and gm["thickness"] == ref["thickness"]
    w = 2 * np.pi * np.geomspace(1, 2e4, 9)
    for preset in (ref, gm, dict(ref, quasi_static_modulus=3e7)):
        m1 = material_from_config("m", {"m": preset})
        m2 = material_from_config("m", {"m": S.scale_moduli(preset, 1.3)})
        np.testing.assert_allclose(m2.modulus(w), 1.3 * m1.modulus(w), rtol=1e-12)
        assert m2.quasi_static_modulus == pytest.approx(1.3 * m1.quasi_static_modulus, rel=1e-12)
        assert m2.density == m1.density
    spec = S.point_surface_spec(cfg["surfaces"]["iso10844"], {"roller_level": None})
    assert spec["roller_level"] is None and cfg["surfaces"]["iso10844"]["roller_level"] == 0.0
    with pytest.raises(ValueError, match="sensitivity.points.bad.material"):
        S.check_points(S.SensitivitySettings.from_config({"points": {"bad": {"material": {"alpha": 1.5}}}}), ref)


def test_loss_variants_are_causal_and_a_seed_point_is_refused(cfg):
    """The sweep runs in the time domain: its loss variants scale the phase (|E| kept at loss_anchor, or at the
    point material's own anchor), and a point whose material is a seed (constant-|E|) variant stops planning."""
    ref = resolved_material_config("tread", cfg["materials"])
    st = S.SensitivitySettings.from_config({"points": {"a": None}})
    assert st.loss_anchor == 1000.0
    v = S.loss_variant_preset(ref, 1.5, st)
    assert v["loss_scale"] == 1.5 and v["loss_anchor"] == 1000.0
    m = material_from_config("v", {"v": v})
    assert m.is_causal and abs(m.modulus(2 * np.pi * 1000.0)) == pytest.approx(
        abs(material_from_config("r", {"r": ref}).modulus(2 * np.pi * 1000.0)), rel=1e-13)
    own = S.loss_variant_preset(dict(ref, loss_scale=0.3, loss_anchor=0.0), 0.5, st)
    assert own["loss_scale"] == pytest.approx(0.15) and own["loss_anchor"] == 0.0
    seed = S.SensitivitySettings.from_config({"points": {"lowloss": {"material": {"loss_scale": 0.3}}}})
    with pytest.raises(ValueError, match=r"^sensitivity\.points\.lowloss\.material = 'lowloss': .*not causal.*"
                                         r"sensitivity\.points\.lowloss\.material\.loss_anchor: 1000\.0"):
        S.check_points(seed, ref)
    S.check_points(S.SensitivitySettings.from_config(cfg["sensitivity"]), ref)  # the shipped sweep is causal


def test_planned_points_and_files(cfg):
    assert S.planned_points({k: v for k, v in cfg.items() if k != "sensitivity"}) == {}
    with pytest.raises(ValueError, match="no 'sensitivity' section"):
        S.point_files({})
    pts = S.planned_points(cfg)
    assert "reference" in pts and S.point_files(pts)[0] == "results/sensitivity/reference.nc"


# ----------------------------------------------------------------------------------------------
# one real point
# ----------------------------------------------------------------------------------------------
def _direct_run(cfg, surface, preset, name, mode, accel):
    """The contact dataset of one run by direct calls of the stage functions (what the study's rules do)."""
    mat = material_from_config(name, {name: preset})
    model = SpringModel.from_config(cfg["springs"])
    springs = element_springs(surface, model, modulus=resolve_spring_modulus(model, mat.quasi_static_modulus),
                              poisson=mat.poisson, thickness=mat.thickness)
    # the kernel the greens rule makes (run_greens writes build_greens' dataset): the configured construction
    greens = build_greens(mat, (6, 6), 1e-3, GreensSettings.from_config(cfg["greens"]))
    res = solve_run(surface, springs, greens, mat, mode, accel, SolverSettings.from_config(cfg["solver"]))
    return contact_dataset(res, mode, accel, "iso10844", name)


class _TickingClock:
    """A fake monotonic clock that advances ``tick`` seconds at each reading."""

    def __init__(self, tick):
        self.now, self.tick = 1000.0, tick

    def __call__(self):
        self.now += self.tick
        return self.now


class _Lines(logging.Handler):
    def __init__(self):
        super().__init__(logging.INFO)
        self.lines = []

    def emit(self, record):
        self.lines.append(record.getMessage())


#: The progress lines of each point of the fixture (the run is too long to repeat for them).
PROGRESS_LINES: dict[str, list[str]] = {}


@pytest.fixture(scope="module")
def points(cfg):
    ref = resolved_material_config("tread", cfg["materials"])
    sens = {"acceleration": 500.0, "target_stiffness": 1.2e5, "calibration_tolerance": 0.005}
    out = {}
    log = logging.getLogger("tyreroad.sensitivity")
    for name, point in {"plain": {"calibrate": False}, "calibrated": {"material": {"alpha": 0.4}}}.items():
        st = S.point_settings(sens, name, point)
        handler, level = _Lines(), log.level
        log.addHandler(handler)
        log.setLevel(logging.INFO)
        try:
            out[name] = S.run_point(name, st.points[name], ref, cfg["surfaces"]["iso10844"], cfg["springs"],
                                    cfg["greens"], cfg["solver"], cfg["study"], st, clock=_TickingClock(10.0))
        finally:
            log.removeHandler(handler)
            log.setLevel(level)
        PROGRESS_LINES[name] = [line for line in handler.lines if line.startswith(f"point {name}: run ")]
    return out


def test_point_progress_lines_of_real_points(points):
    """Each run of a point logs a line with the time left (fake clock: every run takes 10 s)."""
    assert PROGRESS_LINES["plain"] == [
        "point plain: run 1 of 5 done (calibration 1, dynamic a=500), elapsed 10 s, about 40 s left",
        "point plain: run 2 of 5 done (eta-low, dynamic a=500), elapsed 20 s, about 30 s left",
        "point plain: run 3 of 5 done (eta-high, dynamic a=500), elapsed 30 s, about 20 s left",
        "point plain: run 4 of 5 done (rho-high, dynamic a=500), elapsed 40 s, about 10 s left",
        "point plain: run 5 of 5 done (reference, quasistatic a=0), elapsed 50 s",
    ]
    n_cal = int(points["calibrated"]["calibration_runs"].item())
    lines = PROGRESS_LINES["calibrated"]
    assert len(lines) == n_cal + 4
    for k, line in enumerate(lines[:n_cal], start=1):  # while calibrating the total is an estimate
        assert line.startswith(f"point calibrated: run {k} of ~") and f"(calibration {k}, dynamic a=500)" in line
    assert lines[n_cal].startswith(f"point calibrated: run {n_cal + 1} of {n_cal + 4} done (eta-low, ")
    assert lines[-1] == (f"point calibrated: run {n_cal + 4} of {n_cal + 4} done (reference, quasistatic a=0), "
                         f"elapsed {format_duration(10 * (n_cal + 4))}")


def test_point_progress_total_follows_the_calibration(caplog):
    class FakeClock:
        def __init__(self):
            self.now = 1000.0

        def __call__(self):
            return self.now

    clock = FakeClock()
    pp = S.PointProgress("soft", calibrate=True, clock=clock)
    assert pp.total == 6  # first run + one proportional step + 4 variant runs
    with caplog.at_level(logging.INFO, logger="tyreroad.sensitivity"):
        clock.now += 60.0
        assert pp.run_done("calibration 1, dynamic a=500") == (
            "point soft: run 1 of ~6 done (calibration 1, dynamic a=500), elapsed 1 min 00 s, about 5 min 00 s left")
        pp.calibration_step(2)
        assert pp.total == 6
        clock.now += 60.0
        pp.run_done("calibration 2, dynamic a=500")
        pp.calibration_step(3)  # the secant step: one more than estimated
        assert pp.total == 7
        clock.now += 60.0
        assert pp.run_done("calibration 3, dynamic a=500").endswith("run 3 of ~7 done (calibration 3, dynamic a=500), "
                                                                     "elapsed 3 min 00 s, about 4 min 00 s left")
        pp.calibrated(3)
        clock.now += 30.0
        assert pp.run_done("eta-low, dynamic a=500") == (
            "point soft: run 4 of 7 done (eta-low, dynamic a=500), elapsed 3 min 30 s, about 2 min 38 s left")
    assert [r.getMessage() for r in caplog.records if r.name == "tyreroad.sensitivity"][-1].startswith(
        "point soft: run 4 of 7 done")
    # a point that converges at once: the estimate shrinks to the runs it makes
    quick = S.PointProgress("quick", calibrate=True, clock=clock)
    quick.run_done("calibration 1, dynamic a=500")
    quick.calibrated(1)
    assert quick.total == 5


def test_point_matches_the_study_of_the_same_runs(cfg, points):
    """The point's K(d), contact fraction and K_sat are those study.aggregate makes of the same runs."""
    ds = points["plain"].isel(point=0)
    ref = resolved_material_config("tread", cfg["materials"])
    surface = prepare_surface("iso10844", cfg["surfaces"]["iso10844"])
    assert float(ds["modulus_factor"]) == 1.0 and int(ds["calibration_runs"]) == 1
    high = dict(ref, loss_scale=1.5, loss_anchor=1000.0)  # the sweep's loss variants are causal (issue 24)
    runs = [_direct_run(cfg, surface, preset, name, mode, a) for name, preset in (("ref", ref), ("high", high))
            for mode, a in (("quasistatic", 0.0), ("dynamic", 500.0))]
    settings = StudySettings.from_config({**{k: cfg["study"][k] for k in ("indentation_step", "saturation_range")},
                                          "surface": "iso10844", "reference_material": "ref",
                                          "materials": ["ref", "high"], "accelerations": [500.0]},
                                         d_max=cfg["solver"]["d_max"])
    study = aggregate(runs, settings)
    np.testing.assert_array_equal(ds["indentation"].values, study["indentation"].values)
    for variant, (material, mode, a) in {"reference": ("ref", "dynamic", 500.0), "eta-high": ("high", "dynamic", 500.0),
                                         "quasistatic": ("ref", "quasistatic", 0.0)}.items():
        case = study.study.sel_case(material, mode, a)
        point = ds.sel(variant=variant)
        # bit for bit: one implementation of K(d) (a quasi-static run: the tangent's Hermite interpolant, and
        # the contact fraction counted between the solved states, which the sweep's own copy had not done)
        np.testing.assert_array_equal(point["stiffness"].values, case["stiffness"].values)
        np.testing.assert_array_equal(point["contact_fraction"].values, case["contact_fraction"].values)
        assert float(point["saturated_stiffness"]) == float(case["saturated_stiffness"])
    ks = ds["saturated_stiffness"]
    delta = ds["loss_delta"].values
    k_ref = float(ks.sel(variant="reference"))
    np.testing.assert_allclose(delta, [float(ks.sel(variant=v)) / k_ref - 1 for v in ("eta-low", "eta-high")], rtol=1e-12)
    assert str(ds["claim6_verdict"].values) in ("holds", "size holds, direction opposite", "fails")
    assert float(ds["density_delta"]) == pytest.approx(float(ks.sel(variant="rho-high")) / k_ref - 1, rel=1e-12)
    # the dynamic run is stiffer than the quasi-static one: the equivalent factor exceeds 1
    assert float(ds["equivalent_modulus_scale"]) > 1.2
    assert int(ds["contact_runs"]) == 5 and float(ds["wall_time"]) > 0


def _synthetic_runs(density_ripple=0.03):
    """Runs of a point with known curves: K = S (1 - exp(-d/s)) plus a decaying 25 um ripple; the loss
    variants scale K by 0.975 / 1.03 (the seed's direction, ~3 %), the density variant by 1.01 with a
    ripple ``density_ripple`` (reference 0.01), the quasi-static run is 0.8 S without ripple."""
    study = S._point_study("p", {"indentation_step": 1e-6, "saturation_range": [1.8e-4, 2.5e-4]}, 2.5e-4,
                           S.SensitivitySettings.from_config({"points": {"p": None}}))
    d = study.grid
    rise = 1 - np.exp(-d / 4e-5)
    wave = np.sin(2 * np.pi * d / 25e-6) * np.exp(-d / 4e-5)
    fraction = 0.5 * (1 - np.exp(-d / 5e-5)) / (1 - np.exp(-3.0))  # 0.5 at 0.15 mm
    curves = {"reference": (1.0, 0.01), "eta-low": (0.975, 0.01), "eta-high": (1.03, 0.01),
              "rho-high": (1.01, density_ripple), "quasistatic": (0.8, 0.0)}
    runs = {}
    for v, (scale, rip) in curves.items():
        k = 2.75e6 * scale * (rise + rip * wave)
        runs[v] = {"stiffness": k, "contact_fraction": fraction,
                   "ksat": S.saturated_stiffness(d, k, study.saturation_range)}
    return runs, study


def test_point_verdicts_are_the_report_claims():
    """measure_claims gives the report's verdicts; claim 7 keeps the report's condition that the variant
    is heavier (the sweep's former copy dropped it and called a lighter variant's ripples a pass)."""
    runs, study = _synthetic_runs()
    heavy = S.measure_claims(runs, study, S.SensitivitySettings.from_config({"points": {"p": None}}))
    assert heavy["loss_delta"] == pytest.approx({0.5: -0.025, 1.5: 0.03}, rel=1e-9, abs=1e-12)
    assert (heavy["claim5_verdict"], heavy["claim6_verdict"], heavy["claim7_verdict"]) == ("holds", "holds", "holds")
    assert heavy["fraction_at_c5"] == pytest.approx(0.5, rel=1e-9)
    # three times the reference's ripple amplitude; the smooth rise's own residual lowers the ratio a little
    assert 2.5 < heavy["ripple_ratio"] < 3.0 and heavy["density_delta"] == pytest.approx(0.01, abs=5e-4)
    # the same curves with the density variant labelled x0.5: sizes and ripple ratio pass, the claim does not
    light = S.measure_claims(runs, study, S.SensitivitySettings.from_config({"points": {"p": None},
                                                                            "density_scale": 0.5}))
    assert light["ripple_ratio"] == heavy["ripple_ratio"] >= THRESHOLDS["c7_ripple_ratio_min"]
    assert abs(light["density_delta"]) <= THRESHOLDS["c7_delta_max"]
    assert light["claim7_verdict"] == "fails"
    # a density variant without extra ripples fails as the report says
    flat, _ = _synthetic_runs(density_ripple=0.01)
    assert S.measure_claims(flat, study, S.SensitivitySettings.from_config({"points": {"p": None}}))["claim7_verdict"] == "fails"


def test_calibration_reaches_the_target(points):
    ds = points["calibrated"].isel(point=0)
    k = float(ds["saturated_stiffness"].sel(variant="reference"))
    assert k == pytest.approx(1.2e5, rel=0.005)
    assert 1 < int(ds["calibration_runs"]) <= 4
    factor = float(ds["modulus_factor"])
    preset = yaml.safe_load(str(ds["material_preset"].values))
    assert preset["alpha"] == 0.4 and preset["E0"] == pytest.approx(2.5e7 * factor, rel=1e-12)


# ----------------------------------------------------------------------------------------------
# combination, conclusions, markdown, figure
# ----------------------------------------------------------------------------------------------
def _fake(points_ds, name, delta, ratio, change, verdict6, verdict7="fails", verdict5="fails"):
    ds = copy.deepcopy(points_ds).assign_coords(point=[name])
    ds["loss_delta"][:] = [delta]
    ds["ripple_ratio"][:] = ratio
    ds["saturation_change"][:] = change
    # whole-variable assignment: the real point's verdict may be a shorter string than the fake one
    for key, verdict in (("claim6_verdict", verdict6), ("claim7_verdict", verdict7), ("claim5_verdict", verdict5)):
        ds[key] = (ds[key].dims, np.full(ds[key].shape, verdict, dtype=object), ds[key].attrs)
    return ds


def test_conclusions_and_markdown(points, tmp_path):
    base = points["plain"]
    opposite = _fake(base, "opp", [0.033, -0.022], 1.03, 0.157, "size holds, direction opposite")
    seedlike = _fake(base, "seed", [-0.02, 0.03], 1.5, 0.08, "holds", "holds", "holds")
    ds = S.combine_points([opposite, seedlike])
    assert list(ds["point"].values) == ["opp", "seed"]
    c = S.conclusions(ds)
    assert c == {"claim5": ["seed"], "claim6_direction": ["seed"], "claim6": ["seed"], "claim7_ripples": ["seed"],
                 "claim7": ["seed"]}
    text = S.sensitivity_markdown(ds)
    assert "comes out for `seed`" in text and "| `opp` |" in text and "+3.30 % | -2.20 % | size holds, direction opposite" in text
    only_opposite = S.combine_points([opposite])
    text = S.sensitivity_markdown(only_opposite)
    assert "None of the 1 points reproduces the seed's direction" in text
    assert "None of the points gives density ripples" in text
    with pytest.raises(ValueError, match="duplicate"):
        S.combine_points([opposite, opposite])
    from tyreroad.plots.sensitivity import plot_sensitivity
    import matplotlib.image as mpimg

    p = plot_sensitivity(ds, tmp_path / "s.png")
    img = mpimg.imread(p)
    assert img.shape[0] > 800 and img[..., :3].std() > 0.05
