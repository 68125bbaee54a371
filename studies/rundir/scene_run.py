"""One scene into a run directory: ``stickslip run``'s files, signals and ``summary.json``.

``run_scene`` builds a :class:`solver.run.Simulation`, lets it ``proceed``, then writes
``scene.toml``, ``samples.npz``, ``final_field.npz`` and ``summary.json`` (the run's facts plus
the wave analysis of ``postprocess.analysis``). Only rank 0 writes files; every write is atomic
(temporary file, then rename), so a run directory never holds a half-written file.
"""


from __future__ import annotations

import json
import shutil
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from stickslip.postprocess.plotting import DEFAULT_WINDOW, plot_run
from stickslip.postprocess.resolution import sampling_problem
from stickslip.solver import __version__
from stickslip.solver.atomic import atomic_save_npz, remove_temporaries
from stickslip.solver.errors import Diverged, StepTooLarge
from stickslip.solver.run import Profile, Simulation
from stickslip.solver.scene import Scene, SceneError, scene_warnings
from stickslip.solver.schemes import unsteppable
from stickslip.studies.output import output_root, process_alive  # noqa: F401  (re-exported)
from stickslip.studies.resources import ResourceError
from stickslip.studies.resources import check_resources as _check
from stickslip.studies.rundir.directory import RunDirError, _disk_status, _refusal
from stickslip.studies.rundir.signals import RunSignals, _signame
from stickslip.studies.rundir.summary_file import write_summary
from stickslip.studies.rundir.writer import (  # noqa: F401  (summarise, peak_rss_mb: re-exported)
    RunDirectory,
    RunOutputs,
    finish_summary,
    peak_rss_mb,
    print_summary,
    summarise,
)

if TYPE_CHECKING:  # MPI starts where a run uses it, not when this module is imported
    from mpi4py import MPI

def every_rank(comm: MPI.Comm | None) -> MPI.Comm:
    """``comm``, or every rank (``MPI.COMM_WORLD``) where none is given: MPI starts when a run
    does, not when this module is imported (the commands that only read import it too)."""
    if comm is not None:
        return comm
    from mpi4py import MPI

    return MPI.COMM_WORLD


def max_op() -> MPI.Op:
    """``MPI.MAX``, for a run's communicator (MPI has started: see ``every_rank``)."""
    from mpi4py import MPI

    return MPI.MAX


#: Exit status of ``stickslip run`` by the run's final status (README: "Exit codes").
EXIT_CODES = {"completed": 0, "diverged": 1, "failed": 2, "stopped": 3, "interrupted": 130}


#: The final statuses whose runs hold samples to draw (``run_scene``'s ``plot``).
PLOTTABLE = ("completed", "interrupted", "stopped")


def run_scene(scene: Scene, run_dir: Path, *, force: bool = False,
              comm: MPI.Comm | None = None, profile: bool = False,
              stream=None, check_resources: bool = True,
              replace_on_failure: bool = False, check_sampling: bool = False,
              plot: bool = False, window: tuple[float, str] | None | str = DEFAULT_WINDOW) -> dict:
    """Run ``scene`` into ``run_dir``: scene.toml, samples.npz, summary.json (rank 0).

    Statuses: completed, diverged, stopped (wall-time limit), interrupted (SIGINT/SIGTERM;
    the samples so far are saved), failed (an error, with its message). ``running`` is left
    only by a process that is really running (its ``pid`` and ``host`` are recorded) or was
    killed outright. With ``force`` an earlier run directory is replaced atomically, and kept
    if the new run fails or is interrupted (unless ``replace_on_failure``, for sweeps).
    A signal that arrives while the files are written is honoured afterwards
    (KeyboardInterrupt on every rank). Resources are estimated before meshing and a scene
    beyond the machine is refused (:class:`studies.resources.ResourceError`) unless
    ``check_resources`` is False. See :class:`SceneRunner`.

    What ``stickslip run`` and ``stickslip.run`` add, in this one place: ``check_sampling``
    refuses (``ResourceError``, before anything is written) a scene whose samples cannot
    resolve the wave it is expected to end on (``postprocess.resolution.sampling_problem``);
    ``plot`` draws the figures of a run that holds samples (``PLOTTABLE``; the space-time
    maps over ``window``) on rank 0, one ``figure: PATH`` line each on ``stream``. ``comm``:
    the ranks of the run (default: every rank, ``MPI.COMM_WORLD``).
    """
    if check_sampling:
        if problem := sampling_problem(scene, "pass --yes-i-know"):
            raise ResourceError(problem)
    runner = SceneRunner(scene, run_dir, force=force, comm=comm, profile=profile,
                         stream=stream, check_resources=check_resources,
                         replace_on_failure=replace_on_failure)
    summary = runner.run()
    if plot and summary.get("status") in PLOTTABLE:  # rank 0: the others' summary is {}
        for path in plot_run(Path(run_dir), window=window):
            runner.say(f"figure: {path}")
    return summary


class SceneRunner:
    """One scene's run on the ranks of ``comm`` into its directory (``dir``, a
    :class:`studies.rundir.writer.RunDirectory`, the driver of every run directory).

    :meth:`run` checks the place and the resources, claims the directory, writes
    ``scene.toml`` and a ``running`` summary, runs the :class:`solver.run.Simulation` under
    :class:`RunSignals`, and saves (:meth:`_save`). The other methods are the ways a run on
    ranks can end without the normal save: :meth:`mark` (an error on one rank),
    :meth:`hard_stop` (a signal not acknowledged in compiled code), :meth:`rescue` (the forked
    writer under mpirun) and :meth:`tidy` (the process killed outright, seen by the watchdog).
    """

    def __init__(self, scene: Scene, run_dir: Path, *, force: bool = False,
                 comm: MPI.Comm | None = None, profile: bool = False, stream=None,
                 check_resources: bool = True, replace_on_failure: bool = False,
                 resume: Callable[[Simulation], None] | None = None,
                 progress: bool | None = None) -> None:
        """``resume(sim)``, if given, restores the built ``Simulation`` from a checkpoint
        before it proceeds (``studies.rundir.continuation``). ``progress``: progress lines
        on ``stream`` (rank 0), or none; None: as the scene's ``output.progress``."""
        comm = every_rank(comm)
        self.scene, self.run_dir, self.force, self.comm = scene, Path(run_dir), force, comm
        self.resume, self.progress = resume, progress
        self.profile, self.check_resources = profile, check_resources
        self.replace_on_failure = replace_on_failure
        self.stream = sys.stdout if stream is None else stream
        self.rank0 = comm.rank == 0
        self.prof = Profile()
        self.dir = RunDirectory(scene, self.run_dir)
        self.phase = "setup"
        self.sim: Simulation | None = None
        self.status, self.error = "failed", None
        self.ended = False  # the outcome (status, error) is known

    def say(self, msg: str) -> None:
        if self.rank0:
            print(msg, file=self.stream, flush=True)

    # ------------------------------------------------------------------ the normal path

    def run(self) -> dict:
        """Claim, run, save; the summary (rank 0; ``{}`` elsewhere)."""
        est = self._check_first()
        self.dir.claim(self.force, self.comm)
        comm = self.comm
        try:
            mpi_rank0 = self.rank0 and comm.size > 1
            with RunSignals(self.hard_stop, rescue=self.rescue if mpi_rank0 else None,
                            on_death=self.tidy,
                            on_setup_signal=self.setup_signal if mpi_rank0 else None
                            ) as signals:
                self._execute(signals, est)
                summary = self._save(signals)
                signals.mode = "done"
                deferred = signals.requested if self.status != "interrupted" else 0
        finally:
            self.dir.release()  # the directory is no longer live
        if self.rank0:
            summary["profile_s"] = {k: round(v, 4) for k, v in self.prof.seconds.items()}
            print_summary(summary, self.run_dir, self.stream, self.profile)
        if comm.allreduce(deferred, op=max_op()):
            self.say(f"{_signame(deferred)} received while the files were written: they are "
                     "complete; stopping now")
            raise KeyboardInterrupt
        return summary

    def _save(self, signals: RunSignals) -> dict:
        """Collect (collective) and write (rank 0, :func:`studies.rundir.writer.
        write_run_files`) samples, final field, checkpoint and summary.

        A run with nothing worth keeping (no samples, or failed or interrupted) that replaces
        an earlier run leaves that run as it was (unless ``replace_on_failure``). A write
        error makes the run ``failed`` with it.
        """
        sim, rd, status, error = self.sim, self.dir.rd, self.status, self.error
        keep_previous = (status in ("failed", "interrupted") or sim is None) \
            and not self.replace_on_failure
        with self.prof.phase("output"):
            out = RunOutputs(self.scene, None if sim is None else sim.runs[0], status, error)
            if sim is not None and sim.runs[0].kick:
                out.extra["kick"] = sim.runs[0].kick
            if sim is not None:
                sim.status = status
                out.probes, out.final_field = sim.probes.arrays(), sim.final_field()
                out.surface = sim.columns.surface_arrays()
                # the checkpoint of a run that stands at a whole level (not failed, diverged)
                out.states = self.comm.gather(sim.runs[0].state, root=0) \
                    if sim.resumable else None
                if sim.columns.writer is not None:
                    sim.columns.writer.close()
            if not self.rank0:
                return {}
            out.rescued = signals.rescue_pid > 0  # the rescue writer saved this run first
            signals.wait_rescue()
            if keep_previous and rd.replacing:
                self.dir.discard()
                summary = sim.facts() if sim is not None else {"scene": self.scene.name}
                summary.update(status=status, message=f"{error or status}; the earlier run "
                               f"in {rd.final} is kept unchanged")
                return finish_summary(summary, None, self.prof, self.dir.t0)
            if rd.replacing and not rd.work.exists():  # the rescue writer swapped it in
                rd.work = rd.final
            if status in ("interrupted", "failed") and _disk_status(rd.work) == "failed":
                # another rank failed and marked the run before mpirun's signal reached us
                return json.loads((rd.work / "summary.json").read_text())
            return self.dir.save(out, self.prof)

    def _check_first(self):  # noqa: ANN202 - an Estimate or None
        """The place, the scheme (``unsteppable``: a scene it cannot step is refused
        before meshing), then the resources, before anything is created
        (collective)."""
        est = None
        err, kind = None, None
        if self.rank0:
            err, kind = _refusal(self.run_dir, self.force), "dir"
            if err is None and (why := unsteppable(self.scene)):
                err, kind = why, "scene"
            if err is None and self.check_resources:
                try:
                    est = _check(self.scene, self.run_dir, self.comm.size)
                except ValueError as e:
                    err, kind = str(e), "resources"
        err, kind = self.comm.bcast((err, kind), root=0)
        if err:
            raise {"dir": RunDirError, "scene": SceneError}.get(kind, ResourceError)(err)
        return est

    def _execute(self, signals: RunSignals, est) -> None:  # noqa: ANN001
        """Set up and run the simulation; the outcome goes to ``status`` and ``error``."""
        comm = self.comm
        try:
            signals.start()
            self.first_files()
            self._simulate(signals, est)
        except KeyboardInterrupt:
            self.status = "interrupted"
            self.error = f"interrupted by {_signame(signals.requested)} during {self.phase}"
        except RunDirError:
            signals.mode = "done"
            raise
        except Diverged as err:
            self.status, self.error = "diverged", str(err)
        except StepTooLarge as err:  # same on every rank (omega_max is reduced): collective
            self.status, self.error = "failed", f"{type(err).__name__}: {err}"
        except Exception as err:  # noqa: BLE001 - recorded; under MPI every rank must end
            self.status, self.error = "failed", f"{type(err).__name__}: {err}"
            if comm.size > 1:
                signals.mode = "done"
                print(f"error (rank {comm.rank}): {self.error}", file=sys.stderr, flush=True)
                self.mark("failed", f"rank {comm.rank}: {self.error}")
                comm.Abort(EXIT_CODES["failed"])
        finally:
            self.ended = True
            if signals.mode != "done":
                signals.mode = "defer"
                self.phase = "the final save"

    def _simulate(self, signals: RunSignals, est) -> None:  # noqa: ANN001
        """Build the :class:`Simulation`, say what it is, and let it proceed."""
        scene, comm = self.scene, self.comm
        self.say(f"stickslip {__version__}: scene '{scene.name}' on {comm.size} rank(s)")
        if est is not None:
            self.say(f"  {est.line()}")
        for warning in scene_warnings(scene):
            self.say(f"  warning: {warning}")
        sim = self.sim = Simulation(scene, comm, self.prof, output_dir=self.dir.work)
        sim.columns.progress.stream = self.stream  # progress lines go where the run's lines go
        if self.progress is not None:
            sim.columns.progress.enabled = self.progress and self.rank0
        if self.resume is not None:
            self.resume(sim)
        if sim.dt > scene.time.end_time:  # same on every rank: collective
            raise StepTooLarge(
                f"time.end_time = {scene.time.end_time:g} s is shorter than one time step "
                f"(dt = {sim.dt:.4g} s): the run would end before its first sample; raise "
                "time.end_time or lower time.dt")
        surface = sim.problem.surface
        ring = ("" if surface is None else  # a 3D tube records its ring at mid-length
                f" (the ring at mid-length of {surface.n_global})")
        self.say(f"  {sim.problem.n_global_dofs} dofs, {sim.recorder.n_nodes} contact nodes"
                 f"{ring}, "
                 f"dt = {sim.dt:.4g} s ({sim.dt / sim.dt_crit:.2f} dt_crit), "
                 f"{sim.planned_steps()} steps to t = {scene.time.end_time} s")
        self.phase = "the time loop"
        signals.sim, signals.mode = sim, "flag"
        if signals.requested:  # a signal between the last check and now
            sim.stop_requested = True
        reason = sim.proceed()
        self.status = {"signal": "interrupted", "max_wall_time": "stopped",
                       "diverged": "diverged"}.get(reason, "completed")
        if reason == "diverged":  # the energy guard: a blow-up, not a wave
            self.error = sim.message
        elif reason == "signal":
            self.error = f"interrupted by {_signame(signals.requested)}"
        elif reason == "max_wall_time":
            self.error = (f"stopped by time.max_wall_time = {scene.time.max_wall_time} s at "
                          f"t = {sim.integrator.time:.6g} s of {scene.time.end_time} s")

    def first_files(self) -> None:
        """scene.toml and the ``running`` summary; a write error leaves nothing half-made."""
        problem = None
        rd = self.dir.rd
        if self.rank0:
            try:
                self.dir.start()
            except OSError as err:
                problem = (f"cannot write in {self.run_dir}: {err.strerror or err}; choose "
                           "another -o")
                if rd.replacing:
                    self.dir.discard()
                else:  # our two files, and the folder if we made it
                    for name in ("scene.toml", "summary.json"):
                        (rd.work / name).unlink(missing_ok=True)
                    if rd.created:
                        shutil.rmtree(rd.work, ignore_errors=True)
        problem = self.comm.bcast(problem, root=0)
        if problem:
            raise RunDirError(problem)

    # ------------------------------------------------------------------ abnormal ends

    def mark(self, status: str, message: str) -> None:
        """The run ended without the normal save (rank-local; a last resort). A final status
        already on disk (another rank's ``failed``) is the first truth: it stays."""
        rd = self.dir.rd
        if _disk_status(rd.work) not in (None, "running"):
            return
        if rd.replacing and not self.replace_on_failure:
            self.dir.discard()
            return
        try:
            self.dir.end(status, message)
            if rd.replacing:
                self.dir.commit()
        except OSError:
            pass

    def hard_stop(self, signum: int, where: str) -> None:
        """The watchdog's last word before SIGKILL: a signal not acknowledged in time."""
        msg = (f"{_signame(signum)} while in {where} (busy in compiled code: stopped without "
               "saving)")
        print(f"stickslip: {msg}", file=sys.stderr, flush=True)
        if self.rank0:
            self.mark("interrupted", msg)

    def setup_signal(self, signum: int) -> None:
        """In the watchdog (rank 0 under mpirun), at once: a signal during setup ends the run
        ``interrupted``; say so before mpirun's SIGKILL (the normal path writes the same
        status). Only over this run's own ``running`` summary: never another rank's
        ``failed``, never a replacement (its earlier run stays, final)."""
        rd = self.dir.rd
        if rd.replacing or _disk_status(rd.work) != "running":
            return
        try:
            self.dir.end("interrupted", f"interrupted by {_signame(signum)} during setup")
        except OSError:
            pass

    def rescue(self) -> None:
        """The forked rescue writer (rank 0 under mpirun): save what rank 0 holds, now."""
        rd = self.dir.rd
        sim = self.sim if self.phase != "setup" else None  # the time loop has started
        status = self.status if self.ended else "interrupted"
        msg = (self.error if self.ended else None) or f"interrupted during {self.phase}"
        out = sim.facts() if sim is not None else dict(self.dir.started)
        out.pop("pid", None)
        out.update(status=status, wall_time_s=time.perf_counter() - self.dir.t0,
                   message=msg + " (saved by the rescue writer: no probes, no final field)")
        if _disk_status(rd.work) not in (None, "running"):
            return  # another rank marked the run (failed) before mpirun's signal came
        if rd.replacing and (sim is None or not self.replace_on_failure):
            self.dir.discard()  # an interrupted rerun keeps the earlier run
            return
        # The summary first (a small file, written at once): mpirun SIGKILLs the ranks 0.25 s
        # after their SIGTERM and returns, and a script that reads the status then must find
        # it final. samples.npz (megabytes) follows; the run's lock is held until it is there.
        write_summary(rd.work, out)
        self.dir.commit()  # a replacement: swapped in now (rd.work is then rd.final)
        if sim is None:
            return
        try:
            atomic_save_npz(rd.work / "samples.npz", sim.recorder.arrays(), compress=False)
        except OSError as err:
            out["message"] = f"{msg}; the samples could not be written: {err}"
            write_summary(rd.work, out)

    def tidy(self, pid: int, rescued: bool, where: str, signum: int = 0) -> None:
        """The run's process died outright (SIGKILL, out of memory; in the watchdog): remove
        its temporary files and, on rank 0, turn a ``running`` summary into ``crashed``, or
        ``interrupted`` if a SIGINT/SIGTERM came first (mpirun's SIGKILL follows its SIGTERM
        within a second), or drop an unfinished replacement. Neither status is final: a
        resumed sweep runs the scene again. The rescue writer, if any, owns the status."""
        rd = self.dir.rd
        status, message = "crashed", (f"the process was killed outright (SIGKILL: out of "
                                      f"memory, or mpirun/batch system) during {where}")
        if signum:
            status, message = "interrupted", (
                f"{_signame(signum)} during {where}, then the process was killed (mpirun's "
                "SIGKILL) before it could save: nothing of this run was kept")
        for folder in {rd.work, rd.final}:
            remove_temporaries(folder, pid)
        if not self.rank0 or rescued:
            return
        for folder in {rd.work, rd.final}:
            if _disk_status(folder) != "running":
                continue
            if rd.replacing and folder == rd.work:
                self.dir.discard()
            else:
                self.dir.end(status, message, folder)
