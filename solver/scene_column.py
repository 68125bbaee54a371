"""One scene as the columns of a run (B = 1): its dofs distributed over the ranks of ``comm``.

``SceneColumn`` builds, in order: the problem (mesh, K, M, contact nodes: ``solver.problem``),
the steady sliding state (``solver.steady``), the scheme's parts (``Scheme.build``: the step,
refused above the scheme's limit, the stepper and its contact step), and the records as the
scheme's kernel takes them (``SchemeParts.scene_records``: the samples with the energy guard,
the probes and the work observers; a batch of one's ``BatchRecorder`` for the numba kernel).
``solver.run.Simulation`` drives it with
the observers every run has; this module is what differs from a batch's columns
(``solver.ensemble_run.BatchColumns``): any scheme, MPI-distributed dofs, field output, and the
energy guard's sums over the ranks.
"""

from __future__ import annotations

import hashlib
import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from stickslip.solver.columns import (
    Profile,
    SceneRun,
    initial_perturbation,
    kick_fields,
    planned_steps,
    restore_run_state,
    run_state,
)
from stickslip.solver.contact import zone_fractions
from stickslip.solver.field_output import FieldOutput, gather_final_field, last_level_fields
from stickslip.solver.observers import Progress
from stickslip.solver.problem import build_problem, omega_max
from stickslip.solver.scene import Scene
from stickslip.solver.schemes.select import for_scene
from stickslip.solver.steady import solve_steady_sliding
from stickslip.solver.surface_samples import SurfaceSamples

if TYPE_CHECKING:  # mpi4py is imported where a run uses it
    from mpi4py import MPI

__all__ = ["SceneColumn"]


class SceneColumn:
    """The column of one scene on the ranks of ``comm`` (module docstring).

    It starts from steady sliding plus the scene's ``[initial]`` bump, or from
    ``initial_state`` = (u, v, a or None) on the owned dofs (serial use: a wave of
    ``studies.travel.frame.FrameOperators.shift_state``)."""

    def __init__(self, scene: Scene, comm: MPI.Comm | None, profile: Profile,
                 initial_state: tuple | None = None) -> None:
        if comm is None:
            from mpi4py import MPI

            comm = MPI.COMM_WORLD
        self.scene, self.comm, self.profile = scene, comm, profile
        with profile.phase("mesh+assembly"):
            self.problem = build_problem(scene, comm)
        with profile.phase("stability"):
            self.omega_max = omega_max(self.problem)
        with profile.phase("steady-state"):
            self.steady = solve_steady_sliding(self.problem)
            p = self.steady.pressure
            steady_pressure = comm.allreduce(float(p.sum())) / comm.allreduce(p.size)
        # the scheme registry, asked once: the step (refused above the scheme's limit), the
        # stepper, the contact step and how its kernel records; after the steady solve, as
        # the implicit scheme's factorisation always was (the parallel solves in the same order)
        parts = for_scene(scene).build(self.problem, scene, self.omega_max)
        self.dt, self.dt_crit = parts.dt, parts.dt_crit
        self.stepper, self.projection = parts.stepper, parts.contact
        self.integrator = self.stepper
        u0 = self._start(initial_state)
        every = max(1, int(round(scene.output.sample_interval / self.dt)))
        self.records = parts.scene_records(self.problem, every, self.planned_steps(), u0)
        self.sampler = self.records.sampler
        run = SceneRun(scene, self, self.problem, int(self.problem.n_global_dofs), comm.size)
        run.steady, run.steady_mean_pressure = self.steady, steady_pressure
        run.recorder, run.probes = self.records.samples, self.records.probes
        self.runs, self.live, self.failures = [run], [0], {}
        self.active = np.ones(1, dtype=bool)
        self.progress = Progress(scene.time.end_time, scene.output.progress and comm.rank == 0)
        self._stop_code = np.zeros(1, dtype=np.int32)  # reused by ``agree``'s Allreduce
        self.surface: SurfaceSamples | None = None  # a 3D tube's (``observers``)

    @property
    def every(self) -> int:
        """The samples' cadence in steps."""
        return self.sampler.every

    def _start(self, initial_state) -> np.ndarray:
        """Set the stepper's initial state; returns u_0."""
        if initial_state is None:  # steady sliding + the scene's [initial] bump
            u0 = self.steady.u + initial_perturbation(self.problem, self.scene)
            self.stepper.set_state(u0, np.zeros_like(u0))
            return u0
        u0, v0, a0 = (None if x is None else np.asarray(x, dtype=float) for x in initial_state)
        shapes = [x.shape for x in (u0, v0, a0) if x is not None]
        if any(sh != (self.problem.n_owned,) for sh in shapes):
            raise ValueError(f"initial_state: u, v (and a) need {self.problem.n_owned} "
                             f"owned dofs each, got {shapes}")
        if a0 is None:  # the implicit scheme finds a_0 from its own law
            self.stepper.set_state(u0, v0)
        else:
            self.stepper.set_state(u0, v0, a0)
        return u0

    def observers(self, output_dir: Path | None) -> list:
        """The observers of this column before the samples: the contact surface of a 3D
        tube (``solver.surface_samples``) and field output, when the scene asks for it."""
        self.writer, found = None, []
        if self.problem.surface is not None:
            self.surface = SurfaceSamples(self.problem, self.projection, self.due, self.every,
                                          self.planned_steps() // self.every + 2)
            found.append(self.surface)
        if self.scene.output.fields and output_dir is not None:
            field_output = FieldOutput(self, Path(output_dir))
            self.writer = field_output.writer
            found.append(field_output)
        return found

    def surface_before(self, before: dict[str, np.ndarray] | None) -> None:
        """A continued 3D run's surface records up to its checkpoint (rank 0; None
        elsewhere and in plane strain), put in front of the new ones."""
        if self.surface is not None:
            self.surface.before = before

    def surface_arrays(self) -> dict[str, np.ndarray] | None:
        """A 3D tube's contact surface at the samples (``SurfaceSamples.arrays``), gathered
        to rank 0 (collective); None elsewhere and in plane strain."""
        return None if self.surface is None else self.surface.arrays()

    def planned_steps(self) -> int:
        return planned_steps(self.scene, self.dt)

    # ------------------------------------------------------------------ the time loop

    def due(self, level: int) -> bool:
        return self.sampler.due(level)

    def sample(self, stepper) -> dict[int, str]:
        """Record time level n and run the energy guard on it (``solver.errors.EnergyGuard``:
        diverged when E > 1e4 E(0) *and* E > 10 (E(0) + W_cylinder(t)), or not finite):
        {0: message} on a blow-up, the same on every rank (the energies are sums over the
        ranks)."""
        return self.sampler.observe(stepper)

    def mask(self, b: int) -> None:
        """Column b steps no further (the loop ends: it is the only one)."""
        self.active[b] = False

    def recent_zones(self) -> dict[str, float] | None:
        """The contact zones' fractions over the recent tenth of the samples."""
        rec = self.records.samples
        return zone_fractions(rec.recent_status(max(1, rec.n // 10)))

    def agree(self, code: int) -> int:
        """The largest ``code`` over the ranks (one integer allreduce, no pickling)."""
        if self.comm.size == 1:
            return code
        from mpi4py import MPI

        self._stop_code[0] = code
        self.comm.Allreduce(MPI.IN_PLACE, self._stop_code, op=MPI.MAX)
        return int(self._stop_code[0])

    def close(self) -> dict[int, str]:
        """After the loop: the record closed; nothing is left to check (every sample was)."""
        return self.sampler.close()

    def finish(self, b: int, run: SceneRun, at_level: bool) -> None:
        """Column b ended: its checkpoint when it completed at a whole level."""
        if run.status == "completed" and at_level:
            run.state = self.checkpoint(b, run)

    def release(self) -> None:
        """Nothing is held for the finish."""

    # ------------------------------------------------------------------ checkpoint

    def _state_parts(self) -> dict:
        """The objects whose state a continued run needs, by name: the stepper, the contact
        step, and the records' work observers (``SceneRecords.parts``)."""
        return {"stepper": self.stepper, "contact": self.projection, **self.records.parts}

    def checkpoint(self, b: int = 0, run: SceneRun | None = None) -> dict[str, np.ndarray]:
        """This rank's checkpoint of the column, flat ``{"part/name": array}``: each part's
        ``state()`` (``_state_parts``: the last level's vectors, the contact statuses, the work
        sums), this rank's part of the mesh (``run/partition``) and the ``run/`` part every
        column has (``solver.columns.run_state``)."""
        out = {f"{part}/{key}": value for part, obj in self._state_parts().items()
               for key, value in obj.state().items()}
        out["run/partition"] = np.array(self.partition_id())
        out.update(run_state(self.sampler.guard, 0, self.runs[b]))
        return out

    def restore(self, states: list[dict[str, np.ndarray]],
                befores: list[dict[str, np.ndarray] | None]) -> None:
        """Continue from ``checkpoint()`` of the same scene on the same ranks (one state:
        this rank's). ``befores``: the records taken up to the checkpoint (samples.npz, on
        rank 0; None elsewhere), which the run's records then put in front of the new ones
        (``solver.observers.ContinuedRecords``)."""
        (state,), (before,) = states, befores
        mine = str(state["run/partition"]) == self.partition_id()
        if not all(self.comm.allgather(mine)):
            raise ValueError("the mesh partition differs from the checkpoint's (a partitioner "
                             "that is not reproducible: is SCOTCH_PTHREAD_NUMBER set above "
                             "1?); continue with the partition the run had")
        for part, obj in self._state_parts().items():
            head = f"{part}/"
            obj.restore({k[len(head):]: v for k, v in state.items() if k.startswith(head)})
        restore_run_state(self.sampler.guard, 0, self.runs[0], state, before,
                          self.records.samples, self.records.probes)

    def kick(self, b: int, fraction: float, seed: int) -> dict:
        """Perturb the scene where it stands (after ``restore``), as a batch member is
        (``solver.columns.kick_fields``, the RMS over every rank's dofs); the work observers'
        copies of u move with it (``kicked``). Returns the kick's facts."""
        comm = self.comm

        def rms(x: np.ndarray) -> float:
            return math.sqrt(comm.allreduce(float(np.dot(x, x))) / comm.allreduce(x.size))

        state = self.stepper.state()
        du, dv, facts = kick_fields(self.problem, state["u"], state["v_pred"], fraction,
                                    seed, rms)
        self.perturb(b, du, dv)
        return facts

    def perturb(self, b: int, du: np.ndarray, dv: np.ndarray) -> None:
        """Move the scene by (du, dv) where it stands (``Stepper.kick``: u_{n+1} and u_n by
        ``du``, v~ by ``dv``); the work observers' copies of u move with it (``kicked``)."""
        self.stepper.kick(b, du, dv)
        for part in self.records.parts.values():
            part.kicked(du)

    def partition_id(self) -> str:
        """This rank's part of the mesh, as a hash of its owned nodes' coordinates (sorted):
        the same on every build of the same partition, whatever the local numbering."""
        bs = self.problem.V.dofmap.index_map_bs
        x = self.problem.V.tabulate_dof_coordinates()[: self.problem.n_owned // bs, :bs]
        ordered = np.ascontiguousarray(x[np.lexsort(x.T)])
        return hashlib.sha256(ordered.tobytes()).hexdigest()

    def final_field(self, run: SceneRun) -> dict[str, np.ndarray] | None:
        """Displacement on the whole tube at the end, with the stress and contact tractions
        of the last completed level n at ``fields_time`` t_n
        (``solver.field_output.last_level_fields``), gathered to rank 0 (None elsewhere)."""
        stepper = self.stepper
        field = gather_final_field(self.problem, stepper.u, self.comm, stepper.time,
                                   *last_level_fields(self))
        if field is not None:
            field["fields_time"] = np.array(stepper.time - stepper.dt)  # level n
        return field
