"""The README's recipes run as written: every `tyreroad run` line plans (-n added when missing) in a copy of
the repository, every `tyreroad kstar` line runs on a synthetic K* file; the overlays are the README's own
YAML blocks (first line `# name.yaml`). The README stays a user guide of at most 8 kB that starts with the
two commands that .ci/run executes."""

from __future__ import annotations

import re
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import _synthetic

from tyreroad import io as tio

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def _recipe(title):
    """The text of the README section '## Recipe N: <title>'."""
    match = re.search(rf"^## Recipe \d: {re.escape(title)}\n(.*?)(?=^## |\Z)", README, re.S | re.M)
    assert match, f"README has no recipe '{title}'"
    return match.group(1)


def _blocks(text):
    """(language, body) of every fenced code block, opening and closing fences taken in pairs."""
    return [(m.group(1), m.group(2)) for m in re.finditer(r"^```(\w*)\n(.*?)^```$", text, re.S | re.M)]


def _yaml_blocks(text):
    """The YAML blocks whose first line names their file (``# my-road.yaml``)."""
    out = {}
    for lang, body in _blocks(text):
        first = body.split("\n", 1)[0]
        if lang == "yaml" and re.fullmatch(r"# \S+\.yaml", first):
            out[first[2:]] = body
    return out


def _commands(text, verb):
    """The `tyreroad <verb>` lines of the section's plain code blocks, comments removed."""
    lines = []
    for lang, block in _blocks(text):
        for line in block.splitlines() if lang == "" else ():
            line = line.split("#", 1)[0].strip()
            if line.startswith(f"tyreroad {verb}"):
                lines.append(shlex.split(line))
    return lines


def _tyreroad(args, cwd):
    return subprocess.run([sys.executable, "-m", "tyreroad.cli", *args], cwd=cwd, capture_output=True, text=True)


@pytest.fixture(scope="module")
def repo(tmp_path_factory):
    """A copy of the repository's workflow and config, with a measured scan where recipe 1 expects it."""
    wd = tmp_path_factory.mktemp("readme")
    _synthetic.copy_workflow(wd)
    rng = np.random.default_rng(25)
    (wd / "scans").mkdir()
    # 560 x 560 samples of 1/26 mm (21.5 mm square), heights 0 - 1 mm on a tilted plane (detrend: plane)
    x = np.arange(560) * 1e-3 / 26
    np.save(wd / "scans" / "myroad.npy", rng.uniform(0.0, 1.0e-3, (560, 560)) + 0.02 * x[:, None])
    return wd


def _planned(out):
    planned = set()
    for line in out.splitlines():
        if line.strip().startswith("output:"):
            planned.update(p.strip() for p in line.split(":", 1)[1].split(","))
    return planned


def _plan_recipe(title, repo):
    text = _recipe(title)
    for name, body in _yaml_blocks(text).items():
        (repo / name).write_text(body)
    commands = _commands(text, "run")
    assert commands, f"recipe '{title}' has no tyreroad run line"
    planned = set()
    for cmd in commands:
        args = cmd[1:] + ([] if "-n" in cmd else ["-n"])
        proc = _tyreroad(args, repo)
        assert proc.returncode == 0, f"{shlex.join(cmd)}:\n{proc.stdout[-2000:]}{proc.stderr[-4000:]}"
        assert "--configfile config/config.yaml" in proc.stderr  # the command it ran, printed
        planned |= _planned(proc.stdout + proc.stderr)
    return planned


def test_readme_starts_with_the_two_commands_and_is_a_short_user_guide():
    assert README.startswith(
        "# tyreroad\n\n```\n"
        "pip install -e . && snakemake -j2                # the full study -> results/\n"
        'pip install -e ".[test]" && pytest               # the test suite\n```\n')
    assert len(README.encode()) <= 8192
    assert "pytest -m slurm" in README and "## Running on a cluster (SLURM)" in README  # .ci/run's second command
    ci = (ROOT / ".ci" / "run").read_text().splitlines()
    assert 'pip install -e ".[test]" && pytest' in ci and "pytest -m slurm" in ci


def test_readme_links_resolve_inside_the_repository():
    links = re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", README)
    paths = re.findall(r"`((?:docs|workflow|config|profiles|tests)/[^` ]+)`", README)
    assert links
    missing = [p for p in links + paths if not (ROOT / p).exists()]
    assert not missing


@pytest.mark.slow
def test_recipe_your_road_plans(repo):
    planned = _plan_recipe("your road", repo)
    assert {"results-myroad/surface/myroad.nc", "results-myroad/springs/myroad/tread.nc",
            "results-myroad/contact/myroad/tread/dynamic_500.nc", "results-myroad/report.md"} <= planned


@pytest.mark.slow
def test_recipe_your_compound_plans(repo):
    planned = _plan_recipe("your compound", repo)
    assert {"results/greens/mycompound.nc", "results/contact/iso10844/mycompound/dynamic_500.nc",
            "results/stiffness_spectrum/iso10844/mycompound.nc", "results/stiffness_spectrum.nc"} <= planned
    assert {"results/greens/mycompound-T0.nc", "results/contact/iso10844/mycompound-T40/dynamic_500.nc"} <= planned


def test_recipe_your_compound_checks_its_table(repo):
    """The recipe's `tyreroad material` line runs as written and prints a preset block with the shift factors."""
    import yaml

    commands = _commands(_recipe("your compound"), "material")
    assert len(commands) == 1
    proc = _tyreroad(commands[0][1:], repo)
    assert proc.returncode == 0, proc.stderr
    assert "# example-dma-T0: T = 0 degC, a_T = 391.4," in proc.stdout and "Kramers-Kronig" in proc.stdout
    assert yaml.safe_load(proc.stdout)["materials"]["example-dma"]["temperatures"] == [0.0, 40.0]


def test_recipe_k_star_plans_and_exports(repo, tmp_path):
    from test_cli import PRELOADS, synthetic_spectrum

    planned = _plan_recipe("K* for your tyre model", repo)
    assert "results/stiffness_spectrum.nc" in planned
    assert "results/stiffness_spectrum/iso10844/tread.nc" in planned
    # the export lines, run as written on a synthetic K* file of the study's preloads
    assert PRELOADS.min() < 1.2e-4 < PRELOADS.max()
    tio.write_dataset(synthetic_spectrum(), tmp_path / "results" / "stiffness_spectrum" / "iso10844" / "tread.nc",
                      {}, stage="stiffness_spectrum", surface="iso10844", material="tread")
    commands = _commands(_recipe("K* for your tyre model"), "kstar")
    assert len(commands) == 2
    for cmd in commands:
        proc = _tyreroad(cmd[1:], tmp_path)
        assert proc.returncode == 0, proc.stderr
        out = tmp_path / cmd[cmd.index("--csv") + 1]
        rows = [ln for ln in out.read_text().splitlines() if not ln.startswith("#")]
        assert rows[0].startswith("centre_Hz" if "--third-octave" in cmd else "frequency_Hz") and len(rows) > 10
