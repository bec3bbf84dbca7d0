"""Compounds from a DMA master curve (issue 25): time-temperature shift, temperature variants, the table file,
the config checks and the ``tyreroad material`` command (tyreroad.material, tyreroad.dma, tyreroad.cli)."""

from __future__ import annotations

import copy
import logging
import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner
from snakemake.utils import validate

from tyreroad import cli
from tyreroad import config as C
from tyreroad.dma import check_compound, kramers_kronig_storage
from tyreroad.material import (
    GAS_CONSTANT,
    FractionalKelvinVoigt,
    expand_temperatures,
    material_from_config,
    read_dma_table,
    shift_factor,
)

ROOT = Path(__file__).resolve().parents[1]
SCHEMA = ROOT / "workflow" / "schemas" / "config.schema.yaml"
EXAMPLE = ROOT / "config" / "compounds" / "example-dma.csv"
WLF = {"model": "wlf", "C1": 8.86, "C2": 101.6}
TREAD = FractionalKelvinVoigt(E0=2.5e7, E1=5.0e7, alpha=0.24, f1=1000.0)  # config/config.yaml's tread


def _table(f=None, **extra):
    """A table preset of the default tread's master curve (10 mHz - 10 MHz) at 23 degC."""
    f = np.geomspace(1e-2, 1e7, 46) if f is None else f
    e = TREAD.modulus(2 * np.pi * f)
    return {"model": "table", "frequency": f.tolist(), "storage_modulus": e.real.tolist(),
            "loss_factor": (e.imag / e.real).tolist(), "poisson_ratio": 0.49, "density": 1100.0, "thickness": 0.01,
            **extra}


# ------------------------------------------------------------------------------------------------
# shift factors
# ------------------------------------------------------------------------------------------------
def test_wlf_shift_factor_against_hand_values():
    assert shift_factor(WLF, 23.0, 23.0) == 1.0
    # T - T_ref = -23 K: log10 a_T = 8.86 * 23 / (101.6 - 23) = 203.78 / 78.6
    assert math.isclose(math.log10(shift_factor(WLF, 0.0, 23.0)), 203.78 / 78.6, rel_tol=0, abs_tol=1e-12)
    # +17 K: log10 a_T = -8.86 * 17 / 118.6
    assert math.isclose(math.log10(shift_factor(WLF, 40.0, 23.0)), -150.62 / 118.6, rel_tol=0, abs_tol=1e-12)
    # the T_g form (17.44, 51.6 from T_g = -27 degC) is the same law to the constants' rounding
    tg = {"model": "wlf", "C1": 17.44, "C2": 51.6}
    for t in (0.0, 40.0):
        ratio = shift_factor(tg, t, -27.0) / shift_factor(tg, 23.0, -27.0)
        assert math.isclose(math.log10(ratio), math.log10(shift_factor(WLF, t, 23.0)), rel_tol=2e-3)
    with pytest.raises(ValueError, match="WLF shift singular"):
        shift_factor(WLF, -80.0, 23.0)


def test_arrhenius_shift_factor_against_hand_values():
    arr = {"model": "arrhenius", "activation_energy": 1.0e5}
    assert shift_factor(arr, 23.0, 23.0) == 1.0
    # ln a_T = E_a / R (1/273.15 - 1/296.15)
    hand = math.exp(1.0e5 / 8.314462618 * (1.0 / 273.15 - 1.0 / 296.15))
    assert GAS_CONSTANT == 8.314462618
    assert math.isclose(shift_factor(arr, 0.0, 23.0), hand, rel_tol=1e-13)
    assert math.isclose(shift_factor(arr, 0.0, 23.0) * shift_factor(arr, 23.0, 0.0), 1.0, rel_tol=1e-13)


# ------------------------------------------------------------------------------------------------
# the shifted material
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("temperature", [0.0, 40.0])
def test_shifted_table_is_the_reference_fit_at_shifted_frequency(temperature):
    """E(f; T) = E_ref(f a_T) for the fitted model, on the frequency axis and in the Laplace domain."""
    mats = {"dma": _table(reference_temperature=23.0, shift=WLF),
            "dma-T": {"base": "dma", "temperature": temperature}}
    ref, hot = material_from_config("dma", mats), material_from_config("dma-T", mats)
    a_t = shift_factor(WLF, temperature, 23.0)
    assert hot.shift_factor == a_t and hot.temperature == temperature and ref.shift_factor == 1.0
    w = 2 * np.pi * np.geomspace(1e-3, 3e4, 50)
    np.testing.assert_allclose(hot.modulus(w), ref.modulus(w * a_t), rtol=1e-12)
    s = w * (0.3 + 1j)
    np.testing.assert_allclose(hot.laplace_modulus(s), ref.laplace_modulus(s * a_t), rtol=1e-12)
    assert hot.quasi_static_modulus == pytest.approx(ref.quasi_static_modulus, rel=1e-12)  # horizontal shift only
    # colder is stiffer and more lossy at 1 kHz, warmer the opposite
    e_ref, e_t = ref.modulus(2 * np.pi * 1e3), hot.modulus(2 * np.pi * 1e3)
    assert (e_t.real > e_ref.real) == (temperature < 23.0)
    # the resolved preset rebuilds the same material (what the pipeline's jobs receive)
    again = material_from_config("dma-T", {"dma-T": hot.config})
    np.testing.assert_allclose(again.modulus(w), hot.modulus(w), rtol=1e-14)
    assert again.shift_factor == a_t


def test_vertical_shift_is_explicit_and_scales_the_relaxed_modulus_too():
    mats = {"dma": _table(reference_temperature=23.0, shift=WLF, vertical_shift=True, quasi_static_modulus=2.5e7),
            "dma-T0": {"base": "dma", "temperature": 0.0}}
    ref, cold = material_from_config("dma", mats), material_from_config("dma-T0", mats)
    b_t = 273.15 / 296.15
    a_t = shift_factor(WLF, 0.0, 23.0)
    assert cold.vertical_shift_factor == pytest.approx(b_t, rel=1e-15)
    w = 2 * np.pi * np.geomspace(1.0, 1e4, 9)
    np.testing.assert_allclose(cold.modulus(w), b_t * ref.modulus(w * a_t), rtol=1e-12)
    assert cold.quasi_static_modulus == pytest.approx(b_t * 2.5e7, rel=1e-15)
    assert material_from_config("dma-T0", {"dma-T0": cold.config}).quasi_static_modulus == cold.quasi_static_modulus


def test_table_at_its_reference_temperature_is_the_unshifted_material():
    plain = material_from_config("dma", {"dma": _table()})
    for extra in ({"reference_temperature": 23.0, "shift": WLF},
                  {"reference_temperature": 23.0, "shift": WLF, "temperature": 23.0}):
        at_ref = material_from_config("dma", {"dma": _table(**extra)})
        assert at_ref.model == plain.model and at_ref.shift_factor == 1.0 and at_ref.temperature == 23.0
    via_variant = material_from_config("dma-T23", expand_temperatures(
        {"dma": _table(reference_temperature=23.0, shift=WLF, temperatures=[23.0])}))
    assert via_variant.model == plain.model


def test_temperatures_expand_into_base_variants():
    mats = {"dma": _table(reference_temperature=23.0, shift=WLF, temperatures=[0, 40, -10, 23.5])}
    out = expand_temperatures(mats)
    assert mats.keys() == {"dma"}  # the input is left alone
    assert out["dma-T0"] == {"base": "dma", "temperature": 0.0}
    assert set(out) == {"dma", "dma-T0", "dma-T40", "dma-T-10", "dma-T23.5"}
    assert material_from_config("dma-T-10", out).temperature == -10.0
    assert "temperatures" not in material_from_config("dma-T40", out).config
    clash = {**mats, "dma-T0": {"base": "dma", "loss_scale": 0.5, "loss_anchor": 1000.0}}
    with pytest.raises(ValueError, match=r"materials\.dma\.temperatures: the variant at 0 degC is named 'dma-T0'"):
        expand_temperatures(clash)


def test_the_relaxed_modulus_warning_states_the_shifted_values(caplog):
    mats = {"dma": _table(reference_temperature=23.0, shift=WLF), "dma-T0": {"base": "dma", "temperature": 0.0}}
    with caplog.at_level(logging.WARNING, logger="tyreroad.material"):
        cold = material_from_config("dma-T0", mats)
    a_t = shift_factor(WLF, 0.0, 23.0)
    msg = caplog.text
    assert f"materials.dma-T0: the relaxed modulus E(0) = {cold.quasi_static_modulus:.4g} Pa at 0 degC" in msg
    assert f"a_T = {a_t:.4g}" in msg and f"lowest frequency {1e-2 / a_t:.4g} Hz" in msg
    e_low = cold.modulus(2 * np.pi * 1e-2 / a_t).real
    assert f"= {e_low:.4g} Pa" in msg and "materials.dma.quasi_static_modulus" in msg


def test_table_file_matches_the_inline_table_and_loss_modulus_column(tmp_path):
    f = np.geomspace(1e-2, 1e7, 46)
    e = TREAD.modulus(2 * np.pi * f)
    rows = "\n".join(f"{float(fi)!r},{float(ei.real)!r},{float(ei.imag)!r}" for fi, ei in zip(f, e))
    path = tmp_path / "c.csv"
    path.write_text(f"# a comment\nfrequency,storage_modulus,loss_modulus\n{rows}\n")
    preset = {k: v for k, v in _table().items() if k not in ("frequency", "storage_modulus", "loss_factor")}
    from_file = material_from_config("dma", {"dma": {**preset, "table_file": str(path)}})
    inline = material_from_config("dma", {"dma": _table()})
    w = 2 * np.pi * np.geomspace(1e-2, 1e7, 30)
    np.testing.assert_allclose(from_file.modulus(w), inline.modulus(w), rtol=1e-10)
    assert "table_file" not in from_file.config and len(from_file.config["frequency"]) == 46
    bad = tmp_path / "bad.csv"
    bad.write_text("frequency,storage_modulus,loss_factor\n1,2e7,0.1\n2,x,0.1\n")
    with pytest.raises(ValueError, match=r"bad\.csv, line 3: expected numbers"):
        read_dma_table(bad)


# ------------------------------------------------------------------------------------------------
# config checks (as common.smk runs them at planning time)
# ------------------------------------------------------------------------------------------------
def _plan(overlay: dict):
    cfg = C.merge(C.load_config(ROOT / "config" / "config.yaml"), overlay)
    C.validate_schema(cfg, SCHEMA)
    cfg = C.expand_material_temperatures(cfg)
    validate(cfg, str(SCHEMA))
    C.check_config(cfg, base_dir=ROOT)
    return cfg


def _compound(**extra):
    return {"materials": {"dma": {"model": "table", "table_file": str(EXAMPLE), "poisson_ratio": 0.49,
                                  "density": 1100.0, "thickness": 0.01, "quasi_static_modulus": 2.5e7, **extra}}}


def test_the_shipped_overlay_plans_with_its_temperature_variants(monkeypatch):
    monkeypatch.chdir(ROOT)  # table_file is relative to the working directory
    cfg = C.load_config(ROOT / "config" / "config.yaml", ROOT / "config" / "compound-temperature.yaml")
    C.validate_schema(cfg, SCHEMA)
    validate(cfg, str(SCHEMA))
    C.check_config(cfg, base_dir=ROOT)
    assert cfg["materials"]["example-dma-T0"] == {"base": "example-dma", "temperature": 0.0}
    assert material_from_config("example-dma-T40", cfg["materials"]).shift_factor == shift_factor(WLF, 40.0, 23.0)


@pytest.mark.parametrize("extra, match", [
    ({"reference_temperature": 23.0, "shift": {"model": "wlf", "C1": 8.86, "C2": 101.6}, "temperatures": [0, -80]},
     r"^materials\.dma\.temperatures\[1\] = -80 degC: the WLF shift is singular there: materials\.dma\.shift\.C2 "
     r"\+ T - materials\.dma\.reference_temperature = 101\.6 \+ -80 - 23 = -1\.4 <= 0"),
    ({"reference_temperature": 23.0, "temperature": 0.0},
     r"^materials\.dma\.temperature: a study temperature needs materials\.dma\.shift"),
    ({"reference_temperature": 23.0, "temperatures": [0.0]},
     r"^materials\.dma\.temperatures: a study temperature needs materials\.dma\.shift"),
    ({"shift": {"model": "wlf", "C1": 8.86, "C2": 101.6}, "temperature": 0.0},
     r"^materials\.dma\.shift: needs materials\.dma\.reference_temperature"),
    ({"table_file": "config/compounds/no-such.csv"},
     r"^materials\.dma\.table_file = 'config/compounds/no-such\.csv': config/compounds/no-such\.csv: DMA table "
     r"file not found"),
    ({"frequency": [1.0, 2.0, 3.0]}, r"^materials\.dma\.frequency: given beside materials\.dma\.table_file"),
])
def test_config_errors_name_the_keys_and_values(extra, match, monkeypatch):
    monkeypatch.chdir(ROOT)
    with pytest.raises(C.ConfigError, match=match):
        _plan(_compound(**extra))


def test_a_variant_temperature_is_checked_against_the_wlf_form(monkeypatch):
    monkeypatch.chdir(ROOT)
    overlay = _compound(reference_temperature=23.0, shift=WLF)
    overlay["materials"]["dma-cold"] = {"base": "dma", "temperature": -90.0}
    with pytest.raises(C.ConfigError, match=r"^materials\.dma-cold\.temperature = -90 degC: the WLF shift is singular"):
        _plan(overlay)
    overlay["materials"]["dma-cold"] = {"base": "tread", "temperature": 0.0}
    with pytest.raises(C.ConfigError, match=r"^materials\.dma-cold\.temperature: only a variant of a 'table' preset"):
        _plan(overlay)


# ------------------------------------------------------------------------------------------------
# Kramers-Kronig check and the tyreroad material command
# ------------------------------------------------------------------------------------------------
def test_kramers_kronig_check_passes_a_causal_table_and_flags_the_seeds_loss_scaling():
    f, e1, eta = read_dma_table(EXAMPLE)
    _, dev, relaxed = kramers_kronig_storage(f, e1, eta)
    assert dev < 0.01 and relaxed == pytest.approx(2.5e7, rel=0.05)
    # the seed's loss variant (eta x 1.5 at constant E'): no causal material has this E' and this loss
    _, dev_seed, _ = kramers_kronig_storage(f, e1, 1.5 * np.asarray(eta))
    assert dev_seed > 0.2


def test_check_compound_on_the_example_table(monkeypatch):
    monkeypatch.chdir(ROOT)
    check = check_compound("config/compounds/example-dma.csv", reference_temperature=23.0, shift=WLF,
                           temperatures=[0.0, 40.0], quasi_static_modulus=2.5e7)
    assert check.name == "example-dma" and check.n_points == 61 and check.fit_max_error < 1e-4
    assert check.kk_inner_deviation < 1e-3
    by_name = {t["name"]: t for t in check.temperatures}
    assert by_name["example-dma-T0"]["shift_factor"] == shift_factor(WLF, 0.0, 23.0)
    e1k = TREAD.modulus(2 * np.pi * 1e3)
    assert by_name["example-dma"]["storage_modulus"] == pytest.approx(e1k.real, rel=1e-4)


def test_material_command_prints_a_preset_that_plans(monkeypatch, tmp_path):
    monkeypatch.chdir(ROOT)
    out = tmp_path / "preset.yaml"
    result = CliRunner().invoke(cli.main, [
        "material", "config/compounds/example-dma.csv", "--reference-temperature", "23", "--wlf", "8.86", "101.6",
        "--temperature", "0", "-t", "40", "--quasi-static-modulus", "2.5e7", "-o", str(out)])
    assert result.exit_code == 0, result.output
    text = out.read_text()
    assert "# example-dma-T0: T = 0 degC, a_T = 391.4," in text and "Kramers-Kronig" in text
    assert "causal fit (generalised Maxwell" in text
    preset = yaml.safe_load(text)
    assert preset["materials"]["example-dma"]["shift"] == WLF
    overlay = copy.deepcopy(preset)
    overlay["study"] = {"materials": ["tread", "example-dma-T0"]}
    cfg = _plan(overlay)
    assert material_from_config("example-dma-T0", cfg["materials"]).shift_factor == pytest.approx(391.4, rel=1e-4)
    # stdout, and an error as one line naming the key
    result = CliRunner().invoke(cli.main, ["material", "config/compounds/example-dma.csv", "--wlf", "8.86", "101.6",
                                           "-t", "0"])
    assert result.exit_code != 0 and "needs materials.example-dma.reference_temperature" in result.output
    result = CliRunner().invoke(cli.main, ["material", "config/compounds/example-dma.csv"])
    assert result.exit_code == 0 and "(no reference temperature: not shifted)" in result.output
    assert yaml.safe_load(result.output)["materials"]["example-dma"]["quasi_static_modulus"] == "zero_frequency"


def test_greens_file_carries_the_temperature_and_shift_factor():
    """The greens stage of a temperature variant records T and a_T (a 3 x 3 patch, fold kernel: seconds)."""
    from tyreroad.greens import greens_dataset

    mats = {"dma": _table(reference_temperature=23.0, shift=WLF, quasi_static_modulus=2.5e7),
            "dma-T0": {"base": "dma", "temperature": 0.0}}
    ds = greens_dataset(material_from_config("dma-T0", mats), n_elements=(3, 3), element_size=1e-3,
                        sample_rate=51200.0, n_lags=64, n_fft=4096, construction="fold")
    assert ds.attrs["temperature"] == 0.0 and ds.attrs["shift_factor"] == shift_factor(WLF, 0.0, 23.0)
    assert ds.attrs["vertical_shift_factor"] == 1.0
    plain = greens_dataset(material_from_config("tread", {"tread": {
        "model": "fractional_kelvin_voigt", "E0": 2.5e7, "E1": 5.0e7, "alpha": 0.24, "f1": 1000.0,
        "poisson_ratio": 0.49, "density": 1100.0, "thickness": 0.01}}), n_elements=(3, 3), element_size=1e-3,
        sample_rate=51200.0, n_lags=64, n_fft=4096, construction="fold")
    assert "shift_factor" not in plain.attrs
