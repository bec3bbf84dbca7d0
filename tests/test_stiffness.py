"""Tests of tyreroad.stiffness: the quasi-static tangent and the dynamic contact stiffness K*(f; d0) (SPEC 11)."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from tyreroad.contact import SolverSettings, contact_dataset, solve_path, solve_quasistatic
from tyreroad.greens import element_frf, greens_dataset, static_element_kernel, unique_offsets, offset_table_index
from tyreroad.loading import LoadingPreset
from tyreroad.material import material_from_config
from tyreroad.springs import SpringTable
from tyreroad.convolution import OffsetConvolution
from tyreroad.influence import OffsetInfluence, contact_set_stiffness, contact_set_stiffness_krylov, offset_matrix
from tyreroad.greens import ElementFRF
from tyreroad.kernel import LayerKernel
from tyreroad.newton import DenseSubstrate, FFTSubstrate
from tyreroad.stiffness import (
    SpectrumSettings,
    first_harmonic,
    frequency_grid,
    harmonic_stiffness,
    stiffness_spectrum,
    transient_states,
)

C = 1e-3  # m, element size
FS = 51200.0  # Hz
TREAD = {
    "model": "fractional_kelvin_voigt", "E0": 2.5e7, "E1": 5.0e7, "alpha": 0.24, "f1": 1000.0,
    "poisson_ratio": 0.49, "density": 1100.0, "thickness": 0.01,
}
# generalised Maxwell tread, longest relaxation time 0.1 ms (a 5-20 ms hold relaxes it completely)
MAXWELL = {
    "model": "generalized_maxwell", "E_inf": 2.5e7, "moduli": [2.0e7, 4.0e7], "relaxation_times": [1.0e-4, 3.0e-5],
    "poisson_ratio": 0.49, "density": 1100.0, "thickness": 0.01,
}
E_STAR = 2.5e7 / (1 - 0.49**2)


def material(spec, name="m", **extra):
    return material_from_config(name, {name: {**spec, **extra}})


def punch_springs(n_elem: int, rng, step: float = 1e-6, zeta_max: float = 4e-4) -> SpringTable:
    """k = 2 E* sqrt(A / pi), A = max(one sample, pi R zeta) capped at c^2: sqrt(2) x Hertz per element."""
    zeta = np.arange(round(zeta_max / step) + 1) * step
    radius = rng.uniform(1e-3, 4e-3, size=n_elem)[:, None]
    area = np.minimum(np.maximum((C / 26) ** 2, np.pi * radius * zeta[None, :]), C**2)
    k = 2 * E_STAR * np.sqrt(area / np.pi)
    f = np.zeros_like(k)
    np.cumsum(0.5 * step * (k[:, 1:] + k[:, :-1]), axis=1, out=f[:, 1:])
    return SpringTable.checked(k, f, step, n_elem)


def rough_z1(nx: int, ny: int, rng) -> np.ndarray:
    """Element peaks with about half of them within 0.15 mm of the top."""
    z1 = -rng.exponential(0.15e-3 / math.log(2), size=(nx, ny))
    return z1 - z1.max()


def static_table(mat, shape) -> np.ndarray:
    """g_static[dx, dy] of the layer for a patch (the greens stage's quasi-static kernel)."""
    uniq = unique_offsets(shape)
    _, _, index = offset_table_index(shape)
    return static_element_kernel(uniq * C, C, mat.quasi_static_modulus, mat.poisson, mat.thickness)[index]


@pytest.fixture(scope="module")
def patch():
    rng = np.random.default_rng(12)
    shape = (8, 8)
    mat = material(TREAD, "tread")
    return {"z1": rough_z1(*shape, rng), "springs": punch_springs(64, rng), "mat": mat,
            "g_static": static_table(mat, shape)}


@pytest.fixture(scope="module")
def spectra(patch):
    """Dense and matrix-free spectra of the 8 x 8 patch at three preloads."""
    spec = SpectrumSettings(preloads=(5e-5, 1e-4, 1.5e-4), n_frequencies=24)
    settings = SolverSettings(quasistatic_step=1e-5)
    return {m: stiffness_spectrum(patch["z1"], patch["springs"], LayerKernel.quasistatic(patch["g_static"]),
                                  ElementFRF(patch["mat"], C), patch["mat"], FS, spec,
                                  settings, method=m) for m in ("dense", "fft")}


def k_star(ds):
    return ds["storage_stiffness"].values + 1j * ds["loss_stiffness"].values


# --------------------------------------------------------------------------------------------
# settings and grids
# --------------------------------------------------------------------------------------------
def test_settings_defaults_grid_and_errors():
    s = SpectrumSettings.from_config({})
    assert s.preloads == (5e-5, 1e-4, 1.5e-4, 2e-4) and s.figure_preload == 1e-4
    f = s.frequencies(FS)
    assert f[0] == 10.0 and f[-1] == FS / 2 and f.size >= 60
    for x in (100.0, 1000.0, 5000.0):
        assert x in f
    assert np.all(np.diff(f) > 0)
    for bad, key in [
        ({"preloads": [1e-4, 5e-5]}, "stiffness_spectrum.preloads"),
        ({"preloads": []}, "stiffness_spectrum.preloads"),
        ({"f_min": 0}, "stiffness_spectrum.f_min"),
        ({"figure_preload": 3e-4}, "stiffness_spectrum.figure_preload"),
        ({"krylov_tolerance": 0.1}, "stiffness_spectrum.krylov_tolerance"),
        ({"n_frequency": 60}, "stiffness_spectrum.n_frequency"),
    ]:
        with pytest.raises(ValueError, match=re.escape(key)):
            SpectrumSettings.from_config(bad)
    with pytest.raises(ValueError, match="report frequency 30000 Hz"):
        frequency_grid(10, FS / 2, 10, [3e4])


# --------------------------------------------------------------------------------------------
# linear algebra
# --------------------------------------------------------------------------------------------
def test_dense_and_krylov_contact_set_stiffness_against_the_direct_formula():
    rng = np.random.default_rng(3)
    shape = (5, 6)
    n = 30
    mat = material(TREAD)
    uniq = unique_offsets(shape)
    _, _, index = offset_table_index(shape)
    w = 2 * np.pi * 2000.0
    table = element_frf(uniq * C, C, [w], mat.modulus(w), mat.poisson, mat.density, mat.thickness)[0][index]
    ex, ey = np.divmod(np.arange(n), shape[1])
    g = table[ex[:, None] - ex[None, :] + shape[0] - 1, ey[:, None] - ey[None, :] + shape[1] - 1]
    k = np.where(rng.random(n) < 0.6, rng.uniform(1e3, 3e5, n), 0.0)
    c = np.flatnonzero(k)
    direct = np.ones(c.size) @ np.linalg.solve(g[np.ix_(c, c)] + np.diag(1 / k[c]), np.ones(c.size))
    assert contact_set_stiffness(g, k) == pytest.approx(direct, rel=1e-12)
    op = OffsetInfluence(table, shape)
    v = rng.standard_normal(shape) + 1j * rng.standard_normal(shape)
    assert np.allclose(op(v).ravel(), g @ v.ravel(), rtol=0, atol=1e-14 * np.abs(g).max() * np.abs(v).sum())
    value, its, _ = contact_set_stiffness_krylov(op, k.reshape(shape), op.g_self, 1e-13)
    assert value == pytest.approx(direct, rel=1e-10) and its > 0
    assert direct.imag > 0  # passive: Im K* > 0
    # nothing in contact: no stiffness
    assert contact_set_stiffness(g, np.zeros(n)) == 0
    assert contact_set_stiffness_krylov(op, np.zeros(shape), op.g_self)[0] == 0


def test_one_element_with_a_linear_spring():
    """SPEC 11: one element gives K* = 1 / (1/k + g_self(f)) (here to 1e-10)."""
    k_c, step = 2.0e5, 1e-6
    zeta = np.arange(501) * step
    springs = SpringTable.checked(np.full((1, 501), k_c), k_c * zeta[None, :], step, 1)
    mat = material(TREAD)
    spec = SpectrumSettings(preloads=(1e-5, 1e-4), n_frequencies=30, figure_preload=1e-4)
    g_static = static_table(mat, (1, 1))
    ds = stiffness_spectrum(np.zeros((1, 1)), springs, LayerKernel.quasistatic(g_static), ElementFRF(mat, C), mat, FS,
                            spec, SolverSettings(quasistatic_step=1e-5))
    f = ds["frequency"].values
    w = 2 * np.pi * f
    g_self = element_frf(np.zeros((1, 2)), C, w, mat.modulus(w), mat.poisson, mat.density, mat.thickness)[:, 0]
    expected = 1 / (1 / k_c + g_self)
    for p in range(2):
        assert np.max(np.abs(k_star(ds)[p] / expected - 1)) < 1e-10
    k_qs = 1 / (1 / k_c + g_static[0, 0])
    assert np.allclose(ds["tangent_stiffness_qs"].values, k_qs, rtol=1e-12)
    assert np.allclose(ds["relaxed_stiffness"].values, k_qs, rtol=1e-12)
    assert np.allclose(ds["preload_force"].values, k_qs * ds["preload"].values, rtol=1e-10)


# --------------------------------------------------------------------------------------------
# the quasi-static tangent (issue 18) and the f -> 0 limit (SPEC 11 check 1)
# --------------------------------------------------------------------------------------------
def _unchanged_contact_set(result, width: int = 5):
    """Steps with the same loaded elements ``width`` steps before and after (away from contact-set changes).

    Right after an element touches, its spring k ~ sqrt(zeta) is far from linear over a 1 um step,
    which the finite difference cannot follow; 5 steps of 1 um leave every loaded spring >= 5 um in.
    """
    loaded = result.element_force.reshape(result.force.size, -1) > 0
    ok = np.zeros(result.force.size, dtype=bool)
    for n in range(width, result.force.size - width):
        ok[n] = loaded[n].any() and bool(np.all(loaded[n - width : n + width + 1] == loaded[n]))
    return ok


def test_quasistatic_tangent_equals_the_finite_difference_of_a_1um_run(patch):
    """Issue 18: K(d) from the tangent equals the central difference of a 1 um-step run within 0.2 %
    away from contact-set changes; the dense and FFT paths give the same tangent."""
    settings = SolverSettings(quasistatic_step=1e-6, d_max=2e-4, method="dense")
    springs = patch["springs"]
    res = solve_quasistatic(patch["z1"], springs.stiffness, springs.force, springs.zeta_step, patch["g_static"], settings)
    d, force, tangent = res.indentation, res.force, res.tangent_stiffness
    fd = np.zeros_like(force)
    fd[1:-1] = (force[2:] - force[:-2]) / (d[2:] - d[:-2])
    ok = _unchanged_contact_set(res)
    assert ok.sum() > 30
    rel = np.abs(fd[ok] / tangent[ok] - 1)
    assert rel.max() < 2e-3
    assert np.median(rel) < 1e-4
    # where the contact set changes the finite difference is off, and the tangent is not
    assert np.max(np.abs(fd[1:-1] / tangent[1:-1] - 1)) > 2e-3
    fft = solve_quasistatic(patch["z1"], springs.stiffness, springs.force, springs.zeta_step, patch["g_static"],
                            SolverSettings(quasistatic_step=1e-6, d_max=2e-4, method="fft"))
    assert np.max(np.abs(fft.tangent_stiffness - tangent)) < 1e-9 * tangent.max()
    # stored in the contact file of a quasi-static run, not in a dynamic one
    ds = contact_dataset(res, "quasistatic", 0.0, "s", "m")
    assert ds["tangent_stiffness"].attrs["units"] == "N/m"
    assert np.array_equal(ds["tangent_stiffness"].values, tangent)


def test_substrate_tangent_with_no_contact_and_a_table_that_is_not_even():
    """Both substrates give K = 0 without contact; the FFT substrate's COCG tangent (a lag-0 table
    that is not even: no CG, no predictor) equals the dense solve over the same operator."""
    g = np.full((3, 3), 1e-6)
    g[1, 1] = 1e-5
    for substrate in (DenseSubstrate(g), FFTSubstrate(OffsetConvolution(g[:, :, None], (2, 2)), 1e-12)):
        assert substrate.tangent(np.zeros(4)).stiffness == 0.0
    skew = g.copy()
    skew[0, 1] = 2e-6  # offset (-1, 0) differs from (1, 0): G_0 not symmetric
    fft = FFTSubstrate(OffsetConvolution(skew[:, :, None], (2, 2)), 1e-12)
    assert not fft.use_cg
    k = np.array([1e5, 0.0, 3e5, 2e4])
    tangent = fft.tangent(k)
    assert tangent.direction is None  # no CG solve: nothing to predict with
    assert tangent.stiffness == pytest.approx(DenseSubstrate(skew).tangent(k).stiffness, rel=1e-10)
    active = np.flatnonzero(k)
    g_aa = offset_matrix(skew)[np.ix_(active, active)]
    direct = np.ones(3) @ np.linalg.solve(g_aa + np.diag(1 / k[active]), np.ones(3))
    assert tangent.stiffness == pytest.approx(direct, rel=1e-10)


def test_zero_frequency_limit_equals_the_quasistatic_tangent(spectra, patch):
    """SPEC 11 check 1: K*(f -> 0) (E(omega -> 0) through the element FRF) equals dF/dd of the
    quasi-static curve at d0 (g_static, E_qs) at every preload; 10 Hz is still well above it."""
    ds = spectra["dense"]
    k0, k_qs = ds["relaxed_stiffness"].values, ds["tangent_stiffness_qs"].values
    assert np.all(np.abs(k0 / k_qs - 1) < 1e-9)
    # independently: central difference of the quasi-static force over +-10 nm about each preload
    springs = patch["springs"]
    for p, d0 in enumerate(ds["preload"].values):
        path = d0 + np.array([-1e-8, 0.0, 1e-8])
        res = solve_path(patch["z1"], springs.stiffness, springs.force, springs.zeta_step,
                         LayerKernel.quasistatic(patch["g_static"]), np.concatenate([[0.5 * d0], path]), SolverSettings())
        assert (res.force[3] - res.force[1]) / 2e-8 == pytest.approx(k_qs[p], rel=1e-5)
        assert res.force[2] == pytest.approx(float(ds["preload_force"][p]), rel=1e-12)
    # the fractional tread is still much stiffer than its relaxed modulus at 10 Hz
    assert np.all(ds["storage_stiffness"].values[:, 0] > 1.1 * k_qs)
    assert np.all(np.diff(ds["contact_fraction"].values) > 0)


def test_passive_and_dense_equals_matrix_free(spectra):
    """SPEC 11 checks 4 and 5: loss stiffness >= 0 everywhere; dense and matrix-free to 1e-8."""
    dense, fft = k_star(spectra["dense"]), k_star(spectra["fft"])
    assert np.all(dense.imag > 0)
    assert np.max(np.abs(fft - dense) / np.abs(dense)) < 1e-8
    assert np.max(np.abs(spectra["fft"]["relaxed_stiffness"].values / spectra["dense"]["relaxed_stiffness"].values - 1)) < 1e-8
    assert spectra["fft"]["krylov_iterations"].values.min() >= 1
    assert spectra["dense"]["krylov_iterations"].values.max() == 0
    ds = spectra["dense"]
    assert np.allclose(ds["loss_factor"], ds["loss_stiffness"] / ds["storage_stiffness"], rtol=1e-14)
    assert "relaxed" in ds.attrs["preload_state"]
    for name in ds.variables:
        assert {"units", "long_name"} <= set(ds[name].attrs)


@pytest.mark.parametrize("name", ["loss0.5", "loss1.5", "rho2", "maxwell"])
def test_loss_stiffness_nonnegative_for_variants(patch, name):
    """Passivity for loss and density variants and a Maxwell tread (SPEC 11 check 4)."""
    spec = {"loss0.5": {**TREAD, "loss_scale": 0.5}, "loss1.5": {**TREAD, "loss_scale": 1.5},
            "rho2": {**TREAD, "density_scale": 2.0}, "maxwell": MAXWELL}[name]
    mat = material(spec)
    ds = stiffness_spectrum(patch["z1"], patch["springs"], LayerKernel.quasistatic(patch["g_static"]),
                            ElementFRF(mat, C), mat, FS,
                            SpectrumSettings(preloads=(1e-4,), n_frequencies=40), SolverSettings(quasistatic_step=1e-5))
    assert np.all(ds["loss_stiffness"].values > 0)


# --------------------------------------------------------------------------------------------
# time domain (SPEC 11 check 3)
# --------------------------------------------------------------------------------------------
def test_first_harmonic_recovers_amplitude_and_phase():
    t = np.arange(4000) / FS
    x = 3.0 + 5e-3 * t + 2.0 * np.cos(2 * np.pi * 700 * t + 0.4)
    assert first_harmonic(t, x, 700.0, start=0.01) == pytest.approx(2.0 * np.exp(0.4j), rel=1e-9)


@pytest.mark.parametrize("construction", ["fold", "passive"])
@pytest.mark.parametrize("frequency, periods", [(200.0, 6), (1000.0, 10), (5000.0, 20)])
def test_harmonic_run_matches_k_star(frequency, periods, construction):
    """A time-domain harmonic run (1 um at d0 = 0.1 mm, Maxwell tread relaxed by a 5 ms hold) gives
    F_hat/delta_hat within 1 % and 0.01 rad of K*, at the study's 51.2 kHz.

    The time kernel replaces the band-limited kernel's non-causal precursor by a causal correction
    of its first lags (tyreroad.greens.precursor_correction); with the sum on lag 0 alone the 5 kHz
    phase was 0.0105 rad off here.
    """
    sample_rate = FS
    rng = np.random.default_rng(5)
    shape = (6, 6)
    mat = material(MAXWELL, "maxwell")
    z1 = rough_z1(*shape, rng)
    springs = punch_springs(36, rng)
    n_fft, n_lags = int(4096 * sample_rate / FS), int(256 * sample_rate / FS)
    greens = greens_dataset(mat, shape, C, sample_rate, n_lags, n_fft)
    if construction == "passive":  # the default kernel: its spring-safe FIR must not cost the K* check
        from tyreroad.construction import correct_greens

        greens, _ = correct_greens(greens, shape=shape, n_theta=256, n_phi=8)
    g_static = greens["g_static"].transpose("dx", "dy").values
    settings = SolverSettings(quasistatic_step=1e-5, method="dense")
    spec = SpectrumSettings(preloads=(1e-4,), n_frequencies=10, report_frequencies=(frequency,))
    ds = stiffness_spectrum(z1, springs, LayerKernel.quasistatic(g_static), ElementFRF(mat, C), mat, sample_rate, spec, settings)
    expected = complex(k_star(ds.sel(frequency=frequency))[0])
    hold, speed = 5e-3, 0.1
    preset = LoadingPreset("h", {"kind": "harmonic", "preload": 1e-4, "preload_speed": speed, "relax_time": hold,
                                 "amplitude": 1e-6, "frequency": frequency, "periods": periods})
    t, d, _ = preset.path("dynamic", sample_rate, settings.quasistatic_step)
    res = solve_path(z1, springs.stiffness, springs.force, springs.zeta_step,
                     LayerKernel.from_greens(greens, "dynamic"), d, settings, time=t)
    start = 1e-4 / speed + hold
    measured = harmonic_stiffness(res, frequency, start + 2 / frequency)
    assert abs(abs(measured) / abs(expected) - 1) < 0.01
    assert abs(np.angle(measured / expected)) < 0.01
    # the state the oscillation starts from is the relaxed preload state of the file
    before = np.flatnonzero(t < start)[-1]
    assert res.force[before] == pytest.approx(float(ds["preload_force"][0]), rel=1e-3)


# --------------------------------------------------------------------------------------------
# stage, figure and report section
# --------------------------------------------------------------------------------------------
def _stage_files(tmp_path, patch, mat=None):
    """Surface, springs and greens files of the 8 x 8 test patch (only what the stage reads; with a
    material, its full greens file: the transient state needs the dynamic kernel)."""
    import xarray as xr

    nx, ny = patch["z1"].shape
    springs = patch["springs"]
    zeta = np.arange(springs.stiffness.shape[-1]) * springs.zeta_step
    a = {"units": "m", "long_name": "x"}
    surface = xr.Dataset({"z1": (("ex", "ey"), patch["z1"], a)}, attrs={"element_size": C})
    sp = xr.Dataset({"stiffness": (("ex", "ey", "zeta"), springs.stiffness.reshape(nx, ny, -1), a),
                     "force": (("ex", "ey", "zeta"), springs.force.reshape(nx, ny, -1), a)},
                    coords={"zeta": ("zeta", zeta, a)})
    greens = xr.Dataset({"g_static": (("dx", "dy"), patch["g_static"], a)},
                        attrs={"element_size": C, "sample_rate": FS})
    if mat is not None:
        greens = greens_dataset(mat, (nx, ny), C, FS, 256, 4096)
    tmp_path.mkdir(exist_ok=True)
    paths = {}
    for name, ds in (("surface", surface), ("springs", sp), ("greens", greens)):
        paths[name] = tmp_path / f"{name}.nc"
        ds.to_netcdf(paths[name])
    return paths


def test_stage_writes_the_spectrum_with_provenance_and_figure_and_report_section(tmp_path, patch):
    from tyreroad import io, pipeline
    from tyreroad.report import _stiffness_spectrum_section

    spectrum_cfg = {"preloads": [5e-5, 1e-4], "n_frequencies": 12}
    outs = []
    for name, spec in (("tread", TREAD), ("tread-eta1.5", {**TREAD, "loss_scale": 1.5})):
        paths = _stage_files(tmp_path / name, patch, material(spec, name))
        out = tmp_path / f"{name}.nc"
        pipeline.run_stiffness_spectrum(paths["surface"], paths["springs"], paths["greens"], "synth", name, spec,
                                        {"quasistatic_step": 1e-5}, spectrum_cfg, out)
        outs.append(out)
    ds = io.read_dataset(outs[0])
    assert ds.attrs["material"] == "tread" and ds.attrs["surface"] == "synth" and len(ds.attrs["config_sha256"]) == 64
    assert ds.sizes == {"preload": 2, "frequency": 15}  # 12 log-spaced + 100 Hz, 1 kHz, 5 kHz
    assert ds["frequency"].values[-1] == FS / 2
    assert np.all(ds["loss_stiffness"].values > 0)
    assert list(ds.attrs["report_frequencies"]) == [100.0, 1000.0, 5000.0]
    variants = {"loss": [[1.0, "tread"], [1.5, "tread-eta1.5"]], "density": [[1.0, "tread"]]}
    png = tmp_path / "fig9.png"
    pipeline.run_stiffness_figure(outs, "tread", variants, spectrum_cfg, png)
    assert png.stat().st_size > 10_000
    spectra = [io.read_dataset(p) for p in outs]
    text = "\n".join(_stiffness_spectrum_section(spectra, "tread", variants, ["tread", "tread-eta1.5"]))
    k1k = float(ds["storage_stiffness"].sel(preload=1e-4, frequency=1000.0))
    ratio = k1k / float(ds["tangent_stiffness_qs"].sel(preload=1e-4))
    assert f"{k1k * 1e-6:.3f} / {float(ds['loss_factor'].sel(preload=1e-4, frequency=1000.0)):.3f}" in text
    assert f"| {ratio:.3f} |" in text and "relaxed preload state" in text and "| tread-eta1.5 |" in text
    # the transient state: loaded to d0 at the default 0.1 m/s, stiffer than relaxed
    assert ds.attrs["transient_speed"] == 0.1 and np.all(ds["transient_force"] > ds["preload_force"])
    k1k_t = float(ds["storage_stiffness_transient"].sel(preload=1e-4, frequency=1000.0))
    assert f"| 1000 Hz | {k1k * 1e-6:.3f} / " in text and f"| {k1k_t / k1k:.3f} |" in text
    # a bad section is an error naming the key, before any work
    with pytest.raises(ValueError, match="stiffness_spectrum.figure_preload"):
        pipeline.run_stiffness_spectrum(paths["surface"], paths["springs"], paths["greens"], "synth", "tread", TREAD,
                                        {}, {"preloads": [5e-5], "figure_preload": 1e-4}, tmp_path / "bad.nc")
    assert not (tmp_path / "bad.nc").exists()


# --------------------------------------------------------------------------------------------
# the transient preload state (loaded to d0 at a stated speed)
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("spec, speed, relaxes", [(MAXWELL, 0.005, True), (TREAD, 0.1, False)])
def test_transient_state_against_the_relaxed_one(spec, speed, relaxes):
    """A Maxwell tread (relaxation times <= 0.1 ms) loaded to 0.1 mm in 20 ms is as good as relaxed: its
    transient state and K*(1 kHz) equal the relaxed ones within 1 %. The fractional tread loaded in 1 ms
    carries far more force than relaxed. Either way K*_transient is the dense formula over the transient
    state's own springs."""
    rng = np.random.default_rng(31)
    shape = (6, 6)
    mat = material(spec, "m")
    z1 = rough_z1(*shape, rng)
    springs = punch_springs(36, rng)
    greens = greens_dataset(mat, shape, C, FS, 256, 4096)
    relaxed = LayerKernel.from_greens(greens, "quasistatic", mat)
    layer = LayerKernel.from_greens(greens, "dynamic", mat)
    spec_settings = SpectrumSettings(preloads=(1e-4,), n_frequencies=8, report_frequencies=(1000.0,),
                                     transient_speed=speed)
    ds = stiffness_spectrum(z1, springs, relaxed, ElementFRF(mat, C), mat, FS, spec_settings,
                            SolverSettings(quasistatic_step=1e-5, method="dense"), layer=layer)
    at = ds.sel(frequency=1000.0)
    k_relaxed = complex(at["storage_stiffness"][0] + 1j * at["loss_stiffness"][0])
    k_moving = complex(at["storage_stiffness_transient"][0] + 1j * at["loss_stiffness_transient"][0])
    f_relaxed, f_moving = float(ds["preload_force"][0]), float(ds["transient_force"][0])
    if relaxes:
        assert f_moving == pytest.approx(f_relaxed, rel=0.01)
        assert abs(k_moving / k_relaxed - 1) < 0.01
    else:
        assert f_moving > 1.3 * f_relaxed
    # the transient state's own springs through the dense formula, at 1 kHz
    state = transient_states(z1, springs, layer, (1e-4,), speed, SolverSettings(quasistatic_step=1e-5))
    k = state.spring_stiffness[0].ravel()
    c = np.flatnonzero(k)
    table = ElementFRF(mat, C).frequency_response([1000.0], shape)[0]
    g = offset_matrix(table)[np.ix_(c, c)]
    expected = np.ones(c.size) @ np.linalg.solve(g + np.diag(1 / k[c]), np.ones(c.size))
    assert k_moving == pytest.approx(expected, rel=1e-10)
    assert float(state.force[0]) == pytest.approx(f_moving, rel=1e-12) and ds.attrs["transient_speed"] == speed
    assert np.all(ds["loss_stiffness_transient"].values > 0)


def test_harmonic_beyond_the_linear_range_is_refused(tmp_path, patch):
    """Issue 24: a harmonic whose amplitude exceeds the smallest compression in contact of its preload
    state is refused before any step, naming the amplitude and both limits; one below both runs."""
    from tyreroad.contact import check_harmonic_amplitude, linear_range, solve_loading

    springs = patch["springs"]
    relaxed = LayerKernel.quasistatic(patch["g_static"])
    settings = SolverSettings(quasistatic_step=1e-5)
    compression, gap = linear_range(patch["z1"], springs, relaxed, 1e-4, settings)
    # the state itself: its smallest positive compression and smallest gap, solved independently
    state = solve_path(patch["z1"], springs.stiffness, springs.force, springs.zeta_step, relaxed,
                       [5e-5, 1e-4], SolverSettings(quasistatic_step=5e-5)).compression[-1].ravel()
    assert compression == pytest.approx(state[state > 0].min(), rel=1e-9)
    assert gap == pytest.approx((-state[state < 0]).min(), rel=1e-9)
    spec = {"kind": "harmonic", "preload": 1e-4, "relax_time": 0.0, "amplitude": 1.5 * min(compression, gap),
            "frequency": 1000.0, "periods": 2}
    with pytest.raises(ValueError, match=r"loadings\.h\.amplitude = .* smallest compression of a spring in contact is "
                                         r".* and the smallest open gap"):
        check_harmonic_amplitude(LoadingPreset("h", spec), patch["z1"], springs, relaxed, settings)
    check_harmonic_amplitude(LoadingPreset("h", {**spec, "amplitude": 0.5 * min(compression, gap)}), patch["z1"],
                             springs, relaxed, settings)
    # through the loading stage: refused before the run, from the stage datasets
    mat = material(TREAD, "tread")
    paths = _stage_files(tmp_path / "s", patch, mat)
    from tyreroad import io

    surface, sp, greens = (io.read_dataset(paths[k]) for k in ("surface", "springs", "greens"))
    with pytest.raises(ValueError, match="beyond the linear range"):
        solve_loading(surface, sp, greens, mat, "dynamic", LoadingPreset("h", spec), settings)
