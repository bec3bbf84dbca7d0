"""The units of the files the pipeline writes are CF-1.8 units, checked with cf-units (UDUNITS-2).

Every file claims ``Conventions: CF-1.8``: each numeric variable's ``units`` must parse in UDUNITS-2,
and text (label) variables carry no ``units`` (CF gives labels none). Levels in decibels, which
UDUNITS-2 does not know, are dimensionless (``units: "1"``) with their reference stated
(:func:`tyreroad.io.level_attrs`). The datasets are representative of the three kinds of files:
a surface (texture levels, element indices), a study (string case coordinates) and a loading study
(string coordinates of several kinds), each written by :func:`tyreroad.io.write_dataset` and read back.
"""

from __future__ import annotations

import pytest

cf_units = pytest.importorskip("cf_units")

import _synthetic  # noqa: E402
from tyreroad import io  # noqa: E402
from tyreroad import surface as S  # noqa: E402
from tyreroad.hysteresis import aggregate_loading  # noqa: E402
from tyreroad.study import StudySettings, aggregate, expected_cases  # noqa: E402


def cf_problems(ds) -> list[str]:
    """Every variable whose units CF-1.8 would not accept, with the reason."""
    problems = []
    for name, var in {**ds.data_vars, **ds.coords}.items():
        units = var.attrs.get("units")
        if io.is_text(var):
            if units is not None:
                problems.append(f"{name}: text variable with units {units!r}")
            continue
        if units is None:
            problems.append(f"{name}: no units")
            continue
        try:
            cf_units.Unit(units)
        except ValueError as err:
            problems.append(f"{name}: units {units!r} not UDUNITS-2 ({err})")
    return problems


def written(ds, tmp_path, name):
    return io.read_dataset(io.write_dataset(ds, tmp_path / f"{name}.nc", {"test": name}, stage=name))


def test_the_checker_catches_what_the_files_used_to_carry():
    import xarray as xr

    bad = xr.Dataset({"texture_level": ("band", [30.0], {"units": "dB re 1e-6 m", "long_name": "L"})},
                     coords={"material": ("case", ["tread"], {"units": "1", "long_name": "m"})})
    problems = cf_problems(bad)
    assert len(problems) == 2
    assert problems[0].startswith("texture_level: units 'dB re 1e-6 m' not UDUNITS-2")
    assert problems[1] == "material: text variable with units '1'"


def test_surface_file_units(tmp_path):
    ds = S.prepare_surface("spec", {
        "generator": "spectral", "seed": 1, "patch_elements": [6, 6], "field_size": [0.02, 0.02],
        "rms_height": 0.1e-3, "hurst": 0.8, "rolloff_wavelength": 5e-3, "skewness": -0.5,
        "patch_selection": "centre",
    })
    back = written(ds, tmp_path, "surface")
    assert cf_problems(back) == []
    level = back["texture_level"].attrs
    assert level["units"] == "1" and "[dB re 1e-6 m]" in level["long_name"]
    assert level["reference_value"] == pytest.approx(1e-6) and level["reference_value_units"] == "m"


def test_study_and_loading_files_units(tmp_path):
    st = StudySettings.from_config({"surface": "synth", "reference_material": "ref", "materials": ["ref"],
                                    "accelerations": [500]}, d_max=2.5e-4)
    runs = [_synthetic.synthetic_run(m, mode, a, lambda d: 2e6 * (0.5 * d**2 / 1e-4 + 0.2 * d))
            for m, mode, a in expected_cases(st)]
    study = aggregate(runs, st)
    assert study["material"].attrs.get("units") == "1"  # the producers still say "1": the writer drops it
    back = written(study, tmp_path, "study")
    assert cf_problems(back) == []
    assert "units" not in back["material"].attrs and back["material"].attrs["long_name"]

    cycles = []
    for run in runs:
        cycle = _synthetic.append_unloading(run)
        cycle.attrs.update(loading="cycle", loading_kind="cycle")
        cycles.append(cycle)
    loading = written(aggregate_loading(cycles), tmp_path, "loading")
    assert cf_problems(loading) == []
    assert {"case", "material", "mode", "loading"} <= set(loading.coords)


def test_rolling_band_level_attrs_are_cf():
    attrs = io.level_attrs("1/3-octave level of the force fluctuation", 1.0, "N")
    cf_units.Unit(attrs["units"])
    cf_units.Unit(attrs["reference_value_units"])
    assert attrs["long_name"].endswith("[dB re 1 N]") and attrs["level_units"] == "dB"
