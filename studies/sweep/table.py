"""The sweep directory's table: per-scene state from ``summary.json``, ``sweep.{csv,json}``.

Rank 0 rebuilds the table (atomically) from the summaries whenever a scene finishes, so a
killed sweep loses at most the scenes in flight. A scene whose summary holds a final status
for the same resolved scene is done; a re-run skips it.
"""

from __future__ import annotations

import csv
import io
import json
import math
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from stickslip.solver.atomic import atomic_write_text
from stickslip.solver.scene import (
    Scene,
    SceneError,
    load_scene,
    scene_to_dict,
)
from stickslip.studies.output import process_alive
from stickslip.studies.rundir.ownership import owned, user_entries
from stickslip.studies.rundir.readers import (
    ReadError,
    read_json_object,
    read_summary,
    read_sweep_table,
)
from stickslip.studies.sweep.spec import (
    _TABLE_FIELDS,
    FINAL_STATUSES,
    SWEEP_KIND,
    SweepError,
    SweepSpec,
    Task,
    scene_for,
)

# ============================================================================ run directory


def _read_json(path: Path) -> dict | None:
    """The JSON object in ``path``, or None (missing, corrupt, not an object)."""
    try:
        return read_json_object(path)
    except ReadError:
        return None


def run_summary(run_dir: Path) -> dict | None:
    """The scene's summary if ``run_dir`` is stickslip's run directory and its summary is
    valid; None otherwise (a garbage, deleted or foreign summary: the scene runs again)."""
    if not owned(run_dir, "run"):
        return None
    try:
        return read_summary(run_dir)
    except ReadError:
        return None


def _foreign(run_dir: Path) -> bool:
    """A non-empty ``runs/ID`` without stickslip's marker: a user's folder, never written."""
    return bool(user_entries(run_dir)) and not owned(run_dir, "run")


def is_sweep_dir(path: str | Path) -> bool:
    """True if ``path`` is a sweep directory (holds a ``sweep.json`` written by a sweep)."""
    meta = _read_json(Path(path) / "sweep.json")
    return bool(meta) and meta.get("kind") == SWEEP_KIND


def _same_scene(run_dir: Path, scene: Scene, summary: dict | None = None) -> bool:
    """The run in ``run_dir`` ran ``scene``, or ran it and more (``_continued_past``)."""
    try:
        done = load_scene(run_dir / "scene.toml")
    except (SceneError, OSError):
        return False
    a, b = scene_to_dict(done), scene_to_dict(scene)
    return a == b or _continued_past(a, b, summary or {})


def _continued_past(done: dict, wanted: dict, summary: dict) -> bool:
    """A run continued beyond the wanted end time (``stickslip continue``, a census's
    settle-or-extend: a later ``time.end_time``, no ``time.max_steps``), the rest of its
    scene the wanted one, its summary at or past the wanted end: the wanted run, and more.
    Run again from t = 0 it would lose the longer run."""
    def rest(d: dict) -> dict:
        return {**d, "time": {k: v for k, v in d.get("time", {}).items()
                              if k not in ("end_time", "max_steps")}}

    end = float(wanted.get("time", {}).get("end_time", math.inf))
    return (rest(done) == rest(wanted) and not done.get("time", {}).get("max_steps")
            and float(done.get("time", {}).get("end_time", 0.0)) >= end
            and float(summary.get("sim_time_s") or 0.0) >= end * (1.0 - 1e-9))


#: ``sweep.json``'s record of the scenes that failed where their own ``summary.json`` could
#: not say so (a full disk): id -> message. The scene's next final summary supersedes it.
FAILURES = "unrecorded_failures"


def recorded_failures(out_dir: Path) -> dict[str, str]:
    """The failures that ``sweep.json`` records for scenes whose summary could not (id ->
    message); empty without a table."""
    found = (_read_json(Path(out_dir) / "sweep.json") or {}).get(FAILURES)
    return {str(k): str(v) for k, v in found.items()} if isinstance(found, dict) else {}


def task_state(out_dir: Path, spec: SweepSpec, task: Task, scene: Scene | None = None,
               failures: dict[str, str] | None = None) -> str:
    """``pending``, ``changed`` (finished, but for another scene), ``unanalysed`` (saved, but
    killed before its wave analysis was added: run again), ``failed`` where the table
    records a failure that the summary could not (``failures``: :func:`recorded_failures`,
    read here if None), or the summary's status."""
    run_dir = out_dir / "runs" / task.id
    summary = run_summary(run_dir)
    if summary is None:
        state = "foreign" if _foreign(run_dir) else "pending"
    elif str(summary.get("status")) in FINAL_STATUSES \
            and not _same_scene(run_dir, scene or scene_for(spec, task), summary):
        return "changed"
    else:
        state = live_status(summary)
    if state not in FINAL_STATUSES and state != "foreign":
        if task.id in (recorded_failures(out_dir) if failures is None else failures):
            return "failed"
    return state


def check_recorded(run_dir: Path, summary: dict, failures: dict[str, str] | None,
                   task_id: str) -> str:
    """The scene's status, ``failed`` where its ``summary.json`` on disk does not hold the
    run's final word (a write failed: a full disk); such a failure goes into ``failures``."""
    status = str(summary.get("status", "failed"))
    disk = run_summary(run_dir)
    on_disk = live_status(disk) if disk is not None else "missing"
    if status in FINAL_STATUSES and on_disk != status:
        if failures is not None:
            failures[task_id] = str(summary.get("message") or (
                f"the run ended {status} but its summary.json says {on_disk}"))
        return "failed"
    return status


def live_status(summary: dict) -> str:
    """The summary's status, with a ``running`` one whose process is gone shown as ``crashed``
    and a saved run whose wave analysis is still ``pending`` shown as ``unanalysed``.

    ``stickslip run`` records ``pid`` and ``host`` while running; a killed process (SIGKILL,
    out of memory) cannot update its summary, so the table tells it from a live one here.
    A run is saved before its analysis is added (``studies.rundir.scene_run._save``); one
    killed in between is not final, and a resumed sweep runs it again.
    """
    status = str(summary.get("status", "pending"))
    if status == "running" and process_alive(summary) is False:
        return "crashed"
    if summary.get("analysis") == "pending":
        return "unanalysed"
    return status


def _row(spec_keys: Sequence[str], task: Task, summary: dict | None, run_dir: str,
         out_dir: Path | None = None) -> dict:
    row: dict[str, Any] = {"id": task.id}
    row.update({k: task.params.get(k) for k in spec_keys})
    s = summary or {}
    fr = s.get("fractions") if isinstance(s.get("fractions"), dict) else {}
    status = live_status(s) if s else "pending"
    if not s and out_dir is not None and _foreign(out_dir / run_dir):
        status = "foreign"
        s = {"message": f"{run_dir} holds files stickslip did not write: move them out and "
                        "run the sweep again"}
    row.update({
        "status": status,
        "regime": "diverged" if status == "diverged" else s.get("regime"),
        "mode": s.get("mode"),
        "celerity_m_s": s.get("celerity_m_s"),
        "frequency_hz": s.get("frequency_hz"),
        "fraction_separation": fr.get("separation"),
        "fraction_stick": fr.get("stick"),
        "fraction_slip": fr.get("slip"),
        "amplitude_m": s.get("amplitude_m"),
        "limit_cycle": s.get("limit_cycle"),
        "steps": s.get("steps"),
        "dofs": s.get("dofs"),
        "ranks": s.get("ranks"),
        "wall_time_s": s.get("wall_time_s"),
        "aliased": aliased(s),
        "message": "; ".join([*([str(s["message"])] if s.get("message") else []),
                              *(f"warning: {w}" for w in run_warnings(s))]) or None,
        "run_dir": run_dir,
    })
    return row


def run_warnings(summary: dict) -> list[str]:
    """The warnings a run's summary holds (``warnings``: the scene's doubtful choices and
    aliased samples, ``studies.rundir.writer.run_warnings``); a summary that holds only the
    analysis's ``warning`` gives that one."""
    found = summary.get("warnings")
    if isinstance(found, list):
        return [str(w) for w in found]
    return [str(summary["warning"])] if summary.get("warning") else []


def aliased(summary: dict) -> bool | None:
    """Whether the run's samples alias its wave (the probe's frequency above the samples'
    Nyquist frequency: ``postprocess.resolution.sampling_check``), so that its ``mode``,
    ``celerity_m_s`` and ``frequency_hz`` are not the run's; None where it was not checked."""
    probe, nyquist = summary.get("probe_frequency_hz"), summary.get("nyquist_hz")
    if not isinstance(probe, int | float) or not isinstance(nyquist, int | float):
        return None
    return bool(probe > nyquist)


def _meta(spec: SweepSpec) -> dict[str, Any]:
    m = spec.map
    return {
        "kind": SWEEP_KIND,
        "name": spec.name,
        "description": spec.description,
        "sweep_file": str(spec.path),
        "base": str(spec.base),
        "set": list(spec.set),
        "group_size": spec.group_size,
        "parameters": list(spec.keys),
        "map": {"x": m.x, "y": m.y, "xscale": m.xscale, "yscale": m.yscale,
                "semianalytic": m.semianalytic, "k": list(m.k), "junctions": list(m.junctions)},
    }


def write_table(out_dir: Path, spec: SweepSpec, extra: dict | None = None,
                cache: dict[str, tuple[float, dict | None]] | None = None,
                failures: dict[str, str] | None = None) -> list[dict]:
    """Rebuild ``sweep.json`` and ``sweep.csv`` from every scene's ``summary.json``.

    ``cache`` (id -> (mtime, summary)) avoids re-reading unchanged summaries. ``failures``
    (id -> message; None: those the table records now) are scenes that failed where their
    summary could not say so: their rows read ``failed`` until a final summary supersedes.
    """
    rows = []
    cache = {} if cache is None else cache
    failures = dict(recorded_failures(out_dir) if failures is None else failures)
    for task in spec.tasks:
        path = out_dir / "runs" / task.id / "summary.json"
        try:
            mtime = path.stat().st_mtime
        except OSError:
            mtime = -1.0
        if task.id not in cache or cache[task.id][0] != mtime:
            cache[task.id] = (mtime, run_summary(path.parent) if mtime >= 0 else None)
        row = _row(spec.keys, task, cache[task.id][1], f"runs/{task.id}", out_dir)
        if task.id in failures:
            if row["status"] in FINAL_STATUSES or row["status"] == "foreign":
                del failures[task.id]  # the scene's own final word
            else:
                row.update(status="failed", message=failures[task.id])
        rows.append(row)
    counts: dict[str, int] = {}
    for r in rows:
        counts[r["status"]] = counts.get(r["status"], 0) + 1
    meta = _meta(spec)
    meta.update(extra or {})
    meta.update({"updated": time.strftime("%Y-%m-%dT%H:%M:%S"), "counts": counts,
                 FAILURES: failures, "rows": rows})
    atomic_write_text(out_dir / "sweep.json", json.dumps(meta, indent=1, default=str) + "\n")
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=["id", *spec.keys, *_TABLE_FIELDS],
                            lineterminator="\n")
    writer.writeheader()
    for r in rows:
        writer.writerow({k: ("" if v is None else v) for k, v in r.items()})
    atomic_write_text(out_dir / "sweep.csv", buf.getvalue())
    return rows


def read_table(sweep_dir: str | Path) -> dict:
    """The ``sweep.json`` of a sweep directory (meta plus ``rows``)."""
    if not (Path(sweep_dir) / "sweep.json").is_file():
        raise SweepError(f"{sweep_dir} is not a sweep directory (no sweep.json)")
    return read_sweep_table(sweep_dir, SWEEP_KIND)


