"""Every k-periodic wave of the stick · slip · separation · landing-slip topology, by
enumeration of active sets (issue 14 items 3-4; ``studies.travel.family``).

``./dev nice python3 benchmarks/travel_family_scan.py SCENE [--set key=value ...] --c FROM TO
STEP --stick A B --slip A B [--land A B] [--k 4] [--rate bdf1] [--inertia shift]
[--out FILE.json]``

Speeds in m/s (signed: the Figure-1 waves run at c < 0). Zones in nodes per wavelength,
inclusive ranges. One JSON line per speed (progress: the best smallest margin and its
zones), one per member found, then a summary line: the members' speed, amplitude and ψ
ranges. ``--out`` writes every member and the per-speed best margins.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", type=Path)
    ap.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--c", type=float, nargs=3, required=True, metavar=("FROM", "TO", "STEP"))
    ap.add_argument("--stick", type=int, nargs=2, required=True, metavar=("A", "B"))
    ap.add_argument("--slip", type=int, nargs=2, required=True, metavar=("A", "B"))
    ap.add_argument("--land", type=int, nargs=2, default=[0, 2], metavar=("A", "B"))
    ap.add_argument("--k", type=int, default=4)
    ap.add_argument("--rate", choices=("bdf1", "bdf2"), default="bdf1")
    ap.add_argument("--inertia", choices=("rotation", "shift"), default="shift")
    ap.add_argument("--tol", type=float, default=1e-8)
    ap.add_argument("--out", type=Path)
    a = ap.parse_args()
    c_from, c_to, c_step = a.c
    if c_step == 0.0 or (c_to - c_from) * c_step < 0.0:
        ap.error(f"--c {c_from} {c_to} {c_step}: the step must be non-zero and point from "
                 "FROM to TO")
    if not a.scene.is_file():
        ap.error(f"{a.scene}: no such scene file")

    from solver.scene import load_scene
    from studies.travel import driver as D
    from studies.travel.family import scan_family

    scene = load_scene(a.scene)
    if a.overrides:
        scene = scene.with_overrides(*a.overrides)
    t0 = time.process_time()
    st = D.setup(scene, float(scene.damping.tau), rate=a.rate, inertia=a.inertia)
    R = scene.geometry.R
    n_wave = st.prob.n // a.k
    zones = [(s1, s2, s3) for s1 in range(a.stick[0], a.stick[1] + 1)
             for s2 in range(a.slip[0], a.slip[1] + 1)
             for s3 in range(a.land[0], a.land[1] + 1)
             if n_wave - s1 - s2 - s3 >= 1]
    print(json.dumps({"n": st.prob.n, "k": a.k, "active_sets": len(zones), "rate": a.rate,
                      "inertia": a.inertia, "setup_cpu_s": round(time.process_time() - t0, 1)}),
          flush=True)
    speeds = np.arange(c_from, c_to + 1e-9 * c_step, c_step)
    members, best = [], []
    for c in speeds:
        t1 = time.process_time()
        scan = scan_family(st.prob, a.k, [c / R], zones, tol=a.tol)
        om, margin, z, why = scan.best[0]
        best.append({"c_m_s": round(float(c), 6), "best_margin": margin, "zones": z,
                     "violated": why})
        for m in scan.members:
            members.append({"c_m_s": round(m.omega * R, 6), "zones": m.zones,
                            "amplitude_mm": m.amplitude * 1e3, "psi1": m.psi1, "psi2": m.psi2})
            print(json.dumps({"member": members[-1]}), flush=True)
        print(json.dumps(best[-1] | {"cpu_s": round(time.process_time() - t1, 2)}), flush=True)
    summary: dict = {"members": len(members),
                     "active_sets_admissible": len({tuple(m["zones"]) for m in members})}
    if members:
        for key in ("c_m_s", "amplitude_mm", "psi1", "psi2"):
            vals = [m[key] for m in members]
            summary[key] = [min(vals), max(vals)]
    print(json.dumps({"summary": summary}))
    if a.out:
        from solver.atomic import atomic_write_text

        atomic_write_text(a.out, json.dumps({"scene": str(a.scene), "overrides": a.overrides,
                                             "k": a.k, "n": st.prob.n, "rate": a.rate,
                                             "inertia": a.inertia, "summary": summary,
                                             "members": members, "best": best}))


if __name__ == "__main__":
    main()
