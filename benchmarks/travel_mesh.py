"""Mesh convergence of the travelled wave against the transient (issue 14 item 3, third rung).

``./dev nice python3 benchmarks/travel_mesh.py RUN_DIR [RUN_DIR ...] [--lumped] [--step S]``

Each RUN_DIR is a finished ``stickslip run scenes/figure1_n132_damped.toml --set
mesh.n_inner=N --set time.dt_fraction=F`` (mode-k seed 0.1 d, β₂ = 1/2, τ = 1.989 µs);
N is read from the run. For each: the travel problem on the same mesh with the scene's τ
(``--lumped``: the wave-frame inertia by the vertex rule, the transient's mass lumping),
fixed-ω solves from the run's last sample at ω0(1 ± j·S), j ≤ 0.05/S (nearest admissible speed
first), then the band of the wave found. One JSON line per run on stdout.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", type=Path)
    ap.add_argument("--lumped", action="store_true")
    ap.add_argument("--step", type=float, default=0.001)
    ap.add_argument("--scan", type=float, default=0.05)
    ap.add_argument("--k", type=int, default=0, help="wavenumber (default: the run's mode)")
    a = ap.parse_args()

    from postprocess.analysis import analyse_run
    from solver.scene import load_scene
    from studies.travel import driver as D
    from studies.travel.newton import NotConverged, nearest_wave

    for run in a.runs:
        scene = load_scene(str(run / "scene.toml"), [])
        t0 = time.process_time()
        st = D.setup(scene, float(scene.damping.tau), lumped=a.lumped)
        W0, om0, _ = D.start_from_run(run, st)
        wave = analyse_run(run)
        k = a.k or wave.mode
        R = scene.geometry.R
        rec = {"run": str(run), "k": k, "n": st.ops.n, "dofs": int(st.ops.problem.n_global_dofs),
               "lumped": a.lumped, "dt_fraction": scene.time.dt_fraction,
               "transient_c_m_s": wave.celerity_m_s,
               "transient_amplitude_m": wave.amplitude_m, "transient_psi1": wave.psi1,
               "transient_psi2": wave.psi2, "step": a.step, "scan": a.scan}
        try:
            sol = nearest_wave(st.prob, W0, om0, k, rel_step=a.step,
                               max_steps=int(round(a.scan / a.step)), max_iter=30)
            m, _ = D.measure(st, sol, k)
            b = D.band(st, sol, k)
            lo, hi = b["celerity_m_s"]
            c = wave.celerity_m_s
            rec.update(status="converged", celerity_m_s=sol.omega * R, band=b,
                       regime=m["regime"], amplitude_m=m["amplitude_m"],
                       psi1_subnode=m["psi1_subnode"], psi2_subnode=m["psi2_subnode"],
                       transient_outside_band_m_s=max(lo - c, c - hi, 0.0))
        except NotConverged as err:
            rec.update(status="none", last_residual=err.info.get("residual"),
                       violated=err.info.get("violated"))
        rec["cpu_s"] = time.process_time() - t0
        print(json.dumps(rec), flush=True)


if __name__ == "__main__":
    main()
