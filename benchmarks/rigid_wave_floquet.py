"""A rigid wave's stability two ways: its Floquet multipliers, and a transient started on it.

    ./dev python3 benchmarks/rigid_wave_floquet.py RUN_DIR --period T --nodes M \\
        [--krylov 600] [--periods 300]

RUN_DIR is a census start on a rigid wave. The orbit is solved with the shift held at M whole
node passages (``OrbitProblem(hold_shift=True)``, as ``stickslip rpo --nodes``): R_s is then
the node permutation, the mesh's own symmetry, and G = R₋ₛ F_T is the scheme's map. It prints:

* the orbit's residual, T and s;
* the leading multipliers of DG (Arnoldi, ``--krylov`` vectors), each with its Ritz
  residual, its growth rate ln|μ|/T, its frame frequency arg μ/(2πT) and the dominant
  wavenumber of its eigenvector's u_r on the contact circle;
* a transient of G from the orbit plus a random 10⁻⁶ (relative RMS) perturbation over
  ``--periods`` periods: |δξ| every tenth of them, and the growth rate of |δξ| fitted where
  it grows linearly: above 100 times its start (the leading mode dominates) and below a
  tenth of its largest (before it saturates).

The two rates agree when the multipliers are the scheme's (the how-to's table,
docs/howto/rpo.md: P at N = 264, the tutorial point at N = 528).
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from stickslip.studies.rpo.certificate import solve_orbit
from stickslip.studies.rpo.newton import arnoldi
from stickslip.studies.rpo.orbit import OrbitProblem, start_from_run


def contact_wavenumber(problem: OrbitProblem, xi_part: np.ndarray) -> int:
    """The dominant wavenumber of the radial displacement of a state (or an eigenvector) on
    the contact circle."""
    nd = problem.start.problem.nodes
    u = xi_part[: problem.n] * problem.scale[: problem.n]
    ur = (nd.cos_t * u[nd.dofs_x] + nd.sin_t * u[nd.dofs_y])[np.argsort(nd.theta)]
    return int(np.argmax(np.abs(np.fft.fft(ur))[: ur.size // 2 + 1]))  # ur may be complex


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir")
    ap.add_argument("--period", type=float, required=True, help="guess of T (s)")
    ap.add_argument("--nodes", type=int, required=True, help="node passages in T (signed)")
    ap.add_argument("--krylov", type=int, default=600)
    ap.add_argument("--periods", type=int, default=300)
    args = ap.parse_args()
    start = start_from_run(args.run_dir)
    shift = 2.0 * math.pi * args.nodes / start.scene.mesh.n_inner
    P = OrbitProblem(start, args.period, shift, hold_shift=True)
    result, orbit = solve_orbit(P, tol=1e-10, max_iter=25)
    T = orbit.period
    print(f"orbit: residual {result.residual:.2e} after {result.iterations} iterations, "
          f"T = {T:.6e} s ({P.steps} steps), s = {math.degrees(orbit.shift):.4f} deg")
    t0 = time.perf_counter()
    V, H = arnoldi(P.monodromy(orbit), np.random.default_rng(1).standard_normal(orbit.xi.size),
                   args.krylov, 0.0)
    m = H.shape[1]
    values, y = np.linalg.eig(H[:m, :m])
    ritz = np.abs(H[m, m - 1] * y[-1, :] / np.linalg.norm(y, axis=0))
    for j in np.argsort(-np.abs(values))[:8]:
        mu = values[j]
        print(f"  |mu| {abs(mu):.6f}  growth {math.log(abs(mu)) / T:+7.2f} 1/s  "
              f"frame {np.angle(mu) / (2 * math.pi * T):+8.2f} Hz  ritz {ritz[j]:.1e}  "
              f"k {contact_wavenumber(P, V[:, :m] @ y[:, j])}")
    print(f"  ({args.krylov} Arnoldi vectors, {time.perf_counter() - t0:.0f} s)")
    rng = np.random.default_rng(5)
    xi = orbit.xi + 1e-6 * rng.standard_normal(orbit.xi.size) / math.sqrt(orbit.xi.size)
    size = []
    for _ in range(args.periods):
        xi = P.rotate(P.flow(xi, T), -orbit.shift)
        size.append(float(np.linalg.norm(xi - orbit.xi)))
    for k in range(0, args.periods, max(1, args.periods // 10)):
        print(f"  period {k + 1:5d}  |dxi| {size[k]:.3e}")
    size = np.array(size)
    linear = (size > 100.0 * size[0]) & (size < 0.1 * size.max())
    if linear.sum() < 3:
        print("transient from the orbit: no linear range (|dxi| between 100 x its start and "
              "a tenth of its largest) to fit")
        return
    times = T * np.arange(1, args.periods + 1)
    rate = np.polyfit(times[linear], np.log(size[linear]), 1)[0]
    print(f"transient from the orbit: |dxi| grows at {rate:+.2f} 1/s over periods "
          f"{int(np.flatnonzero(linear)[0]) + 1} - {int(np.flatnonzero(linear)[-1]) + 1} "
          f"(its linear range: 100 x its start to a tenth of its largest)")


if __name__ == "__main__":
    main()
