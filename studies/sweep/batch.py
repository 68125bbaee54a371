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
from stickslip.studies.rundir.ownership import refusal
from stickslip.studies.rundir.signals import deferred_signals
from stickslip.studies.rundir.writer import RunDirectory, print_summary
from stickslip.studies.sweep.spec import SweepSpec, Task, scene_for
from stickslip.studies.sweep.table import check_recorded
from stickslip.studies.sweep.task_log import LogTee, TaskLog

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
    scene's run directory (a ``studies.rundir.RunDirectory``, as every run's) and log, and
    saves each scene's files when the batch is done. A member whose files could not be
    written (a full disk) is ``failed``, and where its own summary cannot say so,
    ``failures`` (id -> message, as ``table.check_recorded``) does."""
    t0 = time.perf_counter()
    mine = _claimable(tasks, out_dir, stream)
    if len(mine) < len(tasks):  # a user's folder under runs/ is never written: run the rest
        statuses = dict.fromkeys((t.id for t in tasks), "failed")
        if mine:
            done = run_batch(spec, mine, out_dir, world_rank, backend, stream, failures)
            statuses.update(zip((t.id for t in mine), done, strict=True))
        return [statuses[t.id] for t in tasks]
    members: list[_Member] = []
    with deferred_signals() as early:  # every member marked running (or failed), or none
        for t in tasks:
            member = _Member(spec, t, out_dir, t0, failures)
            if member.start(f"world rank {world_rank} (1 rank(s)) pid {os.getpid()} "
                            f"batch of {len(tasks)} ({backend})"):
                members.append(member)
    if not members:
        if early:
            raise KeyboardInterrupt
        return ["failed"] * len(tasks)
    statuses = dict.fromkeys((t.id for t in tasks), "failed")
    _run_members(members, backend, out_dir, early, spec.compress)
    statuses.update((m.task.id, m.status) for m in members)
    return [statuses[t.id] for t in tasks]


def _run_members(members: list[_Member], backend: str, out_dir: Path, early: list[int],
                 compress: bool) -> None:
    """Run the members whose run directories and logs are ready (``_Member.start``) as one
    batch and save each one's files (``_Member.status``); KeyboardInterrupt once every
    member is written, if a signal came."""
    profile = Profile()
    interrupted = bool(early)
    batch = None
    try:
        if not interrupted:
            batch = Simulation.batch([m.dir.scene for m in members], profile,
                                     backend=backend, spool_parent=out_dir,
                                     memory_budget=SPOOL_MEMORY_FRACTION * available_memory(),
                                     progress=LogTee([m.log for m in members]))
            for k, err in batch.failures.items():  # a set-up that failed fails alone
                members[k].fail(err)
        if batch is not None and batch.live:
            batch.proceed()
    except KeyboardInterrupt:
        interrupted = True
    except Exception as err:  # the batch as a whole failed: every scene still running fails
        for k, member in enumerate(members):
            if batch is None or batch.runs[k].status == "running" or k in batch.live:
                member.fail(err)
        batch = None
    with profile.phase("output"), deferred_signals() as came:
        extra = {"batch": {"size": len(members), "backend": backend}}
        for k, member in enumerate(members):
            if batch is not None and k in batch.live:
                member.save(batch.runs[k], interrupted, profile, backend, extra, compress)
            elif batch is None and interrupted:
                member.end("interrupted", "interrupted before the batch was built")
    interrupted = interrupted or bool(came)  # honoured once every member is written
    if batch is not None and batch.columns.spool_dir is not None:  # now in each samples.npz
        shutil.rmtree(batch.columns.spool_dir, ignore_errors=True)
    for member in members:
        member.close()
    if interrupted:
        raise KeyboardInterrupt


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


class _Member:
    """A batch member's run directory (``studies.rundir.RunDirectory``), its log
    (``task_log.TaskLog``, as a scene run alone has) and its status in the sweep
    (``table.check_recorded``: a failure its own summary cannot hold goes into the sweep's
    ``failures``)."""

    def __init__(self, spec: SweepSpec, task: Task, out_dir: Path, t0: float,
                 failures: dict[str, str] | None) -> None:
        self.task, self.failures = task, failures
        self.dir = RunDirectory(scene_for(spec, task), out_dir / "runs" / task.id)
        self.log_path = out_dir / "logs" / f"{task.id}.log"
        self.log: TaskLog | None = None
        self.t0, self.status = t0, "failed"

    def start(self, where: str) -> bool:
        """Open the log, claim the run directory in place and let its lock go at once (a
        batch of B members would otherwise hold B open files while it runs), write its
        scene.toml and ``running`` summary. False: a write failed (a full disk), and the
        member is ``failed`` and left out of the batch; its log says why, and so does its
        summary or else ``failures``."""
        from mpi4py import MPI

        self.log = TaskLog(self.log_path)
        self.log.start(where)
        try:
            self.dir.claim(True, MPI.COMM_SELF, in_place=True, t0=self.t0)  # the batch's
            self.dir.release()
            self.dir.start()
        except OSError as err:
            self.end("failed", f"{type(err).__name__}: {err}")
            self.log.write(f"{type(err).__name__}: {err}\n")
            self.close()
            return False
        return True

    def fail(self, err: BaseException) -> None:
        """The member's run raised: its traceback in the log, ``failed`` in its summary."""
        tb = "".join(traceback.format_exception(err))
        self.log.write(tb)
        self.end("failed", f"{type(err).__name__}: {err}", traceback=tb.splitlines()[-6:],
                 ranks=1)

    def end(self, status: str, message: str, **facts: object) -> None:
        """``RunDirectory.end``; a summary that cannot be written goes to ``failures``."""
        self.status = status
        try:
            self.dir.end(status, message, **facts)
        except OSError as write_err:  # a full disk: the sweep's table records it
            message += f"; its summary could not be written ({write_err})"
        if status == "failed":
            check_recorded(self.dir.final, {"status": status, "message": message},
                           self.failures, self.task.id)

    def save(self, run, interrupted: bool, profile: Profile, backend: str,  # noqa: ANN001
             extra: dict, compress: bool) -> None:
        """summary.json, samples.npz, final_field.npz and checkpoint.npz of the member's run
        (a ``solver.columns.SceneRun``), saved as a single run's."""
        if run.recorder is None:  # interrupted before the batch was built
            self.end("interrupted", "interrupted before the batch was built")
            return
        if interrupted:
            run.status, run.message = "interrupted", "interrupted"
        summary = self.dir.save_member(run, profile, backend, extra, compress)
        print_summary(summary, self.dir.final, self.log.file, False)
        # the summary's status (failed where a write failed), if its file holds it
        self.status = check_recorded(self.dir.final, summary, self.failures, self.task.id)

    def close(self) -> None:
        if self.log is not None:
            self.log.end(self.status)
