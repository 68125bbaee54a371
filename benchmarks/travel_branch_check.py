"""A branch of the default route against transients started next to it.

``./dev nice python3 benchmarks/travel_branch_check.py RUN_DIR KEY=A:B:N [--check 5]
[--end-time 0.05]``

The wave of RUN_DIR (``studies.travel.from_run``: the transient's own discrete wave at the
run's matched step S) is followed over the N values of KEY (natural parameter, each point
from the last, S held), as ``stickslip travel --from RUN_DIR --continue KEY=A:B:N`` does.
At ``--check`` points spread over the branch, the transient of that point's scene is started
next to the wave (``from_run.transient_next_to``: the wave plus a 0.02 d bump, dt = h) and
run for ``--end-time`` s. One JSON line per checked point: the value, the wave's celerity and
amplitude, the transient's last window, ``stable`` and the drift.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run", type=Path)
    ap.add_argument("branch", metavar="KEY=A:B:N")
    ap.add_argument("--check", type=int, default=5)
    ap.add_argument("--end-time", type=float, default=0.05)
    a = ap.parse_args()
    from stickslip.cli.travel import parse_continue
    from stickslip.studies.travel import driver as D
    from stickslip.studies.travel.from_run import read_end_state, solve_matched, transient_next_to

    key, values = parse_continue(a.branch)
    end = read_end_state(a.run)
    st, sol, _ = solve_matched(end)
    checks = set(np.linspace(0, len(values) - 1, a.check).round().astype(int).tolist())
    W, om, failed = np.r_[sol.W_r, sol.W_t], sol.omega, 0
    for i, val in enumerate(values):
        sc = end.scene.with_overrides(f"{key}={val!r}")
        st = D.retarget(st, sc) if key.startswith(("loading.", "geometry.delta")) else D.setup(
            sc, float(sc.damping.tau), rate="bdf1", inertia="shift", samples=st.ops.samples,
            time_scheme="central")
        sol = D.solve_free(st, end.k, W, om, max_iter=40)
        W, om = np.r_[sol.W_r, sol.W_t], sol.omega
        if i in checks:
            row = {"key": key, "value": val} | transient_next_to(st, sol, end.k,
                                                                 end_time=a.end_time)
            failed += not row["stable"]
            print(json.dumps(row, default=float), flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
