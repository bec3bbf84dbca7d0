"""Tests of tyreroad.material: modulus models, loss/density variants, table fit, config validation (SPEC 5)."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest
import yaml

from tyreroad.material import (
    FractionalKelvinVoigt,
    GeneralizedMaxwell,
    Material,
    fit_generalized_maxwell,
    material_from_config,
    path_safe,
    plane_strain_modulus,
    pwave_modulus,
    shear_modulus,
)

TREAD = {
    "model": "fractional_kelvin_voigt",
    "E0": 22.0e6,
    "E1": 44.0e6,
    "alpha": 0.24,
    "f1": 1000.0,
    "poisson_ratio": 0.49,
    "density": 1100.0,
    "thickness": 0.01,
    "quasi_static_modulus": "zero_frequency",
}
GM_TRUE = GeneralizedMaxwell(20e6, (8e6, 15e6, 12e6, 25e6, 30e6), (3e-2, 2e-3, 3.3e-4, 4e-5, 6e-6))


def section(**extra):
    sec = {"tread": copy.deepcopy(TREAD)}
    sec.update(extra)
    return sec


W = 2 * np.pi * np.geomspace(1e-3, 1e5, 300)


def test_fractional_kelvin_voigt_values_and_sign():
    m = FractionalKelvinVoigt(22e6, 44e6, 0.24, 1000.0)
    assert m.modulus(0.0) == 22e6
    # at w = w1: E0 + E1 exp(i pi alpha / 2) (principal branch of (i)^alpha)
    assert m.modulus(2 * np.pi * 1000.0) == pytest.approx(22e6 + 44e6 * np.exp(0.12j * np.pi), rel=1e-15)
    e = m.modulus(W)
    assert np.all(e.imag > 0) and np.all(e.real > 0)
    eta = e.imag / e.real
    assert np.all(np.diff(eta) > 0)  # loss factor rises monotonically
    assert np.all(np.diff(e.real) > 0)  # storage modulus rises with frequency
    with pytest.raises(ValueError, match="omega"):
        m.modulus(-1.0)


def test_generalized_maxwell_values_and_sign():
    e = GM_TRUE.modulus(W)
    assert np.all(e.imag > 0)
    assert GM_TRUE.modulus(0.0) == 20e6
    assert GM_TRUE.modulus(1e14).real == pytest.approx(20e6 + sum(GM_TRUE.moduli), rel=1e-6)
    # single element by hand: E_k w^2 tau^2 / (1 + w^2 tau^2) + i E_k w tau / (1 + w^2 tau^2)
    one = GeneralizedMaxwell(1e6, (2e6,), (1e-3,))
    assert one.modulus(1e3) == pytest.approx(1e6 + 2e6 * (0.5 + 0.5j), rel=1e-15)


def test_default_tread_loss_factor_range():
    m = material_from_config("tread", section())
    f = np.geomspace(10.0, 25e3, 400)
    eta = m.loss_factor(2 * np.pi * f)
    # SPEC 5: eta ~ 0.15-0.35 over 10 Hz - 25 kHz (measured 0.151 ... 0.317)
    assert eta.min() >= 0.15 and eta.max() <= 0.35
    assert eta[0] == pytest.approx(0.1509, abs=2e-4) and eta[-1] == pytest.approx(0.3172, abs=2e-4)
    assert m.quasi_static_modulus == 22e6


def test_repository_config_tread_in_spec_range():
    cfg_path = Path(__file__).resolve().parents[1] / "config" / "config.yaml"
    materials = yaml.safe_load(cfg_path.read_text())["materials"]
    for name in materials:
        m = material_from_config(name, materials)
        assert m.config["model"] in ("fractional_kelvin_voigt", "generalized_maxwell", "table")
    tread = material_from_config("tread", materials)
    eta = tread.loss_factor(2 * np.pi * np.geomspace(10.0, 25e3, 200))
    assert eta.min() >= 0.15 and eta.max() <= 0.35


@pytest.mark.parametrize("s", [0.0, 0.5, 1.5, 2.0])
def test_loss_scale_keeps_abs_modulus(s):
    sec = section(**{"tread-s": {"base": "tread", "loss_scale": s}})
    base = material_from_config("tread", sec)
    var = material_from_config("tread-s", sec)
    e0, e1 = base.modulus(W), var.modulus(W)
    assert np.max(np.abs(np.abs(e1) - np.abs(e0)) / np.abs(e0)) < 1e-12
    eta0, eta1 = base.loss_factor(W), var.loss_factor(W)
    assert np.allclose(eta1, s * eta0, rtol=1e-12, atol=0)
    assert var.density == base.density and var.poisson == base.poisson and var.thickness == base.thickness
    if s > 0:
        assert np.all(e1.imag > 0)


def test_loss_scale_one_is_identity_and_chains_multiply():
    sec = section(
        **{
            "t1": {"base": "tread", "loss_scale": 1.0},
            "t-half": {"base": "tread", "loss_scale": 0.5, "density_scale": 2.0},
            "t-half-half": {"base": "t-half", "loss_scale": 0.5, "density_scale": 0.25},
        }
    )
    base = material_from_config("tread", sec)
    assert np.allclose(material_from_config("t1", sec).modulus(W), base.modulus(W), rtol=1e-15, atol=0)
    chained = material_from_config("t-half-half", sec)
    assert chained.loss_scale == 0.25 and chained.density == pytest.approx(1100.0 * 0.5, rel=1e-15)
    assert chained.lineage == ("t-half-half", "t-half", "tread")
    assert np.allclose(chained.loss_factor(W), 0.25 * base.loss_factor(W), rtol=1e-12, atol=0)


def test_density_scale_and_derived_moduli():
    sec = section(**{"tread-rho2": {"base": "tread", "density_scale": 2.0}})
    base = material_from_config("tread", sec)
    m = material_from_config("tread-rho2", sec)
    assert m.density == 2200.0
    assert np.array_equal(m.modulus(W), base.modulus(W))
    # wave speeds scale as 1/sqrt(density)
    assert np.allclose(m.shear_speed(W), base.shear_speed(W) / np.sqrt(2), rtol=1e-14, atol=0)
    e, nu = base.modulus(W), base.poisson
    mu, mm = base.shear_modulus(W), base.pwave_modulus(W)
    lam = e * nu / ((1 + nu) * (1 - 2 * nu))
    assert np.allclose(mm, lam + 2 * mu, rtol=1e-13, atol=0)  # M = lambda + 2 mu
    assert np.allclose(mu, shear_modulus(e, nu), rtol=1e-15, atol=0)
    assert np.allclose(pwave_modulus(e, nu), mm, rtol=1e-15, atol=0)
    assert np.allclose(plane_strain_modulus(e, nu), e / (1 - nu**2), rtol=1e-15, atol=0)
    assert np.allclose(base.pwave_speed(W) ** 2 * base.density, mm, rtol=1e-13, atol=0)


def test_quasi_static_modulus_choices():
    sec = section(**{"tread-qs": {**TREAD, "quasi_static_modulus": 35e6}})
    assert material_from_config("tread", sec).quasi_static_modulus == 22e6
    assert material_from_config("tread-qs", sec).quasi_static_modulus == 35e6
    gm = {"model": "generalized_maxwell", "E_inf": 5e6, "moduli": [1e6, 2e6], "relaxation_times": [1e-3, 1e-5]}
    gm.update(poisson_ratio=0.45, density=1000.0, thickness=0.02)
    m = material_from_config("gm", {"gm": gm})
    assert m.quasi_static_modulus == 5e6
    assert m.modulus(1e4) == pytest.approx(5e6 + 1e6 * 10j / (1 + 10j) + 2e6 * 0.1j / (1 + 0.1j), rel=1e-15)


def test_resolved_config_round_trips():
    sec = section(**{"v": {"base": "tread", "loss_scale": 1.5, "density_scale": 0.5}})
    m = material_from_config("v", sec)
    assert "base" not in m.config and "density_scale" not in m.config
    assert m.config["density"] == 550.0 and m.config["loss_scale"] == 1.5
    again = material_from_config("v", {"v": m.config})
    assert again == m
    assert np.array_equal(again.modulus(W), m.modulus(W))
    yaml.safe_dump(m.config)  # provenance must be plain YAML


def test_table_fit_recovers_generalized_maxwell():
    f = np.geomspace(1.0, 30e3, 40)
    e = GM_TRUE.modulus(2 * np.pi * f)
    table = {
        "model": "table",
        "frequency": f.tolist(),
        "storage_modulus": e.real.tolist(),
        "loss_factor": (e.imag / e.real).tolist(),
        "poisson_ratio": 0.49,
        "density": 1100.0,
        "thickness": 0.01,
    }
    m = material_from_config("measured", {"measured": table})
    fd = 2 * np.pi * np.geomspace(1.0, 30e3, 500)  # also between the table points
    rel = np.abs(m.modulus(fd) - GM_TRUE.modulus(fd)) / np.abs(GM_TRUE.modulus(fd))
    assert rel.max() < 1e-3  # measured 4.6e-4
    assert np.all(m.modulus(fd).imag > 0)
    assert m.quasi_static_modulus == pytest.approx(20e6, rel=2e-3)
    # a fractional-model table is reproduced closely as well
    fk = FractionalKelvinVoigt(22e6, 44e6, 0.24, 1000.0)
    ef = fk.modulus(2 * np.pi * f)
    _, err_max, err_rms = fit_generalized_maxwell(f, ef.real, ef.imag / ef.real)
    assert err_max < 1e-4 and err_rms <= err_max


def test_table_fit_rejects_non_causal_data():
    # storage modulus falling with frequency while the loss is large contradicts Kramers-Kronig
    f = np.geomspace(1.0, 1e4, 20)
    table = {
        "model": "table",
        "frequency": f.tolist(),
        "storage_modulus": np.geomspace(100e6, 10e6, 20).tolist(),
        "loss_factor": [0.3] * 20,
        "poisson_ratio": 0.49,
        "density": 1100.0,
        "thickness": 0.01,
    }
    with pytest.raises(ValueError, match=r"materials\.bad: the causal .* fit of the table is poor"):
        material_from_config("bad", {"bad": table})


def test_path_safe():
    for good in ("tread", "tread-eta0.5", "T2", "a.b-c"):
        assert path_safe(good)
    for bad in ("", ".", "..", "tread_1", "a/b", "-x", "with space", 3, None, "é"):
        assert not path_safe(bad)


@pytest.mark.parametrize(
    "name, sec, match",
    [
        ("tread_x", {"tread_x": TREAD}, r"materials\.tread_x: preset name 'tread_x' is not path safe"),
        ("nope", {"tread": TREAD}, r"materials\.nope: unknown material preset"),
        ("v", {"v": {"base": "ghost"}}, r"materials\.v\.base = 'ghost': unknown material preset"),
        ("a", {"a": {"base": "b"}, "b": {"base": "a"}}, r"cyclic base chain a -> b -> a"),
        ("v", {"v": {"base": "v"}}, r"cyclic base chain v -> v"),
        ("t", {"t": {**TREAD, "model": "maxwell"}}, r"materials\.t\.model = 'maxwell': unknown model"),
        ("t", {"t": {k: v for k, v in TREAD.items() if k != "E1"}}, r"materials\.t\.E1: missing"),
        ("t", {"t": {k: v for k, v in TREAD.items() if k != "model"}}, r"materials\.t\.model: missing"),
        ("t", {"t": {**TREAD, "poisson_ratio": 0.5}}, r"materials\.t\.poisson_ratio = 0\.5: expected in \(0, 0\.5\)"),
        ("t", {"t": {**TREAD, "poisson_ratio": -0.1}}, r"materials\.t\.poisson_ratio = -0\.1"),
        ("t", {"t": {**TREAD, "density": -1100.0}}, r"materials\.t\.density = -1100\.0: expected > 0"),
        ("t", {"t": {**TREAD, "thickness": 0}}, r"materials\.t\.thickness = 0: expected > 0"),
        ("t", {"t": {**TREAD, "alpha": 1.2}}, r"materials\.t\.alpha = 1\.2: expected in \(0, 1\)"),
        ("t", {"t": {**TREAD, "E0": "22e6"}}, r"materials\.t\.E0 = '22e6': expected a number"),
        ("t", {"t": {**TREAD, "density": True}}, r"materials\.t\.density = True: expected a number"),
        ("t", {"t": {**TREAD, "colour": "black"}}, r"materials\.t\.colour: unknown key"),
        ("t", {"t": {**TREAD, "quasi_static_modulus": "low"}}, r"materials\.t\.quasi_static_modulus = 'low'"),
        ("v", {**section(), "v": {"base": "tread", "loss_scale": -1}}, r"materials\.v\.loss_scale = -1: expected >= 0"),
        ("v", {**section(), "v": {"base": "tread", "density_scale": 0}}, r"materials\.v\.density_scale = 0"),
        ("v", {**section(), "v": {"base": "tread", "thickness": 0.02}}, r"materials\.v\.thickness: a preset with"),
        (
            "g",
            {"g": {"model": "generalized_maxwell", "E_inf": 1e6, "moduli": [1e6, 2e6], "relaxation_times": [1e-3],
                   "poisson_ratio": 0.45, "density": 1000.0, "thickness": 0.01}},
            r"materials\.g\.relaxation_times: expected as many values as materials\.g\.moduli",
        ),
        (
            "g",
            {"g": {"model": "generalized_maxwell", "E_inf": 1e6, "moduli": [1e6, -2e6], "relaxation_times": [1, 2],
                   "poisson_ratio": 0.45, "density": 1000.0, "thickness": 0.01}},
            r"materials\.g\.moduli\[1\] = -2000000\.0: expected >= 0",
        ),
        (
            "tb",
            {"tb": {"model": "table", "frequency": [1, 3, 2], "storage_modulus": [1e6] * 3, "loss_factor": [0.1] * 3,
                    "poisson_ratio": 0.45, "density": 1000.0, "thickness": 0.01}},
            r"materials\.tb\.frequency = .*strictly increasing",
        ),
    ],
)  # fmt: skip
def test_config_errors_name_the_key(name, sec, match):
    with pytest.raises(ValueError, match=match):
        material_from_config(name, sec)


def test_material_is_frozen_and_hashable():
    m = material_from_config("tread", section())
    with pytest.raises(AttributeError):
        m.density = 1.0  # type: ignore[misc]
    assert hash(m) == hash(material_from_config("tread", section()))
    assert isinstance(m, Material)


# ---------------------------------------------------------------------------------------------- Laplace domain
# E(s) at complex s, Re s >= 0 (convolution-quadrature kernels, issue 23)

S_GRID = np.outer(np.geomspace(1e-2, 1e7, 40), np.exp(1j * np.deg2rad(np.linspace(-90.0, 90.0, 13)))).ravel()


@pytest.mark.parametrize("model", [FractionalKelvinVoigt(22e6, 44e6, 0.24, 1000.0), GM_TRUE])
def test_laplace_modulus_continues_the_frequency_axis(model):
    # on the imaginary axis the continuation is the complex modulus itself
    assert np.max(np.abs(model.laplace_modulus(1j * W) / model.modulus(W) - 1)) < 1e-13
    # real s > 0: real, positive, increasing (a stiffening material), E(0) = the relaxed modulus
    sr = np.geomspace(1e-3, 1e7, 200)
    e = model.laplace_modulus(sr)
    assert np.all(e.imag == 0) and np.all(e.real > 0) and np.all(np.diff(e.real) > 0)
    relaxed = model.E0 if isinstance(model, FractionalKelvinVoigt) else model.E_inf
    assert model.laplace_modulus(0.0) == relaxed
    # reflection symmetry and passivity: arg E(s) between 0 and arg s (so Re E > 0 in Re s > 0)
    e = model.laplace_modulus(S_GRID)
    np.testing.assert_allclose(model.laplace_modulus(np.conj(S_GRID)), np.conj(e), rtol=1e-15, atol=0)
    arg_e, arg_s = np.angle(e), np.angle(S_GRID)
    assert np.all(arg_e * arg_s >= 0) and np.all(np.abs(arg_e) <= np.abs(arg_s) + 1e-15)
    with pytest.raises(ValueError, match="Re s >= 0"):
        model.laplace_modulus(-1.0 + 1j)
    with pytest.raises(ValueError, match="finite"):
        model.laplace_modulus(np.nan)


def test_fractional_laplace_modulus_is_the_principal_branch():
    m = FractionalKelvinVoigt(22e6, 44e6, 0.24, 1000.0)
    w1 = 2 * np.pi * 1000.0
    # s = w1 exp(i theta): (s / w1)^alpha = exp(i alpha theta) exactly, for theta in [-pi/2, pi/2]
    theta = np.linspace(-np.pi / 2, np.pi / 2, 9)
    e = m.laplace_modulus(w1 * np.exp(1j * theta))
    np.testing.assert_allclose(e, 22e6 + 44e6 * np.exp(0.24j * theta), rtol=1e-14, atol=0)


def test_material_laplace_modulus_and_refusals():
    sec = section(
        **{
            "tread-rho2": {"base": "tread", "density_scale": 2.0},
            "tread-eta0.5": {"base": "tread", "loss_scale": 0.5},
            "tread-eta0": {"base": "tread", "loss_scale": 0.0},
        }
    )
    base = material_from_config("tread", sec)
    s = np.array([0.0, 10.0, 1e3 * np.exp(0.7j), 2j * np.pi * 1000.0])
    np.testing.assert_array_equal(base.laplace_modulus(s), base.model.laplace_modulus(s))
    # density does not enter E
    np.testing.assert_array_equal(material_from_config("tread-rho2", sec).laplace_modulus(s), base.laplace_modulus(s))
    for name in ("tread-eta0.5", "tread-eta0"):
        with pytest.raises(ValueError, match=rf"material '{name}'.*loss_scale.*Kramers-Kronig"):
            material_from_config(name, sec).laplace_modulus(s)

    class AxisOnly:
        def modulus(self, omega):
            return np.full(np.shape(omega), 1e7 + 0j)

    with pytest.raises(ValueError, match="material 'probe'.*AxisOnly.*frequency axis only"):
        Material("probe", 0.49, 1100.0, 0.01, AxisOnly()).laplace_modulus(s)


def test_table_preset_continues_through_its_causal_fit():
    # the table is represented by its causal generalised Maxwell fit everywhere in the pipeline; that fit's
    # continuation is E(s) (the raw points are never used off the fit, on the frequency axis either)
    f = np.geomspace(1.0, 1e4, 25)
    e = GM_TRUE.modulus(2 * np.pi * f)
    cfg = {k: v for k, v in TREAD.items() if k not in ("E0", "E1", "alpha", "f1")}
    cfg.update(model="table", frequency=f.tolist(), storage_modulus=e.real.tolist(),
               loss_factor=(e.imag / e.real).tolist())
    m = material_from_config("dma", {"dma": cfg})
    w = 2 * np.pi * f
    assert np.max(np.abs(m.laplace_modulus(1j * w) / m.modulus(w) - 1)) < 1e-13
    s = 2 * np.pi * 300.0 * np.exp(0.5j)
    assert m.laplace_modulus(s) == m.model.laplace_modulus(s)
    # the fit's continuation stays close to the true material's off the axis too
    assert abs(m.laplace_modulus(s) / GM_TRUE.laplace_modulus(s) - 1) < 1e-3


# --------------------------------------------------------------------------------------------
# causal loss variants (issue 24): the phase scaled, |E| kept at an anchor frequency
# --------------------------------------------------------------------------------------------
def _variants():
    from tyreroad.config import load_config

    mats = dict(load_config(Path(__file__).resolve().parents[1] / "config" / "config.yaml")["materials"])
    for s in (0.5, 1.5):
        mats[f"causal{s}"] = {"base": "tread", "loss_scale": s, "loss_anchor": 1000.0}
        mats[f"relaxed{s}"] = {"base": "tread", "loss_scale": s, "loss_anchor": 0.0}
        mats[f"seed{s}"] = {"base": "tread", "loss_scale": s}
    return mats


@pytest.mark.parametrize("scale", [0.5, 1.5])
def test_causal_loss_variant_scales_the_phase_and_keeps_the_anchor(scale):
    mats = _variants()
    ref = material_from_config("tread", mats)
    w = 2 * np.pi * np.logspace(0, 4.4, 30)
    for name, anchor in ((f"causal{scale}", 1000.0), (f"relaxed{scale}", 0.0)):
        m = material_from_config(name, mats)
        e, e_ref = m.modulus(w), ref.modulus(w)
        np.testing.assert_allclose(np.angle(e), scale * np.angle(e_ref), rtol=1e-12)  # eta_s = tan(s arctan eta)
        assert abs(m.modulus(2 * np.pi * anchor)) == pytest.approx(abs(ref.modulus(2 * np.pi * anchor)), rel=1e-13)
        # analytic: the Laplace-domain modulus on the axis is the same function
        np.testing.assert_allclose(m.laplace_modulus(1j * w), e, rtol=1e-12)
        assert m.config["loss_anchor"] == anchor
        assert material_from_config(name, {name: m.config}) == m  # the resolved preset rebuilds it
    assert material_from_config(f"relaxed{scale}", mats).quasi_static_modulus == pytest.approx(
        ref.quasi_static_modulus, rel=1e-12)


def test_causal_variants_are_creeping_solids_and_the_seeds_are_not():
    """The retardation-spectrum fit (a non-negative creep spectrum holds every causal, passive material to
    ~1e-4) holds the phase-scaled variants as well as the reference; the seed's constant-|E| variants
    miss it by 11-13 % (they are not causal)."""
    from tyreroad.memory import fit_retardation_spectrum

    mats = _variants()
    for name in ("tread", "causal0.5", "causal1.5"):
        assert fit_retardation_spectrum(material_from_config(name, mats), 25600.0).fit_error < 2e-4, name
    for name in ("seed0.5", "seed1.5"):
        assert fit_retardation_spectrum(material_from_config(name, mats), 25600.0).fit_error > 0.05, name
    with pytest.raises(ValueError, match="loss_anchor"):
        material_from_config("seed1.5", mats).laplace_modulus(np.array([1j]))


def test_phase_scaling_beyond_passivity_is_refused():
    """arg E of the fractional tread tends to alpha pi / 2 = 0.377 rad: s alpha >= 1 is not passive."""
    mats = _variants()
    mats["too-lossy"] = {"base": "tread", "loss_scale": 4.5, "loss_anchor": 1000.0}
    with pytest.raises(ValueError, match=r"materials\.too-lossy\.loss_scale = 4\.5: .* not passive"):
        material_from_config("too-lossy", mats)
    mats["bad-anchor"] = {"base": "tread", "loss_scale": 1.5, "loss_anchor": -1.0}
    with pytest.raises(ValueError, match=r"materials\.bad-anchor\.loss_anchor"):
        material_from_config("bad-anchor", mats)


def test_a_tables_extrapolated_relaxed_modulus_is_stated(caplog):
    """Issue 25: with quasi_static_modulus: zero_frequency a table's relaxed modulus is the fit's
    extrapolation below its data; the log says so with the value, the lowest frequency and the key that
    sets it from data. Given as a number, nothing is extrapolated and nothing is said."""
    import logging

    f = np.geomspace(10.0, 30e3, 30)
    e = GM_TRUE.modulus(2 * np.pi * f)
    table = {"model": "table", "frequency": f.tolist(), "storage_modulus": e.real.tolist(),
             "loss_factor": (e.imag / e.real).tolist(), "poisson_ratio": 0.49, "density": 1100.0, "thickness": 0.01}
    with caplog.at_level(logging.WARNING, logger="tyreroad.material"):
        m = material_from_config("dma", {"dma": table})
    msg = caplog.text
    assert "materials.dma: the relaxed modulus E(0) = " in msg and "lowest frequency 10 Hz" in msg
    assert f"{m.quasi_static_modulus:.4g} Pa" in msg and "materials.dma.quasi_static_modulus" in msg
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="tyreroad.material"):
        given = material_from_config("dma", {"dma": {**table, "quasi_static_modulus": 2.0e7}})
    assert given.quasi_static_modulus == 2.0e7 and "relaxed modulus" not in caplog.text


def test_default_variants_are_causal_and_passive_up_to_fs2_and_beyond():
    """Every material of the default config that is not one of the seed's frequency-domain variants is causal;
    each phase-scaled one has s arg E < pi/2 (Im E_s >= 0) at every frequency up to fs/2 and far beyond."""
    mats = _variants()
    ref = material_from_config("tread", mats)
    w = 2 * np.pi * np.logspace(-3, np.log10(25600.0), 400)
    w_far = 2 * np.pi * np.logspace(-6, 9, 1501)
    for name in mats:
        m = material_from_config(name, mats)
        if name.endswith("-seed") or name.startswith("seed"):
            assert not m.is_causal and m.loss_anchor is None
            continue
        assert m.is_causal, name
        if m.loss_anchor is not None:
            assert np.all(m.loss_scale * np.angle(ref.modulus(w_far)) < 0.5 * np.pi), name
            assert np.all(m.modulus(w).imag >= 0) and np.all(m.modulus(w).real > 0), name


def test_modulus_scale_and_a_variants_own_quasi_static_modulus():
    mats = _variants()
    ref = material_from_config("tread", mats)
    w = 2 * np.pi * np.logspace(0, 4.4, 20)
    mats["k"] = {"base": "tread", "modulus_scale": 0.96}
    mats["kk"] = {"base": "k", "modulus_scale": 0.5, "loss_scale": 1.5, "loss_anchor": 1000.0}
    mats["qs"] = {"base": "tread", "quasi_static_modulus": 4.0e7}
    k = material_from_config("k", mats)
    np.testing.assert_allclose(k.modulus(w), 0.96 * ref.modulus(w), rtol=1e-14)
    np.testing.assert_allclose(k.loss_factor(w), ref.loss_factor(w), rtol=1e-12)
    assert k.quasi_static_modulus == pytest.approx(0.96 * ref.quasi_static_modulus, rel=1e-14)
    np.testing.assert_allclose(k.laplace_modulus(1j * w), k.modulus(w), rtol=1e-12)
    kk = material_from_config("kk", mats)
    np.testing.assert_allclose(kk.modulus(w), 0.48 * material_from_config("causal1.5", mats).modulus(w), rtol=1e-12)
    assert material_from_config("kk", {"kk": kk.config}) == kk
    q = material_from_config("qs", mats)
    assert q.quasi_static_modulus == 4.0e7
    np.testing.assert_allclose(q.modulus(w), ref.modulus(w), rtol=0)  # E(w) and the dynamic kernel: tread's
    assert material_from_config("qs", {"qs": q.config}) == q


def test_causality_error_names_the_key_the_material_and_the_alternative():
    from tyreroad.material import causality_error

    mats = _variants()
    assert causality_error(material_from_config("causal1.5", mats), "study.materials[2]") is None
    msg = causality_error(material_from_config("seed1.5", mats), "study.materials[2]", "a contact run")
    assert msg.startswith("study.materials[2] = 'seed1.5'")
    assert "materials.seed1.5.loss_anchor: 1000.0" in msg and "not causal" in msg
