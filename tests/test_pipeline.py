"""Stage functions of tyreroad.pipeline: a failing stage raises a clear error and leaves no file."""

import numpy as np
import pytest

from tyreroad import io, pipeline
from tyreroad.config import load_config
from tyreroad.contact import ContactConvergenceError

STEP = 1e-3 / 26


def _scan(tmp_path, nan=False):
    x = (np.arange(6 * 26) + 0.5) * STEP
    xx, yy = np.meshgrid(x, x, indexing="ij")
    heights = 2e-4 * np.sin(2 * np.pi * xx / 3.1e-3) * np.cos(2 * np.pi * yy / 2.3e-3) + 1e-5 * np.sin(xx / 1e-4)
    if nan:
        heights[40, 17] = np.nan
    path = tmp_path / ("bad.npy" if nan else "scan.npy")
    np.save(path, heights)
    return path


def _surface_spec(path):
    return {
        "generator": "file",
        "path": str(path),
        "step": STEP,
        "element_size": 1e-3,
        "samples_per_element": 26,
        "patch_elements": [4, 4],
        "patch_selection": "centre",
    }


def test_bad_scan_raises_naming_the_file_and_writes_nothing(tmp_path):
    bad = _scan(tmp_path, nan=True)
    out_nc, out_png = tmp_path / "out" / "s.nc", tmp_path / "out" / "s.png"
    with pytest.raises(Exception, match="bad.npy") as info:
        pipeline.run_prepare_surface("scan", _surface_spec(bad), out_nc, out_png)
    assert "NaN" in str(info.value) or "missing" in str(info.value)
    assert not out_nc.exists() and not out_png.exists()


def test_non_converging_contact_run_writes_nothing(tmp_path):
    config = load_config("config/config.yaml")
    scan = _scan(tmp_path)
    surface_nc, springs_nc, greens_nc = tmp_path / "surface.nc", tmp_path / "springs.nc", tmp_path / "greens.nc"
    pipeline.run_prepare_surface("scan", _surface_spec(scan), surface_nc, tmp_path / "surface.png")
    material_cfg = pipeline.resolved_material_config("tread", config["materials"])
    inputs = pipeline.spring_material_inputs("tread", config["materials"])
    pipeline.run_element_springs(surface_nc, "scan", "tread", inputs, config["springs"], springs_nc)
    greens_cfg = dict(config["greens"], n_lags=32)
    pipeline.run_greens("tread", material_cfg, greens_cfg, [4, 4], 1e-3, greens_nc)
    args = dict(
        surface_nc=surface_nc, springs_nc=springs_nc, greens_nc=greens_nc, surface_name="scan",
        material_name="tread", material_cfg=material_cfg, mode="dynamic", acceleration=500.0,
    )
    ok = tmp_path / "ok.nc"
    pipeline.run_contact(**args, solver_cfg={"d_max": 5e-5}, out_nc=ok)
    run = io.read_dataset(ok)
    assert run.force.values[-1] > 0 and float(run.residual.max()) <= 1e-12
    failed = tmp_path / "failed.nc"
    with pytest.raises(ContactConvergenceError, match=r"step \d+.*d = .*m"):
        pipeline.run_contact(**args, solver_cfg={"d_max": 5e-5, "max_iterations": 1}, out_nc=failed)
    assert not failed.exists()
