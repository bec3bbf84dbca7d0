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
