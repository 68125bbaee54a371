"""A census at every point of a sweep: the ``[attractors]`` table of a sweep file.

    [attractors]
    starts = 16          # M random starts per grid point (required, >= 1)
    seed = 1             # optional, as ``stickslip attractors``: seeds S .. S + M - 1
    n_modes = 16         # optional: modes 1 .. K of the random start
    amplitude = 0.1      # optional: in units of d
    celerity_tol = 0.02  # optional: members
    spread_tol = 0.10    # optional: rigid waves

``expand`` turns every point of the sweep into M scenes (the point's values plus
``initial.perturbation = "random"`` and its seed); ``run_map`` runs them with the sweep
machinery (batched, resumable) and writes, per point, the census's answer
(``attractors_map.{json,csv}``): the dominant member and its share, the number of
attractors (settled members, rigid or multi-wave), and the probability of
stick-slip-separation with its 95 % Wilson interval. The sweep's regime map draws them
when the sweep directory holds ``attractors_map.json``
(``studies.sweep.regime_map.census_cells``).
"""

from __future__ import annotations

import csv
import io
import json
import math
import sys
from dataclasses import replace
from pathlib import Path
from typing import TextIO

from stickslip.solver.atomic import atomic_write_text
from stickslip.solver.scene import SceneError
from stickslip.studies.attractors.classify import CELERITY_TOL, SPREAD_TOL, group_members, start_row
from stickslip.studies.attractors.starts import (
    DEFAULT_AMPLITUDE,
    DEFAULT_N_MODES,
    DEFAULT_SEED,
    StartDistribution,
)
from stickslip.studies.attractors.statistics import COUNTED, SETTLED, mesh_members, wilson
from stickslip.studies.rundir.ownership import KINDS, register_kind
from stickslip.studies.sweep.schedule import run_sweep
from stickslip.studies.sweep.spec import SweepError, Task, scene_for
from stickslip.studies.sweep.table import _read_json, live_status

#: The per-point table of a census map, in the sweep directory (``.csv`` beside it).
MAP_FILE = "attractors_map.json"
_KEYS = ("starts", "seed", "n_modes", "amplitude", "celerity_tol", "spread_tol")
MAP_FIELDS = ("point", "starts", "finished", "attractors", "dominant", "dominant_share",
              "dominant_lo", "dominant_hi", "p_sss", "p_sss_lo", "p_sss_hi", "diverged",
              "failed", "members")


def distribution(table: dict, where: str) -> tuple[StartDistribution, float, float]:
    """The ``[attractors]`` table -> (start distribution, celerity_tol, spread_tol)."""
    unknown = set(table) - set(_KEYS)
    if unknown:
        raise SweepError(f"{where}: unknown key(s) attractors.{', '.join(sorted(unknown))} "
                         f"(allowed: {', '.join(_KEYS)})")
    starts = table.get("starts")
    if isinstance(starts, bool) or not isinstance(starts, int) or starts < 1:
        raise SweepError(f"{where}: attractors.starts = {starts!r} must be an integer >= 1")
    try:
        dist = StartDistribution(starts=starts, seed=int(table.get("seed", DEFAULT_SEED)),
                                 n_modes=int(table.get("n_modes", DEFAULT_N_MODES)),
                                 amplitude=float(table.get("amplitude", DEFAULT_AMPLITUDE)))
    except (TypeError, ValueError) as err:
        raise SweepError(f"{where}: [attractors]: {err}") from None
    tols = (float(table.get("celerity_tol", CELERITY_TOL)),
            float(table.get("spread_tol", SPREAD_TOL)))
    return dist, *tols


def expand(spec):  # noqa: ANN001, ANN201 - SweepSpec -> SweepSpec
    """Every point of ``spec`` x the M random starts of its ``[attractors]`` table."""
    dist, _, _ = distribution(spec.attractors, str(spec.path))
    extra = {"initial.perturbation": "random", "initial.n_modes": dist.n_modes,
             "initial.amplitude": dist.amplitude}
    tasks = tuple(Task(f"{t.id}_seed-{s}", {**t.params, **extra, "initial.seed": s})
                  for t in spec.tasks for s in dist.seeds)
    out = replace(spec, tasks=tasks, keys=(*spec.keys, *extra, "initial.seed"))
    for task in tasks[:: max(1, dist.starts)]:  # one start per point: the rest differ by seed
        try:
            scene_for(out, task)
        except SceneError as err:
            raise SweepError(f"{spec.path}: [attractors] at {task.id}: {err}") from None
    return out


def run_map(spec, out_dir: Path, *, comm=None, stream: TextIO | None = None,  # noqa: ANN001
            **sweep_options) -> int:
    """Run the census of every point (collective); rank 0 writes attractors_map.*
    (``stream``: where the lines go, sys.stdout as the call finds it by default)."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD if comm is None else comm
    stream = sys.stdout if stream is None else stream
    if "attractors_map.*" not in KINDS["sweep"]:  # the map's files belong to its sweep
        register_kind("sweep", (*KINDS["sweep"], "attractors_map.*"))
    try:
        expanded = expand(spec)
    except SweepError as err:
        if comm.rank == 0:
            print(f"error: {err}", file=sys.stderr, flush=True)
        return 2
    rc = run_sweep(expanded, out_dir, comm=comm, stream=stream, **sweep_options)
    if comm.rank == 0 and rc != 2:
        points = map_table(spec, expanded, Path(out_dir))
        for p in points:
            print(f"{p['point']}: {p['attractors']} attractor(s); dominant {p['dominant']} "
                  f"({100 * p['dominant_share']:.0f} %); P(SSS) = {100 * p['p_sss']:.0f} % "
                  f"[{100 * p['p_sss_lo']:.0f}, {100 * p['p_sss_hi']:.0f}]", file=stream)
        print(f"attractor map: {Path(out_dir) / 'attractors_map.csv'}", file=stream,
              flush=True)
    return rc


def map_table(spec, expanded, out_dir: Path) -> list[dict]:  # noqa: ANN001
    """Per point: the census's dominant member, number of attractors, P(SSS)."""
    _, celerity_tol, spread_tol = distribution(spec.attractors, str(spec.path))
    per_point: dict[str, list[dict]] = {t.id: [] for t in spec.tasks}
    for task in expanded.tasks:
        point = task.id.rsplit("_seed-", 1)[0]
        run_dir = out_dir / "runs" / task.id
        summary = _read_json(run_dir / "summary.json")
        status = live_status(summary) if summary else "pending"
        row = start_row(run_dir, {"initial.perturbation": "random",
                                  "initial.seed": task.params["initial.seed"]},
                        summary, status, spread_tol)
        per_point[point].append(row)
    points = []
    for task in spec.tasks:
        rows = per_point[task.id]
        group_members(rows, celerity_tol)
        members = mesh_members(rows)
        counted = [r for r in rows if r["class"] in COUNTED]
        n_sss = sum(r["regime"] == "stick-slip-separation" and r["class"] in (
            "wave", "multi-wave", "transient", "unsettled") for r in counted)
        lo, hi = wilson(n_sss, len(counted))
        top = members[0] if members else None
        points.append({
            "point": task.id, **task.params, "starts": len(rows), "finished": len(counted),
            "attractors": sum(m["class"] in SETTLED for m in members),
            "dominant": top["member"] if top else None,
            "dominant_share": top["share"] if top else math.nan,
            "dominant_lo": top["share_lo"] if top else math.nan,
            "dominant_hi": top["share_hi"] if top else math.nan,
            "p_sss": n_sss / len(counted) if counted else math.nan, "p_sss_lo": lo,
            "p_sss_hi": hi, "diverged": sum(r["class"] == "diverged" for r in rows),
            "failed": sum(r["class"] == "failed" for r in rows),
            "members": "; ".join(f"{m['member']} {m['count']}" for m in members),
            "table": members})
    _write(out_dir, spec, points)
    return points


def _write(out_dir: Path, spec, points: list[dict]) -> None:  # noqa: ANN001
    """attractors_map.json (NaN and infinities as null) and attractors_map.csv."""
    meta = {"kind": "stickslip-attractor-map", "name": spec.name, "keys": list(spec.keys),
            "attractors": spec.attractors, "map": {"x": spec.map.x, "y": spec.map.y},
            "points": points}
    finite = json.loads(json.dumps(meta, default=str), parse_constant=lambda _: None)
    atomic_write_text(out_dir / MAP_FILE, json.dumps(finite, indent=1) + "\n")
    buf = io.StringIO()
    fields = [*spec.keys, *MAP_FIELDS]
    w = csv.DictWriter(buf, fieldnames=fields, lineterminator="\n", extrasaction="ignore")
    w.writeheader()
    for p in points:
        w.writerow({k: "" if p.get(k) is None else p.get(k) for k in fields})
    atomic_write_text(out_dir / "attractors_map.csv", buf.getvalue())


