"""Is a census member's companion the time step's? Each multi-wave member's first start,
restarted where its checkpoint stands at half its time step, against the member: the
census's ``--half-step`` test (``studies.attractors.step_check``) on a finished census.

    ./dev python3 benchmarks/half_step_check.py CENSUS_DIR [--json FILE]

For every multi-wave member of ``attractors.json`` (two or more components), its first start's
checkpoint (u, v~) is the initial state (u_0, v_0) of the same scene at half its step
(``time.dt_fraction`` / 2, or ``time.dt`` / 2), run alone on this rank for
``HALF_STEP_WINDOWS`` census windows W (``step_check.half_step_members``). The features of
the last window are compared with the start's own (``features.differences``, the census's
tolerances): the member is **kept** when they match; otherwise the differences say what
moved, and the components at Δt/2 what it became. Taking v~ for v_0 is an O(Δt)
perturbation of the velocity, the size of a kick test's: a member that is an attractor of
the finer scheme returns from it.
A companion that vanishes at Δt/2 is the step's (docs/attractors.md, "The time step is a
rung too"). Cost at N = 132 and W = 0.1 s: 1 – 2 s a member on one core (P's census).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from stickslip.studies.attractors.census import settled_members
from stickslip.studies.attractors.features import DEFAULT_TOLERANCES
from stickslip.studies.attractors.step_check import half_step_members


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("census", type=Path, help="a census directory (stickslip attractors -o)")
    ap.add_argument("--json", type=Path, help="write every row here")
    args = ap.parse_args(argv)
    answer = json.loads((args.census / "attractors.json").read_text())
    window = float(json.loads((args.census / "census.json").read_text())["window_s"])
    groups = {f"{n}:{member}": rows
              for (n, member), rows in settled_members(answer["starts"]).items()
              if rows[0]["class"] == "multi-wave"}
    rows = []
    for key, rows_of_key in groups.items():
        t0 = time.perf_counter()
        result = half_step_members({key: rows_of_key}, window, DEFAULT_TOLERANCES)[key]
        row = {"member": key, "starts": len(rows_of_key), **result,
               "wall_s": time.perf_counter() - t0}
        rows.append(row)
        verdict = ("kept" if result.get("kept") else
                   "moved: " + "; ".join(result["differences"]) if "kept" in result
                   else result["message"])
        print(f"{key} ({row['starts']} starts): {verdict}; at Δt/2 = "
              f"{result.get('dt_s', float('nan')):.4g} s: {result.get('components', '')} "
              f"({row['wall_s']:.0f} s)", flush=True)
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
