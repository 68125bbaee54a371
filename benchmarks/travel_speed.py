"""Speed of ``stickslip travel``, one core: ``OMP_NUM_THREADS=1 python3
benchmarks/travel_speed.py [RUN_DIR]``.

Prints, each with its wall time:

1. the reduced-model rung: one wave (k = 8 example, N = 256) from the closed-form start;
2. a 40-point continuation in Ω of that reduced wave (50 ... 1000 rad/s);
3. the FE problem at N = 132 (figure1_n132_damped, the scene's Kelvin–Voigt τ):
   mesh + K + G + D + one condensation (setup), then one wave from the transient run RUN_DIR
   (default runs/figure1_n132_damped; run ``stickslip run scenes/figure1_n132_damped.toml``
   first; fixed-ω nearest-speed route, as ``stickslip travel --fixed-omega``), wall and CPU
   time, with its outcome;
4. a 40-point FE continuation in loading.omega (36 contact nodes, Figure-1 physics, start
   speed −2300 m/s held fixed per point);
5. the issue's two targets as whole ``stickslip travel`` processes (start-up and imports
   included, CPU = user + sys of the child): one wave at N = 132 from RUN_DIR (target < 2 s),
   and a 40-point continuation in loading.omega = 40 … 50 rad/s at N = 132 from the same run
   (target < 60 s); each by the rotation frame (``--inertia rotation --fixed-omega``), by
   the transient's own discrete wave at S = 6 (``--samples 6``) and by the default route
   (the matched S).
"""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from stickslip.semianalytic.coefficients import coefficients, gamma_from_physical
from stickslip.semianalytic.waves import stick_slip_waves
from stickslip.studies.travel.newton import NotConverged, solve_wave
from stickslip.studies.travel.reduced import reduced_problem, wave_start


def main() -> None:
    run_dir = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("runs/figure1_n132_damped")
    co = coefficients(0.3, 1.25, gamma_from_physical(1000.0, 1.0, 100.0))
    w = [x for x in stick_slip_waves(co, 1.0, 8, 0.005) if x.admissible][0]
    n = 256
    prob = reduced_problem(co, 1.0, 0.005, n)
    W0, c0 = wave_start(w, n)
    t0 = time.perf_counter()
    sol = solve_wave(prob, W0, c0, 8)
    print(f"reduced wave k=8 N={n}: {time.perf_counter() - t0:.3f} s, c err "
          f"{abs(sol.omega - w.c) / abs(w.c):.2e}, {sol.iterations} iterations")

    # 2. continuation in Ω, 40 values from 100 down to 50 rad/s (c√γ is Ω independent: the
    # predictor scales c as 1/Ω and W_θ − V_e as Ω, V_e = δfg/h the steady slip value)
    from stickslip.semianalytic.waves import continuation_omega

    omegas = np.linspace(100.0, 50.0, 40)
    t0 = time.perf_counter()
    ok, first_bad = 0, None
    W, c = np.concatenate([sol.W_r, sol.W_t]), sol.omega
    om_prev = 100.0
    for om in omegas:
        cor = coefficients(0.3, 1.25, gamma_from_physical(1000.0, 1.0, om))
        pr = reduced_problem(cor, 1.0, 0.005, n)
        ve = 0.005 * 1.0 * cor.g / cor.h
        Wp = W.copy()
        Wp[n:] = ve + (W[n:] - ve) * om / om_prev
        try:
            s = solve_wave(pr, Wp, c * om_prev / om, 8)
            W, c, om_prev = np.concatenate([s.W_r, s.W_t]), s.omega, om
            ok += 1
        except NotConverged as err:
            first_bad = first_bad or (om, str(err)[:80])
    t_cont = time.perf_counter() - t0
    ref = continuation_omega(w, omegas)
    n_adm = sum(1 for r in ref if r is not None and r.admissible)
    print(f"reduced continuation, 40 values of Omega 100 -> 50: {t_cont:.2f} s, {ok}/40 "
          f"converged (closed form: {n_adm}/40 admissible); first failure: {first_bad}")

    # 3. FE at N = 132
    from stickslip.solver.scene import load_scene
    from stickslip.studies.travel import driver as D

    t0, c0 = time.perf_counter(), time.process_time()
    sc132 = load_scene("scenes/figure1_n132_damped.toml")
    st = D.setup(sc132, sc132.damping.tau)
    st.prob.stiffness(-2500.0)
    t_setup, c_setup = time.perf_counter() - t0, time.process_time() - c0
    msg = "no run directory"
    t1, c1 = time.perf_counter(), time.process_time()
    if (run_dir / "samples.npz").exists():
        W0, om0, _ = D.start_from_run(run_dir, st)
        try:
            s = D.solve_scene(st, 4, W0, om0, max_iter=30, free_omega=False)
            msg = f"converged, {s.omega:.1f} m/s, {s.iterations} iterations"
        except NotConverged as err:
            msg = f"FAILED: {str(err)[:90]}"
    print(f"FE N=132 damped: setup (mesh, K, G, D, one condensation) {t_setup:.2f} s wall, "
          f"{c_setup:.2f} s CPU; one wave from the transient {time.perf_counter() - t1:.2f} s "
          f"wall, {time.process_time() - c1:.2f} s CPU: {msg}")

    # 4. FE continuation, 40 points, N = 36
    from types import SimpleNamespace

    from stickslip.studies.travel.continuation import run_continuation

    sc = load_scene("scenes/figure1.toml", ["mesh.n_inner=36"])
    args = SimpleNamespace(k=4, damping=0.0, from_run=None, celerity=-2300.0,
                           fixed_omega=True, max_iter=40, plot=False, rate="bdf2",
                           inertia="rotation", samples=1, time_scheme="exact")
    out = Path("/tmp/travel_speed_cont")
    out.mkdir(exist_ok=True)
    t0 = time.perf_counter()
    run_continuation(sc, args, "loading.omega", list(np.linspace(30.0, 50.0, 40)), out, t0)
    print(f"FE continuation N=36, 40 points: {time.perf_counter() - t0:.2f} s")

    # 5. the targets as whole processes, two routes: the one-point-per-node rotation frame
    # (fixed ω, band member) and the transient's own discrete wave (central scheme, S = 6,
    # free ω on one wavelength; archive/travel/travelling_waves_history.md 2e)
    if (run_dir / "samples.npz").exists():
        common = ["stickslip", "travel", "scenes/figure1_n132_damped.toml", "--k", "4",
                  "--from", str(run_dir), "--force"]
        routes = {"rotation --fixed-omega": ["--inertia", "rotation", "--fixed-omega"],
                  "central S=6": ["--samples", "6"],
                  "default (matched S)": []}
        for route, flags in routes.items():
            for what, extra, target in (
                    ("one wave", ["-o", "/tmp/travel_speed_one"], 2.0),
                    ("40-point continuation", ["--continue", "loading.omega=40:50:40",
                                               "-o", "/tmp/travel_speed_c132"], 60.0)):
                wall, cpu, rc = _child_cost(common + flags + extra)
                print(f"whole process, N=132, {route}, {what}: {wall:.2f} s wall, "
                      f"{cpu:.2f} s CPU (target {target:g} s), exit {rc}")


def _child_cost(cmd: list[str]) -> tuple[float, float, int]:
    """Wall time and CPU time (user + sys) of one child process, with its exit status."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    rc = subprocess.run(cmd, stdout=subprocess.DEVNULL, env={**os.environ,
                        "OMP_NUM_THREADS": "1"}).returncode
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, rc


if __name__ == "__main__":
    main()
