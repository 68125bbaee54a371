"""Batched sweeps: scenes that share mesh, material, dt and scheme run as one batch.

``stickslip sweep --batch off|auto|B``. ``plan_units`` groups the pending scenes by
``batch_key`` (the scene without what only the contact law and the initial state see: Omega,
f, delta, the initial perturbation, the name) and cuts each group into batches of at most B
scenes; ``run_batch`` runs one batch with ``solver.ensemble.BatchedExplicit`` on one rank.

Each scene keeps what ``stickslip run`` gives it: its run directory (scene.toml, summary.json
with status ``running`` while the batch runs, samples.npz, final_field.npz), its log, its
final status and the resume semantics of the sweep. A scene whose energy check fails is
masked out of the batch (status ``diverged``, with the step at which it blew up) and the
others go on; a scene whose set-up fails (e.g. no steady sliding) is ``failed`` alone.
The numbers are the ones of the single-scene run with the numba kernel, bitwise
(tests/test_ensemble.py): the batched kernel sums in the same order.

Scenes that cannot be batched run one by one, as before: the implicit scheme (beta1 > 0),
field output (``output.fields``), ``time.kernel = "numpy"`` (the reference step), groups of
more than one rank per scene, and groups of a single scene.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import tempfile
import time
import traceback
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace
from typing import TextIO

import numpy as np

from solver.atomic import atomic_write_text
from solver.scene import Scene, scene_to_dict, write_scene
from studies.resources import available_memory
from studies.sweep.spec import SweepSpec, Task, scene_for

#: Scene keys that may differ inside a batch (the contact law's data and the initial state).
PER_SCENE = {"name": None, "description": None, "loading": None, "initial": None,
             "geometry": ("delta",)}
#: Memory a batch may use (bytes) when ``--batch auto`` picks its size.
AUTO_MEMORY_FRACTION = 0.25
AUTO_MAX = 1024
#: A batch keeps its whole sample record in memory when it needs at most this fraction of
#: the available memory; otherwise the record is spooled to files under the sweep directory.
SPOOL_MEMORY_FRACTION = 0.1


def batch_key(scene: Scene) -> str | None:
    """The grouping key of ``scene`` (equal keys: same K, M, dt, scheme), or None if the
    scene must run alone (see the module docstring)."""
    from solver.fused import resolve_kernel

    if scene.time.beta1 > 0.0 or scene.output.fields:
        return None
    try:
        if resolve_kernel(scene) != "numba":
            return None
    except ValueError:
        return None
    d = scene_to_dict(scene)
    for section, keys in PER_SCENE.items():
        if keys is None:
            d.pop(section, None)
        else:
            for k in keys:
                d[section].pop(k, None)
    return json.dumps(d, sort_keys=True)


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


def _member(sim_cls, scene: Scene, problem, base) -> object:
    """A ``Simulation`` shell for one scene of the batch (its facts, field, perturbation)."""
    member = sim_cls.__new__(sim_cls)
    member.scene, member.comm = scene, base.comm
    member.problem = replace(problem, scene=scene)
    member.profile = base.profile
    member.dt, member.dt_crit, member.omega_max = base.dt, base.dt_crit, base.omega_max
    member.status, member.stop_reason = "running", ""
    member.writer = None
    return member


def run_batch(spec: SweepSpec, tasks: list[Task], out_dir: Path, world_rank: int,
              backend: str = "cpu", stream: TextIO | None = None) -> list[str]:
    """Run ``tasks`` (same ``batch_key``) as one batch on this rank; returns their statuses."""
    from mpi4py import MPI

    from solver.ensemble import BatchedExplicit, BatchedProblem, array_namespace
    from solver.ensemble_observers import BatchRecorder
    from solver.observers import InnerCircleRecorder, ProbeRecorder
    from solver.problem import ContactProjection, build_problem, omega_max
    from solver.run import Profile, Simulation
    from solver.schemes import time_step
    from solver.steady import solve_steady_sliding
    from studies.rundir import (
        _print_summary,
        atomic_save_npz,
        peak_rss_mb,
        prepare_run_dir,
        summarise,
    )

    comm = MPI.COMM_SELF
    t0 = time.perf_counter()
    scenes = [scene_for(spec, t) for t in tasks]
    run_dirs = [out_dir / "runs" / t.id for t in tasks]
    logs = []
    for t, sc, rd in zip(tasks, scenes, run_dirs, strict=True):
        prepare_run_dir(rd, True, comm, in_place=True).release()
        write_scene(sc, rd / "scene.toml")
        atomic_write_text(rd / "summary.json",
                          json.dumps({"scene": sc.name, "status": "running"}, indent=2))
        log = open(out_dir / "logs" / f"{t.id}.log", "a")  # noqa: SIM115
        log.write(f"== start {time.strftime('%Y-%m-%dT%H:%M:%S')} world rank {world_rank} "
                  f"(1 rank(s)) pid {os.getpid()} batch of {len(tasks)} ({backend})\n")
        log.flush()
        logs.append(log)
    statuses = ["failed"] * len(tasks)
    messages: list[str | None] = [None] * len(tasks)

    def fail(k: int, err: BaseException) -> None:
        tb = traceback.format_exc()
        logs[k].write(tb)
        statuses[k] = "failed"
        messages[k] = f"{type(err).__name__}: {err}"
        atomic_write_text(run_dirs[k] / "summary.json", json.dumps({
            "scene": scenes[k].name, "status": "failed", "message": messages[k],
            "traceback": tb.splitlines()[-6:], "wall_time_s": time.perf_counter() - t0,
            "ranks": 1}, indent=2))

    members: list = []
    live: list[int] = []
    spools: list[Path] = []
    interrupted = False
    try:
        base = SimpleNamespace(comm=comm, profile=Profile())
        with base.profile.phase("mesh+assembly"):
            problem = build_problem(scenes[0], comm)
        with base.profile.phase("stability"):
            base.omega_max = omega_max(problem)
        base.dt, base.dt_crit = time_step(scenes[0], base.omega_max)
        dt = base.dt
        u0s = []
        for k, sc in enumerate(scenes):
            m = _member(Simulation, sc, problem, base)
            members.append(m)
            try:
                with base.profile.phase("steady-state"):
                    m.steady = solve_steady_sliding(m.problem)
                p = m.steady.pressure
                m.steady_mean_pressure = float(p.sum()) / p.size
                u0s.append(m.steady.u + m.perturbation())
                live.append(k)
            except Exception as err:  # this scene fails alone
                fail(k, err)
        if live:
            statuses = _advance(spec, scenes, members, live, problem, base, dt, u0s, backend,
                                logs, statuses, messages, BatchedProblem, BatchedExplicit,
                                BatchRecorder, array_namespace, InnerCircleRecorder,
                                ProbeRecorder, ContactProjection, out_dir, spools)
    except KeyboardInterrupt:
        interrupted = True
    except Exception as err:  # the batch as a whole failed: every live scene is failed
        for k in live or range(len(tasks)):
            fail(k, err)
        live = []
    with base.profile.phase("output"):
        for k in live:
            m = members[k]
            if not hasattr(m, "recorder"):  # interrupted before the batch was built
                statuses[k] = "interrupted"
                atomic_write_text(run_dirs[k] / "summary.json", json.dumps(
                    {"scene": scenes[k].name, "status": "interrupted"}, indent=2))
                continue
            if interrupted:
                m.status = "interrupted"
                messages[k] = "interrupted"
            summary = summarise(m)
            summary["wall_time_s"] = time.perf_counter() - t0
            if messages[k]:
                summary["message"] = messages[k]
            summary["batch"] = {"size": len(tasks), "backend": backend}
            arrays = m.recorder.arrays()
            arrays.update(m.probes.arrays() or {})
            atomic_save_npz(run_dirs[k] / "samples.npz", arrays)
            field = m.final_field()
            if field is not None:
                atomic_save_npz(run_dirs[k] / "final_field.npz", field)
            summary["profile_s"] = {kk: round(v, 4) for kk, v in base.profile.seconds.items()}
            summary["peak_rss_mb"] = peak_rss_mb()
            atomic_write_text(run_dirs[k] / "summary.json", json.dumps(summary, indent=2))
            _print_summary(summary, run_dirs[k], logs[k], False)
            statuses[k] = m.status
    for spool in spools:  # the batch's sample chunks, now in every scene's samples.npz
        shutil.rmtree(spool, ignore_errors=True)
    for log, st in zip(logs, statuses, strict=True):
        log.write(f"== end {st}\n")
        log.close()
    if interrupted:
        raise KeyboardInterrupt
    return statuses


class _MemberRecorder:
    """``InnerCircleRecorder`` face of one scene of a ``BatchRecorder``."""

    def __init__(self, rec, b: int, n_nodes: int) -> None:
        self.rec, self.b, self.n_nodes = rec, b, n_nodes
        self.n = 0
        self.n_probe = 0

    def arrays(self) -> dict[str, np.ndarray]:
        return self.rec.arrays(self.b, self.n)

    def probe(self) -> SimpleNamespace:
        return SimpleNamespace(arrays=lambda: self.rec.probe_arrays(self.b, self.n_probe))


def _advance(spec, scenes, members, live, problem, base, dt, u0s, backend, logs, statuses,
             messages, BatchedProblem, BatchedExplicit, BatchRecorder, array_namespace,
             InnerCircleRecorder, ProbeRecorder, ContactProjection, out_dir,
             spools) -> list[str]:
    """Build the batch of the ``live`` scenes, step it to the end, fill the members."""
    sc0 = scenes[live[0]]
    ts = sc0.time
    xp = array_namespace(backend)
    bp = BatchedProblem.from_problem(problem, dt, ts.beta2)
    g = [scenes[k] for k in live]
    integ = BatchedExplicit(
        bp, d=np.array([s.geometry.d for s in g]),
        slide=np.array([s.geometry.R * s.loading.omega * dt for s in g]),
        f=np.array([s.loading.f for s in g]), xp=xp,
        kernel="numba" if backend == "cpu" else "cuda")
    integ.set_state(np.stack(u0s, axis=1), np.zeros((bp.n, len(live))))
    kappa = (ts.beta2 + 0.5) * dt * dt
    projection = ContactProjection(problem, kappa, dt)
    shape = InnerCircleRecorder(problem, projection, None, 1, max_samples=0)
    probes = ProbeRecorder(problem, projection, sc0.output.probes_deg, 0)
    every = max(1, int(round(sc0.output.sample_interval / dt)))
    n_steps = members[live[0]].planned_steps()
    # the record stays in memory when it fits (no file round trip in the time loop);
    # otherwise it is spooled to disk in chunks, so memory does not grow with the run
    n_probes = len(probes.index)
    record = BatchRecorder.record_bytes(len(live), bp.cx.size, n_probes,
                                        n_steps // every + 2, n_steps)
    in_memory = xp is np and record <= SPOOL_MEMORY_FRACTION * available_memory()
    spool = None if in_memory else Path(tempfile.mkdtemp(prefix=".batch-", dir=out_dir))
    rec = BatchRecorder(
        integ, mass=problem.mass, perm=shape.perm, theta=shape.theta, ds=shape.ds,
        every=every, max_samples=n_steps // every + 2, max_steps=n_steps,
        probe_nodes=np.asarray(probes.index), probe_pc=probes.phase_conj,
        probe_deg=np.asarray(probes.angles), spool_dir=spool)
    integ.keep_nodes(np.asarray(probes.index))
    views = []
    for b, k in enumerate(live):
        m = members[k]
        m.integrator = SimpleNamespace(step_count=0, time=0.0, beta1=0.0, beta2=ts.beta2,
                                       kernel=f"batched-{integ.kernel}", compile_s=0.0,
                                       contact_seconds=0.0, u=None)
        view = _MemberRecorder(rec, b, shape.n_nodes)
        m.recorder = view
        m.probes = view.probe()
        views.append(view)
    end_time = ts.end_time
    max_steps = ts.max_steps or None
    max_wall = ts.max_wall_time or None
    t_start = time.perf_counter()
    stop = "end_time"
    try:
        with base.profile.phase("time-loop"):
            while True:
                if integ.time >= end_time - 1e-12 * end_time:
                    stop = "end_time"
                    break
                if max_steps is not None and integ.step_count >= max_steps:
                    stop = "max_steps"
                    break
                if not integ.active.any():
                    break
                integ.step(diag=rec.due(integ.step_count))
                rec.record_probes()
                if rec.due(integ.step_count - 1):
                    kin, strain, wcyl = rec.sample()
                    for b, msg in rec.check_health(kin, strain, wcyl, integ.time).items():
                        _finish_member(members[live[b]], views[b], integ, rec, b, "diverged")
                        messages[live[b]] = msg
                        integ.mask(b)
                    if max_wall is not None and time.perf_counter() - t_start > max_wall:
                        stop = "max_wall_time"
                        break
    finally:
        rec.close()
        for b, k in enumerate(live):
            if integ.active[b]:
                _finish_member(members[k], views[b], integ, rec, b, "completed", stop)
    out = list(statuses)
    for k in live:
        out[k] = members[k].status
    if spool is not None:
        spools.append(spool)
    return out


def _finish_member(m, view, integ, rec, b: int, status: str, stop: str = "") -> None:
    """Freeze scene b's facts at this step (a diverged scene stops here, as alone)."""
    m.status = status
    m.stop_reason = stop
    m.integrator.step_count = integ.step_count
    m.integrator.time = integ.time
    m.integrator.compile_s = integ.compile_s
    u = integ.u[:, b]
    m.integrator.u = np.array(u.get() if hasattr(u, "get") else u)
    view.n = rec.n
    view.n_probe = rec.n_probe
