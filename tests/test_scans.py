"""Tests of scan reading (tyreroad.scans) and of the file generator of prepare_surface."""

from __future__ import annotations

import logging
import sys

import numpy as np
import pytest
import xarray as xr

from tyreroad import scans as SC
from tyreroad import surface as S

ELEMENT = 1e-3
N = 26
STEP = ELEMENT / N
PATCH = [10, 8]


@pytest.fixture(scope="module")
def field():
    """A small ISO-like field (16 x 12 mm) in m, at the element grid step."""
    p = S.Iso10844Parameters(field_size=(16e-3, 12e-3))
    return S.generate_iso10844(p, STEP, np.random.default_rng(11))


def _preset(path, **kw):
    return {"generator": "file", "path": str(path), "element_size": ELEMENT, "samples_per_element": N,
            "patch_elements": PATCH, "patch_selection": "centre", **kw}


def _expected_z1(h, origin_samples=(0, 0)):
    i0, j0 = origin_samples
    patch = h[i0 : i0 + PATCH[0] * N, j0 : j0 + PATCH[1] * N]
    return S.element_peaks(patch, N, STEP)[0]


def _centre_origin(h):
    ex, ey = h.shape[0] // N, h.shape[1] // N
    return ((ex - PATCH[0]) // 2 * N, (ey - PATCH[1]) // 2 * N)


# --- round trips ---------------------------------------------------------------------------------
def test_npy_round_trip_exact_without_detrend(field, tmp_path):
    f = tmp_path / "scan.npy"
    np.save(f, field)
    ds = S.prepare_surface("scan", _preset(f, step=STEP, detrend="none"))
    assert np.array_equal(ds["z1"].values, _expected_z1(field, _centre_origin(field)))
    assert float(ds["mpd"]) == pytest.approx(S.mean_profile_depth(field, STEP, baseline=field.shape[0] * STEP))


def test_npy_round_trip_with_plane_detrend(field, tmp_path):
    f = tmp_path / "scan.npy"
    tilt = 1e-3 + 0.02 * (np.arange(field.shape[0]) * STEP)[:, None] - 0.01 * (np.arange(field.shape[1]) * STEP)
    np.save(f, field + tilt)
    ds = S.prepare_surface("scan", _preset(f, step=STEP, origin=[2e-3, 1e-3]))
    ref = SC.plane_detrend(field)
    np.testing.assert_allclose(ds["z1"].values, _expected_z1(ref, (2 * N, 1 * N)), rtol=0, atol=1e-15)
    assert ds.attrs["patch_origin_x"] == pytest.approx(2e-3)


def test_npy_height_unit_mm(field, tmp_path):
    f = tmp_path / "scan_mm.npy"
    np.save(f, field * 1e3)
    ds = S.prepare_surface("scan", _preset(f, step=STEP, height_unit="mm", detrend="none"))
    np.testing.assert_allclose(ds["z1"].values, _expected_z1(field, _centre_origin(field)), rtol=1e-14, atol=0)


@pytest.mark.parametrize("delimiter, suffix", [(",", ".csv"), (" ", ".txt"), ("\t", ".dat"), (";", ".csv")])
def test_text_grid_round_trip(field, tmp_path, delimiter, suffix):
    f = tmp_path / f"scan{suffix}"
    # one line per y, one column per x
    np.savetxt(f, field.T, delimiter=delimiter, fmt="%.17g", header="heights in m")
    ds = S.prepare_surface("scan", _preset(f, step=STEP, detrend="none"))
    assert np.array_equal(ds["z1"].values, _expected_z1(field, _centre_origin(field)))


def test_esri_ascii_round_trip(field, tmp_path):
    f = tmp_path / "scan.asc"
    hdr = (f"ncols {field.shape[0]}\nnrows {field.shape[1]}\nxllcorner 0\nyllcorner 0\n"
           f"cellsize {STEP * 1e3!r}\nNODATA_value -9999\n")
    body = "\n".join(" ".join(f"{v * 1e3:.17g}" for v in row) for row in field.T[::-1])  # north-up
    f.write_text(hdr + body + "\n")
    scan = SC.read_scan(SC.ScanSpec(path=f, height_unit="mm", lateral_unit="mm", detrend="none"))
    assert scan.step == pytest.approx((STEP, STEP), rel=1e-12)
    np.testing.assert_allclose(scan.height, field, rtol=1e-14, atol=0)


def test_xyz_round_trip_shuffled_mm(field, tmp_path):
    f = tmp_path / "scan.xyz"
    sub = field[: 12 * N, : 9 * N]
    i, j = np.meshgrid(np.arange(sub.shape[0]), np.arange(sub.shape[1]), indexing="ij")
    pts = np.c_[i.ravel() * STEP * 1e3, j.ravel() * STEP * 1e3, sub.ravel()]
    pts = pts[np.random.default_rng(0).permutation(len(pts))]
    np.savetxt(f, pts, fmt="%.10f %.10f %.17g", header="x y z", comments="")
    ds = S.prepare_surface("scan", _preset(f, lateral_unit="mm", detrend="none", origin=[1e-3, 0.0]))
    assert np.array_equal(ds["z1"].values, _expected_z1(sub, (N, 0)))


def test_netcdf_round_trip_with_coordinates(field, tmp_path):
    f = tmp_path / "scan.nc"
    x = np.arange(field.shape[0]) * STEP * 1e3
    y = np.arange(field.shape[1]) * STEP * 1e3
    da = xr.DataArray(field.T * 1e6, dims=("y", "x"), coords={"y": ("y", y, {"units": "mm"}),
                                                            "x": ("x", x, {"units": "mm"})},
                      attrs={"units": "um"}, name="z")
    da.to_dataset().to_netcdf(f)
    ds = S.prepare_surface("scan", _preset(f, height_unit="um", variable="z", detrend="none"))
    np.testing.assert_allclose(ds["z1"].values, _expected_z1(field, _centre_origin(field)), rtol=1e-14)
    with pytest.raises(ValueError, match=r"scan\.nc.*units 'um' but height_unit is 'm'"):
        S.prepare_surface("scan", _preset(f, variable="z"))


# --- detrend, resampling, gap filling ----------------------------------------------------------
def test_plane_detrend_removes_exact_plane():
    i, j = np.meshgrid(np.arange(37), np.arange(23), indexing="ij")
    plane = 3.0e-3 + 2.5e-5 * i - 4.0e-5 * j
    assert np.max(np.abs(SC.plane_detrend(plane))) < 1e-17
    z = np.random.default_rng(1).standard_normal(plane.shape) * 1e-4
    r = SC.plane_detrend(plane + z)
    np.testing.assert_allclose(r, SC.plane_detrend(z), atol=1e-17)
    # the residual is orthogonal to 1, i and j (least squares)
    for basis in (np.ones_like(r), i, j):
        assert abs(np.sum(r * basis)) < 1e-13


@pytest.mark.parametrize("scan_step", [STEP / 2.3, STEP * 1.7])
def test_resampling_reproduces_bilinear_function(tmp_path, scan_step):
    nx, ny = int(12e-3 / scan_step) + 1, int(9e-3 / scan_step) + 1
    x = np.arange(nx) * scan_step
    y = np.arange(ny) * scan_step
    f = lambda xx, yy: 1e-4 + 0.01 * xx - 0.02 * yy + 3.0 * xx * yy  # noqa: E731
    scan = SC.Scan(path=tmp_path / "s.npy", height=f(x[:, None], y[None, :]), step=(scan_step, scan_step))
    out = SC.to_element_grid(scan, STEP, PATCH, N)
    tx = np.arange(out.shape[0]) * STEP
    ty = np.arange(out.shape[1]) * STEP
    assert tx[-1] <= x[-1] + 1e-15 and tx[-1] + STEP > x[-1]
    np.testing.assert_allclose(out, f(tx[:, None], ty[None, :]), rtol=0, atol=1e-15)


def test_fill_gaps_interpolates_and_warns(tmp_path, caplog):
    i, j = np.meshgrid(np.arange(300), np.arange(260), indexing="ij")
    h = 2e-4 + 1e-7 * i - 3e-7 * j  # a plane: linear interpolation is exact
    h[100:104, 50:55] = np.nan
    h[200, 200] = np.nan
    f = tmp_path / "gappy.npy"
    np.save(f, h)
    with caplog.at_level(logging.WARNING, logger="tyreroad.scans"):
        scan = SC.read_scan(SC.ScanSpec(path=f, step=(STEP, STEP), fill_gaps=True, detrend="none"))
    assert scan.filled == 21
    np.testing.assert_allclose(scan.height, 2e-4 + 1e-7 * i - 3e-7 * j, rtol=0, atol=1e-18)
    assert any("filled 21 missing samples" in r.getMessage() and "gappy.npy" in r.getMessage() for r in caplog.records)
    # a gap on the border cannot be interpolated
    h[0:2, 0:2] = np.nan  # a corner lies outside the hull of the valid samples
    np.save(f, h)
    with pytest.raises(ValueError, match=r"gappy\.npy.*border"):
        SC.read_scan(SC.ScanSpec(path=f, step=(STEP, STEP), fill_gaps=True))


# --- bad input -----------------------------------------------------------------------------------
def test_nan_is_an_error_naming_the_file(field, tmp_path):
    h = field.copy()
    h[5, 7] = np.nan
    f = tmp_path / "holes.npy"
    np.save(f, h)
    with pytest.raises(ValueError, match=r"holes\.npy: 1 NaN or missing samples.*fill_gaps"):
        S.prepare_surface("scan", _preset(f, step=STEP))


def test_missing_text_samples_are_an_error(field, tmp_path):
    f = tmp_path / "short.csv"
    lines = [",".join(f"{v:.17g}" for v in row) for row in field[:, :300].T]
    lines[3] = lines[3].replace(",", ",,", 1)  # an empty field: one row longer
    f.write_text("\n".join(lines))
    with pytest.raises(ValueError, match=r"short\.csv"):
        S.prepare_surface("scan", _preset(f, step=STEP))


def test_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match=r"nothere\.npy"):
        S.prepare_surface("scan", _preset(tmp_path / "nothere.npy", step=STEP))


def test_relative_path_resolved_against_base_dir(field, tmp_path):
    np.save(tmp_path / "rel.npy", field)
    ds = S.prepare_surface("scan", _preset("rel.npy", step=STEP), base_dir=tmp_path)
    assert ds.attrs["source"].endswith("rel.npy")


def test_scan_smaller_than_patch(field, tmp_path):
    f = tmp_path / "small.npy"
    np.save(f, field[: 9 * N, :])
    with pytest.raises(ValueError, match=r"small\.npy: patch of 10 x 8 elements .* larger than the scan"):
        S.prepare_surface("scan", _preset(f, step=STEP))


def test_non_uniform_xyz_step(tmp_path):
    f = tmp_path / "bad.xyz"
    xs = np.array([0.0, 0.1, 0.2, 0.35, 0.45])  # mm: one spacing of 0.15
    i, j = np.meshgrid(xs, np.arange(5) * 0.1, indexing="ij")
    np.savetxt(f, np.c_[i.ravel(), j.ravel(), np.zeros(i.size)])
    with pytest.raises(ValueError, match=r"bad\.xyz: non-uniform x step"):
        SC.read_scan(SC.ScanSpec(path=f, lateral_unit="mm"))


def test_xyz_missing_points_are_missing_samples(tmp_path):
    f = tmp_path / "hole.xyz"
    i, j = np.meshgrid(np.arange(6) * 0.05, np.arange(5) * 0.05, indexing="ij")
    pts = np.c_[i.ravel(), j.ravel(), 1e-3 * np.ones(i.size)]
    np.savetxt(f, np.delete(pts, 13, axis=0))
    with pytest.raises(ValueError, match=r"hole\.xyz: 1 NaN or missing samples"):
        SC.read_scan(SC.ScanSpec(path=f, lateral_unit="mm", height_unit="mm"))


def test_wrong_height_units(field, tmp_path):
    f = tmp_path / "um.npy"
    np.save(f, field * 1e6)  # written in um, declared as m
    with pytest.raises(ValueError, match=r"um\.npy: heights span 1\.\d+e\+03 m .*look like um"):
        S.prepare_surface("scan", _preset(f, step=STEP))


def test_wrong_step_units(field, tmp_path):
    f = tmp_path / "step.npy"
    np.save(f, field)
    with pytest.raises(ValueError, match=r"step\.npy: step .*wrong units\?"):
        S.prepare_surface("scan", _preset(f, step=STEP * 1e3))  # mm value given as m


def test_step_required_for_npy(field, tmp_path):
    f = tmp_path / "nostep.npy"
    np.save(f, field)
    with pytest.raises(ValueError, match=r"nostep\.npy: .*set 'step'"):
        S.prepare_surface("scan", _preset(f))


def test_config_errors_name_keys(tmp_path):
    with pytest.raises(ValueError, match=r"surfaces\.scan\.height_unit"):
        S.prepare_surface("scan", _preset(tmp_path / "a.npy", step=STEP, height_unit="inch"))
    with pytest.raises(ValueError, match=r"surfaces\.scan\.stone_coverage"):
        S.prepare_surface("scan", _preset(tmp_path / "a.npy", step=STEP, stone_coverage=1.0))
    with pytest.raises(ValueError, match=r"surfaces\.scan\.path"):
        S.prepare_surface("scan", {**_preset("x", step=STEP), "path": None})
    with pytest.raises(ValueError, match=r"a\.weird: cannot infer the scan format"):
        (tmp_path / "a.weird").write_text("1 2\n3 4\n")
        S.prepare_surface("scan", _preset(tmp_path / "a.weird", step=STEP))


def test_instrument_format_needs_extra(tmp_path, monkeypatch):
    f = tmp_path / "scan.x3p"
    f.write_bytes(b"PK\x03\x04")
    monkeypatch.setitem(sys.modules, "SurfaceTopography", None)  # import fails as if not installed
    with pytest.raises(ImportError, match=r'pip install "tyreroad\[scans\]"'):
        S.prepare_surface("scan", _preset(f))


# --- issue 14: empty files, height range, flat scans ----------------------------------------------
def test_empty_file_is_an_error_naming_it(tmp_path):
    f = tmp_path / "empty.npy"
    f.write_bytes(b"")
    with pytest.raises(ValueError, match=r"empty\.npy: the scan file is empty \(0 bytes\)"):
        SC.read_scan(SC.ScanSpec(path=f, step=(STEP, STEP)))
    with pytest.raises(ValueError, match=r"empty\.npy: the scan file is empty"):
        SC.check_scan_header(SC.ScanSpec(path=f, step=(STEP, STEP)))


def test_flat_scan_is_an_error_naming_it(tmp_path):
    f = tmp_path / "flat.npy"
    i, j = np.meshgrid(np.arange(200), np.arange(150), indexing="ij")
    np.save(f, 1e-4 + 2e-7 * i - 1e-7 * j)  # a tilted plane: flat after detrending
    with pytest.raises(ValueError, match=r"flat\.npy: the scan is flat"):
        SC.read_scan(SC.ScanSpec(path=f, step=(STEP, STEP)))


@pytest.mark.parametrize("declared, true_unit", [("mm", "m"), ("m", "mm"), ("um", "nm"), ("pm", "um")])
def test_implausible_range_names_the_suspected_unit(field, tmp_path, declared, true_unit):
    f = tmp_path / "unit.npy"
    np.save(f, field / SC.UNIT_SCALE[true_unit])  # written in true_unit
    with pytest.raises(ValueError, match=rf"unit\.npy: heights span .* look like {true_unit} \(set height_unit: {true_unit}"):
        SC.read_scan(SC.ScanSpec(path=f, step=(STEP, STEP), height_unit=declared))


@pytest.mark.parametrize("unit", ["nm", "pm"])
def test_nm_and_pm_units(field, tmp_path, unit):
    f = tmp_path / "small.npy"
    np.save(f, field / SC.UNIT_SCALE[unit])
    scan = SC.read_scan(SC.ScanSpec(path=f, step=(STEP, STEP), height_unit=unit, detrend="none"))
    np.testing.assert_allclose(scan.height, field, rtol=1e-14, atol=0)


def test_netcdf_unit_attribute_as_surface_topography_writes_it(field, tmp_path):
    f = tmp_path / "unit.nc"
    x = np.arange(field.shape[0]) * STEP * 1e3
    y = np.arange(field.shape[1]) * STEP * 1e3
    xr.Dataset(
        {"heights": (("x", "y"), field * 1e3, {"unit": "mm"})},
        coords={"x": ("x", x, {"unit": "mm"}), "y": ("y", y, {"unit": "mm"})},
    ).to_netcdf(f)
    scan = SC.read_scan(SC.ScanSpec(path=f, height_unit="mm", detrend="none"))
    np.testing.assert_allclose(scan.step, (STEP, STEP), rtol=1e-12)
    np.testing.assert_allclose(scan.height, field, rtol=1e-14, atol=0)
    with pytest.raises(ValueError, match=r"unit\.nc: variable 'heights' has units 'mm' but height_unit is 'm'"):
        SC.read_scan(SC.ScanSpec(path=f, detrend="none"))


def test_header_check_reads_shape_and_step_without_the_data(field, tmp_path):
    np.save(tmp_path / "a.npy", field)
    info = SC.check_scan_header(SC.ScanSpec(path=tmp_path / "a.npy", step=(STEP, STEP)))
    assert info["shape"] == field.shape and info["step"] == (STEP, STEP) and info["format"] == "npy"
    xr.Dataset({"z": (("x", "y"), field)}, coords={"x": np.arange(field.shape[0]) * STEP,
                                                   "y": np.arange(field.shape[1]) * 2 * STEP}).to_netcdf(tmp_path / "b.nc")
    info = SC.check_scan_header(SC.ScanSpec(path=tmp_path / "b.nc"))
    assert info["shape"] == field.shape
    np.testing.assert_allclose(info["step"], (STEP, 2 * STEP), rtol=1e-12)


# --- crop window ----------------------------------------------------------------------------------
def test_border_nans_read_with_a_crop_window_give_the_peaks_of_the_array_cropped_in_memory(field, tmp_path):
    """Issue 15, must show 3."""
    h = field.copy()
    h[:9] = np.nan  # NaNs along the x = 0 border
    h[-1, 40:60] = np.nan  # and a few on the opposite border
    f = tmp_path / "border.npy"
    np.save(f, h)
    # without a crop: the error names the file and suggests the largest NaN-free window
    with pytest.raises(ValueError, match=r"border\.npy: .*largest NaN-free window is crop: \{origin: \[") as err:
        S.prepare_surface("scan", _preset(f, step=STEP))
    n_valid = (h.shape[0] - 10, h.shape[1])
    assert f"({n_valid[0]} x {n_valid[1]} samples)" in str(err.value)
    crop = {"origin": [9 * STEP, 0.0], "size": [n_valid[0] * STEP, n_valid[1] * STEP]}
    ds = S.prepare_surface("scan", _preset(f, step=STEP, crop=crop))
    np.save(tmp_path / "cropped.npy", field[9:-1])
    ref = S.prepare_surface("scan", _preset(tmp_path / "cropped.npy", step=STEP))
    assert ds.z1.shape == (PATCH[0], PATCH[1])
    np.testing.assert_array_equal(ds.z1.values, ref.z1.values)
    np.testing.assert_array_equal(ds.height.values, ref.height.values)
    # and against the peaks computed directly from the array cropped in memory (detrended as the reader does)
    o = _centre_origin(field[9:-1])
    np.testing.assert_array_equal(ds.z1.values, _expected_z1(SC.plane_detrend(field[9:-1]), o))


def test_crop_applies_before_gap_filling(tmp_path):
    i, j = np.meshgrid(np.arange(300), np.arange(260), indexing="ij")
    h = 2e-4 + 1e-6 * i - 3e-7 * j + 1e-4 * np.sin(i / 7.0) * np.cos(j / 5.0)
    h[:5] = np.nan  # border: only a crop removes it
    h[100:103, 50:53] = np.nan  # interior: filled
    f = tmp_path / "gaps.npy"
    np.save(f, h)
    crop = ((5 * STEP, 0.0), (295 * STEP, 260 * STEP))
    scan = SC.read_scan(SC.ScanSpec(path=f, step=(STEP, STEP), fill_gaps=True, crop=crop, detrend="none"))
    assert scan.height.shape == (295, 260) and scan.filled == 9
    assert not np.isnan(scan.height).any()
    np.testing.assert_array_equal(scan.height[:95], h[5:100])


def test_crop_outside_the_scan_is_an_error(field, tmp_path):
    np.save(tmp_path / "c.npy", field)
    with pytest.raises(ValueError, match=r"c\.npy: crop window .* does not lie inside the scan of 416 x 312 samples"):
        S.prepare_surface("scan", _preset(tmp_path / "c.npy", step=STEP, crop={"origin": [0.01, 0.0], "size": [0.01, 0.01]}))
    with pytest.raises(ValueError, match=r"surfaces\.scan\.crop"):
        S.prepare_surface("scan", _preset(tmp_path / "c.npy", step=STEP, crop={"origin": [0.0, 0.0]}))


def test_largest_valid_window_matches_brute_force():
    rng = np.random.default_rng(3)
    for _ in range(30):
        valid = rng.uniform(size=(rng.integers(1, 12), rng.integers(1, 12))) > rng.uniform(0.05, 0.5)
        (i0, j0), (ni, nj) = SC.largest_valid_window(valid)
        best = 0
        nx, ny = valid.shape
        for a in range(nx):
            for b in range(ny):
                for c in range(a + 1, nx + 1):
                    for d in range(b + 1, ny + 1):
                        if valid[a:c, b:d].all():
                            best = max(best, (c - a) * (d - b))
        assert ni * nj == best
        assert best == 0 or valid[i0 : i0 + ni, j0 : j0 + nj].all()


# --- SurfaceTopography's own writers (the scans extra; installed by the test extra) -------------------
@pytest.fixture(scope="module")
def topography(field):
    """A SurfaceTopography topography of the field in mm (416 x 312 samples)."""
    from SurfaceTopography import Topography

    nx, ny = field.shape
    return Topography(field * 1e3, physical_sizes=(nx * STEP * 1e3, ny * STEP * 1e3), unit="mm")


@pytest.mark.parametrize("dtype, rtol", [("D", 1e-15), ("F", 1e-7), ("L", 1e-9), ("I", 2e-5)])
def test_x3p_written_by_surface_topography(field, topography, tmp_path, dtype, rtol):
    f = tmp_path / f"scan_{dtype}.x3p"
    topography.to_x3p(str(f), dtype=dtype)
    scan = SC.read_scan(SC.ScanSpec(path=f, detrend="none"))
    np.testing.assert_allclose(scan.step, (STEP, STEP), rtol=1e-7)
    pv = field.max() - field.min()
    # integer types store (h - min) / range on the full range of the type: half a quantum of error
    np.testing.assert_allclose(scan.height, field, rtol=0, atol=rtol * pv + 1e-15 * pv)


def test_gwy_written_by_surface_topography(field, topography, tmp_path):
    f = tmp_path / "scan.gwy"
    topography.to_gwy(str(f))
    scan = SC.read_scan(SC.ScanSpec(path=f, detrend="none"))
    np.testing.assert_allclose(scan.step, (STEP, STEP), rtol=1e-12)
    np.testing.assert_allclose(scan.height, field, rtol=1e-15, atol=0)


def test_netcdf_written_by_surface_topography(field, topography, tmp_path):
    f = tmp_path / "scan.nc"
    topography.to_netcdf(str(f))
    scan = SC.read_scan(SC.ScanSpec(path=f, height_unit="mm", detrend="none"))  # our netCDF reader
    np.testing.assert_allclose(scan.step, (STEP, STEP), rtol=1e-12)
    np.testing.assert_allclose(scan.height, field, rtol=1e-15, atol=0)
    scan = SC.read_scan(SC.ScanSpec(path=f, format="instrument", detrend="none"))  # through SurfaceTopography
    np.testing.assert_allclose(scan.height, field, rtol=1e-15, atol=0)


def test_text_written_by_surface_topography(field, topography, tmp_path):
    f = tmp_path / "scan.txt"
    topography.to_matrix(str(f))
    # our text reader: rows are y, columns x, '#' header lines are comments; step and unit from the preset
    scan = SC.read_scan(SC.ScanSpec(path=f, step=(STEP, STEP), height_unit="mm", detrend="none"))
    np.testing.assert_allclose(scan.height, field, rtol=1e-15, atol=0)
    # SurfaceTopography's reader takes the sizes and the unit from the header
    scan = SC.read_scan(SC.ScanSpec(path=f, format="instrument", detrend="none"))
    np.testing.assert_allclose(scan.step, (STEP, STEP), rtol=1e-12)
    np.testing.assert_allclose(scan.height, field, rtol=1e-15, atol=0)


def test_instrument_file_without_a_unit_needs_the_preset_units(field, tmp_path):
    from SurfaceTopography import Topography

    nx, ny = field.shape
    f = tmp_path / "nounit.txt"
    Topography(field * 1e6, physical_sizes=(nx * STEP * 1e6, ny * STEP * 1e6)).to_matrix(str(f))
    with pytest.raises(ValueError, match=r"nounit\.txt: the file states no length unit; set height_unit and lateral_unit"):
        SC.read_scan(SC.ScanSpec(path=f, format="instrument"))
    spec = SC.scan_spec_from_config("s", {"path": str(f), "format": "instrument", "height_unit": "um",
                                          "lateral_unit": "um", "detrend": "none"})
    scan = SC.read_scan(spec)
    np.testing.assert_allclose(scan.step, (STEP, STEP), rtol=1e-12)
    np.testing.assert_allclose(scan.height, field, rtol=1e-14, atol=0)


def test_instrument_header_check(topography, tmp_path):
    f = tmp_path / "h.x3p"
    topography.to_x3p(str(f))
    info = SC.check_scan_header(SC.ScanSpec(path=f))
    assert info["format"] == "instrument" and info["shape"] == (416, 312)
    np.testing.assert_allclose(info["step"], (STEP, STEP), rtol=1e-7)
