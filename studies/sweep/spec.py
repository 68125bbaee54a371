"""Sweep files: the format, its validation, and the tasks (scene variants) it expands to.

A sweep file names a base scene and the parameters to vary (dotted scene keys, as for
``stickslip run --set``)::

    name = "omega_delta"
    base = "../scenes/figure3_n36.toml"     # relative to this file, or a shipped scene name
    group_size = 1                           # MPI ranks per scene (default 1)
    batch = "auto"                           # off (default) | auto | B; --batch wins
    backend = "cpu"                          # or "gpu" (CuPy extra); --backend wins
    compress = true                          # batch members' samples.npz deflated
    set = ["time.end_time=0.3"]              # applied to every scene
    [grid]                                   # Cartesian product, in this key order
    "loading.omega" = [2.0, 10.0, 50.0]
    "geometry.delta" = [2e-4, 1e-3]
    [[points]]                               # and/or an explicit list (x grid if both)
    "initial.seed" = 3
    [attractors]                             # optional: a census of M starts at every point
    starts = 16                              # (studies/attractors/maps.py)
    [map]                                    # regime map (``stickslip plot SWEEP_DIR``)
    x = "loading.omega"
    y = "geometry.delta"
    k = [4]                                  # wavenumbers of the semi-analytical boundary
"""

from __future__ import annotations

import itertools
import json
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from stickslip.solver.scene import (
    SCENES_DIR,
    Scene,
    SceneError,
    load_scene,
    parse_override,
)
from stickslip.solver.schemes.select import BACKENDS, unsteppable

SWEEP_KIND = "stickslip-sweep"
#: A scene with one of these statuses is done; a re-run skips it.
FINAL_STATUSES = ("completed", "diverged", "failed", "stopped")
#: Regime categories of the map (``diverged`` = the explicit scheme blew up).
REGIMES = ("steady-sliding", "stick-slip", "slip-separation", "stick-slip-separation",
           "diverged")
_TOP_KEYS = ("name", "description", "base", "group_size", "output", "set", "grid", "points",
             "map", "batch", "backend", "attractors", "compress")
_MAP_KEYS = ("x", "y", "xscale", "yscale", "semianalytic", "k", "junctions")
#: Scene keys that enter the reduced model (semi-analytical existence boundary).
_SEMIANALYTIC_KEYS = ("loading.omega", "loading.f", "geometry.delta", "geometry.d",
                      "geometry.xi", "geometry.R", "material.nu", "material.wave_speed",
                      "material.E", "material.rho")
_TABLE_FIELDS = ("status", "regime", "mode", "celerity_m_s", "frequency_hz",
                 "fraction_separation", "fraction_stick", "fraction_slip", "amplitude_m",
                 "limit_cycle", "steps", "dofs", "ranks", "wall_time_s", "aliased", "message",
                 "run_dir")


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
    batch: str = "off"  # "off", "auto" or a batch size (studies/sweep/batch.py)
    backend: str = "cpu"  # batched integrator on "cpu" or "gpu" (CuPy)
    attractors: dict = field(default_factory=dict)  # census per point (studies/attractors)
    compress: bool = True  # batch members' samples.npz deflated, else stored (faster)


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
    shipped = SCENES_DIR / f"{Path(base).stem}.toml"  # a shipped scene name ("figure3_n36")
    if Path(base).parent == Path(".") and shipped.is_file():
        return shipped
    raise SweepError(f"{sweep_path}: base = {base!r} not found (relative to the sweep file, "
                     "the current directory, or a shipped scene name)")


#: Scenes of one sweep file above which ``load_sweep`` refuses unless told (``large``): each
#: is a run directory of a few MB, and the table and its resume grow with the count.
MAX_SCENES = 100_000


def _read_sweep_file(p: Path) -> dict[str, Any]:
    """The sweep file's TOML, its top-level keys and tables checked."""
    try:
        data = tomllib.loads(p.read_text())
    except tomllib.TOMLDecodeError as err:
        raise SweepError(f"{p}: invalid TOML: {err}") from None
    for key in data:
        if key not in _TOP_KEYS:
            raise SweepError(f"{p}: unknown key {key!r} (allowed: {', '.join(_TOP_KEYS)})")
    for table in ("grid", "map"):
        if not isinstance(data.get(table, {}), dict):
            raise SweepError(f"{p}: {table} = {data[table]!r} must be a table ([{table}])")
    return data


def _sweep_name(data: dict[str, Any], p: Path) -> str:
    name = str(data.get("name", p.stem))
    if not re.fullmatch(r"[A-Za-z0-9_.\-]+", name):
        raise SweepError(f"{p}: name = {name!r}: use letters, digits, '_', '-', '.'")
    return name


def _execution(data: dict[str, Any], p: Path) -> tuple[int, int | str, str]:
    """``group_size`` (ranks per scene), ``batch`` ("off", "auto" or scenes per batch) and
    ``backend`` ("cpu" or "gpu"), checked."""
    group_size = data.get("group_size", 1)
    if isinstance(group_size, bool) or not isinstance(group_size, int) or group_size < 1:
        raise SweepError(f"{p}: group_size = {group_size!r} must be an integer >= 1")
    batch = data.get("batch", "off")
    if isinstance(batch, bool) or not (batch in ("off", "auto")
                                       or (isinstance(batch, int) and batch >= 1)):
        raise SweepError(f"{p}: batch = {batch!r} must be \"off\", \"auto\" or an integer "
                         ">= 1 (scenes per batch)")

    backend = data.get("backend", "cpu")
    if backend not in tuple(BACKENDS):  # a table or list given is refused too
        raise SweepError(f"{p}: backend = {backend!r} must be \"cpu\" or \"gpu\"")
    return group_size, batch, backend


def _fixed_overrides(data: dict[str, Any], p: Path) -> tuple[str, ...]:
    """``set``: the 'key=value' overrides every scene of the sweep shares."""
    raw_set = data.get("set", [])
    if isinstance(raw_set, dict):
        return tuple(f"{k}={_toml_value(v)}" for k, v in _flatten(raw_set, f"{p} [set]").items())
    if isinstance(raw_set, list) and all(isinstance(s, str) for s in raw_set):
        return tuple(raw_set)
    raise SweepError(f"{p}: set must be a list of 'key=value' strings or a table")


def _swept_values(data: dict[str, Any], p: Path,
                  large: bool) -> tuple[list[str], list[dict[str, Any]]]:
    """The swept keys (in order of first appearance) and one parameter dict per scene:
    [grid] (a Cartesian product) times each of [[points]]."""
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
    size = math.prod(len(v) for v in grid.values()) * max(1, len(points))
    if size > MAX_SCENES and not large:
        raise SweepError(f"{p}: {size} scenes ([grid] x [[points]]); at most {MAX_SCENES} per "
                         "sweep file: split it, or pass --yes-i-know")
    combos = [dict(zip(grid, vals, strict=True)) for vals in itertools.product(*grid.values())]
    params_list: list[dict[str, Any]] = []
    for pt in points or [{}]:
        for combo in combos:
            clash = set(pt) & set(combo)
            if clash:
                raise SweepError(f"{p}: {sorted(clash)} both in [grid] and in [[points]]")
            merged = {**pt, **combo}
            params_list.append({k: merged[k] for k in keys if k in merged})
    return keys, params_list


def _tasks(keys: list[str], params_list: list[dict[str, Any]], p: Path) -> list[Task]:
    """One task per parameter dict, its id from the keys' last components (the full key
    where two keys share one)."""
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
    return tasks


def _map_spec(data: dict[str, Any], p: Path, keys: list[str]) -> MapSpec:
    """[map]: the regime map's axes (swept keys), scales and semianalytic overlay."""
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
    return MapSpec(x=raw_map.get("x"), y=raw_map.get("y"),
                   xscale=raw_map.get("xscale", "auto"), yscale=raw_map.get("yscale", "auto"),
                   semianalytic=bool(raw_map.get("semianalytic", True)), k=tuple(ks),
                   junctions=tuple(junctions))


def load_sweep(path: str | Path, large: bool = False) -> SweepSpec:
    """Parse and validate a sweep file; every scene is built once here (fail early)."""
    p = Path(path)
    if not p.is_file():
        raise SweepError(f"sweep file {str(path)!r} not found")
    data = _read_sweep_file(p)
    name = _sweep_name(data, p)
    if "base" not in data:
        raise SweepError(f"{p}: 'base' is required (the scene file every variant starts from)")
    base = _resolve_base(str(data["base"]), p)
    group_size, batch, backend = _execution(data, p)
    fixed = _fixed_overrides(data, p)
    try:
        base_scene = load_scene(base, fixed)
    except SceneError as err:
        raise SweepError(f"{p}: base scene: {err}") from None
    keys, params_list = _swept_values(data, p, large)
    tasks = _tasks(keys, params_list, p)
    map_spec = _map_spec(data, p, keys)
    if not isinstance(data.get("attractors", {}), dict):
        raise SweepError(f"{p}: [attractors] must be a table (starts = M, ...)")
    if not isinstance(data.get("compress", True), bool):
        raise SweepError(f"{p}: compress = {data['compress']!r} must be true or false")
    spec = SweepSpec(
        name=name, path=p.resolve(), base=base, base_scene=base_scene, set=fixed,
        keys=tuple(keys), tasks=tuple(tasks), group_size=group_size, batch=str(batch),
        backend=backend, attractors=dict(data.get("attractors", {})),
        compress=data.get("compress", True),
        output=p.parent / str(data["output"]) if data.get("output") else None,
        description=str(data.get("description", "")), map=map_spec,
    )
    for task in spec.tasks:  # every variant a valid scene its scheme steps, before any runs
        try:
            why = unsteppable(scene_for(spec, task))
        except SceneError as err:
            raise SweepError(f"{p}: scene {task.id}: {err}") from None
        if why:
            raise SweepError(f"{p}: scene {task.id}: {why}")
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


