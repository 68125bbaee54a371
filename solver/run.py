"""Simulation: scene -> problem -> steady state -> Newmark + contact -> observers.

``Simulation.proceed()`` advances the time loop until a stop criterion (simulated time, steps,
wall time) is met, as Dedalus' ``solver.proceed``. The run directory (files, signals,
``summary.json`` with the wave analysis) is ``studies.rundir.run_scene``.
"""

from __future__ import annotations

import math
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np
from mpi4py import MPI

from solver import __version__
from solver.contact import zone_fractions
from solver.errors import Diverged, StepTooLarge  # noqa: F401  (re-exported for scripts)
from solver.scene import Scene


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
    """One scene's explicit run. Build with ``Simulation(scene)``, then ``proceed()``.

    It starts from steady sliding plus the scene's ``[initial]`` bump, or from
    ``initial_state`` = (u, v, a or None) on the owned dofs (serial use: a wave of
    ``studies.travel.frame.FrameOperators.shift_state``)."""

    def __init__(self, scene: Scene, comm: MPI.Comm = MPI.COMM_WORLD,
                 profile: Profile | None = None,
                 output_dir: Path | None = None,
                 initial_state: tuple[np.ndarray, np.ndarray, np.ndarray | None] | None = None,
                 ) -> None:
        from solver.observers import (
            InnerCircleRecorder,
            ProbeRecorder,
            Progress,
        )
        from solver.problem import build_problem, omega_max
        from solver.schemes import make_energy, make_integrator, time_step
        from solver.steady import solve_steady_sliding

        self.scene, self.comm = scene, comm
        self.profile = profile or Profile()
        ts = scene.time
        with self.profile.phase("mesh+assembly"):
            self.problem = build_problem(scene, comm)
        with self.profile.phase("stability"):
            self.omega_max = omega_max(self.problem)
        dt, self.dt_crit = time_step(scene, self.omega_max)
        self.dt = dt
        with self.profile.phase("steady-state"):
            self.steady = solve_steady_sliding(self.problem)
            p = self.steady.pressure
            self.steady_mean_pressure = comm.allreduce(float(p.sum())) / comm.allreduce(p.size)
        self.integrator, self.projection = make_integrator(self.problem, scene, dt)
        if initial_state is None:  # steady sliding + the scene's [initial] bump
            u0 = self.steady.u + self.perturbation()
            self.integrator.set_state(u0, np.zeros_like(u0))
        else:  # a given state, e.g. a travelled wave (studies.travel.frame.shift_state)
            u0, v0, a0 = (None if x is None else np.asarray(x, dtype=float)
                          for x in initial_state)
            shapes = [x.shape for x in (u0, v0, a0) if x is not None]
            if any(sh != (self.problem.n_owned,) for sh in shapes):
                raise ValueError(f"initial_state: u, v (and a) need {self.problem.n_owned} "
                                 f"owned dofs each, got {shapes}")
            if a0 is None:  # the implicit scheme finds a_0 from its own law
                self.integrator.set_state(u0, v0)
            else:
                self.integrator.set_state(u0, v0, a0)
        self.energy = make_energy(self.integrator, self.projection, scene.loading.f > 0.0, u0)
        every = max(1, int(round(scene.output.sample_interval / dt)))
        n_steps = self.planned_steps()
        self.recorder = InnerCircleRecorder(self.problem, self.projection, self.energy, every,
                                            max_samples=n_steps // every + 2)
        self.damping_work = None  # Kelvin-Voigt dissipation, only for damped explicit runs
        if getattr(self.integrator, "damped", False):
            from solver.observers import DampingWork

            self.damping_work = self.recorder.damping = DampingWork(self.integrator, u0)
        self.probes = ProbeRecorder(self.problem, self.projection, scene.output.probes_deg,
                                    n_steps)
        self.progress = Progress(ts.end_time, scene.output.progress and comm.rank == 0)
        self.writer = None  # field output only when the scene asks for it
        self.writer_every = 0
        if scene.output.fields and output_dir is not None:
            from solver.writers import FieldWriter

            self.writer = FieldWriter(self.problem, Path(output_dir) / "fields.xdmf")
            self.writer_every = max(1, int(round(scene.output.field_interval / dt)))
        self.initial_energy: float | None = None
        self.energy_bound = math.inf
        self.status = "running"
        self.stop_reason = ""
        #: Set (e.g. by a SIGINT/SIGTERM handler) to stop at the next sample; see _stop_now.
        self.stop_requested = False
        self._stop_code = np.zeros(1, dtype=np.int32)  # reused by _stop_now's Allreduce

    def planned_steps(self) -> int:
        n = int(math.ceil(self.scene.time.end_time / self.dt - 1e-9))
        if self.scene.time.max_steps:
            n = min(n, self.scene.time.max_steps)
        return n

    def perturbation(self) -> np.ndarray:
        """Initial radial bump (scene ``initial``), amplitude x d, shaped by X(r) (eq. [1])."""
        ini, d = self.scene.initial, self.scene.geometry.d
        if ini.perturbation == "none" or ini.amplitude == 0.0:
            return np.zeros(self.problem.n_owned)
        amp = ini.amplitude * d
        if ini.perturbation == "mode":
            k = ini.mode
            return self.problem.radial_field(lambda th: amp * 0.5 * (1.0 + np.cos(k * th)))
        rng = np.random.default_rng(ini.seed)  # same numbers on every rank: partition-free
        ks = np.arange(1, ini.n_modes + 1)
        weights = rng.uniform(0.0, 1.0, ks.size)
        phases = rng.uniform(0.0, 2 * np.pi, ks.size)
        weights /= weights.sum()

        def shape(th: np.ndarray) -> np.ndarray:
            s = np.zeros_like(th)
            for k, w, ph in zip(ks, weights, phases, strict=True):
                s += w * 0.5 * (1.0 + np.cos(k * th + ph))
            return amp * s

        return self.problem.radial_field(shape)

    def _check_health(self, kinetic: float, strain: float) -> None:
        """NaN check, and an energy bound: a blow-up, not a wave fed by the cylinder.

        The energy can only grow by the work fed in by the rotating cylinder, so the run is
        declared diverged when E > 1e4 E(0) *and* E > 10 (E(0) + W_cylinder(t)): a physical
        wave (even at Omega = 1000 rad/s) stays below the second bound, a blow-up does not.
        """
        total = kinetic + strain
        if not math.isfinite(total):
            raise Diverged(f"non-finite energy at t = {self.integrator.time:.6g} s")
        if self.initial_energy is None:
            self.initial_energy = total
            self.energy_bound = 1e4 * max(total, 1e-300)
            return
        fed = self.initial_energy + abs(self.recorder.last_work[1])
        if total > self.energy_bound and total > 10.0 * fed:
            raise Diverged(
                f"energy {total:.3g} J/m exceeds 1e4 x the initial energy and 10 x the energy "
                f"fed by the cylinder ({fed:.3g} J/m) at t = {self.integrator.time:.6g} s: the "
                "time scheme is unstable here; reduce time.dt_fraction"
            )

    def _stop_now(self, t_start: float, max_wall: float | None) -> str:
        """At a sample: "" or why to stop, agreed by every rank (one integer allreduce).

        "signal": some rank saw ``stop_requested`` (SIGINT/SIGTERM), so all ranks stop at the
        same step and save the same samples; "max_wall_time": the wall-clock limit.
        """
        code = 2 if self.stop_requested else 0
        if not code and max_wall is not None and time.perf_counter() - t_start > max_wall:
            code = 1
        if self.comm.size > 1:  # buffer Allreduce: no pickling (65 us vs 240 us measured)
            self._stop_code[0] = code
            self.comm.Allreduce(MPI.IN_PLACE, self._stop_code, op=MPI.MAX)
            code = int(self._stop_code[0])
        return ("", "max_wall_time", "signal")[code]

    def proceed(self, end_time: float | None = None, max_steps: int | None = None,
                max_wall_time: float | None = None) -> str:
        """Advance until a stop criterion: sim time, step count or wall time. Returns reason."""
        ts = self.scene.time
        end_time = ts.end_time if end_time is None else end_time
        max_steps = (ts.max_steps or None) if max_steps is None else max_steps
        max_wall = (ts.max_wall_time or None) if max_wall_time is None else max_wall_time
        integ, rec, energy, probes = self.integrator, self.recorder, self.energy, self.probes
        damping, writer, writer_every = self.damping_work, self.writer, self.writer_every
        # invariants hoisted out of the loop (the same comparisons, evaluated once)
        t_stop = end_time - 1e-12 * end_time
        step_stop = max_steps if max_steps is not None else math.inf
        after_step = energy.after_step if getattr(energy, "per_step", True) else None
        every, max_samples, root = rec.every, rec.max_samples, self.comm.rank == 0
        # one rank, fused kernel, nothing per step in Python: the steps between two samples
        # run as one compiled call that also records the probes (same numbers as step())
        per_step_python = after_step is not None or damping is not None or writer is not None
        advance = (integ.advance if getattr(integ, "can_advance", False)
                   and not per_step_python else None)
        if advance is not None:
            from solver.fused import kernel

            rec.use_compiled(kernel("record_sample"))
        t_start = time.perf_counter()
        with self.profile.phase("time-loop"):
            while True:
                if integ.time >= t_stop:
                    self.stop_reason = "end_time"
                    break
                if integ.step_count >= step_stop:
                    self.stop_reason = "max_steps"
                    break
                if advance is not None:  # compiled steps up to the next sampled level
                    s = integ.step_count
                    advance(int(min(-s % every + 1, step_stop - s)), t_stop, probes)
                else:
                    integ.step()
                    if after_step is not None:
                        after_step(integ.u)
                    if damping is not None:
                        damping.after_step(integ)
                    probes.record(integ)
                level = integ.step_count - 1  # the time level n the observers record
                if writer is not None and level % writer_every == 0:
                    with self.profile.phase("output"):
                        writer.write(integ.time, integ.u, self.projection.out.status)
                if level % every == 0 and rec.n < max_samples:  # rec.due(level), inlined
                    kin, strain = rec.sample(integ)
                    self._check_health(kin, strain)
                    if root and self.progress.due():
                        recent = zone_fractions(rec.recent_status(max(1, rec.n // 10)))
                        self.progress.update(integ.time, integ.step_count, recent)
                    stop = self._stop_now(t_start, max_wall)
                    if stop:
                        self.stop_reason = stop
                        break
        from solver.schemes import contact_seconds

        self.profile.seconds["contact (in time-loop)"] = contact_seconds(self.integrator)
        return self.stop_reason

    def final_field(self) -> dict[str, np.ndarray] | None:
        """Displacement on the whole tube at the end, gathered to rank 0 (None elsewhere).

        VTK-ready arrays for iso-value maps: ``points`` (n, 3), ``cells`` (flat VTK topology
        [nv, i0, ..., nv, ...]), ``cell_types``, ``u`` (n, 2) at the points. Each rank sends
        its local cells; ghost points are duplicated, which is harmless for plotting.
        """
        import dolfinx.plot

        fn = self.problem.to_function(self.integrator.u)
        topology, cell_types, geometry = dolfinx.plot.vtk_mesh(self.problem.V)
        values = fn.x.array.reshape(-1, 2)[: geometry.shape[0]]
        pieces = self.comm.gather((topology, cell_types, geometry, values), root=0)
        if self.comm.rank != 0:
            return None
        cells, types, points, us = [], [], [], []
        offset = 0
        for top, ct, geo, val in pieces:
            nv = int(top[0]) if top.size else 0
            blocks = top.reshape(-1, nv + 1).copy() if top.size else top.reshape(0, 1)
            blocks[:, 1:] += offset
            cells.append(blocks.ravel())
            types.append(ct)
            points.append(geo)
            us.append(val)
            offset += geo.shape[0]
        return {
            "points": np.concatenate(points),
            "cells": np.concatenate(cells),
            "cell_types": np.concatenate(types),
            "u": np.concatenate(us),
            "time": np.array(self.integrator.time),
        }

    def facts(self) -> dict:
        """What the run did (rank 0): status, steps, dt, dofs, ranks, scheme. No analysis."""
        from solver.schemes import scheme_summary

        out: dict = {
            "stickslip_version": __version__,
            "scene": self.scene.name,
            "status": self.status,
            "stop_reason": self.stop_reason,
            "steps": self.integrator.step_count,
            "sim_time_s": self.integrator.time,
            "dt_s": self.dt,
            "dt_crit_s": self.dt_crit,
            "omega_max_rad_s": self.omega_max,
            "dofs": int(self.problem.n_global_dofs),
            "contact_nodes": int(self.recorder.n_nodes),
            "ranks": self.comm.size,
            "samples": int(self.recorder.n),
            "steady_pressure_pa": self.steady_mean_pressure,
            "scheme": scheme_summary(self.integrator),
        }
        data = self.recorder.arrays()
        if data["t"].size >= 4:  # as many samples as the wave analysis needs
            e = data["energies"]
            # damping work: column 6 (the batched ensemble records 5 columns, undamped only)
            wd = e[:, 5] if e.shape[1] > 5 else np.zeros(e.shape[0])
            out["energy"] = {
                "initial_J_per_m": float(e[0, 0] + e[0, 1]),
                "final_J_per_m": float(e[-1, 0] + e[-1, 1]),
                "work_contact_J_per_m": float(e[-1, 2]),
                "work_cylinder_J_per_m": float(e[-1, 3]),
                "friction_dissipation_J_per_m": float(e[-1, 4]),
                "damping_dissipation_J_per_m": float(wd[-1]),
                "balance_residual_J_per_m": float(e[-1, 0] + e[-1, 1] - e[0, 0] - e[0, 1]
                                                  - (e[-1, 2] - e[0, 2])
                                                  + (wd[-1] - wd[0])),
            }
        return out
