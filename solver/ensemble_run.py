"""B scenes that share a mesh, a material, dt and the scheme, as the columns of one run.

``BatchColumns`` builds what ``solver.scene_column.SceneColumn`` builds for one scene, once for
all: the problem and dt of the first scene, then each scene's steady sliding state and start,
the batched stepper (``solver.ensemble.BatchedExplicit``, one (n, B) column per scene, each
with its own ``solver.contact.ContactLaw``), the probes as a step hook and the samples
(``solver.ensemble_observers.BatchRecorder``). ``solver.run.Simulation.batch`` drives it with
the observers every run has, in the one time loop.

A scene whose energy guard trips (``solver.errors.blown_up``) is masked out of the batch and
recorded ``diverged`` at that step; the others go on. A scene whose steady state cannot be
found is ``failed`` alone. ``runs`` holds one ``solver.columns.SceneRun`` per scene.

What the batch is built from, once the problem and the starts are known, is plain host arrays
(``BatchLayout``: K, M, dt, the samples' and probes' layout, the problem's facts; and the
(n, B) starts): ``BatchOptions(prepared=(layout, starts))`` builds the same batch from them
without dolfinx or MPI (``solver.bundle``: a GPU node without the FE stack).
"""

from __future__ import annotations

import math
import tempfile
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TextIO

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
from stickslip.solver.contact import ContactLaw, ContactProjection
from stickslip.solver.ensemble import BatchedProblem
from stickslip.solver.ensemble_observers import (
    BatchRecorder,
    MemberProbes,
    MemberRecords,
    ProbeHook,
)
from stickslip.solver.field_output import gather_final_field
from stickslip.solver.observers import (
    ContactCircle,
    ProbeChoice,
    Progress,
)
from stickslip.solver.scene import Scene
from stickslip.solver.schemes.select import for_scene
from stickslip.solver.stepper import BatchStepper

__all__ = ["BatchColumns", "BatchLayout", "BatchOptions", "BatchStarts", "BuiltProblem"]


@dataclass
class BatchLayout:
    """What a batch is built from besides its scenes and starts, as host arrays (npz-able):
    K, M and dt (``BatchedProblem``), the contact circle's order for the samples (``perm``,
    ``theta``, ``ds``, ``n_nodes``: ``ContactCircle``), the probes (``probe_nodes``,
    ``probe_pc``, ``probe_deg``: ``ProbeChoice``) and the problem's facts (``dofs``,
    ``dt_crit``, ``omega_max``)."""

    problem: BatchedProblem
    perm: np.ndarray
    theta: np.ndarray
    ds: np.ndarray
    n_nodes: int
    probe_nodes: np.ndarray
    probe_pc: np.ndarray
    probe_deg: np.ndarray
    dofs: int
    dt_crit: float
    omega_max: float

    ARRAYS = ("perm", "theta", "ds", "probe_nodes", "probe_pc", "probe_deg")
    FACTS = ("n_nodes", "dofs", "dt_crit", "omega_max")

    @classmethod
    def of(cls, problem, law: ContactLaw, scene: Scene, dt_crit: float,
           omega_max: float) -> BatchLayout:
        """The layout of a dolfinx ``TubeProblem`` (one rank) at the law's dt."""
        projection = ContactProjection(problem, law)
        circle = ContactCircle(problem)
        probes = ProbeChoice.of(problem, projection, scene.output.probes_deg)
        return cls(BatchedProblem.from_problem(problem, law.dt, law.beta2),
                   perm=np.asarray(circle.perm), theta=np.asarray(circle.theta),
                   ds=np.asarray(circle.ds), n_nodes=int(circle.n_nodes),
                   probe_nodes=np.asarray(probes.index), probe_pc=np.asarray(probes.phase_conj),
                   probe_deg=np.asarray(probes.angles), dofs=int(problem.n_global_dofs),
                   dt_crit=float(dt_crit), omega_max=float(omega_max))

    def arrays(self) -> dict[str, np.ndarray]:
        """Every field as an array, for ``numpy.savez`` (``from_arrays`` reads them back)."""
        out = {f"problem/{k}": np.asarray(getattr(self.problem, k))
               for k in BatchedProblem.FIELDS}
        out.update({k: getattr(self, k) for k in self.ARRAYS})
        out.update({k: np.asarray(getattr(self, k)) for k in self.FACTS})
        return out

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray]) -> BatchLayout:
        head = "problem/"
        problem = BatchedProblem(**{k[len(head):]: v for k, v in arrays.items()
                                    if k.startswith(head)})
        return cls(problem, **{k: arrays[k] for k in cls.ARRAYS},
                   n_nodes=int(arrays["n_nodes"]), dofs=int(arrays["dofs"]),
                   dt_crit=float(arrays["dt_crit"]), omega_max=float(arrays["omega_max"]))


@dataclass
class BuiltProblem:
    """What ``BatchColumns`` builds before its scenes' starts, the same for every batch of
    scenes that share a mesh, material, dt and scheme (one batch key): the dolfinx problem
    (one rank), its largest eigenfrequency ω_max, dt and the explicit limit dt_crit, and the
    ``BatchLayout``. ``BatchColumns.built`` hands it out; a later batch of such scenes
    (the next leg of a continuation) takes it instead of building it again."""

    problem: object
    omega_max: float
    dt: float
    dt_crit: float
    layout: BatchLayout


@dataclass
class BatchStarts:
    """The starts of a batch's live scenes: u_0 (n, B) (steady sliding + the bump) and each
    scene's mean steady contact pressure (B,)."""

    u0: np.ndarray
    steady_pressure: np.ndarray


@dataclass
class BatchOptions:
    """How a batch is held (``solver.run.Simulation.batch``).

    ``backend``: "cpu" or "gpu" (``solver.schemes.select``). The batch's sample record stays
    whole in host memory when it needs at most ``memory_budget`` bytes on the CPU; otherwise it
    is spooled in chunks to ``spool_dir``, a new folder under ``spool_parent`` that the caller
    removes once the files are written.

    ``prepared``: the batch's ``BatchLayout`` and ``BatchStarts`` (every scene live) instead
    of building the problem and the steady states here: no dolfinx, no MPI. ``build=False``:
    only the problem, dt, ``layout`` and ``starts`` (what ``prepared`` takes), no stepper.

    ``built``: the ``BuiltProblem`` of an earlier batch of the same batch key, taken instead
    of building the mesh, K, M, ω_max and the layout again (``BatchColumns.built`` holds this
    batch's). ``resumed``: the batch is continued from checkpoints (``restore`` follows): no
    steady sliding solve and no start, which ``restore`` overwrites (u, u_prev, v~, the contact
    state and the steady pressure come from the checkpoint; v and a start at rest either
    way). ``progress``: where the batch's progress lines go (``solver.observers.Progress``;
    a sweep's member logs, whose scenes have ``output.progress`` off for the console); None:
    nowhere (a batch's scenes finish together, so its caller hears of none until then)."""

    backend: str = "cpu"
    spool_parent: Path | None = None
    memory_budget: float = math.inf
    prepared: tuple[BatchLayout, BatchStarts] | None = None
    build: bool = True
    built: BuiltProblem | None = None
    resumed: bool = False
    progress: TextIO | None = None


class BatchColumns:
    """The columns of B scenes on one rank (see the module docstring)."""

    def __init__(self, scenes: list[Scene], profile: Profile, options: BatchOptions) -> None:
        self.scenes, self.profile = scenes, profile
        self.scheme = for_scene(scenes[0])  # the scheme registry, asked once
        self.backend = options.backend
        self.failures: dict[int, BaseException] = {}
        self.built: BuiltProblem | None = None
        if options.prepared is None:
            self.layout, starts = self._prepare(options.built, options.resumed)
        else:
            self.comm, self.problem = None, None
            self.layout, starts = options.prepared
            self.dt = self.layout.problem.dt
            self.dt_crit, self.omega_max = self.layout.dt_crit, self.layout.omega_max
            self.runs = [SceneRun(sc, self, None, self.layout.dofs, 1, k)
                         for k, sc in enumerate(scenes)]
            self.live = list(range(len(scenes)))
            for run, p in zip(self.runs, starts.steady_pressure, strict=True):
                run.steady_mean_pressure = float(p)
        self.stepper: BatchStepper | None = None
        self.recorder = None
        self.spool_dir: Path | None = None
        self.active = np.zeros(0, dtype=bool)
        self.progress = Progress(scenes[0].time.end_time, options.progress is not None,
                                 stream=options.progress)
        self.members: dict[int, tuple[MemberRecords, MemberProbes]] = {}  # the live records
        self.finals: dict[int, np.ndarray] = {}  # each finished scene's u
        self._host_state: dict | None = None  # the stepper's arrays on the host, while finishing
        self.starts = None if options.build else starts
        if self.live and options.build:
            self._build(starts.u0, options.spool_parent, options.memory_budget)

    def _prepare(self, built: BuiltProblem | None = None, resumed: bool = False
                 ) -> tuple[BatchLayout | None, BatchStarts]:
        """The problem (dolfinx, one rank; ``built``'s if given), dt and every scene's start:
        the layout and the live scenes' starts (a scene whose steady state fails is
        ``failed`` alone; ``resumed``: no start, zeros that ``restore`` overwrites)."""
        from mpi4py import MPI

        # dolfinx: a node without it runs batches from a bundle (solver.bundle)
        from stickslip.solver.problem import build_problem, omega_max

        scenes = self.scenes
        self.comm = MPI.COMM_SELF
        if built is None:
            with self.profile.phase("mesh+assembly"):
                self.problem = build_problem(scenes[0], self.comm)
            with self.profile.phase("stability"):
                self.omega_max = omega_max(self.problem)
            self.dt, self.dt_crit = self.scheme.time_step(scenes[0], self.omega_max)
        else:
            self.problem, self.omega_max = built.problem, built.omega_max
            self.dt, self.dt_crit = built.dt, built.dt_crit
        dofs = int(self.problem.n_global_dofs)
        self.runs = [SceneRun(sc, self, replace(self.problem, scene=sc), dofs, 1, k)
                     for k, sc in enumerate(scenes)]
        self.live: list[int] = []  # runs in the batch, in column order
        if resumed:
            self.live = list(range(len(scenes)))
            u0s = [np.zeros(self.problem.inv_mass.size) for _ in scenes]
        else:
            u0s = [self._start(k) for k in range(len(scenes))]
        if not self.live:
            return None, BatchStarts(np.zeros((0, 0)), np.zeros(0))
        k0 = self.live[0]
        if built is None:
            layout = BatchLayout.of(self.problem, ContactLaw.from_scene(scenes[k0], self.dt),
                                    scenes[k0], self.dt_crit, self.omega_max)
            built = BuiltProblem(self.problem, self.omega_max, self.dt, self.dt_crit, layout)
        self.built = built
        return built.layout, BatchStarts(np.stack([u0s[k] for k in self.live], axis=1),
                                         np.array([self.runs[k].steady_mean_pressure
                                                   for k in self.live]))

    def _start(self, k: int) -> np.ndarray | None:
        """Scene k's steady state + its [initial] bump, or None (the scene fails alone)."""
        # dolfinx: a node without it runs batches from a bundle (solver.bundle)
        from stickslip.solver.steady import solve_steady_sliding

        run = self.runs[k]
        try:
            with self.profile.phase("steady-state"):
                run.steady = solve_steady_sliding(run.problem)
            p = run.steady.pressure
            run.steady_mean_pressure = float(p.sum()) / p.size
            u0 = run.steady.u + initial_perturbation(run.problem, run.scene)
        except Exception as err:  # this scene fails alone
            self.failures[k] = err
            run.fail()
            return None
        self.live.append(k)
        return u0

    def planned_steps(self) -> int:
        return planned_steps(self.scenes[self.live[0]], self.dt)

    def _build(self, u0: np.ndarray, spool_parent: Path | None, memory_budget: float) -> None:
        """The batched stepper, the recorder and the probe hook."""
        sc0, lay = self.scenes[self.live[0]], self.layout
        laws = [ContactLaw.from_scene(self.scenes[k], self.dt) for k in self.live]
        stepper = self.scheme.build_batch(lay.problem, laws, self.backend, sc0.damping.tau)
        stepper.set_state(u0, np.zeros_like(u0))
        every = max(1, int(round(sc0.output.sample_interval / self.dt)))
        n_steps = self.planned_steps()
        record = BatchRecorder.record_bytes(len(self.live), stepper.m, len(lay.probe_nodes),
                                            n_steps // every + 2, n_steps)
        if not stepper.host_records or record > memory_budget:
            self.spool_dir = Path(tempfile.mkdtemp(prefix=".batch-", dir=spool_parent))
        rec = BatchRecorder(
            stepper, mass=lay.problem.mass, perm=lay.perm, theta=lay.theta, ds=lay.ds,
            every=every, max_samples=n_steps // every + 2, max_steps=n_steps,
            probe_nodes=lay.probe_nodes, probe_pc=lay.probe_pc, probe_deg=lay.probe_deg,
            spool_dir=self.spool_dir)
        stepper.keep_nodes(lay.probe_nodes)
        stepper.full_state_at = rec.due
        stepper.attach(ProbeHook(rec))
        for b, k in enumerate(self.live):
            run = self.runs[k]
            self.members[k] = (MemberRecords(rec, b, lay.n_nodes), MemberProbes(rec, b))
            run.recorder, run.probes = self.members[k]
        self.stepper, self.recorder = stepper, rec
        self.active = stepper.active

    def observers(self, output_dir: Path | None) -> list:
        """No observers before the samples: a batch writes no fields while it runs."""
        return []

    # ------------------------------------------------------------------ the time loop

    @property
    def every(self) -> int:
        """The samples' cadence in steps."""
        return self.recorder.every

    def due(self, level: int) -> bool:
        return self.recorder.due(level)

    def sample(self, stepper) -> dict[int, str]:
        """Record time level n and run the energy guard: {b: message} of the blow-ups found
        (CPU: in this sample; GPU: in the chunks that reached the host since the last)."""
        return self.recorder.observe(stepper)

    def mask(self, b: int) -> None:
        """Column b steps no further; the others go on."""
        self.stepper.mask(b)

    def recent_zones(self) -> dict[str, float] | None:
        """None: a batch's progress line (``BatchOptions.progress``) has no zones of its
        own (each column has its own)."""
        return None

    def agree(self, code: int) -> int:
        """One rank: its own word."""
        return code

    def close(self) -> dict[int, str]:
        """Write out the record; the blow-ups a GPU's guard found in its last chunks."""
        self._host_state = None
        return self.recorder.close()

    def finish(self, b: int, run: SceneRun, at_level: bool) -> None:
        """Column b ended: its u, its records' counts, and its checkpoint when it completed
        at a whole level (not a masked, diverged scene)."""
        records, probes = self.members[run.index]
        records.n = self.recorder.n  # this scene's count stops here
        probes.n = self.recorder.n_probe
        if run.status == "completed" and at_level:
            run.state = self.checkpoint(b, run)  # from the one host copy of the batch
        self.finals[run.index] = self.stepper.host_column("u", b) if run.state is None \
            else run.state["stepper/u"]

    def release(self) -> None:
        """Drop the host copy of the batch's state that the finish used."""
        self._host_state = None

    def final_field(self, run: SceneRun) -> dict[str, np.ndarray] | None:
        """The final field (rank 0), or None where the batch has no dolfinx problem."""
        if run.problem is None:
            return None

        return gather_final_field(run.problem, self.finals[run.index], self.comm,
                                  run.sim_time)

    # ------------------------------------------------------------------ checkpoint

    def checkpoint(self, b: int, run: SceneRun) -> dict[str, np.ndarray]:
        """Column b's checkpoint, flat as ``SceneColumn.checkpoint``'s: the stepper's column
        (``BatchedExplicit.state``) and the ``run/`` part (``solver.columns.run_state``)."""
        if self._host_state is None:  # one copy of the batch for all its columns
            self._host_state = self.stepper.host_state()
        out = {f"stepper/{k}": v for k, v in self.stepper.state(b, self._host_state).items()}
        out.update(run_state(self.recorder.guard, b, run))
        return out

    def restore(self, states: list[dict[str, np.ndarray]],
                befores: list[dict[str, np.ndarray]]) -> None:
        """Continue every scene from its checkpoint (``checkpoint``, in the order of
        ``scenes``; every one must be live and at the same step) with its earlier records
        ``befores`` (samples.npz) in front of the new ones."""
        if self.live != list(range(len(self.scenes))):
            raise ValueError("a continued batch needs every scene live (a steady state failed)")
        head = "stepper/"
        self.stepper.restore([{k[len(head):]: v for k, v in s.items() if k.startswith(head)}
                              for s in states])
        for b, (run, state, before) in enumerate(zip(self.runs, states, befores, strict=True)):
            restore_run_state(self.recorder.guard, b, run, state, before, *self.members[b])

    def kick(self, b: int, fraction: float, seed: int) -> dict:
        """Perturb scene ``b`` where it stands (after ``restore``): ``kick_fields`` with the
        RMS over its dofs. Returns the kick's facts (RMS sizes of u, v~, δu, δv)."""
        u, v = (self.stepper.host_column(name, b) for name in ("u", "v_pred"))  # before it

        def rms(x: np.ndarray) -> float:
            return float(np.sqrt(np.mean(x**2)))

        du, dv, facts = kick_fields(self.problem, u, v, fraction, seed, rms)
        self.stepper.kick(b, du, dv)
        return facts
