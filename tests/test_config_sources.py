"""A planning-time error about a key names the config file that set it (issue 25): with
``--configfile config/config.yaml my.yaml`` an overlay's bad key or value is reported as
``[greens.n_fft: set in my.yaml]``; a key no file sets (a schema default) names the file of its preset.

In-process tests of :func:`tyreroad.config.key_source` and friends, and two real ``snakemake -n`` runs
(about 3 s each) in a copy of the workflow.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

import _synthetic

from tyreroad import config as C

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture()
def files(tmp_path):
    (tmp_path / "base.yaml").write_text(
        "greens:\n  n_fft: 4096\nmaterials:\n  tread: {E0: 2.5e+7}\n  tread-eta0.5: {base: tread, loss_scale: 0.5}\n"
        "study:\n  accelerations: [500, 1000]\n")
    (tmp_path / "a.yaml").write_text("greens:\n  n_fft: 5000\nsurfaces:\n  myroad: {generator: file}\n")
    (tmp_path / "b.yaml").write_text("materials:\n  tread-eta0.5: {loss_scale: 0.7}\nstudy:\n  accelerations: [1, 2]\n")
    return [str(tmp_path / f) for f in ("base.yaml", "a.yaml", "b.yaml")]


def test_key_source_takes_the_last_file_that_sets_the_key(files):
    base, a, b = files
    assert C.key_source("greens.n_fft", files) == (a, "greens.n_fft", True)
    assert C.key_source("greens.n_fft", [a, base]) == (base, "greens.n_fft", True)
    # preset names with dots, list items
    assert C.key_source("materials.tread-eta0.5.loss_scale", files) == (b, "materials.tread-eta0.5.loss_scale", True)
    assert C.key_source("materials.tread-eta0.5.base", files) == (base, "materials.tread-eta0.5.base", True)
    assert C.key_source("study.accelerations[1]", files) == (b, "study.accelerations[1]", True)
    # a key no file sets: the file of its preset; a section alone names no file
    assert C.key_source("surfaces.myroad.patch_selection", files) == (a, "surfaces.myroad", False)
    assert C.key_source("greens.sample_rate", files) == (None, "greens.sample_rate", False)


def test_with_config_file_wording(files):
    base, a, b = files
    msg = "greens.n_fft = 5000: expected a power of two"
    assert C.with_config_file(msg, files) == f"{msg} [greens.n_fft: set in {a}]"
    msg = "surfaces.myroad.patch_selection = 'contact_fraction': no patch"
    assert C.with_config_file(msg, files).endswith(
        f"[surfaces.myroad.patch_selection: not set in any config file (a default); surfaces.myroad is set in {a}]")
    assert "in none of the config files" in C.with_config_file("greens.sample_rate = 1: bad", files)
    # a paragraph that starts with a file or a sentence is left alone
    for msg in (f"{a}, line 2: duplicate key 'n_fft'", "patch at origin [0, 0] m extends beyond the field"):
        assert C.with_config_file(msg, files) == msg


def test_naming_config_files_reraises_with_the_file(files):
    with pytest.raises(C.ConfigError, match=r"\[greens\.n_fft: set in .*a\.yaml\]$"):
        with C.naming_config_files(files):
            raise C.ConfigError("greens.n_fft = 5000: expected a power of two")
    with pytest.raises(ValueError, match=r"^plain$"):  # other errors pass unchanged
        with C.naming_config_files(files):
            raise ValueError("plain")


def test_config_file_order_puts_the_snakefile_configfile_first():
    # Snakemake lists the --configfile files first and appends the Snakefile's configfile:, which applies first
    assert C.config_file_order(["my.yaml", "config/config.yaml"], ["my.yaml"]) == ["config/config.yaml", "my.yaml"]
    assert C.config_file_order(["config/config.yaml", "my.yaml", "config/config.yaml"],
                               ["config/config.yaml", "my.yaml"]) == ["config/config.yaml", "my.yaml"]
    assert C.config_file_order(["config/config.yaml"], []) == ["config/config.yaml"]


def test_sections_are_the_schemas_top_level_keys():
    schema = yaml.safe_load((ROOT / "workflow" / "schemas" / "config.schema.yaml").read_text())
    assert set(C._SECTIONS) == set(schema["properties"])


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    wd = _synthetic.copy_workflow(tmp_path_factory.mktemp("sources"))
    (wd / "my.yaml").write_text("# my overlay\ngreens:\n  n_fft: 5000\n")
    (wd / "typo.yaml").write_text("surfaces:\n  iso10844:\n    seeed: 3\n")
    (wd / "later.yaml").write_text("greens:\n  n_lags: 256\n")
    return wd


def _plan(wd, *overlays):
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OPENBLAS_NUM_THREADS": "1"}
    proc = subprocess.run([sys.executable, "-m", "snakemake", "-n", "-j1", "--configfile", "config/config.yaml",
                           *overlays], cwd=wd, capture_output=True, text=True, env=env)
    return proc.returncode, proc.stdout + proc.stderr


def test_snakemake_names_the_overlay_of_a_bad_value(workdir):
    rc, out = _plan(workdir, "my.yaml")
    assert rc != 0
    assert "greens.n_fft = 5000" in out and "[greens.n_fft: set in my.yaml]" in out, out[-3000:]
    assert not (workdir / "results").exists()


def test_snakemake_names_the_overlay_of_an_unknown_key_among_several(workdir):
    rc, out = _plan(workdir, "typo.yaml", "later.yaml")
    assert rc != 0
    assert "surfaces.iso10844.seeed: unknown key; did you mean 'seed'?" in out, out[-3000:]
    assert "[surfaces.iso10844.seeed: set in typo.yaml]" in out, out[-3000:]
