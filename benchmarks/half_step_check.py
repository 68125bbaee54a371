"""Is a census member's companion the time step's? Each multi-wave member's first start,
restarted where its checkpoint stands at half its time step, against the member: the
census's ``--half-step`` test (``studies.attractors.step_check``) on a finished census.

    ./dev python3 benchmarks/half_step_check.py CENSUS_DIR [--windows 4] [--json FILE]

For every multi-wave member of ``attractors.json`` (two or more components), its first start's
checkpoint (u, v~) is the initial state (u_0, v_0) of the same scene at half its step
(``time.dt_fraction`` / 2, or ``time.dt`` / 2), run alone on this rank for ``--windows``
census windows W. The features of the last window (``features.window_features``) are
compared with the member's (``features.differences``, the census's tolerances): the member
is **kept** when they match; otherwise the differences say what moved, and the components
at Δt/2 what it became. Taking v~ for v_0 is an O(Δt) perturbation of the velocity, the
size of a kick test's: a member that is an attractor of the finer scheme returns from it.
A companion that vanishes at Δt/2 is the step's (docs/attractors.md, "The time step is a
rung too"). Cost at N = 132 and W = 0.1 s: about 10 s a member on one core.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from stickslip.studies.attractors.features import (
    DEFAULT_TOLERANCES,
    components_text,
    differences,
    window_features,
)
from stickslip.studies.attractors.statistics import member_features
from stickslip.studies.attractors.step_check import half_step_run


def first_start(answer: dict, member: dict, n_text: str) -> Path:
    """The run directory of the member's start with the lowest seed on mesh ``n_text``."""
    seed = min(member["seeds"])
    start = next(s for s in answer["starts"] if s["member"] == member["member"]
                 and s["seed"] == seed and str(s["n_inner"]) == n_text)
    return Path(start["run_dir"])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("census", type=Path, help="a census directory (stickslip attractors -o)")
    ap.add_argument("--windows", type=int, default=4, help="census windows W at Δt/2")
    ap.add_argument("--json", type=Path, help="write every row here")
    args = ap.parse_args(argv)
    answer = json.loads((args.census / "attractors.json").read_text())
    window = float(json.loads((args.census / "census.json").read_text())["window_s"])
    rows = []
    for n_text, members in answer["members"].items():
        for member in members:
            if member["class"] != "multi-wave" or not member.get("seeds"):
                continue
            t0 = time.perf_counter()
            run = half_step_run(first_start(answer, member, n_text), args.windows, window)
            samples = run["samples"]
            t_end = float(samples["t"][-1])
            after = window_features(samples, run["radius"], t_end - window, t_end)
            why = differences(member_features(member), after, DEFAULT_TOLERANCES)
            row = {"N": n_text, "member": member["member"], "starts": member["count"],
                   "kept": not why, "differences": why, "dt_s": run["dt_s"],
                   "components_at_half_step": components_text(after.components),
                   "wall_s": time.perf_counter() - t0}
            rows.append(row)
            print(f"N = {n_text} {member['member']} ({member['count']} starts): "
                  f"{'kept' if not why else 'moved: ' + '; '.join(why)}; at Δt/2 = "
                  f"{run['dt_s']:.4g} s: {row['components_at_half_step']} "
                  f"({row['wall_s']:.0f} s)", flush=True)
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
