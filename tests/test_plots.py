"""What the figures show: curves that would hide each other are merged or get a difference panel.

The figure functions write PNGs; these tests capture the matplotlib figure before it is saved
and check what a reader can see: legend entries, line styles, panels and notes.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import xarray as xr

import _synthetic
from tyreroad.plots import greens as plots_greens
from tyreroad.plots import study as plots_study
from tyreroad.study import StudySettings, aggregate, expected_cases


@pytest.fixture
def captured(monkeypatch):
    """Replace the modules' ``_save`` by one that keeps the figure (and still writes nothing)."""
    return _synthetic.capture_figures(monkeypatch, plots_greens, plots_study)


def greens_like(name, e_scale=1.0, eta_scale=1.0, g_static=3.1e-5, e_qs=25e6):
    f = np.linspace(0, 25600, 257)
    c = lambda u, n: {"units": u, "long_name": n}  # noqa: E731
    e1 = e_scale * (40e6 + 3e3 * f)
    eta = eta_scale * (0.15 + 0.15 * f / f[-1])
    mag = g_static * e_qs / np.hypot(e1, e1 * eta) * (1 + 0.05 * np.sin(f / 3000.0) * (f > 2000) * e_scale)
    return xr.Dataset(
        {
            "storage_modulus": ("frequency", e1, c("Pa", "E'")),
            "loss_factor": ("frequency", eta, c("1", "eta")),
            "frf_real": ("frequency", mag, c("m/N", "Re g")),
            "frf_imag": ("frequency", 0 * mag, c("m/N", "Im g")),
            "g_static": (("dx", "dy"), np.full((3, 3), g_static), c("m/N", "static g")),
        },
        coords={"frequency": ("frequency", f, c("Hz", "f")), "dx": [-1, 0, 1], "dy": [-1, 0, 1]},
        attrs={"material": name, "quasi_static_modulus": e_qs},
    )


def test_fig2_draws_identical_material_curves_once_and_says_so(captured, tmp_path):
    datasets = [greens_like("ref"), greens_like("ref-soft", eta_scale=1.5), greens_like("ref-heavy"),
                greens_like("added", e_scale=1.1)]
    plots_greens.plot_materials(datasets, tmp_path / "fig2.png")
    fig = captured[-1]
    ax_e1, ax_e2, ax_eta = fig.axes
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert labels == ["ref = ref-heavy (same curve)", "ref-soft", "added"]
    assert all(ax.get_legend() is None for ax in fig.axes)  # the legend sits outside, below the panels
    for ax in (ax_e1, ax_e2, ax_eta):  # one line per distinct curve, each with its own colour and style
        lines = ax.get_lines()
        assert len(lines) == 3
        assert len({(ln.get_color(), ln.get_linestyle()) for ln in lines}) == 3
        assert len({ln.get_linestyle() for ln in lines}) == 3
    np.testing.assert_allclose(ax_e2.get_lines()[1].get_ydata(),
                               (40e6 + 3e3 * datasets[1]["frequency"].values[1:]) * 1.5
                               * (0.15 + 0.15 * datasets[1]["frequency"].values[1:] / 25600) / 1e6)


def test_fig3_quasistatic_line_matches_its_legend_and_the_gap_is_explained(captured, tmp_path):
    datasets = [greens_like("ref"), greens_like("ref-soft", e_scale=1.1), greens_like("other", g_static=2.5e-5)]
    plots_greens.plot_frf(datasets, tmp_path / "fig3.png")
    ax = captured[-1].axes[0]
    legend = ax.get_legend()
    by_label = dict(zip([t.get_text() for t in legend.get_texts()], legend.legend_handles))
    static_lines = [ln for ln in ax.get_lines() if ln.get_label().startswith("quasi-static g")]
    assert sorted(ln.get_label() for ln in static_lines) == ["quasi-static g (other)", "quasi-static g (ref, ref-soft)"]
    for ln in static_lines:  # the legend swatch is drawn like the line it names
        handle = by_label[ln.get_label()]
        assert handle.get_color() == ln.get_color() and handle.get_linestyle() == ln.get_linestyle()
    assert all(ln.get_marker() in ("None", None, "") for ln in ax.get_lines())  # no unexplained markers
    fig = captured[-1]
    fig.canvas.draw()  # the legend covers no curve: it lies right of the axes
    assert legend.get_window_extent().x0 >= ax.get_window_extent().x1
    note = " ".join(t.get_text() for t in ax.texts)
    ratio = (3.1e-5 * 25e6 / math.hypot(40e6 + 3e3 * 100, (40e6 + 3e3 * 100) * (0.15 + 0.15 * 100 / 25600))) / 3.1e-5
    assert f"at 100 Hz |g| = {ratio:.2f} × quasi-static g" in note
    assert "quasi-static modulus is E(ω→0) = 25 MPa" in note


def test_fig3_same_static_g_for_all_materials_is_one_line(captured, tmp_path):
    plots_greens.plot_frf([greens_like("a"), greens_like("b", eta_scale=1.2)], tmp_path / "fig3.png")
    ax = captured[-1].axes[0]
    static_lines = [ln for ln in ax.get_lines() if ln.get_label().startswith("quasi-static g")]
    assert [ln.get_label() for ln in static_lines] == ["quasi-static g (all materials)"]
    assert "coincide" in " ".join(t.get_text() for t in ax.texts)


def test_variant_figure_has_a_difference_panel(captured, tmp_path):
    mats = ["ref", "light", "heavy"]
    st = StudySettings.from_config({"surface": "synth", "reference_material": "ref", "materials": mats,
                                    "accelerations": [500]}, d_max=2.5e-4)
    scale = {"ref": 1.0, "light": 0.99, "heavy": 1.02}
    runs = [_synthetic.synthetic_run(m, mode, a, lambda d, S=2e6 * scale[m]: S * (0.5 * d**2 / 1e-4 + 0.2 * d))
            for m, mode, a in expected_cases(st)]
    ds = aggregate(runs, st)
    plots_study.plot_variants(ds, [(0.5, "light"), (1.0, "ref"), (2.0, "heavy")], "density", 500.0, tmp_path / "f.png")
    ax, ax2 = captured[-1].axes
    assert ax2.get_ylabel() == "K − K_ref [kN/m]"
    d = ds["indentation"].values
    k_ref = 2e6 * (d / 1e-4 + 0.2)
    diffs = {ln.get_linestyle(): ln.get_ydata() for ln in ax2.get_lines()}
    assert len(diffs) == 3  # three distinct styles
    np.testing.assert_allclose(diffs["--"], 0.0, atol=1e-9)  # the reference, black dashed
    np.testing.assert_allclose(diffs[":"], 0.02 * k_ref * 1e-3, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(diffs["-"], -0.01 * k_ref * 1e-3, rtol=1e-9, atol=1e-9)
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels[1].startswith("ρ ×1 (ref), K_sat") and "see K − K_ref below" in ax.get_legend().get_title().get_text()


def test_fig6_lower_panel_has_a_legend_and_figures_name_their_study(captured, tmp_path):
    mats = ["ref", "light"]
    st = StudySettings.from_config({"surface": "synth", "reference_material": "ref", "materials": mats,
                                    "accelerations": [50, 500]}, d_max=2.5e-4)
    runs = [_synthetic.synthetic_run(m, mode, a, lambda d: 2e6 * (0.5 * d**2 / 1e-4 + 0.2 * d))
            for m, mode, a in expected_cases(st)]
    ds = aggregate(runs, st)
    caption = plots_study.study_caption(ds, "my-results/study.nc")
    assert caption == "study my-results/study.nc, surface synth, ref, light (reference ref)"
    plots_study.plot_stiffness(ds, tmp_path / "f6.png", "ref", caption)
    fig = captured[-1]
    ax, ax2 = fig.axes
    assert [t.get_text() for t in ax2.get_legend().get_texts()] == [
        "quasi-static", "dynamic, a = 50 m/s²", "dynamic, a = 500 m/s²"]
    assert fig._suptitle.get_text() == caption and "surface synth" in ax.get_title()


def test_fig10_work_is_printed_at_one_precision_and_round_off_reads_zero():
    from tyreroad.plots.hysteresis import _decimals, work_label

    decimals = _decimals([0.0205, 0.0350])  # 0.1 % of 35 mJ = 0.035 mJ: two decimals
    assert decimals == 2
    assert work_label(-6.3e-19, 0.02048, decimals) == "W = 0 (|W| < 1e-6 of 20.48 mJ input)"
    assert work_label(0.013037, 0.035030, decimals) == "W = 13.04 mJ, 37.2% of 35.03 mJ input"
    assert work_label(3e-8, 0.02048, decimals).startswith("W = 0.00 mJ")  # above round-off: printed, not hidden
