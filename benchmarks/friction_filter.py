"""Linear-stage evidence and step cost of the 1-2-1 filtered friction bound
(docs/friction_filter.md).

    ./dev python3 benchmarks/friction_filter.py

1. Round-off growth of unperturbed steady sliding, figure3_n132 (Figure-3 physics, N = 132),
   beta2 = 1/2, dt = 0.9 dt_crit, numpy kernel: nodal vs 1-2-1. Stops when max|u - u0| reaches
   4e-10 m (linear stage); growth = slope of log max|u - u0| over the second half; the
   u_theta spectrum peak of u - u0 at the end.
2. Step cost at N = 264, side by side in one process: nodal/numba, nodal/numpy, 1-2-1/numpy,
   2000 steps x 3 repetitions, min reported (the machine is shared: ratios, not absolutes).
"""

from __future__ import annotations

import time

import numpy as np
from mpi4py import MPI

from stickslip.solver.run import Simulation
from stickslip.solver.scene import load_scene


def roundoff_growth(filt: str, stop_m: float = 4e-10, max_steps: int = 900) -> str:
    """Growth rate and dominant wavenumber of round-off from steady sliding (one line)."""
    sc = load_scene("figure3_n132", ['initial.perturbation="none"', "output.progress=false",
                                     "time.beta2=0.5", 'time.kernel="numpy"',
                                     f'friction.filter="{filt}"'])
    sim = Simulation(sc, MPI.COMM_SELF)
    u0 = sim.integrator.u.copy()
    _, ut0 = sim.problem.polar(u0)
    order = np.argsort(sim.problem.nodes.theta)
    dev = np.zeros(max_steps)
    m = max_steps
    for i in range(max_steps):
        sim.integrator.step()
        dev[i] = np.max(np.abs(sim.integrator.u - u0))
        if dev[i] > stop_m:
            m = i + 1
            break
    t = sim.dt * np.arange(1, m + 1)
    rate = np.polyfit(t[m // 2:m], np.log(dev[m // 2:m]), 1)[0]
    _, ut = sim.problem.polar(sim.integrator.u)
    spec = np.abs(np.fft.rfft((ut - ut0)[order]))
    k = int(np.argmax(spec[1:]) + 1)
    return (f"| {filt} | {sim.problem.nodes.n_global} | {sim.dt * 1e6:.2f} | {m} | {rate:.0f} | "
            f"{k} |")


def step_cost() -> list[str]:
    """us per step of the three step variants, N = 264, interleaved repetitions."""
    base = ["output.progress=false", "mesh.n_inner=264", "mesh.n_radial=0", "time.beta2=0.5"]
    cases = {"nodal, numba": ['time.kernel="auto"'], "nodal, numpy": ['time.kernel="numpy"'],
             "1-2-1, numpy": ['friction.filter="1-2-1"']}
    sims = {k: Simulation(load_scene("figure3_n132", base + v), MPI.COMM_SELF)
            for k, v in cases.items()}
    for s in sims.values():
        for _ in range(50):
            s.integrator.step()
    res: dict[str, list[float]] = {k: [] for k in sims}
    for _ in range(3):
        for k, s in sims.items():
            t0 = time.perf_counter()
            for _ in range(2000):
                s.integrator.step()
            res[k].append((time.perf_counter() - t0) / 2000 * 1e6)
    return [f"| {k} | {getattr(sims[k].integrator, 'kernel', 'numpy')} | {min(v):.0f} | "
            + ", ".join(f"{x:.0f}" for x in v) + " |" for k, v in res.items()]


def main() -> None:
    print("| friction | N | dt (us) | steps | growth (1/s) | u_theta peak k |")
    print("|---|---|---|---|---|---|")
    for filt in ("nodal", "1-2-1"):
        print(roundoff_growth(filt), flush=True)
    print("\n| step | kernel | min (us/step) | repetitions |\n|---|---|---|---|")
    print("\n".join(step_cost()))


if __name__ == "__main__":
    main()
