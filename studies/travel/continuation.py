"""Natural-parameter continuation of a travelling wave in any scene key (``--continue``).

Each value is one Newton solve started from the previous wave (the first from the usual
start). Loading and mismatch keys (``loading.*``, ``geometry.delta``) reuse the condensed
operators (K and G do not depend on them); any other key rebuilds the problem. Where a solve
fails after two converged points, in Ω, f or δ, the branch is followed on by pseudo-arclength
(``studies.travel.arclength``: λ an unknown, steps along the branch's secant), which turns
around a fold; a fold (λ changes sense) is reported with its value. The branch ends where a
solve fails: the row names the last residual and the inequality that failed, and no wave is
reported there.

A converged solve is not always on the branch: Newton (or the fixed-speed search for the
nearest admissible speed) may land on another wave of the same k. A point is a jump
(``jump``) when a measure of its wave (celerity, amplitude, ψ₁, ψ₂) moves away from the
secant prediction through the two converged points before it by more than its bound
(``JUMP_BOUNDS``) and by more than ``JUMP_TREND`` times the change the branch's own trend
predicts for the step. Its row gets ``status`` "jumped" (not converged; the wave's values
are kept, ``violated`` says which measure jumped) with a one-line warning, and the branch
stops there: the points after it would follow the other wave, not the branch. More points
over the range (a finer step) may follow the branch further, or show that it ends there.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from stickslip.solver.scene import Scene
from stickslip.studies.travel import driver as D
from stickslip.studies.travel.arclength import (
    ARCLENGTH_KEYS,
    arclength_step,
    phase_row_of,
    problem_at,
)
from stickslip.studies.travel.command import celerity_note
from stickslip.studies.travel.newton import NotConverged, fold_state, unfold
from stickslip.studies.travel.output import plot_branch, shown, write_branch

__all__ = ["JUMP_BOUNDS", "REUSE_KEYS", "jump", "run_continuation"]

REUSE_KEYS = ("loading.omega", "loading.f", "geometry.delta")

#: The most a measure may move from the secant prediction in one step of a branch, in its
#: unit: celerity and amplitude relative to the last point's (the waves of a branch move
#: their speed by 0.25 % steps of the fixed-speed search, so 1 % is four of them; an
#: amplitude follows the key smoothly), ψ₁ and ψ₂ in fractions of the wavelength (a zone
#: boundary that moves a fifth of a wavelength in one step belongs to another wave).
JUMP_BOUNDS = {"celerity_m_s": 0.01, "amplitude_m": 0.25, "psi1_subnode": 0.2,
               "psi2_subnode": 0.2}
#: Of those, the measures compared relative to the last point's value.
RELATIVE = ("celerity_m_s", "amplitude_m")
#: A move is a jump only when it is also this many times the change the trend predicts for
#: the step (a branch that changes fast everywhere is no jump).
JUMP_TREND = 3.0
#: The measures a branch row carries for a converged wave.
MEASURES = ("celerity_m_s", "amplitude_m", "psi1", "psi2", "psi1_subnode", "psi2_subnode",
            "regime", "residual")


def jump(before: list[dict], row: dict, by_index: bool = False) -> str | None:
    """Why the converged ``row`` is not on the branch of the converged rows ``before`` (the
    measure, how far it moved, against what; one phrase), or None (module doc). The
    prediction is the secant through the last two rows in the key's value (``by_index``: in
    the step count, for pseudo-arclength steps, whose value may turn at a fold); with one
    row before, the last value and its bound only."""
    if not before:
        return None
    last = before[-1]
    prev = before[-2] if len(before) >= 2 else None
    ratio = 0.0
    if prev is not None:
        ratio = 1.0
        if not by_index and last["value"] != prev["value"]:
            ratio = (row["value"] - last["value"]) / (last["value"] - prev["value"])
    for name, bound in JUMP_BOUNDS.items():
        q, q1 = row[name], last[name]
        trend = 0.0 if prev is None else (q1 - prev[name]) * ratio
        scale = abs(q1) if name in RELATIVE and q1 else 1.0
        moved, expected = abs(q - (q1 + trend)) / scale, abs(trend) / scale
        if moved > bound and moved > JUMP_TREND * expected:
            size = f"{100 * moved:.1f} %" if name in RELATIVE else f"{moved:.3f}"
            return (f"{name} {q:.4g} moved {size} from the branch's prediction "
                    f"{q1 + trend:.4g} (bound {100 * bound if name in RELATIVE else bound:g}"
                    f"{' %' if name in RELATIVE else ''})")
    return None


def _mark_jump(rows: list[dict], row: dict, key: str, by_index: bool = False) -> bool:
    """Mark the converged ``row`` "jumped" when ``jump`` says so against the converged rows
    before it in ``rows``, with its one-line warning; True if it jumped."""
    why = jump([r for r in rows if r["status"] == "converged"], row, by_index)
    if why is None:
        return False
    last = next(r for r in reversed(rows) if r["status"] == "converged")
    row.update(status="jumped", violated=f"jumped to another wave: {why}")
    print(f"warning: {key} = {row['value']:g} jumped to another wave ({why}): marked "
          f"jumped, not converged; the branch stops after {key} = {last['value']:g} (more "
          "points over the range may follow it further)")
    return True


def _arclength(st, k: int, key: str, last: list, values: list[float], rows: list[dict]
               ) -> None:
    """Follow the branch from its last two waves by pseudo-arclength (module doc), at most
    as many steps as ``values``, until λ leaves their range or a step fails; one row per
    wave (``arclength``: true; ``fold``: true where λ turned)."""
    R = st.scene.geometry.R
    prob0 = D.folded(st, k).prob
    period = prob0.period
    x = [np.r_[fold_state(W, period), om, lam] for lam, W, om in last]
    n = prob0.n
    scale = np.r_[np.full(2 * n, prob0.d), abs(x[1][2 * n]), abs(x[1][-1])]
    tangent = (x[1] - x[0]) / scale
    ds = float(np.linalg.norm(tangent))
    tangent /= ds
    phase_row = phase_row_of(x[1][n: 2 * n], prob0.theta, k)
    lo, hi = min(values), max(values)
    sense = np.sign(x[1][-1] - x[0][-1])
    x_now = x[1]
    print(f"{key}: pseudo-arclength from {key} = {x_now[-1]:g}")
    for _ in range(len(values)):
        try:
            x_new, sol = arclength_step(lambda lam: problem_at(prob0, key, lam, R), k, x_now,
                                        tangent, ds, scale, phase_row)
        except NotConverged as err:
            rows.append({"value": None, "status": "failed", "arclength": True,
                         "residual": err.info.get("residual"),
                         "violated": err.info.get("violated") or str(err)})
            print(f"branch ends after {key} = {x_now[-1]:g}: {err}")
            return
        lam = float(x_new[-1])
        fold = bool(np.sign(lam - x_now[-1]) != sense)
        if fold:
            sense = -sense
            print(f"fold near {key} = {x_now[-1]:g}: the branch turns back")
        summ, _ = D.measure(D.retarget(st, st.scene.with_overrides(f"{key}={lam!r}")),
                            unfold(sol, period), k)
        row = {"value": lam, "status": "converged", "arclength": True, "fold": fold,
               **{q: summ[q] for q in MEASURES}, "violated": None}
        jumped = _mark_jump(rows, row, key, by_index=True)
        rows.append(row)
        if jumped:
            return
        print(f"{key} = {lam:g} (arclength): {summ['celerity_m_s']:.1f} m/s, amplitude "
              f"{summ['amplitude_m']:.3g} m" + (" [fold passed]" if fold else ""))
        tangent = (x_new - x_now) / scale
        tangent /= float(np.linalg.norm(tangent))
        x_now = x_new
        if not lo - 1e-9 * abs(hi) <= lam <= hi + 1e-9 * abs(hi):
            return


def run_continuation(scene: Scene, args: argparse.Namespace, key: str, values: list[float],
                     out: Path, t0: float) -> int:
    """Follow the branch; write branch.json/csv (+ branch.png); exit 0 if any point solved.
    Interrupted (Ctrl-C), it writes the points solved so far and re-raises."""
    rows: list[dict] = []
    try:
        _follow(scene, args, key, values, rows)
    except KeyboardInterrupt as stop:  # keep the points already solved; exit 130 (cli.main)
        if not rows:
            raise
        write_branch(out, rows)
        raise KeyboardInterrupt(f"after {len(rows)} of {len(values)} points; those are in "
                                f"{shown(out) / 'branch.json'}") from stop
    write_branch(out, rows)
    if args.plot:
        print(f"figure: {shown(plot_branch(out, rows, key))}")
    ok = sum(r["status"] == "converged" for r in rows)
    print(f"{ok}/{len(rows)} points converged -> {shown(out)}  "
          f"({time.perf_counter() - t0:.1f} s)")
    if ok == 0:
        print("error: no point of the branch converged", file=sys.stderr)
        return 1
    return 0


def _follow(scene: Scene, args: argparse.Namespace, key: str, values: list[float],
            rows: list[dict]) -> None:
    """Solve each point from the last converged one, appending a row per point to ``rows``."""
    st = None
    W, om = None, None
    waves: list[tuple[float, np.ndarray, float]] = []  # (λ, W, ω) of the converged points
    for val in values:
        sc = scene.with_overrides(f"{key}={val}")
        row: dict = {"value": val}
        try:
            if st is None or key not in REUSE_KEYS:
                st = D.setup(sc, args.damping, rate=args.rate, inertia=args.inertia,
                             samples=args.samples, time_scheme=args.time_scheme)
            else:
                st = D.retarget(st, sc)
            if W is None:
                if args.from_run:
                    W, om, _ = D.start_from_run(Path(args.from_run), st)
                else:
                    W, om, _ = D.start_from_reduced(st, args.k)
                if getattr(args, "celerity", None) is not None:
                    om = args.celerity / sc.geometry.R
            start = om * sc.geometry.R
            sol = D.solve_scene(st, args.k, W, om, max_iter=args.max_iter,
                                free_omega=not args.fixed_omega)
            summ, _ = D.measure(st, sol, args.k)
            row.update(status="converged", **{k: summ[k] for k in MEASURES}, violated=None)
        except NotConverged as err:
            row.update(status="failed", residual=err.info.get("residual"),
                       violated=err.info.get("violated") or str(err))
        except ValueError as err:
            row.update(status="error", violated=str(err))
        if row["status"] == "converged" and _mark_jump(rows, row, key):
            rows.append(row)
            return
        rows.append(row)
        print(f"{key} = {val:g}: {row['status']}"
              + (f", {row['celerity_m_s']:.1f} m/s, amplitude {row['amplitude_m']:.3g} m"
                 if row["status"] == "converged" else f" ({row.get('violated')})"))
        if row["status"] == "converged":
            if not waves and (note := celerity_note(start, summ["celerity_m_s"],
                                                    summ["solve"])):
                print(f"note: {note}")
            W = np.concatenate([sol.W_r, sol.W_t])
            om = sol.omega
            waves.append((val, W, om))
        if row["status"] != "converged" and rows[:-1] and rows[-2]["status"] == "converged":
            print(f"branch lost between {key} = {rows[-2]['value']:g} and {val:g}: "
                  f"{row.get('violated')}")
            if key in ARCLENGTH_KEYS and len(waves) >= 2:
                _arclength(st, args.k, key, waves[-2:], values, rows)
                return
