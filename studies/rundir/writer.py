"""A run's files, written by one piece of code for every kind of run.

A single run (``studies.rundir.scene_run``), a member of a batch (``studies.sweep.batch``, a
census) and a continued run (``studies.rundir.continuation``) all leave the same directory,
driven by one :class:`RunDirectory`: ``scene.toml`` and a ``running`` summary when they start
(:meth:`RunDirectory.start`), then :func:`write_run_files` when they end:

1. ``samples.npz`` (uncompressed for an interrupted run: faster), ``final_field.npz``,
   ``checkpoint.npz`` (a run that stands at a whole level),
2. ``summary.json`` with the status and ``"analysis": "pending"``, the swap of a replacement
   into place (:meth:`studies.rundir.ownership.Claim.commit`),
3. ``summary.json`` again with the wave analysis (:func:`summarise`), without that key.

A process killed between 2 and 3 leaves a truthful, loadable run that a resumed sweep runs
again (``studies.sweep.table.task_state``: "unanalysed"). Every write is atomic (a temporary
file, then a rename): a run directory never holds a half-written file. A write error makes
the run ``failed``, with the error in its message.
"""

from __future__ import annotations

import os
import socket
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from stickslip.postprocess.analysis import TRAVEL_PURITY_MIN, analyse
from stickslip.postprocess.resolution import sampling_check
from stickslip.postprocess.surface_map import axial_modes, axial_structure
from stickslip.solver.atomic import atomic_save_npz
from stickslip.solver.run import Profile
from stickslip.solver.scene import Scene, scene_warnings, write_scene
from stickslip.solver.scene.files import scene_digest
from stickslip.studies.rundir import directory
from stickslip.studies.rundir.checkpoint import write_checkpoint
from stickslip.studies.rundir.summary_file import write_summary


def running_summary(name: str) -> dict:
    """The ``running`` summary of the run of scene ``name`` that starts now, in this process:
    its ``pid`` and ``host`` tell a live run from one whose process was killed
    (``studies.output``)."""
    return {"scene": name, "status": "running", "pid": os.getpid(),
            "host": socket.gethostname(), "started": time.strftime("%Y-%m-%dT%H:%M:%S%z")}


@dataclass
class RunOutputs:
    """What an ended run hands its writer (rank 0).

    Attributes:
        scene: the run's scene.
        run: the run of the scene: ``facts()``, ``recorder``, ``scene`` (a
            ``solver.columns.SceneRun``, one of a ``solver.run.Simulation``'s ``runs``); None if
            it was never built.
        status: the final status (completed, diverged, stopped, interrupted, failed).
        error: the message of a run that did not complete, else None.
        probes: the probes' arrays (``probe_t``, ``probe_data``), gathered over the ranks.
        final_field: the final field, gathered (None where there is none).
        surface: a 3D tube's contact surface at the samples, gathered (``surface.npz``;
            None in plane strain).
        states: the checkpoint's state per rank, or None (a run not at a whole level).
        kind: the checkpoint's kind: ``run`` (continued alone) or ``batch`` (continued as
            a batch again).
        backend: the batch's backend (cpu, gpu), for the checkpoint.
        extra: keys added to the summary after the run's own (``batch``, ``kick``).
        compress: samples.npz deflated (``solver.atomic.NPZ_LEVEL``), else stored: the same
            arrays, about 1.5x the bytes, written and read without zlib (for runs continued
            again, as a census's starts are); an interrupted run's are always stored.
        rescued: the rescue writer (rank 0 under mpirun) saved this run first.
    """

    scene: Scene
    run: Any
    status: str
    error: str | None = None
    probes: dict | None = None
    final_field: dict | None = None
    surface: dict | None = None
    states: list[dict] | None = None
    kind: str = "run"
    backend: str = "cpu"
    extra: dict = field(default_factory=dict)
    compress: bool = True
    rescued: bool = False


class _ArraysOnce:
    """A run's recorder whose ``arrays()`` is taken once and then handed out again (a new
    dict of the same arrays each time): the writer reads the samples three times (the
    facts, samples.npz, the wave analysis), and a continued run's are the records before
    its checkpoint joined with the new ones (``solver.observers.ContinuedRecords``), the
    whole record copied at each join. Everything else is the recorder's."""

    def __init__(self, recorder) -> None:  # noqa: ANN001 - any run's recorder
        self.recorder, self.taken = recorder, None

    def __getattr__(self, name: str):  # noqa: ANN204
        return getattr(self.recorder, name)

    def arrays(self) -> dict:
        if self.taken is None:
            self.taken = self.recorder.arrays()
        return dict(self.taken)


def write_run_files(rd: directory.RunDir, out: RunOutputs, prof: Profile, t0: float) -> dict:
    """Write an ended run into its claimed directory ``rd`` (rank 0; the order of the module
    docstring) and swap it into place; returns the summary as written. The samples of a
    run that has ended are taken from its recorder once (``_ArraysOnce``; a rescued run's
    loop may still record while it is written)."""
    run = out.run
    if run is None or out.rescued:
        return _write_run_files(rd, out, prof, t0)
    recorder = run.recorder
    run.recorder = _ArraysOnce(recorder)
    try:
        return _write_run_files(rd, out, prof, t0)
    finally:
        run.recorder = recorder


def _write_run_files(rd: directory.RunDir, out: RunOutputs, prof: Profile, t0: float) -> dict:
    """``write_run_files``."""
    run = out.run
    summary = run.facts() if run is not None else {"scene": out.scene.name,
                                                   "status": out.status}
    if run is not None:  # until the second write below: a kill in between is visible
        summary["analysis"] = "pending"
    finish_summary(summary, out, prof, t0)
    try:
        if run is not None and out.rescued:
            # The rescue's summary counts the rescue's samples; the loop has taken one more
            # since. Without the count it tells of either file, so a kill between the writes
            # below never leaves a count that samples.npz contradicts.
            write_summary(rd.work, {k: v for k, v in summary.items() if k != "samples"})
        if run is not None:
            _write_arrays(rd.work, out, summary)
        write_summary(rd.work, summary)
        directory.commit_run_dir(rd)
    except OSError as err:
        return _write_failed(rd, summary, err)
    if run is None:
        return summary
    analysed = finish_summary(summarise(run, out.probes), out, prof, t0)
    if out.surface is not None and analysed.get("mode"):  # a 3D tube's wave along z
        analysed["tube_3d"]["axial"] = dict(axial_structure(out.surface, analysed["mode"]),
                                            modes=axial_modes(out.surface))
    try:  # the run is saved and true; the analysis is a bonus on top
        write_summary(rd.final, analysed)
    except OSError as err:
        summary["message"] = (f"{summary['message']}; " if summary.get("message") else
                              "") + f"could not add the wave analysis to summary.json: {err}"
        return summary
    return analysed


def _write_arrays(work: Path, out: RunOutputs, summary: dict) -> None:
    """samples.npz (the samples and the probes), final_field.npz, surface.npz (a 3D tube),
    checkpoint.npz."""
    arrays = out.run.recorder.arrays()
    arrays.update(out.probes or {})
    atomic_save_npz(work / "samples.npz", arrays,
                    compress=out.compress and out.status != "interrupted")
    if out.final_field is not None:
        atomic_save_npz(work / "final_field.npz", out.final_field)
    if out.surface is not None:
        atomic_save_npz(work / "surface.npz", out.surface)
    if out.states is not None:
        write_checkpoint(work, out.states, kind=out.kind, scene=out.scene, status=out.status,
                         kernel=summary["scheme"].get("kernel", ""), backend=out.backend)


def _write_failed(rd: directory.RunDir, summary: dict, err: OSError) -> dict:
    """The run's files could not be written: it is ``failed``; a replacement is dropped (the
    earlier run stays), else the small summary.json may still fit where samples.npz did not."""
    summary["status"] = "failed"
    summary["message"] = f"could not write the run's files: {err}"
    if rd.replacing and rd.work.exists():
        directory.discard_run_dir(rd)
        summary["message"] += f"; the earlier run in {rd.final} is kept unchanged"
    else:
        try:
            write_summary(rd.final, summary)
        except OSError:
            pass
    return summary


def finish_summary(s: dict, out: RunOutputs | None, prof: Profile, t0: float) -> dict:
    """Add the wall time, the message, the run's ``warnings``, the peak memory, the profile
    and ``out.extra`` to summary ``s``."""
    s["wall_time_s"] = time.perf_counter() - t0
    if out is not None and out.error:
        s["message"] = out.error
    if out is not None:
        warnings = run_warnings(out.scene, s)
        if warnings:
            s["warnings"] = warnings
    s["peak_rss_mb"] = peak_rss_mb()
    s["profile_s"] = {k: round(v, 4) for k, v in prof.seconds.items()}
    if out is not None:
        s.update(out.extra)
    return s


def run_warnings(scene: Scene, summary: dict) -> list[str]:
    """Every warning of a run, one line each with its fix: the scene's doubtful choices
    (``solver.scene.scene_warnings``) and the analysis's ``warning`` (samples that alias the
    wave). ``summary.json`` keeps them as ``warnings``; a sweep's table and console show them."""
    found = scene_warnings(scene)
    if summary.get("warning"):
        found.append(str(summary["warning"]))
    return found


def summarise(run: Any, probes: dict | None = None) -> dict:
    """Run summary (rank 0): the run's facts plus the wave analysis of the recorded samples;
    with the gathered ``probes``, whether the samples resolve the wave
    (:func:`postprocess.resolution.sampling_check`: a ``warning`` where they alias it).
    ``run``: a scene's run (``solver.columns.SceneRun``, or a ``solver.run.Simulation`` of one
    scene)."""
    out = run.facts()
    data = run.recorder.arrays()
    if data["t"].size >= 4:
        sc = run.scene
        wave = analyse(data["t"], data["theta"], data["u_r"], data["u_theta"], data["status"],
                       d=sc.geometry.d, radius=sc.geometry.R)
        energy = out.pop("energy")  # keep summary.json's key order: wave keys, then energy
        out.update(
            regime=wave.regime, mode=wave.mode, celerity_m_s=wave.celerity_m_s,
            frequency_hz=wave.frequency_hz, fractions=wave.fractions,
            amplitude_m=wave.amplitude_m, limit_cycle=wave.limit_cycle,
            analysis_window_s=wave.window_s, psi1=wave.psi1, psi2=wave.psi2,
            zone_order=wave.zone_order, direction=wave.direction,
            travel_purity=round(wave.travel_purity, 6),
        )
        out.update(sampling_check(data["t"], probes, out))
        out["energy"] = energy
    out["scene_sha256"] = scene_digest(run.scene)  # tells an edited scene.toml (readers)
    return out


class RunDirectory:
    """One run's directory from its claim to its final summary: the one driver of every run
    directory, whatever runs in it (a scene on ranks, ``studies.rundir.scene_run``; a batch
    member, ``studies.sweep.batch``; a continued run or batch, ``studies.rundir.
    continuation``; a census start read back from a node, ``studies.attractors.bundle``).

    1. :meth:`claim` (``directory.prepare_run_dir``): the path is stickslip's or new; a
       replacement is written beside an earlier run and swapped in at the end (``force``), or
       the earlier run's files go first (``in_place``);
    2. :meth:`start`: ``scene.toml`` and the ``running`` summary (``started``: pid, host);
    3. :meth:`save` (:func:`write_run_files`), or :meth:`end`: a run that ended without its
       files, its status and why;
    4. :meth:`release`: the directory's lock let go (it is no longer live).

    Only the rank that claimed (rank 0 of ``comm``) writes.
    """

    def __init__(self, scene: Scene, path: Path) -> None:
        self.scene, self.path = scene, Path(path)
        self.rd: directory.RunDir | None = None
        self.started = running_summary(scene.name)
        self.t0 = time.perf_counter()

    @property
    def work(self) -> Path:
        """Where the run is written meanwhile: the claim's, else (no claim) the path."""
        return self.path if self.rd is None else self.rd.work

    @property
    def final(self) -> Path:
        """Where the run ends up."""
        return self.path if self.rd is None else self.rd.final

    def claim(self, force: bool, comm: Any, in_place: bool = False,
              t0: float | None = None) -> None:
        """Claim the path (collective over ``comm``; ``directory.prepare_run_dir``). The
        run's wall time counts from ``t0`` (``time.perf_counter``; a batch's start, shared by
        its members), default from here."""
        self.rd = directory.prepare_run_dir(self.path, force, comm, in_place=in_place)
        self.t0 = time.perf_counter() if t0 is None else t0

    def start(self) -> None:
        """``scene.toml`` and the ``running`` summary (OSError: the caller removes what it
        made, or records the failure)."""
        write_scene(self.scene, self.work / "scene.toml")
        write_summary(self.work, self.started)

    def save(self, out: RunOutputs, prof: Profile) -> dict:
        """The run's files (:func:`write_run_files`); returns the summary as written."""
        return write_run_files(self.rd, out, prof, self.t0)

    def save_member(self, run: Any, prof: Profile, backend: str, extra: dict | None = None,
                    compress: bool = True) -> dict:
        """A finished batch member (``solver.columns.SceneRun``) saved as a single run;
        ``extra`` (the ``batch`` facts, a ``kick``) goes at the end of its summary."""
        out = RunOutputs(run.scene, run, run.status, run.message or None,
                         probes=run.probes.arrays(), final_field=run.final_field(),
                         states=None if run.state is None else [run.state], kind="batch",
                         backend=backend, extra=dict(extra or {}), compress=compress)
        return self.save(out, prof)

    def end(self, status: str, message: str, folder: Path | None = None, **facts: Any) -> dict:
        """``summary.json`` of a run that ended without its files (into ``folder``, default
        ``work``): what was known at its start (no pid: nobody runs it now), the status, why,
        the wall time and ``facts``. Returns it (OSError: not written)."""
        summary = dict(self.started, status=status, message=message,
                       wall_time_s=time.perf_counter() - self.t0, **facts)
        summary.pop("pid", None)
        write_summary(self.work if folder is None else folder, summary)
        return summary

    def commit(self) -> None:
        """Swap a finished replacement into place."""
        directory.commit_run_dir(self.rd)

    def discard(self) -> None:
        """Drop an unfinished replacement: the earlier run stays as it was."""
        directory.discard_run_dir(self.rd)

    def release(self) -> None:
        """Let the directory's lock go (no-op where nothing was claimed)."""
        if self.rd is not None:
            self.rd.release()


def peak_rss_mb() -> float:
    """Peak resident memory of this process (MB)."""
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def print_summary(s: dict, run_dir: Path, stream, profile: bool) -> None:  # noqa: ANN001
    """The run's summary in a few lines on ``stream``: status, regime, zones, cost."""
    msg = s.get("message")
    lines = [f"status: {s.get('status')}" + (f" ({msg})" if msg and msg != s.get("status") else "")]
    if "regime" in s:
        fr = s["fractions"]
        travel = (f"standing (does not travel: travel purity {s.get('travel_purity', 0):.2f} "
                  f"< {TRAVEL_PURITY_MIN:g})" if s.get("direction") == "standing" else
                  f"celerity {s['celerity_m_s']:+.1f} m/s (+ = rotation sense)")
        lines += [
            f"regime: {s['regime']}, mode k = {s['mode']}, {travel}, "
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
