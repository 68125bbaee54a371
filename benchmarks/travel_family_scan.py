"""Every k-periodic wave of the stick · slip · separation · landing-slip topology, by
enumeration of active sets (``studies.travel.family``).

``./dev nice python3 benchmarks/travel_family_scan.py SCENE [--set key=value ...] --c FROM TO
STEP --stick A B --slip A B [--land A B] [--k 4] [--rate bdf1] [--inertia shift]
[--samples S] [--time-scheme central] [--out FILE.json]``

``./dev nice python3 benchmarks/travel_family_scan.py RUN_DIR [--span 0.03] [--step 1]
[--pad 3]``: around a transient. k, its speed and the zone lengths seen in its last 40
snapshots (``family.zones_of_statuses``, ± ``--pad`` nodes) set the scan; the summary then
says where the transient lies in the family: inside the members' speed range or not, the
member nearest in speed, and the members at the scanned speed nearest to the transient's.

Speeds in m/s (signed: the Figure-1 waves run at c < 0). Zones in contact points per
wavelength, inclusive ranges: nodes, or with ``--samples S`` (S points per node, the node's
history between node passages, ``studies.travel.frame``) S times as many; from a RUN_DIR the
seen ranges are scaled by S. One JSON line per speed (progress: the best smallest margin and its
zones), one per member found, then a summary line: the members' speed, amplitude and ψ
ranges. ``--out`` writes every member and the per-speed best margins.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("source", type=Path, help="a scene file, or a `stickslip run` directory")
    ap.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--c", type=float, nargs=3, metavar=("FROM", "TO", "STEP"))
    ap.add_argument("--stick", type=int, nargs=2, metavar=("A", "B"))
    ap.add_argument("--slip", type=int, nargs=2, metavar=("A", "B"))
    ap.add_argument("--land", type=int, nargs=2, default=[0, 2], metavar=("A", "B"))
    ap.add_argument("--span", type=float, default=0.03, help="RUN_DIR: relative half-width")
    ap.add_argument("--step", type=float, default=1.0, help="RUN_DIR: speed step (m/s)")
    ap.add_argument("--pad", type=int, default=3, help="RUN_DIR: nodes added to each zone range")
    ap.add_argument("--k", type=int, default=4)
    ap.add_argument("--rate", choices=("bdf1", "bdf2"), default="bdf1")
    ap.add_argument("--inertia", choices=("rotation", "shift"), default="shift")
    ap.add_argument("--samples", type=int, default=1, help="contact points per mesh node")
    ap.add_argument("--time-scheme", choices=("exact", "central"), default="exact",
                    help="shift operator exact in time, or the transient's central-difference "
                         "step h = node passage / samples")
    ap.add_argument("--tol", type=float, default=1e-8)
    ap.add_argument("--out", type=Path)
    a = ap.parse_args()
    if a.samples < 1 or ((a.samples > 1 or a.time_scheme != "exact")
                         and a.inertia != "shift"):
        ap.error(f"--samples {a.samples} --time-scheme {a.time_scheme}: give a whole number "
                 ">= 1; more than 1, or central, needs --inertia shift")
    if a.span <= 0.0 or a.step <= 0.0 or a.pad < 0:
        ap.error(f"--span {a.span} --step {a.step} --pad {a.pad}: give a positive span and step "
                 "and a pad >= 0")
    transient = None
    if a.source.is_dir():
        if not (a.source / "samples.npz").is_file():
            ap.error(f"{a.source}: no samples.npz there (give a finished `stickslip run` "
                     "directory or a scene file)")
        transient = _transient(a)
        scene_file = a.source / "scene.toml"
    elif a.source.is_file():
        scene_file = a.source
        if a.c is None or a.stick is None or a.slip is None:
            ap.error("with a scene file give --c FROM TO STEP, --stick A B and --slip A B")
    else:
        ap.error(f"{a.source}: no such scene file or run directory")
    c_from, c_to, c_step = a.c
    if c_step == 0.0 or (c_to - c_from) * c_step < 0.0:
        ap.error(f"--c {c_from} {c_to} {c_step}: the step must be non-zero and point from "
                 "FROM to TO")

    from stickslip.solver.scene import SceneError, load_scene
    from stickslip.studies.travel import driver as D

    try:
        scene = load_scene(scene_file)
        if a.overrides:
            scene = scene.with_overrides(*a.overrides)
    except SceneError as err:
        ap.error(f"{scene_file}: {err}")
    t0 = time.process_time()
    st = D.setup(scene, float(scene.damping.tau), rate=a.rate, inertia=a.inertia,
                 samples=a.samples, time_scheme=a.time_scheme)
    R = scene.geometry.R
    if a.k < 1 or st.prob.n % a.k:
        ap.error(f"k = {a.k}: a k-periodic wave on {st.prob.n} contact nodes needs k to divide "
                 f"{st.prob.n} (choose another k or mesh.n_inner)")
    n_wave = st.prob.n // a.k
    zones = [(s1, s2, s3) for s1 in range(a.stick[0], a.stick[1] + 1)
             for s2 in range(a.slip[0], a.slip[1] + 1)
             for s3 in range(a.land[0], a.land[1] + 1)
             if n_wave - s1 - s2 - s3 >= 1]
    if not zones:
        ap.error(f"--stick {a.stick} --slip {a.slip} --land {a.land}: no zone lengths that fit a "
                 f"wavelength of {n_wave} nodes (give A <= B and room for a separation run)")
    print(json.dumps({"n": st.prob.n, "samples": a.samples, "time_scheme": a.time_scheme,
                      "k": a.k,
                      "active_sets": len(zones), "rate": a.rate, "inertia": a.inertia,
                      "setup_cpu_s": round(time.process_time() - t0, 1)}),
          flush=True)
    speeds = np.arange(c_from, c_to + 1e-9 * c_step, c_step)
    members, best = [], []
    try:
        _scan(a, st, R, speeds, zones, members, best)
    except KeyboardInterrupt:
        print(f"travel_family_scan: interrupted after {len(best)} of {speeds.size} speeds; the "
              "lines above are complete, --out was not written", file=sys.stderr)
        raise SystemExit(130) from None
    summary: dict = {"members": len(members),
                     "active_sets_admissible": len({tuple(m["zones"]) for m in members})}
    if members:
        for key in ("c_m_s", "amplitude_mm", "psi1", "psi2"):
            vals = [m[key] for m in members]
            summary[key] = [min(vals), max(vals)]
    if transient is not None:
        summary["transient"] = transient["wave"]
        if members:
            ct = transient["wave"]["c_m_s"]
            summary["transient_inside_speed_range"] = (
                summary["c_m_s"][0] <= ct <= summary["c_m_s"][1])
            summary["nearest_in_speed"] = min(members, key=lambda m: abs(m["c_m_s"] - ct))
            c_at = summary["nearest_in_speed"]["c_m_s"]
            summary["members_at_that_speed"] = [m for m in members if m["c_m_s"] == c_at]
    print(json.dumps({"summary": summary}))
    if a.out:
        from stickslip.solver.atomic import atomic_write_text

        atomic_write_text(a.out, json.dumps({"source": str(a.source), "overrides": a.overrides,
                                             "k": a.k, "n": st.prob.n, "rate": a.rate,
                                             "inertia": a.inertia, "samples": a.samples,
                                             "time_scheme": a.time_scheme,
                                             "summary": summary,
                                             "members": members, "best": best}))


def _scan(a: argparse.Namespace, st, R: float, speeds: np.ndarray, zones: list,
          members: list, best: list) -> None:
    """The speed loop: one JSON line per speed and per member; fills ``members``, ``best``."""
    from stickslip.studies.travel.family import scan_family

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


def _transient(a: argparse.Namespace) -> dict:
    """k, speed, amplitude, ψ and zone ranges of a run's wave; sets a.k, a.c and the zones."""
    from stickslip.postprocess.analysis import analyse_run, load_run
    from stickslip.studies.travel.family import zones_of_statuses

    run = load_run(a.source)
    wave = analyse_run(run)
    s = run.samples
    order = np.argsort(s["theta"])
    seen = []
    for status in s["status"][-40:]:
        z = zones_of_statuses(np.asarray(status)[order])
        if z:
            seen.extend(z)
    if wave.angular_speed_rad_s == 0.0 or not seen:
        raise SystemExit(f"{a.source}: the run's last samples hold no stick · slip · "
                         "separation · slip wave (steady sliding or another topology)")
    sm = a.samples
    lo, hi = sm * np.min(seen, axis=0), sm * np.max(seen, axis=0)
    a.k = wave.mode
    a.stick = [max(1, int(lo[0]) - sm * a.pad), int(hi[0]) + sm * a.pad]
    a.slip = [max(0, int(lo[1]) - sm * a.pad), int(hi[1]) + sm * a.pad]
    a.land = [max(0, int(lo[2]) - sm * a.pad), int(hi[2]) + sm * a.pad]
    c0 = wave.celerity_m_s
    step = -a.step if c0 < 0 else a.step
    a.c = [c0 * (1.0 - a.span), c0 * (1.0 + a.span), step]
    return {"wave": {"c_m_s": c0, "k": wave.mode, "amplitude_mm": wave.amplitude_m * 1e3,
                     "psi1": wave.psi1, "psi2": wave.psi2,
                     "zones_seen": sorted({tuple(z) for z in seen})}}


if __name__ == "__main__":
    main()
