"""A run's checkpoint, ``RUN_DIR/checkpoint.npz``: where ``stickslip continue`` starts from.

Every run that ends at a whole time level (completed, stopped by its wall-time limit,
interrupted by a signal; a member of a batch that completed) writes it beside its samples,
atomically (``solver.atomic``). It holds only the state of the last level, not a history:

=========================  ===============================================================
``meta``                   JSON: ``format``, ``kind`` (``run``: one ``Simulation`` on
                           ``ranks`` ranks; ``batch``: a member of a batch (``Simulation.batch``),
                           with its ``backend``), ``kernel``, ``scene`` (name),
                           ``scene_sha256`` (``scene_fingerprint``), ``status``,
                           ``step``, ``time``, ``samples``, ``probe_steps``
``rank<r>/stepper/...``    rank r's stepper state (``Stepper.state``): u_{n+1}, u_n, the
                           velocity predictor or v_{n+1}, the kernel's contact sums, the
                           clock ``time`` and ``step_count``
``rank<r>/contact/...``    the contact statuses of the last level and a regularised bound's
                           sigma_eff (implicit: the forces of the next level, the active set)
``rank<r>/energy/...``     the contact-work sums (numpy and implicit steps)
``rank<r>/damping/...``    the Kelvin-Voigt work sums (damped explicit runs)
``rank<r>/run/...``        the energy guard's E(0) and bound, the steady pressure, the
                           counts of samples and probe steps taken
=========================  ===============================================================

``meta`` also holds ``arrays``, the layout of every other member (its dtype and shape), so
that a missing, added or reshaped array is seen before the run is built.

Nothing of a checkpoint is taken on trust: ``read_checkpoint`` checks the file (an archive
of arrays, the meta's fields and types, the arrays against their layout) and
``check_checkpoint`` checks it against the run beside it (its scene, summary.json and
samples.npz): every rank's state, its dtypes, finite numbers, the clock, the counts, the
energy guard, the statuses, the sizes of the mesh and the kind (a one-scene run or a batch
member). Each fault is one ``ReadError`` line naming the file, the field and what is wrong;
``stickslip continue`` checks before it claims or changes anything.

The samples and probe histories taken so far are the run's ``samples.npz``; the checkpoint's
counts must match it. The observers' cadences need nothing: they are fixed time levels and
the step count is the stepper's. Light: numpy, the standard library and the solver's small
tables (scene, energy guard, contact statuses, batch kernels, backends).
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from stickslip.solver.atomic import atomic_save_npz
from stickslip.solver.contact.law import SEPARATION, SLIP, STICK
from stickslip.solver.ensemble import BATCH_KERNELS
from stickslip.solver.errors import energy_bound
from stickslip.solver.scene import Scene, scene_to_dict
from stickslip.solver.schemes.select import BACKENDS
from stickslip.studies.rundir.readers import ReadError, _load_npz

__all__ = ["CHECKPOINT", "FORMAT", "Checkpoint", "check_checkpoint", "read_checkpoint",
           "scene_fingerprint", "write_checkpoint"]

#: Scene keys a continuation may change: when and how long it runs, and what it prints.
CONTINUATION_KEYS = {"time": ("end_time", "max_steps", "max_wall_time"),
                     "output": ("progress",)}


def scene_fingerprint(scene: Scene) -> str:
    """A hash of ``scene`` without ``CONTINUATION_KEYS``: a continuation runs the scene
    that wrote the checkpoint (a scene.toml edited since is refused)."""
    d = scene_to_dict(scene)
    for section, keys in CONTINUATION_KEYS.items():
        for key in keys:
            d.get(section, {}).pop(key, None)
    return hashlib.sha256(json.dumps(d, sort_keys=True).encode()).hexdigest()

CHECKPOINT = "checkpoint.npz"
#: 2: the meta holds the arrays' layout (``arrays``).
FORMAT = 2
#: The formats read: 1, written before the meta named its arrays (the file's own arrays are
#: its layout then; every other check applies), and this one.
READ_FORMATS = (1, FORMAT)

#: The fix for a run without a checkpoint, and for a checkpoint that cannot be trusted.
MISSING_FIX = ("run the scene again to the time you want (`stickslip run RUN/scene.toml --set "
               "time.end_time=T -o NEW`): runs written before continuation, and failed or "
               "diverged runs, have no checkpoint")
DAMAGED_FIX = ("run the scene again to the time you want (`stickslip run RUN/scene.toml --set "
               "time.end_time=T -o NEW`)")

#: The meta's fields and their JSON types (float: a finite number).
META = {"format": int, "kind": str, "ranks": int, "kernel": str, "backend": str,
        "scene": str, "scene_sha256": str, "status": str, "step": int, "time": float,
        "samples": int, "probe_steps": int, "arrays": dict}
#: How a message names each of those types.
JSON_TYPES = {int: "an integer", str: "a string", float: "a finite number", dict: "an object"}
#: Meta fields that count (>= 0), and the most ranks a checkpoint is read for.
COUNTS = ("step", "time", "samples", "probe_steps")
MAX_RANKS = 1 << 16

#: The kinds of checkpoint: the parts of each rank's state and the keys every state holds
#: (the scheme's own arrays besides them are named by the layout).
PARTS = {"run": ("stepper", "contact", "energy", "damping", "run"), "batch": ("stepper", "run")}
RUN_PART = ("run/initial_energy", "run/energy_bound", "run/steady_pressure", "run/samples",
            "run/probe_steps")
REQUIRED = {
    "run": ("stepper/u", "stepper/u_prev", "stepper/time", "stepper/step_count",
            "contact/status", "run/partition", *RUN_PART),
    "batch": ("stepper/u", "stepper/u_prev", "stepper/time", "stepper/step_count",
              "stepper/kernel", *RUN_PART),
}


def _arrays(kind: str, shapes: tuple, *names: str) -> dict[str, tuple[str, tuple]]:
    """``STATE_ARRAYS``' entries for ``names``, all of dtype ``kind`` and ``shapes``."""
    return dict.fromkeys(names, (kind, shapes))


#: Every array a rank's state may hold (the ``state()`` of each stepper, contact step and
#: work observer, and ``run/``): its dtype ("f": float64, "c": complex128, "i": an integer,
#: "U": text) and the shapes it may have, in this rank's dofs "n" (its u) and contact nodes
#: "m" (its statuses; a batch member's: the run's), the run's contact nodes "M" and the
#: checkpoint's step "step"; a number stands for itself. A name not here is not stickslip's.
STATE_ARRAYS = {
    **_arrays("f", (("n",),), "stepper/u", "stepper/u_prev", "stepper/v_pred",
              "stepper/v_next", "stepper/a_next", "stepper/kb", "stepper/kvd",
              "stepper/u_tau", "damping/u_older"),
    **_arrays("f", (("2m",), ("m", 2)), "stepper/zprev"),
    **_arrays("f", ((4,), (3, "m")), "stepper/work"),  # the totals, or per node (CUDA)
    **_arrays("f", (("n/2",),), "stepper/dwork"),
    **_arrays("f", ((0,), ("m",)), "stepper/sigma", "stepper/ut_last"),
    **_arrays("f", ((),), "stepper/d", "stepper/u0_ku0", "stepper/damping_work_local",
              "stepper/time", "damping/u0_ku0", "run/initial_energy", "run/energy_bound",
              "run/steady_pressure"),
    **_arrays("i", ((),), "stepper/step_count", "contact/started", "run/samples",
              "run/probe_steps"),
    **_arrays("i", (("step",),), "stepper/iterations"),
    **_arrays("U", ((),), "stepper/kernel", "run/partition"),
    **_arrays("i", (("m",),), "contact/status"),
    **_arrays("i", (("M",),), "contact/mode"),  # the active set, on rank 0
    **_arrays("f", (("m",),), "contact/sigma", "contact/u_t_last", "contact/u_z_last",
              "contact/rate"),
    **_arrays("c", (("m",),), "contact/r_polar", "contact/r_xy", "energy/z_prev",
              "energy/z_now"),
    **_arrays("f", ((2,),), "contact/work", "contact/work_exposed", "damping/sums"),
    **_arrays("f", ((3,),), "energy/sums"),
    **_arrays("f", (("m", 3),), "energy/u_prev", "energy/u_now"),  # a 3D tube's surface
}
DTYPES = {"f": ("float64",), "c": ("complex128",), "i": ("int8", "int16", "int32", "int64"),
          "U": ()}
#: The one number that may be NaN: E(0) of a run stopped before its first sample.
MAY_BE_NAN = ("run/initial_energy",)

#: meta field -> the summary.json key path that must hold the same value, and the value a
#: summary without it stands for (the implicit scheme names no kernel; a one-scene run's
#: checkpoint says the CPU).
AGREE = {"status": (("status",), None), "step": (("steps",), None),
         "time": (("sim_time_s",), None), "ranks": (("ranks",), None),
         "samples": (("samples",), None), "kernel": (("scheme", "kernel"), ""),
         "backend": (("batch", "backend"), "cpu")}
NOTHING = object()
#: summary.json keys a run that wrote a checkpoint has, with their JSON types.
SUMMARY = {"steps": int, "sim_time_s": float, "dt_s": float, "dofs": int,
           "contact_nodes": int, "ranks": int, "samples": int}
#: The clock's tolerance: time is summed step by step (time += dt), so it is step x dt to
#: a few step x eps; 1e-6 of it holds for up to ~1e9 steps and refuses a step count off by
#: one for runs of up to ~1e6 steps (summary.json's steps refuses the rest).
CLOCK_RTOL = 1e-6


@dataclass(frozen=True)
class Checkpoint:
    """A checkpoint read back: its ``meta``, one flat state dict per rank and its file."""

    meta: dict
    states: list[dict[str, np.ndarray]]
    path: Path = Path(CHECKPOINT)

    @property
    def time(self) -> float:
        return float(self.meta["time"])

    @property
    def kind(self) -> str:
        return str(self.meta["kind"])


def write_checkpoint(folder: str | Path, states: list[dict[str, np.ndarray]], *, kind: str,
                     scene: Scene, status: str, kernel: str, backend: str = "cpu") -> Path:
    """Write ``folder/checkpoint.npz`` (atomically) from the per-rank states of
    ``Simulation.checkpoint`` (gathered, rank order) or one batch column's ``SceneRun.state``.
    The atomic rename replaces a symbolic link in its place, never writing through it."""
    first = states[0]
    arrays: dict[str, np.ndarray] = {}
    for rank, state in enumerate(states):
        arrays.update({f"rank{rank}/{key}": np.asarray(value) for key, value in state.items()})
    meta = {"format": FORMAT, "kind": kind, "ranks": len(states), "kernel": kernel,
            "backend": backend, "scene": scene.name,
            "scene_sha256": scene_fingerprint(scene), "status": status,
            "step": int(first["stepper/step_count"]), "time": float(first["stepper/time"]),
            "samples": int(first["run/samples"]), "probe_steps": int(first["run/probe_steps"]),
            "arrays": {key: [a.dtype.str, list(a.shape)] for key, a in arrays.items()}}
    return atomic_save_npz(Path(folder) / CHECKPOINT,
                           {"meta": np.array(json.dumps(meta)), **arrays}, compress=False)


# ---------------------------------------------------------------------- the file itself


def read_checkpoint(run_dir: str | Path) -> Checkpoint:
    """``RUN_DIR/checkpoint.npz``, checked as a file: an archive of arrays (no pickles, not
    a symbolic link), a meta of this format with every field of its type, and arrays that
    are exactly the meta's layout, each a state of one of its ranks. ReadError (one line:
    the file, the field, the fix) otherwise. ``check_checkpoint`` then checks it against
    the run."""
    p = Path(run_dir) / CHECKPOINT
    if not p.is_symlink() and not p.exists():
        raise ReadError(p, "missing (no checkpoint to continue from)", MISSING_FIX)
    arrays = _load_npz(p, ("meta",), DAMAGED_FIX)
    meta = _read_meta(p, arrays.pop("meta"))
    layout = meta.get("arrays", {key: [a.dtype.str, list(a.shape)] for key, a in arrays.items()})
    _check_layout(p, arrays, layout)
    ranks = meta["ranks"]
    states: list[dict[str, np.ndarray]] = [{} for _ in range(ranks)]
    for key, value in arrays.items():
        head, _, name = key.partition("/")
        rank = int(head[4:]) if head.startswith("rank") and head[4:].isdigit() else -1
        if not 0 <= rank < ranks or not name:
            _bad(p, f"holds {key!r}, not a state of its {ranks} rank(s)")
        states[rank][name] = value
    return Checkpoint(meta, states, p)


def _bad(p: Path, fault: str) -> None:
    """Refuse the checkpoint ``p``: one line, the fault and ``DAMAGED_FIX``."""
    raise ReadError(p, fault, DAMAGED_FIX)


def _read_meta(p: Path, raw: np.ndarray) -> dict:
    """The meta of ``p``: a JSON object of this ``FORMAT`` with every field of ``META``, of
    its type and in range, and nothing else."""
    if raw.dtype.kind != "U" or raw.ndim != 0:
        _bad(p, f"meta is a {raw.dtype} array of shape {raw.shape}, not the JSON text "
                "stickslip writes")
    try:
        meta = json.loads(str(raw))
    except (ValueError, RecursionError) as err:
        _bad(p, f"meta is not valid JSON ({' '.join(str(err).split())[:60]})")
    if not isinstance(meta, dict):
        _bad(p, f"meta holds a JSON {type(meta).__name__}, not an object")
    if meta.get("format") not in READ_FORMATS or type(meta.get("format")) is not int:
        _bad(p, f"meta.format is {_show(meta.get('format'))}, not one of {READ_FORMATS} "
                "(written by another version of stickslip, or not a checkpoint)")
    fields = META if meta["format"] == FORMAT else {k: v for k, v in META.items()
                                                   if k != "arrays"}
    extra = sorted(set(meta) - set(fields))
    if extra:
        _bad(p, f"meta holds {extra[0]!r}, a field stickslip does not write (edited)")
    for key, kind in fields.items():
        if key not in meta:
            _bad(p, f"meta has no {key!r} (not written by stickslip, or edited)")
        value = meta[key]
        ok = (type(value) is int or (type(value) is float and math.isfinite(value))
              if kind is float else type(value) is kind)
        if not ok:
            _bad(p, f"meta.{key} is {_show(value)}, not {JSON_TYPES[kind]}")
    if meta["kind"] not in PARTS:
        _bad(p, f"meta.kind is {meta['kind']!r}, not one of {', '.join(PARTS)}")
    if not 1 <= meta["ranks"] <= MAX_RANKS:
        _bad(p, f"meta.ranks is {meta['ranks']}, not a number of ranks (1 to {MAX_RANKS})")
    for key in COUNTS:
        if meta[key] < 0:
            _bad(p, f"meta.{key} is {meta[key]!r}, below 0")
    return meta


def _show(value: object) -> str:
    """``value`` in a message: its repr, cut to 40 characters."""
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _check_layout(p: Path, arrays: dict[str, np.ndarray], layout: dict) -> None:
    """Every array of ``p`` is one that ``layout`` (meta.arrays) names, of its dtype and
    shape, and every array it names is there."""
    for key, entry in layout.items():
        if not (isinstance(entry, list) and len(entry) == 2 and isinstance(entry[0], str)
                and isinstance(entry[1], list)
                and all(type(n) is int and n >= 0 for n in entry[1])):
            _bad(p, f"meta.arrays[{key!r}] is {_show(entry)}, not [dtype, shape]")
        if key not in arrays:
            _bad(p, f"{key} is missing (meta.arrays names it)")
        a = arrays[key]
        if a.dtype.str != entry[0] or list(a.shape) != entry[1]:
            _bad(p, f"{key} is {a.dtype} of shape {a.shape}, not {_dtype_name(entry[0])} of "
                    f"shape {tuple(entry[1])} as meta.arrays says")
    extra = sorted(set(arrays) - set(layout))
    if extra:
        _bad(p, f"holds {extra[0]}, an array its meta does not name (added)")


def _dtype_name(text: str) -> str:
    """The numpy dtype ``text`` names (``<f8``: float64), else ``text`` as it is."""
    try:
        return str(np.dtype(text))
    except (TypeError, ValueError):
        return _show(text)


# ---------------------------------------------------------------------- against the run


def check_checkpoint(ck: Checkpoint, *, scene: Scene, summary: dict,
                     samples: dict[str, np.ndarray]) -> None:
    """``ck`` (``read_checkpoint``) is the checkpoint of the run beside it: the kind and
    facts its summary.json tells (status, steps, time, ranks, samples, kernel, backend), a
    full state on every rank (``REQUIRED``, nothing of another kind's parts), text only
    where text belongs, finite numbers, the clock at the checkpoint's step (step x dt), the
    counts of samples.npz, the energy guard's bound of its E(0), statuses the contact law
    knows, vectors of the mesh's dofs and contact nodes. ReadError (one line naming the
    file, the field, what is wrong) for the first fault; nothing is changed."""
    p = ck.path
    _check_summary(p, ck.meta, summary, scene)
    for rank, state in enumerate(ck.states):
        _check_state(p, f"rank{rank}/", state, ck.meta, summary)
    _check_sizes(p, ck, summary)
    _check_clock(p, ck.meta, summary)
    _check_records(p, ck.meta, samples)


def _check_summary(p: Path, meta: dict, summary: dict, scene: Scene) -> None:
    """The facts of summary.json (beside ``p``) and the scene agree with the meta's."""
    s = p.parent / "summary.json"
    for key, kind in SUMMARY.items():
        value = summary.get(key)
        if not (type(value) is kind or (kind is float and type(value) is int)):
            raise ReadError(s, f"{key} is {_show(value)}, not {JSON_TYPES[kind]} as in every "
                               "run that wrote a checkpoint (edited)", DAMAGED_FIX)
    if meta["scene"] != scene.name:
        _bad(p, f"meta.scene is {meta['scene']!r}, but scene.toml is {scene.name!r}")
    batch = summary.get("batch")
    member = meta["kind"] == "batch"
    if member != isinstance(batch, dict):
        _bad(p, f"meta.kind is {meta['kind']!r}, but summary.json is of "
                f"{'a batch member' if isinstance(batch, dict) else 'a one-scene run'}")
    if meta["backend"] not in BACKENDS:
        _bad(p, f"meta.backend is {meta['backend']!r}, not one of {', '.join(BACKENDS)}")
    for key, (where, default) in AGREE.items():
        found: object = summary
        for name in where:
            found = found.get(name, NOTHING) if isinstance(found, dict) else NOTHING
        says = (f"summary.json's {'.'.join(where)} is {_show(found)}" if found is not NOTHING
                else f"summary.json has no {'.'.join(where)} (that is, {default!r})")
        if meta[key] != (default if found is NOTHING else found):
            _bad(p, f"meta.{key} is {_show(meta[key])}, but {says} (not this run's "
                    "checkpoint)")
    if member and meta["ranks"] != 1:
        _bad(p, f"meta.ranks is {meta['ranks']}, but a batch member runs on one rank")


def _check_state(p: Path, head: str, state: dict[str, np.ndarray], meta: dict,
                 summary: dict) -> None:
    """One rank's state: its keys (``PARTS``, ``REQUIRED``), each array's dtype, shape and
    finite values (``STATE_ARRAYS``), its clock and counts (the meta's), the energy guard,
    the statuses, the partition's hash and a batch column's kernel."""
    kind = meta["kind"]
    missing = [key for key in REQUIRED[kind] if key not in state]
    if missing:
        _bad(p, f"{head}{missing[0]} is missing (every {kind} checkpoint holds it)")
    for key in state:
        part = key.split("/")[0]
        if part not in PARTS[kind] or key not in STATE_ARRAYS \
                or (part == "run" and key not in REQUIRED[kind]):
            _bad(p, f"holds {head}{key}, which no {kind} checkpoint of stickslip has")
    sizes = _sizes(p, head, state, meta, summary)
    for key, a in state.items():
        _check_array(p, head + key, a, *STATE_ARRAYS[key], sizes)
    for key, field in (("stepper/step_count", "step"), ("stepper/time", "time"),
                       ("run/samples", "samples"), ("run/probe_steps", "probe_steps")):
        if state[key].item() != meta[field]:
            _bad(p, f"{head}{key} is {_show(state[key].item())}, but meta.{field} is "
                    f"{meta[field]!r}")
    _check_guard(p, head, state, summary)
    status = state.get("contact/status")
    if status is not None and not np.isin(status, (SEPARATION, STICK, SLIP)).all():
        _bad(p, f"{head}contact/status holds values that are not contact statuses "
                f"({SEPARATION}, {STICK}, {SLIP})")
    if "run/partition" in state:
        text = str(state["run/partition"])
        if len(text) != 64 or set(text) - set("0123456789abcdef"):
            _bad(p, f"{head}run/partition is {_show(text)}, not the hash of a partition")
    if "stepper/kernel" in state and str(state["stepper/kernel"]) not in BATCH_KERNELS:
        _bad(p, f"{head}stepper/kernel is {_show(str(state['stepper/kernel']))}, not one of "
                f"{', '.join(sorted(BATCH_KERNELS))}")


def _sizes(p: Path, head: str, state: dict[str, np.ndarray], meta: dict,
           summary: dict) -> dict[str, int]:
    """The sizes ``STATE_ARRAYS`` counts in for this rank: its dofs n (its u), contact
    nodes m (its statuses; a batch member's: the run's), the run's contact nodes M (a 3D
    tube's: its surface's) and the checkpoint's step."""
    n_all, m_all = summary["dofs"], stepped_contact_nodes(summary)
    for key, n in (("stepper/u", n_all), ("contact/status", m_all)):
        a = state.get(key)
        if a is not None and (a.ndim != 1 or a.size > n):
            _bad(p, f"{head}{key} has shape {a.shape}, not a vector of at most the run's {n} "
                    f"{'dofs' if key.startswith('stepper') else 'contact nodes'}")
    n = state["stepper/u"].size
    m = state["contact/status"].size if "contact/status" in state else m_all
    return {"n": n, "n/2": n // 2, "m": m, "2m": 2 * m, "M": m_all, "step": meta["step"]}


def _check_array(p: Path, field: str, a: np.ndarray, kind: str, shapes: tuple,
                 sizes: dict[str, int]) -> None:
    """``a`` is of dtype ``kind`` (``DTYPES``; text: a str), one of ``shapes`` (in
    ``sizes``), and finite (but for ``MAY_BE_NAN``, which may be NaN)."""
    ok = a.dtype.kind == "U" if kind == "U" else a.dtype.name in DTYPES[kind]
    if not ok:
        want = "text" if kind == "U" else " or ".join(DTYPES[kind])
        _bad(p, f"{field} is {a.dtype}, not {want}")
    allowed = [tuple(sizes.get(d, d) for d in shape) for shape in shapes]
    if a.shape not in allowed:
        want = " or ".join(str(s) for s in allowed)
        _bad(p, f"{field} has shape {a.shape}, not {want} (this run's sizes)")
    if kind in "fc" and not np.isfinite(a).all():
        if not (field.endswith(MAY_BE_NAN) and np.isnan(a).all()):
            bad = int((~np.isfinite(a)).sum())
            _bad(p, f"{field} holds {bad} NaN or infinite value(s) of {a.size}")


def _check_guard(p: Path, head: str, state: dict[str, np.ndarray], summary: dict) -> None:
    """The energy guard: E(0) >= 0 and its bound ``energy_bound(E(0))`` (NaN and inf before
    the guard's first sample); the steady pressure that of summary.json."""
    e0 = state["run/initial_energy"].item()
    bound = state["run/energy_bound"].item()
    want = math.inf if math.isnan(e0) else float(energy_bound(e0))
    if e0 < 0.0 or bound != want:
        _bad(p, f"{head}run/energy_bound is {bound!r} for run/initial_energy {e0!r}, not the "
                f"guard's bound {want!r}")
    pressure = state["run/steady_pressure"].item()
    found = summary.get("steady_pressure_pa")
    if isinstance(found, float) and pressure != found:
        _bad(p, f"{head}run/steady_pressure is {pressure!r}, but summary.json's "
                f"steady_pressure_pa is {found!r}")


def stepped_contact_nodes(summary: dict) -> int:
    """The contact nodes the run's contact step holds: its ``contact_nodes``, or a 3D
    tube's whole surface (``tube_3d.surface_nodes``; its samples are one ring's)."""
    tube = summary.get("tube_3d")
    if isinstance(tube, dict) and isinstance(tube.get("surface_nodes"), int):
        return tube["surface_nodes"]
    return summary["contact_nodes"]


def _check_sizes(p: Path, ck: Checkpoint, summary: dict) -> None:
    """The ranks' parts add up to the run: their u to its dofs, their contact statuses to
    its contact nodes (each dof and node is one rank's)."""
    for key, n, what in (("stepper/u", summary["dofs"], "dofs"),
                         ("contact/status", stepped_contact_nodes(summary), "contact nodes")):
        parts = [state[key].size for state in ck.states if key in state]
        if parts and sum(parts) != n:
            _bad(p, f"{key} holds {' + '.join(map(str, parts))} {what} on its "
                    f"{len(parts)} rank(s), but the run has {n}")


def _check_clock(p: Path, meta: dict, summary: dict) -> None:
    """The clock: meta.time is meta.step steps of summary.json's dt."""
    dt, step, t = float(summary["dt_s"]), meta["step"], float(meta["time"])
    if not (dt > 0.0 and abs(t - step * dt) <= CLOCK_RTOL * step * dt):
        _bad(p, f"meta.time {t!r} s is not meta.step {step} steps of dt = {dt!r} s")


def _check_records(p: Path, meta: dict, samples: dict[str, np.ndarray]) -> None:
    """samples.npz holds the checkpoint's counts of samples and probe steps, none of them
    after its time."""
    s = p.parent / "samples.npz"
    t = samples["t"]
    probes = samples.get("probe_t", np.zeros(0))
    for key, found in (("samples", t), ("probe_steps", probes)):
        if found.size != meta[key]:
            raise ReadError(s, f"holds {found.size} {key.replace('_', ' ')}, its checkpoint "
                               f"{meta[key]} (not the same run)", DAMAGED_FIX)
        if found.size and not found[-1] <= float(meta["time"]) * (1.0 + 1e-12):
            raise ReadError(s, f"its last {key.replace('_', ' ')[:-1]} is at t = "
                               f"{float(found[-1])!r} s, after its checkpoint's "
                               f"{meta['time']!r} s (not the same run)", DAMAGED_FIX)
