"""Mesh convergence of the FE layer cell (tyreroad.fe_layer, issue 27) against the analytic element kernel.

For each mesh (base A and two refinements towards the load, B and C: fine spacing 0.5, 0.25, 0.125 mm) the
quarter cell of the tread preset's layer (h = 10 mm, nu = 0.49, 80 x 80 mm period) is solved statically
(quasi-static modulus) and at 100 Hz, 1 kHz and 5 kHz. Printed per mesh and frequency: the relative error
g_FE / g - 1 [%] (static: signed; FRF: its modulus) at the excitation element (0,0) and the neighbours (1,0),
(1,1), (2,0), where g is

* ``inf``: today's analytic kernel of the laterally infinite layer (greens.static_element_kernel /
  greens.element_frf): the issue's acceptance numbers (discretisation + cell-size error), and
* ``per``: the same kernel summed over the cell's periodic images (fe_layer.periodic_images), which is what
  the FE cell represents exactly: the discretisation error alone.

plus free DOFs, assembly time, factor-and-solve time per frequency, SuperLU factor entries and the peak RSS of
the process that ran the mesh (each mesh runs in its own process). Never fails on time.

Run: OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python benchmarks/fe_layer_convergence.py [--element hex2|hexs2|hex1]
     [--volumetric full|reduced] [--half-width 0.04] [--quick]
Hex2 needs about 11 GB (mesh C, 127 k DOFs, 256 M complex LU entries) and 20 min on one core; hexs2 about half.
With --fine-extent 0.0015, mesh C (0.125 mm over 1.5 mm) needs more than 24 GB (killed here).
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import functools
import resource
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
C = 1e-3
FREQS = (0.0, 100.0, 1000.0, 5000.0)
PROBES = ((0, 0), (1, 0), (1, 1), (2, 0))
# base mesh and two refinements towards the load: fine spacing halved, the uniformly fine patch kept at
# four fine elements, the same growth ratio 1.5 and far-field spacing (the last row also halves that)
MESHES = {
    "A (base)": dict(fine=0.5e-3, fine_extent=2e-3, growth=1.5, coarse=4e-3),
    "B = A/2 near": dict(fine=0.25e-3, fine_extent=1e-3, growth=1.5, coarse=4e-3),
    "C = A/4 near": dict(fine=0.125e-3, fine_extent=0.5e-3, growth=1.5, coarse=4e-3),
}


def material():
    from tyreroad.pipeline import _material, resolved_material_config

    cfg = yaml.safe_load(open(ROOT / "config" / "config.yaml"))
    return _material("tread", resolved_material_config("tread", cfg["materials"]))


def run_mesh(name, spec, element, half_width, volumetric="full"):
    from tyreroad.fe_layer import CellMesh, LayerCell

    m = material()
    cell = LayerCell(m.thickness, m.poisson, m.density, C,
                     CellMesh(half_width=half_width, element=element, volumetric=volumetric, **spec), n_field=2)
    rows = []
    for f in FREQS:
        w = 2 * np.pi * f
        e = m.quasi_static_modulus if f == 0 else m.modulus(w)
        t0 = time.perf_counter()
        g = cell.solve(e, w)
        rows.append((f, g, time.perf_counter() - t0, cell.factor_nnz))
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6  # kB -> GB
    return dict(name=name, dofs=cell.n_dofs, assembly=cell.assembly_time, rows=rows, rss=rss,
                offsets=cell.offsets)


def references(offsets, half_width):
    from tyreroad import greens
    from tyreroad.fe_layer import periodic_images

    m = material()
    out = {}
    for f in FREQS:
        w = 2 * np.pi * f
        if f == 0:
            k = functools.partial(greens.static_element_kernel, element_size=C, modulus=m.quasi_static_modulus,
                                  poisson=m.poisson, thickness=m.thickness)
        else:
            k = lambda o, w=w: greens.element_frf(o, C, w, m.modulus(w), m.poisson, m.density, m.thickness)[0]
        out[f] = (k(offsets), periodic_images(k, offsets, 2 * half_width))
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--element", default="hex2", choices=("hex2", "hexs2", "hex1"))
    ap.add_argument("--half-width", type=float, default=40e-3, help="quarter cell's lateral size L/2 [m]")
    ap.add_argument("--volumetric", default="full", choices=("full", "reduced"),
                    help="Gauss order of the lambda div u div v term (reduced: selective reduced integration)")
    ap.add_argument("--fine-extent", type=float, default=None,
                    help="keep the uniformly fine patch at this size [m] on all meshes instead of 4 fine elements")
    ap.add_argument("--quick", action="store_true", help="base mesh only")
    args = ap.parse_args()
    meshes = dict(list(MESHES.items())[:1]) if args.quick else MESHES
    if args.fine_extent is not None:
        meshes = {name: dict(spec, fine_extent=args.fine_extent) for name, spec in meshes.items()}
    print(f"FE layer cell vs analytic kernel: element {args.element} ({args.volumetric} volumetric integration), "
          f"period {2e3 * args.half_width:.0f} mm, "
          f"h = 10 mm, nu = 0.49, c = 1 mm; errors g_FE/g - 1 in % (static, signed) and |g_FE/g - 1| in % (FRF)")
    ref = None
    for name, spec in meshes.items():
        with cf.ProcessPoolExecutor(max_workers=1) as pool:
            r = pool.submit(run_mesh, name, spec, args.element, args.half_width, args.volumetric).result()
        offsets = r["offsets"] / C
        idx = [int(np.flatnonzero((offsets[:, 0] == i) & (offsets[:, 1] == j))[0]) for i, j in PROBES]
        if ref is None:
            ref = references(r["offsets"][idx], args.half_width)
        print(f"\nmesh {name}: {spec}  free DOFs {r['dofs']}, assembly {r['assembly']:.1f} s, "
              f"peak RSS {r['rss']:.2f} GB")
        head = "  f [Hz]   " + "".join(f"{str(p):>17s}" for p in PROBES) + "   solve [s]  LU entries"
        print(head)
        print("           " + "     inf      per" * len(PROBES))
        for f, g, dt, nnz in r["rows"]:
            g_inf, g_per = ref[f]
            sign = np.real if f == 0 else np.abs
            e_inf = 100 * sign(g[idx] / g_inf - 1)
            e_per = 100 * sign(g[idx] / g_per - 1)
            cells = "".join(f"  {a:7.3f}  {b:7.3f}" for a, b in zip(e_inf, e_per))
            print(f"  {f:7.0f} {cells}   {dt:8.1f}   {nnz / 1e6:7.1f} M")


if __name__ == "__main__":
    main()
