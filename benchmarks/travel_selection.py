"""Which member of a band of travelling waves does the transient reach?.

``./dev nice python3 benchmarks/travel_selection.py RUN_DIR [RUN_DIR ...] [--k K]``

For each finished transient run: the fixed-ω travel wave nearest to its speed (steps of 0.1 %,
±5 %, the scene's Kelvin–Voigt τ), then every member of that wave's band (``newton.wave_band``,
steps of 0.2 %, edges bisected), each measured like ``stickslip run`` (``driver.measure``:
amplitude, sub-node ψ, inequality margins). One JSON line per run: the transient's celerity,
amplitude, ψ and the members' table, the inequality violated beyond each edge, and where the
transient sits (relative position 0 = lower-c edge, 1 = upper-c edge).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", type=Path)
    ap.add_argument("--k", type=int, default=0)
    a = ap.parse_args()

    from stickslip.postprocess.analysis import analyse_run
    from stickslip.solver.scene import load_scene
    from stickslip.studies.travel import driver as D
    from stickslip.studies.travel.newton import NotConverged, nearest_wave, wave_band

    for run in a.runs:
        scene = load_scene(str(run / "scene.toml"), [])
        st = D.setup(scene, float(scene.damping.tau))
        W0, om0, _ = D.start_from_run(run, st)
        wave = analyse_run(run)
        k = a.k or wave.mode
        R = scene.geometry.R
        rec = {"run": str(run), "k": k, "n": st.ops.n, "dt_fraction": scene.time.dt_fraction,
               "transient": {"celerity_m_s": wave.celerity_m_s, "amplitude_m": wave.amplitude_m,
                             "psi1": wave.psi1, "psi2": wave.psi2}}
        try:
            sol = nearest_wave(st.prob, W0, om0, k, rel_step=0.001, max_steps=50, max_iter=30)
        except NotConverged as err:
            rec["status"] = f"none: {err}"
            print(json.dumps(rec), flush=True)
            continue
        why: list = []
        lo, hi, members = wave_band(st.prob, sol, k, rel_step=0.002, max_steps=60,
                                    bisections=5, max_iter=30, edge_reasons=why)
        rows = []
        for m in members:
            s, _ = D.measure(st, m, k)
            rows.append({"c": m.omega * R, "amplitude_m": s["amplitude_m"],
                         "psi1": s["psi1_subnode"], "psi2": s["psi2_subnode"],
                         "psi1_nodal": s["psi1"], "psi2_nodal": s["psi2"],
                         "cone_margin": s["inequalities"]["margins"]["cone_stick"],
                         "gap_margin": s["inequalities"]["margins"]["gap_separation"],
                         "slip_margin": s["inequalities"]["margins"]["slip_direction"],
                         "pressure_margin": s["inequalities"]["margins"]["pressure_contact"]})
        rows.sort(key=lambda r: r["c"])
        c = wave.celerity_m_s
        clo, chi = rows[0]["c"], rows[-1]["c"]
        rec.update(status="converged", band_m_s=[clo, chi], edge_violated=why,
                   transient_position=(c - clo) / (chi - clo) if chi > clo else None,
                   members=rows)
        print(json.dumps(rec), flush=True)


if __name__ == "__main__":
    main()
