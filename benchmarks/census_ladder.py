"""Does the census's answer settle along a refinement ladder, and from where? The table of
docs/attractors.md ("Where the answer settles"), from finished census directories.

    ./dev python3 benchmarks/census_ladder.py NAME=DIR[:TIMINGS.jsonl] [NAME=DIR ...]
        [--json docs/facts/census_ladder.json]
    ./dev python3 benchmarks/census_ladder.py NAME=DIR_DT+DIR_DT2+DIR_DT4   # in the time step
    ./dev python3 benchmarks/census_ladder.py NAME=DIR --compare 264p2:528 [--compare ...]

Each DIR is a census directory (``stickslip attractors ... -o DIR``) whose ladder holds the
rungs measured; TIMINGS (optional) the JSON lines that ``benchmarks/attractor_census.py``
printed, one per invocation, each adding one rung to DIR (so each invocation's wall time is
its new rung's: the rungs before are read from the directory, not run again). The censuses
of the table, each rung added in turn (16 starts, defaults, under ``mpirun -n 2``):

    ./dev python3 benchmarks/attractor_census.py --starts 16 --ranks 2 --meshes 132 -o DIR
    ./dev python3 benchmarks/attractor_census.py --starts 16 --ranks 2 --meshes 132,264 -o DIR
    ./dev python3 benchmarks/attractor_census.py --starts 16 --ranks 2 --meshes 132,264,528 -o DIR

(``--scene figure3_n132_damped`` for Figure 3 damped; ``--set loading.omega=60 --set
geometry.delta=8e-4 --set loading.f=0.6`` for the public point P; ``132,264,528,132p2`` and
then ``...,264p2`` for the degree-2 rungs.)

Printed per point and rung: the attractors (rigid / multi-wave / chaotic), the starts that
reach them, the dominant-component distribution's two largest entries, the basin-weighted
celerity, the wall time of the rung; per step: the settle criterion's four numbers
(``statistics.rung_steps``) and whether it holds; last, the first rung from which the answer
stays the same (``ladder.settles_from``), or that none does.

``--compare A:B`` prints, per point, the settle criterion between two rungs that need not be
neighbours by dofs (``statistics.ladder`` on those two): whether a coarse rung of one degree
already gives a fine rung of the other's answer.

With ``NAME=DIR+DIR+...`` the ladder is in the time step: each DIR a census of one rung at
one ``time.dt_fraction`` (``--set time.dt_fraction=0.45``, then 0.225), the rungs labelled
``N@fraction`` in the order given and compared by the same criterion.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path


def rung_walls(timings: Path | None) -> dict[str, float]:
    """{rung key: wall s} of the invocation that added it (the rung not in the one before)."""
    walls: dict[str, float] = {}
    if timings is None or not timings.is_file():
        return walls
    seen: set[str] = set()
    for line in timings.read_text().splitlines():
        if not line.strip().startswith("{"):
            continue
        rec = json.loads(line)
        rungs = rec["command"].split("--meshes ")[1].split()[0].split(",")
        new = [r for r in rungs if r not in seen]
        if len(new) == 1:
            walls[new[0]] = rec["wall_s"]
        seen |= set(rungs)
    return walls


def point_table(name: str, census: Path, timings: Path | None) -> dict:
    answer = json.loads((census / "attractors.json").read_text())
    lad = answer["ladder"]
    walls = rung_walls(timings)
    coarse = lad.get("coarse") or {}
    rungs = []
    for key, members in answer["members"].items():
        acc = answer["accounting"][key]
        kinds = {c: sum(m["class"] == c for m in members)
                 for c in ("wave", "multi-wave", "chaotic")}
        dist = sorted((coarse.get("dominant_k") or {}).get(key, {}).items(),
                      key=lambda kv: -kv[1])[:2]
        cel = coarse["weighted_celerity_m_s"]["values"][list(answer["members"]).index(key)]
        rungs.append({"rung": key, "attractors": acc["attractors"], "kinds": kinds,
                      "reached": acc["reached"], "starts": acc["starts"],
                      "dominant": dist, "weighted_celerity_m_s": cel,
                      "wall_s": walls.get(key)})
    return {"point": name, "finished": answer["finished"], "rungs": rungs,
            "steps": lad.get("steps") or [], "settles_from": lad.get("settles_from")}


def time_step_table(name: str, dirs: list[Path]) -> dict:
    """The same table for a ladder in the time step: census directories of one rung each
    (the same scene and mesh, ``time.dt_fraction`` halved from one to the next), each rung
    labelled ``N@fraction``; the steps are ``statistics.ladder``'s on those rungs."""
    from stickslip.studies.attractors.statistics import ladder

    answers = [json.loads((d / "attractors.json").read_text()) for d in dirs]
    fractions = [a["scene"]["time"]["dt_fraction"] for a in answers]
    per_rung, accounts, labels = {}, {}, {}
    for answer, fraction in zip(answers, fractions, strict=True):
        (key, members), = answer["members"].items()
        step = str(round(max(fractions) / fraction))  # the ladder's rung: 1, 2, 4 (Δt / h)
        labels[step] = f"{key}@{fraction:g}"
        per_rung[step], accounts[step] = members, answer["accounting"][key]
    lad = ladder(per_rung)
    for step in lad["steps"]:
        step["from"], step["to"] = labels[str(step["from"])], labels[str(step["to"])]
    coarse = lad["coarse"]
    rungs = []
    for i, (key, members) in enumerate(per_rung.items()):
        kinds = {c: sum(m["class"] == c for m in members)
                 for c in ("wave", "multi-wave", "chaotic")}
        dist = sorted(coarse["dominant_k"][key].items(), key=lambda kv: -kv[1])[:2]
        rungs.append({"rung": labels[key], "attractors": accounts[key]["attractors"],
                      "kinds": kinds, "reached": accounts[key]["reached"],
                      "starts": accounts[key]["starts"], "dominant": dist,
                      "weighted_celerity_m_s": coarse["weighted_celerity_m_s"]["values"][i],
                      "wall_s": None})
    settles = lad["settles_from"]
    return {"point": name, "finished": True, "rungs": rungs, "steps": lad["steps"],
            "settles_from": None if settles is None else labels[str(settles)]}


def _dominant(dist: list) -> str:
    return ", ".join(f"{k} {100 * p:.0f} %" for k, p in dist)


def markdown(tables: list[dict]) -> str:
    out = ["| point | rung | attractors (rigid/multi/chaotic) | reached | dominant | "
           "weighted celerity | wall | step to next: set, Fisher p, TV, celerity |",
           "|---|---|---|---|---|---|---|---|"]
    for t in tables:
        steps = {str(s["from"]): s for s in t["steps"]}
        for r in t["rungs"]:
            s = steps.get(r["rung"])
            step = "" if s is None else (
                f"{'same' if s['same_set'] else 'changes'}, "
                f"{s['fisher_min_p']:.2g}, {s['dominant_tv']:.2f}, "
                f"{100 * s['celerity_change']:.3g} %" + (" ✓" if s["holds"] else ""))
            k = r["kinds"]
            cel = r["weighted_celerity_m_s"]
            cel_text = f"{cel:+.1f} m/s" if cel is not None and math.isfinite(cel) else "–"
            wall = f"{r['wall_s'] / 60:.1f} min" if r["wall_s"] else "–"
            out.append(f"| {t['point']} | {r['rung']} | {r['attractors']} "
                       f"({k['wave']}/{k['multi-wave']}/{k['chaotic']}) | "
                       f"{r['reached']}/{r['starts']} | {_dominant(r['dominant'])} | "
                       f"{cel_text} | {wall} | {step} |")
        verdict = (f"settles from {t['settles_from']}" if t["settles_from"] is not None
                   else "no rung qualifies")
        out.append(f"| {t['point']} | **{verdict}** | | | | | | |")
    return "\n".join(out)


def compare_line(name: str, census: Path, a: str, b: str) -> str:
    """The settle criterion between rungs ``a`` and ``b`` of one census (``--compare``)."""
    from stickslip.studies.attractors.statistics import ladder

    members = json.loads((census / "attractors.json").read_text())["members"]
    if missing := [r for r in (a, b) if r not in members]:
        raise SystemExit(f"--compare {a}:{b}: {census} has no rung {missing[0]!r} (its rungs: "
                         f"{', '.join(members)})")
    lad = ladder({a: members[a], b: members[b]})
    s, cel = lad["steps"][0], lad["coarse"]["weighted_celerity_m_s"]["values"]
    return (f"{name} {a} -> {b}: {'same set' if s['same_set'] else 'set changes'}, Fisher p "
            f"{s['fisher_min_p']:.2g}, TV {s['dominant_tv']:.2f}, celerity "
            f"{cel[0]:+.1f} -> {cel[1]:+.1f} m/s ({100 * s['celerity_change']:.2f} %)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("points", nargs="+", metavar="NAME=DIR[:TIMINGS]")
    ap.add_argument("--json", type=Path, help="also write the tables as JSON here")
    ap.add_argument("--compare", action="append", default=[], metavar="A:B",
                    help="two rungs of each census to compare directly (e.g. 264p2:528)")
    args = ap.parse_args()
    if args.compare:
        for item in args.points:
            name, _, census = item.partition("=")
            for pair in args.compare:
                a, _, b = pair.partition(":")
                print(compare_line(name, Path(census.partition(":")[0]), a, b))
        return
    tables = []
    for item in args.points:
        name, _, rest = item.partition("=")
        if "+" in rest:  # a ladder in the time step: one rung per directory
            tables.append(time_step_table(name, [Path(d) for d in rest.split("+")]))
            continue
        census, _, timings = rest.partition(":")
        tables.append(point_table(name, Path(census), Path(timings) if timings else None))
    print(markdown(tables))
    if args.json:
        args.json.write_text(json.dumps(tables, indent=1) + "\n")


if __name__ == "__main__":
    main()
