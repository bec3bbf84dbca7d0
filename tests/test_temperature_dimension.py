"""Temperature as a study dimension (issue 25): the study file (study.nc) and the combined K* file
(stiffness_spectrum.nc) carry per-material coordinates ``compound`` and ``temperature`` [degC], so that
a compound run at several temperatures unstacks into compound x temperature arrays.

Small datasets built here (synthetic contact runs and K* spectra); no study is run.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import _synthetic
from test_cli import synthetic_spectrum

from tyreroad import io as tio
from tyreroad import pipeline
from tyreroad.config import load_config
from tyreroad.material import compound_and_temperature
from tyreroad.study import StudySettings, expected_cases

ROOT = Path(__file__).resolve().parents[1]
#: The study materials of config/compound-temperature.yaml and what they are.
COMPOUNDS = {"tread": ["tread", None], "example-dma": ["example-dma", 23.0],
             "example-dma-T0": ["example-dma", 0.0], "example-dma-T40": ["example-dma", 40.0]}


def test_compound_and_temperature_of_the_shipped_overlay():
    cfg = load_config(ROOT / "config" / "config.yaml", ROOT / "config" / "compound-temperature.yaml")
    assert pipeline.material_compounds(cfg["study"]["materials"], cfg["materials"]) == COMPOUNDS
    # loss and density variants are compounds of their own, without a temperature
    name, t = compound_and_temperature("tread-eta0.5", cfg["materials"])
    assert name == "tread-eta0.5" and math.isnan(t)
    # a variant that sets more than base and temperature is a compound of its own, at the inherited temperature
    mats = {**cfg["materials"], "soft": {"base": "example-dma-T40", "modulus_scale": 0.5}}
    assert compound_and_temperature("soft", mats) == ("soft", 40.0)
    # a variant of a temperature variant with its own temperature: the nearest temperature wins
    mats["cold"] = {"base": "example-dma-T40", "temperature": -10.0}
    assert compound_and_temperature("cold", mats) == ("example-dma", -10.0)
    with pytest.raises(ValueError, match="materials.nosuch: unknown material preset"):
        compound_and_temperature("nosuch", mats)


def test_study_file_has_compound_and_temperature(tmp_path):
    st = StudySettings.from_config({"surface": "synth", "reference_material": "tread", "materials": list(COMPOUNDS),
                                    "accelerations": [500]}, d_max=2.5e-4)
    scale = {"tread": 1.0, "example-dma": 1.2, "example-dma-T0": 1.5, "example-dma-T40": 1.1}
    paths = []
    for m, mode, a in expected_cases(st):
        run = _synthetic.synthetic_run(m, mode, a, lambda d, s=scale[m]: s * 2e6 * (0.5 * d**2 / 1e-4 + 0.2 * d))
        paths.append(tio.write_dataset(run, tmp_path / f"{m}_{mode}.nc", {"test": 1}, stage="contact"))
    out = tmp_path / "study.nc"
    pipeline.run_study(paths, {"surface": "synth", "reference_material": "tread", "materials": list(COMPOUNDS),
                               "accelerations": [500]}, 2.5e-4, out, compounds=COMPOUNDS)
    ds = tio.read_dataset(out)
    assert list(ds["compound"].dims) == ["case"] and list(ds["temperature"].dims) == ["case"]
    assert ds["temperature"].attrs["units"] == "degC" and "units" not in ds["compound"].attrs
    by_case = dict(zip(ds["material"].values, zip(ds["compound"].values, ds["temperature"].values)))
    assert by_case["example-dma-T0"] == ("example-dma", 0.0) and by_case["example-dma"] == ("example-dma", 23.0)
    assert by_case["tread"][0] == "tread" and math.isnan(by_case["tread"][1])

    # compound x temperature: the dynamic cases, then every case with mode and acceleration as dimensions too
    grid = tio.unstack_compounds(ds.where(ds["mode"] == "dynamic", drop=True), "case")
    np.testing.assert_array_equal(grid["temperature"].values, [np.nan, 0.0, 23.0, 40.0])
    assert grid["temperature"].attrs["units"] == "degC"
    for m, (c, t) in COMPOUNDS.items():
        cell = grid["saturated_stiffness"].sel(compound=c).isel(temperature=0 if t is None else
                                                                  [0.0, 23.0, 40.0].index(t) + 1)
        assert float(cell) == pytest.approx(float(ds["saturated_stiffness"].sel(case=f"{m}/dynamic/500")), rel=1e-12)
    assert int(grid["saturated_stiffness"].notnull().sum()) == 4  # the other cells are combinations not run
    full = tio.unstack_compounds(ds, "case", ("mode", "accel"))
    assert set(full["saturated_stiffness"].dims) == {"compound", "temperature", "mode", "accel"}
    assert float(full["saturated_stiffness"].sel(compound="example-dma", temperature=40.0, mode="quasistatic",
                                                 accel=0.0)) == pytest.approx(
        float(ds["saturated_stiffness"].sel(case="example-dma-T40/quasistatic/0")), rel=1e-12)
    assert int(full["saturated_stiffness"].notnull().sum()) == ds.sizes["case"]


def test_combined_stiffness_file_has_compound_and_temperature(tmp_path):
    paths = []
    for i, m in enumerate(COMPOUNDS):
        ds = synthetic_spectrum(m)
        ds["storage_stiffness"] = ds["storage_stiffness"] * (1 + i)  # tell the materials apart
        paths.append(tio.write_dataset(ds, tmp_path / f"{m}.nc", {"stiffness_spectrum": {}}, stage="stiffness_spectrum",
                                       material=m))
    out = tmp_path / "stiffness_spectrum.nc"
    pipeline.run_stiffness_combined(paths, out, compounds=COMPOUNDS)
    ds = tio.read_dataset(out)
    assert ds["compound"].dims == ("material",) and ds["temperature"].attrs["units"] == "degC"
    np.testing.assert_array_equal(ds["temperature"].values, [np.nan, 23.0, 0.0, 40.0])
    grid = tio.unstack_compounds(ds)
    k = grid["storage_stiffness"]
    np.testing.assert_allclose(k.sel(compound="tread").isel(temperature=0), ds["storage_stiffness"].sel(material="tread"))
    for m, (c, t) in list(COMPOUNDS.items())[1:]:
        np.testing.assert_allclose(k.sel(compound=c, temperature=t), ds["storage_stiffness"].sel(material=m))
    assert int(k.isel(preload=0, frequency=0).notnull().sum()) == 4
    # the plain xarray recipe, for the materials that have a temperature
    warm = ds.isel(material=np.isfinite(ds["temperature"].values))
    plain = warm.set_index(material=["compound", "temperature"]).unstack("material")
    np.testing.assert_array_equal(plain["temperature"].values, [0.0, 23.0, 40.0])
    np.testing.assert_allclose(plain["storage_stiffness"].sel(compound="example-dma", temperature=0.0),
                               ds["storage_stiffness"].sel(material="example-dma-T0"))


def test_a_material_without_a_compound_is_an_error_naming_it(tmp_path):
    ds = synthetic_spectrum("tread").expand_dims(material=["tread"])
    with pytest.raises(ValueError, match=r"no compound and temperature for the material\(s\) tread"):
        tio.assign_compound_coords(ds, {"other": ["other", None]}, "material")


def test_the_workflow_passes_the_compounds(tmp_path):
    """The study and combined K* rules hand the compounds to their stages (params, so a change re-runs them)."""
    for rule, script in (("study", "study"), ("stiffness", "stiffness_combined")):
        assert "compounds=STUDY_COMPOUNDS" in (ROOT / "workflow" / "rules" / f"{rule}.smk").read_text()
        assert "compounds=snakemake.params.compounds" in (ROOT / "workflow" / "scripts" / f"{script}.py").read_text()
