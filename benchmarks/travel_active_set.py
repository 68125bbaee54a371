"""Is a transient's wave a member of the band of its own active set? (selection)

``./dev nice python3 benchmarks/travel_active_set.py RUN_DIR [--span S] [--speeds M]
[--rate bdf1|bdf2] [--inertia rotation|shift] [--tol T] [--sample I]``

The nodal statuses (separation / stick / slip) and slip senses of the run's last sample
(``--sample I``: sample I) are held fixed. For a fixed active set the wave-frame contact
law is linear in W at every ω (archive/travel/travelling_waves_history.md, "The discrete waves come
in
bands"):

    separated:  λ = S(ω) W = 0                    (both components)
    contact:    W_r = d
    stick:      W_θ − prev(W_θ) = RΩ · step       (newton.rate_stencil: the upwind rate)
    slip:       λ_θ = f sgn(q) λ_r

so one linear solve gives W(ω) (``newton.wave_of_active_set``). At M speeds ω0 (1 ± S)
the script solves it and checks that active set's inequalities
(``newton.inequality_margins``: gap in separation, p ≥ 0, |q| ≤ f p in stick, slip velocity
in the sense of q). The band of the transient's own active set is
where all of them hold. One JSON line: per speed the smallest margin and the inequality
that fails, the band, and the member nearest the transient's speed against the transient
(amplitude, sub-node ψ).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run", type=Path)
    ap.add_argument("--span", type=float, default=0.01, help="relative half-width of the scan")
    ap.add_argument("--speeds", type=int, default=81)
    ap.add_argument("--rate", choices=("bdf1", "bdf2"), default="bdf2")
    ap.add_argument("--inertia", choices=("rotation", "shift"), default="rotation")
    ap.add_argument("--sample", type=int, default=-1,
                    help="which sample's statuses (index, default the last)")
    ap.add_argument("--tol", type=float, default=1e-8,
                    help="a member: every margin >= -tol (relative, as newton's margin_tol)")
    a = ap.parse_args()
    if a.span <= 0.0 or a.speeds < 2:
        ap.error(f"--span {a.span} --speeds {a.speeds}: give a positive span and >= 2 speeds")

    from stickslip.postprocess.analysis import analyse_run, load_run
    from stickslip.solver.contact import SEPARATION, SLIP, STICK
    from stickslip.solver.scene import load_scene
    from stickslip.studies.travel import driver as D
    from stickslip.studies.travel.newton import (
        INEQUALITY_NAMES,
        inequality_margins,
        nodal_stiffness,
        wave_of_active_set,
    )

    if not (a.run / "samples.npz").is_file():
        ap.error(f"{a.run}: no samples.npz there (give a finished `stickslip run` directory)")
    scene = load_scene(a.run / "scene.toml")
    st = D.setup(scene, float(scene.damping.tau), rate=a.rate, inertia=a.inertia)
    prob, n = st.prob, st.prob.n
    run = load_run(a.run)
    s = run.samples
    order = np.argsort(s["theta"])
    status = np.asarray(s["status"][a.sample][order], dtype=np.int8)
    sense = np.sign(s["r_theta"][a.sample][order])
    wave = analyse_run(run)
    k, om0 = wave.mode, wave.angular_speed_rad_s
    R = scene.geometry.R
    fscale = nodal_stiffness(prob) * prob.d  # c·d, as solve_wave
    counts = {name: int(np.count_nonzero(status == code))
              for name, code in (("separation", SEPARATION), ("stick", STICK), ("slip", SLIP))}

    rows, members = [], []
    for om in om0 * np.linspace(1.0 - a.span, 1.0 + a.span, a.speeds):
        sol = wave_of_active_set(prob, status, sense, float(om))
        margins = inequality_margins(prob, sol, fscale)
        worst = min(margins, key=margins.get)
        rows.append({"c_m_s": om * R, "min_margin": margins[worst],
                     "failing": INEQUALITY_NAMES[worst] if margins[worst] < -a.tol else None})
        if margins[worst] >= -a.tol:
            summary, _ = D.measure(st, sol, k)
            members.append({"c_m_s": om * R, "amplitude_m": summary["amplitude_m"],
                            "psi1": summary["psi1_subnode"], "psi2": summary["psi2_subnode"]})
    t = {"c_m_s": wave.celerity_m_s, "amplitude_m": wave.amplitude_m, "psi1": wave.psi1,
         "psi2": wave.psi2}
    out = {"run": str(a.run), "k": k, "n": n, "rate": prob.rate, "inertia": a.inertia,
           "tol": a.tol, "sample": a.sample,
           "statuses": counts,
           "transient": t, "scan": rows, "members": members,
           "band_m_s": ([min(m["c_m_s"] for m in members), max(m["c_m_s"] for m in members)]
                        if members else None)}
    if members:
        out["member_at_c"] = min(members, key=lambda m: abs(m["c_m_s"] - t["c_m_s"]))
    print(json.dumps(out))


if __name__ == "__main__":
    main()
