"""The CEA of a finite tube: does the plane-strain flutter survive free ends, and which
axial order does it take?

    ./dev python3 benchmarks/cea_3d.py [SCENE] [--n 64] [--lengths 0.25 0.5 1 2]
        [--ends free roller] [--fmax 3000] [--top 4] [--set KEY=VALUE ...]

For the scene (default ``scenes/figure3_n132_damped.toml``: R = 1 m, ξ = 1.25, f = 0.7,
Kelvin–Voigt 2 % at 1.6 kHz) in quadrilaterals at N contact nodes around, it runs the 2D
CEA (``complex_eigenvalue_analysis``) and, for each L/R of ``--lengths`` and each end
condition, the CEA of the 3D tube (``solver.problem.tube_problem_3d``, hexahedra extruded
from that cross-section, N_z = round(L / (2πR/N)) layers: cells as long as they are wide on
the contact surface). It prints the ``--top`` most unstable modes of each: wavenumber k
(signed: + against the rotation, as ``CEAMode``), axial order m (nodal rings along z,
``cea.axial_order``), frequency and growth rate, and the 3D tube's dofs and wall time.

With roller ends the 2D modes are 3D modes exactly (m = 0; tests/test_tube3d.py). The CEA of
the 3D tube couples the friction to the θ-rows only: the damping f λ₀/(ΩR) that the disc
cone adds on the contact's z-dofs is left out (``tube_problem_3d``), as industrial CEA
leaves it out by default; modes with u_z on the contact surface are so slightly less damped
than they should be.
"""

from __future__ import annotations

import argparse
import time

from mpi4py import MPI

from stickslip.solver.problem import build_problem, tube_problem_3d
from stickslip.solver.scene import axial_layers, load_scene
from stickslip.studies.flutter_fe.cea import complex_eigenvalue_analysis


def modes_text(result, top: int) -> str:  # noqa: ANN001 - a CEAResult
    return "; ".join(f"k {m.k:+d} m {m.axial_order} {m.frequency_hz:.1f} Hz "
                     f"{m.growth_rate:.1f} 1/s" for m in result.unstable()[:top])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", nargs="?", default="scenes/figure3_n132_damped.toml")
    ap.add_argument("--n", type=int, default=64)
    ap.add_argument("--lengths", type=float, nargs="+", default=[0.25, 0.5, 1.0, 2.0])
    ap.add_argument("--ends", nargs="+", default=["free", "roller"])
    ap.add_argument("--fmax", type=float, default=3000.0)
    ap.add_argument("--top", type=int, default=4)
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="a scene override, as stickslip's --set")
    args = ap.parse_args()
    scene = load_scene(args.scene, [*args.set, f"mesh.n_inner={args.n}",
                                    "mesh.cell=quadrilateral"])
    R = scene.geometry.R
    t0 = time.perf_counter()
    two = complex_eigenvalue_analysis(build_problem(scene, MPI.COMM_SELF), fmax_hz=args.fmax)
    print(f"2D, N = {args.n}: {len(two.unstable())} unstable ({time.perf_counter() - t0:.1f} s)"
          f": {modes_text(two, args.top)}")
    for ratio in args.lengths:
        n_axial = int(axial_layers(scene, ratio * R))
        for ends in args.ends:
            t0 = time.perf_counter()
            problem = tube_problem_3d(scene, length=ratio * R, n_axial=n_axial, ends=ends,
                                      comm=MPI.COMM_SELF)
            res = complex_eigenvalue_analysis(problem, fmax_hz=args.fmax)
            print(f"L/R = {ratio:g}, N_z = {n_axial}, {ends}: {problem.n_global_dofs} dofs, "
                  f"{len(res.unstable())} unstable ({time.perf_counter() - t0:.1f} s): "
                  f"{modes_text(res, args.top)}", flush=True)


if __name__ == "__main__":
    main()
