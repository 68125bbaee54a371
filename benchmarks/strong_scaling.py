"""Strong scaling of one large scene: time per explicit step on 1 and 2 MPI ranks.

    ./dev python3 benchmarks/strong_scaling.py [--n 1024] [--steps 1000] [--ranks 1 2] [--repeat 2]
        [--set KEY=VALUE ...]

Drives ``mpirun -n P python3 benchmarks/strong_scaling.py --worker ...`` for each P. A worker
builds scenes/figure3_n132.toml with ``mesh.n_inner = N`` (automatic layers), warms up 20
steps, then times (a) ``--steps`` bare integrator steps (stiffness MatMult + contact
projection) and (b) the same number of steps of the full time loop (observers: energy, probes,
samples every 1e-4 s). Setup phases (mesh + assembly, stability, steady state) are reported
as well, with the peak resident memory of all ranks together. ``--set`` adds scene
overrides: ``--set mesh.dim=3 --set geometry.length=1 --set mesh.cell=quadrilateral`` times
the finite tube (its numpy step).

The stability limit uses a Gershgorin bound, omega_max^2 <= max_i sum_j |K_ij| / m_i (safe:
it only shortens dt, which changes nothing per step), instead of the SLEPc solve, because at
N >= 1000 SLEPc's Krylov-Schur does not reach its 1e-10 tolerance in 500 iterations
(solver/problem.py ``omega_max``); ``--omega slepc`` uses the solver's own routine.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def gershgorin_omega_max(problem) -> float:  # noqa: ANN001
    """Upper bound of the largest eigenfrequency of M^-1 K (lumped M; clamped rows skipped)."""
    import numpy as np
    from mpi4py import MPI

    indptr, _, values = problem.K.getValuesCSR()
    row_abs = np.add.reduceat(np.abs(values), indptr[:-1]) if values.size else np.zeros(0)
    row_abs[np.diff(indptr) == 0] = 0.0
    lam = float(np.max(row_abs[: problem.n_owned] * problem.inv_mass, initial=0.0))
    return math.sqrt(problem.comm.allreduce(lam, op=MPI.MAX))


def worker(n: int, steps: int, omega: str, sets: list[str]) -> None:
    import resource

    import numpy as np
    from mpi4py import MPI

    import stickslip.solver.problem  # noqa: F401 (loaded: used as an attribute)
    from stickslip import solver
    from stickslip.solver.run import Simulation
    from stickslip.solver.scene import load_scene

    if omega == "gershgorin":
        solver.problem.omega_max = gershgorin_omega_max
    comm = MPI.COMM_WORLD
    scene = load_scene(REPO / "scenes" / "figure3_n132.toml",
                       [f"mesh.n_inner={n}", "output.progress=false", "time.end_time=10.0",
                        f"time.max_steps={2 * steps + 40}", *sets])  # recorders sized to the run
    t0 = time.perf_counter()
    sim = Simulation(scene, comm)
    setup = time.perf_counter() - t0
    integ = sim.integrator
    for _ in range(20):
        integ.step()
    comm.Barrier()
    t0 = time.perf_counter()
    for _ in range(steps):
        integ.step()
    comm.Barrier()
    step = (time.perf_counter() - t0) / steps
    n0 = integ.step_count
    comm.Barrier()
    t0 = time.perf_counter()
    sim.proceed(end_time=np.inf, max_steps=n0 + steps)
    comm.Barrier()
    loop = (time.perf_counter() - t0) / steps
    result = {
        "ranks": comm.size, "n_inner": n, "dofs": int(sim.problem.n_global_dofs),
        "dt_s": sim.dt, "setup_s": setup, "step_us": 1e6 * step, "loop_us": 1e6 * loop,
        "profile_s": {k: round(v, 3) for k, v in sim.profile.seconds.items()},
        "omega": omega,
        "rss_mb": comm.allreduce(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024),
    }
    if comm.rank == 0:
        print("RESULT " + json.dumps(result), flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1024, help="contact nodes N (>= 1000)")
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--omega", choices=("gershgorin", "slepc"), default="gershgorin")
    ap.add_argument("--repeat", type=int, default=1,
                    help="alternate the rank counts this many times, keep the fastest loop")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--json", help="also write the results here")
    ap.add_argument("--set", dest="sets", action="append", default=[],
                    help="a scene override KEY=VALUE (repeatable)")
    args = ap.parse_args()
    if args.worker:
        worker(args.n, args.steps, args.omega, args.sets)
        return
    load = os.getloadavg()
    print(f"load average before: {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} on "
          f"{os.cpu_count()} cores")
    runs: dict[int, list[dict]] = {p: [] for p in args.ranks}
    for _ in range(args.repeat):
        for p in args.ranks:
            cmd = ["mpirun", "-n", str(p), sys.executable, __file__, "--worker", "--n",
                   str(args.n), "--steps", str(args.steps), "--omega", args.omega,
                   *(f"--set={kv}" for kv in args.sets)]
            res = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True,
                                 env=dict(os.environ, PYTHONPATH=str(REPO)))
            line = next((ln for ln in res.stdout.splitlines() if ln.startswith("RESULT ")),
                        None)
            if res.returncode != 0 or line is None:
                raise SystemExit(f"{p} rank(s) failed:\n{res.stdout}\n{res.stderr}")
            runs[p].append(json.loads(line[7:]))
    for p, rs in runs.items():
        print(f"  {p} rank(s), loop us/step of each run: "
              + ", ".join(f"{r['loop_us']:.0f}" for r in rs))
    results = [min(rs, key=lambda r: r["loop_us"]) for rs in runs.values()]
    ref = results[0]
    print(f"N = {ref['n_inner']}, {ref['dofs']} dofs, dt = {ref['dt_s']:.3g} s, "
          f"{args.steps} timed steps")
    print(f"{'ranks':>5} {'setup s':>8} {'step us':>9} {'loop us':>9} {'speed-up':>9} "
          f"{'efficiency':>10} {'RSS MB':>8}")
    for r in results:
        sp = ref["loop_us"] / r["loop_us"]
        print(f"{r['ranks']:5d} {r['setup_s']:8.1f} {r['step_us']:9.1f} {r['loop_us']:9.1f} "
              f"{sp:9.2f} {sp / (r['ranks'] / ref['ranks']):10.2f} {r['rss_mb']:8.0f}")
    load = os.getloadavg()
    print(f"load average after: {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
