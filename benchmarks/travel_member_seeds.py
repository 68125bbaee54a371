"""Which wave does the transient reach when it starts *on* a family member?

``./dev nice python3 benchmarks/travel_member_seeds.py FAMILY.json [--pick 8] [--shard I/N]
[--end-time 0.3] [--window 0.05] [--out FILE.jsonl]``

FAMILY.json is the ``--out`` of ``benchmarks/travel_family_scan.py`` (its scene or run
directory, overrides, k and operator). One member per admissible active set (the one at the
median speed of that set), ``--pick`` of them spread over the speed range, are each

1. re-solved (``newton.wave_of_active_set``: the same linear solve as the scan) and checked
   admissible;
2. turned into a whole-mesh state (u, v, a) of the transient's semi-discrete equations
   (``frame.FrameOperators.shift_state``: the interior rows of M a + K(u + τv) vanish, the
   contact rows are the member's nodal forces);
3. run as a transient from that state (``solver.run.Simulation(initial_state=...)``, the
   scene's own time step and scheme) for ``--end-time`` seconds, and measured by
   ``postprocess.analysis.analyse`` over consecutive windows of ``--window`` seconds.

One JSON line per member: the member (speed, zones, amplitude, ψ) and the transient's speed,
mode, amplitude and ψ per window, so one sees whether the transient stays on the member
(a family of attractors) or leaves it (and for which wave). ``--shard I/N`` runs every N-th
picked member from the I-th, to use N processes. ``--out`` appends the lines atomically at the
end. Exit status 1 if a transient stopped before ``--end-time``. Serial (one process per
shard).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np


def pick_members(members: list[dict], n_pick: int) -> list[dict]:
    """One member per active set (the median speed of its members), then ``n_pick`` of those
    spread evenly over the speed range (all of them if there are fewer)."""
    by_set: dict[tuple, list[dict]] = {}
    for m in members:
        by_set.setdefault(tuple(m["zones"]), []).append(m)
    one = [sorted(ms, key=lambda m: m["c_m_s"])[len(ms) // 2] for ms in by_set.values()]
    one.sort(key=lambda m: m["c_m_s"])
    if len(one) <= n_pick:
        return one
    idx = np.unique(np.round(np.linspace(0, len(one) - 1, n_pick)).astype(int))
    return [one[i] for i in idx]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("family", type=Path, help="the --out JSON of travel_family_scan.py")
    ap.add_argument("--pick", type=int, default=8)
    ap.add_argument("--shard", default="0/1", metavar="I/N")
    ap.add_argument("--end-time", type=float, default=0.3, help="transient length (s)")
    ap.add_argument("--window", type=float, default=0.05, help="analysis window (s)")
    ap.add_argument("--out", type=Path)
    a = ap.parse_args()
    try:
        shard, n_shards = (int(x) for x in a.shard.split("/"))
        if not 0 <= shard < n_shards:
            raise ValueError
    except ValueError:
        ap.error(f"--shard {a.shard}: give I/N with 0 <= I < N, e.g. 0/2")
    if a.pick < 1 or a.end_time <= 0.0 or not 0.0 < a.window <= a.end_time:
        ap.error(f"--pick {a.pick} --end-time {a.end_time} --window {a.window}: give a pick >= 1 "
                 "and 0 < window <= end-time")
    try:
        fam = json.loads(a.family.read_text())
        members, k = fam["members"], int(fam["k"])
    except (OSError, ValueError, KeyError) as err:
        ap.error(f"{a.family}: not a travel_family_scan --out file ({err})")
    if not members:
        ap.error(f"{a.family}: the scan found no members; nothing to start from")
    if fam.get("inertia") != "shift":
        ap.error(f"{a.family}: scanned with inertia {fam.get('inertia')!r}; a transient start "
                 "needs the transient's own operator (--inertia shift)")
    chosen = pick_members(members, a.pick)[shard::n_shards]
    from stickslip.solver.scene import SceneError
    from stickslip.studies.travel import driver as D

    try:
        scene = _scene(fam)
    except SceneError as err:
        ap.error(f"{a.family}: its source {fam['source']!r} gives no scene ({err})")
    st = D.setup(scene, float(scene.damping.tau), rate=fam["rate"], inertia="shift")
    lines = []
    try:
        for m in chosen:
            lines.append(run_member(st, k, m, a.end_time, a.window))
            print(json.dumps(lines[-1]), flush=True)
    except KeyboardInterrupt:
        print(f"travel_member_seeds: interrupted after {len(lines)} of {len(chosen)} members; "
              "the lines above are complete, --out was not written", file=sys.stderr)
        raise SystemExit(130) from None
    if a.out:
        from stickslip.solver.atomic import atomic_write_text

        old = a.out.read_text() if a.out.exists() else ""
        atomic_write_text(a.out, old + "".join(json.dumps(x) + "\n" for x in lines))
    stopped = [x["member"]["c_m_s"] for x in lines if x["status"] != "end_time"]
    if stopped:
        print(f"travel_member_seeds: the transients from the members at {stopped} m/s stopped "
              "before --end-time (see their status)", file=sys.stderr)
        raise SystemExit(1)


def _scene(fam: dict):
    from stickslip.solver.scene import load_scene

    src = Path(fam["source"])
    scene = load_scene(src / "scene.toml" if src.is_dir() else src)
    return scene.with_overrides(*fam["overrides"]) if fam["overrides"] else scene


def analyse_windows(rec: dict, scene, window: float) -> list[dict]:
    """``postprocess.analysis.analyse`` over consecutive windows of ``window`` seconds of a
    run's inner-circle record ``rec`` (``sim.recorder.arrays()``): mode, speed,
    amplitude, ψ and regime per window."""
    from stickslip.postprocess.analysis import analyse

    t = rec["t"]
    windows = []  # the last sample lies within one sample interval before end_time
    last = t[-1] + scene.output.sample_interval
    for end in np.arange(window, last, window):
        sel = (t > end - window - 1e-12) & (t <= end + 1e-12)
        if np.count_nonzero(sel) < 8:
            continue
        w = analyse(t[sel], rec["theta"], rec["u_r"][sel], rec["u_theta"][sel],
                    rec["status"][sel], d=scene.geometry.d, radius=scene.geometry.R,
                    window=window)
        windows.append({"t_end_s": round(float(end), 4), "mode": w.mode,
                        "c_m_s": round(w.celerity_m_s, 2),
                        "amplitude_mm": round(w.amplitude_m * 1e3, 3),
                        "psi1": round(w.psi1, 4), "psi2": round(w.psi2, 4),
                        "regime": w.regime})
    return windows


def run_member(st, k: int, member: dict, end_time: float, window: float) -> dict:
    """Re-solve ``member`` on the wave-frame setup ``st`` (``driver.setup``, inertia "shift"),
    start a transient of ``st.scene`` on it, measure it window by window."""
    from mpi4py import MPI

    from stickslip.solver.run import Simulation
    from stickslip.studies.travel.family import zone_pattern
    from stickslip.studies.travel.newton import (
        inequality_margins,
        nodal_stiffness,
        wave_amplitude,
        wave_of_active_set,
    )

    scene = st.scene
    prob, R = st.prob, scene.geometry.R
    n = prob.n
    omega = member["c_m_s"] / R
    status = np.tile(zone_pattern(n // k, *member["zones"]), k)
    sol = wave_of_active_set(prob, status, np.ones(n), omega, period=k)
    margin = min(inequality_margins(prob, sol, nodal_stiffness(prob) * prob.d).values())
    state = st.ops.shift_state(np.r_[sol.W_r, sol.W_t], omega)
    run_scene = scene.with_overrides(f"time.end_time={end_time}", "output.progress=false")
    t0 = time.perf_counter()
    sim = Simulation(run_scene, MPI.COMM_SELF, initial_state=state)
    sim.proceed()
    windows = analyse_windows(sim.recorder.arrays(), scene, window)
    return {"member": {"c_m_s": member["c_m_s"], "zones": member["zones"],
                       "amplitude_mm": round(wave_amplitude(prob, sol) * 1e3, 3),
                       "psi1": round(member["psi1"], 4), "psi2": round(member["psi2"], 4),
                       "min_margin": margin},
            "n": n, "k": k, "dt_fraction": scene.time.dt_fraction, "beta2": scene.time.beta2,
            "tau_s": scene.damping.tau, "status": sim.stop_reason,
            "wall_s": round(time.perf_counter() - t0, 1), "windows": windows}


if __name__ == "__main__":
    main()
