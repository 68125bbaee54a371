"""Batched sweeps: scenes that share mesh, material, dt and scheme run as one batch.

``stickslip sweep --batch off|auto|B``. ``plan_units`` groups the pending scenes by
``studies.batching.batch_key`` (the scene without what only the contact law and the initial
state see: Omega, f, delta, the initial perturbation, the name) and cuts each group into
batches of at most B scenes; ``run_batch`` runs one batch as a
``solver.run.Simulation.batch`` on one rank and writes each scene's run directory.

Each scene keeps what ``stickslip run`` gives it: its run directory (scene.toml, summary.json
with status ``running`` while the batch runs, samples.npz, final_field.npz), its log, its
final status and the resume semantics of the sweep. A scene whose energy check fails is
masked out of the batch (status ``diverged``, with the step at which it blew up) and the
others go on; a scene whose set-up fails (e.g. no steady sliding) is ``failed`` alone.
The numbers are the ones of the single-scene run with the numba kernel, bitwise
(tests/test_ensemble.py): the batched kernel sums in the same order.

Scenes that cannot be batched (``solver.schemes.select.batchable``: the implicit scheme,
field output, ``time.kernel = "numpy"``, physics the kernel lacks) run one by one, as do groups
of more than one rank per scene and groups of a single scene.
"""

from __future__ import annotations

import math
import os
import shutil
import time
import traceback
from pathlib import Path
from typing import TextIO

from stickslip.solver.run import Profile, Simulation
from stickslip.solver.scene import Scene
from stickslip.studies.batching import SPOOL_MEMORY_FRACTION, batch_key
from stickslip.studies.resources import available_memory
from stickslip.studies.rundir import (
    prepare_run_dir,
    print_summary,
    running_summary,
    write_first_files,
    write_member,
)
from stickslip.studies.rundir.ownership import refusal
from stickslip.studies.rundir.signals import deferred_signals
from stickslip.studies.rundir.summary_file import write_summary
from stickslip.studies.sweep.spec import SweepSpec, Task, scene_for
from stickslip.studies.sweep.table import check_recorded

#: Memory a batch may use (bytes) when ``--batch auto`` picks its size.
AUTO_MEMORY_FRACTION = 0.25
AUTO_MAX = 1024


def bytes_per_scene(scene: Scene, chunk: int = 16) -> float:
    """Memory of one scene in a batch: 6 (n,) state arrays + scratch, contact arrays, the
    sample and probe chunks (estimate from the mesh size: dofs ~ 2 N n_layers)."""
    n_inner = scene.mesh.n_inner * scene.mesh.degree
    layers = scene.mesh.n_radial or max(2, round(n_inner * (scene.geometry.xi - 1.0)
                                                 / (2 * math.pi)))
    n = 2 * n_inner * (layers + 1)
    m = n_inner
    return 8.0 * (8 * n + 12 * m + chunk * (7 * m + 5) + 16 * chunk * 4)


def auto_batch_size(scene: Scene, n_scenes: int, n_groups: int) -> int:
    """B for ``--batch auto``: all the group's scenes, split evenly over the rank groups
    (every rank gets work), capped by memory (a quarter of the free memory) and AUTO_MAX."""
    try:
        free = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError):  # pragma: no cover
        free = 4 << 30
    by_memory = max(1, int(AUTO_MEMORY_FRACTION * free / bytes_per_scene(scene)))
    even = max(1, math.ceil(n_scenes / max(1, n_groups)))
    return int(min(by_memory, even, AUTO_MAX))


def plan_units(spec: SweepSpec, pending: list[Task], batch: str, n_groups: int,
               group_size: int) -> list[list[Task]]:
    """Cut the pending scenes (in their LPT order) into work units: batches and singles."""
    if batch == "off" or group_size != 1:
        return [[t] for t in pending]
    groups: dict[str, list[Task]] = {}
    units: list[list[Task]] = []
    scenes = {}
    for t in pending:
        sc = scene_for(spec, t)
        key = batch_key(sc)
        if key is None:
            units.append([t])
            continue
        scenes[key] = sc
        groups.setdefault(key, []).append(t)
    for key, tasks in groups.items():
        if len(tasks) == 1:
            units.append(tasks)
            continue
        size = (auto_batch_size(scenes[key], len(tasks), n_groups) if batch == "auto"
                else int(batch))
        units += [tasks[i:i + size] for i in range(0, len(tasks), size)]
    return units


def parse_batch(value: str) -> str:
    """``--batch`` value check: "off", "auto" or an integer >= 1 (ValueError names the fix)."""
    if value in ("off", "auto"):
        return value
    try:
        if int(value) >= 1:
            return str(int(value))
    except ValueError:
        pass
    raise ValueError(f"--batch {value!r}: use off, auto or a batch size >= 1")


# ------------------------------------------------------------------------------ one batch


def run_batch(spec: SweepSpec, tasks: list[Task], out_dir: Path, world_rank: int,
              backend: str = "cpu", stream: TextIO | None = None,
              failures: dict[str, str] | None = None) -> list[str]:
    """Run ``tasks`` (same ``batch_key``) as one batch on this rank; returns their statuses.

    The batch is a ``solver.run.Simulation.batch``; this function only prepares each
    scene's run directory and log, and writes each scene's files when the batch is done.
    A member whose files could not be written (a full disk) is ``failed``, and where its own
    summary cannot say so, ``failures`` (id -> message, as ``table.check_recorded``) does."""
    t0 = time.perf_counter()
    mine = _claimable(tasks, out_dir, stream)
    if len(mine) < len(tasks):  # a user's folder under runs/ is never written: run the rest
        statuses = dict.fromkeys((t.id for t in tasks), "failed")
        if mine:
            done = run_batch(spec, mine, out_dir, world_rank, backend, stream, failures)
            statuses.update(zip((t.id for t in mine), done, strict=True))
        return [statuses[t.id] for t in tasks]
    logs, claims, started = [], [], []
    with deferred_signals() as early:  # every member marked running (or failed), or none
        for t in tasks:
            if _start_member(spec, t, len(tasks), out_dir, world_rank, backend, logs, claims,
                             failures):
                started.append(t)
    if not started:
        if early:
            raise KeyboardInterrupt
        return ["failed"] * len(tasks)
    statuses = dict.fromkeys((t.id for t in tasks), "failed")
    done = _run_started(spec, started, logs, claims, t0, backend, out_dir, early, failures)
    statuses.update(zip((t.id for t in started), done, strict=True))
    return [statuses[t.id] for t in tasks]


def _run_started(spec: SweepSpec, tasks: list[Task], logs: list, claims: list, t0: float,
                 backend: str, out_dir: Path, early: list[int],
                 failures: dict[str, str] | None) -> list[str]:
    """Run the members whose run directories and logs are ready (``_start_member``) as one
    batch and write each one's files; returns their statuses (KeyboardInterrupt once every
    member is written, if a signal came)."""
    scenes = [scene_for(spec, t) for t in tasks]
    files = _BatchFiles(scenes, claims, logs, t0, len(tasks), backend, spec.compress,
                        failures)
    profile = Profile()
    interrupted = bool(early)
    batch = None
    try:
        if not interrupted:
            batch = _build_batch(scenes, backend, out_dir, profile, files)
        if batch is not None and batch.live:
            batch.proceed()
    except KeyboardInterrupt:
        interrupted = True
    except Exception as err:  # the batch as a whole failed: every scene still running fails
        for k in range(len(tasks)):
            if batch is None or batch.runs[k].status == "running" or k in batch.live:
                files.fail(k, err)
        batch = None
    with profile.phase("output"), deferred_signals() as came:
        if batch is not None:
            files.write_runs(batch, interrupted, profile)
        elif interrupted:
            for k in range(len(tasks)):
                files.interrupted(k)
    interrupted = interrupted or bool(came)  # honoured once every member is written
    if batch is not None and batch.columns.spool_dir is not None:  # now in each samples.npz
        shutil.rmtree(batch.columns.spool_dir, ignore_errors=True)
    files.close()
    if interrupted:
        raise KeyboardInterrupt
    return files.statuses


def _start_member(spec: SweepSpec, task: Task, size: int, out_dir: Path, world_rank: int,
                  backend: str, logs: list, claims: list,
                  failures: dict[str, str] | None) -> bool:
    """A member's log opened (appended to ``logs``), its run directory claimed (appended to
    ``claims``), its scene.toml and a ``running`` summary written as a single run's
    (``studies.rundir.writer``). The claims are written in place and their locks let go at
    once: a batch of B members would otherwise hold B open files while it runs.

    Returns False, the member ``failed`` and left out of the batch, where a write failed
    (a full disk): its log says why, and so does its summary or else ``failures``."""
    from mpi4py import MPI

    scene, run_dir = scene_for(spec, task), out_dir / "runs" / task.id
    log = open(out_dir / "logs" / f"{task.id}.log", "a")  # noqa: SIM115
    log.write(f"== start {time.strftime('%Y-%m-%dT%H:%M:%S')} world rank {world_rank} "
              f"(1 rank(s)) pid {os.getpid()} batch of {size} ({backend})\n")
    log.flush()
    try:
        claim = prepare_run_dir(run_dir, True, MPI.COMM_SELF, in_place=True)
        claim.release()
        write_first_files(claim.work, scene, running_summary(scene.name))
    except OSError as err:
        message = f"{type(err).__name__}: {err}"
        log.write(f"{message}\n== end failed\n")
        log.close()
        try:
            write_summary(run_dir, {"scene": scene.name, "status": "failed",
                                    "message": message})
        except OSError as write_err:
            message += f"; its summary could not be written ({write_err})"
        check_recorded(run_dir, {"status": "failed", "message": message}, failures, task.id)
        return False
    claims.append(claim)
    logs.append(log)
    return True


def _claimable(tasks: list[Task], out_dir: Path, stream: TextIO | None) -> list[Task]:
    """The tasks whose ``runs/ID`` is stickslip's or new; the others (a user's folder) are
    named on ``stream`` and left alone (the sweep table shows them as foreign)."""
    out = []
    for t in tasks:
        why = refusal(out_dir / "runs" / t.id, "run", force=True)
        if why is not None:
            if stream is not None:
                print(f"  {t.id}: not run: {why}", file=stream, flush=True)
            continue
        out.append(t)
    return out


def _build_batch(scenes, backend, out_dir, profile, files):
    """The batch (``Simulation.batch``); scenes whose set-up failed are written ``failed`` at once.

    The batch keeps its whole sample record in memory when it needs at most
    ``SPOOL_MEMORY_FRACTION`` of the available memory (no file round trip in the time loop);
    otherwise it spools it in chunks to a folder under the sweep directory, so that memory
    does not grow with the run length."""
    batch = Simulation.batch(scenes, profile, backend=backend, spool_parent=out_dir,
                             memory_budget=SPOOL_MEMORY_FRACTION * available_memory())
    for k, err in batch.failures.items():
        files.fail(k, err)
    return batch


class _BatchFiles:
    """Each scene's run directory and log while and after its batch runs."""

    def __init__(self, scenes, claims, logs, t0: float, size: int, backend: str,
                 compress: bool = True, failures: dict[str, str] | None = None) -> None:
        self.scenes, self.claims, self.logs = scenes, claims, logs
        self.run_dirs = [c.final for c in claims]
        self.t0, self.size, self.backend, self.compress = t0, size, backend, compress
        self.statuses = ["failed"] * len(scenes)
        self.failures = failures  # the sweep's: the failures no summary could record

    def fail(self, k: int, err: BaseException) -> None:
        tb = "".join(traceback.format_exception(err))
        self.logs[k].write(tb)
        self.statuses[k] = "failed"
        message = f"{type(err).__name__}: {err}"
        try:
            write_summary(self.run_dirs[k], {
                "scene": self.scenes[k].name, "status": "failed", "message": message,
                "traceback": tb.splitlines()[-6:],
                "wall_time_s": time.perf_counter() - self.t0, "ranks": 1})
        except OSError as write_err:  # a full disk: the sweep's table records it
            message += f"; its summary could not be written ({write_err})"
        check_recorded(self.run_dirs[k], {"status": "failed", "message": message},
                       self.failures, self.run_dirs[k].name)

    def interrupted(self, k: int) -> None:
        self.statuses[k] = "interrupted"
        write_summary(self.run_dirs[k], {"scene": self.scenes[k].name, "status": "interrupted"})

    def write_runs(self, batch, interrupted: bool, profile) -> None:
        """summary.json, samples.npz, final_field.npz and checkpoint.npz of every scene that
        ran, written as a single run's (``studies.rundir.write_member``)."""
        for k in batch.live:
            run = batch.runs[k]
            if run.recorder is None:  # interrupted before the batch was built
                self.interrupted(k)
                continue
            if interrupted:
                run.status, run.message = "interrupted", "interrupted"
            summary = write_member(self.claims[k], run, profile, self.t0, self.backend,
                                   {"batch": {"size": self.size, "backend": self.backend}},
                                   self.compress)
            print_summary(summary, self.run_dirs[k], self.logs[k], False)
            # the summary's status (failed where a write failed), if its file holds it
            self.statuses[k] = check_recorded(self.run_dirs[k], summary, self.failures,
                                              self.run_dirs[k].name)

    def close(self) -> None:
        for log, st in zip(self.logs, self.statuses, strict=True):
            log.write(f"== end {st}\n")
            log.close()
