"""The CEA beside the census: which unstable mode of steady sliding do the starts end on?

For each rung (mesh and element degree) of a census, the complex eigenvalue analysis of its
steady sliding (``studies.flutter_fe.complex_eigenvalue_analysis``, the scene's damping and
friction law) gives the unstable modes; those the mesh resolves (not ``mesh_scale``) are listed, the
fastest-growing of each wavenumber k and direction, with its growth rate, damping ratio ζ and
frequency. For each, the share of
the census's random starts whose settled end state (a rigid or multi-wave attractor) holds a
component of that k and direction as the **dominant** one, or as a listed **companion**
(``features``), with 95 % Wilson intervals. The fastest-growing mode **wins** when it is
the dominant component of more starts than any other mode: the brake-squeal question
"which unstable mode squeals".

The spectra are cached in ``DIR/cea.json`` per rung key (the scene is the census's own).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from stickslip.solver.scene import load_scene
from stickslip.studies.attractors.census import read_cache, write_if_changed
from stickslip.studies.attractors.starts import parse_rung_key, rung_key
from stickslip.studies.attractors.statistics import COUNTED, SETTLED, wilson
from stickslip.studies.flutter_fe import complex_eigenvalue_analysis

CACHE = "cea.json"
#: The printed table shows the fastest-growing modes and every mode a start ends on.
FASTEST_SHOWN = 5


def unstable_modes(scene_file: Path, n_inner: int, fmax_hz: float, degree: int = 1
                   ) -> list[dict]:
    """The resolved unstable modes of the scene's steady sliding at ``n_inner`` contact
    nodes and element ``degree``, most unstable first (k, direction, growth rate, ζ,
    frequency, phase speed)."""
    from mpi4py import MPI

    # dolfinx on first use: the command line imports this module at start
    from stickslip.solver.problem import build_problem

    scene = load_scene(scene_file, [f"mesh.n_inner={int(n_inner)}",
                                    f"mesh.degree={int(degree)}"])
    problem = build_problem(scene, MPI.COMM_SELF)
    res = complex_eigenvalue_analysis(problem, None, fmax_hz)
    out, seen = [], set()
    for m in res.unstable():  # most unstable first: the fastest of each (k, direction)
        if m.mesh_scale or (m.wavenumber, m.direction) in seen:
            continue
        seen.add((m.wavenumber, m.direction))
        out.append({"k": m.wavenumber, "direction": m.direction,
                    "growth_rate_per_s": m.growth_rate, "zeta": m.zeta,
                    "frequency_hz": m.frequency_hz, "phase_speed_m_s": m.phase_speed_m_s})
    return out


def cea_table(out_dir: Path, answer: dict, fmax_hz: float = 10_000.0) -> dict:
    """Per rung of the census (its key): its unstable modes, and for each the shares of the
    random starts that end on it as dominant or companion; whether the fastest-growing mode
    wins (module docstring). The spectra are cached in ``out_dir/cea.json``."""
    cache = read_cache(out_dir / CACHE, list)
    out = {}
    for n in answer["members"]:
        key = f"{n}@{fmax_hz:g}"
        if key not in cache:
            n_inner, degree = parse_rung_key(n)
            cache[key] = unstable_modes(out_dir / "base.toml", n_inner, fmax_hz, degree)
            write_if_changed(out_dir / CACHE, json.dumps(cache, indent=1) + "\n",
                             required=False)
        rows = [r for r in answer["starts"]
                if rung_key(r["n_inner"], r.get("degree") or 1) == str(n)
                and r["start"] == "random" and r["class"] in COUNTED]
        out[n] = mode_shares(cache[key], rows)
    return out


def mode_shares(modes: list[dict], rows: list[dict]) -> dict:
    """For each mode, the starts (of ``rows``, every counted random start of one mesh) whose
    settled end state holds it as dominant component or as a listed companion."""
    n = len(rows)
    held = []
    for r in rows:
        comps = [c for c in (r.get("features") or {}).get("components") or []
                 if not c.get("weak")] if r["class"] in SETTLED else []
        held.append([(c["k"], c["direction"]) for c in comps])
    table = []
    for m in modes:
        key = (m["k"], m["direction"])
        dom = sum(1 for h in held if h and h[0] == key)
        comp = sum(1 for h in held if key in h[1:])
        table.append({**m, "dominant": dom, "companion": comp, "starts": n,
                      "dominant_ci": wilson(dom, n), "companion_ci": wilson(comp, n)})
    winner = max(table, key=lambda e: e["dominant"], default=None)
    fastest = table[0] if table else None
    wins = bool(fastest and fastest["dominant"] > 0 and all(
        e["dominant"] < fastest["dominant"] for e in table[1:]))
    return {"modes": table, "fastest_wins": wins, "settled": sum(1 for h in held if h),
            "most_reached": None if winner is None or not winner["dominant"] else
            {"k": winner["k"], "direction": winner["direction"]}}


def cea_lines(table: dict) -> list[str]:
    """The printed table (``stickslip attractors DIR --cea``)."""
    sense = {"rotation": "with", "opposite": "against"}
    lines = []
    for n, t in table.items():
        modes = t["modes"]
        lines.append(f"N = {n}: {len(modes)} resolved unstable mode(s) of steady sliding "
                     "(most unstable first); share of the random starts ending with it as "
                     "the dominant / a companion component:")
        shown = [m for i, m in enumerate(modes)
                 if i < FASTEST_SHOWN or m["dominant"] or m["companion"]]
        for m in shown:
            lo, hi = m["dominant_ci"]
            lines.append(
                f"  k = {m['k']:>2} {sense.get(m['direction'], m['direction']):>7} Ω, "
                f"growth {m['growth_rate_per_s']:8.1f} /s, ζ = {m['zeta']:+.4f}, "
                f"{m['frequency_hz']:7.1f} Hz: dominant {m['dominant']}/{m['starts']} "
                f"({_pct(lo)}–{_pct(hi)}), companion {m['companion']}/{m['starts']}")
        if len(shown) < len(modes):
            lines.append(f"  … and {len(modes) - len(shown)} slower mode(s) that no start "
                         "ends on (cea.json)")
        if modes:
            top = modes[0]
            lines.append(
                f"  the fastest-growing mode (k = {top['k']} {sense.get(top['direction'])} Ω) "
                + ("cannot be compared: no start has settled on an attractor at this mesh"
                   if not t.get("settled") else
                   "wins: it is the dominant component of the most starts" if t["fastest_wins"]
                   else "does not win" + (
                       f": k = {t['most_reached']['k']} "
                       f"{sense.get(t['most_reached']['direction'])} Ω is the dominant "
                       "component of the most starts" if t["most_reached"] else
                       ": no start ends on an unstable mode's wavenumber")))
    return lines


def _pct(x: float) -> str:
    return f"{100 * x:.0f} %" if math.isfinite(x) else "–"
