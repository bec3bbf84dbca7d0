"""Tests of the road surface stage (tyreroad.surface, tyreroad.plots.surface)."""

from __future__ import annotations

import numpy as np
import pytest

from pathlib import Path

from tyreroad import surface as S
from tyreroad import texture as T
from tyreroad.config import load_config

STEP = 1e-3 / 26
# the study's default preset, exactly as configured
DEFAULT_PRESET = load_config(Path(__file__).resolve().parents[1] / "config" / "config.yaml")["surfaces"]["iso10844"]


@pytest.fixture(scope="module")
def default_ds():
    """The default preset's surface dataset, generated once per test session module."""
    return S.prepare_surface("iso10844", DEFAULT_PRESET)


# --- default ISO 10844-like field ----------------------------------------------------------------
def test_default_field_texture_targets(default_ds):
    mpd = float(default_ds["mpd"])
    assert 0.3e-3 <= mpd <= 0.7e-3
    assert float(default_ds["skewness"]) < 0.0
    # rms of a dense 0/8 surface: a few tenths of a mm, not microns nor centimetres
    assert 0.2e-3 < float(default_ds["rms_height"]) < 0.8e-3
    assert default_ds["mpd"].attrs["baseline"] == pytest.approx(0.1)


def test_default_patch_fraction(default_ds):
    frac = default_ds["peak_fraction_within"].sel(depth=0.15e-3)
    assert 0.40 <= float(frac) <= 0.65
    # the rule picks the candidate closest to 51 %: one element of 400 is 0.25 %
    assert float(frac) == pytest.approx(0.51, abs=0.0125)
    f = default_ds["peak_fraction_within"].values
    assert f[0] < f[1] < f[2]  # deeper -> more peaks


def test_dataset_contract(default_ds):
    from tyreroad.io import check_metadata

    check_metadata(default_ds)
    ds = default_ds
    n = 26
    assert ds["height"].shape == (520, 520)
    assert ds["z1"].shape == (20, 20)
    assert ds.attrs["element_size"] == pytest.approx(1e-3)
    assert ds.attrs["samples_per_element"] == n
    assert ds.attrs["scan_step"] == pytest.approx(1e-3 / 26)
    assert ds["x"].values[0] == pytest.approx(0.5 * STEP)
    assert ds["element_x"].values[3] == pytest.approx(3.5e-3)
    # z1 is the element maximum, and the peak position points at that sample
    h = ds["height"].values
    for i, j in [(0, 0), (7, 13), (19, 19)]:
        block = h[i * n : (i + 1) * n, j * n : (j + 1) * n]
        assert ds["z1"].values[i, j] == block.max()
        ix = int(round(ds["peak_x"].values[i, j] / STEP - 0.5))
        iy = int(round(ds["peak_y"].values[i, j] / STEP - 0.5))
        assert h[ix, iy] == ds["z1"].values[i, j]
        assert i * 1e-3 < ds["peak_x"].values[i, j] < (i + 1) * 1e-3
    wl = ds["wavelength"].values
    assert wl[0] == pytest.approx(0.501e-3, rel=1e-3) and wl[-1] == pytest.approx(50.1e-3, rel=1e-3)
    # a macro-textured road: the texture level rises from 0.5 mm to the aggregate scale
    lev = ds["texture_level"].values
    assert lev[wl > 4e-3].max() > lev[0] + 8.0


def test_same_seed_identical_other_seed_differs():
    p = S.Iso10844Parameters(field_size=(0.03, 0.025))
    a = S.generate_iso10844(p, STEP, np.random.default_rng(5))
    b = S.generate_iso10844(p, STEP, np.random.default_rng(5))
    c = S.generate_iso10844(p, STEP, np.random.default_rng(6))
    assert a.shape == (780, 650)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)
    assert np.mean(a != c) > 0.9


def test_stone_tops_rolled_to_common_level():
    # without mortar texture and micro-texture every height is a stone cap or the mortar plane
    p = S.Iso10844Parameters(field_size=(0.04, 0.04), top_scatter=0.0, mortar_rms=0.0, microtexture_rms=0.0,
                             mortar_depth=1.0e-3)
    h = S.generate_iso10844(p, STEP, np.random.default_rng(1))
    assert h.max() <= 0.0
    assert h.max() > -2e-6  # some sample lies within a few um of a stone top at z = 0
    assert h.min() == pytest.approx(-1.0e-3, abs=1e-15)
    stone = h > -1.0e-3
    covered = stone.mean()
    assert covered == pytest.approx(1 - np.exp(-p.stone_coverage), abs=0.08)


# --- MPD and texture levels on analytic profiles ---------------------------------------------------
def test_mpd_of_cosine_exact():
    n = 2600  # 100 mm at 1/26 mm
    x = (np.arange(n) + 0.5) * STEP
    amp, lam = 0.4e-3, 10e-3
    prof = amp * np.cos(2 * np.pi * x / lam)
    # a linear trend is removed by the ISO regression line
    field = prof[:, None] + np.array([0.0, 1e-3])[None, :] + 2e-3 * x[:, None]
    # samples are half a step off the crests: the sampled peak is A cos(pi step / lambda)
    expected = amp * np.cos(np.pi * STEP / lam)
    assert T.mean_profile_depth(field, STEP) == pytest.approx(expected, rel=1e-9)


def test_mpd_two_level_profile():
    # spikes placed symmetrically about the centre (zero regression slope); each 50 mm half
    # holds a 0.3 mm and a 0.1 mm spike, so both half peaks are 0.3 mm above the zero base
    n = 2600
    prof = np.zeros(n)
    prof[100] = 0.3e-3
    prof[n - 101] = 0.3e-3  # keeps the profile symmetric -> zero regression slope
    prof[1400] = 0.1e-3
    prof[n - 1 - 1400] = 0.1e-3
    mean = prof.mean()
    expected = 0.5 * ((0.3e-3 - mean) + (0.3e-3 - mean))
    assert T.mean_profile_depth(prof, STEP) == pytest.approx(expected, rel=1e-12)
    # two baselines in a 200 mm profile are averaged
    prof2 = np.concatenate([prof, 0.5 * prof])
    assert T.mean_profile_depth(prof2, STEP) == pytest.approx(0.75 * expected, rel=1e-12)


def test_texture_level_of_pure_sinusoid():
    n = 2600
    x = (np.arange(n) + 0.5) * STEP
    amp, lam = 0.3e-3, 10e-3  # band centre 10 mm; 10 periods in the profile
    field = np.repeat((amp * np.cos(2 * np.pi * x / lam))[:, None], 4, axis=1)
    wl, level = T.texture_level_spectrum(field, STEP)
    k = int(np.argmax(level))
    assert wl[k] == pytest.approx(10e-3, rel=1e-9)
    expected = 20 * np.log10(amp / np.sqrt(2) / 1e-6)  # 46.53 dB
    assert level[k] == pytest.approx(expected, abs=1e-6)
    others = np.delete(level, k)
    assert np.all(others < expected - 100.0)


def test_texture_levels_two_sinusoids_and_hann_spread():
    n = 2600
    x = (np.arange(n) + 0.5) * STEP
    # 2 mm: bin 50 and its Hann neighbours 49, 51 lie inside the 1.995 mm band -> exact level.
    # 25 mm: bin 4 is alone in the 25.1 mm band; the periodic Hann window puts 1/6 of the power
    # into each neighbour bin (33.3 mm -> 31.6 mm band, 20 mm -> 19.95 mm band), 2/3 stays.
    a2, a25 = 0.2e-3, 0.1e-3
    z = a2 * np.cos(2 * np.pi * x / 2e-3) + a25 * np.cos(2 * np.pi * x / 25e-3)
    wl, level = T.texture_level_spectrum(z, STEP)
    ms = 10 ** (level / 10) * 1e-12

    def band(lam):
        return int(np.argmin(np.abs(wl - lam)))

    assert level[band(2e-3)] == pytest.approx(20 * np.log10(a2 / np.sqrt(2) / 1e-6), abs=1e-6)
    assert ms[band(25e-3)] == pytest.approx(2 / 3 * a25**2 / 2, rel=1e-9)
    assert ms[band(20e-3)] == pytest.approx(1 / 6 * a25**2 / 2, rel=1e-9)
    assert ms[band(31.6e-3)] == pytest.approx(1 / 6 * a25**2 / 2, rel=1e-9)


def test_texture_band_limits_follow_field_length():
    # a 30 mm profile cannot resolve wavelengths above 15 mm
    wl, _ = T.texture_level_spectrum(np.random.default_rng(0).standard_normal(780) * 1e-4, STEP)
    assert wl.max() <= 15e-3 * 10**0.05 and wl.max() > 10e-3
    assert wl.min() == pytest.approx(0.501e-3, rel=1e-3)


def test_rms_and_skewness_simple():
    h = np.array([0.0, 0.0, 0.0, 3.0])
    assert T.rms_height(h) == pytest.approx(np.sqrt(27 / 16))
    # mean 0.75; deviations -0.75 x3, 2.25: m3 = (3 * -0.421875 + 11.390625)/4
    assert T.skewness(h) == pytest.approx(((3 * -0.421875 + 11.390625) / 4) / (27 / 16) ** 1.5)


# --- elements and patch selection --------------------------------------------------------------
def test_element_samples_view_and_peaks():
    rng = np.random.default_rng(3)
    h = rng.standard_normal((3 * 4 + 2, 2 * 4))  # trailing partial element ignored
    el = S.element_samples(h, 4)
    assert el.shape == (3, 2, 4, 4)
    assert np.shares_memory(el, h)
    assert np.array_equal(el[2, 1], h[8:12, 4:8])
    z1, px, py = S.element_peaks(h, 4, 0.25e-3)
    assert z1[1, 0] == h[4:8, 0:4].max()
    i, j = np.unravel_index(np.argmax(h[4:8, 0:4]), (4, 4))
    assert px[1, 0] == pytest.approx((4 + i + 0.5) * 0.25e-3)
    assert py[1, 0] == pytest.approx((j + 0.5) * 0.25e-3)
    with pytest.raises(ValueError, match="smaller than one element"):
        S.element_samples(h[:3], 4)


def test_peak_fraction_within():
    z1 = np.array([[0.0, -0.05e-3], [-0.12e-3, -0.3e-3]])
    f = T.peak_fraction_within(z1, [0.05e-3, 0.10e-3, 0.15e-3])
    assert f.tolist() == [0.5, 0.5, 0.75]


def test_select_patch_rule_on_constructed_field():
    # 6 x 4 elements of 2 samples; patches of 2 x 2 elements. Element peaks 0.2 mm apart give
    # every window 25 % within 0.15 mm of its top, except window (3, 1), made to have 50 %.
    n = 2
    z1 = -0.2e-3 * np.arange(24, dtype=float).reshape(6, 4)
    z1[3, 1] = 1.0e-3
    z1[4, 2] = 0.9e-3
    h = np.repeat(np.repeat(z1, n, axis=0), n, axis=1)
    sel = S.PatchSelection(patch_elements=(2, 2), target_fraction=0.5, fraction_range=(0.4, 0.65))
    i0, j0, frac = S.select_patch(h, n, 1e-3 / n, sel)
    assert (i0, j0) == (3 * n, 1 * n)
    assert frac == 0.5
    # explicit origin wins; centre rule picks the middle element-aligned patch
    sel_o = S.PatchSelection(patch_elements=(2, 2), origin=(2e-3, 1e-3))
    assert S.select_patch(h, n, 1e-3 / n, sel_o)[:2] == (4, 2)
    sel_c = S.PatchSelection(patch_elements=(2, 2), rule="centre")
    assert S.select_patch(h, n, 1e-3 / n, sel_c)[:2] == (2 * n, 1 * n)


def test_select_patch_errors():
    flat = np.zeros((40, 40))
    sel = S.PatchSelection(patch_elements=(4, 4))
    with pytest.raises(ValueError, match="no 4 x 4-element patch"):
        S.select_patch(flat, 4, 0.25e-3, sel)  # every peak is at the top: 100 %
    with pytest.raises(ValueError, match="larger than the field"):
        S.select_patch(flat, 4, 0.25e-3, S.PatchSelection(patch_elements=(11, 4)))
    with pytest.raises(ValueError, match="extends beyond the field"):
        S.select_patch(flat, 4, 0.25e-3, S.PatchSelection(patch_elements=(4, 4), origin=(8e-3, 0.0)))


# --- spectral generator ------------------------------------------------------------------------
def test_self_affine_field_rms_and_slope():
    shape, step = (512, 512), 0.1e-3
    h = S.self_affine_field(shape, step, 0.2e-3, 0.7, 10e-3, np.random.default_rng(2))
    assert T.rms_height(h) == pytest.approx(0.2e-3, rel=1e-12)
    assert abs(h.mean()) < 1e-18
    # radially averaged PSD slope between 4 and 0.8 mm wavelength: -2(1 + H) = -3.4
    p = np.abs(np.fft.fft2(h)) ** 2
    qx = np.fft.fftfreq(shape[0], step)
    q = np.hypot(qx[:, None], qx[None, :])
    sel = (q > 1 / 4e-3) & (q < 1 / 0.8e-3)
    slope = np.polyfit(np.log(q[sel]), np.log(p[sel]), 1)[0]
    assert slope == pytest.approx(-3.4, abs=0.1)


def test_spectral_short_cutoff_removes_fine_scales():
    shape, step = (256, 256), 0.1e-3
    h = S.self_affine_field(shape, step, 1e-4, 0.8, 5e-3, np.random.default_rng(2), short_cutoff=1e-3)
    p = np.abs(np.fft.fft2(h)) ** 2
    qx = np.fft.fftfreq(shape[0], step)
    q = np.hypot(qx[:, None], qx[None, :])
    assert p[q > 1.001 / 1e-3].max() < 1e-20 * p.max()


def test_skew_transform_hits_target():
    h = S.self_affine_field((300, 300), 0.1e-3, 0.3e-3, 0.8, 5e-3, np.random.default_rng(4))
    for target in (-1.0, 0.6):
        t = S.skew_transform(h, target)
        assert T.skewness(t) == pytest.approx(target, abs=0.02)
        assert T.rms_height(t) == pytest.approx(0.3e-3, rel=1e-9)
        # monotone: the ordering of heights is kept
        assert np.array_equal(np.argsort(t.ravel()[:500]), np.argsort(h.ravel()[:500]))


def test_prepare_spectral_preset():
    ds = S.prepare_surface("spec", {
        "generator": "spectral", "seed": 1, "patch_elements": [10, 10], "field_size": [0.03, 0.03],
        "rms_height": 0.1e-3, "hurst": 0.8, "rolloff_wavelength": 5e-3, "skewness": -0.5,
        "patch_selection": "centre",
    })
    assert float(ds["rms_height"]) == pytest.approx(0.1e-3, rel=1e-9)
    assert float(ds["skewness"]) == pytest.approx(-0.5, abs=0.03)
    assert ds["z1"].shape == (10, 10)
    assert ds["mpd"].attrs["baseline"] == pytest.approx(0.03)


# --- config validation ---------------------------------------------------------------------------
@pytest.mark.parametrize(
    "change, match",
    [
        ({"generator": "gravel"}, r"surfaces\.bad\.generator"),
        ({"stone_diameter": [8e-3, 2e-3]}, r"surfaces\.bad\.stone_diameter"),
        ({"foo": 1}, r"surfaces\.bad\.foo"),
        ({"samples_per_element": 2.5}, r"surfaces\.bad\.samples_per_element"),
        ({"element_size": 1.0}, r"surfaces\.bad\.element_size"),
        ({"mortar_hurst": 1.5}, r"surfaces\.bad\.mortar_hurst"),
        ({"fraction_range": [0.6, 0.7]}, r"surfaces\.bad\.fraction_range"),
        ({"patch_selection": "best"}, r"surfaces\.bad\.patch_selection"),
        ({"stone_coverage": "lots"}, r"surfaces\.bad\.stone_coverage: expected a number"),
        ({"hurst": 0.5}, r"surfaces\.bad\.hurst"),  # a spectral key is unknown to iso10844
    ],
)
def test_preset_validation_names_key(change, match):
    with pytest.raises(ValueError, match=match):
        S.prepare_surface("bad", {**DEFAULT_PRESET, "field_size": [0.025, 0.025], **change})


# --- figure 4 ----------------------------------------------------------------------------------
def test_plot_patch_writes_png(default_ds, tmp_path):
    import matplotlib.image as mpimg

    from tyreroad.plots.surface import plot_patch

    out = plot_patch(default_ds, tmp_path / "fig" / "patch.png")
    assert out.exists()
    img = mpimg.imread(out)
    assert img.ndim == 3 and img.shape[0] > 500 and img.shape[1] > 500
    # not a blank canvas: the colour map spans many colours
    assert np.unique(img.reshape(-1, img.shape[2])[:, :3], axis=0).shape[0] > 100


def test_plot_patch_colour_scale_spans_the_top_few_tenths(default_ds, tmp_path, monkeypatch):
    import matplotlib.figure

    from tyreroad.plots.surface import COLOUR_RANGE, plot_patch

    kept = []
    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", lambda self, *a, **k: kept.append(self))
    plot_patch(default_ds, tmp_path / "patch.png")
    ax, cax = kept[0].axes
    mesh = ax.collections[0]
    top = float(default_ds["height"].max()) * 1e3
    assert mesh.norm.vmax == pytest.approx(top) and mesh.norm.vmin == pytest.approx(top - COLOUR_RANGE * 1e3)
    assert "clipped to the top 0.3 mm" in cax.get_ylabel()
    assert any("contour 0.15 mm" in t.get_text() for t in ax.get_legend().get_texts())


def test_roller_presses_stone_tops_down_to_its_level():
    """tops = min(N(0, scatter), roller_level): no stone stands above the roller plane."""
    small = dict(field_size=(0.03, 0.03), mortar_rms=0.0, microtexture_rms=0.0, top_scatter=4e-5)
    rolled = S.generate_iso10844(S.Iso10844Parameters(**small, roller_level=0.0), STEP, np.random.default_rng(3))
    free = S.generate_iso10844(S.Iso10844Parameters(**small), STEP, np.random.default_rng(3))
    assert rolled.max() <= 1e-15
    assert free.max() > 4e-5  # about 2.5 standard deviations for ~100 stones
    # rolling concentrates the stone tops at the plane: many samples within 5 um of the top
    assert np.mean(rolled > rolled.max() - 5e-6) > 5 * np.mean(free > free.max() - 5e-6)


def test_element_samples_flat_is_row_major_inside_the_element():
    """The one element-slicing helper: flat=True gives the layout the springs stage uses."""
    n = 3
    h = np.arange(6 * 9, dtype=float).reshape(6, 9)
    flat = S.element_samples(h, n, flat=True)
    assert flat.shape == (2, 3, 9)
    # element (1, 2) holds rows 3..5, columns 6..8, in C order
    np.testing.assert_array_equal(flat[1, 2], h[3:6, 6:9].ravel())
    ref = h.reshape(2, n, 3, n).transpose(0, 2, 1, 3).reshape(2, 3, n * n)  # springs' former private copy
    np.testing.assert_array_equal(flat, ref)
