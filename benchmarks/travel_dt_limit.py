"""The Δt → 0 wave of ``stickslip travel --dt-limit`` against transients at Δt/2 and Δt/4.

``./dev nice python3 benchmarks/travel_dt_limit.py RUN_DIR [RUN_DIR ...] [--end-time 0.1]``

For each finished run (dt = Δt): ``wave_from_run(RUN_DIR, dt_limit=True)`` gives the waves
at S, 2S, 4S and their extrapolation in h. Then the transient of the run's scene is run at
Δt/2 and Δt/4, each started on the wave at 2S or 4S (``FrameOperators.shift_state``, a
state next to the transient's own wave at that step, so it stays on the run's member instead
of choosing another attractor, as a start from steady sliding may), for ``--end-time`` s
and analysed over its last third like a run. The three transients (Δt, Δt/2, Δt/4) are
extrapolated the same way (observed order from their celerities). One JSON line per run:
the waves, the transients, both extrapolations and their relative difference.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np


def nested_waves(end, s: int) -> list:
    """(Setup, wave) at S, 2S, 4S: the matched wave from the run, each next one from the last
    prolonged (as ``from_run.dt_limit_wave``)."""
    from stickslip.studies.travel import driver as D
    from stickslip.studies.travel.from_run import _setup, solve_matched

    st, sol, _ = solve_matched(end, s)
    out = [(st, sol)]
    for f in (2, 4):
        st = _setup(end, f * s)
        sol = D.solve_free(st, end.k, D.prolong(np.r_[sol.W_r, sol.W_t], st.ops.n), sol.omega,
                           max_iter=40)
        out.append((st, sol))
    return out


def transient_on(end, st, sol, dt: float, end_time: float) -> dict:
    """The run's scene at ``dt``, started on the wave ``sol`` of the frame ``st``."""
    from mpi4py import MPI

    from stickslip.postprocess.analysis import analyse
    from stickslip.solver.run import Simulation
    u, v, a = st.ops.shift_state(np.r_[sol.W_r, sol.W_t], sol.omega)
    scene = end.scene.with_overrides(f"time.dt={float(dt)!r}", f"time.end_time={end_time!r}",
                                     "output.progress=false")
    sim = Simulation(scene, MPI.COMM_SELF, initial_state=(u, v, a))
    sim.proceed()
    rec = sim.recorder.arrays()
    t = rec["t"]
    window = end_time / 3.0
    sel = t >= t[-1] - window
    w = analyse(t[sel], rec["theta"], rec["u_r"][sel], rec["u_theta"][sel], rec["status"][sel],
                d=scene.geometry.d, radius=scene.geometry.R, window=window)
    return {"dt_s": dt, "k": w.mode, "celerity_m_s": w.celerity_m_s,
            "amplitude_m": w.amplitude_m, "status": sim.stop_reason}


def extrapolate(c: list[float]) -> tuple[float, float | None]:
    """(limit, order) from three values at steps halving (the finest if no asymptotic range)."""
    ratio = (c[0] - c[1]) / (c[1] - c[2]) if c[1] != c[2] else 0.0
    if ratio <= 1.0:
        return c[2], None
    p = math.log2(ratio)
    return c[2] + (c[2] - c[1]) / (2.0**p - 1.0), p


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", type=Path, nargs="+")
    ap.add_argument("--end-time", type=float, default=0.1)
    a = ap.parse_args()
    from stickslip.studies.travel.from_run import matched_samples, read_end_state, wave_from_run

    for run in a.runs:
        w = wave_from_run(run, dt_limit=True)
        if w.get("dt_limit") is None:
            raise SystemExit(f"{run}: {w.get('dt_limit_message') or w.get('message')}")
        end = read_end_state(run)
        s = matched_samples(end.node_passage, end.dt)
        tr = [{"dt_s": end.dt, "k": end.k, "celerity_m_s": end.summary["celerity_m_s"],
               "amplitude_m": end.summary["amplitude_m"], "status": "run"}]
        waves = nested_waves(end, s)
        tr += [transient_on(end, *waves[j], end.dt / f, a.end_time)
               for j, f in ((1, 2), (2, 4))]
        c_lim, p = extrapolate([x["celerity_m_s"] for x in tr])
        a_lim, _ = extrapolate([x["amplitude_m"] for x in tr])
        lim = w["dt_limit"]
        print(json.dumps({
            "run": str(run), "k": end.k, "S": s, "transients": tr,
            "transient_limit": {"celerity_m_s": c_lim, "amplitude_m": a_lim, "order": p},
            "travel_limit": {key: lim[key] for key in ("celerity_m_s", "amplitude_m", "order")},
            "travel_levels": lim["levels"],
            "difference": {"celerity_rel": lim["celerity_m_s"] / c_lim - 1.0,
                           "amplitude_rel": lim["amplitude_m"] / a_lim - 1.0},
            "run_dt_error": lim["run_dt_error"]}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
