"""Cost of one explicit step against a bare loop of one PETSc MatMult plus vector updates.

    ./dev python3 benchmarks/step_cost.py [--n 132 528] [--steps 3000]

Prints, per mesh: the bare loop (MatMult + the 6 Newmark vector updates, same matrix), the
integrator step with contact, and the full time loop (observers: energy work, probes,
samples), in microseconds per step and as a ratio to the bare loop. Targets (issue 15, fused
step): loop/bare <= 1.3 at N = 132 and <= 1.1 at N >= 528. One process, one core.

``--kernel numpy numba`` (one or more of numpy, numba, auto; ``time.kernel``, solver/fused.py)
gives one row per kernel, side by side; the first step is taken before timing and its wall
time (numba compile or on-disk cache load) printed.
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


def measure(n_inner: int, steps: int, kernel: str) -> dict:
    scene = load_scene("scenes/figure3_n132.toml",
                       [f"mesh.n_inner={n_inner}", "output.progress=false",
                        f'time.kernel="{kernel}"'])
    sim = Simulation(scene, MPI.COMM_SELF)
    bare = min(bare_loop(sim.problem, steps) for _ in range(3))
    integ = sim.integrator
    t0 = time.perf_counter()
    integ.step()  # first call: numba compiles or loads its cache
    first = time.perf_counter() - t0
    t0 = time.perf_counter()
    for _ in range(steps):
        integ.step()
    step_only = (time.perf_counter() - t0) / steps
    n0 = integ.step_count + 8  # warm-up: the loop's own kernel (fused: ``advance``) compiles
    t0 = time.perf_counter()
    sim.proceed(end_time=np.inf, max_steps=n0)
    first += time.perf_counter() - t0
    t0 = time.perf_counter()
    sim.proceed(end_time=np.inf, max_steps=n0 + steps)
    full = (time.perf_counter() - t0) / steps
    return {"n_inner": n_inner, "dofs": sim.problem.n_global_dofs, "bare_us": 1e6 * bare,
            "step_us": 1e6 * step_only, "loop_us": 1e6 * full, "first_s": first,
            "kernel": getattr(integ, "kernel", "numpy")}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[132, 528])
    ap.add_argument("--steps", type=int, default=3000)
    ap.add_argument("--kernel", choices=("auto", "numpy", "numba"), nargs="+",
                    default=["auto"], help="one row per kernel and mesh, side by side")
    args = ap.parse_args()
    print(f"{'N':>5} {'dofs':>7} {'kernel':>6} {'1st call s':>10} {'bare us':>9} {'step us':>9} "
          f"{'loop us':>9} {'step/bare':>9} {'target':>7} {'loop/bare':>9}")
    for n, kernel in ((n, k) for n in args.n for k in args.kernel):
        r = measure(n, args.steps, kernel)
        tgt = 1.3 if n < 528 else 1.1
        print(f"{n:5d} {r['dofs']:7d} {r['kernel']:>6} {r['first_s']:10.3f} {r['bare_us']:9.1f}"
              f" {r['step_us']:9.1f} {r['loop_us']:9.1f} {r['step_us'] / r['bare_us']:9.2f}"
              f" {tgt:7.1f} {r['loop_us'] / r['bare_us']:9.2f}")
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"peak RSS {rss:.0f} MB")


if __name__ == "__main__":
    main()
