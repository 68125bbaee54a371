"""Simulation: scene -> problem -> steady state -> Newmark + contact -> observers.

``Simulation.proceed()`` advances the time loop until a stop criterion (simulated time, steps,
wall time) is met, as Dedalus' ``solver.proceed``. The run directory (files, signals,
``summary.json`` with the wave analysis) is ``studies.rundir.run_scene``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from stickslip.solver import __version__
from stickslip.solver.contact import zone_fractions
from stickslip.solver.errors import (  # noqa: F401  (StepTooLarge re-exported for scripts)
    Diverged,
    StepTooLarge,
    blown_up,
    blowup_message,
    energy_bound,
)
from stickslip.solver.observers import Cadence, Observer
from stickslip.solver.scene import Scene
from stickslip.solver.schemes.protocol import Stepper

if TYPE_CHECKING:  # mpi4py is imported where a run uses it: ``run_loop`` runs without it
    from mpi4py import MPI


class Profile:
    """Wall time per phase (mesh, assembly, steady state, time loop, contact, I/O)."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}

    @contextmanager
    def phase(self, name: str):
        t0 = time.perf_counter()
        try:
            yield
        finally:
            self.seconds[name] = self.seconds.get(name, 0.0) + time.perf_counter() - t0


class Simulation:
    """One scene's run. Build with ``Simulation(scene)``, then ``proceed()``.

    The objects, in the order they are built: the problem (mesh, K, M, contact nodes:
    ``solver.problem``), the steady sliding state (``solver.steady``), the scheme's parts
    (``solver.schemes.select.for_scene(scene).build``: the step, the stepper, its contact step
    and its work observers), the step hooks (the work observers that need them, the probes),
    and the observers with a cadence (field output, the inner-circle samples with their health
    and stop checks). ``proceed`` is the one time loop: it advances the stepper to the next
    level an observer wants and asks them.

    It starts from steady sliding plus the scene's ``[initial]`` bump, or from
    ``initial_state`` = (u, v, a or None) on the owned dofs (serial use: a wave of
    ``studies.travel.frame.FrameOperators.shift_state``)."""

    def __init__(self, scene: Scene, comm: MPI.Comm | None = None,
                 profile: Profile | None = None,
                 output_dir: Path | None = None,
                 initial_state: tuple[np.ndarray, np.ndarray, np.ndarray | None] | None = None,
                 ) -> None:
        from stickslip.solver.problem import build_problem, omega_max
        from stickslip.solver.schemes.select import for_scene
        from stickslip.solver.steady import solve_steady_sliding

        if comm is None:
            from mpi4py import MPI

            comm = MPI.COMM_WORLD
        self.scene, self.comm = scene, comm
        self.profile = profile or Profile()
        with self.profile.phase("mesh+assembly"):
            self.problem = build_problem(scene, comm)
        with self.profile.phase("stability"):
            self.omega_max = omega_max(self.problem)
        with self.profile.phase("steady-state"):
            self.steady = solve_steady_sliding(self.problem)
            p = self.steady.pressure
            self.steady_mean_pressure = comm.allreduce(float(p.sum())) / comm.allreduce(p.size)
        # the scheme registry, asked once: the step (refused above the scheme's limit), the
        # stepper, the contact step and the work observers; after the steady solve, as the
        # implicit scheme's factorisation always was (the parallel solves in the same order)
        parts = for_scene(scene).build(self.problem, scene, self.omega_max)
        self.dt, self.dt_crit = parts.dt, parts.dt_crit
        self.integrator, self.projection = parts.stepper, parts.contact
        u0 = self._start(initial_state)
        self._attach_step_hooks(parts, u0)
        self.observers = self._observers(output_dir)
        self.initial_energy: float | None = None
        self.energy_bound = math.inf
        self.status = "running"
        self.stop_reason = ""
        #: Set (e.g. by a SIGINT/SIGTERM handler) to stop at the next sample; see _stop_now.
        self.stop_requested = False
        self._stop_code = np.zeros(1, dtype=np.int32)  # reused by _stop_now's Allreduce
        self._t_start, self._max_wall = time.perf_counter(), None

    @property
    def dofs(self) -> int:
        """Degrees of freedom of the whole tube."""
        return int(self.problem.n_global_dofs)

    @property
    def ranks(self) -> int:
        return self.comm.size

    @property
    def stepper(self):
        """The time scheme (``solver.schemes.protocol.Stepper``); also ``integrator``."""
        return self.integrator

    def _start(self, initial_state) -> np.ndarray:
        """Set the stepper's initial state; returns u_0."""
        if initial_state is None:  # steady sliding + the scene's [initial] bump
            u0 = self.steady.u + self.perturbation()
            self.integrator.set_state(u0, np.zeros_like(u0))
            return u0
        u0, v0, a0 = (None if x is None else np.asarray(x, dtype=float) for x in initial_state)
        shapes = [x.shape for x in (u0, v0, a0) if x is not None]
        if any(sh != (self.problem.n_owned,) for sh in shapes):
            raise ValueError(f"initial_state: u, v (and a) need {self.problem.n_owned} "
                             f"owned dofs each, got {shapes}")
        if a0 is None:  # the implicit scheme finds a_0 from its own law
            self.integrator.set_state(u0, v0)
        else:
            self.integrator.set_state(u0, v0, a0)
        return u0

    def _attach_step_hooks(self, parts, u0: np.ndarray) -> None:
        """The scheme's work observers (contact work; Kelvin-Voigt work of a damped scene:
        step hooks unless the kernel sums them, ``SchemeParts.work_observers``), the samples'
        recorder and the probes (a step hook, after the work observers)."""
        from stickslip.solver.observers import InnerCircleRecorder, ProbeRecorder

        sc, stepper = self.scene, self.integrator
        self.energy, self.damping_work = parts.work_observers(sc.loading.f > 0.0, u0)
        n_steps = self.planned_steps()
        every = max(1, int(round(sc.output.sample_interval / self.dt)))
        self.recorder = InnerCircleRecorder(self.problem, self.projection, self.energy, every,
                                            max_samples=n_steps // every + 2)
        self.recorder.damping = self.damping_work
        self.probes = ProbeRecorder(self.problem, self.projection, sc.output.probes_deg,
                                    n_steps)
        stepper.attach(self.probes)

    def _observers(self, output_dir: Path | None) -> list:
        """The observers with a cadence, in the order they see a level: field output (only
        when the scene asks for it), the samples with the energy guard, the progress line,
        the stop check."""
        from stickslip.solver.observers import Progress

        sc = self.scene
        self.progress = Progress(sc.time.end_time, sc.output.progress and self.comm.rank == 0)
        self.writer = None
        observers: list = []
        if sc.output.fields and output_dir is not None:
            from stickslip.solver.field_output import FieldOutput

            observers.append(FieldOutput(self, Path(output_dir)))
            self.writer = observers[-1].writer
        observers += [Sampling(self), ProgressLine(self), StopCheck(self)]
        return observers

    def planned_steps(self) -> int:
        return planned_steps(self.scene, self.dt)

    def perturbation(self) -> np.ndarray:
        """Initial radial bump of the scene's ``[initial]`` table (``initial_perturbation``)."""
        return initial_perturbation(self.problem, self.scene)

    def _check_health(self, kinetic: float, strain: float) -> None:
        """NaN check, and an energy bound: a blow-up, not a wave fed by the cylinder.

        The guard of ``solver.errors``: diverged when E > 1e4 E(0) *and*
        E > 10 (E(0) + W_cylinder(t)).
        """
        total = kinetic + strain
        if not math.isfinite(total):
            raise Diverged(f"non-finite energy at t = {self.integrator.time:.6g} s")
        if self.initial_energy is None:
            self.initial_energy = total
            self.energy_bound = float(energy_bound(total))
            return
        fed = self.initial_energy + abs(self.recorder.last_work[1])
        if blown_up(total, self.energy_bound, fed):
            raise Diverged(blowup_message(total, fed, self.integrator.time))

    def _stop_now(self) -> str:
        """At a sample: "" or why to stop, agreed by every rank (one integer allreduce).

        "signal": some rank saw ``stop_requested`` (SIGINT/SIGTERM), so all ranks stop at the
        same step and save the same samples; "max_wall_time": the wall-clock limit.
        """
        code = 2 if self.stop_requested else 0
        max_wall = self._max_wall
        if not code and max_wall is not None and time.perf_counter() - self._t_start > max_wall:
            code = 1
        if self.comm.size > 1:  # buffer Allreduce: no pickling (65 us vs 240 us measured)
            from mpi4py import MPI

            self._stop_code[0] = code
            self.comm.Allreduce(MPI.IN_PLACE, self._stop_code, op=MPI.MAX)
            code = int(self._stop_code[0])
        return ("", "max_wall_time", "signal")[code]

    def proceed(self, end_time: float | None = None, max_steps: int | None = None,
                max_wall_time: float | None = None) -> str:
        """Advance until a stop criterion: sim time, step count, wall time, or an observer's
        word (a signal). Returns the reason. The one time loop: the stepper advances to the
        next level that an observer wants (``advance``: compiled where it can be), then each
        observer due at that level observes it."""
        ts = self.scene.time
        end_time = ts.end_time if end_time is None else end_time
        max_steps = (ts.max_steps or None) if max_steps is None else max_steps
        self._max_wall = (ts.max_wall_time or None) if max_wall_time is None else max_wall_time
        stepper, observers = self.integrator, self.observers
        t_stop = end_time - 1e-12 * end_time
        step_stop = max_steps if max_steps is not None else math.inf
        record_sample = stepper.compiled_recorder()  # a compiled loop samples compiled too
        if record_sample is not None:
            self.recorder.use_compiled(record_sample)
        self._t_start = time.perf_counter()
        with self.profile.phase("time-loop"):
            self.stop_reason = run_loop(stepper, observers, t_stop, step_stop)
        self.profile.seconds["contact (in time-loop)"] = float(stepper.facts()["contact_s"])
        return self.stop_reason

    # ------------------------------------------------------------------ checkpoint

    def _state_parts(self) -> dict:
        """The objects whose state a continued run needs, by name: the stepper, the contact
        step, the contact-work and (damped explicit) damping-work observers."""
        parts = {"stepper": self.integrator, "contact": self.projection, "energy": self.energy}
        if self.damping_work is not None:
            parts["damping"] = self.damping_work
        return parts

    @property
    def resumable(self) -> bool:
        """True once ``proceed`` has returned: the run stands at a whole time level (every
        observer has seen what it was due to see), so ``checkpoint`` can be continued."""
        return bool(self.stop_reason)

    def checkpoint(self) -> dict[str, np.ndarray]:
        """This rank's checkpoint, flat ``{"part/name": array}``: each part's ``state()``
        (``_state_parts``: the last level's vectors, the contact statuses, the work sums), and
        under ``run/`` the energy guard's E(0) and bound, the steady pressure and the counts
        of samples and probe steps taken. The cadences need nothing: they are fixed levels
        (``Cadence``) and the step count is the stepper's. The records themselves are the
        run's samples.npz (``restore``'s ``before``)."""
        out = {f"{part}/{key}": value for part, obj in self._state_parts().items()
               for key, value in obj.state().items()}
        e0 = math.nan if self.initial_energy is None else self.initial_energy
        out.update({"run/partition": np.array(self.partition_id()),
                    "run/initial_energy": np.float64(e0),
                    "run/energy_bound": np.float64(self.energy_bound),
                    "run/steady_pressure": np.float64(self.steady_mean_pressure),
                    "run/samples": np.int64(self.recorder.n),
                    "run/probe_steps": np.int64(self.probes.n)})
        return out

    def restore(self, state: dict[str, np.ndarray],
                before: dict[str, np.ndarray] | None = None) -> None:
        """Continue from ``checkpoint()`` of the same scene on the same ranks (call before
        ``proceed``). ``before``: the records taken up to the checkpoint (samples.npz, on
        rank 0; None elsewhere), which ``recorder.arrays()`` and ``probes.arrays()`` then put
        in front of the new ones (``solver.observers.ContinuedRecords``)."""
        from stickslip.solver.observers import ContinuedRecords

        mine = str(state["run/partition"]) == self.partition_id()
        if not all(self.comm.allgather(mine)):
            raise ValueError("the mesh partition differs from the checkpoint's (a partitioner "
                             "that is not reproducible: is SCOTCH_PTHREAD_NUMBER set above "
                             "1?); continue with the partition the run had")
        for part, obj in self._state_parts().items():
            head = f"{part}/"
            obj.restore({k[len(head):]: v for k, v in state.items() if k.startswith(head)})
        e0 = float(state["run/initial_energy"])
        self.initial_energy = None if math.isnan(e0) else e0
        self.energy_bound = float(state["run/energy_bound"])
        self.steady_mean_pressure = float(state["run/steady_pressure"])
        self.recorder = ContinuedRecords(self.recorder, before, state["run/samples"])
        self.probes = ContinuedRecords(self.probes, before, state["run/probe_steps"])

    def partition_id(self) -> str:
        """This rank's part of the mesh, as a hash of its owned nodes' coordinates (sorted):
        the same on every build of the same partition, whatever the local numbering."""
        import hashlib

        x = self.problem.V.tabulate_dof_coordinates()[: self.problem.n_owned // 2, :2]
        ordered = np.ascontiguousarray(x[np.lexsort(x.T)])
        return hashlib.sha256(ordered.tobytes()).hexdigest()

    def final_field(self) -> dict[str, np.ndarray] | None:
        """Displacement on the whole tube at the end, with the stress and contact tractions
        of the last completed level n at ``fields_time`` t_n
        (``solver.field_output.last_level_fields``), gathered to rank 0 (None elsewhere);
        see ``gather_final_field``."""
        from stickslip.solver.field_output import last_level_fields

        stepper = self.integrator
        field = gather_final_field(self.problem, stepper.u, self.comm, stepper.time,
                                   *last_level_fields(self))
        if field is not None:
            field["fields_time"] = np.array(stepper.time - stepper.dt)  # level n
        return field

    @property
    def steps(self) -> int:
        return self.integrator.step_count

    @property
    def sim_time(self) -> float:
        return self.integrator.time

    def facts(self) -> dict:
        """What the run did (rank 0): status, steps, dt, dofs, ranks, scheme. No analysis."""
        return run_facts(self, self.integrator.facts())


def planned_steps(scene: Scene, dt: float) -> int:
    """Steps to ``time.end_time`` at step dt, capped by ``time.max_steps``."""
    n = int(math.ceil(scene.time.end_time / dt - 1e-9))
    if scene.time.max_steps:
        n = min(n, scene.time.max_steps)
    return n


def initial_perturbation(problem, scene: Scene) -> np.ndarray:
    """Initial radial bump (scene ``[initial]``), amplitude x d, shaped by X(r) (eq. [1]).

    "mode": A (1 + cos k theta) / 2; "random": sum_k w_k (1 + cos(k theta + phi_k)) / 2 over
    k = 1 .. n_modes, weights w_k uniform and normalised to sum 1, phases uniform in
    [0, 2 pi), from ``initial.seed`` (the same numbers on every rank: partition-free).
    """
    ini, d = scene.initial, scene.geometry.d
    if ini.perturbation == "none" or ini.amplitude == 0.0:
        return np.zeros(problem.n_owned)
    amp = ini.amplitude * d
    if ini.perturbation == "mode":
        k = ini.mode
        return problem.radial_field(lambda th: amp * 0.5 * (1.0 + np.cos(k * th)))
    return problem.radial_field(random_bump(ini.seed, ini.n_modes, amp))


def random_bump(seed: int, n_modes: int, amplitude: float) -> Callable[[np.ndarray],
                                                                         np.ndarray]:
    """The random start's shape A(θ) = amplitude Σ_k w_k (1 + cos(kθ + φ_k)) / 2, k = 1 ..
    n_modes, w_k ~ U(0, 1) normalised to sum 1, φ_k ~ U(0, 2π) from
    ``numpy.random.default_rng(seed)`` (``initial_perturbation``; a kick's field)."""
    rng = np.random.default_rng(seed)
    ks = np.arange(1, n_modes + 1)
    weights = rng.uniform(0.0, 1.0, ks.size)
    phases = rng.uniform(0.0, 2 * np.pi, ks.size)
    weights /= weights.sum()

    def shape(th: np.ndarray) -> np.ndarray:
        s = np.zeros_like(th)
        for k, w, ph in zip(ks, weights, phases, strict=True):
            s += w * 0.5 * (1.0 + np.cos(k * th + ph))
        return amplitude * s

    return shape


def gather_final_field(problem, u: np.ndarray, comm: MPI.Comm, time_s: float,
                       point_data: dict[str, np.ndarray] | None = None,
                       cell_data: dict[str, np.ndarray] | None = None,
                       ) -> dict[str, np.ndarray] | None:
    """Displacement ``u`` (owned dofs) on the whole tube, gathered to rank 0 (None elsewhere).

    VTK-ready arrays for iso-value maps: ``points`` (n, 3), ``cells`` (flat VTK topology
    [nv, i0, ..., nv, ...]), ``cell_types``, ``u`` (n, 2) at the points. Each rank sends
    its local cells; ghost points are duplicated, which is harmless for plotting.
    ``point_data`` (values at the rank's local dofs of the scalar space, ghosts included)
    and ``cell_data`` (values at its owned cells) are gathered alongside, under their keys.
    """
    import dolfinx.plot

    point_data, cell_data = point_data or {}, cell_data or {}
    fn = problem.to_function(u)
    topology, cell_types, geometry = dolfinx.plot.vtk_mesh(problem.V)
    n_points = geometry.shape[0]
    values = fn.x.array.reshape(-1, 2)[:n_points]
    extra = {k: np.asarray(v)[:n_points] for k, v in point_data.items()}
    extra.update(cell_data)
    pieces = comm.gather((topology, cell_types, geometry, values, extra), root=0)
    if comm.rank != 0:
        return None
    cells, types, points, us = [], [], [], []
    offset = 0
    for top, ct, geo, val, _ in pieces:
        nv = int(top[0]) if top.size else 0
        blocks = top.reshape(-1, nv + 1).copy() if top.size else top.reshape(0, 1)
        blocks[:, 1:] += offset
        cells.append(blocks.ravel())
        types.append(ct)
        points.append(geo)
        us.append(val)
        offset += geo.shape[0]
    out = {
        "points": np.concatenate(points),
        "cells": np.concatenate(cells),
        "cell_types": np.concatenate(types),
        "u": np.concatenate(us),
        "time": np.array(time_s),
    }
    for key in (*point_data, *cell_data):
        out[key] = np.concatenate([piece[4][key] for piece in pieces])
    return out


def run_facts(run, scheme: dict) -> dict:
    """The facts of a run (a ``Simulation``, or one scene of a ``BatchSimulation``): status,
    steps, dt, dofs, ranks, the scheme's ``facts()``, and the energy balance of its samples."""
    out: dict = {
        "stickslip_version": __version__,
        "scene": run.scene.name,
        "status": run.status,
        "stop_reason": run.stop_reason,
        "steps": run.steps,
        "sim_time_s": run.sim_time,
        "dt_s": run.dt,
        "dt_crit_s": run.dt_crit,
        "omega_max_rad_s": run.omega_max,
        "dofs": run.dofs,
        "contact_nodes": int(run.recorder.n_nodes),
        "ranks": run.ranks,
        "samples": int(run.recorder.n),
        "steady_pressure_pa": run.steady_mean_pressure,
        "scheme": scheme,
    }
    data = run.recorder.arrays()
    if data["t"].size >= 4:  # as many samples as the wave analysis needs
        out["energy"] = energy_balance(data["energies"])
    return out


def energy_balance(e: np.ndarray) -> dict[str, float]:
    """The energy terms at the last sample and the residual of the balance
    E(t) - E(0) = W_contact - W_damping (columns of ``solver.observers.ENERGY_FIELDS``)."""
    wd = e[:, 5] if e.shape[1] > 5 else np.zeros(e.shape[0])
    return {
        "initial_J_per_m": float(e[0, 0] + e[0, 1]),
        "final_J_per_m": float(e[-1, 0] + e[-1, 1]),
        "work_contact_J_per_m": float(e[-1, 2]),
        "work_cylinder_J_per_m": float(e[-1, 3]),
        "friction_dissipation_J_per_m": float(e[-1, 4]),
        "damping_dissipation_J_per_m": float(wd[-1]),
        "balance_residual_J_per_m": float(e[-1, 0] + e[-1, 1] - e[0, 0] - e[0, 1]
                                          - (e[-1, 2] - e[0, 2]) + (wd[-1] - wd[0])),
    }


def run_loop(stepper: Stepper, observers: list[Observer], t_stop: float,
             step_stop: float) -> str:
    """THE time loop, for one scene or a batch: advance ``stepper`` to the next level an
    observer is due at, let the due observers observe, until ``t_stop``, ``step_stop`` or an
    observer's stop reason. Returns "end_time", "max_steps" or the observer's reason."""
    while True:
        if stepper.time >= t_stop:
            return "end_time"
        if stepper.step_count >= step_stop:
            return "max_steps"
        s = stepper.step_count  # the level the next step completes
        target = min(obs.cadence.next_level(s) for obs in observers) if observers else s
        stepper.advance(int(min(target - s + 1, step_stop - s)), t_stop)
        level = stepper.step_count - 1
        stop = ""
        for obs in observers:
            if obs.due(level):
                stop = obs.observe(stepper) or stop
        if stop:
            return stop


class Sampling:
    """Observer: the inner-circle samples and energies at ``output.sample_interval``, then the
    energy guard (``Simulation._check_health``) on them."""

    def __init__(self, sim: Simulation) -> None:
        self.sim = sim
        self.recorder = sim.recorder
        self.cadence = Cadence(sim.recorder.every)

    def due(self, level: int) -> bool:
        return self.recorder.due(level)

    def observe(self, stepper) -> str:
        kin, strain = self.recorder.sample(stepper)
        self.sim._check_health(kin, strain)
        return ""


class ProgressLine:
    """Observer: one progress line on rank 0 at a sampled level once ``Progress.interval``
    seconds of wall time have passed (the zone fractions of the recent samples)."""

    def __init__(self, sim: Simulation) -> None:
        self.progress, self.recorder = sim.progress, sim.recorder
        self.cadence = Cadence(sim.recorder.every)
        self.enabled = sim.comm.rank == 0

    def due(self, level: int) -> bool:
        return self.enabled and self.cadence.at(level) and self.progress.due()

    def observe(self, stepper) -> str:
        rec = self.recorder
        recent = zone_fractions(rec.recent_status(max(1, rec.n // 10)))
        self.progress.update(stepper.time, stepper.step_count, recent)
        return ""


class StopCheck:
    """Observer: at each sampled level, whether to stop (a signal, the wall-time limit),
    agreed by every rank (``Simulation._stop_now``: one integer allreduce)."""

    def __init__(self, sim: Simulation) -> None:
        self.sim, self.recorder = sim, sim.recorder
        self.cadence = Cadence(sim.recorder.every)

    def due(self, level: int) -> bool:
        return self.recorder.due(level)

    def observe(self, stepper) -> str:
        return self.sim._stop_now()
