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

The samples and probe histories taken so far are the run's ``samples.npz``; the checkpoint's
counts must match it. The observers' cadences need nothing: they are fixed time levels and
the step count is the stepper's. Light: numpy, the standard library and ``solver.scene``.
"""

from __future__ import annotations

import hashlib
import json
import os
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from stickslip.solver.atomic import atomic_save_npz
from stickslip.solver.scene import Scene, scene_to_dict
from stickslip.studies.rundir.readers import ReadError, _no_link

__all__ = ["CHECKPOINT", "FORMAT", "Checkpoint", "read_checkpoint", "scene_fingerprint",
           "write_checkpoint"]

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
FORMAT = 1


@dataclass(frozen=True)
class Checkpoint:
    """A checkpoint read back: its ``meta`` and one flat state dict per rank."""

    meta: dict
    states: list[dict[str, np.ndarray]]

    @property
    def time(self) -> float:
        return float(self.meta["time"])


def write_checkpoint(folder: str | Path, states: list[dict[str, np.ndarray]], *, kind: str,
                     scene: Scene, status: str, kernel: str, backend: str = "cpu") -> Path:
    """Write ``folder/checkpoint.npz`` (atomically) from the per-rank states of
    ``Simulation.checkpoint`` (gathered, rank order) or one batch column's ``SceneRun.state``.
    The atomic rename replaces a symbolic link in its place, never writing through it."""
    first = states[0]
    meta = {"format": FORMAT, "kind": kind, "ranks": len(states), "kernel": kernel,
            "backend": backend, "scene": scene.name,
            "scene_sha256": scene_fingerprint(scene), "status": status,
            "step": int(first["stepper/step_count"]), "time": float(first["stepper/time"]),
            "samples": int(first["run/samples"]), "probe_steps": int(first["run/probe_steps"])}
    arrays: dict[str, np.ndarray] = {"meta": np.array(json.dumps(meta))}
    for rank, state in enumerate(states):
        arrays.update({f"rank{rank}/{key}": np.asarray(value) for key, value in state.items()})
    return atomic_save_npz(Path(folder) / CHECKPOINT, arrays, compress=False)


def read_checkpoint(run_dir: str | Path) -> Checkpoint:
    """``RUN_DIR/checkpoint.npz``, checked (its format, one state per rank); ReadError (one
    line with the fix) if it is missing, foreign, damaged or a symbolic link (opened without
    following one, as ``studies.rundir.readers`` reads every run file)."""
    p = Path(run_dir) / CHECKPOINT
    fix = ("run the scene again to the time you want (`stickslip run RUN/scene.toml --set "
           "time.end_time=T -o NEW`): runs written before continuation, and failed or "
           "diverged runs, have no checkpoint")
    _no_link(p, fix)
    if not p.is_file():
        raise ReadError(p, "missing (no checkpoint to continue from)", fix)
    try:
        with os.fdopen(os.open(p, os.O_RDONLY | os.O_NOFOLLOW), "rb") as fh, \
                np.load(fh, allow_pickle=False) as data:
            arrays = {k: data[k] for k in data.files}
        meta = json.loads(str(arrays.pop("meta")))
        ranks = int(meta["ranks"])
        if meta.get("format") != FORMAT:
            raise ValueError(f"format {meta.get('format')!r}, not {FORMAT}")
    except (OSError, ValueError, KeyError, TypeError, EOFError, zipfile.BadZipFile) as err:
        raise ReadError(p, f"not a stickslip checkpoint ({type(err).__name__}: "
                           f"{str(err)[:60]})", fix) from None
    states: list[dict[str, np.ndarray]] = [{} for _ in range(ranks)]
    for key, value in arrays.items():
        head, _, name = key.partition("/")
        rank = int(head[4:]) if head.startswith("rank") and head[4:].isdigit() else -1
        if not 0 <= rank < ranks:
            raise ReadError(p, f"holds {key!r}, not a state of its {ranks} rank(s)", fix)
        states[rank][name] = value
    return Checkpoint(meta, states)
