"""The flexible belt in the pipeline (issue 26, tyreroad.belt_stage): config, the element FRF of tread + belt with
its indentation reference, and the greens file with the belt (kernel, memory, margin, fidelity)."""

import numpy as np
import pytest

from tyreroad import belt as beltmod
from tyreroad.belt_stage import (
    BeltElementFRF,
    belt_from_config,
    belt_settings,
    patch_mean_weights,
)
from tyreroad.config import ConfigError, check_config
from tyreroad.greens import ElementFRF
from tyreroad.material import material_from_config

TREAD = {
    "model": "fractional_kelvin_voigt", "E0": 2.5e7, "E1": 5.0e7, "alpha": 0.24, "f1": 1000.0,
    "poisson_ratio": 0.49, "density": 1100.0, "thickness": 0.01,
}


@pytest.fixture(scope="module")
def tread():
    return material_from_config("tread", {"tread": TREAD})


def test_config_properties_replace_the_defaults_and_bad_keys_are_named():
    b = belt_from_config({"loss_factor": 0.05, "mass": 12.0})
    assert b.loss_factor == 0.05 and b.mass == 12.0 and b.tension_x == beltmod.DEFAULT_BELT.tension_x
    assert belt_from_config(None) == beltmod.DEFAULT_BELT
    with pytest.raises(ValueError, match=r"belt\.properties\.stiffness: unknown belt property"):
        belt_from_config({"stiffness": 1.0})
    with pytest.raises(ValueError, match=r"belt\.properties: .*mass"):
        belt_from_config({"mass": -1.0})
    assert belt_settings(None) is None
    assert belt_settings({"reference": "rim"})[1] == "rim"
    with pytest.raises(ValueError, match=r"belt\.reference = 'hub'"):
        belt_settings({"reference": "hub"})


def test_planning_refuses_a_bad_belt_and_the_radau_kernel():
    import yaml

    cfg = yaml.safe_load(open("config/config.yaml"))
    cfg["belt"] = {"study": True, "properties": {"mass": 0.0}}
    with pytest.raises(ConfigError, match=r"belt\.properties.*mass"):
        check_config(cfg)
    cfg["belt"] = {"study": True, "properties": {}}
    cfg["greens"]["construction"] = "radau"
    with pytest.raises(ConfigError, match=r"belt\.study: true with greens\.construction = 'radau'"):
        check_config(cfg)


def test_patch_mean_weights():
    shape = (3, 2)
    w = patch_mean_weights(shape)
    assert w.sum() == pytest.approx(1.0, abs=1e-15)
    # the mean over the patch of the response to a uniform unit total load, done element by element
    rng = np.random.default_rng(1)
    g = rng.normal(size=(5, 3))
    g = g + g[::-1, ::-1]  # even
    mean = sum(g[i - k + 2, j - m + 1] for i in range(3) for j in range(2) for k in range(3) for m in range(2)) / 36
    assert np.sum(g * w) == pytest.approx(mean, rel=1e-14)


def test_element_frf_with_a_stiff_belt_is_the_layers(tread):
    """belt stiffness -> inf: tread + belt gives the rigid-belt element FRF within 1e-10 relative."""
    f = np.array([0.0, 100.0, 1000.0, 5000.0])
    stiff = beltmod.DEFAULT_BELT.scaled(1e12)
    rigid = ElementFRF(tread, 1e-3).frequency_response(f, (3, 3))
    for reference in ("rim", "patch_mean"):
        both = BeltElementFRF(tread, stiff, 1e-3, reference, (3, 3)).frequency_response(f, (3, 3))
        assert np.max(np.abs(both - rigid)) < 1e-10 * np.abs(rigid[:, 2, 2]).min()


def test_footprint_reference_is_the_cells_variation_only(tread):
    """'footprint': the belt's response to the patch repeated over the footprint without the uniform mode: periodic
    over the cell with zero sum over one period (the aliases of the cell's wavenumbers lie beyond the mode sum's
    k_max), and on a 20 x 20 mm cell 0.1-0.6 % of the rigid belt's g_00 up to 5 kHz, where the patch alone measured
    from the rim gets 20-50 %."""
    f = np.array([0.0, 100.0, 1000.0, 5000.0])
    part = BeltElementFRF(tread, beltmod.DEFAULT_BELT, 1e-3, "footprint", (20, 20)).belt_part(f, (20, 20))
    assert np.abs(part[:, 19:, 19:].sum(axis=(1, 2))).max() < 1e-12 * np.abs(part[:, 19, 19]).min()
    np.testing.assert_allclose(part[:, 19 + 1, 19], part[:, 19 - 19, 19], rtol=1e-12)  # period 20 in x: d = 1 ~ -19
    rigid = ElementFRF(tread, 1e-3).frequency_response(f, (20, 20))[:, 19, 19]
    ratio = np.abs(part[:, 19, 19]) / np.abs(rigid)
    assert np.all((ratio > 1e-3) & (ratio < 7e-3)), ratio
    with pytest.raises(ValueError, match="reference_shape"):
        BeltElementFRF(tread, beltmod.DEFAULT_BELT, 1e-3, "footprint")


def test_patch_mean_reference_removes_the_belts_mean_and_keeps_its_shape(tread):
    """'patch_mean': the belt part has zero patch mean; it differs from 'rim' by one constant per frequency, which
    at 0 Hz is most of the belt's compliance (the belt deflects as a whole under the patch)."""
    f = np.array([0.0, 300.0])
    shape = (4, 3)
    rim = BeltElementFRF(tread, beltmod.DEFAULT_BELT, 1e-3, "rim").belt_part(f, shape)
    mean = BeltElementFRF(tread, beltmod.DEFAULT_BELT, 1e-3, "patch_mean", shape).belt_part(f, shape)
    w = patch_mean_weights(shape)
    assert np.abs(np.einsum("fxy,xy->f", mean, w)).max() < 1e-12 * np.abs(rim[:, 3, 2]).max()
    shift = rim - mean
    assert np.ptp(shift.real, axis=(1, 2)).max() < 1e-12 * np.abs(rim).max()
    # at 0 Hz the removed mean is > 90 % of the belt's compliance at the loaded element
    assert shift[0, 0, 0].real > 0.9 * rim[0, 3, 2].real > 0
    # the belt's deformation across a 4 x 3 mm patch stays: the loaded element gives more than its neighbours
    assert mean[0, 3, 2].real > mean[0, 6, 2].real
    # the loaded element's belt part is orthotropic: x (circumference) and y (width) neighbours differ
    assert abs(rim[0, 4, 2] - rim[0, 3, 3]) > 1e-6 * abs(rim[0, 3, 2])


# --- the greens file with the belt --------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def greens_files(tread):
    """Greens datasets on a 3 x 3 patch, fold kernel: the rigid belt and the default belt measured from the rim (the
    largest belt part; the footprint reference's 'cell' path: test_footprint_reference_is_the_cells_variation_only;
    belt stiffness -> inf on the kernel's own tables: tests/test_belt_kernel.py)."""
    from tyreroad.greens import GreensSettings
    from tyreroad.pipeline import build_greens

    settings = GreensSettings(construction="fold")
    build = lambda belt: build_greens(tread, (3, 3), 1e-3, settings, belt=belt)  # noqa: E731
    return {"rigid": build(None), "belt": build((beltmod.DEFAULT_BELT, "rim"))}


def test_the_belt_kernel_is_faithful_passive_and_recorded(greens_files, tread):
    """The whole kernel (tread + belt, lags + tail + belt filters) against the exact FRF of tread + belt: within the
    greens stage's limits (1 % / 0.01 rad, 10 Hz - 5 kHz); the file records the belt and its fit."""
    from tyreroad.belt_kernel import BeltMemory
    from tyreroad.belt_stage import response_of
    from tyreroad.kernel import LayerKernel, MemorySum

    ds = greens_files["belt"]
    assert int(ds.attrs["belt"]) == 1 and ds.attrs["belt_reference"] == "rim"
    assert 0 < ds.attrs["belt_fit_error"] < 2e-3 and ds.attrs["belt_passivity_min"] > 0
    assert float(ds["fidelity_magnitude"]) < 0.01 and float(ds["fidelity_phase"]) < 0.01
    kernel = LayerKernel.from_greens(ds, "dynamic")
    assert isinstance(kernel.memory, MemorySum) and isinstance(kernel.memory.part(BeltMemory), BeltMemory)
    response = response_of(ds, tread)
    assert isinstance(response, BeltElementFRF) and response.reference_shape == (3, 3)
    f = np.array([20.0, 150.0, 1000.0, 4000.0])
    own, exact = kernel.own_frequency_response(f, (3, 3)), response.frequency_response(f, (3, 3))
    assert np.abs(own - exact).max() < 0.01 * np.abs(exact[:, 2, 2]).min()
    # measured from the rim, the belt adds 30-50 % of the compliance at 20-150 Hz, in the kernel and in its static
    # part (g_static: the quasi-static modulus)
    rigid = ElementFRF(tread, 1e-3).frequency_response(f, (3, 3))
    assert np.all(np.abs(exact - rigid)[:2, 2, 2] > 0.3 * np.abs(rigid[:2, 2, 2]))
    extra = ds["g_static"].values - greens_files["rigid"]["g_static"].values
    static = BeltElementFRF(tread, beltmod.DEFAULT_BELT, 1e-3, "rim").belt_part([0.0], (3, 3))[0].real
    np.testing.assert_allclose(extra, static, rtol=1e-9)
    assert extra.min() > 0.15 * float(ds["g_static"].max())


def test_a_run_on_the_belt_kernel_uses_its_memory(greens_files):
    """A 350-step load-hold-unload cycle on the belt kernel (256 kept lags + creep tail + belt filters) equals the same
    run on the kernel with all its lags explicit, dense and FFT."""
    from tyreroad.belt_kernel import BeltKernel
    from tyreroad.contact import run_loading_path
    from tyreroad.kernel import LayerKernel
    from tyreroad.loading import LoadingPreset
    from tyreroad.solver import SolverSettings
    from tyreroad.springs import SpringTable, linear_tables

    ds = greens_files["belt"]
    kernel = LayerKernel.from_greens(ds, "dynamic")
    fs, n_kept = kernel.sample_rate, kernel.n_lags
    z1 = -np.random.default_rng(3).uniform(0, 1e-5, size=(3, 3))
    preset = LoadingPreset("cycle", {"kind": "cycle", "load_speed": 0.05, "d_max": 3e-5, "hold_time": 5e-3,
                                     "unload_speed": 0.05})
    loading = preset.loading(z1, "dynamic", fs, 1e-6)
    n = loading.n_steps
    assert n_kept < n < 1500  # longer than the kept lags: the memory is used
    k, f = linear_tables(z1.size, 2e4)
    springs = SpringTable.checked(k, f, 1e-6, z1.size)
    tail = kernel.memory.models[0]
    later = np.arange(n_kept, n)
    explicit = np.concatenate([kernel.lags, tail.residual_compliance[:, :, None] * tail.sequence(n)[None, None, :]
                               + BeltKernel.from_dataset(ds).lags(n)[:, :, n_kept:]], axis=2)
    assert later.size == explicit.shape[2] - n_kept
    reference = run_loading_path(loading, springs, LayerKernel.dynamic(explicit, fs), SolverSettings(method="dense"))
    scale = reference.force.max()
    assert scale > 0.1
    for method in ("dense", "fft"):
        res = run_loading_path(loading, springs, kernel, SolverSettings(method=method))
        np.testing.assert_allclose(res.force, reference.force, rtol=0, atol=1e-10 * scale)
