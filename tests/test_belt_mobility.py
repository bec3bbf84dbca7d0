"""Tread-surface mobilities on the flexible belt (tyreroad.belt_mobility).

One module-scoped dataset (the default 60 frequencies, 20 Hz - 5 kHz, 1 mm element, the default points plus their
mirror images in x) serves the passivity, symmetry, high-frequency, round-trip and figure checks (~8 s); the limit
checks use a few frequencies of their own. Tolerances are what was measured, with the margin stated.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from tyreroad.belt import DEFAULT_BELT, belt_point_mobility
from tyreroad.belt_mobility import (
    DEFAULT_OFFSETS,
    PUBLISHED_MOBILITY,
    PublishedStatement,
    infinite_plate_mobility,
    mobility_dataset,
    mobility_figure,
    run_belt_mobility,
    tread_surface_mobility,
)
from tyreroad.greens import element_frf
from tyreroad.io import read_dataset, write_dataset
from tyreroad.pipeline import _material, resolved_material_config

ROOT = Path(__file__).resolve().parents[1]
C = 1e-3
OFFSETS = (*DEFAULT_OFFSETS, (-0.010, 0.0), (-0.100, 0.0))
LABELS = ("point", "x 10 mm", "x 30 mm", "x 100 mm", "y 30 mm", "x -10 mm", "x -100 mm")


@pytest.fixture(scope="module")
def tread_cfg():
    cfg = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    return resolved_material_config("tread", cfg["materials"])


@pytest.fixture(scope="module")
def tread(tread_cfg):
    return _material("tread", tread_cfg)


@pytest.fixture(scope="module")
def ds(tread):
    return mobility_dataset(tread, DEFAULT_BELT, C, offsets=OFFSETS, labels=LABELS)


def _y(ds, prefix):
    return ds[f"{prefix}_real"].values + 1j * ds[f"{prefix}_imag"].values


def test_a_rigid_belt_gives_the_element_frf_back(tread):
    # belt.scaled(1e12): Delta g = O(1 / Z); measured |i w Delta g| <= 1.5e-13 m/(N s) at every offset, i.e. 9e-13 of
    # the driving-point mobility (and 9e-10 of the smallest transfer mobility, 30 mm across at 3 kHz)
    f = np.array([50.0, 500.0, 3000.0])
    w = 2 * math.pi * f
    off = np.array([[0.0, 0.0], [0.010, 0.0], [0.0, 0.030]])
    y = tread_surface_mobility(tread, DEFAULT_BELT.scaled(1e12), C, f, off)
    ref = 1j * w[:, None] * element_frf(off, C, w, tread.modulus(w), tread.poisson, tread.density, tread.thickness)
    assert np.max(np.abs(y["tread_belt"][:, 0] - ref[:, 0]) / np.abs(ref[:, 0])) < 1e-10
    assert np.all(np.abs(y["tread_belt"] - ref) < 1e-10 * np.abs(ref[:, :1]))
    np.testing.assert_array_equal(y["tread_rigid"], ref)


def test_driving_point_mobility_is_passive(ds):
    # exp(+i w t): a passive driving point has Re Y >= 0 (tread on belt, on a rigid belt, and the bare belt)
    i0 = int(np.nonzero((ds.offset_x.values == 0) & (ds.offset_y.values == 0))[0][0])
    assert np.all(_y(ds, "mobility")[:, i0].real > 0.0)
    assert np.all(_y(ds, "rigid_mobility")[:, i0].real > 0.0)
    assert np.all(_y(ds, "belt_mobility").real > 0.0)


def test_transfer_mobility_is_symmetric_in_x(ds):
    y = _y(ds, "mobility")
    labels = list(ds.point_label.values)
    for plus, minus in (("x 10 mm", "x -10 mm"), ("x 100 mm", "x -100 mm")):
        np.testing.assert_allclose(y[:, labels.index(minus)], y[:, labels.index(plus)], rtol=1e-12, atol=0.0)


def test_the_belt_matters_at_low_and_not_at_high_frequency(ds):
    y, yr = _y(ds, "mobility")[:, 0], _y(ds, "rigid_mobility")[:, 0]
    f = ds.frequency.values
    assert f[-1] == pytest.approx(5000.0)
    ratio = y[-1] / yr[-1]
    # measured at 5 kHz: |Y| / |Y_rigid| = 0.987, phase -1.6 deg (within 0.05 and 5 deg; a factor 2 is far outside)
    assert abs(abs(ratio) - 0.987) < 0.05
    assert abs(math.degrees(np.angle(ratio))) < 5.0
    # at 20 Hz the belt is in series with the tread: measured ratio 1.31
    assert abs(y[0]) / abs(yr[0]) == pytest.approx(1.31, abs=0.05)


def test_belt_alone_tends_to_the_infinite_plate():
    # 1/(8 sqrt(B m'')), B = sqrt(D_x D_y): measured |Y| / Y_inf on 2-10 kHz between 0.851 and 1.230, geometric
    # mean 0.987 (the finite, lightly damped strip still rings there); below 150 Hz at most 0.59 (stiffness-like)
    y_inf = infinite_plate_mobility(DEFAULT_BELT)
    b = DEFAULT_BELT
    assert y_inf == pytest.approx(1.0 / (8.0 * math.sqrt(math.sqrt(b.bending_x * b.bending_y) * b.mass)))
    f = np.geomspace(2000.0, 10000.0, 120)
    # with the causal loss the bending stiffness at 2-10 kHz is 1.2-1.4 x its 100 Hz value: the plate's level there
    r = np.abs(belt_point_mobility(2 * math.pi * f, DEFAULT_BELT)) / infinite_plate_mobility(DEFAULT_BELT, 2 * math.pi * f)
    assert 0.8 < r.min() and r.max() < 1.3
    assert np.exp(np.mean(np.log(r))) == pytest.approx(1.0, abs=0.03)
    low = np.abs(belt_point_mobility(2 * math.pi * np.geomspace(20.0, 150.0, 30), DEFAULT_BELT)) / y_inf
    assert low.max() < 0.7


def test_dataset_round_trip_through_netcdf(ds, tmp_path):
    path = write_dataset(ds, tmp_path / "belt_mobility.nc", {"test": True}, stage="belt_mobility")
    back = read_dataset(path)
    for name in ds.data_vars:
        np.testing.assert_array_equal(back[name].values, ds[name].values)
        assert back[name].attrs["units"] == "m/(N s)"
    np.testing.assert_array_equal(back.frequency.values, ds.frequency.values)
    np.testing.assert_array_equal(back.offset_x.values, ds.offset_x.values)
    assert list(back.point_label.values) == list(LABELS)
    assert back.attrs["belt_tension_x"] == DEFAULT_BELT.tension_x
    assert back.attrs["element_size"] == C


def test_figure_draws_bands_and_levels(ds, tmp_path):
    out = mobility_figure(ds, tmp_path / "fig" / "mobility.png")
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    level = PublishedStatement("test", "a test", "none", "none", "a level", 100.0, 1000.0, 1e-3, 1e-2)
    assert mobility_figure(ds, tmp_path / "levels.png", reference=[level]).is_file()


def test_published_table_says_where_each_statement_comes_from():
    assert PUBLISHED_MOBILITY
    for s in PUBLISHED_MOBILITY:
        assert s.source and s.statement and s.tyre and s.condition
        assert s.f_lo is not None or s.f_hi is not None
        # none of the sources read gave a level: the table must not pretend otherwise
        assert s.level_lo is None and s.level_hi is None


def test_run_belt_mobility_writes_file_and_figure(tread_cfg, tmp_path):
    ds = run_belt_mobility("tread", tread_cfg, {"loss_factor": 0.2}, tmp_path / "m.nc", tmp_path / "m.png",
                           frequencies=[100.0, 1000.0])
    back = read_dataset(tmp_path / "m.nc")
    assert back.attrs["belt_loss_factor"] == 0.2 and back.attrs["stage"] == "belt_mobility"
    assert "loss_factor: 0.2" in back.attrs["config"]
    np.testing.assert_array_equal(back.mobility_real.values, ds.mobility_real.values)
    assert (tmp_path / "m.png").is_file()
    with pytest.raises(ValueError, match="unknown belt property"):
        run_belt_mobility("tread", tread_cfg, {"stiffness": 1.0}, tmp_path / "x.nc", tmp_path / "x.png")
