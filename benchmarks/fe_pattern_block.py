"""Edge softening, mesh convergence and cost of the FE tread-block influence matrix (tyreroad.fe_pattern, issue 27).

Cases (each in its own process, so that the peak RSS is the case's; one core; never fails on time):

* ``flat``: the 60 mm free-standing block's centre element against the analytic flat layer
  (greens.static_element_kernel) at offsets (0,0) (1,0) (1,1) (2,0) (3,0), per mesh;
* ``block``: the static influence matrix of a block (20 x 20 or 40 x 40 mm, full-depth grooves or an undertread),
  the compliance g_ii at the centre, edge-centre and corner elements and their ratios to the centre, per mesh
  (``per_element`` 1 with and without the difference correction, 2, 3), with assembly/factor/solve time and
  peak RSS, the influence table's memory (N^2 doubles) and the asymmetry of G (centre convention);
* ``tet``: the independent model (fe_pattern.tet_reference_influence, quadratic tetrahedra) against the block model;
* ``plate``: the bonded rigid-plate modulus E_a / E against Gent & Lindley's closed form;
* ``edge``: the undertread's cell-boundary condition (periodic against free) for one load;
* ``dyn``: |g| at the excitation element and across the block, 10 Hz - 5 kHz, and the first peaks.

Run: OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python benchmarks/fe_pattern_block.py [case ...]
"""

from __future__ import annotations

import json
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
C = 1e-3


def _tread():
    from tyreroad.pipeline import _material, resolved_material_config

    cfg = yaml.safe_load(open(ROOT / "config" / "config.yaml"))
    return _material("tread", resolved_material_config("tread", cfg["materials"]))


def _rss_gb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6


def _probes(pattern):
    nx, ny = pattern.shape
    return {"centre": (nx // 2) * ny + ny // 2, "edge": (nx // 2) * ny, "corner": 0}


def case_flat(pe, element="hexs2"):
    from tyreroad import fe_pattern as fp, greens

    mat = _tread()
    pat = fp.TreadPattern(60e-3, 60e-3, 5e-3, 10e-3)
    t = time.perf_counter()
    cell = fp.BlockCell(pat, mat.thickness, mat.poisson, mat.density,
                        fp.BlockMesh(per_element=pe, element=element, depth_fine=2e-3, uniform_extent=4e-3))
    ny = pat.shape[1]
    g = cell.influence(mat.quasi_static_modulus, 0.0, [30 * ny + 30])[:, 0]
    offs = [(0, 0), (1, 0), (1, 1), (2, 0), (3, 0)]
    ref = greens.static_element_kernel(np.array(offs) * C, C, mat.quasi_static_modulus, mat.poisson, mat.thickness)
    err = [100 * (g[(30 + i) * ny + 30 + j] / r - 1) for (i, j), r in zip(offs, ref)]
    return {"case": "flat", "pe": pe, "element": element, "dofs": cell.n_dofs, "err_pct": err,
            "time": time.perf_counter() - t, "rss": _rss_gb()}


def case_block(size, depth, pe, correction="none", edge="periodic"):
    from tyreroad import fe_pattern as fp

    mat = _tread()
    pat = fp.TreadPattern(size, size, 5e-3, depth)
    mesh = fp.BlockMesh(per_element=pe, depth_fine=2e-3, undertread_edge=edge)
    t = time.perf_counter()
    _, g, cell = fp.block_static_influence(pat, mat, mesh, return_cell=True, correction=correction)
    pr = _probes(pat)
    d = {k: float(g[v, v]) for k, v in pr.items()}
    n = g.shape[0]
    return {"case": "block", "size": size, "depth": depth, "pe": pe, "correction": correction, "edge": edge,
            "dofs": cell.n_dofs, "g": d, "edge/centre": d["edge"] / d["centre"],
            "corner/centre": d["corner"] / d["centre"], "asym": float(np.abs(g - g.T).max() / np.abs(g).max()),
            "time": time.perf_counter() - t, "assembly": cell.assembly_time, "factor": cell.factor_time,
            "solve": cell.solve_time, "rss": _rss_gb(), "table_MB": n * n * 8 / 1e6,
            "diag": np.diag(g).reshape(pat.shape).tolist()}


def case_tet(size, lateral, pe):
    from tyreroad import fe_pattern as fp

    mat = _tread()
    pat = fp.TreadPattern(size, size, 5e-3, 10e-3)
    pr = _probes(pat)
    src = list(pr.values())
    t = time.perf_counter()
    if pe == 0:
        g = fp.tet_reference_influence(pat, mat.quasi_static_modulus, mat.poisson, mat.thickness, src, lateral)
        label = f"tet {lateral * 1e3:g} mm"
    else:
        cell = fp.BlockCell(pat, mat.thickness, mat.poisson, mat.density, fp.BlockMesh(per_element=pe, depth_fine=2e-3))
        g = cell.influence(mat.quasi_static_modulus, 0.0, src)
        label = f"hexs2 pe={pe}"
    d = {k: float(g[v, n]) for n, (k, v) in enumerate(pr.items())}
    return {"case": "tet", "size": size, "model": label, "g": d, "time": time.perf_counter() - t, "rss": _rss_gb()}


def case_plate(size, pe):
    from tyreroad import fe_pattern as fp

    mat = _tread()
    pat = fp.TreadPattern(size, size, 5e-3, 10e-3)
    cell = fp.BlockCell(pat, mat.thickness, mat.poisson, mat.density, fp.BlockMesh(per_element=pe, depth_fine=2e-3))
    return {"case": "plate", "size": size, "pe": pe, "bonded": fp.bonded_plate_modulus(cell),
            "frictionless": fp.bonded_plate_modulus(cell, bonded=False),
            "gent_lindley": fp.gent_lindley_modulus(size, size, mat.thickness, mat.poisson)}


def case_dyn(size, pe, nf=40):
    from tyreroad import fe_pattern as fp

    mat = _tread()
    pat = fp.TreadPattern(size, size, 5e-3, 10e-3)
    pr = _probes(pat)
    f = np.geomspace(10.0, 5000.0, nf)
    t = time.perf_counter()
    g = fp.block_frequency_response(pat, mat, f, list(pr.values()), fp.BlockMesh(per_element=pe, depth_fine=2e-3))
    nx, ny = pat.shape
    across = [(nx // 2) * ny + j for j in range(0, ny // 2 + 1, max(1, ny // 8))]
    out = {"case": "dyn", "size": size, "pe": pe, "f": f.tolist(), "time": time.perf_counter() - t, "rss": _rss_gb()}
    for n, (k, v) in enumerate(pr.items()):
        out[k] = np.abs(g[:, v, n]).tolist()
        out[k + "_phase"] = np.angle(g[:, v, n]).tolist()
    out["across_centre"] = {int(a): np.abs(g[:, a, 0]).tolist() for a in across}
    return out


def case_modal(size, pe, n_modes, depth=10e-3, check=(1000.0, 5000.0), nf=200):
    from tyreroad import fe_pattern as fp

    mat = _tread()
    pat = fp.TreadPattern(size, size, 5e-3, depth)
    pr = _probes(pat)
    nx, ny = pat.shape
    across = [(nx // 2) * ny + j for j in range(0, ny // 2 + 1, max(1, ny // 8))]
    src = list(pr.values())
    t = time.perf_counter()
    cell = fp.BlockCell(pat, mat.thickness, mat.poisson, mat.density, fp.BlockMesh(per_element=pe, depth_fine=2e-3))
    bm = fp.BlockModes(cell, n_modes)
    t_modes = time.perf_counter() - t
    f = np.geomspace(10.0, 5000.0, nf)
    g = np.empty((nf, nx * ny, len(src)), dtype=complex)
    for n, fn in enumerate(f):
        w = 2 * np.pi * fn
        g[n] = bm.influence(complex(np.ravel(mat.modulus(w))[0]), w, src)
    t_sweep = time.perf_counter() - t - t_modes
    errs = {}
    for fc in check:
        w = 2 * np.pi * fc
        e = complex(np.ravel(mat.modulus(w))[0])
        gd = cell.influence(e, w, src)
        gm = bm.influence(e, w, src)
        errs[fc] = float(max(abs(gm[s, k] / gd[s, k] - 1) for k, s in enumerate(src)))
        errs[f"{fc}_all"] = float(np.abs(gm - gd).max() / np.abs(gd).max())
    out = {"case": "modal", "size": size, "depth": depth, "pe": pe, "n_modes": n_modes, "dofs": cell.n_dofs,
           "t_modes": t_modes, "t_sweep": t_sweep, "t_direct_per_f": (time.perf_counter() - t - t_modes - t_sweep)
           / len(check), "rss": _rss_gb(), "modal_vs_direct": errs,
           "natural_f": {str(k): v[:6].tolist() for k, v in bm.frequencies(mat).items()}}
    for k_, (k, v) in enumerate(pr.items()):
        a = np.abs(g[:, v, k_])
        peaks = [float(f[i]) for i in range(1, nf - 1) if a[i] > a[i - 1] and a[i] > a[i + 1]]
        out[k] = {"g0": float(a[0]), "g1k": float(np.interp(1000, f, a)), "g5k": float(a[-1]), "peaks_Hz": peaks,
                  "max_over_g10": float(a.max() / a[0]), "f_max": float(f[np.argmax(a)])}
    out["across_centre_5k_over_10Hz"] = {int(j): float(abs(g[-1, j, 0]) / abs(g[0, j, 0])) for j in across}
    return out


CASES = {
    "block": [("block", 20e-3, 10e-3, 1), ("block", 20e-3, 10e-3, 1, "difference"), ("block", 20e-3, 10e-3, 2),
              ("block", 40e-3, 10e-3, 1), ("block", 40e-3, 10e-3, 1, "difference")],
    "big": [("block", 40e-3, 10e-3, 2)],
    "fine": [("block", 20e-3, 10e-3, 3)],
    "under": [("block", 20e-3, 6e-3, 2), ("block", 20e-3, 6e-3, 2, "none", "free")],
    "plate": [("plate", 20e-3, 1), ("plate", 20e-3, 2), ("plate", 40e-3, 1)],
    "tet": [("tet", 4e-3, 0.5e-3, 0), ("tet", 4e-3, 1e-3 / 3, 0), ("tet", 4e-3, 0.25e-3, 0), ("tet", 4e-3, 0, 2),
            ("tet", 4e-3, 0, 3), ("tet", 8e-3, 0.5e-3, 0), ("tet", 8e-3, 0, 2), ("tet", 8e-3, 0, 3)],
    "dyn": [("modal", 20e-3, 2, 40)],
    "dyn40": [("modal", 40e-3, 1, 60)],
    "flat": [("flat", 1), ("flat", 2)],
}


def _summary(r):
    """One readable line per result (the JSON line follows it)."""
    if r["case"] == "block":
        g = r["g"]
        return (f"# block {r['size'] * 1e3:g} mm groove depth {r['depth'] * 1e3:g} mm per_element {r['pe']} "
                f"{r['correction']} {r['edge']}: g_ii centre/edge/corner {g['centre']:.4e} {g['edge']:.4e} "
                f"{g['corner']:.4e} m/N, ratios {r['edge/centre']:.3f} {r['corner/centre']:.3f}, |G-G^T| "
                f"{100 * r['asym']:.2f} %, {r['dofs']} DOFs/class, {r['time']:.0f} s (factor {r['factor']:.0f}, "
                f"solve {r['solve']:.0f}), {r['rss']:.2f} GB, table {r['table_MB']:.1f} MB")
    if r["case"] == "flat":
        return f"# flat 60 mm block, per_element {r['pe']}: g/g_an - 1 [%] " + " ".join(f"{e:+.2f}" for e in r["err_pct"])
    if r["case"] == "tet":
        g = r["g"]
        return f"# {r['size'] * 1e3:g} mm block, {r['model']}: {g['centre']:.4e} {g['edge']:.4e} {g['corner']:.4e} m/N"
    if r["case"] == "plate":
        return (f"# plate {r['size'] * 1e3:g} mm per_element {r['pe']}: E_a/E bonded {r['bonded']:.3f}, frictionless "
                f"{r['frictionless']:.3f}, Gent & Lindley {r['gent_lindley']:.3f}")
    if r["case"] == "modal":
        return (f"# modal {r['size'] * 1e3:g} mm, {r['n_modes']} modes/class: vs direct {r['modal_vs_direct']}, "
                f"first natural f {{cls: Hz}} { {k: round(v[0]) for k, v in r['natural_f'].items()} }")
    return "#"


def main(argv):
    if argv and argv[0] == "--one":
        spec = json.loads(argv[1])
        # keep one case under ~10 GB of address space (SuperLU raises MemoryError instead of the OOM killer)
        resource.setrlimit(resource.RLIMIT_AS, (10 * 2**30, 10 * 2**30))
        fn = globals()["case_" + spec[0]]
        print("RESULT " + json.dumps(fn(*spec[1:])), flush=True)
        return
    groups = argv or list(CASES)
    for grp in groups:
        for spec in CASES[grp]:
            r = subprocess.run([sys.executable, __file__, "--one", json.dumps(spec)], capture_output=True, text=True)
            line = [ln for ln in r.stdout.splitlines() if ln.startswith("RESULT ")]
            if not line:
                print(spec, "FAILED", r.stderr[-2000:], flush=True)
                continue
            res = json.loads(line[0][7:])
            res.pop("diag", None)
            print(_summary(res), flush=True)
            print(json.dumps(res), flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
