"""Continue runs from their checkpoints: ``stickslip continue RUN --until T [-o DIR]``.

A run that ended at a whole time level left ``checkpoint.npz`` (``studies.rundir.checkpoint``):
its last level's state and its observers' sums. ``continue_run`` builds the same scene with
``time.end_time = T`` (and no ``time.max_steps``), restores the checkpoint into the
``solver.run.Simulation`` (``Simulation.restore``) and lets it proceed through the one time
loop (``solver.run.run_loop``); the samples taken before are read back from samples.npz and
put in front of the new ones. The continued run's samples, final field and summary are
bitwise those of one run straight to T, except the wall-clock keys (``WALL_CLOCK_KEYS``).

``continue_batch`` does the same for many run directories at once: the members of a batch
(``solver.run.Simulation.batch``, e.g. a census's starts) that share mesh, material, dt,
scheme and their checkpoint's step are continued as one batch again (``Simulation.batch``
+ ``restore``, the same ``run_loop``); single runs are continued one by one. A continued
batch solves no steady state (``restore`` overwrites the start), and its mesh, K, M, ω_max
and layout are kept in the process (``BUILT``, per batch key without the end time) for the
next leg of the same scenes, which takes them instead of building them again.

Where the result goes:

* without ``out_dir`` the run directory is extended in place, atomically: the continued run
  is written into a hidden sibling claimed by ``studies.rundir.ownership`` and swapped in
  when it ends; a continuation that fails or is interrupted leaves the run as it was;
* with ``out_dir`` the original is not touched and ``out_dir`` becomes a run directory of its
  own (``force`` replaces an earlier one there).

Refused in one line (``studies.rundir.readers.ReadError``, exit status 2), by
``plan_continuation`` before anything is claimed, built or written: ``until`` not beyond the
checkpoint's time, a run without a checkpoint (older, failed or diverged), a checkpoint of
another number of ranks, a run that writes fields (``output.fields``: its fields.bp + stress.bp,
or fields.xdmf + fields.h5, are not extended; the line gives the ``stickslip run`` that
writes them to T), and a checkpoint that is damaged or does not fit its run in any field
(``studies.rundir.checkpoint.check_checkpoint``: its kind, shapes, dtypes, finite numbers,
clock and counts against the scene, summary.json and samples.npz). A batch member's
checkpoint is checked the same way, every member before any batch starts.
"""

from __future__ import annotations

import math
import shlex
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from stickslip.solver.run import Profile, Simulation
from stickslip.solver.scene import Scene, write_scene
from stickslip.solver.schemes.select import (
    check_continuing_kernel,
    continuing_backend,
    moved_backends,
)
from stickslip.studies.batching import SPOOL_MEMORY_FRACTION, batch_key
from stickslip.studies.resources import available_memory
from stickslip.studies.rundir.checkpoint import (
    CHECKPOINT,
    DAMAGED_FIX,
    Checkpoint,
    check_checkpoint,
    read_checkpoint,
    scene_fingerprint,
)
from stickslip.studies.rundir.ownership import owned
from stickslip.studies.rundir.readers import (
    ReadError,
    check_agreement,
    read_samples,
    read_scene_file,
    read_summary,
    read_surface,
)
from stickslip.studies.rundir.scene_run import SceneRunner, every_rank
from stickslip.studies.rundir.writer import RunDirectory, print_summary

if TYPE_CHECKING:  # MPI starts where a run uses it, not when this module is imported
    from mpi4py import MPI

__all__ = ["RESUMABLE", "WALL_CLOCK_KEYS", "checkpoint_plan", "continue_batch", "continue_run",
           "plan_continuation"]

#: The field files a run directory gets per ``output.field_format`` (as
#: ``solver.writers.FIELD_FILES``, which needs dolfinx to import).
FIELD_FILES = {"vtx": ("fields.bp", "stress.bp"), "xdmf": ("fields.xdmf", "fields.h5")}

#: The final statuses whose runs stand at a whole level and wrote a checkpoint.
RESUMABLE = ("completed", "stopped", "interrupted")

#: Summary keys that measure the machine, not the run: they differ between a continued run
#: and one run straight to T (wall time, peak memory, the time per phase, the kernels'
#: compile time and the contact and linear solves' wall time) and between any two runs.
WALL_CLOCK_KEYS = ("wall_time_s", "peak_rss_mb", "profile_s", "scheme.kernel_first_call_s",
                   "scheme.contact_s", "scheme.factorisation_s", "scheme.linear_solves_s")


#: The ``solver.ensemble_run.BuiltProblem`` of the batches continued in this process, by
#: ``built_key``; the last ``BUILT_KEEP`` kept (a census has one per mesh).
BUILT: dict[str, object] = {}
BUILT_KEEP = 4


def built_key(scene: Scene) -> str | None:
    """The batch key of ``scene`` (``studies.batching.batch_key``: same K, M, dt,
    scheme, layout) without its run limits, which the legs of a continuation change."""
    return batch_key(scene.with_overrides("time.end_time=1.0", "time.max_steps=0",
                                          "time.max_wall_time=0.0"))


@dataclass
class _Plan:
    """What a continuation of ``run_dir`` needs (rank 0): the scene to T, the checkpoint and
    the records taken so far."""

    run_dir: Path
    scene: Scene
    checkpoint: Checkpoint
    before: dict[str, np.ndarray]
    surface: dict[str, np.ndarray] | None = None  # a 3D tube's surface.npz

    @property
    def kind(self) -> str:
        return self.checkpoint.kind


def plan_continuation(run_dir: str | Path, until: float, ranks: int = 1) -> _Plan:
    """Check that ``run_dir`` can be continued to ``until`` on ``ranks`` ranks, reading
    every file and changing none: the run (its marker, a final status that stands at a
    whole level), its checkpoint as a file (``read_checkpoint``), the ranks, the time, its
    scene.toml (the scene that wrote the checkpoint), its samples.npz and summary.json (one
    run, ``check_agreement``) and the checkpoint against them all (``check_checkpoint``).
    ReadError (one line: the file, the field, the fix) for the first fault; the plan
    otherwise. ``continue_run`` and ``continue_batch`` call it before they claim anything."""
    run_dir = Path(run_dir)
    if not owned(run_dir, "run"):
        raise ReadError(run_dir, "not a stickslip run directory (no .stickslip marker of a "
                                 "run)", "give the directory that `stickslip run` wrote")
    summary = read_summary(run_dir)
    status = summary["status"]
    if status == "running":
        raise ReadError(run_dir, "the run is still running (or its process was killed)",
                        "wait for it to end, or run the scene again")
    if status not in RESUMABLE:
        raise ReadError(run_dir, f"the run ended {status}: there is no whole time level to "
                                 "continue from", "fix the scene and run it again")
    ck = read_checkpoint(run_dir)
    written = int(ck.meta["ranks"])
    if written != ranks:
        raise ReadError(run_dir / CHECKPOINT,
                        f"written on {written} rank(s), continued on {ranks}",
                        f"continue it under `mpirun -n {written}` (the partition must match)"
                        if written > 1 else "continue it without mpirun (one rank)")
    if not (math.isfinite(until) and until * (1.0 - 1e-12) > ck.time):
        raise ReadError(run_dir, f"--until {until!r}: the run is already at t = "
                                 f"{ck.time:.9g} s", "give a later time")
    scene = read_scene_file(run_dir / "scene.toml")
    if scene_fingerprint(scene) != ck.meta["scene_sha256"]:
        raise ReadError(run_dir / "scene.toml", "is not the scene its checkpoint was written "
                        "with (edited since?)", "continue with the scene as it ran, or run "
                        "the edited scene from the start")
    if scene.output.fields:
        files = " + ".join(FIELD_FILES[scene.output.field_format])
        limit = " --set time.max_steps=0" if scene.time.max_steps else ""
        again = (f"stickslip run {shlex.quote(str(run_dir / 'scene.toml'))} --set "
                 f"time.end_time={until!r}{limit} -o "
                 f"{shlex.quote(f'{run_dir}_to_{until:g}s')}")
        raise ReadError(run_dir, f"the run writes fields (output.fields = true: {files}), "
                                 "which a continuation does not extend",
                        f"for the fields of the span to T = {until:g} s run the scene again "
                        f"to T: `{again}`")
    before = read_samples(run_dir, need=0)
    check_agreement(run_dir, summary, scene, before)
    check_checkpoint(ck, scene=scene, summary=summary, samples=before)
    surface = read_surface(run_dir, before) if scene.mesh.dim == 3 else None
    scene = scene.with_overrides(f"time.end_time={until!r}", "time.max_steps=0")
    return _Plan(run_dir, scene, ck, before, surface)


def checkpoint_plan(run_dir: str | Path) -> _Plan:
    """``plan_continuation`` of ``run_dir`` where its checkpoint stands, on one rank (a
    second past it: every file read and checked): what a test restarted from the checkpoint
    reads, its scene and state, without continuing the run itself."""
    run_dir = Path(run_dir)
    t_ck = float(read_summary(run_dir)["sim_time_s"])
    return plan_continuation(run_dir, t_ck + 1.0, 1)


class Refused(ReadError):
    """Rank 0's ``ReadError``, raised on the other ranks with the same line."""

    def __init__(self, message: str) -> None:
        ValueError.__init__(self, message)


def _planned(run_dir: Path, until: float, comm: MPI.Comm) -> _Plan | None:
    """``plan_continuation`` on rank 0; its refusal raised on every rank. The plan on rank
    0, else None."""
    plan, error = None, None
    if comm.rank == 0:
        try:
            plan = plan_continuation(Path(run_dir), float(until), comm.size)
        except ReadError as err:
            error = err
    message = comm.bcast(None if error is None else str(error), root=0)
    if message is not None:
        raise error if error is not None else Refused(message)
    return plan


def continue_run(run_dir: str | Path, until: float, out_dir: str | Path | None = None, *,
                 force: bool = False, comm: MPI.Comm | None = None, stream=None,
                 check_resources: bool = True, kick: float = 0.0,
                 kick_seed: int = 0, progress: bool | None = None) -> dict:
    """Continue the run in ``run_dir`` from its checkpoint to ``until`` seconds (collective).

    Args:
        run_dir: a run directory with a checkpoint (a run or a batch member).
        until: the new end time (s), beyond the checkpoint's time.
        out_dir: where the continued run goes; None: ``run_dir`` itself, swapped in
            atomically when the continuation ends (kept as it was if it fails or is
            interrupted).
        force: replace an earlier run directory at ``out_dir``.
        comm: the ranks; the same number as the run's (its partition); default: every rank.
        stream: where the progress and summary lines go (default stdout).
        check_resources: refuse a continuation beyond the machine's memory or disk.
        kick: perturb the run where it stands by this fraction of its displacement and
            velocity RMS (``solver.scene_column.SceneColumn.kick``, seed ``kick_seed``; its
            facts in the summary's ``kick``), into ``out_dir`` only: a new experiment from
            the kick on, its records starting there (as ``continue_batch``'s kicks).
        progress: progress lines on ``stream`` while it runs; None: as its scene's
            ``output.progress`` (off in a sweep's or census's scenes, for their consoles).

    Returns:
        The continued run's summary (rank 0; ``{}`` elsewhere), as ``run_scene``'s.

    Raises:
        studies.rundir.readers.ReadError: the run cannot be continued (one line, the fix).
        studies.rundir.RunDirError: ``out_dir`` is not free, or the run is live.
    """
    run_dir, comm = Path(run_dir), every_rank(comm)
    if kick and (out_dir is None or Path(out_dir).resolve() == run_dir.resolve()):
        raise ValueError("a kick continues a run into another directory (out_dir), never "
                         "into the run itself")
    plan = _planned(run_dir, until, comm)
    if comm.bcast(plan.kind if plan is not None else None, root=0) == "batch":
        return continue_batch([run_dir], until, None if out_dir is None else [out_dir],
                              force=force, stream=stream, plans=[plan], kick=kick,
                              kick_seed=kick_seed, progress=plan.scene.output.progress
                              if progress is None else progress)[0]
    scene = comm.bcast(plan.scene if plan is not None else None, root=0)
    state = comm.scatter(plan.checkpoint.states if plan is not None else None, root=0)
    before = plan.before if plan is not None and not kick else None
    surface = plan.surface if plan is not None and not kick else None
    if kick:  # records from the kick on: no history copied along
        state = dict(state, **{"run/samples": np.int64(0), "run/probe_steps": np.int64(0)})
    kernel = comm.bcast(plan.checkpoint.meta["kernel"] if plan is not None else None, root=0)

    def resume(sim) -> None:  # noqa: ANN001 - a solver.run.Simulation

        check_continuing_kernel(kernel, sim.stepper)
        try:
            sim.restore([state], [before])
            sim.columns.surface_before(surface)
            if kick:
                sim.runs[0].kick = sim.columns.kick(0, kick, kick_seed)
        except KeyError as err:  # every key is written by this format: an edited file
            raise ValueError(f"checkpoint.npz has no {err}: not written by this version of "
                             "stickslip (or edited); run the scene again to T") from None

    target = run_dir if out_dir is None else Path(out_dir)
    in_place = target.resolve() == run_dir.resolve()
    if plan is not None:
        meta = plan.checkpoint.meta
        print(f"continuing {run_dir} from t = {meta['time']:.6g} s (step {meta['step']}) to "
              f"{until:g} s" + ("" if in_place else f" into {target}"),
              file=sys.stdout if stream is None else stream, flush=True)
    return SceneRunner(scene, target, force=force or in_place, comm=comm, stream=stream,
                       check_resources=check_resources, resume=resume,
                       progress=progress).run()


def continue_batch(run_dirs: list[str | Path], until: float,
                   out_dirs: list[str | Path] | None = None, *, force: bool = False,
                   stream=None, kick: float = 0.0, kick_seed: int = 0,
                   compress: bool = True, plans: list[_Plan] | None = None,
                   progress: bool = False) -> list[dict]:
    """Continue many runs of one rank each to ``until``: the members of batches that share a
    mesh, material, dt, scheme, backend and checkpoint step as one ``Simulation.batch`` (one
    time loop for all of them), single runs one by one (``continue_run``).

    Args:
        run_dirs: run directories with checkpoints (batch members or one-rank runs).
        until: the new end time (s), beyond every checkpoint's time.
        out_dirs: one output directory per run (None: each run extended in place, as
            ``continue_run``).
        force: replace earlier run directories at ``out_dirs``.
        stream: where the summary lines go (default stdout).
        kick: perturb every run where it stands by this fraction of its displacement and
            velocity RMS before it goes on (``solver.ensemble_run.BatchColumns.kick``,
            seed ``kick_seed``; its facts in the summary's ``kick``; a one-scene run's:
            ``continue_run``'s), into ``out_dirs`` (the runs themselves are never kicked).
            A kicked run is a new experiment from the kick on: its records (samples,
            probes) start there, without the history before it, which stays in the run it
            was kicked from.
        compress: the batch members' samples.npz deflated, else stored (faster to write
            and to read again; ``RunDirectory.save_member``).
        plans: ``plan_continuation`` of each run, where the caller has made them
            (``continue_run``): a run's samples are then read once, not twice.
        progress: a batch's progress line on ``stream`` every few seconds of its time loop
            (``solver.observers.Progress``; a census's settle log), which its members'
            scenes (a sweep's: ``output.progress`` off) would not print.

    Returns:
        The continued runs' summaries, in the order of ``run_dirs``.

    Raises:
        studies.rundir.readers.ReadError: a run cannot be continued (checked for every run
            before any starts).
        ValueError: a kick without ``out_dirs``.
    """
    from mpi4py import MPI  # a continuation starts MPI; importing this module does not

    comm = MPI.COMM_SELF
    dirs = [Path(d) for d in run_dirs]
    outs = [None] * len(dirs) if out_dirs is None else [Path(d) for d in out_dirs]
    if plans is None:
        plans = [plan_continuation(d, float(until), 1) for d in dirs]
    if kick and out_dirs is None:
        raise ValueError("a kick continues a run into another directory (out_dirs), never "
                         "in place")
    summaries: list[dict] = [{} for _ in dirs]
    groups: dict[tuple, list[int]] = {}
    backends = [p.checkpoint.meta["backend"] for p in plans if p.kind == "batch"]
    here = {there: continuing_backend(there) for there in set(backends)}  # asked once each
    for i, plan in enumerate(plans):
        meta = plan.checkpoint.meta
        if plan.kind == "batch":
            key = (meta["step"], here[meta["backend"]], batch_key(plan.scene))
            groups.setdefault(key, []).append(i)
    for line in moved_backends(backends, here):
        print(line, file=sys.stdout if stream is None else stream, flush=True)
    for i, plan in enumerate(plans):
        if plan.kind != "batch":
            summaries[i] = continue_run(dirs[i], until, outs[i], force=force, comm=comm,
                                        stream=stream, kick=kick, kick_seed=kick_seed)
    out = sys.stdout if stream is None else stream
    for (_, backend, _), members in groups.items():
        done = _continue_members([plans[i] for i in members], [outs[i] for i in members],
                                 backend, force, out, kick, kick_seed, compress,
                                 out if progress else None)
        for i, summary in zip(members, done, strict=True):
            summaries[i] = summary
    return summaries


def _continue_members(plans: list[_Plan], outs: list[Path | None], backend: str,
                      force: bool, stream, kick: float = 0.0, kick_seed: int = 0,
                      compress: bool = True, progress=None) -> list[dict]:  # noqa: ANN001
    """One ``Simulation.batch`` of batch members at the same step, continued (each kicked
    by ``kick``, ``continue_batch``) and written; an error or interrupt drops every
    replacement (the runs stay as they were). ``progress``: where the batch's progress
    lines go, or None."""
    import shutil
    import time

    from mpi4py import MPI  # a continuation starts MPI; importing this module does not

    t0 = time.perf_counter()
    claims = []
    batch = None
    try:
        for plan, out in zip(plans, outs, strict=True):
            target = plan.run_dir if out is None else out
            in_place = target.resolve() == plan.run_dir.resolve()
            member = RunDirectory(plan.scene, target)
            member.claim(force or in_place, MPI.COMM_SELF, t0=t0)  # the batch's wall time
            claims.append(member)
        profile = Profile()
        key = built_key(plans[0].scene)
        batch = Simulation.batch([p.scene for p in plans], profile, backend=backend,
                                 spool_parent=plans[0].run_dir.parent,
                                 memory_budget=SPOOL_MEMORY_FRACTION * available_memory(),
                                 built=BUILT.get(key), resumed=True, progress=progress)
        if batch.failures:
            raise next(iter(batch.failures.values()))
        BUILT.pop(key, None)  # the latest last: the oldest goes first
        BUILT[key] = batch.columns.built
        while len(BUILT) > BUILT_KEEP:
            BUILT.pop(next(iter(BUILT)))
        states = [p.checkpoint.states[0] for p in plans]
        befores = [p.before for p in plans]
        if kick:  # records from the kick on (``continue_batch``): no history copied along
            states = [dict(s, **{"run/samples": np.int64(0), "run/probe_steps": np.int64(0)})
                      for s in states]
            befores = [None] * len(plans)
        try:
            batch.restore(states, befores)
        except (KeyError, ValueError) as err:  # checked before: a forgery consistent in itself
            raise ReadError(plans[0].checkpoint.path, f"does not fit the batch built for its "
                            f"scene ({' '.join(str(err).split())[:120]})", DAMAGED_FIX) from None
        kicks = [batch.columns.kick(b, kick, kick_seed) if kick else None
                 for b in range(len(plans))]
        batch.proceed()
        summaries = []
        for claim, run, kicked in zip(claims, batch.runs, kicks, strict=True):
            write_scene(run.scene, claim.work / "scene.toml")
            extra = {"batch": {"size": len(plans), "backend": backend}}
            if kicked:
                extra["kick"] = kicked
            summary = claim.save_member(run, profile, backend, extra, compress)
            print_summary(summary, claim.final, stream, False)
            summaries.append(summary)
        return summaries
    except BaseException:
        for claim in claims:
            claim.discard()
        raise
    finally:
        for claim in claims:
            claim.release()
        if batch is not None and batch.columns.spool_dir is not None:
            shutil.rmtree(batch.columns.spool_dir, ignore_errors=True)
