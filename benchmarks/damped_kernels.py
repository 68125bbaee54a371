"""Kelvin-Voigt damped scenes: the numpy step, the fused kernel and the batched kernel, side by
side in one process.

    ./dev python3 benchmarks/damped_kernels.py [--scene scenes/figure1_n132_damped.toml]
        [--steps 2000] [--batch 16] [--repeat 3] [--set KEY=VALUE ...]

The scene (default: the damped Figure-1 scene, N = 132, beta2 = 1/2, loss factor 2 % at
1.6 kHz, 0.9 dt_crit) runs ``--steps`` steps from its start, with its samples every
``output.sample_interval`` (the energies, W_d included), three ways:

* ``numpy``: the numpy kernel (PETSc MatMult of K w_n) with ``DampingWork`` as a step hook;
* ``fused``: ``SceneExplicit`` with tau (one compiled call between two samples);
* ``batched``: ``Simulation.batch`` of ``--batch`` copies of the scene with random starts
  (``initial.seed`` = 0 .. B - 1), ``BatchedExplicit`` with tau.

Printed: the time loop's wall time (the best of ``--repeat`` interleaved rounds; set-up,
steady state and the kernels' first call excluded: a warm-up run compiles or loads them
first), scene-steps per second and the speed-up over the numpy step. The undamped fused and
batched kernels on the same scene are printed too, for the cost of the damping (w_n formed
per step, the damping sums, one K u_n per sample).
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))


def loop_seconds(make) -> float:
    """The time-loop wall time of a fresh run (``make()`` builds it)."""
    sim = make()
    sim.proceed() if hasattr(sim, "runs") else sim.proceed(end_time=float("inf"))
    return sim.profile.seconds["time-loop"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default=str(REPO / "scenes" / "figure1_n132_damped.toml"))
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--batch", type=int, default=16)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="scene override, e.g. --set mesh.n_inner=264 (repeatable)")
    args = ap.parse_args()

    from mpi4py import MPI

    from stickslip.solver.run import Simulation
    from stickslip.solver.scene import load_scene

    base = load_scene(args.scene, ["output.progress=false", f"time.max_steps={args.steps}",
                                   "time.end_time=10.0", *args.set])
    if base.damping.tau <= 0.0:
        raise SystemExit(f"{args.scene}: no [damping] (tau = 0); pick a damped scene")
    starts = [base.with_overrides('initial.perturbation="random"', f"initial.seed={k}")
              for k in range(args.batch)]

    def single(kernel: str, scene=base):
        def make():
            return Simulation(scene.with_overrides(f'time.kernel="{kernel}"'), MPI.COMM_SELF)
        return make

    undamped = ("damping.retardation_time=0.0", "damping.loss_factor=0.0")
    cases = {
        "numpy kernel": (single("numpy"), 1),
        "fused (SceneExplicit)": (single("numba"), 1),
        f"batched B = {args.batch}": (lambda: Simulation.batch(starts), args.batch),
        "fused, undamped": (single("numba", base.with_overrides(*undamped)), 1),
        f"batched B = {args.batch}, undamped": (
            lambda: Simulation.batch([s.with_overrides(*undamped) for s in starts]),
            args.batch),
    }
    short = base.with_overrides("time.max_steps=5")  # compile or load every kernel once
    Simulation(short, MPI.COMM_SELF).proceed(end_time=float("inf"))
    Simulation.batch([short] * args.batch).proceed()

    sim = Simulation(base, MPI.COMM_SELF)
    print(f"{base.name}: N = {base.mesh.n_inner}, dofs = {sim.problem.n_global_dofs}, "
          f"dt = {sim.dt:.4g} s ({base.time.dt_fraction} dt_crit), beta2 = {base.time.beta2}, "
          f"tau = {base.damping.tau:.4g} s, {args.steps} steps, samples every "
          f"{base.output.sample_interval:g} s; best of {args.repeat}; "
          f"{os.cpu_count()} CPU(s), load {os.getloadavg()[0]:.1f}")
    best = dict.fromkeys(cases, float("inf"))
    for _ in range(args.repeat):  # interleaved: a burst of other jobs hits every case alike
        for name, (make, _scenes) in cases.items():
            best[name] = min(best[name], loop_seconds(make))
    print(f"{'step':34s} {'loop s':>9s} {'scene-steps/s':>14s} {'vs numpy':>9s}")
    first = None
    for name, (_make, scenes) in cases.items():
        rate = scenes * args.steps / best[name]
        first = first or rate
        print(f"{name:34s} {best[name]:9.3f} {rate:14.0f} {rate / first:8.1f}x")


if __name__ == "__main__":
    main()
