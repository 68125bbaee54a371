"""One scene into a run directory: ``stickslip run``'s files, signals and ``summary.json``.

``run_scene`` builds a :class:`solver.run.Simulation`, lets it ``proceed``, then writes
``scene.toml``, ``samples.npz``, ``final_field.npz`` and ``summary.json`` (the run's facts plus
the wave analysis of ``postprocess.analysis``). Only rank 0 writes files; every write is atomic
(temporary file, then rename), so a run directory never holds a half-written file.
"""


from __future__ import annotations

import json
import os
import shutil
import socket
import sys
import time
from collections.abc import Callable
from pathlib import Path

from mpi4py import MPI

from solver import __version__
from solver.atomic import atomic_save_npz, atomic_write_text
from solver.errors import Diverged, StepTooLarge
from solver.run import Profile, Simulation
from solver.scene import Scene, write_scene
from studies.output import output_root, process_alive  # noqa: F401  (re-exported)
from studies.rundir.checkpoint import write_checkpoint
from studies.rundir.directory import (
    RunDir,
    RunDirError,
    _disk_status,
    _refusal,
    commit_run_dir,
    discard_run_dir,
    prepare_run_dir,
)
from studies.rundir.signals import RunSignals, _signame


def summarise(sim: Simulation, probes: dict | None = None) -> dict:
    """Run summary (rank 0): the run's facts plus the wave analysis of the recorded samples;
    with the gathered ``probes``, whether the samples resolve the wave
    (:func:`postprocess.resolution.sampling_check`: a ``warning`` where they alias it)."""
    from postprocess.analysis import analyse
    from postprocess.resolution import sampling_check

    out = sim.facts()
    data = sim.recorder.arrays()
    if data["t"].size >= 4:
        sc = sim.scene
        wave = analyse(data["t"], data["theta"], data["u_r"], data["u_theta"], data["status"],
                       d=sc.geometry.d, radius=sc.geometry.R)
        energy = out.pop("energy")  # keep summary.json's key order: wave keys, then energy
        out.update(
            regime=wave.regime, mode=wave.mode, celerity_m_s=wave.celerity_m_s,
            frequency_hz=wave.frequency_hz, fractions=wave.fractions,
            amplitude_m=wave.amplitude_m, limit_cycle=wave.limit_cycle,
            analysis_window_s=wave.window_s, psi1=wave.psi1, psi2=wave.psi2,
            zone_order=wave.zone_order, direction=wave.direction,
        )
        out.update(sampling_check(data["t"], probes, out))
        out["energy"] = energy
    from solver.scene.files import scene_digest

    out["scene_sha256"] = scene_digest(sim.scene)  # tells an edited scene.toml (readers)
    return out


#: Exit status of ``stickslip run`` by the run's final status (README: "Exit codes").
EXIT_CODES = {"completed": 0, "diverged": 1, "failed": 2, "stopped": 3, "interrupted": 130}


def run_scene(scene: Scene, run_dir: Path, *, force: bool = False,
              comm: MPI.Comm = MPI.COMM_WORLD, profile: bool = False,
              stream=None, check_resources: bool = True,
              replace_on_failure: bool = False) -> dict:
    """Run ``scene`` into ``run_dir``: scene.toml, samples.npz, summary.json (rank 0).

    Statuses: completed, diverged, stopped (wall-time limit), interrupted (SIGINT/SIGTERM;
    the samples so far are saved), failed (an error, with its message). ``running`` is left
    only by a process that is really running (its ``pid`` and ``host`` are recorded) or was
    killed outright. With ``force`` an earlier run directory is replaced atomically, and kept
    if the new run fails or is interrupted (unless ``replace_on_failure``, for sweeps).
    A signal that arrives while the files are written is honoured afterwards
    (KeyboardInterrupt on every rank). Resources are estimated before meshing and a scene
    beyond the machine is refused (:class:`studies.resources.ResourceError`) unless
    ``check_resources`` is False. See :class:`RunDirectory`.
    """
    return RunDirectory(scene, run_dir, force=force, comm=comm, profile=profile,
                        stream=stream, check_resources=check_resources,
                        replace_on_failure=replace_on_failure).run()


class RunDirectory:
    """One scene's run into its directory, from the claim to the final summary.

    :meth:`run` checks the place and the resources, claims the directory
    (:func:`studies.rundir.directory.prepare_run_dir`), writes ``scene.toml`` and a
    ``running`` summary, runs the :class:`solver.run.Simulation` under :class:`RunSignals`,
    and saves (:func:`_save`). The other methods are the ways a run can end without the
    normal save: :meth:`mark` (an error on one rank), :meth:`hard_stop` (a signal not
    acknowledged in compiled code), :meth:`rescue` (the forked writer under mpirun) and
    :meth:`tidy` (the process killed outright, seen by the watchdog).
    """

    def __init__(self, scene: Scene, run_dir: Path, *, force: bool = False,
                 comm: MPI.Comm = MPI.COMM_WORLD, profile: bool = False, stream=None,
                 check_resources: bool = True, replace_on_failure: bool = False,
                 resume: Callable[[Simulation], None] | None = None) -> None:
        """``resume(sim)``, if given, restores the built ``Simulation`` from a checkpoint
        before it proceeds (``studies.rundir.continuation``)."""
        self.scene, self.run_dir, self.force, self.comm = scene, Path(run_dir), force, comm
        self.resume = resume
        self.profile, self.check_resources = profile, check_resources
        self.replace_on_failure = replace_on_failure
        self.stream = sys.stdout if stream is None else stream
        self.rank0 = comm.rank == 0
        self.prof = Profile()
        self.rd: RunDir | None = None
        self.t0 = time.perf_counter()
        self.started = {"scene": scene.name, "status": "running", "pid": os.getpid(),
                        "host": socket.gethostname(),
                        "started": time.strftime("%Y-%m-%dT%H:%M:%S%z")}
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
        self.rd = prepare_run_dir(self.run_dir, self.force, self.comm)
        self.t0 = time.perf_counter()
        comm = self.comm
        try:
            with RunSignals(self.hard_stop, rescue=self.rescue if self.rank0 and comm.size > 1
                            else None, on_death=self.tidy) as signals:
                self._execute(signals, est)
                if self.sim is not None:
                    self.sim.status = self.status
                summary = _save(self.sim, self.rd, self.scene, self.status, self.error,
                                self.prof, self.t0, comm, signals,
                                keep_previous=(self.status in ("failed", "interrupted")
                                               or self.sim is None)
                                and not self.replace_on_failure)
                signals.mode = "done"
                deferred = signals.requested if self.status != "interrupted" else 0
        finally:
            self.rd.release()  # the directory is no longer live
        if self.rank0:
            summary["profile_s"] = {k: round(v, 4) for k, v in self.prof.seconds.items()}
            _print_summary(summary, self.run_dir, self.stream, self.profile)
        if comm.allreduce(deferred, op=MPI.MAX):
            self.say(f"{_signame(deferred)} received while the files were written: they are "
                     "complete; stopping now")
            raise KeyboardInterrupt
        return summary

    def _check_first(self):  # noqa: ANN202 - an Estimate or None
        """The place, then the resources, before anything is created (collective)."""
        from studies.resources import ResourceError
        from studies.resources import check_resources as _check

        est = None
        err, kind = None, None
        if self.rank0:
            err, kind = _refusal(self.run_dir, self.force), "dir"
            if err is None and self.check_resources:
                try:
                    est = _check(self.scene, self.run_dir, self.comm.size)
                except ValueError as e:
                    err, kind = str(e), "resources"
        err, kind = self.comm.bcast((err, kind), root=0)
        if err:
            raise (RunDirError if kind == "dir" else ResourceError)(err)
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
        sim = self.sim = Simulation(scene, comm, self.prof, output_dir=self.rd.work)
        if self.resume is not None:
            self.resume(sim)
        if sim.dt > scene.time.end_time:  # same on every rank: collective
            raise StepTooLarge(
                f"time.end_time = {scene.time.end_time:g} s is shorter than one time step "
                f"(dt = {sim.dt:.4g} s): the run would end before its first sample; raise "
                "time.end_time or lower time.dt")
        self.say(f"  {sim.problem.n_global_dofs} dofs, {sim.recorder.n_nodes} contact nodes, "
                 f"dt = {sim.dt:.4g} s ({sim.dt / sim.dt_crit:.2f} dt_crit), "
                 f"{sim.planned_steps()} steps to t = {scene.time.end_time} s")
        self.phase = "the time loop"
        signals.sim, signals.mode = sim, "flag"
        if signals.requested:  # a signal between the last check and now
            sim.stop_requested = True
        reason = sim.proceed()
        self.status = {"signal": "interrupted", "max_wall_time": "stopped"}.get(reason,
                                                                                "completed")
        if reason == "signal":
            self.error = f"interrupted by {_signame(signals.requested)}"
        elif reason == "max_wall_time":
            self.error = (f"stopped by time.max_wall_time = {scene.time.max_wall_time} s at "
                          f"t = {sim.integrator.time:.6g} s of {scene.time.end_time} s")

    def first_files(self) -> None:
        """scene.toml and the ``running`` summary; a write error leaves nothing half-made."""
        problem = None
        rd = self.rd
        if self.rank0:
            try:
                write_scene(self.scene, rd.work / "scene.toml")
                atomic_write_text(rd.work / "summary.json", json.dumps(self.started, indent=2))
            except OSError as err:
                problem = (f"cannot write in {self.run_dir}: {err.strerror or err}; choose "
                           "another -o")
                if rd.replacing:
                    discard_run_dir(rd)
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
        rd = self.rd
        if _disk_status(rd.work) not in (None, "running"):
            return
        if rd.replacing and not self.replace_on_failure:
            discard_run_dir(rd)
            return
        summary = dict(self.started, status=status, message=message,
                       wall_time_s=time.perf_counter() - self.t0)
        summary.pop("pid", None)
        try:
            atomic_write_text(rd.work / "summary.json", json.dumps(summary, indent=2))
            if rd.replacing:
                commit_run_dir(rd)
        except OSError:
            pass

    def hard_stop(self, signum: int, where: str) -> None:
        """The watchdog's last word before SIGKILL: a signal not acknowledged in time."""
        msg = (f"{_signame(signum)} while in {where} (busy in compiled code: stopped without "
               "saving)")
        print(f"stickslip: {msg}", file=sys.stderr, flush=True)
        if self.rank0:
            self.mark("interrupted", msg)

    def rescue(self) -> None:
        """The forked rescue writer (rank 0 under mpirun): save what rank 0 holds, now."""
        rd = self.rd
        sim = self.sim if self.phase != "setup" else None  # the time loop has started
        status = self.status if self.ended else "interrupted"
        msg = (self.error if self.ended else None) or f"interrupted during {self.phase}"
        out = sim.facts() if sim is not None else dict(self.started)
        out.pop("pid", None)
        out.update(status=status, wall_time_s=time.perf_counter() - self.t0,
                   message=msg + " (saved by the rescue writer: no probes, no final field)")
        if _disk_status(rd.work) not in (None, "running"):
            return  # another rank marked the run (failed) before mpirun's signal came
        if rd.replacing and (sim is None or not self.replace_on_failure):
            discard_run_dir(rd)  # an interrupted rerun keeps the earlier run
            return
        if sim is not None:
            atomic_save_npz(rd.work / "samples.npz", sim.recorder.arrays(), compress=False)
        atomic_write_text(rd.work / "summary.json", json.dumps(out, indent=2))
        commit_run_dir(rd)

    def tidy(self, pid: int, rescued: bool, where: str, signum: int = 0) -> None:
        """The run's process died outright (SIGKILL, out of memory; in the watchdog): remove
        its temporary files and, on rank 0, turn a ``running`` summary into ``crashed``, or
        ``interrupted`` if a SIGINT/SIGTERM came first (mpirun's SIGKILL follows its SIGTERM
        within a second), or drop an unfinished replacement. Neither status is final: a
        resumed sweep runs the scene again. The rescue writer, if any, owns the status."""
        from solver.atomic import remove_temporaries

        rd = self.rd
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
                discard_run_dir(rd)
            else:
                atomic_write_text(folder / "summary.json", json.dumps(dict(
                    self.started, status=status, message=message,
                    wall_time_s=time.perf_counter() - self.t0), indent=2))


def _save(sim: Simulation | None, rd: RunDir, scene: Scene, status: str, error: str | None,
          prof: Profile, t0: float, comm: MPI.Comm, signals: RunSignals,
          keep_previous: bool) -> dict:
    """Collect (collective) and write (rank 0) samples, final field and summary.

    Order: samples.npz and final_field.npz, then summary.json with the status and
    ``"analysis": "pending"``, the swap into place, then summary.json again with the wave
    analysis (and without that key). A process killed after the first summary (mpirun sends
    SIGKILL ~0.3 s after SIGTERM) leaves a truthful, loadable run, which a resumed sweep runs
    again (``studies.sweep.table.task_state``: "unanalysed"). ``interrupted`` runs save
    uncompressed (faster) samples.
    ``keep_previous``: the run has nothing worth keeping (no samples, or failed); an earlier
    run being replaced stays as it was. A write error makes the run ``failed`` with it.
    """
    rank0 = comm.rank == 0
    work = rd.work
    with prof.phase("output"):
        probe_arrays = sim.probes.arrays() if sim is not None else None
        field = sim.final_field() if sim is not None else None
        # the checkpoint of a run that stands at a whole level (not failed or diverged)
        states = comm.gather(sim.checkpoint(), root=0) \
            if sim is not None and sim.resumable else None
        if sim is not None and sim.writer is not None:
            sim.writer.close()
        if not rank0:
            return {}
        signals.wait_rescue()
        summary = sim.facts() if sim is not None else {"scene": scene.name, "status": status}
        if keep_previous and rd.replacing:
            discard_run_dir(rd)
            summary.update(status=status, message=f"{error or status}; the earlier run in "
                           f"{rd.final} is kept unchanged")
            return _finish(summary, t0, None, prof)
        if rd.replacing and not rd.work.exists():  # the rescue writer swapped it in
            rd.work = rd.final
        work = rd.work
        if status in ("interrupted", "failed") and _disk_status(work) == "failed":
            # another rank failed and marked the run before mpirun's signal reached us
            return json.loads((work / "summary.json").read_text())
        if sim is not None:  # until the second write below: a kill in between is visible
            summary["analysis"] = "pending"

        def finish(s: dict) -> dict:
            return _finish(s, t0, error, prof)

        finish(summary)
        try:
            if sim is not None:
                arrays = sim.recorder.arrays()
                arrays.update(probe_arrays or {})
                atomic_save_npz(work / "samples.npz", arrays,
                                compress=status != "interrupted")
                if field is not None:
                    atomic_save_npz(work / "final_field.npz", field)
                if states is not None:
                    write_checkpoint(work, states, kind="run", scene=scene,
                                     status=status, kernel=summary["scheme"].get("kernel", ""))
            atomic_write_text(work / "summary.json", json.dumps(summary, indent=2))
            commit_run_dir(rd)
        except OSError as err:
            summary["status"] = "failed"
            summary["message"] = f"could not write the run's files: {err}"
            if rd.replacing and rd.work.exists():
                discard_run_dir(rd)
                summary["message"] += f"; the earlier run in {rd.final} is kept unchanged"
            else:
                try:  # small: may still fit where samples.npz did not
                    atomic_write_text(rd.final / "summary.json", json.dumps(summary, indent=2))
                except OSError:
                    pass
            return summary
        if sim is not None:  # the run is saved and true; the analysis is a bonus on top
            analysed = finish(summarise(sim, probe_arrays))
            try:
                atomic_write_text(rd.final / "summary.json", json.dumps(analysed, indent=2))
                summary = analysed
            except OSError as err:
                summary["message"] = (f"{summary.get('message', '')}; " if summary.get(
                    "message") else "") + f"could not add the wave analysis to summary.json: {err}"
    return summary


def write_batch_member(run, folder: Path, extra: dict, prof: Profile, backend: str,
                       compress: bool = True) -> dict:
    """A finished batch member's files into ``folder`` (``solver.ensemble_run.SceneRun``):
    samples.npz, final_field.npz, its checkpoint (when it ended at a whole level), then
    summary.json (the facts, the wave analysis, ``extra``, the profile and peak memory).
    Returns the summary. Used by a batched sweep and by a continued batch. ``compress``:
    samples.npz deflated (``solver.atomic.NPZ_LEVEL``), else stored (the same arrays,
    about 1.5x the bytes, written and read without zlib: for runs continued again)."""
    summary = summarise(run)
    summary.update(extra)
    arrays = run.recorder.arrays()
    arrays.update(run.probes.arrays() or {})
    atomic_save_npz(folder / "samples.npz", arrays, compress=compress)
    field = run.final_field()
    if field is not None:
        atomic_save_npz(folder / "final_field.npz", field)
    if run.state is not None:
        write_checkpoint(folder, [run.state], kind="batch", scene=run.scene,
                         status=run.status, kernel=summary["scheme"]["kernel"],
                         backend=backend)
    summary["profile_s"] = {k: round(v, 4) for k, v in prof.seconds.items()}
    summary["peak_rss_mb"] = peak_rss_mb()
    atomic_write_text(folder / "summary.json", json.dumps(summary, indent=2))
    return summary


def _finish(s: dict, t0: float, error: str | None, prof: Profile) -> dict:
    """Add the wall time, the message, the peak memory and the profile to summary ``s``."""
    s["wall_time_s"] = time.perf_counter() - t0
    if error:
        s["message"] = error
    s["peak_rss_mb"] = peak_rss_mb()
    s["profile_s"] = {k: round(v, 4) for k, v in prof.seconds.items()}
    return s


def peak_rss_mb() -> float:
    """Peak resident memory of this process (MB)."""
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def scene_warnings(scene: Scene) -> list[str]:
    """Legal but doubtful choices, said before a long run starts."""
    out = []
    ini, n = scene.initial, scene.mesh.n_inner
    if ini.perturbation == "mode" and n / ini.mode < 8:
        out.append(
            f"initial.mode = {ini.mode} has only {n / ini.mode:.1f} contact nodes per "
            f"wavelength on mesh.n_inner = {n}; the wave will be poorly resolved "
            f"(use mesh.n_inner >= {8 * ini.mode})"
        )
    out_ = scene.output
    if out_.sample_interval > scene.time.end_time:
        out.append(
            f"output.sample_interval = {out_.sample_interval} s is longer than time.end_time "
            f"= {scene.time.end_time} s: at most one sample, nothing to analyse (use "
            "output.sample_interval <= time.end_time / 100)"
        )
    return out


def _print_summary(s: dict, run_dir: Path, stream, profile: bool) -> None:
    msg = s.get("message")
    lines = [f"status: {s.get('status')}" + (f" ({msg})" if msg and msg != s.get("status") else "")]
    if "regime" in s:
        fr = s["fractions"]
        lines += [
            f"regime: {s['regime']}, mode k = {s['mode']}, "
            f"celerity {s['celerity_m_s']:+.1f} m/s (+ = rotation sense), "
            f"frequency {s['frequency_hz']:.1f} Hz",
            f"zones: separation {fr['separation']:.3f}, stick {fr['stick']:.3f}, "
            f"slip {fr['slip']:.3f}; amplitude {s['amplitude_m']:.3g} m; "
            f"limit cycle: {s['limit_cycle']}",
        ]
    if s.get("warning"):
        lines.append(f"warning: {s['warning']}")
    lines.append(f"steps {s.get('steps', 0)}, wall {s.get('wall_time_s', 0):.2f} s, "
                 f"peak RSS {s.get('peak_rss_mb', 0):.0f} MB -> {run_dir}")
    if profile:
        lines.append("profile: " + ", ".join(f"{k} {v:.3f} s" for k, v in s["profile_s"].items()))
    print("\n".join(lines), file=stream, flush=True)
