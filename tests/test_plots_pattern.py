"""tyreroad.plots.pattern: the patterned-tread figures (issue 27), the numbers they are drawn from, the report's
figure links and the planning of rule pattern_figures."""

from __future__ import annotations

import subprocess
import sys

import matplotlib.image as mpimg
import numpy as np
import pytest
import xarray as xr
import yaml

import _synthetic
from test_figure_captions import _stem, figure_outputs  # noqa: F401 (the fixture: every .png output of the rules)
from tyreroad import io, pipeline
from tyreroad.pattern import PatternGeometry
from tyreroad.pattern_stage import pattern_greens_dataset, slick_greens_dataset
from tyreroad.pipeline import _material, resolved_material_config
from tyreroad.plots import pattern as pp
from tyreroad.report.figures import FIGURE_CAPTIONS
from tyreroad.report.pattern import figures_section

C = 1e-3
# 4 x 4 x 10 mm FE block, default mesh (Hex S2, 2 per element): edge-centre / centre, corner / centre, the same
# numbers tests/test_fe_pattern.py measures (RATIO_4MM); a wrong row/column order or normalisation breaks them
RATIO_4MM = (1.7231, 2.4868)


@pytest.fixture(scope="module")
def tread():
    cfg = yaml.safe_load(open("config/config.yaml"))
    return _material("tread", resolved_material_config("tread", cfg["materials"]))


def _geometry(name, length, width, groove=2e-3):
    return PatternGeometry.from_config(name, {"block_length": length, "block_width": width, "groove_width": groove,
                                              "groove_depth": 0.01}, C)


@pytest.fixture(scope="module")
def fe_blocks(tread):
    """Real FE block tables (tyreroad.fe_pattern, default mesh): 4 x 4 mm (even: four central elements) and
    5 x 5 mm (odd: one central element); 0.4 s and 0.7 s."""
    return {n: pattern_greens_dataset(_geometry(f"b{n}", n * C, n * C), tread, "fe") for n in (4, 5)}


def synthetic_greens(nx=6, ny=4, name="synth", g0=3e-5):
    """A greens file with a known diagonal: g_ii = g0 (1 + 1/(1 + distance to the nearest side [elements]))
    (symmetric, softest at the corners), and a small coupling off the diagonal."""
    ix, iy = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    dist = np.minimum(np.minimum(ix, nx - 1 - ix), np.minimum(iy, ny - 1 - iy))
    diag = (g0 * (1 + 1 / (1 + dist))).ravel()  # row-major over x then y
    g = np.full((diag.size, diag.size), 0.1 * g0)
    np.fill_diagonal(g, diag)
    x, y = (ix.ravel() + 0.5) * C, (iy.ravel() + 0.5) * C
    n = nx * ny
    return xr.Dataset({"influence": (("element", "source"), g, {"units": "m/N"})},
                      coords={"element": np.arange(n), "source": np.arange(n), "x": ("element", x),
                              "y": ("element", y)},
                      attrs={"pattern": name, "material": "tread", "element_size": C, "influence_model": "synthetic"})


def synthetic_spectrum(pattern="b20", scale=0.5, natural=((6700.0, 7000.0), (3670.0, 7000.0), (3670.0, 7000.0),
                                                          (3900.0, 6000.0)), slick_shift=0.0):
    f = np.geomspace(10.0, 5000.0, 12)
    k_slick = 12e6 * (1 + 0.1 * np.log10(f)) * (1 + slick_shift)
    eta_slick = 0.07 + 0.01 * np.log10(f)
    k1 = np.stack([scale * k_slick, k_slick])[:, None, :]
    eta = np.stack([eta_slick + 0.03, eta_slick])[:, None, :]
    def c(units, name):
        return {"units": units, "long_name": name}

    return xr.Dataset(
        {"k_storage": (("case", "preload", "frequency"), k1, c("N/m", "K'")),
         "k_loss": (("case", "preload", "frequency"), k1 * eta, c("N/m", "K''")),
         "contact_count": (("case", "preload"), np.array([[900], [1400]]), c("1", "contact")),
         "natural_frequency": (("symmetry_class", "mode"), np.array(natural), c("Hz", "block modes"))},
        coords={"case": ("case", [pattern, "slick"], {"long_name": "case"}),
                "preload": ("preload", [1e-4], c("m", "d0")), "frequency": ("frequency", f, c("Hz", "f")),
                "symmetry_class": ("symmetry_class", ["even-x even-y", "even-x odd-y", "odd-x even-y", "odd-x odd-y"],
                                   {"long_name": "class"}),
                "mode": ("mode", [0, 1], c("1", "mode"))},
        attrs={"pattern": pattern, "material": "tread"})


@pytest.fixture
def captured(monkeypatch):
    """Keep the figures instead of writing them."""
    return _synthetic.capture_figures(monkeypatch, pp)


def _png_is_a_picture(path, min_bytes=20_000):
    assert path.is_file() and path.stat().st_size > min_bytes
    img = mpimg.imread(path)
    assert img.ndim == 3 and img.shape[0] > 400 and img.shape[1] > 800
    assert float(img[..., :3].std()) > 0.05  # not a blank canvas


# --- the numbers the compliance figure is drawn from --------------------------------------------------------------

def test_compliance_grid_reads_the_row_major_diagonal():
    ds = synthetic_greens(6, 4)
    x, y, g = pp.compliance_grid(ds)
    np.testing.assert_allclose(x, (np.arange(6) + 0.5) * C, rtol=0, atol=1e-15)
    np.testing.assert_allclose(y, (np.arange(4) + 0.5) * C, rtol=0, atol=1e-15)
    assert g.shape == (6, 4)
    diag = np.diagonal(ds["influence"].values)
    assert g[2, 3] == diag[2 * 4 + 3] and g[5, 0] == diag[5 * 4]  # (ix, iy) is element ix * ny + iy


def test_edge_profile_and_ratios_on_a_known_diagonal():
    """6 x 4 elements: middle rows iy = 1, 2 (distance 1 from y's sides), so the middle-row g/g0 = 1 + 1/(1 + d) with
    d = min(ix, 5 - ix, 1): 1.5 at the ends (ix 0, 5 have d = 0: 2), centre elements ix = 2, 3 at 1.5."""
    ds = synthetic_greens(6, 4)
    pos, prof = pp.edge_profile(ds)
    np.testing.assert_allclose(pos, (np.arange(6) - 2.5) * C, atol=1e-15)
    np.testing.assert_allclose(prof, np.array([2.0, 1.5, 1.5, 1.5, 1.5, 2.0]) / 1.5, rtol=1e-14)
    r = pp.softening_ratios(ds)
    assert r["centre"] == pytest.approx(1.5 * 3e-5, rel=1e-14)
    assert r["edge"] == pytest.approx(2.0 / 1.5, rel=1e-14) and r["corner"] == pytest.approx(2.0 / 1.5, rel=1e-14)


@pytest.mark.parametrize("n", [4, 5])
def test_edge_profile_of_a_real_fe_block(fe_blocks, n):
    """On the FE block: the middle-row profile is symmetric (the quarter model's mirror planes), 1 at the centre,
    and rises monotonically to the free sides; on the 4 mm block the ratios are the measured 1.723 / 2.487."""
    ds = fe_blocks[n]
    pos, prof = pp.edge_profile(ds)
    assert pos.size == n
    np.testing.assert_allclose(pos, -pos[::-1], atol=1e-15)
    np.testing.assert_allclose(prof, prof[::-1], rtol=1e-12)
    mid = [n // 2] if n % 2 else [n // 2 - 1, n // 2]
    np.testing.assert_allclose(prof[mid], 1.0, rtol=1e-12)
    half = prof[: (n + 1) // 2]
    assert np.all(np.diff(half) < 0), prof  # softer towards the sides
    r = pp.softening_ratios(ds)
    assert r["edge"] == pytest.approx(prof[0], rel=1e-12) and 1.3 < r["edge"] < r["corner"]
    _, _, g = pp.compliance_grid(ds)
    assert r["centre"] == pytest.approx(g[mid[-1], mid[-1]], rel=1e-12)  # the four central ones are equal
    if n == 4:
        assert (r["edge"], r["corner"]) == pytest.approx(RATIO_4MM, abs=2e-4)


def test_standin_block_has_no_edge_softening(tread):
    """The stand-in table is the flat layer restricted to the block: every g_ii equal, the profile 1 everywhere."""
    ds = pattern_greens_dataset(_geometry("s5", 5 * C, 3 * C), tread, "standin")
    _, prof = pp.edge_profile(ds)
    np.testing.assert_allclose(prof, 1.0, rtol=1e-12)
    r = pp.softening_ratios(ds)
    assert r["edge"] == pytest.approx(1.0, rel=1e-12) and r["corner"] == pytest.approx(1.0, rel=1e-12)


def test_compliance_figure_names_the_missing_variable(tread, tmp_path):
    slick = slick_greens_dataset((4, 4), C, tread).assign_attrs(pattern="slick")
    with pytest.raises(ValueError, match=r"slick \(#1\) lacks variable\(s\) \['influence', 'x', 'y'\].*g_static"):
        pp.compliance_map_figure([synthetic_greens(), slick], tmp_path / "x.png")
    with pytest.raises(ValueError, match="no greens datasets"):
        pp.compliance_map_figure([], tmp_path / "x.png")
    assert not (tmp_path / "x.png").exists()
    bad = synthetic_greens().drop_vars("y")
    with pytest.raises(ValueError, match=r"lacks variable\(s\) \['y'\]"):
        pp.edge_profile(bad)


def test_compliance_figure_draws_each_block_and_its_cut(fe_blocks, captured, tmp_path):
    out = pp.compliance_map_figure([fe_blocks[4], fe_blocks[5]], tmp_path / "map.png")
    assert out == tmp_path / "map.png"
    (fig,) = captured
    images = [im for ax in fig.axes for im in ax.get_images()]
    assert len(images) == 2
    _, _, g5 = pp.compliance_grid(fe_blocks[5])
    np.testing.assert_allclose(images[1].get_array(), (g5 / g5[2, 2]).T, rtol=1e-12)
    assert images[0].get_clim() == images[1].get_clim()  # one colour scale
    cut = next(ax for ax in fig.axes if len(ax.get_lines()) >= 2)
    pos, prof = pp.edge_profile(fe_blocks[4])
    line = cut.get_lines()[0]
    np.testing.assert_allclose(line.get_xdata(), 1e3 * pos)
    np.testing.assert_allclose(line.get_ydata(), prof)
    r = pp.softening_ratios(fe_blocks[4])
    assert f"edge {r['edge']:.3f}×, corner {r['corner']:.3f}×" in fig.axes[0].get_title()


def test_compliance_figure_writes_a_png(fe_blocks, tmp_path):
    out = pp.compliance_map_figure([fe_blocks[4], fe_blocks[5]], tmp_path / "sub" / "map.png")
    _png_is_a_picture(out)


# --- the K* figure ------------------------------------------------------------------------------------------------

def test_lowest_modes_merge_the_rocking_pair_and_sort():
    modes = pp.lowest_modes(synthetic_spectrum())
    assert [f for f, _ in modes] == [3670.0, 3900.0, 6700.0]
    assert modes[0][1] == "rocking pair (even-x odd-y / odd-x even-y)"
    assert modes[1][1] == "twist (odd-x odd-y)" and modes[2][1] == "vertical (even-x even-y)"
    assert pp.lowest_modes(synthetic_spectrum().drop_vars("natural_frequency")) == []


def test_spectrum_figure_draws_k_and_eta_and_slick_once(captured, tmp_path):
    a, b = synthetic_spectrum("b20", 0.5), synthetic_spectrum("b40", 0.6)
    pp.pattern_spectrum_figure([a, b], tmp_path / "k.png")
    (fig,) = captured
    ax_k, ax_eta = fig.axes[:2]
    assert ax_k.get_xscale() == "log"
    curves = [ln for ln in ax_k.get_lines() if len(ln.get_xdata()) > 2]
    assert [ln.get_label().split(" (")[0] for ln in curves] == ["b20", "slick", "b40"]  # the same slick: once
    np.testing.assert_allclose(curves[0].get_ydata(), a["k_storage"].sel(case="b20").values[0] / 1e6, rtol=1e-14)
    eta = [ln for ln in ax_eta.get_lines() if len(ln.get_xdata()) > 2]
    np.testing.assert_allclose(eta[1].get_ydata(), (a["k_loss"] / a["k_storage"]).sel(case="slick").values[0],
                               rtol=1e-14)
    marks = sorted({float(ln.get_xdata()[0]) for ln in ax_k.get_lines() if len(ln.get_xdata()) == 2})
    assert marks == [3670.0, 3900.0]  # the lowest modes on the axis (6.7 kHz lies above 5 kHz)
    assert "vertical (even-x even-y) 6.70 kHz (off the axis)" in fig._supxlabel.get_text()


def test_spectrum_figure_keeps_a_slick_case_that_differs(captured, tmp_path):
    pp.pattern_spectrum_figure([synthetic_spectrum("b20"), synthetic_spectrum("b40", slick_shift=0.01)],
                               tmp_path / "k.png")
    labels = [ln.get_label() for ln in captured[0].axes[0].get_lines() if len(ln.get_xdata()) > 2]
    assert len(labels) == 4 and "differs" in labels[-1]


def test_spectrum_figure_names_what_is_missing(tmp_path):
    with pytest.raises(ValueError, match=r"b20 \(#0\) lacks variable\(s\) \['k_loss'\]"):
        pp.pattern_spectrum_figure([synthetic_spectrum().drop_vars("k_loss")], tmp_path / "k.png")
    with pytest.raises(ValueError, match="no case 'slick'"):
        pp.pattern_spectrum_figure([synthetic_spectrum().sel(case=["b20"])], tmp_path / "k.png")


def test_run_pattern_figures_writes_both_pngs_from_files(fe_blocks, tmp_path):
    """The stage function reads the files (io round trip) and writes the spectrum figure only when asked."""
    greens = tmp_path / "b4.nc"
    spectrum = tmp_path / "k.nc"
    io.write_dataset(fe_blocks[4], greens, {}, stage="pattern_greens")
    io.write_dataset(synthetic_spectrum(), spectrum, {}, stage="pattern_stiffness_spectrum")
    pipeline.run_pattern_figures([greens], [spectrum], tmp_path / "fig" / "compliance_map.png",
                                 tmp_path / "fig" / "stiffness_spectrum.png")
    _png_is_a_picture(tmp_path / "fig" / "compliance_map.png")
    _png_is_a_picture(tmp_path / "fig" / "stiffness_spectrum.png")
    pipeline.run_pattern_figures([greens], [], tmp_path / "only" / "compliance_map.png")
    assert sorted(p.name for p in (tmp_path / "only").iterdir()) == ["compliance_map.png"]


# --- the report's links and the workflow ------------------------------------------------------------------------

def test_figures_section_links_relative_to_pattern_md_with_captions():
    rels = ["figures/pattern/compliance_map.png", "figures/pattern/stiffness_spectrum.png"]
    lines = figures_section(rels)
    assert lines[0].startswith("## ")
    assert [ln for ln in lines if ln.startswith("![")] == [f"![compliance_map]({rels[0]})",
                                                            f"![stiffness_spectrum]({rels[1]})"]
    assert f"*{FIGURE_CAPTIONS['compliance_map']}* (`{rels[0]}`)" in lines
    assert figures_section([]) == []


def test_pattern_report_ends_with_the_figures(monkeypatch):
    """build_pattern_report appends figures_section after the study's sections (pattern_section stubbed: its
    study file is tests/test_pattern.py's business)."""
    from tyreroad.report import pattern as rp

    monkeypatch.setattr(rp, "pattern_section", lambda ds: ["## study", ""])
    text = rp.build_pattern_report(None, figures=["figures/pattern/compliance_map.png"])
    assert text.index("## study") < text.index("![compliance_map](figures/pattern/compliance_map.png)")
    assert "![" not in rp.build_pattern_report(None)


def test_pattern_target_plans_the_figures(tmp_path):
    """`snakemake -n pattern` with pattern.study: true plans one pattern_figures job, whose two figures the pattern
    report links; without a K* pattern only the compliance map."""
    wd = _synthetic.copy_workflow(tmp_path)
    (wd / "config" / "study.yaml").write_text("pattern:\n  study: true\n")
    (wd / "config" / "nospec.yaml").write_text("pattern:\n  study: true\n  stiffness_spectrum:\n    patterns: []\n")
    base = [sys.executable, "-m", "snakemake", "-n", "-j1", "pattern", "--configfile", "config/config.yaml",
            "config/test.yaml"]
    proc = subprocess.run(base + ["config/study.yaml"], cwd=wd, capture_output=True, text=True)
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0, out[-3000:]
    assert any(line.split() == ["pattern_figures", "1"] for line in out.splitlines()), out[-2000:]
    for png in ("compliance_map.png", "stiffness_spectrum.png"):
        assert f"results-test/figures/pattern/{png}" in out
    assert "results-test/greens/pattern/block20/tread.nc" in out
    # the dynamic runs on the blocks' modal forms (pattern.modes with dynamic): one modes job per pattern, per pattern
    # the quasi-static run on its relaxed table and one run per acceleration, and their study
    counts = {line.split()[0]: int(line.split()[1]) for line in out.splitlines()
              if len(line.split()) == 2 and line.split()[1].isdigit()}
    # (and the four loss and density variants at the highest acceleration)
    assert counts.get("pattern_modes") == 2 and counts.get("pattern_dynamic") == 2 * 4 + 2 * 4, counts
    assert counts.get("pattern_dynamic_study") == 1
    assert "results-test/pattern/modal/iso10844-pattern/tread/block40/dynamic_500.nc" in out
    proc = subprocess.run(base + ["config/nospec.yaml"], cwd=wd, capture_output=True, text=True)
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0, out[-3000:]
    assert "results-test/figures/pattern/compliance_map.png" in out and "stiffness_spectrum.png" not in out


def test_pattern_figures_are_in_the_html_report_with_their_captions(figure_outputs):  # noqa: F811
    """Both outputs of rule pattern_figures (default config: a K* pattern) carry report(..., caption=...) whose
    file says what FIGURE_CAPTIONS says (tests/test_figure_captions.py checks every rule the same way)."""
    from pathlib import Path

    ours = {name: flag for name, flag in figure_outputs.items() if name.startswith("pattern_figures: ")}
    assert sorted(_stem(n) for n in ours) == ["compliance_map", "stiffness_spectrum"]
    for name, flag in ours.items():
        path = Path(flag.caption.get_path_or_uri(secret_free=True))
        assert path.read_text(encoding="utf-8").strip() == FIGURE_CAPTIONS[_stem(name)]
