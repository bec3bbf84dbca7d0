"""End-to-end: the whole workflow on the tiny study of config/test.yaml, in a temporary directory.

It never touches the repository's results/. Marked slow (about a minute on 2 cores). The copy of
the workflow also holds a results tree of the default study (results/), which the test study
(results-test/) must leave untouched, and the tests of what a change re-plans: a changed scan
file, a changed line of the package source.
"""

import hashlib
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import _synthetic
import yaml

import tyreroad
from tyreroad import io

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = ["config/config.yaml", "config/test.yaml"]
RESULTS = "results-test"  # results_dir of config/test.yaml
STEP = 1e-3 / 26  # element grid step [m]


def _snakemake(workdir, *args, overlays=(), env=None):
    """Snakemake on the test study (plus ``overlays``); ``args``: options and targets."""
    return subprocess.run(
        [sys.executable, "-m", "snakemake", "-j2", *args, "--configfile", *CONFIGS, *overlays],
        cwd=workdir,
        capture_output=True,
        text=True,
        env=env,
    )


def _planned(out):
    """Output files of the jobs a dry run plans."""
    planned = set()
    for line in out.splitlines():
        if line.strip().startswith("output:"):
            planned.update(p.strip() for p in line.split(":", 1)[1].split(","))
    return planned


def _digest(folder):
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


_DEFAULT_BEFORE: dict = {}  # digest of the default study's results tree before the test study ran


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    wd = tmp_path_factory.mktemp("study")
    _synthetic.copy_workflow(wd)
    # a results tree of the default study, as a completed run leaves it
    rng = np.random.default_rng(15)
    for rel in ("surface/iso10844.nc", "greens/tread.nc", "contact/iso10844/tread/dynamic_500.nc",
                "study.nc", "report.md", "figures/fig6_stiffness.png", "logs/study.log",
                "benchmarks/greens/tread.tsv"):
        (wd / "results" / rel).parent.mkdir(parents=True, exist_ok=True)
        (wd / "results" / rel).write_bytes(rng.bytes(512))
    default_before = _digest(wd / "results")
    # the study runs through the user's command (README): `tyreroad run -c config/test.yaml`, in a fresh copy
    proc = subprocess.run([sys.executable, "-m", "tyreroad.cli", "run", "-c", "config/test.yaml", "-j", "2"], cwd=wd,
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-6000:]
    assert "$ snakemake -j 2 --configfile config/config.yaml config/test.yaml" in proc.stderr
    _DEFAULT_BEFORE[wd] = default_before
    return wd


@pytest.mark.slow
def test_test_overlay_leaves_the_default_results_untouched(workdir):
    assert _digest(workdir / "results") == _DEFAULT_BEFORE[workdir]
    assert (workdir / RESULTS / "study.nc").is_file()
    assert (workdir / RESULTS / "logs" / "study.log").is_file()
    assert (workdir / RESULTS / "benchmarks" / "greens" / "tread.tsv").is_file()


@pytest.mark.slow
def test_full_tiny_study_produces_every_output(workdir):
    results = workdir / RESULTS
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
        "loading/iso10844/tread/quasistatic_cycle.nc",
        "loading/iso10844/tread/dynamic_cycle.nc",
        "loading.nc",
        "figures/fig10_hysteresis.png",
        "stiffness_spectrum/iso10844/tread.nc",
        "stiffness_spectrum/iso10844/tread-rho2.nc",
        "stiffness_spectrum.nc",
        "figures/fig9_stiffness_spectrum.png",
        "claim6.nc",  # issue 24: claim 6 by loss-variant definition
        "contact/iso10844/tread-eta0.5-a0/dynamic_500.nc",
    ]
    missing = [p for p in expected if not (results / p).is_file()]
    assert not missing
    loading = io.read_dataset(results / "loading.nc")
    w = dict(zip(loading["mode"].values.astype(str), loading["dissipated_energy"].values))
    work = dict(zip(loading["mode"].values.astype(str), loading["loading_work"].values))
    assert w["dynamic"] > 0.05 * work["dynamic"] and abs(w["quasistatic"]) <= 1e-6 * work["quasistatic"]
    assert "## Load-unload cycles: hysteresis" in (results / "report.md").read_text()
    assert "## Claim 6 by loss-variant definition" in (results / "report.md").read_text()


@pytest.mark.slow
def test_second_run_has_nothing_to_do(workdir):
    proc = _snakemake(workdir, "-n")
    assert proc.returncode == 0
    assert "Nothing to be done" in proc.stdout + proc.stderr


@pytest.mark.slow
def test_outputs_record_provenance_and_physics_is_sane(workdir):
    run = io.read_dataset(workdir / RESULTS / "contact/iso10844/tread/dynamic_500.nc")
    assert yaml.safe_load(run.attrs["config"])["solver"]["d_max"] == pytest.approx(1.0e-4)
    assert len(run.attrs["config_sha256"]) == 64
    # force grows with indentation and equals the sum of the element forces
    assert np.all(np.diff(run.force.values) >= -1e-9 * run.force.values.max())
    np.testing.assert_allclose(run.element_force.sum(("ex", "ey")).values, run.force.values, rtol=1e-12, atol=1e-15)
    assert float(run.residual.max()) <= 1e-12
    study = io.read_dataset(workdir / RESULTS / "study.nc")
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
    planned = _planned(out)
    assert planned, out[-3000:]
    stages = tuple(f"{RESULTS}/{stage}/" for stage in ("greens", "contact", "springs", "surface"))
    contact_and_greens = {p for p in planned if p.startswith(stages)}
    assert contact_and_greens == {
        f"{RESULTS}/greens/tread-rho2.nc",
        f"{RESULTS}/contact/iso10844/tread-rho2/quasistatic_0.nc",
        f"{RESULTS}/contact/iso10844/tread-rho2/dynamic_500.nc",
    }
    assert {f"{RESULTS}/study.nc", f"{RESULTS}/report.md"} <= planned


@pytest.fixture()
def package_copy(tmp_path):
    """A copy of the tyreroad package to edit; planning with it on PYTHONPATH hashes the copy."""
    src = Path(tyreroad.__file__).resolve().parent
    shutil.copytree(src, tmp_path / "tyreroad", ignore=shutil.ignore_patterns("__pycache__"))
    env = {**os.environ, "PYTHONPATH": str(tmp_path)}
    return tmp_path / "tyreroad", env


@pytest.mark.slow
def test_changed_package_line_replans_exactly_the_stages_that_run_it(workdir, package_copy):
    pkg, env = package_copy
    proc = _snakemake(workdir, "-n", env=env)
    assert proc.returncode == 0 and "Nothing to be done" in proc.stdout + proc.stderr  # a copy hashes the same
    greens = pkg / "greens.py"
    text = greens.read_text()
    line = "_GROUP = 32.0\n"
    assert text.count(line) == 1
    greens.write_text(text.replace(line, "_GROUP = 32.0  # a changed line\n"))
    proc = _snakemake(workdir, "-n", env=env)
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0, out
    planned = _planned(out)
    materials = ("tread", "tread-eta0.5", "tread-rho2")
    claim6 = ("tread-eta0.5-a0", "tread-eta0.5-storage", "tread-eta0.5-springs", "tread-eta0.5-layer")
    runs = {f"{RESULTS}/contact/iso10844/{m}/{mode}.nc" for m in materials for mode in ("quasistatic_0", "dynamic_500")}
    expected = {f"{RESULTS}/greens/{m}.nc" for m in materials} | runs | {
        f"{RESULTS}/study.nc", f"{RESULTS}/report.md",
        f"{RESULTS}/figures/fig2_material.png", f"{RESULTS}/figures/fig3_frf.png",
        *(f"{RESULTS}/figures/{n}.png" for n in ("fig5_force", "fig6_stiffness", "fig7_loss", "fig8_density")),
        # the test study's load-unload cycle of tread reads the greens file too
        *(f"{RESULTS}/loading/iso10844/tread/{mode}_cycle.nc" for mode in ("quasistatic", "dynamic")),
        f"{RESULTS}/loading.nc", f"{RESULTS}/figures/fig10_hysteresis.png",
        # K*(f) evaluates the element FRF (greens.py) itself
        *(f"{RESULTS}/stiffness_spectrum/iso10844/{m}.nc" for m in materials),
        f"{RESULTS}/stiffness_spectrum.nc",
        f"{RESULTS}/figures/fig9_stiffness_spectrum.png",
        # claim 6 (issue 24): the test study's anchor variant and checks (greens and one dynamic run each), and
        # the seed variant's K* from the element FRF
        *(f"{RESULTS}/{kind}" for m in claim6 for kind in (f"greens/{m}.nc", f"contact/iso10844/{m}/dynamic_500.nc")),
        f"{RESULTS}/claim6.nc",
        # the seed's kernel construction beside the default (issue 23): its greens, dynamic runs and study
        *(f"{RESULTS}/constructions/seed/greens/{m}.nc" for m in materials),
        *(f"{RESULTS}/constructions/seed/contact/iso10844/{m}/dynamic_500.nc" for m in materials),
        f"{RESULTS}/constructions/seed/study.nc",
    }
    assert planned == expected, planned ^ expected
    assert not any("/surface/" in p or "/springs/" in p for p in planned)


@pytest.mark.slow
def test_changed_scan_file_replans_its_surface_and_everything_downstream(workdir):
    rng = np.random.default_rng(16)
    scan = workdir / "scan.npy"
    heights = rng.uniform(0.0, 1.0e-3, (200, 180))
    np.save(scan, heights)
    (workdir / "scan.yaml").write_text(
        "surfaces:\n  scan: {generator: file, path: scan.npy, step: 3.846153846153846e-05, "
        "patch_elements: [6, 6], patch_selection: centre}\n"
    )
    target = f"{RESULTS}/contact/scan/tread/quasistatic_0.nc"
    proc = _snakemake(workdir, target, overlays=["scan.yaml"])
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    proc = _snakemake(workdir, "-n", target, overlays=["scan.yaml"])
    assert "Nothing to be done" in proc.stdout + proc.stderr, proc.stdout[-3000:] + proc.stderr[-3000:]
    np.save(scan, heights[::-1].copy())  # new contents
    proc = _snakemake(workdir, "-n", target, overlays=["scan.yaml"])
    assert proc.returncode == 0
    assert _planned(proc.stdout + proc.stderr) == {
        f"{RESULTS}/surface/scan.nc",
        f"{RESULTS}/figures/fig4_surface_scan.png",
        f"{RESULTS}/springs/scan/tread.nc",
        target,
    }


def test_lint_reports_only_the_conda_note():
    proc = subprocess.run(
        [sys.executable, "-m", "snakemake", "--lint"], cwd=ROOT, capture_output=True, text=True
    )
    lints = {line.strip() for line in (proc.stdout + proc.stderr).splitlines() if line.strip().startswith("* ")}
    assert lints == {"* Specify a conda environment or container for each rule.:"}, lints

