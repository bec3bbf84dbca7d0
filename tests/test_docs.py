"""The documentation site builds with warnings as errors, and its tutorials execute in that build.

`mkdocs build --strict` (mkdocs.yml: material theme, markdown-exec) turns every warning into a failed build:
a missing page or anchor, a page left out of the nav, and an exception in a tutorial's executed code block.
The tutorials' output is checked in the built HTML, and a copy of the docs with one broken block must fail
to build, so that the test cannot pass with execution switched off.
"""

from __future__ import annotations

import html
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TUTORIALS = ("first_contact_run", "kstar", "compound_from_dma")


def _build(config: Path, site: Path, cwd: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, NO_MKDOCS_2_WARNING="1")  # mkdocs-material's banner about its successor
    return subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-f", str(config), "-d", str(site)],
                          cwd=cwd, env=env, capture_output=True, text=True, timeout=600)


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """The site built from the repository, as CI builds it (the tutorials read config/ from the repository)."""
    out = tmp_path_factory.mktemp("site")
    proc = _build(ROOT / "mkdocs.yml", out, ROOT)
    return proc, out


def _outputs(page: Path) -> str:
    """The text of the executed blocks' output on a built page (plain code blocks, not the highlighted source)."""
    text = page.read_text()
    return "\n".join(html.unescape(m) for m in re.findall(r"<pre><span></span><code>([^<]*)</code></pre>", text))


def test_site_builds_strictly_without_warnings(site):
    proc, out = site
    log = proc.stdout + proc.stderr
    assert proc.returncode == 0, log[-6000:]
    assert "WARNING" not in log and "Traceback" not in log, log[-6000:]
    assert (out / "index.html").is_file()
    for name in TUTORIALS:
        assert (out / "tutorials" / name / "index.html").is_file()


def test_tutorials_show_their_executed_output(site):
    _, out = site
    pages = {name: out / "tutorials" / name / "index.html" for name in TUTORIALS}
    number = r"\d+(?:\.\d+)?(?:e[+-]\d+)?"

    run = _outputs(pages["first_contact_run"])
    assert re.search(rf"K_sat \(median K over 0\.18-0\.25 mm\) = {number} N/m", run), run
    assert re.search(rf"F = {number} N with \d+ of 16 elements in contact", run), run
    assert re.search(r"construction: passive, sample rate 51200 Hz, 64 lags", run), run
    assert 'src="data:image/png;base64,' in pages["first_contact_run"].read_text()  # the K(d) figure

    kstar = _outputs(pages["kstar"])
    assert re.search(rf"d0 = 0\.1 mm: quasi-static K = {number} N/m", kstar), kstar
    assert "centre_Hz,nominal_Hz,lower_Hz,upper_Hz,storage_relaxed_N_per_m" in kstar
    assert re.search(rf"^\s+1000\s+{number}\s+{number}\s+{number}\s+{number}$", kstar, re.M), kstar

    dma = _outputs(pages["compound_from_dma"])
    assert re.search(r"example-dma-T0: T =\s+0 degC, a_T =\s+391\.4,", dma), dma  # the WLF shift at 0 degC
    assert "materials:\n  example-dma:\n    model: table" in dma


def test_a_tutorial_block_that_raises_fails_the_build(tmp_path):
    """The repository's mkdocs.yml on a copy of docs/ whose tutorials are one short block each: it builds
    with a block that runs, and fails with a block that raises (markdown-exec's warning under --strict)."""
    shutil.copy(ROOT / "mkdocs.yml", tmp_path / "mkdocs.yml")
    shutil.copytree(ROOT / "docs", tmp_path / "docs")
    tutorial = tmp_path / "docs" / "tutorials" / "first_contact_run.md"
    links = "[kstar](kstar.md) [dma](compound_from_dma.md)\n\n"

    def write(block: str) -> None:
        tutorial.write_text(f"# First run\n\n{links}```python exec=\"on\" result=\"text\"\n{block}\n```\n")
        for name in TUTORIALS[1:]:
            (tmp_path / "docs" / "tutorials" / f"{name}.md").write_text(f"# {name}\n")

    write('from tyreroad.kstar import parse_length\nprint(f"d0 = {parse_length(\'0.12mm\') * 1e6:.0f} um")')
    good = _build(tmp_path / "mkdocs.yml", tmp_path / "good", ROOT)
    assert good.returncode == 0, (good.stdout + good.stderr)[-4000:]
    assert "d0 = 120 um" in _outputs(tmp_path / "good" / "tutorials" / "first_contact_run" / "index.html")

    write('from tyreroad.kstar import parse_length\nprint(parse_length("twelve"))')
    bad = _build(tmp_path / "mkdocs.yml", tmp_path / "bad", ROOT)
    log = bad.stdout + bad.stderr
    assert bad.returncode != 0, log[-4000:]
    assert "Execution of python code block exited with errors" in log and "length 'twelve'" in log
    assert "Aborted with 1 warnings in strict mode" in log


def test_repository_paths_named_in_the_docs_exist():
    """docs/ names repository files as code paths (`tyreroad/greens.py`): the site cannot link them, so they
    are checked here, as tests/test_readme.py checks the README's."""
    pattern = r"`((?:docs|workflow|config|profiles|tests|tyreroad|benchmarks)/[^`\s*]+)`"
    named = {(page.relative_to(ROOT).as_posix(), path)
             for page in (ROOT / "docs").rglob("*.md") for path in re.findall(pattern, page.read_text())}
    assert named
    assert not [(page, path) for page, path in sorted(named) if not (ROOT / path).exists()]
