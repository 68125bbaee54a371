"""Cost of one explicit step against a bare loop of one PETSc MatMult plus vector updates.

    ./dev python3 benchmarks/step_cost.py [--n 132 528] [--steps 3000]

Prints, per mesh: the bare loop (MatMult + the 6 Newmark vector updates, same matrix), the
integrator step with contact, and the full time loop (observers: energy work, probes,
samples), in microseconds per step and as a ratio to the bare loop. Targets (issue 4):
ratio <= 2.0 at N = 132 and <= 1.3 at N = 528 for the full loop. One process, one core.
"""

from __future__ import annotations

import argparse
import resource
import time

import numpy as np
from mpi4py import MPI

from solver.run import Simulation
from solver.scene import load_scene


def bare_loop(problem, steps: int) -> float:
    mult = problem.stiffness_mult()
    n = problem.n_owned
    u, v, a, ku, vp, s = (np.zeros(n) for _ in range(6))
    u[:] = 1e-6
    minv = problem.inv_mass
    dt = 1e-9
    t0 = time.perf_counter()
    for _ in range(steps):
        mult(u, ku)
        np.multiply(ku, minv, out=a)
        np.multiply(a, 0.5 * dt, out=v)
        v += vp
        np.multiply(v, dt, out=s)
        u += s
        np.multiply(a, 0.5 * dt, out=vp)
    return (time.perf_counter() - t0) / steps


def measure(n_inner: int, steps: int) -> dict:
    scene = load_scene("scenes/figure3_n132.toml",
                       [f"mesh.n_inner={n_inner}", "output.progress=false"])
    sim = Simulation(scene, MPI.COMM_SELF)
    bare = min(bare_loop(sim.problem, steps) for _ in range(3))
    integ = sim.integrator
    t0 = time.perf_counter()
    for _ in range(steps):
        integ.step()
    step_only = (time.perf_counter() - t0) / steps
    t0 = time.perf_counter()
    n0 = integ.step_count
    sim.proceed(end_time=np.inf, max_steps=n0 + steps)
    full = (time.perf_counter() - t0) / steps
    return {"n_inner": n_inner, "dofs": sim.problem.n_global_dofs, "bare_us": 1e6 * bare,
            "step_us": 1e6 * step_only, "loop_us": 1e6 * full}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[132, 528])
    ap.add_argument("--steps", type=int, default=3000)
    args = ap.parse_args()
    targets = {132: 2.0, 528: 1.3}
    print(f"{'N':>5} {'dofs':>7} {'bare us':>9} {'step us':>9} {'loop us':>9} "
          f"{'step/bare':>9} {'loop/bare':>9} {'target':>7}")
    for n in args.n:
        r = measure(n, args.steps)
        tgt = targets.get(n)
        print(f"{n:5d} {r['dofs']:7d} {r['bare_us']:9.1f} {r['step_us']:9.1f} {r['loop_us']:9.1f}"
              f" {r['step_us'] / r['bare_us']:9.2f} {r['loop_us'] / r['bare_us']:9.2f}"
              f" {tgt if tgt else '-':>7}")
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"peak RSS {rss:.0f} MB")


if __name__ == "__main__":
    main()
