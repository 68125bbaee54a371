"""B scenes that share a mesh, a material, dt and the scheme, run as one batch.

``BatchSimulation(scenes)`` builds what ``solver.run.Simulation`` builds for one scene, once for
all: the problem and dt of the first scene, then each scene's steady sliding state and start,
the batched stepper (``solver.ensemble.BatchedExplicit``, one (n, B) column per scene, each
with its own ``solver.contact.ContactLaw``), the probes as a step hook and the samples as an
observer. ``proceed`` is ``solver.run.run_loop``, the time loop of a single scene.

A scene whose energy guard trips (``solver.errors.blown_up``) is masked out of the batch and
recorded ``diverged`` at that step; the others go on. A scene whose steady state cannot be
found is ``failed`` alone. ``runs`` holds one ``SceneRun`` per scene with what a run directory
needs: ``facts()``, ``recorder.arrays()``, ``probes.arrays()``, ``final_field()``.

What the batch is built from, once the problem and the starts are known, is plain host arrays
(``BatchLayout``: K, M, dt, the samples' and probes' layout, the problem's facts; and the
(n, B) starts): ``BatchSimulation(scenes, prepared=(layout, u0))`` builds the same batch from
them without dolfinx or MPI (``solver.bundle``: a GPU node without the FE stack).
"""

from __future__ import annotations

import math
import tempfile
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from stickslip.solver.contact import ContactLaw
from stickslip.solver.ensemble import BatchedProblem
from stickslip.solver.observers import Cadence, ContinuedRecords
from stickslip.solver.run import Profile, gather_final_field, random_bump, run_facts, run_loop
from stickslip.solver.scene import Scene

__all__ = ["BatchLayout", "BatchSimulation", "BuiltProblem", "SceneRun"]

#: The modes of a kick's random bump (``BatchSimulation.kick``): a start's default.
KICK_MODES = 16


class SceneRun:
    """One scene of a batch: its problem view, steady state, status and records."""

    def __init__(self, scene: Scene, problem, batch: BatchSimulation) -> None:
        self.scene, self.comm = scene, batch.comm
        #: the dolfinx problem (None in a batch built from a ``BatchLayout``)
        self.problem = None if problem is None else replace(problem, scene=scene)
        self.dt, self.dt_crit, self.omega_max = batch.dt, batch.dt_crit, batch.omega_max
        self.dofs = batch.layout.dofs if problem is None else int(problem.n_global_dofs)
        self.ranks = 1  # a batch runs on one rank
        self.status, self.stop_reason, self.message = "running", "", ""
        self.steps, self.sim_time = 0, 0.0
        self.steady = None
        self.steady_mean_pressure = float("nan")
        self.u_final: np.ndarray | None = None
        #: what the outputs read: this scene's records (with the earlier ones in front
        #: when continued, ``solver.observers.ContinuedRecords``)
        self.recorder: MemberRecords | ContinuedRecords | None = None
        self.probes: MemberProbes | ContinuedRecords | None = None
        self.members: tuple[MemberRecords, MemberProbes] | None = None  # the live records
        #: this scene's checkpoint when it finished at a whole level (``finish``), else None
        self.state: dict[str, np.ndarray] | None = None
        self._scheme: dict = {}

    def facts(self) -> dict:
        """``Simulation.facts`` of this scene (frozen when it finished)."""
        return run_facts(self, self._scheme)

    def final_field(self) -> dict[str, np.ndarray] | None:
        """The final field (rank 0), or None where the batch has no dolfinx problem."""
        if self.problem is None:
            return None
        return gather_final_field(self.problem, self.u_final, self.comm, self.sim_time)

    def finish(self, batch: BatchSimulation, b: int, status: str, stop: str = "") -> None:
        """Freeze this scene's facts at the batch's current step (a masked scene stops here,
        as it would alone)."""
        st = batch.stepper
        self.status, self.stop_reason = status, stop
        self.steps, self.sim_time = st.step_count, st.time
        self._scheme = st.facts()
        u = st.u[:, b]
        self.u_final = np.array(u.get() if hasattr(u, "get") else u)
        records, probes = self.members
        records.n = batch.recorder.n
        probes.n = batch.recorder.n_probe
        if status == "completed" and batch.at_level:  # not a masked (diverged) scene
            self.state = batch.checkpoint(b, self)


class MemberRecords:
    """``InnerCircleRecorder`` face of scene b of a ``BatchRecorder``."""

    def __init__(self, rec, b: int, n_nodes: int) -> None:
        self.rec, self.b, self.n_nodes = rec, b, n_nodes
        self.n = 0

    def arrays(self) -> dict[str, np.ndarray]:
        return self.rec.arrays(self.b, self.n)


class MemberProbes:
    """``ProbeRecorder`` face of scene b of a ``BatchRecorder``."""

    def __init__(self, rec, b: int) -> None:
        self.rec, self.b = rec, b
        self.n = 0

    def arrays(self) -> dict[str, np.ndarray]:
        return self.rec.probe_arrays(self.b, self.n)


class ProbeHook:
    """Step hook: the batch's probes every step (``BatchRecorder.record_probes``)."""

    def __init__(self, rec) -> None:
        self.rec = rec

    def after_step(self, stepper) -> None:
        self.rec.record_probes()


class BatchSampling:
    """Observer: every scene's samples, the energy guard per scene (a blow-up masks that
    scene: ``diverged``), and the wall-time limit. Stops the loop when no scene is left."""

    def __init__(self, batch: BatchSimulation) -> None:
        self.batch = batch
        self.cadence = Cadence(batch.recorder.every)

    def due(self, level: int) -> bool:
        return self.batch.recorder.due(level)

    def observe(self, stepper) -> str:
        batch = self.batch
        self.diverge(batch.recorder.observe(stepper.time), stepper)
        if not stepper.active.any():
            return "diverged"
        wall = batch.max_wall
        if wall is not None and time.perf_counter() - batch.t_start > wall:
            return "max_wall_time"
        return ""

    def diverge(self, found: dict[int, str], stepper) -> None:
        """Scenes {b: message} that the energy guard found: diverged, masked. After the
        loop, ``diverge(recorder.close(), stepper)`` takes those a GPU's guard found in the
        last chunks of samples."""
        batch = self.batch
        for b, msg in found.items():
            run = batch.runs[batch.live[b]]
            run.finish(batch, b, "diverged")
            run.message = msg
            stepper.mask(b)


@dataclass
class BatchLayout:
    """What a batch is built from besides its scenes and starts, as host arrays (npz-able):
    K, M and dt (``BatchedProblem``), the contact circle's order for the samples (``perm``,
    ``theta``, ``ds``, ``n_nodes``: ``InnerCircleRecorder``), the probes (``probe_nodes``,
    ``probe_pc``, ``probe_deg``: ``ProbeRecorder``) and the problem's facts (``dofs``,
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
        from stickslip.solver.contact import ContactProjection
        from stickslip.solver.observers import InnerCircleRecorder, ProbeRecorder

        projection = ContactProjection(problem, law)
        shape = InnerCircleRecorder(problem, projection, None, 1, max_samples=0)
        probes = ProbeRecorder(problem, projection, scene.output.probes_deg, 0)
        return cls(BatchedProblem.from_problem(problem, law.dt, law.beta2),
                   perm=np.asarray(shape.perm), theta=np.asarray(shape.theta),
                   ds=np.asarray(shape.ds), n_nodes=int(shape.n_nodes),
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
    """What ``BatchSimulation`` builds before its scenes' starts, the same for every batch of
    scenes that share a mesh, material, dt and scheme (one batch key): the dolfinx problem
    (one rank), its largest eigenfrequency ω_max, dt and the explicit limit dt_crit, and the
    ``BatchLayout``. ``BatchSimulation.built`` hands it out; a later batch of such scenes
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


class BatchSimulation:
    """``Simulation`` for B scenes on one rank (see the module docstring).

    The batch's sample record stays whole in host memory when it needs at most
    ``memory_budget`` bytes on the CPU; otherwise it is spooled in chunks to ``spool_dir``, a
    new folder under ``spool_parent`` that the caller removes once the files are written.

    ``prepared``: the batch's ``BatchLayout`` and ``BatchStarts`` (every scene live) instead
    of building the problem and the steady states here: no dolfinx, no MPI. ``build=False``:
    only the problem, dt, ``layout`` and ``starts`` (what ``prepared`` takes), no stepper.

    ``built``: the ``BuiltProblem`` of an earlier batch of the same batch key, taken instead
    of building the mesh, K, M, ω_max and the layout again (``built`` holds this batch's).
    ``resumed``: the batch is continued from checkpoints (``restore`` follows): no steady
    sliding solve and no start, which ``restore`` overwrites (u, u_prev, v~, the contact
    state and the steady pressure come from the checkpoint; v and a start at rest either
    way)."""

    def __init__(self, scenes: list[Scene], backend: str = "cpu",
                 spool_parent: Path | None = None, profile: Profile | None = None,
                 memory_budget: float = math.inf,
                 prepared: tuple[BatchLayout, BatchStarts] | None = None,
                 build: bool = True, built: BuiltProblem | None = None,
                 resumed: bool = False) -> None:
        from stickslip.solver.schemes.select import for_scene

        self.scenes, self.backend = scenes, backend
        self.profile = profile or Profile()
        self.scheme = for_scene(scenes[0])  # the scheme registry, asked once
        self.failures: dict[int, BaseException] = {}
        self.built: BuiltProblem | None = None
        if prepared is None:
            self.layout, starts = self._prepare(built, resumed)
        else:
            self.comm, self.problem = None, None
            self.layout, starts = prepared
            self.dt = self.layout.problem.dt
            self.dt_crit, self.omega_max = self.layout.dt_crit, self.layout.omega_max
            self.runs = [SceneRun(sc, None, self) for sc in scenes]
            self.live = list(range(len(scenes)))
            for run, p in zip(self.runs, starts.steady_pressure, strict=True):
                run.steady_mean_pressure = float(p)
        self.stepper = self.recorder = None
        self.spool_dir: Path | None = None
        self.observers: list = []
        self.t_start, self.max_wall = time.perf_counter(), None
        self.at_level = False  # ``proceed`` returned: every scene stands at a whole level
        self._host_state: dict | None = None  # the stepper's arrays on the host, while finishing
        self.starts = None if build else starts
        if self.live and build:
            self._build(starts.u0, spool_parent, memory_budget)

    def _prepare(self, built: BuiltProblem | None = None, resumed: bool = False
                 ) -> tuple[BatchLayout | None, BatchStarts]:
        """The problem (dolfinx, one rank; ``built``'s if given), dt and every scene's start:
        the layout and the live scenes' starts (a scene whose steady state fails is
        ``failed`` alone; ``resumed``: no start, zeros that ``restore`` overwrites)."""
        from mpi4py import MPI

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
        self.layout = None
        self.runs = [SceneRun(sc, self.problem, self) for sc in scenes]
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
        from stickslip.solver.run import initial_perturbation
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
            run.status = "failed"
            return None
        self.live.append(k)
        return u0

    def planned_steps(self) -> int:
        from stickslip.solver.run import planned_steps

        return planned_steps(self.scenes[self.live[0]], self.dt)

    def _build(self, u0: np.ndarray, spool_parent: Path | None, memory_budget: float) -> None:
        """The batched stepper, the recorder, the probe hook and the sampling observer."""
        from stickslip.solver.ensemble_observers import BatchRecorder

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
            run.members = (MemberRecords(rec, b, lay.n_nodes), MemberProbes(rec, b))
            run.recorder, run.probes = run.members
        self.stepper, self.recorder = stepper, rec
        self.observers = [BatchSampling(self)]

    # ------------------------------------------------------------------ checkpoint

    def checkpoint(self, b: int, run: SceneRun) -> dict[str, np.ndarray]:
        """Column b's checkpoint, flat as ``Simulation.checkpoint``'s: the stepper's column
        (``BatchedExplicit.state``), the energy guard's E(0) and bound of that scene, its
        steady pressure and its counts of samples and probe steps (those before a
        continuation included)."""
        if self._host_state is None:  # one copy of the batch for all its columns
            self._host_state = self.stepper.host_state()
        out = {f"stepper/{k}": v for k, v in self.stepper.state(b, self._host_state).items()}
        out.update({"run/initial_energy": np.float64(self.recorder.initial[b]),
                    "run/energy_bound": np.float64(self.recorder.bound[b]),
                    "run/steady_pressure": np.float64(run.steady_mean_pressure),
                    "run/samples": np.int64(run.recorder.n),
                    "run/probe_steps": np.int64(run.probes.n)})
        return out

    def restore(self, states: list[dict[str, np.ndarray]],
                befores: list[dict[str, np.ndarray]]) -> None:
        """Continue every scene from its checkpoint (``checkpoint``, in the order of
        ``scenes``; every one must be live and at the same step) with its earlier records
        ``befores`` (samples.npz) in front of the new ones. Call before ``proceed``."""
        if self.live != list(range(len(self.scenes))):
            raise ValueError("a continued batch needs every scene live (a steady state failed)")
        head = "stepper/"
        self.stepper.restore([{k[len(head):]: v for k, v in s.items() if k.startswith(head)}
                              for s in states])
        for b, (run, state, before) in enumerate(zip(self.runs, states, befores, strict=True)):
            self.recorder.initial[b] = float(state["run/initial_energy"])
            self.recorder.bound[b] = float(state["run/energy_bound"])
            run.steady_mean_pressure = float(state["run/steady_pressure"])
            run.recorder = ContinuedRecords(run.members[0], before, state["run/samples"])
            run.probes = ContinuedRecords(run.members[1], before, state["run/probe_steps"])

    def kick(self, b: int, fraction: float, seed: int) -> dict:
        """Perturb scene ``b`` where it stands (after ``restore``), as a start is perturbed:
        δu = ε ‖u‖ φ₁/‖φ₁‖ and δv = ε ‖v~‖ φ₂/‖φ₂‖, ε = ``fraction``, ‖·‖ the RMS over the
        dofs, φ_i the random start's radial bump A(θ) X(r) e_r (``solver.run.random_bump``
        with its default 16 modes, seeds ``seed`` and ``seed + 1``; clamped outside, smooth,
        the contact circle's shape spread through the thickness by eq. [1]). Returns the
        kick's facts (RMS sizes of u, v~, δu, δv)."""
        u, v = (np.array(a.get() if hasattr(a, "get") else a)  # copies, before the kick
                for a in (self.stepper.u[:, b], self.stepper.v_pred[:, b]))

        def rms(x: np.ndarray) -> float:
            return float(np.sqrt(np.mean(x**2)))

        kicks = []
        for x, s in ((u, seed), (v, seed + 1)):
            shape = self.problem.radial_field(random_bump(s, KICK_MODES, 1.0))
            kicks.append(fraction * rms(x) / rms(shape) * shape)
        self.stepper.kick(b, kicks[0], kicks[1])
        return {"fraction": fraction, "seed": seed, "u_rms_m": rms(u), "v_rms_m_s": rms(v),
                "du_rms_m": rms(kicks[0]), "dv_rms_m_s": rms(kicks[1])}

    def proceed(self) -> str:
        """Run every live scene to the end (``solver.run.run_loop``); returns the reason."""
        sc0 = self.scenes[self.live[0]]
        ts = sc0.time
        end = ts.end_time
        self.max_wall = ts.max_wall_time or None
        self.t_start = time.perf_counter()
        stop = "end_time"
        self.at_level = False
        try:
            with self.profile.phase("time-loop"):
                stop = run_loop(self.stepper, self.observers, end - 1e-12 * end,
                                ts.max_steps or math.inf)
            self.at_level = True  # not interrupted inside a step: the scenes can continue
        finally:
            self.observers[0].diverge(self.recorder.close(), self.stepper)
            self._host_state = None
            for b, k in enumerate(self.live):
                if self.stepper.active[b]:
                    self.runs[k].finish(self, b, "completed",
                                        "" if stop == "diverged" else stop)
            self._host_state = None
        return stop
