"""Sweep execution (``run_sweep``) under MPI.

COMM_WORLD is split into groups of ``group_size`` ranks; the leader of each group takes the
next pending scene from a shared counter on rank 0 (MPI-3 passive target
``Fetch_and_op``), so every rank works and a slow scene only occupies its own group.
Each scene runs with ``studies.rundir.run_scene`` into ``SWEEP_DIR/runs/<id>/``, its console
output goes to ``SWEEP_DIR/logs/<id>.log`` (appended: one ``== start`` line per attempt).

Resume and faults: a scene whose ``summary.json`` holds a final status (completed, diverged,
failed) for the same resolved scene is skipped; ``running``/``interrupted`` ones (killed in
flight) run again. An exception inside a scene is recorded as status ``failed`` with its
message and the sweep goes on. Rank 0 rebuilds the table ``SWEEP_DIR/sweep.{csv,json}``
(atomically) from the summaries whenever a scene finishes (a sweep of more than
``TABLE_SMALL`` scenes at most every ``TABLE_PERIOD`` s), so a killed sweep's table lags by
at most the scenes in flight (or that period); a resume rebuilds it from the summaries.
"""

from __future__ import annotations

import math
import os
import shutil
import sys
import threading
import time
import traceback
from collections import Counter
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

from stickslip.postprocess.style import wave_title
from stickslip.solver.atomic import atomic_write_text
from stickslip.solver.scene import (
    write_scene,
)
from stickslip.studies.output import process_alive
from stickslip.studies.resources import MAX_SECONDS, ResourceError, _duration, estimate
from stickslip.studies.rundir import run_scene
from stickslip.studies.rundir.ownership import OwnershipError, claim, owned, user_entries
from stickslip.studies.rundir.summary_file import write_summary
from stickslip.studies.sweep.batch import plan_units, run_batch
from stickslip.studies.sweep.spec import (
    FINAL_STATUSES,
    SweepError,
    SweepSpec,
    Task,
    _cost,
    scene_for,
)
from stickslip.studies.sweep.table import (
    _read_json,
    check_recorded,
    recorded_failures,
    run_warnings,
    task_state,
    write_table,
)
from stickslip.studies.sweep.task_log import TaskLog

if TYPE_CHECKING:  # pragma: no cover
    from mpi4py import MPI

# ============================================================================ progress


def _fmt_duration(seconds: float) -> str:
    if not math.isfinite(seconds):
        return "?"
    seconds = int(round(seconds))
    h, rem = divmod(seconds, 3600)
    m, s = divmod(rem, 60)
    return f"{h}h{m:02d}m" if h else (f"{m}m{s:02d}s" if m else f"{s}s")


TABLE_SMALL = 1000  # scenes: up to this many, the table is rewritten at every finished one
TABLE_PERIOD = 30.0  # s between rewrites of a larger table


class _Monitor(threading.Thread):
    """Rank 0's progress and table keeper: polls the pending scenes' ``summary.json``.

    Runs beside rank 0's own scenes (no MPI calls, wakes every ``interval`` s). Each newly
    finished scene rewrites the table and prints one line; on a TTY (``live``) a status line
    with done / running / failed counts and an ETA is redrawn in place.
    """

    def __init__(self, out_dir: Path, spec: SweepSpec, pending: Sequence[Task], n_done: int,
                 stream: TextIO, live: bool, interval: float = 1.0,
                 failures: dict[str, str] | None = None) -> None:
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
        self.table_written, self.table_dirty = 0.0, False
        self.failures = failures  # the sweep's, shared: the scenes no summary says failed
        # the summaries left by an earlier session (an interrupted scene's, say): each one's
        # file identity now; a rerun replaces the file (atomic write), so only a new one
        # tells this session's outcome
        self.earlier = {t.id: _identity(self._summary(t)) for t in self.pending}

    def _summary(self, task: Task) -> Path:
        return self.out_dir / "runs" / task.id / "summary.json"

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
                path = self._summary(task)
                now = _identity(path)
                fresh = now is not None and now != self.earlier[task.id]  # this session's
                s = (_read_json(path) or {}) if fresh else {}
                failure = (self.failures or {}).get(task.id)
                if failure is not None:  # failed where its own summary could not say so
                    new.append((task, {**s, "status": "failed", "message": failure}))
                    continue
                if not fresh:  # no summary yet, or an earlier session's
                    continue
                status = s.get("status")
                if s.get("analysis") == "pending" and process_alive(s) is not False:
                    # saved, its wave analysis comes next: report the scene with its result
                    running += 1
                elif status in FINAL_STATUSES or status == "interrupted":
                    new.append((task, s))
                elif status == "running" and process_alive(s) is not False:
                    running += 1
            self.running = running
            for task, s in new:
                self.finished[task.id] = s.get("status", "")
                self.failed += s.get("status") in ("failed", "diverged")
                self._say(self._scene_line(task, s))
            self.table_dirty = self.table_dirty or bool(new)
            if self.table_dirty and self._table_due():
                write_table(self.out_dir, self.spec, cache=self.cache, failures=self.failures)
                self.table_written, self.table_dirty = time.time(), False
            if self.live:
                self._redraw()

    def _table_due(self) -> bool:
        """Rewrite the table at every finished scene while it is small; a large one (each
        rewrite reads every summary and writes every row) at most every ``TABLE_PERIOD`` s.
        The final table is always written (:func:`run_sweep`), and a resume rebuilds it."""
        return (self.total <= TABLE_SMALL or self.stop_event.is_set()
                or time.time() - self.table_written >= TABLE_PERIOD)

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
        """One line for a finished scene: its wave or its status and the first line of its
        message, each of its warnings (aliased samples, doubtful choices), its wall time
        where known."""
        done, _, _, eta = self.counts()
        status = s.get("status")
        what = status
        if status == "completed":
            what = wave_title(s)
        elif s.get("message") and s["message"] != status:
            what = f"{status}: {str(s['message']).splitlines()[0]}"  # whole: the fix is last
        warned = "".join(f"; warning: {w}" for w in run_warnings(s))
        wall = s.get("wall_time_s")
        took = f" ({wall:.1f} s)" if isinstance(wall, int | float) else ""
        return (f"[{self.n_done_before + done}/{self.total}] {task.id}: {what}{warned}{took}"
                f"  ETA {_fmt_duration(eta)}")

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


def _identity(path: Path) -> tuple[int, int, int] | None:
    """Which file ``path`` is now (inode, change time, size), or None if there is none."""
    try:
        st = path.stat()
    except OSError:
        return None
    return st.st_ino, st.st_ctime_ns, st.st_size


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
             world_rank: int, check_cost: bool = True,
             failures: dict[str, str] | None = None) -> str:
    """Run one scene on ``group``; exceptions become status ``failed``. Returns the status.

    A failure that the scene's summary does not show (its write failed too: a full disk), or
    a summary that could not take the run's final word, goes into ``failures`` (id ->
    message; leader only) for the table."""
    leader = group.rank == 0
    run_dir = out_dir / "runs" / task.id
    log = TaskLog(out_dir / "logs" / f"{task.id}.log") if leader else None
    t0 = time.perf_counter()
    status = "failed"
    try:
        if log is not None:
            log.start(f"world rank {world_rank} ({group.size} rank(s)) pid {os.getpid()}")
        try:
            summary = run_scene(scene_for(spec, task), run_dir, force=True, comm=group,
                                replace_on_failure=True, check_resources=check_cost,
                                stream=log.file if log is not None else sys.stdout)
            status = str(summary.get("status", "failed")) if leader else "?"
            if leader:
                status = check_recorded(run_dir, summary, failures, task.id)
        except KeyboardInterrupt:
            status = "interrupted"
        except Exception as err:  # recorded, the sweep goes on
            status = "failed"
            if leader:
                tb = traceback.format_exc()
                assert log is not None
                log.write(tb)
                message = f"{type(err).__name__}: {err}"
                try:
                    _record_failure(spec, task, run_dir, err, tb,
                                    time.perf_counter() - t0, group.size)
                except OSError as write_err:  # a full disk: the table records it
                    message += f"; its summary could not be written ({write_err})"
                check_recorded(run_dir, {"status": "failed", "message": message}, failures,
                               task.id)
        if group.size > 1:
            status = group.bcast(status, root=0)
    finally:
        if log is not None:
            log.end(status)
    return status


def _record_failure(spec: SweepSpec, task: Task, run_dir: Path, err: Exception, tb: str,
                    wall: float, ranks: int) -> None:
    """Write a ``failed`` summary for a scene whose run raised, into its run directory only if
    that is stickslip's (or new): a user's folder under ``runs/`` is never written (the
    table shows it as ``foreign``; the log has the error)."""
    if isinstance(err, OwnershipError):
        return
    if not owned(run_dir, "run"):
        try:
            claim(run_dir, "run", force=True, in_place=True).release()
        except OwnershipError:
            return
    if not (run_dir / "scene.toml").exists():  # resume compares against it
        write_scene(scene_for(spec, task), run_dir / "scene.toml")
    prev = _read_json(run_dir / "summary.json") or {}
    prev.update({"scene": f"{spec.name}.{task.id}", "status": "failed",
                 "message": f"{type(err).__name__}: {err}", "traceback": tb.splitlines()[-6:],
                 "wall_time_s": wall, "ranks": ranks})
    write_summary(run_dir, prev)


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


def _classify(out_dir: Path, spec: SweepSpec, retry_failed: bool
              ) -> tuple[list[Task], int, float]:
    """Rank 0, writing nothing: the pending scenes (largest first), the number already done,
    and the estimated one-rank seconds of the pending ones (``studies.resources``)."""
    pending: list[tuple[float, int, Task]] = []
    n_done = 0
    seconds = 0.0
    failures = recorded_failures(out_dir)
    for i, task in enumerate(spec.tasks):
        scene = scene_for(spec, task)
        state = task_state(out_dir, spec, task, scene, failures)
        redo = retry_failed and state in ("failed", "diverged")
        if state in FINAL_STATUSES and not redo:
            n_done += 1
        else:
            pending.append((-_cost(scene), i, task))
            seconds += estimate(scene, spec.group_size).seconds
    pending.sort(key=lambda x: (x[0], x[1]))
    return [t for _, _, t in pending], n_done, seconds


def _cost_problem(spec: SweepSpec, n_pending: int, seconds: float, n_groups: int,
                  group_size: int) -> str | None:
    """Why the pending scenes are too long to start without ``--yes-i-know``, or None."""
    wall = seconds / max(1, n_groups * group_size)
    if wall <= MAX_SECONDS:
        return None
    return (f"sweep {spec.name}: {n_pending} pending scenes would take about "
            f"{_duration(wall)} on {n_groups} group(s) of {group_size} rank(s) (estimate); "
            "use fewer points or a shorter time.end_time, more ranks, or pass --yes-i-know")


def _prepare(out_dir: Path, spec: SweepSpec) -> None:
    """Rank 0: the sweep directory's folders, its copy of the sweep file, the initial table.
    A folder that is a symbolic link is refused (SweepError): stickslip writes no link's
    target."""
    for name in ("runs", "logs"):
        if (out_dir / name).is_symlink():
            raise SweepError(f"{out_dir / name} is a symbolic link, which stickslip never "
                             "makes; it does not write through it: replace it with a folder, "
                             "or choose another -o")
    (out_dir / "runs").mkdir(parents=True, exist_ok=True)
    (out_dir / "logs").mkdir(exist_ok=True)
    atomic_write_text(out_dir / "sweep.toml", spec.path.read_text())
    write_table(out_dir, spec)


def _lock(out_dir: Path):  # noqa: ANN202
    """Claim the sweep directory (``studies.rundir.ownership``, kind ``sweep``): a new one,
    or a sweep directory to resume; a live one (another sweep), a user's folder or another
    kind of directory is refused in one line."""
    try:
        return claim(out_dir, "sweep", reuse=True)
    except OwnershipError as err:
        raise SweepError(str(err)) from None


def _run_unit(spec: SweepSpec, unit: list[Task], out_dir: Path, group: MPI.Comm,
              world_rank: int, backend: str, check_cost: bool = True,
              failures: dict[str, str] | None = None) -> str:
    """One work unit: a single scene (``_run_one``) or a batch (``studies.sweep.batch``)."""
    if len(unit) == 1:
        return _run_one(spec, unit[0], out_dir, group, world_rank, check_cost, failures)

    try:
        statuses = run_batch(spec, unit, out_dir, world_rank, backend=backend,
                             failures=failures)
    except KeyboardInterrupt:
        return "interrupted"
    return "failed" if "failed" in statuses else "completed"


def run_sweep(spec: SweepSpec, out_dir: str | Path, *, comm: MPI.Comm | None = None,
              group_size: int | None = None, retry_failed: bool = False,
              stream: TextIO | None = None, progress: str = "auto", batch: str | None = None,
              backend: str | None = None, check_cost: bool = True) -> int:
    """Run every pending scene of ``spec`` into ``out_dir``; collective over ``comm``.

    ``check_cost``: refuse (exit 2, before anything is written) pending scenes whose
    estimated time on the groups exceeds ``studies.resources.MAX_SECONDS``, and each scene
    beyond the machine (``studies.resources.check_resources``); ``--yes-i-know``: False.

    ``batch`` ("off", "auto" or a size B): scenes sharing mesh, material, dt and scheme run
    as batches of ``solver.ensemble`` (studies/sweep/batch.py) on ``backend`` (cpu, gpu);
    None: the sweep file's ``batch`` / ``backend`` (default off / cpu).

    Returns 0 (every scene final, none ``failed``), 1 (the table holds a scene that failed
    with an exception), 130 (interrupted: the table holds what finished; run again to resume).
    """
    from mpi4py import MPI

    comm = MPI.COMM_WORLD if comm is None else comm
    stream = sys.stdout if stream is None else stream  # the current one (a test's capture)
    batch = spec.batch if batch is None else batch
    backend = spec.backend if backend is None else backend
    out_dir = Path(out_dir)
    g = group_size or spec.group_size
    rank0 = comm.rank == 0
    t_start = time.time()
    info, lock = _plan_on_rank0(spec, out_dir, comm, g, retry_failed, check_cost, batch) \
        if rank0 else (None, None)
    info = comm.bcast(info, root=0)
    if isinstance(info, str):
        if rank0:
            print(f"error: {info}", file=sys.stderr, flush=True)
            if lock is not None:
                lock.release()
        return 2
    by_id = {t.id: t for t in spec.tasks}
    units = [[by_id[i] for i in u] for u in info[0]]
    pending = [t for u in units for t in u]
    n_done = info[1]
    n_groups = (comm.size + g - 1) // g
    group = comm.Split(comm.rank // g, comm.rank)
    _init_petsc(group)
    monitor = None
    # the failures that no summary records (a full disk): those recorded before, less the
    # scenes that run again now (rank 0), then this session's; the table shows them
    failures: dict[str, str] = {}
    if rank0:
        ran = {t.id for t in pending}
        failures.update({k: v for k, v in recorded_failures(out_dir).items() if k not in ran})
        _announce(spec, out_dir, units, n_done, comm.size, g, backend, stream)
        monitor = _Monitor(out_dir, spec, pending, n_done, stream, _want_live(progress, stream),
                           failures=failures)
        monitor.start()
    interrupted = _run_units(spec, units, out_dir, comm, group, backend, check_cost, failures)
    rc = 130
    if rank0:
        assert monitor is not None
        monitor.stop()
        session = {"started": t_start, "finished": time.time(), "ranks": comm.size,
                   "groups": n_groups, "group_size": g, "pending_at_start": len(pending),
                   "interrupted": interrupted}
        rc = _report(spec, out_dir, session, failures, stream)
        if lock is not None:
            lock.release()
    if not interrupted:
        rc = comm.bcast(rc, root=0)
    return rc


def _plan_on_rank0(spec: SweepSpec, out_dir: Path, comm: MPI.Comm, g: int, retry_failed: bool,
                   check_cost: bool, batch: str) -> tuple[tuple | str, Any]:
    """Rank 0: claim the sweep directory, find the pending scenes, refuse them if too long,
    prepare the directory and plan the work units. Returns ((unit ids, scenes done) or the
    refusal's message, the claim or None)."""
    lock = None
    try:
        lock = _lock(out_dir)
        n_groups = (comm.size + g - 1) // g
        try:
            pending, n_done, seconds = _classify(out_dir, spec, retry_failed)
            problem = _cost_problem(spec, len(pending), seconds, n_groups, g) \
                if check_cost else None
        except ResourceError as err:  # a scene whose steps cannot even be counted
            problem = f"sweep {spec.name}: {err}"
        if problem:
            if lock.created and not user_entries(out_dir):
                shutil.rmtree(out_dir, ignore_errors=True)  # made for nothing
            raise SweepError(problem)
        _prepare(out_dir, spec)

        units = plan_units(spec, pending, batch, (comm.size + g - 1) // g, g)
        return ([[t.id for t in u] for u in units], n_done), lock
    except (SweepError, OSError) as err:
        return str(err), lock


def _announce(spec: SweepSpec, out_dir: Path, units: list[list[Task]], n_done: int,
              ranks: int, g: int, backend: str, stream: TextIO) -> None:
    """Rank 0: the sweep's first lines (scenes, groups, batches)."""
    n_groups = (ranks + g - 1) // g
    pending = sum(len(u) for u in units)
    print(f"sweep {spec.name}: {len(spec.tasks)} scenes, {n_done} already done, "
          f"{pending} to run on {n_groups} group(s) of {g} rank(s) -> {out_dir}",
          file=stream, flush=True)
    batches = Counter(len(u) for u in units if len(u) > 1)  # size -> how many
    if batches:  # one entry per size, however many batches: "(250 × 4, 1 × 2 scenes)"
        sizes = ", ".join(f"{n} × {size}" for size, n in sorted(batches.items(), reverse=True))
        print(f"  batched ({backend}): {batches.total()} batch(es) ({sizes} scenes), "
              f"{len(units) - batches.total()} single scene(s)", file=stream, flush=True)
    if g > ranks:
        print(f"  note: group_size {g} is more than the {ranks} rank(s) of this run: each "
              f"scene runs on {ranks} rank(s) (mpirun -n {g} gives it {g})", file=stream,
              flush=True)
    elif ranks % g:
        print(f"  note: {ranks} ranks are not a multiple of group_size {g}; the last "
              f"group has {ranks % g} rank(s)", file=stream, flush=True)


#: Seconds between two looks of a rank waiting for the others (``wait_quietly``).
QUIET_POLL_S = 0.02


def wait_quietly(comm: MPI.Comm, poll_s: float = QUIET_POLL_S) -> None:
    """Collective: return when every rank of ``comm`` has called it, sleeping meanwhile.

    A blocking MPI collective busy-waits: the rank that waits (for rank 0's analysis, or
    for a slower rank's batch) burns a core at 100 %, which on a machine with as many
    busy processes as cores takes that core from the rank that works. Here the waiting
    rank tests a non-blocking barrier every ``poll_s`` and sleeps in between (at most
    ``poll_s`` late); the collective that follows then finds every rank there. A
    KeyboardInterrupt (SIGINT, or SIGTERM where a handler raises it) is raised once every
    rank has arrived, as it would be after a blocking collective returned."""
    if comm.size == 1:
        return
    interrupt: KeyboardInterrupt | None = None
    request = comm.Ibarrier()
    while True:
        try:
            if request.Test():
                break
            time.sleep(poll_s)
        except KeyboardInterrupt as err:
            interrupt = err
    if interrupt is not None:
        raise interrupt


def _run_units(spec: SweepSpec, units: list[list[Task]], out_dir: Path, comm: MPI.Comm,
               group: MPI.Comm, backend: str, check_cost: bool,
               failures: dict[str, str]) -> bool:
    """Each group takes the next unit from the shared counter until none is left; SIGTERM
    and SIGHUP stop it as Ctrl-C does. Returns whether the sweep was interrupted; if not,
    the ranks' failures are gathered on rank 0 (collective)."""
    import signal

    terminated = [False]

    def on_term(signum, frame):  # noqa: ANN001, ARG001
        # The flag survives where the exception is lost: raised while an at-fork callback
        # runs (a scene's start forks), Python prints "Exception ignored" and goes on.
        terminated[0] = True
        raise KeyboardInterrupt

    stops = (signal.SIGTERM, signal.SIGHUP)  # a batch system's stop, a closed terminal
    previous = {sig: signal.signal(sig, on_term) for sig in stops}
    counter = None
    interrupted = False
    try:
        counter = _Counter(comm)
        while True:
            idx = counter.next() if group.rank == 0 else 0
            if group.size > 1:
                idx = group.bcast(idx, root=0)
            if idx >= len(units):
                break
            status = _run_unit(spec, units[idx], out_dir, group, comm.rank, backend,
                               check_cost, failures)
            if status == "interrupted" or terminated[0]:
                interrupted = True
                break
    except KeyboardInterrupt:
        interrupted = True
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    if not interrupted:  # collective clean-up only when every rank got here normally
        wait_quietly(comm)
        if counter is not None:
            counter.free()
        for found in comm.gather(failures, root=0) or []:
            failures.update(found)
    return interrupted


def _report(spec: SweepSpec, out_dir: Path, session: dict[str, Any],
            failures: dict[str, str], stream: TextIO) -> int:
    """Rank 0: the final table and its one-line count. Returns 130 if interrupted, else 1 if
    a scene failed (or a foreign run directory sits in runs/), else 0."""
    interrupted = session["interrupted"]
    rows = write_table(out_dir, spec, extra={"last_session": session}, failures=failures)
    counts: dict[str, int] = {}
    for r in rows:
        counts[r["status"]] = counts.get(r["status"], 0) + 1
    text = ", ".join(f"{v} {k}" for k, v in sorted(counts.items()))
    print(f"sweep {spec.name}: {text}; table {out_dir / 'sweep.csv'}"
          + ("  (interrupted: run the same command again to resume)" if interrupted else ""),
          file=stream, flush=True)
    if interrupted:
        return 130
    return 1 if counts.get("failed") or counts.get("foreign") else 0


