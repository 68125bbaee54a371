"""Is a travelling wave an attractor? The transient started next to it.

``./dev nice python3 benchmarks/travel_wave_seeds.py WAVE.npz [WAVE.npz ...] [--eps 0.02]
[--end-time 0.2] [--window 0.025] [--out FILE.jsonl]``

WAVE.npz: a central-scheme wave saved by ``benchmarks/travel_family.py --time-scheme central``
(scene name, k, samples S, ω, W on the N·S contact points). Its whole-mesh state
(``FrameOperators.shift_state``) is a periodic orbit of the transient at dt = h = Δφ/(S|ω|)
(``tests/test_travel_fe.py``). The transient of the scene is started on it, with dt = h and
a radial bump eps·d·mean_m cos(mθ + 2πm/12), m = 1 … 12, added (through the tube's radial
profile, ``TubeProblem.radial_field``, as the scene's ``[initial]`` bump), and measured over
consecutive windows (``travel_member_seeds.analyse_windows``). A wave that the transient
keeps (same mode and speed in the last window) is stable to that perturbation; one that it
leaves is not an attractor, and the last window names the wave it goes to.

One JSON line per wave: the wave (k, speed, amplitude), dt, and the windows; ``--out``
gets them appended, also after Ctrl-C (the waves finished; exit 130). Exit status 1 if a
transient stopped before ``--end-time``.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("waves", type=Path, nargs="+")
    ap.add_argument("--eps", type=float, default=0.02, help="bump amplitude / d")
    ap.add_argument("--end-time", type=float, default=0.2)
    ap.add_argument("--window", type=float, default=0.025)
    ap.add_argument("--out", type=Path)
    a = ap.parse_args()
    if a.eps < 0.0 or a.end_time <= 0.0 or not 0.0 < a.window <= a.end_time:
        ap.error(f"--eps {a.eps} --end-time {a.end_time} --window {a.window}: need eps >= 0 "
                 "and 0 < window <= end-time")
    for w in a.waves:
        if not w.is_file():
            ap.error(f"{w}: no such wave file (run travel_family.py --time-scheme central)")
    lines: list[dict] = []
    try:
        for w in a.waves:
            lines.append(seed_next_to(w, a.eps, a.end_time, a.window))
            print(json.dumps(lines[-1]), flush=True)
    except KeyboardInterrupt:
        _append(a.out, lines)
        print(f"travel_wave_seeds: interrupted after {len(lines)} of {len(a.waves)} waves; the "
              "lines above are complete" + (f" and appended to {a.out}" if a.out else ""),
              file=sys.stderr)
        return 130
    _append(a.out, lines)
    return 1 if any(x["status"] != "end_time" for x in lines) else 0


def _append(out: Path | None, lines: list[dict]) -> None:
    """Append the finished lines to ``out`` (atomic: the old file plus them, or the old one)."""
    if out and lines:
        from stickslip.solver.atomic import atomic_write_text

        old = out.read_text() if out.exists() else ""
        atomic_write_text(out, old + "".join(json.dumps(x) + "\n" for x in lines))


def seed_next_to(path: Path, eps: float, end_time: float, window: float) -> dict:
    """The transient started on the wave of ``path`` plus the bump (module doc)."""
    from mpi4py import MPI
    from travel_member_seeds import analyse_windows  # benchmarks/ (this script's folder)

    from stickslip.solver.run import Simulation
    from stickslip.solver.scene import load_scene
    from stickslip.studies.travel import driver as D

    wave = np.load(path)
    scene = load_scene(f"scenes/{wave['scene']}.toml")
    k, omega = int(wave["k"]), float(wave["omega"])
    st = D.setup(scene, float(scene.damping.tau), rate="bdf1", inertia="shift",
                 samples=int(wave["samples"]), time_scheme="central")
    u, v, a = st.ops.shift_state(wave["W"], omega)
    d = scene.geometry.d
    modes = np.arange(1, 13)
    u = u + st.ops.problem.radial_field(
        lambda th: eps * d * np.cos(np.outer(th, modes) + 2.0 * math.pi * modes / 12.0).mean(1))
    h = st.ops.step(omega)
    run = scene.with_overrides(f"time.dt={h!r}", f"time.end_time={end_time}",
                               "output.progress=false")
    t0 = time.perf_counter()
    sim = Simulation(run, MPI.COMM_SELF, initial_state=(u, v, a))
    sim.proceed()
    R = scene.geometry.R
    return {"wave": str(path), "scene": str(wave["scene"]), "k": k,
            "start": str(wave["start"]), "c_m_s": round(omega * R, 3),
            "amplitude_mm": round(1e3 * float(wave["W"][: st.ops.n].max() - d), 3),
            "eps": eps, "dt_s": h, "status": sim.stop_reason,
            "wall_s": round(time.perf_counter() - t0, 1),
            "windows": analyse_windows(sim.recorder.arrays(), scene, window)}


if __name__ == "__main__":
    sys.exit(main())
