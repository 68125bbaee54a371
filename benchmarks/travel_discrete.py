"""The transient's own discrete travelling wave, solved directly: ladders in Δt and in N
(``studies.travel.frame``, "Samples" and the central time scheme).

``./dev nice python3 benchmarks/travel_discrete.py SCENE --k 4 --level N:S[:RUN_DIR] ...
[--set key=value ...] [--out FILE.jsonl]``

Each ``--level`` is one wave: the scene on ``mesh.n_inner=N`` with S contact points per node
(the time step h = Δφ/(S|ω|) of the explicit central-difference scheme, β₂ = 1/2, and its
first-order contact law), solved by the semismooth Newton with free ω (``driver.solve_free``:
``newton.solve_wave`` on one wavelength when k divides N·S).
Its start is the probe history of RUN_DIR (a finished ``stickslip run`` of that mesh,
``driver.probe_history``) or, without RUN_DIR, the previous level's wave carried to the new
points (``driver.prolong``: nested iteration in N or S).

One JSON line per level: N, S, the step h and the node passage τ = S·h, celerity, amplitude,
sub-node ψ₁ and ψ₂, the residual, iterations, the smallest inequality margin, CPU; with
RUN_DIR the run's own celerity (``postprocess.analysis.analyse_run``) and time step. A level
that fails is a line with its error; the exit status is 1 if any level failed. After three or
more levels of one S (an N ladder) or one N (an S ladder), the observed order of the celerity
from the last three, p = log2(|c₁ − c₂| / |c₂ − c₃|) (levels in the order given, each
refining the last by 2).
``--out`` gets the same lines, also after Ctrl-C (the levels finished; exit 130).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np


def _level(text: str) -> tuple[int, int, Path | None]:
    parts = text.split(":", 2)
    try:
        n, s = int(parts[0]), int(parts[1])
    except (ValueError, IndexError):
        raise argparse.ArgumentTypeError(f"--level {text!r}: expected N:S[:RUN_DIR] with whole "
                                         "numbers N (contact nodes) and S (points per node)"
                                         ) from None
    if n < 4 or s < 1:
        raise argparse.ArgumentTypeError(f"--level {text!r}: need N >= 4 and S >= 1")
    run = Path(parts[2]) if len(parts) == 3 else None
    if run is not None and not (run / "samples.npz").is_file():
        raise argparse.ArgumentTypeError(f"--level {text!r}: {run} holds no samples.npz (give "
                                         "a finished `stickslip run` directory)")
    return n, s, run


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", type=Path)
    ap.add_argument("--k", type=int, required=True)
    ap.add_argument("--level", type=_level, action="append", required=True,
                    metavar="N:S[:RUN_DIR]")
    ap.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--max-iter", type=int, default=40)
    ap.add_argument("--out", type=Path)
    a = ap.parse_args()
    if a.level[0][2] is None:
        ap.error("the first --level needs a RUN_DIR to start from (N:S:RUN_DIR)")
    if a.k < 1:
        ap.error(f"--k {a.k}: the wavenumber must be >= 1")

    from stickslip.solver.scene import SceneError, load_scene

    try:
        base = load_scene(a.scene, a.overrides)
    except (SceneError, FileNotFoundError) as err:
        ap.error(f"{a.scene}: {err}")
    rows: list[dict] = []
    wave, failed = None, False
    try:
        for n, s, run in a.level:
            row, solved = _solve(base, a, n, s, run, wave)
            failed |= solved is None
            wave = solved or wave
            rows.append(row)
            print(json.dumps(row), flush=True)
    except KeyboardInterrupt:
        _write(a.out, rows)
        print(f"travel_discrete: interrupted after {len(rows)} of {len(a.level)} levels; the "
              "lines above are complete" + (f" and in {a.out}" if a.out else ""),
              file=sys.stderr)
        return 130
    order = _order(rows)
    if order is not None:
        rows.append({"observed_order": order})
        print(json.dumps(rows[-1]), flush=True)
    _write(a.out, rows)
    return 1 if failed else 0


def _write(out: Path | None, rows: list[dict]) -> None:
    """The finished lines to ``out`` (atomic: a complete file or the old one)."""
    if out and rows:
        from stickslip.solver.atomic import atomic_write_text

        atomic_write_text(out, "".join(json.dumps(r) + "\n" for r in rows))


def _solve(base, a: argparse.Namespace, n: int, s: int, run: Path | None,
           previous: tuple[np.ndarray, float] | None) -> tuple[dict, tuple | None]:
    """One level (module doc): its row, and its wave (W, ω) for the next level (None if the
    Newton failed)."""
    from stickslip.studies.travel import driver as D
    from stickslip.studies.travel.newton import NotConverged

    t0 = time.process_time()
    scene = base.with_overrides(f"mesh.n_inner={n}")
    row: dict = {"N": n, "S": s, "start": "run" if run else "previous level"}
    st = D.setup(scene, float(scene.damping.tau), rate="bdf1", inertia="shift", samples=s,
                 time_scheme="central")
    R = scene.geometry.R
    if run is not None:
        W0, om0, info = D.start_from_run(run, st)
        row.update(run=str(run), run_celerity_m_s=info["start_celerity_m_s"],
                   run_start=info["start"], run_dt_s=_run_dt(run))
    else:
        W0, om0 = D.prolong(previous[0], st.prob.n), previous[1]
    try:
        sol = D.solve_free(st, a.k, W0, om0, max_iter=a.max_iter)  # one wavelength if k | N·S
    except NotConverged as err:
        row.update(error=str(err), cpu_s=round(time.process_time() - t0, 1))
        return row, None
    summary, _ = D.measure(st, sol, a.k)
    h = st.ops.step(sol.omega)
    row.update(celerity_m_s=sol.omega * R, amplitude_mm=summary["amplitude_m"] * 1e3,
               psi1=summary["psi1_subnode"], psi2=summary["psi2_subnode"], h_s=h,
               passage_s=h * s, residual=sol.residual, iterations=sol.iterations,
               violated=sol.violated, min_margin=min(sol.margins.values()),
               cpu_s=round(time.process_time() - t0, 1))
    return row, (np.r_[sol.W_r, sol.W_t], sol.omega)


def _run_dt(run: Path) -> float | None:
    t = np.load(run / "samples.npz")["probe_t"]
    return float(t[1] - t[0]) if t.size > 1 else None


def _order(rows: list[dict]) -> float | None:
    """p from the last three converged levels' celerities (module doc), or None if they are
    not a ladder: one S with N doubling, or one N with S doubling."""
    last = [r for r in rows if "celerity_m_s" in r][-3:]
    if len(last) < 3:
        return None
    n, s = [r["N"] for r in last], [r["S"] for r in last]
    halving = (len(set(s)) == 1 and n[1] == 2 * n[0] and n[2] == 2 * n[1]) or (
        len(set(n)) == 1 and s[1] == 2 * s[0] and s[2] == 2 * s[1])
    c = [r["celerity_m_s"] for r in last]
    if not halving or c[1] == c[2]:
        return None
    return math.log2(abs(c[0] - c[1]) / abs(c[1] - c[2]))


if __name__ == "__main__":
    raise SystemExit(main())
