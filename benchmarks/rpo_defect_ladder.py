"""The RPO obstruction under mesh refinement: commutation defect and Newton residual of a
census's two-generator members at each mesh N.

    ./dev python3 benchmarks/rpo_defect_ladder.py /work/census/P/census \\
        /tmp/tut2,/tmp/c528d --max-iter 16 --json /tmp/rpo_defect_ladder.json

Each positional argument is one scene point: a census directory, or several separated by
commas that hold rungs of the same scene (checked: their scenes differ in mesh.n_inner only).
At each N, the members with two generators (``attractors.json``; type "relative periodic
orbit" or "torus") are keyed by the generators' signed wavenumbers (k₁, k₂), + with the
rotation; of the members sharing a key, the one with most starts is taken, at its first
start (lowest seed). On that start ``rpo_certificate`` (floquet off) gives:

* the commutation defect ‖F_T(R_{Δφ/2} ξ) − R_{Δφ/2} F_T(ξ)‖ at the census's guess T, s;
* the residual ‖G‖ at the guess and after ``--max-iter`` Newton iterations (0: the defect
  only, two maps per row), the Jacobian products and the wall time.

Then, per key present at several N and per *family* (the two generators' directions and
k₁ − k₂, e.g. "k, k − 1 against the rotation", whose k may change with N), the observed
order of the defect, p = ln(d_a/d_b)/ln(N_b/N_a) between consecutive rungs (defect ∝ N^−p),
and of the generators' frequencies of one k across three rungs
(``statistics.observed_order``). With ``--in-time`` the censuses of a point are one mesh at
``time.dt_fraction`` halved from one to the next, and the rungs (the N column) are the
step's refinement 1, 2, 4 (Δt, Δt/2, Δt/4). Costs at P (Ω = 60, N = 528, T ≈ 12.7 ms, 2497 steps):
one map of two columns (a Jacobian product) 1.4 s on one core.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

from stickslip.studies.attractors.statistics import observed_order
from stickslip.studies.rpo.certificate import rpo_certificate

TWO_GENERATOR_TYPES = ("relative periodic orbit", "torus")


def signed_k(g: dict) -> int:
    """k, + with the rotation, − against it."""
    return int(g["k"]) if g["direction"] == "rotation" else -int(g["k"])


def scene_without(census: Path, section: str, key: str) -> dict:
    """The census's scene less its ``section.key`` (what its ladder varies)."""
    scene = json.loads((census / "census.json").read_text())["definition"]["scene"]
    return {**scene, section: {**scene[section], key: None}}


def point_members(dirs: list[Path], in_time: bool = False) -> tuple[dict, dict[int, dict]]:
    """(scene, {rung: {(k₁, k₂): row}}) of one scene point: each row a member with two
    generators (module docstring) and its first start's run directory. The rung is N, or
    with ``in_time`` (censuses of one mesh, ``time.dt_fraction`` halved from one to the
    next) the step's refinement, round(coarsest fraction / fraction): 1, 2, 4, ..."""
    varied = ("time", "dt_fraction") if in_time else ("mesh", "n_inner")
    scenes = [scene_without(d, *varied) for d in dirs]
    if any(s != scenes[0] for s in scenes[1:]):
        sys.exit(f"{dirs}: the censuses' scenes differ beyond {'.'.join(varied)}")
    fractions = [json.loads((d / "census.json").read_text())["definition"]["scene"]["time"]
                 ["dt_fraction"] for d in dirs]
    per_n: dict[int, dict] = {}
    for d, fraction in zip(dirs, fractions, strict=True):
        data = json.loads((d / "attractors.json").read_text())
        run_dirs = {s["id"]: s for s in data["starts"]}
        for n_text, members in data["members"].items():
            rung = round(max(fractions) / fraction) if in_time else int(n_text)
            for m in members:
                gens = [g for g in (m.get("generators") or []) if g.get("frequency_hz")]
                if m.get("type") not in TWO_GENERATOR_TYPES or len(gens) < 2:
                    continue
                key = (signed_k(gens[0]), signed_k(gens[1]))
                rows = per_n.setdefault(rung, {})
                if key in rows and rows[key]["count"] >= m["count"]:
                    continue
                seed = min(m["seeds"])
                start = next(s for s in run_dirs.values()
                             if s["member"] == m["member"] and s["seed"] == seed
                             and int(s["n_inner"]) == int(n_text))
                rows[key] = {"member": m["member"], "type": m["type"], "count": m["count"],
                             "starts": m["starts"], "seed": seed,
                             "run_dir": start["run_dir"], "generators": gens[:2],
                             "components": m.get("components"),
                             "period_s": m.get("period_s")}
    return scenes[0], dict(sorted(per_n.items()))


def certify(row: dict, max_iter: int) -> dict:
    """The defect and Newton residual of ``row``'s first start (module docstring)."""
    t0 = time.perf_counter()
    cert = rpo_certificate(row["run_dir"], row["generators"], components=row["components"],
                           max_iter=max_iter, floquet=0)
    hist = cert["history"]
    return {"defect": cert["commutation_defect"], "residual_guess": cert["guess"]["residual"],
            "residual": cert["residual"], "iterations": cert["iterations"],
            "residual_history": [h["residual_after"] for h in hist],
            "jvp": cert["jvp_status_changes"]["products"],
            "jvp_with_status_changes": cert["jvp_status_changes"]["with_changes"],
            "steps": cert["steps"], "run_step_s": cert["run_step_s"],
            "period_s": cert["period_s"], "wall_s": time.perf_counter() - t0}


def pair_orders(ns: list[int], values: list[float]) -> list[float]:
    """p = ln(v_a/v_b)/ln(N_b/N_a) between consecutive rungs (v ∝ N^−p)."""
    return [math.log(values[i] / values[i + 1]) / math.log(ns[i + 1] / ns[i])
            for i in range(len(ns) - 1)]


def ladders(per_n: dict[int, dict]) -> list[tuple[str, list[tuple[int, tuple]]]]:
    """(label, [(N, key)]) of each key and each family present at two or more N."""
    out = []
    keys = sorted({k for rows in per_n.values() for k in rows})
    for key in keys:
        rungs = [(n, key) for n, rows in per_n.items() if key in rows]
        if len(rungs) > 1:
            out.append((f"k = {key[0]:+d}, {key[1]:+d}", rungs))
    families: dict[tuple, list] = {}
    for n, rows in per_n.items():
        for key in rows:
            fam = (key[0] > 0, key[1] > 0, abs(key[0]) - abs(key[1]))
            families.setdefault(fam, []).append((n, key))
    for (r1, r2, dk), rungs in sorted(families.items()):
        ns = [n for n, _ in rungs]
        if len(set(ns)) == len(ns) > 1 and len({k for _, k in rungs}) > 1:
            sign = lambda r: "+" if r else "-"  # noqa: E731
            out.append((f"family k{sign(r1)}, (k - {dk}){sign(r2)}", rungs))
    return out


def frequency_orders(per_n: dict[int, dict]) -> list[str]:
    """Each signed k that is a generator at two or more N: its frequencies, the differences
    between rungs and, with three rungs, the observed order."""
    seen: dict[int, dict[int, float]] = {}
    for n, rows in per_n.items():
        for row in sorted(rows.values(), key=lambda r: -r["count"]):
            for g in row["generators"]:
                seen.setdefault(signed_k(g), {}).setdefault(n, float(g["frequency_hz"]))
    lines = []
    for k, by_n in sorted(seen.items()):
        if len(by_n) < 2:
            continue
        ns, fs = list(by_n), list(by_n.values())
        diffs = [fs[i + 1] - fs[i] for i in range(len(fs) - 1)]
        p = observed_order(ns, fs) if len(ns) == 3 else math.nan
        lines.append(f"  k = {k:+d}: " + ", ".join(f"N {n}: {f:+.2f} Hz" for n, f in by_n.items())
                     + "; differences " + ", ".join(f"{d:+.2f}" for d in diffs)
                     + (f"; observed order {p:.2f}" if math.isfinite(p) else ""))
    return lines


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("points", nargs="+", help="census dir, or dirs joined by commas (one point)")
    ap.add_argument("--max-iter", type=int, default=8, help="Newton iterations (0: defect only)")
    ap.add_argument("--newton-max-n", type=int, default=None,
                    help="Newton only on rungs N up to this (the others: defect only)")
    ap.add_argument("--json", type=Path, help="write every row here")
    ap.add_argument("--in-time", action="store_true",
                    help="the censuses of a point are one mesh at time.dt_fraction halved "
                         "from one to the next: the rungs are the step's refinement 1, 2, 4")
    args = ap.parse_args(argv)
    report = []
    for point in args.points:
        dirs = [Path(p) for p in point.split(",")]
        scene, per_n = point_members(dirs, args.in_time)
        print(f"\n== {point}: Ω = {scene['loading']['omega']} rad/s, δ = "
              f"{scene['geometry']['delta']}, f = {scene['loading']['f']}, β₂ = "
              f"{scene['time']['beta2']}, Δt = {scene['time']['dt_fraction']} Δt_crit, "
              f"loss factor {scene['damping']['loss_factor']} at "
              f"{scene['damping']['reference_frequency_hz']} Hz")
        print(f"{'N':>4} {'k1,k2':>8} {'type':>5} {'starts':>6} {'seed':>4} {'Δt s':>9} "
              f"{'steps':>5} {'defect':>9} {'|G| guess':>9} {'|G| end':>9} {'it':>2} "
              f"{'jvp':>4} {'wall s':>6}  f1, f2 Hz")
        for n, rows in per_n.items():
            for key, row in rows.items():
                it = args.max_iter if (args.newton_max_n is None or n <= args.newton_max_n) else 0
                row.update(certify(row, it), N=n, key=list(key))
                g1, g2 = row["generators"]
                print(f"{n:>4} {key[0]:+3d},{key[1]:+3d} {row['type'][:5]:>5} "
                      f"{row['count']:>3}/{row['starts']:<2} {row['seed']:>4} "
                      f"{row['run_step_s']:9.3e} {row['steps']:>5} {row['defect']:9.3e} "
                      f"{row['residual_guess']:9.3e} {row['residual']:9.3e} "
                      f"{row['iterations']:>2} {row['jvp']:>4} {row['wall_s']:6.1f}  "
                      f"{g1['frequency_hz']:+.2f}, {g2['frequency_hz']:+.2f}", flush=True)
                report.append({"point": point, **{k: v for k, v in row.items()
                                                   if k != "components"}})
        for label, rungs in ladders(per_n):
            ns = [n for n, _ in rungs]
            d = [per_n[n][k]["defect"] for n, k in rungs]
            r = [per_n[n][k]["residual"] for n, k in rungs]
            print(f"  {label}: N {ns}: defect {[f'{x:.3e}' for x in d]}, order "
                  f"{[round(p, 2) for p in pair_orders(ns, d)]}; |G| after Newton "
                  f"{[f'{x:.2e}' for x in r]}, order {[round(p, 2) for p in pair_orders(ns, r)]}")
        print("\n".join(frequency_orders(per_n)))
    if args.json:
        args.json.write_text(json.dumps(report, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
