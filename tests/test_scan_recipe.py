"""The newcomer's scan case (issue 25, must-show 5): the default study's patch, exported as a ``.npy`` scan
and read back with the README's recipe 1 ("Your road") exactly as written, runs the surface stage and the
springs stage; the same scan under the schema default ``patch_selection: contact_fraction`` stops at
planning time (not 12 s into the job) with a message that names the keys to set and the cause: the default
``detrend: plane`` tilts the levelled patch (1.5 % of its peaks near the top instead of 51 %); with
``detrend: none`` the default rule takes the whole scan.

The overlay is the README's own YAML block (first line ``# my-road.yaml``), so a change of the documented
settings is tested here.
"""

from __future__ import annotations

import copy
import re
from pathlib import Path

import numpy as np
import pytest
import yaml
from snakemake.utils import validate

from tyreroad import config as C
from tyreroad import io as tio
from tyreroad import pipeline
from tyreroad import scans as SC
from tyreroad import surface as S

ROOT = Path(__file__).resolve().parents[1]
SCHEMA = ROOT / "workflow" / "schemas" / "config.schema.yaml"


def _recipe_overlay():
    """The README's ``# my-road.yaml`` block (recipe 1), parsed."""
    readme = (ROOT / "README.md").read_text()
    blocks = re.findall(r"^```yaml\n(# my-road\.yaml\n.*?)^```$", readme, re.S | re.M)
    assert len(blocks) == 1, "README has no (or more than one) '# my-road.yaml' block"
    return yaml.safe_load(blocks[0])


def _planned(overlay, base_dir):
    """config/config.yaml + ``overlay`` through the planning checks of workflow/rules/common.smk."""
    cfg = C.merge(C.load_config(ROOT / "config" / "config.yaml"), overlay)
    C.validate_schema(cfg, SCHEMA)
    cfg["materials"] = C.expand_material_temperatures(cfg)["materials"]
    validate(cfg, str(SCHEMA))  # inserts the schema's defaults (patch_selection: contact_fraction among them)
    C.check_config(cfg, base_dir=base_dir)
    return cfg


@pytest.fixture(scope="module")
def default_patch():
    """The default study's surface (config/config.yaml, preset iso10844), as the surface stage makes it."""
    cfg = C.load_config(ROOT / "config" / "config.yaml")
    validate(cfg, str(SCHEMA))
    return S.prepare_surface("iso10844", cfg["surfaces"]["iso10844"])


@pytest.fixture()
def exported(default_patch, tmp_path, monkeypatch):
    """The default patch's heights saved where the recipe expects the scan ([x, y] array in m, ``.npy``)."""
    (tmp_path / "scans").mkdir()
    height = default_patch["height"].values
    np.save(tmp_path / "scans" / "myroad.npy", height)
    monkeypatch.chdir(tmp_path)  # the job's working directory: relative scan paths resolve here
    return height


@pytest.mark.parametrize("detrend", ["plane", "none"])
def test_exported_default_patch_reads_back_with_the_readme_recipe(default_patch, exported, tmp_path, detrend):
    overlay = _recipe_overlay()
    assert overlay["surfaces"]["myroad"]["detrend"] == "plane"  # the recipe as written; 'none' is its alternative
    overlay["surfaces"]["myroad"]["detrend"] = detrend
    cfg = _planned(overlay, tmp_path)
    spec = cfg["surfaces"]["myroad"]
    assert spec["patch_selection"] == "centre" and spec["patch_elements"] == [20, 20]

    pipeline.run_prepare_surface("myroad", spec, "surface.nc", "surface.png")
    ds = tio.read_dataset("surface.nc")
    # the selected patch is the whole scan
    assert ds["height"].shape == exported.shape == (520, 520)
    assert (ds.attrs["patch_origin_x"], ds.attrs["patch_origin_y"]) == (0.0, 0.0)
    assert ds.attrs["field_size_x"] == pytest.approx(20e-3) and ds.attrs["field_size_y"] == pytest.approx(20e-3)
    if detrend == "none":  # the exported heights, bit for bit, and so the same element peaks
        assert np.array_equal(ds["height"].values, exported)
        assert np.array_equal(ds["z1"].values, default_patch["z1"].values)
    else:  # the exported heights less their least-squares plane (a few um over the patch)
        np.testing.assert_allclose(ds["height"].values, SC.plane_detrend(exported), rtol=0, atol=1e-15)
        removed = exported - ds["height"].values  # a plane: its own plane fit leaves nothing
        assert np.max(np.abs(SC.plane_detrend(removed))) < 1e-15
        # ... but not a negligible one: the patch's own least-squares plane spans ~0.6 mm, so the element
        # peaks move relative to each other and the read-back study is not the default one (hence
        # 'detrend: none' for levelled heights, as the recipe says)
        assert np.ptp(ds["z1"].values - default_patch["z1"].values) > 0.1e-3

    # the springs stage for the default material on the read-back patch
    mat = pipeline.spring_material_inputs("tread", cfg["materials"], cfg["springs"])
    pipeline.run_element_springs("surface.nc", "myroad", "tread", mat, cfg["springs"], "springs.nc")
    springs = tio.read_dataset("springs.nc")
    assert springs.attrs["surface"] == "myroad" and springs.attrs["material"] == "tread"
    assert (springs.sizes["ex"], springs.sizes["ey"]) == (20, 20)
    np.testing.assert_array_equal(springs["force"].isel(zeta=0).values, 0.0)
    assert np.all(np.diff(springs["force"].values, axis=-1) > 0)  # every element spring loads monotonically


def test_exported_patch_under_the_default_rule_stops_planning_naming_the_keys(exported, tmp_path):
    """The newcomer's case as it was: the schema default contact_fraction on an exported patch."""
    overlay = copy.deepcopy(_recipe_overlay())
    del overlay["surfaces"]["myroad"]["patch_selection"]
    with pytest.raises(C.ConfigError) as exc:
        _planned(overlay, tmp_path)
    msg = str(exc.value)
    assert "surfaces.myroad.patch_selection = 'contact_fraction'" in msg
    assert "'surfaces.myroad.patch_selection: centre'" in msg
    assert "'surfaces.myroad.origin: [x, y]'" in msg
    assert "myroad.npy" in msg
    assert re.search(r"no 20 x 20-element patch has 40 ?%-65 ?% of its element peaks", msg)
    assert "(closest to the target 51%: 1.5%;" in msg  # the newcomer's number
    # the cause: the plane removal tilts the levelled patch (as exported it has the contact fraction it was chosen for)
    assert "the heights as they are in the file have a patch with 51.0%" in msg
    assert "set 'surfaces.myroad.detrend: none'" in msg


def test_exported_patch_as_it_is_passes_the_default_rule(default_patch, exported, tmp_path):
    """With 'detrend: none' (heights already levelled) the default contact-fraction rule takes the whole scan."""
    overlay = copy.deepcopy(_recipe_overlay())
    del overlay["surfaces"]["myroad"]["patch_selection"]
    overlay["surfaces"]["myroad"]["detrend"] = "none"
    spec = _planned(overlay, tmp_path)["surfaces"]["myroad"]
    assert spec.get("patch_selection", "contact_fraction") == "contact_fraction"
    ds = S.prepare_surface("myroad", spec)
    assert ds.attrs["patch_selection"] == "contact_fraction" and ds.attrs["selected_fraction"] == 0.51
    assert np.array_equal(ds["z1"].values, default_patch["z1"].values)


def test_job_time_failure_of_a_plane_detrended_exported_patch_says_why(exported, tmp_path):
    """The same failure in the job (a scan too large to read at planning): the message has the same hint."""
    spec = {**_recipe_overlay()["surfaces"]["myroad"], "patch_selection": "contact_fraction"}
    with pytest.raises(ValueError) as exc:
        pipeline.run_prepare_surface("myroad", spec, "surface.nc", "surface.png")
    msg = str(exc.value)
    assert msg.startswith("surfaces.myroad.patch_selection = 'contact_fraction': no 20 x 20-element patch")
    assert "set 'surfaces.myroad.detrend: none'" in msg
    assert not Path("surface.nc").exists()


def test_job_time_failure_names_the_keys(tmp_path, monkeypatch):
    """A surface whose patch selection only runs in the job (here a generated field whose every element
    peak is at its top, as a scan above the planning read limit would be) fails naming the keys to set."""
    monkeypatch.chdir(tmp_path)
    spec = {"generator": "flat", "patch_elements": [4, 4], "field_size": [8e-3, 8e-3],
            "patch_selection": "contact_fraction"}
    with pytest.raises(ValueError) as exc:
        pipeline.run_prepare_surface("plain", spec, "surface.nc", "surface.png")
    msg = str(exc.value)
    assert msg.startswith("surfaces.plain.patch_selection = 'contact_fraction': no 4 x 4-element patch")
    assert "'surfaces.plain.patch_selection: centre'" in msg and "'surfaces.plain.origin: [x, y]'" in msg
    assert "'surfaces.plain.fraction_range'" in msg
    assert not Path("surface.nc").exists()
