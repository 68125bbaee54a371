"""Attractors along a parameter: a census at every point of a curve, matched by features.

``stickslip attractors SCENE --along loading.omega=30:100:8`` runs the census
(``census.run_census``, the same starts and meshes) at each of the 8 values 30 … 100
(``parse_along``: ``A:B:M`` is M equally spaced values from A to B, or ``V1,V2,...``) into
``DIR/points/<key>-<value>``, each resumable as any census (a finished start is never run
again). On the finest mesh, the attractors (settled members) are matched by their features
with the nearest earlier point that has them (``statistics.align`` with ``lookback`` and
``ALONG_TOLERANCES``: the same dominant component and the same listed companions,
celerities within 15 %, shares within 20 points), in the spirit of Attractors.jl's
``global_continuation``. Each chain of matched
attractors is one curve: its basin share with the 95 % Wilson interval and its dominant
celerity at every point it exists; where it appears or vanishes inside the range is marked.
``DIR/along.json`` holds the table; ``--plot`` draws ``along.png`` (stacked basin shares with
95 % Wilson bars; celerity against the parameter).
"""

from __future__ import annotations

import json
import math
import sys
from dataclasses import replace
from pathlib import Path
from typing import TextIO

from stickslip.solver.atomic import atomic_write_text
from stickslip.studies.attractors.census import CensusError, claim_on_rank0, run_census
from stickslip.studies.attractors.features import Tolerances
from stickslip.studies.attractors.statistics import SETTLED, align
from stickslip.studies.rundir.ownership import OwnershipError, claim, register_kind

KIND = "attractors-along"
ENTRIES = ("along.json", "points", "*.png")
#: How far an attractor may move between neighbouring points of the curve and still be one.
ALONG_TOLERANCES = {"celerity": 0.15, "share_rel": 0.5, "share_abs": 0.20, "fraction": 0.10}
#: Most values of one curve: each is a whole census (a curve needs a few tens). Checked
#: before the list is made and each value's scene is checked.
MAX_POINTS = 200


#: Scene keys that every start of a census sets itself (its sweep point): the flag that
#: varies them instead.
START_KEYS = {"mesh.n_inner": "--meshes", "mesh.degree": "--degrees",
              "initial.perturbation": "--structured",
              "initial.seed": "--seed", "initial.mode": "--structured"}
#: Scene keys that the start distribution sets (``census.Census.base_scene``): a curve along
#: one varies the distribution's field.
DISTRIBUTION_KEYS = {"initial.n_modes": "n_modes", "initial.amplitude": "amplitude"}


def parse_along(text: str) -> tuple[str, list[float]]:
    """``loading.omega=30:100:8`` or ``loading.omega=30,40,60`` -> (key, values); an
    integral value is an ``int`` (so an integer key, ``mesh.n_radial=2,3``, takes it);
    ValueError naming the fix."""
    key, sep, spec = text.partition("=")
    fix = "give KEY=A:B:M (M values from A to B) or KEY=V1,V2,..."
    if not sep or not key.strip() or "." not in key:
        raise ValueError(f"--along {text!r}: {fix}, e.g. loading.omega=30:100:8")
    if key.strip() in START_KEYS:
        raise ValueError(f"--along {text!r}: every start of a census sets {key.strip()} "
                         f"itself; vary it with {START_KEYS[key.strip()]}")
    try:
        if ":" in spec:
            a, b, m = spec.split(":")
            count, lo, hi = int(m), float(a), float(b)
            if count < 2:
                raise ValueError
            if count > MAX_POINTS:
                raise ValueError(f"--along {text!r}: M = {count} values, each a whole census;"
                                 f" give M <= {MAX_POINTS}")
            values = [lo + (hi - lo) * i / (count - 1) for i in range(count)]
        else:
            values = [float(v) for v in spec.split(",") if v.strip()]
    except ValueError as err:
        raise ValueError(str(err) if str(err).startswith("--along") else
                         f"--along {text!r}: {fix} (M >= 2)") from None
    if len(values) > MAX_POINTS:
        raise ValueError(f"--along {text!r}: {len(values)} values, each a whole census; give "
                         f"at most {MAX_POINTS}")
    if not all(map(math.isfinite, values)):
        raise ValueError(f"--along {text!r}: the values must be finite numbers ({fix})")
    if len(values) < 2 or len(set(values)) != len(values):
        raise ValueError(f"--along {text!r}: {fix} with at least two distinct values")
    return key.strip(), [int(v) if float(v).is_integer() else v for v in values]


def point_census(census, key: str, value: float):  # noqa: ANN001, ANN201 - a Census
    """The census at ``key = value``: the start distribution's own field for its keys
    (``DISTRIBUTION_KEYS``), else one more scene override."""
    if key in DISTRIBUTION_KEYS:
        field = DISTRIBUTION_KEYS[key]
        given = float(value) if field == "amplitude" else value
        try:
            return replace(census, distribution=replace(census.distribution, **{field: given}))
        except ValueError as err:  # the distribution's own check (an integer, > 0)

            raise CensusError(f"{key} = {value}: {err}") from None
    return replace(census, overrides=(*census.overrides, f"{key}={value!r}"))


def point_dir(out_dir: Path, key: str, value: float) -> Path:
    return out_dir / "points" / f"{key.rsplit('.', 1)[-1]}-{value:g}"


def run_along(census, key: str, values: list[float], out_dir: Path, *,  # noqa: ANN001
              comm=None, stream: TextIO | None = None, **options) -> int:  # noqa: ANN001
    """The census at every value (collective), then rank 0 writes along.json and prints
    the curve (on ``stream``, default stdout). Returns the worst census status
    (2 > 130 > 1 > 0)."""
    from mpi4py import MPI

    stream = sys.stdout if stream is None else stream

    comm = MPI.COMM_WORLD if comm is None else comm
    if comm.rank == 0:
        register_kind("along", ENTRIES)
    owned, refused = claim_on_rank0(comm, lambda: claim(out_dir, "along", reuse=True),
                                    (OwnershipError,))
    if refused:
        return 2
    worst = 0
    try:
        for v in values:
            if comm.rank == 0:
                print(f"== {key} = {v:g}", file=stream, flush=True)
            try:
                point = point_census(census, key, v)
                point.base_scene()
            except CensusError as e:
                if comm.rank == 0:
                    print(f"error: {e}", file=sys.stderr, flush=True)
                return 2
            rc = run_census(point, point_dir(out_dir, key, v), comm=comm, stream=stream,
                            **options)
            worst = max(worst, rc, key=lambda r: {2: 3, 130: 2, 1: 1}.get(r, 0))
            if rc in (2, 130):
                return rc
        if comm.rank == 0:
            table = along_table(out_dir, key, values)
            print("\n".join(along_lines(table)), file=stream, flush=True)
    finally:
        if owned is not None:
            owned.release()
    return worst


def along_table(out_dir: Path, key: str, values: list[float]) -> dict:
    """Match the attractors of neighbouring points (module docstring); write along.json."""
    points = []
    for v in values:
        path = point_dir(out_dir, key, v) / "attractors.json"
        answer = json.loads(path.read_text()) if path.is_file() else None
        mesh = list(answer["members"])[-1] if answer else None  # the ladder's last rung
        members = [m for m in answer["members"][mesh] if m["class"] in SETTLED] \
            if answer else []
        points.append({"value": v, "mesh": mesh, "members": members,
                       "starts": members[0]["starts"] if members else (
                           answer["members"][mesh][0]["starts"]
                           if answer and answer["members"][mesh] else 0)})
    per = {i: p["members"] for i, p in enumerate(points)}
    align(per, Tolerances(**ALONG_TOLERANCES), lookback=True)
    chains: dict[str, dict] = {}
    for i, p in enumerate(points):
        for m in p["members"]:
            c = chains.setdefault(m["ladder_id"], {"name": m.get("name") or m["member"],
                                                   "points": {}})
            c["points"][i] = {"share": m["share"], "share_lo": m["share_lo"],
                              "share_hi": m["share_hi"], "count": m["count"],
                              "celerity_m_s": m["celerity_m_s"], "member": m["member"]}
    for c in chains.values():  # where it appears or vanishes inside the range
        have = [i in c["points"] for i in range(len(values))]
        c["appears"] = [values[i] for i in range(1, len(values)) if have[i] and not have[i - 1]]
        c["vanishes"] = [values[i] for i in range(1, len(values))
                         if have[i - 1] and not have[i]]
    table = {"kind": KIND, "key": key, "values": values,
             "points": [{k: p[k] for k in ("value", "mesh", "starts")} for p in points],
             "chains": {name: {**c, "points": {str(i): v for i, v in c["points"].items()}}
                        for name, c in chains.items()},
             "tolerances": ALONG_TOLERANCES}
    atomic_write_text(out_dir / "along.json", json.dumps(_finite(table), indent=1) + "\n")
    return table


def _finite(x):  # noqa: ANN001, ANN202
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if isinstance(x, dict):
        return {k: _finite(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_finite(v) for v in x]
    return x


def along_lines(table: dict) -> list[str]:
    """The printed curve: per attractor, its share and celerity at each point."""
    values = table["values"]
    lines = [f"attractors along {table['key']} = " + ", ".join(f"{v:g}" for v in values)
             + " (finest mesh; matched by features with the nearest earlier point that has"
             " the attractor)"]
    if not table["chains"]:
        lines.append("  no attractor at any point")
    for name, c in table["chains"].items():
        cells = []
        for i, v in enumerate(values):
            p = c["points"].get(str(i))
            cells.append(f"{v:g}: –" if p is None else
                         f"{v:g}: {100 * p['share']:.0f} % ({p['celerity_m_s']:+.0f} m/s)")
        marks = [text for _, text in sorted(
            [(v, f"appears at {v:g}") for v in c["appears"]]
            + [(v, f"vanishes at {v:g}") for v in c["vanishes"]])]
        lines.append(f"  {c['name']} [{name}]" + (f" ({', '.join(marks)})" if marks else ""))
        lines.append("    " + "; ".join(cells))
    return lines


def plot_along(out_dir: Path) -> Path:
    """along.png: stacked basin shares (bars, 95 % Wilson error bars) and each attractor's
    dominant celerity against the value; ▲/▼ where a chain appears or vanishes."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    table = json.loads((out_dir / "along.json").read_text())
    x = np.array(table["values"])
    n = len(table["chains"])
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7.5, 7.5 + 0.22 * n), sharex=True,
                                   constrained_layout=True)
    width = 0.6 * float(np.min(np.diff(np.sort(x))))
    base = np.zeros_like(x)
    for j, (name, c) in enumerate(table["chains"].items()):
        def at(key: str, c: dict = c) -> np.ndarray:
            return np.array([(c["points"].get(str(i)) or {}).get(key) or 0.0
                             for i in range(len(x))])

        share, lo, hi = at("share"), at("share_lo"), at("share_hi")
        colour = f"C{j % 10}"
        have = share > 0
        ax1.bar(x[have], share[have], width, bottom=base[have], color=colour, alpha=0.75,
                label=c["name"])
        ax1.errorbar(x[have], (base + share)[have],
                     yerr=np.vstack([(share - lo)[have], (hi - share)[have]]), fmt="none",
                     ecolor="k", elinewidth=0.8, capsize=3)
        base = base + share
        cel = np.where(have, at("celerity_m_s"), np.nan)
        ax2.plot(x, cel, "o-", color=colour, label=name)
        for values, marker, step in ((c["appears"], "^", 0), (c["vanishes"], "v", -1)):
            for v in values:
                k = int(np.argmin(np.abs(x - v))) + step
                ax2.plot(x[k], cel[k], marker, ms=12, mfc="none", color=colour)
    counted = np.array([p["starts"] > 0 for p in table["points"]])
    ax1.bar(x[counted], (1.0 - base)[counted], width, bottom=base[counted], color="0.85",
            label="no attractor (unsettled, transient, steady sliding, ...)")
    ax1.set(ylabel="basin share (stacked; 95 % Wilson bars)", ylim=(0, 1.05),
            title="attractors along " + table["key"])
    if table["chains"]:
        fig.legend(*ax1.get_legend_handles_labels(), fontsize=7, loc="outside lower center",
                   ncol=1, frameon=False)
    else:
        ax1.text(0.5, 0.5, "no attractor at any point", ha="center", transform=ax1.transAxes)
    ax2.set(xlabel=table["key"], ylabel="dominant celerity (m/s; + with the rotation)")
    ax2.axhline(0.0, color="0.7", lw=0.8)
    path = out_dir / "along.png"
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
