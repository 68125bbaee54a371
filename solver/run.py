"""The run: B ≥ 1 scenes advanced by one time loop, watched by one set of observers.

``Simulation(scene)`` runs one scene, its dofs distributed over the ranks of ``comm``
(``solver.scene_column.SceneColumn``: any scheme, field output); ``Simulation.batch(scenes)``
runs B scenes that share a mesh, material, dt and scheme as one (n, B) explicit batch on one
rank (``solver.ensemble_run.BatchColumns``). Either way the run is the same object: its
columns, one ``solver.columns.SceneRun`` per scene (status, records, facts, checkpoint), the
observers (the columns' own, then the samples with the energy guard, the progress line, the
stop check), and ``proceed()``, which advances the time loop until a stop criterion
(simulated time, steps, wall time, a signal), as Dedalus' ``solver.proceed``. A column whose
energy guard trips is masked and recorded ``diverged``; the others go on, and the loop ends
"diverged" when none is left. The run directory (files, signals, ``summary.json`` with the
wave analysis) is ``studies.rundir.run_scene``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

import numpy as np

from stickslip.solver.columns import Profile, SceneRun
from stickslip.solver.ensemble_run import BatchColumns, BatchOptions
from stickslip.solver.errors import StepTooLarge
from stickslip.solver.observers import Cadence, Observer
from stickslip.solver.scene import Scene
from stickslip.solver.stepper import Stepper

if TYPE_CHECKING:  # mpi4py is imported where a run uses it: ``run_loop`` runs without it
    from mpi4py import MPI

    from stickslip.solver.ensemble_run import BatchOptions

#: ``Profile`` and ``StepTooLarge`` are re-exported: a script's run needs no other import
__all__ = ["Columns", "Profile", "Simulation", "StepTooLarge", "run_loop"]


class Columns(Protocol):
    """What a run asks of its columns (``SceneColumn``, ``BatchColumns``)."""

    comm: MPI.Comm | None
    problem: object
    stepper: Stepper | None
    dt: float
    dt_crit: float
    omega_max: float
    runs: list[SceneRun]
    live: list[int]  # the runs in the stepper, in column order
    failures: dict[int, BaseException]
    active: np.ndarray  # (len(live),) bool: the columns still stepped
    every: int  # the samples' cadence in steps
    progress: object  # ``solver.observers.Progress``

    def observers(self, output_dir: Path | None) -> list[Observer]: ...
    def planned_steps(self) -> int: ...
    def due(self, level: int) -> bool: ...
    def sample(self, stepper: Stepper) -> dict[int, str]: ...
    def mask(self, b: int) -> None: ...
    def recent_zones(self) -> dict[str, float] | None: ...
    def agree(self, code: int) -> int: ...
    def close(self) -> dict[int, str]: ...
    def finish(self, b: int, run: SceneRun, at_level: bool) -> None: ...
    def release(self) -> None: ...
    def restore(self, states: list[dict], befores: list[dict | None]) -> None: ...
    def final_field(self, run: SceneRun) -> dict[str, np.ndarray] | None: ...
    def checkpoint(self, b: int, run: SceneRun) -> dict[str, np.ndarray]: ...


class Simulation:
    """A run of B ≥ 1 scenes (module docstring). Build with ``Simulation(scene, comm)`` (one
    scene on the ranks of ``comm``; ``initial_state`` = (u, v, a or None) on the owned dofs
    instead of steady sliding and the bump) or ``Simulation.batch(scenes, ...)``, then
    ``proceed()``; each scene's outcome is in ``runs``. One scene (B = 1) also reads as
    ``sim.recorder``, ``sim.status``, ``sim.facts()``, ``sim.checkpoint()``...

    The columns ask the scheme registry (``for_scene``) once and build the scheme's parts."""

    def __init__(self, scenes: Scene | Sequence[Scene], comm: MPI.Comm | None = None,
                 profile: Profile | None = None, output_dir: Path | None = None,
                 initial_state: tuple[np.ndarray, np.ndarray, np.ndarray | None] | None = None,
                 *, batch: BatchOptions | None = None) -> None:
        self.scenes = [scenes] if isinstance(scenes, Scene) else list(scenes)
        self.scene = self.scenes[0]
        self.profile = profile or Profile()
        if batch is None:
            # dolfinx: one scene meshes; a batch on a node without dolfinx never does
            from stickslip.solver.scene_column import SceneColumn

            if len(self.scenes) != 1:
                raise ValueError(f"{len(self.scenes)} scenes on the ranks of one run: give "
                                 "one, or run them as Simulation.batch")
            columns: Columns = SceneColumn(self.scene, comm, self.profile, initial_state)
        else:
            columns = BatchColumns(self.scenes, self.profile, batch)
        self.columns = columns
        self.comm, self.problem = columns.comm, columns.problem
        self.dt, self.dt_crit, self.omega_max = columns.dt, columns.dt_crit, columns.omega_max
        self.runs, self.live, self.failures = columns.runs, columns.live, columns.failures
        self.stepper = self.integrator = columns.stepper
        self.observers: list[Observer] = []
        if self.stepper is not None:
            self.observers = [*columns.observers(output_dir), Sampling(self),
                              ProgressLine(self), StopCheck(self)]
        #: Set (e.g. by a SIGINT/SIGTERM handler) to stop at the next sample; see _stop_now.
        self.stop_requested = False
        self.at_level = False  # ``proceed`` returned: every column stands at a whole level
        self.stop_reason = ""
        self._t_start, self._max_wall = time.perf_counter(), None

    @classmethod
    def batch(cls, scenes: Sequence[Scene], profile: Profile | None = None,
              **options) -> Simulation:
        """B scenes as one explicit (n, B) batch on one rank; ``options`` are
        ``solver.ensemble_run.BatchOptions``'s (backend, spool_parent, memory_budget,
        prepared, build, built, resumed)."""
        return cls(scenes, profile=profile, batch=BatchOptions(**options))

    def planned_steps(self) -> int:
        return self.columns.planned_steps()

    # ------------------------------------------------------------------ the time loop

    def proceed(self, end_time: float | None = None, max_steps: int | None = None,
                max_wall_time: float | None = None) -> str:
        """Advance until a stop criterion: sim time, step count, wall time, an observer's
        word (a signal), or no column left ("diverged"). Returns the reason. The one time
        loop (``run_loop``); afterwards every column still stepped is ``completed`` (its
        checkpoint taken when the loop ended at a whole level)."""
        ts = self.scenes[self.live[0]].time
        end_time = ts.end_time if end_time is None else end_time
        max_steps = (ts.max_steps or None) if max_steps is None else max_steps
        self._max_wall = (ts.max_wall_time or None) if max_wall_time is None else max_wall_time
        t_stop = end_time - 1e-12 * end_time
        step_stop = max_steps if max_steps is not None else math.inf
        columns, stop = self.columns, ""
        self.at_level = False
        self._t_start = time.perf_counter()
        columns.progress.begin(self.stepper.time)
        try:
            with self.profile.phase("time-loop"):
                stop = run_loop(self.stepper, self.observers, t_stop, step_stop)
            self.at_level = True  # not interrupted inside a step: the scenes can continue
        finally:
            self.diverge(columns.close())
            for b, k in enumerate(self.live):
                if columns.active[b]:
                    self.finish(k, b, "completed", "" if stop == "diverged" else stop)
            columns.release()
        self.stop_reason = stop
        self.profile.seconds["contact (in time-loop)"] = float(
            self.stepper.facts()["contact_s"])
        return stop

    def diverge(self, found: dict[int, str]) -> None:
        """Columns {b: message} that the energy guard found: ``diverged``, masked."""
        for b, message in found.items():
            self.finish(self.live[b], b, "diverged")
            self.runs[self.live[b]].message = message
            self.columns.mask(b)

    def finish(self, k: int, b: int, status: str, stop: str = "") -> None:
        """Run k (column b) ends here: its facts frozen, its columns' part of it kept."""
        run = self.runs[k]
        run.finish(status, stop)
        self.columns.finish(b, run, self.at_level)

    def _stop_now(self) -> str:
        """At a sample: "" or why to stop, agreed by every rank (``Columns.agree``).

        "signal": some rank saw ``stop_requested`` (SIGINT/SIGTERM), so all ranks stop at the
        same step and save the same samples; "max_wall_time": the wall-clock limit.
        """
        code = 2 if self.stop_requested else 0
        max_wall = self._max_wall
        if not code and max_wall is not None and time.perf_counter() - self._t_start > max_wall:
            code = 1
        return ("", "max_wall_time", "signal")[self.columns.agree(code)]

    # ------------------------------------------------------------------ checkpoint

    def checkpoint(self, k: int = 0) -> dict[str, np.ndarray]:
        """Run k's checkpoint (this rank's part) where it stands: flat ``{"part/name":
        array}`` (``Columns.checkpoint``). ``runs[k].state`` keeps the one taken when it
        completed at a whole level."""
        return self.columns.checkpoint(self.live.index(k), self.runs[k])

    @property
    def resumable(self) -> bool:
        """True once run 0 completed at a whole level (every observer has seen what it was
        due to see), so its checkpoint can be continued."""
        return self.runs[0].state is not None

    def restore(self, states: list[dict[str, np.ndarray]],
                befores: list[dict[str, np.ndarray] | None]) -> None:
        """Continue every run from its checkpoint (in the order of ``runs``; for one scene
        on several ranks, this rank's) with its earlier records ``befores`` (samples.npz, on
        rank 0; None elsewhere) in front of the new ones. Call before ``proceed``."""
        self.columns.restore(states, befores)

    # ------------------------------------------------------------------ one scene (B = 1)

    @property
    def recorder(self):
        """Run 0's samples (``MemberRecords``, or its records when continued)."""
        return self.runs[0].recorder

    @property
    def probes(self):
        """Run 0's probe histories."""
        return self.runs[0].probes

    @property
    def status(self) -> str:
        return self.runs[0].status

    @status.setter
    def status(self, value: str) -> None:
        self.runs[0].status = value

    @property
    def message(self) -> str:
        return self.runs[0].message

    @property
    def steps(self) -> int:
        return self.runs[0].steps

    def facts(self) -> dict:
        """What run 0 did (rank 0): status, steps, dt, dofs, ranks, scheme. No analysis."""
        return self.runs[0].facts()

    def final_field(self) -> dict[str, np.ndarray] | None:
        """Run 0's final field, gathered to rank 0 (``Columns.final_field``)."""
        return self.runs[0].final_field()


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
        for obs in observers:  # the first observer with a reason ends the loop
            if obs.due(level) and (stop := obs.observe(stepper)):
                return stop


class Sampling:
    """Observer: every column's samples and energies at ``output.sample_interval``, and the
    energy guard on them (a blow-up masks that column: ``Simulation.diverge``). Stops the
    loop ("diverged") when no column is left."""

    def __init__(self, sim: Simulation) -> None:
        self.sim, self.columns = sim, sim.columns
        self.cadence = Cadence(sim.columns.every)

    def due(self, level: int) -> bool:
        return self.columns.due(level)

    def observe(self, stepper) -> str:
        self.sim.diverge(self.columns.sample(stepper))
        return "" if self.columns.active.any() else "diverged"


class ProgressLine:
    """Observer: one progress line on rank 0 at a sampled level once ``Progress.interval``
    seconds of wall time have passed (the zone fractions of the recent samples)."""

    def __init__(self, sim: Simulation) -> None:
        self.columns, self.progress = sim.columns, sim.columns.progress
        self.cadence = Cadence(sim.columns.every)

    def due(self, level: int) -> bool:
        return self.cadence.at(level) and self.progress.due()

    def observe(self, stepper) -> str:
        self.progress.update(stepper.time, stepper.step_count, self.columns.recent_zones())
        return ""


class StopCheck:
    """Observer: at each sampled level, whether to stop (a signal, the wall-time limit),
    agreed by every rank (``Simulation._stop_now``)."""

    def __init__(self, sim: Simulation) -> None:
        self.sim, self.columns = sim, sim.columns
        self.cadence = Cadence(sim.columns.every)

    def due(self, level: int) -> bool:
        return self.columns.due(level)

    def observe(self, stepper) -> str:
        return self.sim._stop_now()
