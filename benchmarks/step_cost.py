"""Cost of one explicit step against a bare loop of one PETSc MatMult plus vector updates.

    ./dev python3 benchmarks/step_cost.py [--n 132 528] [--steps 1000] [--repeats 5]

Prints, per mesh: the bare loop (MatMult + the 6 Newmark vector updates, same matrix), the
integrator step with contact, and the full time loop (observers: energy work, probes,
samples), in microseconds per step and as a ratio to the bare loop; each is the minimum
over ``--repeats`` interleaved blocks of ``--steps`` steps. Targets (fused
step): loop/bare <= 1.3 at N = 132 and <= 1.1 at N >= 528. One process, one core.

``--kernel numpy numba`` (one or more of numpy, numba, auto; ``time.kernel``, solver/fused.py)
gives one row per kernel, side by side; the first steps are taken before timing and their
wall time (numba compiles or loads its on-disk cache) printed. With the fused kernel on one
rank the loop advances between two samples in one compiled call (``SceneExplicit.advance``).

``--tube L`` measures the finite tube besides (``mesh.dim = 3``, length L m, free ends,
numpy: its contact surface has the numpy step) and its plane-strain cross-section, both in
quadrilaterals, and prints the loop's cost per dof of each and their ratio (3D / 2D), and
the bare loop's share of the step (bare/step: what a fused compiled step could not save; the
rest bounds its gain).
"""

from __future__ import annotations

import argparse
import resource
import time

import numpy as np
from mpi4py import MPI

from stickslip.solver.run import Simulation
from stickslip.solver.scene import load_scene


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


def measure(n_inner: int, steps: int, kernel: str, repeats: int,
            extra: tuple[str, ...] = ()) -> dict:
    """Bare loop, step alone and full loop, ``repeats`` interleaved blocks of ``steps`` steps
    each; the minimum per block kind (the least-disturbed block: on a shared machine other
    jobs only ever add time)."""
    scene = load_scene("scenes/figure3_n132.toml",
                       [f"mesh.n_inner={n_inner}", "output.progress=false",
                        f'time.kernel="{kernel}"', *extra])
    sim = Simulation(scene, MPI.COMM_SELF)
    integ = sim.integrator
    if 2 * repeats * steps + 16 > sim.planned_steps():
        raise SystemExit(f"--steps {steps} x --repeats {repeats} x 2 exceeds the scene's "
                         f"{sim.planned_steps()} planned steps: the observers would stop "
                         "recording; lower --steps")
    t0 = time.perf_counter()
    integ.step()  # first call: numba compiles or loads its cache
    sim.proceed(end_time=np.inf, max_steps=integ.step_count + 8)  # the loop's own kernels
    first = time.perf_counter() - t0
    bare = step_only = full = np.inf
    for _ in range(repeats):
        bare = min(bare, bare_loop(sim.problem, steps))
        t0 = time.perf_counter()
        for _ in range(steps):
            integ.step()
        step_only = min(step_only, (time.perf_counter() - t0) / steps)
        t0 = time.perf_counter()
        sim.proceed(end_time=np.inf, max_steps=integ.step_count + steps)
        full = min(full, (time.perf_counter() - t0) / steps)
    rec = sim.columns.sampler  # the run's BatchRecorder: no record may have filled up
    assert rec.n < rec.max_samples and rec.n_probe < rec.probe_t.size
    return {"n_inner": n_inner, "dofs": sim.problem.n_global_dofs, "bare_us": 1e6 * bare,
            "step_us": 1e6 * step_only, "loop_us": 1e6 * full, "first_s": first,
            "kernel": getattr(integ, "kernel", "numpy")}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[132, 528])
    ap.add_argument("--steps", type=int, default=1000, help="steps per timed block")
    ap.add_argument("--repeats", type=int, default=5, help="interleaved blocks per kind")
    ap.add_argument("--kernel", choices=("auto", "numpy", "numba"), nargs="+",
                    default=["auto"], help="one row per kernel and mesh, side by side")
    ap.add_argument("--tube", type=float, default=0.0,
                    help="also the 3D tube of this length (m) against its cross-section")
    args = ap.parse_args()
    if args.tube > 0.0:
        tube_rows(args)
        return
    print(f"{'N':>5} {'dofs':>7} {'kernel':>6} {'1st call s':>10} {'bare us':>9} {'step us':>9} "
          f"{'loop us':>9} {'step/bare':>9} {'target':>7} {'loop/bare':>9}")
    for n, kernel in ((n, k) for n in args.n for k in args.kernel):
        r = measure(n, args.steps, kernel, args.repeats)
        tgt = 1.3 if n < 528 else 1.1
        print(f"{n:5d} {r['dofs']:7d} {r['kernel']:>6} {r['first_s']:10.3f} {r['bare_us']:9.1f}"
              f" {r['step_us']:9.1f} {r['loop_us']:9.1f} {r['step_us'] / r['bare_us']:9.2f}"
              f" {tgt:7.1f} {r['loop_us'] / r['bare_us']:9.2f}")
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"peak RSS {rss:.0f} MB")


def tube_rows(args: argparse.Namespace) -> None:
    """The loop's cost per dof of the 3D tube against its plane-strain cross-section, both
    numpy and in quadrilaterals, measured side by side (``--tube``)."""
    plane = ("mesh.cell=quadrilateral",)
    tube = (*plane, "mesh.dim=3", f"geometry.length={args.tube}", "boundary.ends=free")
    print(f"{'N':>5} {'case':>6} {'dofs':>7} {'loop us':>9} {'loop ns/dof':>11} "
          f"{'bare/step':>9}")
    for n in args.n:
        rows = {name: measure(n, args.steps, "numpy", args.repeats, extra)
                for name, extra in (("2D", plane), ("3D", tube))}
        per_dof = {name: 1e3 * r["loop_us"] / r["dofs"] for name, r in rows.items()}
        for name, r in rows.items():
            print(f"{n:5d} {name:>6} {r['dofs']:7d} {r['loop_us']:9.1f} {per_dof[name]:11.2f} "
                  f"{r['bare_us'] / r['step_us']:9.2f}")
        print(f"{n:5d} {'3D/2D':>6} {'':>7} {'':>9} {per_dof['3D'] / per_dof['2D']:11.2f}")


if __name__ == "__main__":
    main()
