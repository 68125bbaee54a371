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
import signal
import sys
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np
from mpi4py import MPI

from solver import __version__
from solver.atomic import atomic_write_text
from solver.errors import Diverged
from solver.run import Profile, Simulation
from solver.scene import Scene, write_scene
from studies.output import output_root  # noqa: F401  (re-exported)


def summarise(sim: Simulation) -> dict:
    """Run summary (rank 0): the run's facts plus the wave analysis of the recorded samples."""
    from postprocess.analysis import analyse

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
        out["energy"] = energy
    return out


def atomic_save_npz(path: Path, arrays: dict[str, np.ndarray]) -> None:
    tmp = path.with_name(f".{path.stem}.tmp.npz")
    np.savez_compressed(tmp, **arrays)
    os.replace(tmp, path)


def prepare_run_dir(path: Path, force: bool, comm: MPI.Comm) -> None:
    """Create the run directory; refuse to overwrite an existing one unless ``force``."""
    error = None
    if comm.rank == 0:
        if path.exists() and any(path.iterdir()):
            if not force:
                error = (f"run directory {path} exists; use --force to overwrite it, "
                         "or -o to choose another")
            else:
                shutil.rmtree(path)
        if error is None:
            path.mkdir(parents=True, exist_ok=True)
    error = comm.bcast(error, root=0)
    if error:
        raise FileExistsError(error)


@contextmanager
def _sigterm_as_interrupt():
    """SIGTERM (e.g. a batch system or mpirun being killed) behaves like Ctrl-C."""

    def handler(signum, frame):
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def run_scene(scene: Scene, run_dir: Path, *, force: bool = False,
              comm: MPI.Comm = MPI.COMM_WORLD, profile: bool = False,
              stream=sys.stdout) -> dict:
    """Run ``scene`` into ``run_dir``: scene.toml, samples.npz, summary.json (rank 0)."""
    prof = Profile()
    rank0 = comm.rank == 0

    def say(msg: str) -> None:
        if rank0:
            print(msg, file=stream, flush=True)

    prepare_run_dir(run_dir, force, comm)
    if rank0:
        write_scene(scene, run_dir / "scene.toml")
        atomic_write_text(run_dir / "summary.json",
                          json.dumps({"scene": scene.name, "status": "running"}, indent=2))
    t0 = time.perf_counter()
    sim = None
    error = None
    with _sigterm_as_interrupt():
        try:
            say(f"stickslip {__version__}: scene '{scene.name}' on {comm.size} rank(s)")
            sim = Simulation(scene, comm, prof, output_dir=run_dir)
            for warning in scene_warnings(scene):
                say(f"  warning: {warning}")
            say(f"  {sim.problem.n_global_dofs} dofs, {sim.recorder.n_nodes} contact nodes, "
                f"dt = {sim.dt:.4g} s ({sim.dt / sim.dt_crit:.2f} dt_crit), "
                f"{sim.planned_steps()} steps to t = {scene.time.end_time} s")
            sim.proceed()
            sim.status = "completed"
        except KeyboardInterrupt:
            if sim is not None:
                sim.status = "interrupted"
            error = "interrupted"
        except Diverged as err:
            if sim is not None:
                sim.status = "diverged"
            error = str(err)
    with prof.phase("output"):
        summary = summarise(sim) if (sim is not None and rank0) else {}
        probe_arrays = sim.probes.arrays() if sim is not None else None
        field = sim.final_field() if sim is not None else None
        if sim is not None and sim.writer is not None:
            sim.writer.close()
        if rank0:
            if sim is None:
                summary = {"scene": scene.name, "status": "interrupted"}
            summary["wall_time_s"] = time.perf_counter() - t0
            if error:
                summary["message"] = error
            if sim is not None:
                arrays = sim.recorder.arrays()
                arrays.update(probe_arrays or {})
                atomic_save_npz(run_dir / "samples.npz", arrays)
                if field is not None:
                    atomic_save_npz(run_dir / "final_field.npz", field)
    if rank0:
        summary["profile_s"] = {k: round(v, 4) for k, v in prof.seconds.items()}
        summary["peak_rss_mb"] = peak_rss_mb()
        atomic_write_text(run_dir / "summary.json", json.dumps(summary, indent=2))
        _print_summary(summary, run_dir, stream, profile)
    return summary


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
    return out


def _print_summary(s: dict, run_dir: Path, stream, profile: bool) -> None:
    lines = [f"status: {s.get('status')}" + (f" ({s['message']})" if s.get("message") else "")]
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
    lines.append(f"steps {s.get('steps')}, wall {s.get('wall_time_s', 0):.2f} s, "
                 f"peak RSS {s.get('peak_rss_mb', 0):.0f} MB -> {run_dir}")
    if profile:
        lines.append("profile: " + ", ".join(f"{k} {v:.3f} s" for k, v in s["profile_s"].items()))
    print("\n".join(lines), file=stream, flush=True)
