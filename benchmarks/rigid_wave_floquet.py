"""A rigid wave's stability three ways: the multipliers of its orbit locked to p steps per M
node passages, the growth of the map started on that orbit, and λ₁ of the run at its own
step.

    ./dev python3 benchmarks/rigid_wave_floquet.py RUN_DIR --period T --nodes M \\
        [--steps P [P ...]] [--periods 0] [--krylov 150]

RUN_DIR is a census start on a rigid wave; T a guess of M node passages (M signed: − against
the rotation). For each p of ``--steps`` (default round(T/Δt)) the orbit is solved with the
shift held at M whole node passages (``OrbitProblem(hold_shift=True)``, as ``stickslip rpo
--nodes``): R_s is the node permutation, and G = R₋ₛ F_T the scheme's map over p steps of
h = T/p. It prints per p:

* h/Δt, the orbit's residual, and the leading multipliers' growth rates ln|μ|/T and
  frame angles (``floquet_multipliers``, ``--krylov`` vectors);
* with ``--periods`` > 0, the map G iterated from the orbit plus 10⁻⁶ over that many
  periods, and the growth rate fitted over its linear range (``growth_from_the_orbit``).

Then λ₁ of the run where its checkpoint stands, at its own step Δt (``fe_lyapunov``: the
census's stability certificate, 0.2 s of twin renormalised every 5 ms). The how-to's table
(docs/howto/rpo.md) is this script's output at the tutorial point (N = 132) and at P
(N = 264): the locked orbit's growth swings with p; λ₁ at Δt does not see it.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from stickslip.studies.attractors.chaos import fe_lyapunov
from stickslip.studies.rpo.certificate import solve_orbit
from stickslip.studies.rpo.floquet import floquet_multipliers, growth_from_the_orbit
from stickslip.studies.rpo.orbit import OrbitProblem, start_from_run


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir")
    ap.add_argument("--period", type=float, required=True, help="guess of T (s)")
    ap.add_argument("--nodes", type=int, required=True, help="node passages in T (signed)")
    ap.add_argument("--steps", type=int, nargs="*", default=None, help="steps p in T")
    ap.add_argument("--krylov", type=int, default=150)
    ap.add_argument("--periods", type=int, default=0)
    args = ap.parse_args()
    start = start_from_run(args.run_dir)
    shift = 2.0 * math.pi * args.nodes / start.scene.mesh.n_inner
    print(f"node passages per step of the run: {abs(args.nodes) * start.dt / args.period:.4f}")
    for steps in args.steps or [None]:
        t0 = time.perf_counter()
        P = OrbitProblem(start, args.period, shift, steps=steps, hold_shift=True)
        result, orbit = solve_orbit(P, tol=1e-10, max_iter=25)
        flo = floquet_multipliers(P, orbit, count=6, krylov=args.krylov)
        growth = ", ".join(f"{g:+.2f} ({a:+.3f})" for g, a in
                           zip(flo.growth, np.angle(flo.multipliers), strict=True))
        print(f"p = {P.steps}, M = {args.nodes}: h/dt = {P.step_of(orbit.period) / start.dt:.4f}"
              f", residual {result.residual:.1e}; growth 1/s (angle): {growth}; "
              f"{'stable' if flo.stable else 'UNSTABLE' if flo.stable is False else '?'} "
              f"({time.perf_counter() - t0:.0f} s)")
        if args.periods > 0:
            _, rate, (first, last) = growth_from_the_orbit(P, orbit, args.periods)
            print("  the map from the orbit: " + (
                "no linear range" if rate is None else
                f"|dxi| grows at {rate:+.2f} 1/s over periods {first} - {last}"))
    lyap = fe_lyapunov(args.run_dir, 0.2, 0.005)
    print(f"lambda1 of the run at its own step: {lyap.exponent:+.2f} +- {lyap.error:.2f} 1/s")


if __name__ == "__main__":
    main()
