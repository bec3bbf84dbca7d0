"""tyreroad.io: provenance, metadata checks, atomic writes."""

import numpy as np
import pytest
import xarray as xr
import yaml

from tyreroad import io


def _dataset():
    ds = xr.Dataset(
        {"force": ("step", np.array([0.0, 1.5, 3.0]), {"units": "N", "long_name": "total contact force"})},
        coords={"step": ("step", np.arange(3), {"units": "1", "long_name": "time step"})},
    )
    return ds


def test_write_records_provenance_and_round_trips(tmp_path):
    section = {"solver": {"tolerance": 1e-12, "d_max": 2.5e-4}}
    path = io.write_dataset(_dataset(), tmp_path / "a" / "run.nc", section, stage="contact")
    ds = io.read_dataset(path)
    np.testing.assert_array_equal(ds.force.values, [0.0, 1.5, 3.0])
    assert ds.force.attrs["units"] == "N"
    assert yaml.safe_load(ds.attrs["config"]) == section
    assert ds.attrs["config_sha256"] == io.config_hash(section)
    assert ds.attrs["tyreroad_version"] == io.code_version() != ""
    assert ds.attrs["stage"] == "contact"
    assert "created" in ds.attrs


def test_config_hash_is_order_independent_and_value_sensitive():
    assert io.config_hash({"a": 1, "b": 2}) == io.config_hash({"b": 2, "a": 1})
    assert io.config_hash({"a": 1, "b": 2}) != io.config_hash({"a": 1, "b": 3})
    assert io.config_hash({"a": np.float64(0.5)}) == io.config_hash({"a": 0.5})


def test_missing_units_is_refused_and_nothing_is_written(tmp_path):
    ds = _dataset()
    ds["force"].attrs.pop("units")
    target = tmp_path / "run.nc"
    with pytest.raises(ValueError, match="force.units"):
        io.write_dataset(ds, target, {})
    assert not target.exists()
    assert list(tmp_path.iterdir()) == []


def test_failed_write_keeps_existing_file_and_leaves_no_temporary(tmp_path):
    target = tmp_path / "run.nc"
    io.write_dataset(_dataset(), target, {"v": 1})
    before = target.read_bytes()
    with pytest.raises(RuntimeError):
        with io.atomic_path(target) as tmp:
            tmp.write_bytes(b"partial")
            raise RuntimeError("job failed half-way")
    assert target.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["run.nc"]


def test_complex_variables_are_refused(tmp_path):
    ds = _dataset()
    ds["frf"] = ("step", np.ones(3) * (1 + 1j), {"units": "m N-1", "long_name": "FRF"})
    with pytest.raises(TypeError, match="frf"):
        io.write_dataset(ds, tmp_path / "x.nc", {})


def test_read_missing_file_names_it(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.nc"):
        io.read_dataset(tmp_path / "nope.nc")


def test_written_files_get_normal_permissions(tmp_path):
    import os
    import stat

    umask = os.umask(0o022)
    try:
        path = io.write_dataset(_dataset(), tmp_path / "run.nc", {})
    finally:
        os.umask(umask)
    assert stat.S_IMODE(path.stat().st_mode) == 0o644


def test_read_selected_variables_keeps_coords_and_attrs(tmp_path):
    ds = xr.Dataset(
        {"stiffness": (("ex", "zeta"), np.arange(6.0).reshape(2, 3), {"units": "N/m", "long_name": "k"}),
         "area": (("ex", "zeta"), np.ones((2, 3)), {"units": "m2", "long_name": "A"})},
        coords={"zeta": ("zeta", [0.0, 1e-6, 2e-6], {"units": "m", "long_name": "zeta"})},
        attrs={"element_size": 1e-3},
    )
    path = io.write_dataset(ds, tmp_path / "s.nc", {"springs": {}})
    back = io.read_dataset(path, ["stiffness"])
    assert list(back.data_vars) == ["stiffness"]
    np.testing.assert_array_equal(back["stiffness"].values, ds["stiffness"].values)
    np.testing.assert_array_equal(back["zeta"].values, ds["zeta"].values)
    assert back.attrs["element_size"] == 1e-3
    with pytest.raises(KeyError, match=r"s\.nc: no variable\(s\) force"):
        io.read_dataset(path, ["stiffness", "force"])
    with pytest.raises(TypeError, match="sequence of names"):
        io.read_dataset(path, "stiffness")
