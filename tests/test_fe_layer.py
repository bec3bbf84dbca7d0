"""tyreroad.fe_layer: the FE model of the flat layer against the analytic element kernel (issue 27)."""

import functools

import numpy as np
import pytest
import yaml

skfem = pytest.importorskip("skfem")

from tyreroad import fe_layer, greens  # noqa: E402
from tyreroad.pipeline import _material, resolved_material_config  # noqa: E402

C = 1e-3
# The test mesh: 20-node serendipity hexahedra, fully integrated (at 0.5 mm the reduced volumetric term is 6 % off),
# 0.5 mm at the load (uniform over 2 mm) growing by 1.6 to 5 mm, quarter cell 30 x 30 x 10 mm (period 60 mm),
# 18.9 k DOFs. Measured g_FE / g - 1 against the infinite layer: static -0.38 % (0,0), +0.81 % (1,0), -0.79 % (1,1),
# -0.24 % (2,0); |.| at 1 kHz 0.38 / 0.80 / 0.80 / 0.26 %, at 5 kHz 0.41 / 1.06 / 1.14 / 1.56 %. Against the kernel
# summed over the cell's periodic images (the discretisation error alone) every |.| <= 0.87 %. The images matter at
# 5 kHz, where the layer carries lightly damped guided waves (0.2 % at (0,0), 0.7-1.5 % at the neighbours here).
MESH = fe_layer.CellMesh(half_width=30e-3, fine=0.5e-3, fine_extent=2e-3, growth=1.6, coarse=5e-3, element="hexs2",
                         volumetric="full")
FREQS = (0.0, 1000.0, 5000.0)


@pytest.fixture(scope="module")
def tread():
    cfg = yaml.safe_load(open("config/config.yaml"))
    return _material("tread", resolved_material_config("tread", cfg["materials"]))


@pytest.fixture(scope="module")
def solved(tread):
    cell = fe_layer.LayerCell(tread.thickness, tread.poisson, tread.density, C, MESH, n_field=2)
    out = {}
    for f in FREQS:
        w = 2 * np.pi * f
        e = tread.quasi_static_modulus if f == 0 else tread.modulus(w)
        out[f] = cell.solve(e, w)
    return cell, out


def _index(cell, i, j):
    o = np.rint(cell.offsets / C).astype(int)
    return int(np.flatnonzero((o[:, 0] == i) & (o[:, 1] == j))[0])


def test_block_assembly_equals_skfem_vector_form():
    from skfem import Basis, ElementVector, MeshHex, asm
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    x = np.array([0.0, 0.3, 1.0, 1.7])
    mesh = MeshHex.init_tensor(x, 1.3 * x, np.array([0.0, 0.5, 1.2]))
    for name in ("hex2", "hexs2", "hex1"):
        el = fe_layer._scalar_element(name)
        sb = Basis(mesh, el, intorder=fe_layer._INTORDER[name])
        vb = Basis(mesh, ElementVector(el), intorder=fe_layer._INTORDER[name])
        k, _ = fe_layer.elasticity_matrices(sb, 0.49, 1100.0)
        idx = np.concatenate(vb.split_indices())  # component-major, same node order as the scalar basis
        kv = asm(linear_elasticity(*lame_parameters(1.0, 0.49)), vb)[idx][:, idx]
        assert abs(k - kv).max() < 1e-13 * abs(kv).max()


def test_nested_dissection_is_a_permutation():
    x = np.linspace(0, 1, 7)
    pts = np.stack(np.meshgrid(x, x, x[:4], indexing="ij")).reshape(3, -1)
    p = fe_layer.nested_dissection(pts, (x, x, x[:4]), leaf=4)
    assert np.array_equal(np.sort(p), np.arange(pts.shape[1]))


def test_static_within_one_percent(solved, tread):
    cell, g = solved
    probes = [(0, 0), (1, 0), (0, 1), (1, 1)]
    idx = [_index(cell, *p) for p in probes]
    ref = greens.static_element_kernel(cell.offsets[idx], C, tread.quasi_static_modulus, tread.poisson,
                                       tread.thickness)
    fe = g[0.0][idx]
    assert np.isrealobj(fe) or np.all(np.abs(np.imag(fe)) < 1e-12 * np.abs(fe))
    err = np.real(fe) / ref - 1
    assert np.all(np.abs(err) < 0.01), err
    # the quarter symmetry holds: (1,0) and (0,1) alike
    assert fe[1] == pytest.approx(fe[2], rel=1e-10)


def test_frf_excitation_element_within_two_percent(solved, tread):
    cell, g = solved
    i0 = _index(cell, 0, 0)
    for f in FREQS[1:]:
        w = 2 * np.pi * f
        ref = greens.element_frf(cell.offsets[[i0]], C, w, tread.modulus(w), tread.poisson, tread.density,
                                 tread.thickness)[0, 0]
        assert abs(g[f][i0] / ref - 1) < 0.02, (f, g[f][i0], ref)


def test_frf_neighbours(solved, tread):
    """(1,0), (1,1), (2,0) at 1 and 5 kHz: 2 % against the infinite layer (measured <= 1.56 %, of which the 60 mm
    period's images are up to 1.5 % at 5 kHz) and 1.5 % against the kernel summed over the cell's images
    (measured <= 0.87 %)."""
    cell, g = solved
    idx = [_index(cell, *p) for p in [(1, 0), (1, 1), (2, 0)]]
    off = cell.offsets[idx]
    for f in (1000.0, 5000.0):
        w = 2 * np.pi * f
        kern = functools.partial(lambda o, w: greens.element_frf(o, C, w, tread.modulus(w), tread.poisson,
                                                                 tread.density, tread.thickness)[0], w=w)
        inf = kern(off)
        per = fe_layer.periodic_images(kern, off, 2 * MESH.half_width, n_images=5)
        assert np.all(np.abs(g[f][idx] / inf - 1) < 0.02), (f, np.abs(g[f][idx] / inf - 1))
        assert np.all(np.abs(g[f][idx] / per - 1) < 0.015), (f, np.abs(g[f][idx] / per - 1))


def test_sign_and_factor(solved, tread):
    """Cannot pass with a wrong sign, a factor of two (e.g. half or double the load on the quarter) or the wrong
    time convention: compression is positive, the passive layer lags (Im g < 0), and the ratio is 1 within 1 %."""
    cell, g = solved
    i0 = _index(cell, 0, 0)
    g0 = greens.static_element_kernel(np.zeros((1, 2)), C, tread.quasi_static_modulus, tread.poisson,
                                      tread.thickness)[0]
    assert g0 > 0 and 0.99 < np.real(g[0.0][i0]) / g0 < 1.01
    for f in FREQS[1:]:
        assert np.real(g[f][i0]) > 0 and np.imag(g[f][i0]) < 0


def test_response_uses_quasi_static_modulus_at_zero_and_checks_the_material(tread):
    mesh = fe_layer.CellMesh(half_width=6e-3, fine=0.5e-3, fine_extent=1e-3, growth=2.0, coarse=3e-3, element="hexs2")
    cell = fe_layer.LayerCell(tread.thickness, tread.poisson, tread.density, C, mesh, n_field=1)
    w = 2 * np.pi * 2000.0
    g = cell.response(tread, [0.0, 2000.0])
    assert g.shape == (2, len(cell.offsets))
    np.testing.assert_allclose(g[0], cell.solve(tread.quasi_static_modulus), rtol=1e-12)
    np.testing.assert_allclose(g[1], cell.solve(complex(np.ravel(tread.modulus(w))[0]), w), rtol=1e-12)
    other = fe_layer.LayerCell(tread.thickness, 0.45, tread.density, C, mesh, n_field=1)
    with pytest.raises(ValueError, match="poisson"):
        other.response(tread, [0.0])
