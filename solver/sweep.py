"""Batch sweeps: ``stickslip sweep SWEEP.toml`` runs a grid/list of scene variants under mpirun.

A sweep file names a base scene and the parameters to vary (dotted scene keys, as for
``stickslip run --set``)::

    name = "omega_delta"
    base = "../scenes/figure3_n36.toml"     # relative to this file, or a shipped scene name
    group_size = 1                           # MPI ranks per scene (default 1)
    set = ["time.end_time=0.3"]              # applied to every scene
    [grid]                                   # Cartesian product, in this key order
    "loading.omega" = [2.0, 10.0, 50.0]
    "geometry.delta" = [2e-4, 1e-3]
    [[points]]                               # and/or an explicit list (x grid if both)
    "initial.seed" = 3
    [map]                                    # regime map (``stickslip plot SWEEP_DIR``)
    x = "loading.omega"
    y = "geometry.delta"
    k = [4]                                  # wavenumbers of the semi-analytical boundary

Execution (``run_sweep``): COMM_WORLD is split into groups of ``group_size`` ranks; the leader
of each group takes the next pending scene from a shared counter on rank 0 (MPI-3 passive
target ``Fetch_and_op``), so every rank works and a slow scene only occupies its own group.
Each scene runs with ``solver.run.run_scene`` into ``SWEEP_DIR/runs/<id>/``, its console
output goes to ``SWEEP_DIR/logs/<id>.log`` (appended: one ``== start`` line per attempt).

Resume and faults: a scene whose ``summary.json`` holds a final status (completed, diverged,
failed) for the same resolved scene is skipped; ``running``/``interrupted`` ones (killed in
flight) run again. An exception inside a scene is recorded as status ``failed`` with its
message and the sweep goes on. Rank 0 rebuilds the table ``SWEEP_DIR/sweep.{csv,json}``
(atomically) from the summaries whenever a scene finishes, so a killed sweep loses at most
the scenes in flight.
"""

from __future__ import annotations

import argparse
import csv
import io
import itertools
import json
import math
import os
import re
import sys
import threading
import time
import tomllib
import traceback
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

from solver.atomic import atomic_write_text
from solver.scene import (
    Scene,
    SceneError,
    load_scene,
    parse_override,
    scene_to_dict,
    write_scene,
)

if TYPE_CHECKING:  # pragma: no cover
    from mpi4py import MPI

__all__ = [
    "FINAL_STATUSES",
    "REGIMES",
    "MapSpec",
    "SweepError",
    "SweepSpec",
    "Task",
    "existence_grid",
    "is_sweep_dir",
    "load_sweep",
    "plot_sweep",
    "read_table",
    "register",
    "run_sweep",
    "scene_for",
]

SWEEP_KIND = "stickslip-sweep"
#: A scene with one of these statuses is done; a re-run skips it.
FINAL_STATUSES = ("completed", "diverged", "failed")
#: Regime categories of the map (``diverged`` = the explicit scheme blew up).
REGIMES = ("steady-sliding", "stick-slip", "slip-separation", "stick-slip-separation",
           "diverged")
_TOP_KEYS = ("name", "description", "base", "group_size", "output", "set", "grid", "points",
             "map")
_MAP_KEYS = ("x", "y", "xscale", "yscale", "semianalytic", "k", "junctions")
#: Scene keys that enter the reduced model (semi-analytical existence boundary).
_SEMIANALYTIC_KEYS = ("loading.omega", "loading.f", "geometry.delta", "geometry.d",
                      "geometry.xi", "geometry.R", "material.nu", "material.wave_speed",
                      "material.E", "material.rho")
_TABLE_FIELDS = ("status", "regime", "mode", "celerity_m_s", "frequency_hz",
                 "fraction_separation", "fraction_stick", "fraction_slip", "amplitude_m",
                 "limit_cycle", "steps", "dofs", "ranks", "wall_time_s", "message", "run_dir")


class SweepError(ValueError):
    """Invalid sweep file or sweep directory (the message names the key and the fix)."""


# ============================================================================ sweep files


@dataclass(frozen=True)
class Task:
    """One scene of the sweep: its id (directory name) and its swept parameter values."""

    id: str
    params: dict[str, Any]

    @property
    def overrides(self) -> tuple[str, ...]:
        return tuple(f"{k}={_toml_value(v)}" for k, v in self.params.items())


@dataclass(frozen=True)
class MapSpec:
    """Axes and overlays of the regime map."""

    x: str | None = None
    y: str | None = None
    xscale: str = "auto"
    yscale: str = "auto"
    semianalytic: bool = True
    k: tuple[int, ...] = ()
    junctions: tuple[str, ...] = ("impact",)


@dataclass(frozen=True)
class SweepSpec:
    """A parsed, validated sweep file."""

    name: str
    path: Path
    base: Path
    base_scene: Scene
    set: tuple[str, ...]
    keys: tuple[str, ...]
    tasks: tuple[Task, ...]
    group_size: int = 1
    output: Path | None = None
    description: str = ""
    map: MapSpec = field(default_factory=MapSpec)


def _toml_value(v: Any) -> str:
    """A Python value as a TOML value (for ``key=value`` overrides)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return repr(int(v))
    if isinstance(v, float):
        return repr(float(v))
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise SweepError(f"cannot use value {v!r} of type {type(v).__name__} in a sweep")


def _dotted(table: dict[str, Any]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in table.items():
        if isinstance(value, dict):
            out.update({f"{key}.{sub}": v for sub, v in _dotted(value).items()})
        else:
            out[key] = value
    return out


def _flatten(table: dict[str, Any], where: str) -> dict[str, Any]:
    """Nested ``{"loading": {"omega": x}}`` or dotted ``{"loading.omega": x}`` -> dotted."""
    out = _dotted(table)
    for key in out:
        try:
            parse_override(f"{key}=0")
        except SceneError as err:
            raise SweepError(f"{where}: {err}") from None
    return out


def _slug_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return repr(v).replace("e+", "e")
    if isinstance(v, list | tuple):
        return "+".join(_slug_value(x) for x in v)
    return str(v)


def _task_id(params: dict[str, Any], leaves: dict[str, str]) -> str:
    text = "_".join(f"{leaves[k]}-{_slug_value(v)}" for k, v in params.items()) or "base"
    return re.sub(r"[^A-Za-z0-9_.\-]", "_", text)


def _resolve_base(base: str, sweep_path: Path) -> Path:
    candidates = [sweep_path.parent / base, Path(base)]
    for c in candidates:
        if c.is_file():
            return c.resolve()
    try:  # a shipped scene name ("figure3_n36")
        from solver.scene import SCENES_DIR

        shipped = SCENES_DIR / f"{Path(base).stem}.toml"
        if Path(base).parent == Path(".") and shipped.is_file():
            return shipped
    except ImportError:  # pragma: no cover
        pass
    raise SweepError(f"{sweep_path}: base = {base!r} not found (relative to the sweep file, "
                     "the current directory, or a shipped scene name)")


def load_sweep(path: str | Path) -> SweepSpec:
    """Parse and validate a sweep file; every scene is built once here (fail early)."""
    p = Path(path)
    if not p.is_file():
        raise SweepError(f"sweep file {str(path)!r} not found")
    try:
        data = tomllib.loads(p.read_text())
    except tomllib.TOMLDecodeError as err:
        raise SweepError(f"{p}: invalid TOML: {err}") from None
    for key in data:
        if key not in _TOP_KEYS:
            raise SweepError(f"{p}: unknown key {key!r} (allowed: {', '.join(_TOP_KEYS)})")
    name = str(data.get("name", p.stem))
    if not re.fullmatch(r"[A-Za-z0-9_.\-]+", name):
        raise SweepError(f"{p}: name = {name!r}: use letters, digits, '_', '-', '.'")
    if "base" not in data:
        raise SweepError(f"{p}: 'base' is required (the scene file every variant starts from)")
    base = _resolve_base(str(data["base"]), p)
    group_size = data.get("group_size", 1)
    if isinstance(group_size, bool) or not isinstance(group_size, int) or group_size < 1:
        raise SweepError(f"{p}: group_size = {group_size!r} must be an integer >= 1")
    raw_set = data.get("set", [])
    if isinstance(raw_set, dict):
        fixed = tuple(f"{k}={_toml_value(v)}"
                      for k, v in _flatten(raw_set, f"{p} [set]").items())
    elif isinstance(raw_set, list) and all(isinstance(s, str) for s in raw_set):
        fixed = tuple(raw_set)
    else:
        raise SweepError(f"{p}: set must be a list of 'key=value' strings or a table")
    try:
        base_scene = load_scene(base, fixed)
    except SceneError as err:
        raise SweepError(f"{p}: base scene: {err}") from None

    grid = _flatten(data.get("grid", {}), f"{p} [grid]")
    for key, values in grid.items():
        if not isinstance(values, list) or not values:
            raise SweepError(f"{p}: [grid] {key} = {values!r} must be a non-empty list")
    raw_points = data.get("points", [])
    if not isinstance(raw_points, list) or not all(isinstance(x, dict) for x in raw_points):
        raise SweepError(f"{p}: points must be an array of tables ([[points]])")
    points = [_flatten(pt, f"{p} [[points]] #{i + 1}") for i, pt in enumerate(raw_points)]
    keys: list[str] = []
    for d in [*points, grid]:
        keys += [k for k in d if k not in keys]
    combos = [dict(zip(grid, vals, strict=True)) for vals in itertools.product(*grid.values())]
    params_list: list[dict[str, Any]] = []
    for pt in points or [{}]:
        for combo in combos:
            clash = set(pt) & set(combo)
            if clash:
                raise SweepError(f"{p}: {sorted(clash)} both in [grid] and in [[points]]")
            merged = {**pt, **combo}
            params_list.append({k: merged[k] for k in keys if k in merged})
    leaves_count: dict[str, int] = {}
    for k in keys:
        leaves_count[k.rsplit(".", 1)[-1]] = leaves_count.get(k.rsplit(".", 1)[-1], 0) + 1
    leaves = {k: k.rsplit(".", 1)[-1] if leaves_count[k.rsplit(".", 1)[-1]] == 1 else k
              for k in keys}
    tasks, seen = [], set()
    for params in params_list:
        tid = _task_id(params, leaves)
        if tid in seen:
            raise SweepError(f"{p}: scene {tid!r} appears twice (duplicate grid/points values)")
        seen.add(tid)
        tasks.append(Task(tid, params))

    raw_map = data.get("map", {})
    for key in raw_map:
        if key not in _MAP_KEYS:
            raise SweepError(f"{p}: unknown key map.{key} (allowed: {', '.join(_MAP_KEYS)})")
    for axis in ("x", "y"):
        if raw_map.get(axis) is not None and raw_map[axis] not in keys:
            raise SweepError(f"{p}: map.{axis} = {raw_map[axis]!r} is not a swept key "
                             f"({', '.join(keys)})")
    for axis in ("xscale", "yscale"):
        if raw_map.get(axis, "auto") not in ("auto", "linear", "log"):
            raise SweepError(f"{p}: map.{axis} must be 'auto', 'linear' or 'log'")
    ks = raw_map.get("k", [])
    if not isinstance(ks, list) or not all(isinstance(k, int) and k >= 1 for k in ks):
        raise SweepError(f"{p}: map.k must be a list of wavenumbers >= 1")
    junctions = raw_map.get("junctions", ["impact"])
    if not set(junctions) <= {"impact", "smooth"}:
        raise SweepError(f"{p}: map.junctions must be a subset of ['impact', 'smooth']")
    spec = SweepSpec(
        name=name, path=p.resolve(), base=base, base_scene=base_scene, set=fixed,
        keys=tuple(keys), tasks=tuple(tasks), group_size=group_size,
        output=p.parent / str(data["output"]) if data.get("output") else None,
        description=str(data.get("description", "")),
        map=MapSpec(x=raw_map.get("x"), y=raw_map.get("y"),
                    xscale=raw_map.get("xscale", "auto"), yscale=raw_map.get("yscale", "auto"),
                    semianalytic=bool(raw_map.get("semianalytic", True)), k=tuple(ks),
                    junctions=tuple(junctions)),
    )
    for task in spec.tasks:  # every variant must be a valid scene before anything runs
        try:
            scene_for(spec, task)
        except SceneError as err:
            raise SweepError(f"{p}: scene {task.id}: {err}") from None
    return spec


def scene_for(spec: SweepSpec, task: Task) -> Scene:
    """The resolved scene of ``task``: base + ``set`` + the task's values, progress off."""
    return spec.base_scene.with_overrides(
        *task.overrides, "output.progress=false", f'name="{spec.name}.{task.id}"')


def _cost(scene: Scene) -> float:
    """Relative cost estimate (largest first = LPT order): dofs ~ N^2, steps ~ N t_end.

    With automatic layers the explicit step is dt ~ 1 / (360 N) s for the reference tube
    (N = 36: dt = 7.7e-5 s), hence steps ~ 360 N t_end, capped by ``time.max_steps``.
    """
    n = scene.mesh.n_inner * scene.mesh.degree
    steps = 360.0 * n * scene.time.end_time
    if scene.time.max_steps:
        steps = min(steps, float(scene.time.max_steps))
    return n * n * steps


# ============================================================================ run directory


def _read_json(path: Path) -> dict | None:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


def is_sweep_dir(path: str | Path) -> bool:
    """True if ``path`` is a sweep directory (holds a ``sweep.json`` written by a sweep)."""
    meta = _read_json(Path(path) / "sweep.json")
    return bool(meta) and meta.get("kind") == SWEEP_KIND


def _same_scene(run_dir: Path, scene: Scene) -> bool:
    try:
        done = load_scene(run_dir / "scene.toml")
    except (SceneError, OSError):
        return False
    a, b = scene_to_dict(done), scene_to_dict(scene)
    return a == b


def task_state(out_dir: Path, spec: SweepSpec, task: Task, scene: Scene | None = None) -> str:
    """``pending``, ``changed`` (finished, but for another scene), or the summary's status."""
    run_dir = out_dir / "runs" / task.id
    summary = _read_json(run_dir / "summary.json")
    if summary is None:
        return "pending"
    status = str(summary.get("status", "pending"))
    if status in FINAL_STATUSES and not _same_scene(run_dir, scene or scene_for(spec, task)):
        return "changed"
    return status


def _row(spec_keys: Sequence[str], task: Task, summary: dict | None, run_dir: str) -> dict:
    row: dict[str, Any] = {"id": task.id}
    row.update({k: task.params.get(k) for k in spec_keys})
    s = summary or {}
    fr = s.get("fractions") or {}
    status = s.get("status", "pending")
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
        "message": s.get("message"),
        "run_dir": run_dir,
    })
    return row


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
                cache: dict[str, tuple[float, dict | None]] | None = None) -> list[dict]:
    """Rebuild ``sweep.json`` and ``sweep.csv`` from every scene's ``summary.json``.

    ``cache`` (id -> (mtime, summary)) avoids re-reading unchanged summaries.
    """
    rows = []
    cache = {} if cache is None else cache
    for task in spec.tasks:
        path = out_dir / "runs" / task.id / "summary.json"
        try:
            mtime = path.stat().st_mtime
        except OSError:
            mtime = -1.0
        if task.id not in cache or cache[task.id][0] != mtime:
            cache[task.id] = (mtime, _read_json(path) if mtime >= 0 else None)
        rows.append(_row(spec.keys, task, cache[task.id][1], f"runs/{task.id}"))
    counts: dict[str, int] = {}
    for r in rows:
        counts[r["status"]] = counts.get(r["status"], 0) + 1
    meta = _meta(spec)
    meta.update(extra or {})
    meta.update({"updated": time.strftime("%Y-%m-%dT%H:%M:%S"), "counts": counts, "rows": rows})
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
    path = Path(sweep_dir) / "sweep.json"
    meta = _read_json(path)
    if not meta or meta.get("kind") != SWEEP_KIND:
        raise SweepError(f"{sweep_dir} is not a sweep directory (no valid sweep.json)")
    return meta


# ============================================================================ progress


def _fmt_duration(seconds: float) -> str:
    if not math.isfinite(seconds):
        return "?"
    seconds = int(round(seconds))
    h, rem = divmod(seconds, 3600)
    m, s = divmod(rem, 60)
    return f"{h}h{m:02d}m" if h else (f"{m}m{s:02d}s" if m else f"{s}s")


class _Monitor(threading.Thread):
    """Rank 0's progress and table keeper: polls the pending scenes' ``summary.json``.

    Runs beside rank 0's own scenes (no MPI calls, wakes every ``interval`` s). Each newly
    finished scene rewrites the table and prints one line; on a TTY (``live``) a status line
    with done / running / failed counts and an ETA is redrawn in place.
    """

    def __init__(self, out_dir: Path, spec: SweepSpec, pending: Sequence[Task], n_done: int,
                 stream: TextIO, live: bool, interval: float = 1.0) -> None:
        super().__init__(daemon=True, name="sweep-monitor")
        self.out_dir, self.spec, self.stream, self.live = out_dir, spec, stream, live
        self.pending = list(pending)
        self.total = len(spec.tasks)
        self.n_done_before = n_done
        self.interval = interval
        self.t0 = time.time()
        self.finished: dict[str, str] = {}
        self.failed = 0
        self.running = 0
        self.stop_event = threading.Event()
        self.cache: dict[str, tuple[float, dict | None]] = {}
        self.lock = threading.Lock()
        self._line_len = 0

    def run(self) -> None:
        while not self.stop_event.wait(self.interval):
            try:
                self.poll()
            except Exception as err:  # never let the monitor take the sweep down
                print(f"sweep monitor: {err}", file=sys.stderr, flush=True)

    def stop(self) -> None:
        self.stop_event.set()
        self.join(timeout=10)
        self.poll()
        if self.live and self._line_len:
            print(file=self.stream, flush=True)

    def poll(self) -> None:
        with self.lock:
            new = []
            running = 0
            for task in self.pending:
                if task.id in self.finished:
                    continue
                path = self.out_dir / "runs" / task.id / "summary.json"
                try:
                    mtime = path.stat().st_mtime
                except OSError:
                    continue
                if mtime < self.t0 - 1.0:  # left over from an earlier sweep
                    continue
                s = _read_json(path) or {}
                status = s.get("status")
                if status in FINAL_STATUSES or status == "interrupted":
                    new.append((task, s))
                elif status == "running":
                    running += 1
            self.running = running
            for task, s in new:
                self.finished[task.id] = s.get("status", "")
                self.failed += s.get("status") in ("failed", "diverged")
                self._say(self._scene_line(task, s))
            if new:
                write_table(self.out_dir, self.spec, cache=self.cache)
            if self.live:
                self._redraw()

    def counts(self) -> tuple[int, int, int, float]:
        done = sum(1 for st in self.finished.values() if st != "interrupted")
        elapsed = time.time() - self.t0
        left = len(self.pending) - done
        eta = elapsed / done * left if done else math.nan
        return done, self.running, self.failed, eta

    def status_line(self) -> str:
        done, running, failed, eta = self.counts()
        return (f"sweep {self.spec.name}: {self.n_done_before + done}/{self.total} done, "
                f"{running} running, {failed} failed/diverged, "
                f"elapsed {_fmt_duration(time.time() - self.t0)}, ETA {_fmt_duration(eta)}")

    def _scene_line(self, task: Task, s: dict) -> str:
        done, _, _, eta = self.counts()
        status = s.get("status")
        what = status
        if "regime" in s and status == "completed":
            what = (f"{s['regime']}, k = {s.get('mode')}, "
                    f"c = {s.get('celerity_m_s', math.nan):+.0f} m/s")
        elif s.get("message") and s["message"] != status:
            what = f"{status}: {str(s['message']).splitlines()[0][:120]}"
        return (f"[{self.n_done_before + done}/{self.total}] {task.id}: {what} "
                f"({s.get('wall_time_s', math.nan):.1f} s)  ETA {_fmt_duration(eta)}")

    def _say(self, text: str) -> None:
        if self.live and self._line_len:
            self.stream.write("\r" + " " * self._line_len + "\r")
            self._line_len = 0
        print(text, file=self.stream, flush=True)

    def _redraw(self) -> None:
        line = self.status_line()
        pad = max(0, self._line_len - len(line))
        self.stream.write("\r" + line + " " * pad)
        self.stream.flush()
        self._line_len = len(line)


def _want_live(mode: str, stream: TextIO) -> bool:
    """Live status line only on a real terminal (mpirun gives ranks a pseudo-TTY, so no)."""
    if mode in ("live", "lines"):
        return mode == "live"
    launched = any(v in os.environ for v in ("OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK"))
    return (stream.isatty() and not launched and not os.environ.get("CI")
            and os.environ.get("TERM", "") != "dumb")


# ============================================================================ execution


class _Counter:
    """Shared next-scene counter: MPI-3 atomic ``Fetch_and_op`` on a window at rank 0."""

    def __init__(self, comm: MPI.Comm) -> None:
        import numpy as np
        from mpi4py import MPI

        self.comm = comm
        self.local = 0
        self.win = None
        if comm.size > 1:
            self.win = MPI.Win.Allocate(8 if comm.rank == 0 else 0, 8, comm=comm)
            if comm.rank == 0:
                np.frombuffer(self.win.tomemory(), dtype=np.int64)[:] = 0
            self.one = np.ones(1, dtype=np.int64)
            self.res = np.zeros(1, dtype=np.int64)
            comm.Barrier()

    def next(self) -> int:
        from mpi4py import MPI

        if self.win is None:
            self.local += 1
            return self.local - 1
        self.win.Lock(0, MPI.LOCK_SHARED)
        self.win.Fetch_and_op(self.one, self.res, 0, 0, MPI.SUM)
        self.win.Unlock(0)
        return int(self.res[0])

    def free(self) -> None:
        if self.win is not None:
            self.win.Free()
            self.win = None


def _run_one(spec: SweepSpec, task: Task, out_dir: Path, group: MPI.Comm,
             world_rank: int) -> str:
    """Run one scene on ``group``; exceptions become status ``failed``. Returns the status."""
    from solver.run import run_scene

    leader = group.rank == 0
    run_dir = out_dir / "runs" / task.id
    log = open(out_dir / "logs" / f"{task.id}.log", "a") if leader else None  # noqa: SIM115
    t0 = time.perf_counter()
    status = "failed"
    try:
        if log is not None:
            log.write(f"== start {time.strftime('%Y-%m-%dT%H:%M:%S')} world rank {world_rank} "
                      f"({group.size} rank(s)) pid {os.getpid()}\n")
            log.flush()
        try:
            summary = run_scene(scene_for(spec, task), run_dir, force=True, comm=group,
                                stream=log if log is not None else sys.stdout)
            status = str(summary.get("status", "failed")) if leader else "?"
        except KeyboardInterrupt:
            status = "interrupted"
        except Exception as err:  # recorded, the sweep goes on
            status = "failed"
            if leader:
                tb = traceback.format_exc()
                assert log is not None
                log.write(tb)
                run_dir.mkdir(parents=True, exist_ok=True)
                if not (run_dir / "scene.toml").exists():  # resume compares against it
                    write_scene(scene_for(spec, task), run_dir / "scene.toml")
                prev = _read_json(run_dir / "summary.json") or {}
                prev.update({"scene": f"{spec.name}.{task.id}", "status": "failed",
                             "message": f"{type(err).__name__}: {err}",
                             "traceback": tb.splitlines()[-6:],
                             "wall_time_s": time.perf_counter() - t0, "ranks": group.size})
                atomic_write_text(run_dir / "summary.json", json.dumps(prev, indent=2))
        if group.size > 1:
            status = group.bcast(status, root=0)
    finally:
        if log is not None:
            log.write(f"== end {status}\n")
            log.close()
    return status


_PETSC_WORLD: list = []  # the group communicator PETSc was initialised on (kept alive)


def _init_petsc(group: MPI.Comm) -> None:
    """Initialise PETSc/SLEPc/dolfinx on every rank now, with the group as PETSc's world.

    ``PetscInitialize`` (the first ``import petsc4py.PETSc``, e.g. by dolfinx) is collective
    over PETSC_COMM_WORLD. Left to each group's first scene it deadlocks as soon as the
    groups start scenes at different times (a resumed sweep with one scene left: one rank
    imports PETSc while the other waits in the final barrier). ``petsc4py.init(comm=group)``
    makes every PETSc-level collective a group collective. If PETSc is already initialised
    (a caller imported dolfinx), SLEPc and dolfinx are still imported here, on all ranks.
    """
    if "petsc4py.PETSc" not in sys.modules:
        import petsc4py

        petsc4py.init(comm=group)
        _PETSC_WORLD.append(group)  # PetscFinalize uses it at exit: never free it
    import dolfinx  # noqa: F401
    from petsc4py import PETSc  # noqa: F401
    from slepc4py import SLEPc  # noqa: F401


def _prepare(out_dir: Path, spec: SweepSpec, retry_failed: bool) -> tuple[list[Task], int]:
    """Rank 0: create the sweep directory, classify the scenes, write the initial table."""
    (out_dir / "runs").mkdir(parents=True, exist_ok=True)
    (out_dir / "logs").mkdir(exist_ok=True)
    atomic_write_text(out_dir / "sweep.toml", spec.path.read_text())
    pending: list[tuple[float, int, Task]] = []
    n_done = 0
    for i, task in enumerate(spec.tasks):
        scene = scene_for(spec, task)
        state = task_state(out_dir, spec, task, scene)
        redo = retry_failed and state in ("failed", "diverged")
        if state in FINAL_STATUSES and not redo:
            n_done += 1
        else:
            pending.append((-_cost(scene), i, task))
    pending.sort(key=lambda x: (x[0], x[1]))
    write_table(out_dir, spec)
    return [t for _, _, t in pending], n_done


def _lock(out_dir: Path):  # noqa: ANN202
    """Exclusive lock on the sweep directory (a second sweep on it refuses to start)."""
    import fcntl

    fh = open(out_dir / ".lock", "w")  # noqa: SIM115
    try:
        fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        fh.close()
        raise SweepError(f"another sweep is running in {out_dir} (lock {out_dir / '.lock'})"
                         ) from None
    return fh


def run_sweep(spec: SweepSpec, out_dir: str | Path, *, comm: MPI.Comm | None = None,
              group_size: int | None = None, retry_failed: bool = False,
              stream: TextIO = sys.stdout, progress: str = "auto") -> int:
    """Run every pending scene of ``spec`` into ``out_dir``; collective over ``comm``.

    Returns 0 (every scene final, none ``failed``), 1 (the table holds a scene that failed
    with an exception), 130 (interrupted: the table holds what finished; run again to resume).
    """
    import signal

    from mpi4py import MPI

    comm = MPI.COMM_WORLD if comm is None else comm
    out_dir = Path(out_dir)
    g = group_size or spec.group_size
    rank0 = comm.rank == 0
    info: tuple | str | None = None
    lock = None
    t_start = time.time()
    if rank0:
        try:
            out_dir.mkdir(parents=True, exist_ok=True)
            lock = _lock(out_dir)
            pending, n_done = _prepare(out_dir, spec, retry_failed)
            info = ([t.id for t in pending], n_done)
        except (SweepError, OSError) as err:
            info = str(err)
    info = comm.bcast(info, root=0)
    if isinstance(info, str):
        if rank0:
            print(f"error: {info}", file=sys.stderr, flush=True)
            if lock is not None:
                lock.close()
        return 2
    by_id = {t.id: t for t in spec.tasks}
    pending = [by_id[i] for i in info[0]]
    n_done = info[1]
    color = comm.rank // g
    n_groups = (comm.size + g - 1) // g
    group = comm.Split(color, comm.rank)
    _init_petsc(group)
    monitor = None
    if rank0:
        print(f"sweep {spec.name}: {len(spec.tasks)} scenes, {n_done} already done, "
              f"{len(pending)} to run on {n_groups} group(s) of {g} rank(s) -> {out_dir}",
              file=stream, flush=True)
        if comm.size % g:
            print(f"  note: {comm.size} ranks are not a multiple of group_size {g}; the last "
                  f"group has {comm.size % g} rank(s)", file=stream, flush=True)
        monitor = _Monitor(out_dir, spec, pending, n_done, stream, _want_live(progress, stream))
        monitor.start()

    def on_term(signum, frame):  # noqa: ANN001, ARG001
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, on_term)
    counter = None
    interrupted = False
    try:
        counter = _Counter(comm)
        while True:
            idx = counter.next() if group.rank == 0 else 0
            if group.size > 1:
                idx = group.bcast(idx, root=0)
            if idx >= len(pending):
                break
            if _run_one(spec, pending[idx], out_dir, group, comm.rank) == "interrupted":
                interrupted = True
                break
    except KeyboardInterrupt:
        interrupted = True
    finally:
        signal.signal(signal.SIGTERM, previous)
    if not interrupted:  # collective clean-up only when every rank got here normally
        comm.Barrier()
        if counter is not None:
            counter.free()
    rc = 130
    if rank0:
        assert monitor is not None
        monitor.stop()
        session = {"started": t_start, "finished": time.time(), "ranks": comm.size,
                   "groups": n_groups, "group_size": g, "pending_at_start": len(pending),
                   "interrupted": interrupted}
        rows = write_table(out_dir, spec, extra={"last_session": session})
        counts: dict[str, int] = {}
        for r in rows:
            counts[r["status"]] = counts.get(r["status"], 0) + 1
        text = ", ".join(f"{v} {k}" for k, v in sorted(counts.items()))
        print(f"sweep {spec.name}: {text}; table {out_dir / 'sweep.csv'}"
              + ("  (interrupted: run the same command again to resume)" if interrupted else ""),
              file=stream, flush=True)
        if lock is not None:
            lock.close()
        if not interrupted:
            rc = 1 if counts.get("failed") else 0
    if not interrupted:
        rc = comm.bcast(rc, root=0)
    return rc


# ============================================================================ regime map


def _axis_scale(values: Sequence[float], scale: str) -> str:
    if scale != "auto":
        return scale
    v = [float(x) for x in values]
    return "log" if min(v) > 0 and max(v) / min(v) >= 20 else "linear"


def _edges(values: Sequence[float], scale: str) -> list[float]:
    """Cell edges around sorted ``values``: midpoints (geometric for log axes)."""
    import numpy as np

    v = np.asarray(values, dtype=float)
    t = np.log(v) if scale == "log" else v
    if t.size == 1:
        mid = np.array([t[0] - 0.5, t[0] + 0.5]) if scale == "log" else \
            np.array([t[0] - 0.5 * max(abs(t[0]), 1.0), t[0] + 0.5 * max(abs(t[0]), 1.0)])
    else:
        inner = 0.5 * (t[1:] + t[:-1])
        mid = np.concatenate([[t[0] - (inner[0] - t[0])], inner, [t[-1] + (t[-1] - inner[-1])]])
    return [float(x) for x in (np.exp(mid) if scale == "log" else mid)]


def _refine(values: Sequence[float], scale: str, factor: int) -> list[float]:
    import numpy as np

    v = np.asarray(sorted(values), dtype=float)
    if v.size < 2:
        return list(v)
    t = np.log(v) if scale == "log" else v
    fine = np.concatenate([np.linspace(a, b, factor, endpoint=False) for a, b in
                           zip(t[:-1], t[1:], strict=True)] + [t[-1:]])
    return [float(x) for x in (np.exp(fine) if scale == "log" else fine)]


def _span(values: Sequence[float], scale: str) -> list[float]:
    """``values`` plus the outer cell edges (the map is covered edge to edge).

    On a linear axis a non-positive lower edge is dropped (Ω, δ, f, ξ... must stay > 0).
    """
    if len(values) < 2:
        return list(values)
    e = _edges(values, scale)
    return ([e[0]] if e[0] > 0 else []) + list(values) + [e[-1]]


def _reduced_params(scene: Scene) -> tuple[float, float, float, float, float, float]:
    """(nu, xi, gamma, f, delta, omega) of the reduced model (paper section 2) for ``scene``."""
    from semianalytic.coefficients import gamma_from_physical

    g, m, ld = scene.geometry, scene.material, scene.loading
    return (m.nu, g.xi, gamma_from_physical(m.wave_speed, g.R, ld.omega), ld.f, g.delta,
            ld.omega)


def existence_grid(base: Scene, xkey: str, xs: Sequence[float], ykey: str, ys: Sequence[float],
                   ks: Iterable[int], *, regime: str,
                   junctions: Sequence[str] = ("impact",)) -> list[list[int]]:
    """Admissibility (0/1, rows = y) of semi-analytical waves of ``regime`` on an x-y grid.

    Uses ``semianalytic.waves.find_waves`` (eqs. [4]-[7]). A point counts when any wavenumber
    of ``ks`` has an admissible wave. Stick-slip waves: c sqrt(gamma) and psi depend only on
    (nu, xi, f, k) (docs/semianalytic.md), so the multistart runs once per (nu, xi, f, k)
    and each grid point is one Newton step (``refine_wave``) with its own admissibility check;
    stick-slip-separation waves: one multistart per point and k.
    """
    import warnings

    from semianalytic.coefficients import coefficients
    from semianalytic.waves import find_waves, refine_wave

    ks = tuple(ks)
    searched: dict[tuple, list] = {}
    out = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        for y in ys:
            row = []
            for x in xs:
                scene = base.with_overrides(f"{xkey}={_toml_value(x)}",
                                            f"{ykey}={_toml_value(y)}")
                nu, xi, gamma, f, delta, _ = _reduced_params(scene)
                if f <= 0 or delta <= 0:
                    row.append(0)
                    continue
                co = coefficients(nu, xi, gamma)
                ok = False
                for k in ks:
                    if regime == "stick-slip":
                        key = (nu, xi, f, k)
                        if key not in searched:
                            searched[key] = find_waves(co, f, k, delta, regime="stick-slip")
                        for w in searched[key]:
                            r = refine_wave(w, co, f=f, delta=delta)
                            if r is not None and r.admissible:
                                ok = True
                                break
                    else:
                        waves = find_waves(co, f, k, delta, regime="stick-slip-separation",
                                           junctions=tuple(junctions))
                        ok = any(w.admissible for w in waves)
                    if ok:
                        break
                row.append(int(ok))
            out.append(row)
    return out


def _numeric(values: Iterable[Any]) -> bool:
    return all(isinstance(v, int | float) and not isinstance(v, bool) for v in values)


def _semianalytic_overlay(sweep_dir: Path, meta: dict, base: Scene, xkey: str, xs: list,
                          xscale: str, ykey: str, ys: list, yscale: str, others: dict,
                          ks: tuple[int, ...]) -> dict:
    """Existence grids for both wave types, cached in ``semianalytic.json`` of the sweep."""
    scene = base.with_overrides(*(f"{k}={_toml_value(v)}" for k, v in others.items()))
    junctions = tuple(meta["map"].get("junctions") or ("impact",))
    # The stick-slip check is one Newton step a point: refine the axes of the reduced model 4x.
    fx = _refine(_span(xs, xscale), xscale, 4) if xkey in _SEMIANALYTIC_KEYS else list(xs)
    fy = _refine(_span(ys, yscale), yscale, 4) if ykey in _SEMIANALYTIC_KEYS else list(ys)
    physics = {k: v for k, v in scene_to_dict(scene).items()
               if k in ("material", "geometry", "loading")}  # all the reduced model sees
    key = json.dumps({"x": xkey, "y": ykey, "xs": xs, "ys": ys, "k": list(ks),
                      "junctions": list(junctions), "scene": physics},
                     sort_keys=True, default=str)
    cache_path = sweep_dir / "semianalytic.json"
    cache = _read_json(cache_path) or {}
    if key in cache:
        return cache[key]
    t0 = time.perf_counter()
    res = {
        "k": list(ks), "junctions": list(junctions),
        "stick-slip": {"x": fx, "y": fy, "admissible": existence_grid(
            scene, xkey, fx, ykey, fy, ks, regime="stick-slip")},
        "stick-slip-separation": {"x": list(xs), "y": list(ys), "admissible": existence_grid(
            scene, xkey, xs, ykey, ys, ks, regime="stick-slip-separation",
            junctions=junctions)},
    }
    res["seconds"] = time.perf_counter() - t0
    cache[key] = res
    try:
        atomic_write_text(cache_path, json.dumps(cache))
    except OSError:  # read-only sweep directory: just don't cache
        pass
    return res


_REGIME_COLORS = {
    "steady-sliding": "#d9d9d9",
    "stick-slip": "#4c9be8",
    "slip-separation": "#f5b041",
    "stick-slip-separation": "#d64541",
    "diverged": "#222222",
    "failed": "#ffffff",
}


def plot_sweep(sweep_dir: str | Path) -> list[Path]:
    """Regime map(s) of a sweep directory: ``regime_map[_<other params>].png``.

    One map per combination of the swept parameters that are not on the axes. Cells are
    coloured by the FE regime, annotated with the mode k and the celerity (m/s, + = rotation
    sense); lines mark the semi-analytical existence boundary of stick-slip (solid) and
    stick-slip-separation (dashed) waves for the wavenumbers of ``map.k`` (default: the
    modes the FE runs selected).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    from matplotlib.colors import BoundaryNorm, ListedColormap
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    sweep_dir = Path(sweep_dir)
    meta = read_table(sweep_dir)
    rows = meta["rows"]
    params = list(meta["parameters"])
    distinct = {k: sorted({_hashable(r[k]) for r in rows if r.get(k) is not None}, key=_sortkey)
                for k in params}
    varying = [k for k in params if len(distinct[k]) > 1]
    mp = meta.get("map") or {}
    xkey = mp.get("x") or (varying[0] if varying else (params[0] if params else None))
    ykey = mp.get("y") or next((k for k in varying if k != xkey), None)
    if xkey is None:
        raise SweepError(f"{sweep_dir}: nothing was swept; no map to draw")
    others = [k for k in varying if k not in (xkey, ykey)]
    base = _map_base(sweep_dir, meta)
    categories = [*REGIMES, "failed"]
    cmap = ListedColormap([_REGIME_COLORS[c] for c in categories])
    cmap.set_bad("white")
    norm = BoundaryNorm(np.arange(len(categories) + 1) - 0.5, cmap.N)
    outputs = []
    combos = list(itertools.product(*(distinct[k] for k in others))) or [()]
    for combo in combos:
        fixed = dict(zip(others, combo, strict=True))
        sel = [r for r in rows if all(_hashable(r.get(k)) == v for k, v in fixed.items())
               and r.get(xkey) is not None and (ykey is None or r.get(ykey) is not None)]
        xs = [v for v in distinct[xkey] if any(_hashable(r[xkey]) == v for r in sel)]
        ys = ([v for v in distinct[ykey] if any(_hashable(r[ykey]) == v for r in sel)]
              if ykey else [0.0])
        numeric = _numeric(xs) and _numeric(ys)
        xscale = _axis_scale(xs, mp.get("xscale", "auto")) if numeric else "linear"
        yscale = (_axis_scale(ys, mp.get("yscale", "auto")) if numeric and ykey else "linear")
        xpos = xs if numeric else list(range(len(xs)))
        ypos = ys if numeric else list(range(len(ys)))
        codes = np.full((len(ys), len(xs)), np.nan)
        fig, ax = plt.subplots(figsize=(2.0 + 1.15 * len(xs), 1.9 + 0.75 * len(ys)))
        for r in sel:
            i = ys.index(_hashable(r[ykey])) if ykey else 0
            j = xs.index(_hashable(r[xkey]))
            st, regime = r.get("status"), r.get("regime")
            cat = ("diverged" if st == "diverged" else
                   "failed" if st == "failed" else regime if st == "completed" else None)
            if cat not in categories:
                continue
            codes[i, j] = categories.index(cat)
            dark = cat in ("diverged", "stick-slip-separation")
            if st == "completed" and r.get("mode") is not None:
                text = f"k={r['mode']}\n{r['celerity_m_s']:+.0f}"
            else:
                text = {"diverged": "div.", "failed": "error"}.get(cat, "")
            ax.text(xpos[j], ypos[i], text, ha="center", va="center", fontsize=7,
                    color="white" if dark else "black",
                    bbox={"boxstyle": "round,pad=0.2", "fc": _REGIME_COLORS[cat],
                          "ec": "none", "alpha": 0.9})
        xe = _edges(xpos, xscale) if numeric else list(np.arange(len(xs) + 1) - 0.5)
        ye = (_edges(ypos, yscale) if numeric and ykey else
              list(np.arange(len(ys) + 1) - 0.5))
        ax.pcolormesh(xe, ye, np.ma.masked_invalid(codes), cmap=cmap, norm=norm,
                      edgecolors="white", linewidth=0.8)
        ax.set_xscale(xscale)
        ax.set_yscale(yscale)
        ax.minorticks_off()
        ax.set_xticks(xpos, [f"{v:g}" if numeric else str(v) for v in xs])
        ax.set_yticks(ypos, [f"{v:g}" if numeric else str(v) for v in ys])
        ax.set_xlabel(_label(xkey))
        ax.set_ylabel(_label(ykey) if ykey else "")
        if not ykey:
            ax.set_yticks([])
        handles = [Patch(facecolor=_REGIME_COLORS[c], edgecolor="0.5", label=c)
                   for c in categories if c in {categories[int(v)] for v in
                                                codes[np.isfinite(codes)].ravel()}]
        note = ""
        ks = tuple(mp.get("k") or sorted({int(r["mode"]) for r in sel
                                          if r.get("status") == "completed"
                                          and r.get("mode") is not None})[:4])
        if (mp.get("semianalytic", True) and numeric and ykey and ks
                and (xkey in _SEMIANALYTIC_KEYS or ykey in _SEMIANALYTIC_KEYS)):
            sa = _semianalytic_overlay(sweep_dir, meta, base, xkey, [float(v) for v in xs],
                                       xscale, ykey, [float(v) for v in ys], yscale, fixed, ks)
            for name, style, hatch, what in (("stick-slip", "-", "//", "solid"),
                                             ("stick-slip-separation", "--", "\\\\", "dashed")):
                g = sa[name]
                z = np.asarray(g["admissible"], dtype=float)
                found = bool(z.any())
                if found and not z.all():
                    ax.contour(g["x"], g["y"], z, levels=[0.5], colors="k", linestyles=style,
                               linewidths=1.8)
                if found:
                    ax.contourf(g["x"], g["y"], z, levels=[0.5, 1.5], colors="none",
                                hatches=[hatch])
                kset = ", ".join(map(str, ks))
                if found:
                    handles.append(Patch(facecolor="none", edgecolor="k", hatch=hatch,
                                         linestyle=style,
                                         label=f"semi-analytical {name} wave exists "
                                               f"(k ∈ {{{kset}}}; {what} boundary)"))
                else:
                    handles.append(Line2D([], [], color="0.6", linestyle=style,
                                          label=f"no admissible semi-analytical {name} wave "
                                                f"on this grid (k ∈ {{{kset}}})"))
            note = f"; boundaries: reduced model, junction {'/'.join(sa['junctions'])}"
        fixed_txt = ", ".join(f"{_label(k)} = {v}" for k, v in fixed.items())
        sc = base.with_overrides(*(f"{k}={_toml_value(v)}" for k, v in fixed.items()))
        ax.set_title(f"sweep {meta['name']}: FE regime, k and celerity (m/s)"
                     + (f"\n{fixed_txt}" if fixed_txt else "")
                     + f"\nf = {sc.loading.f:g}, N = {sc.mesh.n_inner}, "
                       f"t_end = {sc.time.end_time:g} s{note}", fontsize=8)
        ax.legend(handles=handles, fontsize=7, loc="upper center", frameon=False, ncol=2,
                  bbox_to_anchor=(0.5, -0.13 if len(ys) > 3 else -0.25))
        suffix = "".join(f"_{k.rsplit('.', 1)[-1]}-{_slug_value(v)}" for k, v in fixed.items())
        path = sweep_dir / f"regime_map{suffix}.png"
        fig.savefig(path, dpi=130, bbox_inches="tight")
        plt.close(fig)
        outputs.append(path)
    return outputs


def _map_base(sweep_dir: Path, meta: dict) -> Scene:
    """A resolved scene of the sweep (every swept key is overridden per cell anyway).

    A run's own ``scene.toml`` first, so a sweep directory copied elsewhere (out of a
    container) still plots; the base scene file the sweep named otherwise.
    """
    for row in meta["rows"]:
        path = sweep_dir / str(row.get("run_dir", "")) / "scene.toml"
        if row.get("run_dir") and path.is_file():
            return load_scene(path)
    return load_scene(meta["base"], meta.get("set", []))


def _hashable(v: Any) -> Any:
    return tuple(v) if isinstance(v, list) else v


def _sortkey(v: Any) -> tuple:
    return (0, float(v), "") if _numeric([v]) else (1, 0.0, str(v))


_LABELS = {"loading.omega": "Ω (rad/s)", "geometry.delta": "δ = d/R", "loading.f": "f",
           "mesh.n_inner": "N (contact nodes)", "initial.seed": "seed",
           "initial.mode": "initial mode", "geometry.xi": "ξ = R*/R"}


def _label(key: str | None) -> str:
    return _LABELS.get(key or "", key or "")


# ============================================================================ CLI


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "sweep",
        help="run a grid/list of scene variants (mpirun: dynamic load balancing, resumable)",
        description=(
            "Run every scene of a sweep file (base scene + [grid]/[[points]] of dotted-key "
            "overrides) into SWEEP_DIR/runs/<id>/, with a table SWEEP_DIR/sweep.{csv,json}. "
            "Under `mpirun -n P`, groups of group_size ranks take scenes from a shared "
            "counter. Re-running resumes: finished scenes are skipped. "
            "`stickslip sweep --plot SWEEP_DIR` draws the regime map of a sweep directory."
        ),
    )
    p.add_argument("target", help="sweep file (TOML), or a sweep directory with --plot")
    p.add_argument("-o", "--output", help="sweep directory (default: the file's `output`, "
                   "else $STICKSLIP_OUTPUT/sweeps/<name>)")
    p.add_argument("--group-size", type=int, help="ranks per scene (overrides the file)")
    p.add_argument("--retry-failed", action="store_true",
                   help="run scenes that failed or diverged again")
    p.add_argument("--plot", action="store_true",
                   help="draw the regime map (after the sweep, or of an existing SWEEP_DIR)")
    p.add_argument("--list", action="store_true",
                   help="list the scenes and their state; run nothing")
    p.add_argument("--progress", choices=("auto", "live", "lines"), default="auto",
                   help="live status line (TTY) or one line per finished scene (auto: live "
                        "only on a terminal outside mpirun)")
    p.set_defaults(func=_sweep)


def _out_dir(spec: SweepSpec, args: argparse.Namespace) -> Path:
    from solver.cli import output_root

    if args.output:
        return Path(args.output)
    if spec.output is not None:
        return spec.output
    return output_root() / "sweeps" / spec.name


def _sweep(args: argparse.Namespace) -> int:
    target = Path(args.target)
    if target.is_dir():
        if not args.plot:
            print(f"error: {target} is a directory; use `stickslip sweep --plot {target}` to "
                  "draw its map, or give a sweep file", file=sys.stderr)
            return 2
        try:
            for path in plot_sweep(target):
                print(f"figure: {path}")
        except SweepError as err:
            print(f"error: {err}", file=sys.stderr)
            return 2
        return 0
    # Only an atomic counter is needed (one operation per scene): keep OpenMPI's UCX one-sided
    # component, which warns on hosts without UCX devices, out of the way unless asked for.
    os.environ.setdefault("OMPI_MCA_osc", "^ucx")
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    try:
        spec = load_sweep(target)
    except SweepError as err:
        if comm.rank == 0:
            print(f"error: {err}", file=sys.stderr)
        return 2
    out_dir = _out_dir(spec, args)
    if args.group_size is not None and args.group_size < 1:
        if comm.rank == 0:
            print("error: --group-size must be >= 1", file=sys.stderr)
        return 2
    if args.list:
        if comm.rank == 0:
            for task in spec.tasks:
                print(f"{task.id:40s} {task_state(out_dir, spec, task)}")
        return 0
    rc = run_sweep(spec, out_dir, comm=comm, group_size=args.group_size,
                   retry_failed=args.retry_failed, progress=args.progress)
    if args.plot and rc in (0, 1) and comm.rank == 0:
        for path in plot_sweep(out_dir):
            print(f"figure: {path}")
    return rc
