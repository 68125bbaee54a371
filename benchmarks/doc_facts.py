"""The numbers that README.md and the tutorial quote, regenerated into docs/facts/*.json.

    ./dev python3 benchmarks/doc_facts.py census DIR   # DIR: the tutorial's census directory
    ./dev python3 benchmarks/doc_facts.py timings [--repeat 2] [--only KEY] [--skip KEY]
    ./dev python3 benchmarks/doc_facts.py estimates    # after a change of the cost model

``census`` reads DIR/attractors.json of the tutorial's census (the command is
``CENSUS_COMMAND`` with ``-o DIR``; a few minutes under ``mpirun -n 2`` on a 2-core machine)
and writes ``docs/facts/tutorial_census.json``: per mesh the time step, the counted starts,
the number of attractors and each member's class, wavenumber, direction, count, celerity,
frequency, settle times and certified stability. It reads the census's answer file, not its
printed report, so a change of the report's wording changes nothing here.

``timings`` runs every command whose time a page states (``TIMED``) ``--repeat`` times on this
machine and keeps the lowest (the machine may be shared: the lowest is the closest to a clean
run), and writes ``docs/facts/timings.json``: per command the seconds of each repetition, and
for the ``stickslip run`` cases also the run's own wall time and the pre-run estimate
(``studies.resources``) beside it. ``--only``/``--skip`` (repeatable) regenerate a part and keep
the rest of the file.

``estimates`` recomputes the pre-run estimates of timings.json's ``stickslip run`` cases with
the cost model as it is now, beside the measured wall times (nothing runs).

``tests/test_tutorial_numbers.py`` checks that every page quotes these files, and recomputes
what is cheap (the scene values, the first run's printed lines).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from stickslip.studies.attractors.statistics import ATTRACTING, UNFINISHED

REPO = Path(__file__).resolve().parents[1]
FACTS = REPO / "docs" / "facts"
CENSUS_FACTS = FACTS / "tutorial_census.json"
TIMING_FACTS = FACTS / "timings.json"

#: The tutorial's census (README, docs/tutorial/attractors.md).
CENSUS_COMMAND = ("mpirun -n 2 stickslip attractors scenes/figure1_n132_damped.toml "
                  "--starts 16 --meshes 132,264")
#: The rungs of that command: a census directory that holds more (a ladder run into it
#: later) gives the facts of these only.
CENSUS_MESHES = CENSUS_COMMAND.rsplit("--meshes ", 1)[1].split(",")

_DAMPED = "scenes/figure3_n132_damped.toml"
#: Every timed command: key -> (the command's arguments after ``stickslip``, what is timed:
#: ``process`` = the whole command as a user runs it, ``run`` = the run's own ``wall`` line
#: (``summary.json``'s ``wall_time_s``), which the pre-run estimate predicts), ranks.
TIMED = {
    "main_job": (["run", "scenes/figure3_n132.toml", "--force", "--plot"], "process", 1),
    "figure3_n132": (["run", "scenes/figure3_n132.toml", "--force"], "run", 1),
    "figure3_n264": (["run", "scenes/figure3_n132.toml", "--set", "mesh.n_inner=264",
                      "--force"], "run", 1),
    "damped_n132": (["run", _DAMPED, "--force"], "run", 1),
    "damped_n264": (["run", _DAMPED, "--set", "mesh.n_inner=264", "--force"], "run", 1),
    "damped_n264_dt045": (["run", _DAMPED, "--set", "mesh.n_inner=264",
                           "--set", "time.dt_fraction=0.45", "--force"], "run", 1),
    "damped_n528": (["run", _DAMPED, "--set", "mesh.n_inner=528", "--force"], "run", 1),
    "damped_n1056": (["run", _DAMPED, "--set", "mesh.n_inner=1056", "--force"], "run", 1),
    "travel_k4": (["travel", "scenes/figure1_n132_damped.toml", "--set", "mesh.n_inner=36",
                   "--k", "4", "--celerity", "-2300", "--fixed-omega"], "process", 1),
    "regime_map": (["sweep", "sweeps/omega_delta_damped.toml", "--plot"], "process", 2),
}


# ------------------------------------------------------------------------------- census

def census_facts(answer: dict) -> dict:
    """The tutorial census's numbers from its ``attractors.json`` (see the module docstring)."""
    certificates = answer.get("certificates") or {}
    rows = answer["starts"]
    meshes, counts, finished = {}, {}, not answer.get("stopped")
    for n, members in answer["members"].items():
        if n not in CENSUS_MESHES:
            continue
        mine = [r for r in rows if str(r["n_inner"]) == n and int(r.get("degree") or 1) == 1]
        for r in mine:
            counts[r["class"]] = counts.get(r["class"], 0) + 1
            finished = finished and r["class"] not in UNFINISHED
        dts = sorted({float(r["dt_s"]) for r in mine if r.get("dt_s")})
        out = []
        for m in members:
            settle = [float(r["settle_time_s"]) for r in mine
                      if r["member"] == m["member"] and r.get("settle_time_s") is not None
                      and math.isfinite(float(r["settle_time_s"]))]
            cert = certificates.get(f"{n}:{m['member']}")
            out.append({
                "member": m["member"], "class": m["class"], "name": m.get("name", ""),
                "k": m["k"], "direction": m["direction"], "count": m["count"],
                "celerity_m_s": _finite(m.get("celerity_m_s")),
                "frequency_hz": _finite(m.get("frequency_hz")),
                "settle_time_s_min": min(settle) if settle else None,
                "settle_time_s_max": max(settle) if settle else None,
                "stable": cert.get("stable") if isinstance(cert, dict) else None})
        counted = members[0]["starts"] if members else 0
        meshes[n] = {"dt_s": dts[0] if len(dts) == 1 else dts, "counted_starts": counted,
                     "attractors": sum(m["class"] in ATTRACTING for m in members),
                     "members": out}
    scene, starts = answer["scene"], answer.get("distribution") or {}
    return {"command": CENSUS_COMMAND, "scene": scene["name"],
            "finished": finished, "counts": counts,
            "starts": starts.get("starts"), "seed": starts.get("seed"),
            "first_leg_s": scene["time"]["end_time"], "max_time_s": answer.get("max_time_s"),
            "meshes": meshes}


def _finite(x: object) -> float | None:
    return float(x) if isinstance(x, (int, float)) and math.isfinite(x) else None


# ------------------------------------------------------------------------------ timings

def pre_run_estimate(args: list[str]):  # noqa: ANN201 - studies.resources.Estimate
    """The estimate ``stickslip run ARGS`` prints before meshing, unrounded."""
    from stickslip.solver.scene import load_scene
    from stickslip.studies.resources import estimate

    sets = [args[i + 1] for i, a in enumerate(args) if a == "--set"]
    return estimate(load_scene(args[1], sets))


def time_command(args: list[str], what: str, ranks: int, out: Path) -> dict:
    """One run of ``stickslip ARGS`` (output under ``out``): its seconds, and for a
    ``stickslip run`` the estimate line's numbers and the run's own wall time."""
    cmd = [sys.executable, "-m", "stickslip.cli.main", *args]
    if ranks > 1:
        cmd = ["mpirun", "-n", str(ranks), *cmd]
    if args[0] in ("run", "travel", "sweep"):
        cmd += ["-o", str(out)]
    load = os.getloadavg()[0]
    t0 = time.perf_counter()
    res = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True)
    process_s = time.perf_counter() - t0
    if res.returncode != 0:
        raise SystemExit(f"{' '.join(args)}: exit {res.returncode}\n{res.stderr[-2000:]}")
    rec = {"process_s": round(process_s, 2), "load_before": round(load, 2)}
    if args[0] == "run":
        summary = json.loads((out / "summary.json").read_text())
        rec["run_wall_s"] = round(summary["wall_time_s"], 2)
        rec["steps"], rec["dofs"] = summary.get("steps"), summary.get("dofs")
        rec["samples"], rec["profile_s"] = summary.get("samples"), summary.get("profile_s")
        est = pre_run_estimate(args)
        rec["estimate_steps"], rec["estimate_s"] = est.steps, round(est.seconds, 2)
        rec["estimate_ratio"] = round(est.seconds / summary["wall_time_s"], 3)
    rec["seconds"] = rec["run_wall_s"] if what == "run" else rec["process_s"]
    return rec


def timings(repeat: int, keys: list[str]) -> dict:
    facts = json.loads(TIMING_FACTS.read_text()) if TIMING_FACTS.exists() else {}
    facts.update(machine=f"{os.cpu_count()} cores",
                 rule="the lowest of the repetitions (a shared machine only slows a run)")
    cases = facts.setdefault("cases", {})
    with tempfile.TemporaryDirectory(prefix="doc-facts-") as tmp:
        for key in keys:
            args, what, ranks = TIMED[key]
            reps = []
            for i in range(repeat):
                reps.append(time_command(args, what, ranks, Path(tmp) / f"{key}-{i}"))
                print(key, json.dumps(reps[-1]), flush=True)
            best = min(reps, key=lambda r: r["seconds"])
            cases[key] = {"command": "stickslip " + " ".join(args), "ranks": ranks,
                          "timed": what, "seconds": best["seconds"], "best": best,
                          "repetitions": reps}
    return facts


def refresh_estimates(facts: dict) -> dict:
    """Each run case's estimate and estimate/wall ratio, from the current cost model."""
    for key, case in facts["cases"].items():
        if TIMED[key][0][0] != "run":
            continue
        est = pre_run_estimate(TIMED[key][0])
        for rec in case["repetitions"]:
            rec["estimate_steps"], rec["estimate_s"] = est.steps, round(est.seconds, 2)
            rec["estimate_ratio"] = round(est.seconds / rec["run_wall_s"], 3)
        case["best"] = min(case["repetitions"], key=lambda r: r["seconds"])
    return facts


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="what", required=True)
    c = sub.add_parser("census", help="docs/facts/tutorial_census.json from a census directory")
    c.add_argument("dir", type=Path)
    t = sub.add_parser("timings", help="docs/facts/timings.json: run the timed commands")
    t.add_argument("--repeat", type=int, default=2)
    t.add_argument("--only", action="append", choices=list(TIMED), default=[])
    t.add_argument("--skip", action="append", choices=list(TIMED), default=[])
    sub.add_parser("estimates", help="recompute timings.json's estimates (no runs)")
    args = ap.parse_args(argv)
    FACTS.mkdir(parents=True, exist_ok=True)
    if args.what == "census":
        answer = json.loads((args.dir / "attractors.json").read_text())
        facts = census_facts(answer)
        CENSUS_FACTS.write_text(json.dumps(facts, indent=1) + "\n")
        print(f"-> {CENSUS_FACTS.relative_to(REPO)}")
        return 0
    if args.what == "estimates":
        facts = refresh_estimates(json.loads(TIMING_FACTS.read_text()))
    else:
        facts = timings(args.repeat, [k for k in (args.only or TIMED) if k not in args.skip])
    TIMING_FACTS.write_text(json.dumps(facts, indent=1) + "\n")
    print(f"-> {TIMING_FACTS.relative_to(REPO)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
