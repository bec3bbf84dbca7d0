"""Config validation: the JSON schema and the cross-reference checks, before any job runs."""

import copy
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from snakemake.utils import validate

from tyreroad.config import ConfigError, check_references, load_config, merge

ROOT = Path(__file__).resolve().parents[1]
SCHEMA = str(ROOT / "workflow" / "schemas" / "config.schema.yaml")


@pytest.fixture(scope="module")
def config():
    return load_config(ROOT / "config" / "config.yaml")


def _validate(cfg):
    validate(copy.deepcopy(cfg), SCHEMA)


def test_default_and_test_configs_are_valid(config):
    _validate(config)
    check_references(config)
    for name in ("test.yaml", "footprint.yaml"):
        overlay = load_config(ROOT / "config" / "config.yaml", ROOT / "config" / name)
        _validate(overlay)
        check_references(overlay)


@pytest.mark.parametrize(
    "mutate, expected",
    [
        (lambda c: c["solver"].update(tolerence=1e-9), "tolerence"),
        (lambda c: c["surfaces"]["iso10844"].update(element_size=-1e-3), "element_size"),
        (lambda c: c["greens"].update(sample_rate="fast"), "sample_rate"),
        (lambda c: c["materials"]["tread"].update(poisson_ratio=0.5), "poisson_ratio"),
        (lambda c: c["study"].update(accelerations=[500, -50]), "accelerations"),
        (lambda c: c.update(extra_section={}), "extra_section"),
    ],
)
def test_schema_rejects_bad_values_naming_the_key(config, mutate, expected):
    cfg = copy.deepcopy(config)
    mutate(cfg)
    with pytest.raises(Exception, match=expected):
        _validate(cfg)


def test_yaml_exponent_without_sign_is_caught_as_a_string(config):
    cfg = copy.deepcopy(config)
    cfg["materials"]["tread"]["E0"] = yaml.safe_load("x: 2.2e7")["x"]  # PyYAML reads this as the string '2.2e7'
    with pytest.raises(Exception, match="E0"):
        _validate(cfg)


@pytest.mark.parametrize(
    "mutate, expected",
    [
        (lambda c: c["study"].update(surface="nowhere"), "study.surface"),
        (lambda c: c["study"]["materials"].append("tread-x"), r"study.materials\[5\]"),
        (lambda c: c["materials"].update({"tread-y": {"base": "missing"}}), "materials.tread-y.base"),
        (lambda c: c["study"].update(saturation_range=[2e-4, 1e-4]), "saturation_range"),
    ],
)
def test_cross_references_are_checked(config, mutate, expected):
    cfg = copy.deepcopy(config)
    mutate(cfg)
    with pytest.raises(ConfigError, match=expected):
        check_references(cfg)


def test_merge_is_recursive_and_replaces_lists():
    base = {"a": {"x": 1, "y": [1, 2]}, "b": 2}
    out = merge(base, {"a": {"y": [3]}, "c": 4})
    assert out == {"a": {"x": 1, "y": [3]}, "b": 2, "c": 4}
    assert base["a"]["y"] == [1, 2]


def test_bad_config_stops_snakemake_before_any_job(tmp_path):
    for item in ("Snakefile", "workflow", "config"):
        src = ROOT / item
        (shutil.copytree if src.is_dir() else shutil.copy)(src, tmp_path / item)
    bad = tmp_path / "bad.yaml"
    bad.write_text("surfaces:\n  iso10844:\n    element_size: -0.001\n")
    proc = subprocess.run(
        [sys.executable, "-m", "snakemake", "-n", "-j1", "--configfile", "config/config.yaml", str(bad)],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert proc.returncode != 0
    assert "element_size" in proc.stdout + proc.stderr
    assert not (tmp_path / "results").exists()


def test_schema_defaults_are_accepted_by_the_package(config):
    """Snakemake inserts schema defaults into the config; the package must accept the result."""
    from tyreroad.contact import SolverSettings
    from tyreroad.greens import GreensSettings
    from tyreroad.material import material_from_config
    from tyreroad.springs import SpringModel

    cfg = copy.deepcopy(config)
    validate(cfg, SCHEMA)
    for name in cfg["materials"]:
        material_from_config(name, cfg["materials"])
    SpringModel.from_config(cfg["springs"])
    GreensSettings.from_config(cfg["greens"])
    SolverSettings.from_config(cfg["solver"])
