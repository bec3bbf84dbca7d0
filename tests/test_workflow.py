"""End-to-end: the whole workflow on the tiny study of config/test.yaml, in a temporary directory.

It never touches the repository's results/. Marked slow (about a minute on 2 cores).
"""

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from tyreroad import io

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = ["config/config.yaml", "config/test.yaml"]


def _snakemake(workdir, *args):
    return subprocess.run(
        [sys.executable, "-m", "snakemake", "-j2", "--configfile", *CONFIGS, *args],
        cwd=workdir,
        capture_output=True,
        text=True,
    )


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    wd = tmp_path_factory.mktemp("study")
    for item in ("Snakefile", "workflow", "config"):
        src = ROOT / item
        (shutil.copytree if src.is_dir() else shutil.copy)(src, wd / item)
    proc = _snakemake(wd)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-6000:]
    return wd


@pytest.mark.slow
def test_full_tiny_study_produces_every_output(workdir):
    results = workdir / "results"
    expected = [
        "surface/iso10844.nc",
        "springs/iso10844/tread.nc",
        "greens/tread.nc",
        "greens/tread-rho2.nc",
        "contact/iso10844/tread/quasistatic_0.nc",
        "contact/iso10844/tread/dynamic_500.nc",
        "contact/iso10844/tread-eta0.5/dynamic_500.nc",
        "study.nc",
        "report.md",
        "figures/fig2_material.png",
        "figures/fig3_frf.png",
        "figures/fig4_surface_iso10844.png",
        "figures/springs_iso10844.png",
        "figures/fig5_force.png",
        "figures/fig6_stiffness.png",
        "figures/fig7_loss.png",
        "figures/fig8_density.png",
        "stiffness_spectrum/iso10844/tread.nc",
        "stiffness_spectrum/iso10844/tread-rho2.nc",
        "figures/fig9_stiffness_spectrum.png",
    ]
    missing = [p for p in expected if not (results / p).is_file()]
    assert not missing


@pytest.mark.slow
def test_second_run_has_nothing_to_do(workdir):
    proc = _snakemake(workdir, "-n")
    assert proc.returncode == 0
    assert "Nothing to be done" in proc.stdout + proc.stderr


@pytest.mark.slow
def test_outputs_record_provenance_and_physics_is_sane(workdir):
    run = io.read_dataset(workdir / "results/contact/iso10844/tread/dynamic_500.nc")
    assert yaml.safe_load(run.attrs["config"])["solver"]["d_max"] == pytest.approx(1.0e-4)
    assert len(run.attrs["config_sha256"]) == 64
    # force grows with indentation and equals the sum of the element forces
    assert np.all(np.diff(run.force.values) >= -1e-9 * run.force.values.max())
    np.testing.assert_allclose(run.element_force.sum(("ex", "ey")).values, run.force.values, rtol=1e-12, atol=1e-15)
    assert float(run.residual.max()) <= 1e-12
    study = io.read_dataset(workdir / "results/study.nc")
    assert study.sizes["case"] == 3 * 2  # three materials, QS + one acceleration each


@pytest.mark.slow
def test_changing_one_variant_replans_only_that_variant(workdir):
    overlay = workdir / "rho.yaml"
    overlay.write_text("materials:\n  tread-rho2: {base: tread, density_scale: 2.5}\n")
    proc = subprocess.run(
        [sys.executable, "-m", "snakemake", "-n", "-j2", "--configfile", *CONFIGS, str(overlay)],
        cwd=workdir,
        capture_output=True,
        text=True,
    )
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0, out
    planned = set()
    for line in out.splitlines():
        if line.strip().startswith("output:"):
            planned.update(p.strip() for p in line.split(":", 1)[1].split(","))
    contact_and_greens = {p for p in planned if p.startswith(("results/greens/", "results/contact/", "results/springs/", "results/surface/"))}
    assert contact_and_greens == {
        "results/greens/tread-rho2.nc",
        "results/contact/iso10844/tread-rho2/quasistatic_0.nc",
        "results/contact/iso10844/tread-rho2/dynamic_500.nc",
    }
    assert {"results/study.nc", "results/report.md"} <= planned


def test_lint_reports_only_the_conda_note():
    proc = subprocess.run(
        [sys.executable, "-m", "snakemake", "--lint"], cwd=ROOT, capture_output=True, text=True
    )
    lints = {line.strip() for line in (proc.stdout + proc.stderr).splitlines() if line.strip().startswith("* ")}
    assert lints == {"* Specify a conda environment or container for each rule.:"}, lints


def test_slurm_profile_plans_the_study(tmp_path):
    """The cluster profile (issue 7) is a valid workflow profile: a dry run plans every job."""
    for item in ("Snakefile", "workflow", "config", "profiles"):
        src = ROOT / item
        (shutil.copytree if src.is_dir() else shutil.copy)(src, tmp_path / item)
    proc = subprocess.run(
        [sys.executable, "-m", "snakemake", "--workflow-profile", "profiles/slurm", "-n"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0, out[-3000:]
    totals = [line.split() for line in out.splitlines() if line.startswith("total")]
    # 5 materials x (3 + 1) runs + 5 stiffness spectra + 18 other jobs (figure 9 included)
    assert totals and int(totals[0][1]) == 43, out[-3000:]
