"""Natural-parameter continuation of a travelling wave in any scene key (``--continue``).

Each value is one Newton solve started from the previous wave (the first from the usual
start). Loading and mismatch keys (``loading.*``, ``geometry.delta``) reuse the condensed
operators (K and G do not depend on them); any other key rebuilds the problem. The branch
ends where a solve fails: the row names the last residual and the inequality that failed,
and no wave is reported there.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from solver.scene import Scene

__all__ = ["run_continuation", "REUSE_KEYS"]

REUSE_KEYS = ("loading.omega", "loading.f", "geometry.delta")


def run_continuation(scene: Scene, args: argparse.Namespace, key: str, values: list[float],
                     out: Path, t0: float) -> int:
    """Follow the branch; write branch.json/csv (+ branch.png); exit 0 if any point solved.
    Interrupted (Ctrl-C), it writes the points solved so far and re-raises."""
    from studies.travel.output import plot_branch, write_branch

    rows: list[dict] = []
    try:
        _follow(scene, args, key, values, rows)
    except KeyboardInterrupt as stop:  # keep the points already solved; exit 130 (cli.main)
        if not rows:
            raise
        write_branch(out, rows)
        raise KeyboardInterrupt(f"after {len(rows)} of {len(values)} points; those are in "
                                f"{out / 'branch.json'}") from stop
    write_branch(out, rows)
    if args.plot:
        print(f"figure: {plot_branch(out, rows, key)}")
    ok = sum(r["status"] == "converged" for r in rows)
    print(f"{ok}/{len(rows)} points converged -> {out}  ({time.perf_counter() - t0:.1f} s)")
    if ok == 0:
        print("error: no point of the branch converged", file=sys.stderr)
        return 1
    return 0


def _follow(scene: Scene, args: argparse.Namespace, key: str, values: list[float],
            rows: list[dict]) -> None:
    """Solve each point from the last converged one, appending a row per point to ``rows``."""
    from studies.travel import driver as D
    from studies.travel.newton import NotConverged

    st = None
    W, om = None, None
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
            sol = D.solve_scene(st, args.k, W, om, max_iter=args.max_iter,
                                free_omega=not args.fixed_omega)
            summ, _ = D.measure(st, sol, args.k)
            row.update(status="converged", **{k: summ[k] for k in (
                "celerity_m_s", "amplitude_m", "psi1", "psi2", "psi1_subnode", "psi2_subnode",
                "regime", "residual")}, violated=None)
            W = np.concatenate([sol.W_r, sol.W_t])
            om = sol.omega
        except NotConverged as err:
            row.update(status="failed", residual=err.info.get("residual"),
                       violated=err.info.get("violated") or str(err))
        except ValueError as err:
            row.update(status="error", violated=str(err))
        rows.append(row)
        print(f"{key} = {val:g}: {row['status']}"
              + (f", {row['celerity_m_s']:.1f} m/s, amplitude {row['amplitude_m']:.3g} m"
                 if row["status"] == "converged" else f" ({row.get('violated')})"))
        if row["status"] != "converged" and rows[:-1] and rows[-2]["status"] == "converged":
            print(f"branch lost between {key} = {rows[-2]['value']:g} and {val:g}: "
                  f"{row.get('violated')}")
