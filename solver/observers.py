"""Observers of the time loop: the work of the contact forces and of the damping, progress,
and what the records of a run are built from (the contact circle over the ranks, the probes'
choice, a one-scene stepper seen as a batch of one); the records themselves are
``solver.ensemble_observers.BatchRecorder``'s, for every scheme and every B.

Two kinds, as Dedalus' file handlers:

* observers with a ``Cadence`` (``every`` time levels, from a sim-time interval): the time
  loop (``solver.run.Simulation.proceed``) advances the stepper to the next level at which one
  is due and calls ``observe(stepper)`` on each that is (the ``Observer`` protocol);
* step hooks, which need every step (the probes, the work of the contact forces and of the
  damping): attached to the stepper (``solver.stepper.StepHook``).
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from stickslip.solver.fused import numba_available, sample_kernels


@dataclass(frozen=True)
class Cadence:
    """An observer's pace: every ``every`` time levels (level 0, every, 2 every, ...)."""

    every: int

    @classmethod
    def from_interval(cls, interval: float, dt: float) -> Cadence:
        """The cadence of a sim-time interval at step dt (at least every level)."""
        return cls(max(1, int(round(interval / dt))))

    def at(self, level: int) -> bool:
        return level % self.every == 0

    def next_level(self, level: int) -> int:
        """The first level >= ``level`` on this cadence."""
        return level + (-level % self.every)


@runtime_checkable
class Observer(Protocol):
    """What the time loop asks of an observer with a cadence."""

    cadence: Cadence

    def due(self, level: int) -> bool:
        """True when time level ``level`` (just completed by the stepper) is to be observed."""

    def observe(self, stepper) -> str:
        """Observe time level n = ``stepper.step_count - 1``; return "" or why to stop."""

ENERGY_FIELDS = (
    "kinetic",
    "strain",
    "work_contact",
    "work_cylinder",
    "friction_dissipation",
    "damping_dissipation",
)


class CentredWork:
    """The three work sums of the contact forces, taken with the centred increment
    Delta u_n = (u_{n+1} - u_{n-1}) / 2 (``EnergyAccumulator``: the contact circle;
    ``SurfaceWork``: a 3D tube's contact surface). It keeps u_{n-1}, u_n at the contact nodes
    (``prev``, ``now``: the checkpoint's ``KEYS``), taken by the subclass's ``at_nodes``,
    and writes, restores, kicks and sums them alike."""

    #: The checkpoint's names of ``prev`` and ``now``.
    KEYS: tuple[str, str] = ("prev", "now")

    def __init__(self, projection, with_friction: bool, u0: np.ndarray) -> None:
        self.p, self.with_friction = projection, with_friction
        self.now = self.at_nodes(u0)  # u_n (u_0 before the first step)
        self.prev = self.now.copy()  # u_{n-1}
        self.next = np.zeros_like(self.now)  # u_{n+1}
        self.delta = np.zeros_like(self.now)  # u_{n+1} - u_{n-1}
        self.work_contact = self.work_cylinder = self.friction_dissipation = 0.0

    def at_nodes(self, array: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """``array`` (owned dofs) at the contact nodes, into ``out`` where given."""
        raise NotImplementedError

    def state(self) -> dict[str, np.ndarray]:
        """The checkpoint: u_n, u_{n+1} at the nodes and the three sums (after a step)."""
        return {self.KEYS[0]: self.prev.copy(), self.KEYS[1]: self.now.copy(),
                "sums": np.array([self.work_contact, self.work_cylinder,
                                  self.friction_dissipation])}

    def restore(self, state: dict[str, np.ndarray]) -> None:
        """Continue from ``state()``."""
        self.prev[:] = state[self.KEYS[0]]
        self.now[:] = state[self.KEYS[1]]
        self.work_contact, self.work_cylinder, self.friction_dissipation = (
            float(x) for x in state["sums"])

    def kicked(self, du: np.ndarray) -> None:
        """A kick moved u_n and u_{n+1} by ``du`` (``BatchedExplicit.kick``): so do their copies at
        the contact nodes, and the next increment is motion, not the kick."""
        moved = self.at_nodes(du)
        self.prev += moved
        self.now += moved

    def roll(self) -> None:
        """After a step: (n-1, n, n+1) <- (n, n+1, reuse)."""
        self.prev, self.now, self.next = self.now, self.next, self.prev

    def local_sums(self) -> np.ndarray:
        """(work_contact, work_cylinder, friction_dissipation) on this rank's contact nodes
        (the records add them over the ranks)."""
        return np.array([self.work_contact, self.work_cylinder, self.friction_dissipation])


class EnergyAccumulator(CentredWork):
    """Work of the contact forces, accumulated every step over the owned contact nodes.

    The force r_n acts at t_n; its work uses the centred displacement increment
    Delta u_n = (u_{n+1} - u_{n-1}) / 2 (with the forward increment, the systematic error
    r_n . dt^2 M^{-1} r_n / 2 > 0 of every stiff constraint force would pile up):
      work_contact         = sum r_n . Delta u_n           (work done on the tube)
      work_cylinder        = sum r_theta,n R Omega dt       (work fed by the rotating cylinder)
      friction_dissipation = work_cylinder - sum r_theta,n Delta u_theta,n
    The balance E(t) - E(0) - work_contact closes to O(dt^2) for beta_2 = 1/2 and is the
    (negative) numerical dissipation for beta_2 > 1/2. Nodal values are complex
    z = u_x + i u_y (see ``ContactProjection``), so r . Delta u = Re(conj(r_xy) Delta z).
    """

    KEYS = ("z_prev", "z_now")

    def __init__(self, projection, with_friction: bool, u0: np.ndarray,
                 exact_work: bool = False) -> None:
        super().__init__(projection, with_friction, u0)
        # the implicit scheme's contact solve keeps exact work sums (``work_totals``)
        self._exact_work = exact_work

    def at_nodes(self, array: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """z = u_x + i u_y at the contact nodes (a plain view: ``array`` may be a one-off
        array, which the projection's cached views must not hold)."""
        return array.view(np.complex128).take(self.p.node_index, out=out, mode="clip")

    def after_step(self, stepper) -> None:
        """Accumulate the work of r_n with the centred increment (u_{n+1} - u_{n-1}) / 2."""
        p = self.p
        p.complex_view(stepper.u).take(p.node_index, out=self.next, mode="clip")
        np.subtract(self.next, self.prev, out=self.delta)
        self.work_contact += 0.5 * np.vdot(p.r_xy, self.delta).real
        if self.with_friction:
            self.delta *= p.phase_conj  # polar increment: Delta u_r + i Delta u_theta
            wt = 0.5 * float(np.dot(p.out.r_t, self.delta.imag))
            wc = float(p.out.r_t.sum()) * p.slide
            self.work_cylinder += wc
            self.friction_dissipation += wc - wt
        self.roll()

    def local_sums(self) -> np.ndarray:
        """``CentredWork.local_sums``; a projection that keeps its own exact work
        bookkeeping (the implicit scheme's ``work_exposed``, whose energy identity is exact)
        supplies the first two."""
        sums = super().local_sums()
        if self._exact_work:
            sums[:2] = self.p.work_exposed
        return sums


class SurfaceWork(CentredWork):
    """``EnergyAccumulator`` on the finite tube's contact surface
    (``solver.contact.surface.SurfaceContactProjection``): the same sums with the forces in
    (x, y, z), and the friction's axial power besides its circumferential one,

      friction_dissipation = work_cylinder - sum (r_theta,n Delta u_theta,n + r_z,n Delta u_z,n),

    with the centred increment Delta u_n = (u_{n+1} - u_{n-1}) / 2."""

    KEYS = ("u_prev", "u_now")

    def __init__(self, projection, with_friction: bool, u0: np.ndarray) -> None:
        super().__init__(projection, with_friction, u0)
        self.du_polar = np.zeros((2, self.now.shape[0]))  # Delta u_r, Delta u_theta

    def at_nodes(self, array: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """(x, y, z) at the surface's nodes, (m, 3)."""
        return array.take(self.p.dofs, out=out, mode="clip")

    def after_step(self, stepper) -> None:
        """Accumulate the work of r_n with the centred increment (u_{n+1} - u_{n-1}) / 2."""
        p, du = self.p, self.delta
        self.at_nodes(stepper.u, self.next)
        np.subtract(self.next, self.prev, out=du)
        self.work_contact += 0.5 * float(np.vdot(p.force, du))
        if self.with_friction:
            p.rotate(du, self.du_polar[0], self.du_polar[1])
            out = p.surface_out
            wt = 0.5 * (float(np.dot(out.r_t, self.du_polar[1]))
                        + float(np.dot(p.r_z, du[:, 2])))
            wc = float(out.r_t.sum()) * p.slide
            self.work_cylinder += wc
            self.friction_dissipation += wc - wt
        self.roll()


class DampingWork:
    """Work dissipated by the Kelvin-Voigt damping of the numpy explicit step (scene
    ``[damping]``, ``solver.scene_explicit.SceneExplicit``).

    The damping force tau K v~_n acts at t_n; its work with the centred increment
    Delta u_n = (u_{n+1} - u_{n-1}) / 2 (as the contact work) is W_d = sum tau K v~_n . Delta u_n.
    The step only forms K w_n, w_n = u_n + tau v~_n, so W_d = sum K w_n . Delta u_n
    - sum K u_n . Delta u_n, and the second sum telescopes exactly (K symmetric, u_{-1} := u_0):

        sum_{m<=n} K u_m . (u_{m+1} - u_{m-1}) / 2 = (u_{n+1} . K u_n - u_0 . K u_0) / 2.

    So each step costs two local dot products and one copy (no MatMult); the K u_n of the
    closing term is the one the observers compute at a sample anyway. Then
    E_n - E_0 = W_contact - W_d + O(dt^2) (beta_2 = 1/2). Created only for damped scenes.
    """

    def __init__(self, integrator, u0: np.ndarray) -> None:
        self.u_older = u0.copy()  # u_{n-1}
        ku0 = np.zeros_like(u0)
        integrator.stiffness_product(u0, ku0)
        self.u0_ku0 = float(np.dot(u0, ku0))
        self.sum_kw = 0.0

    def state(self) -> dict[str, np.ndarray]:
        """The checkpoint: u_{n-1}, u_0 . K u_0 and the step sum."""
        return {"u_older": self.u_older.copy(),
                "sums": np.array([self.u0_ku0, self.sum_kw])}

    def restore(self, state: dict[str, np.ndarray]) -> None:
        """Continue from ``state()``."""
        self.u_older[:] = state["u_older"]
        self.u0_ku0, self.sum_kw = (float(x) for x in state["sums"])

    def kicked(self, du: np.ndarray) -> None:
        """A kick moved u_n (this part's u_{n-1} at the next step) by ``du``."""
        self.u_older += du

    def after_step(self, integrator) -> None:
        """Accumulate K w_n . (u_{n+1} - u_{n-1}) / 2 (integrator.u = u_{n+1}, u_prev = u_n)."""
        kw = integrator.kw
        self.sum_kw += 0.5 * (float(np.dot(kw, integrator.u)) - float(np.dot(kw, self.u_older)))
        self.u_older[:] = integrator.u_prev

    def local_total(self, integrator) -> float:
        """W_d up to level n on this rank's dofs; needs ``integrator.ku`` = K u_n (refreshed)."""
        return self.sum_kw - 0.5 * (float(np.dot(integrator.u, integrator.ku)) - self.u0_ku0)

    def at_sample(self, integrator) -> float:
        """W_d up to level n on this rank's dofs, K u_n refreshed first."""
        integrator.refresh_ku()  # the damped step forms K (u + tau v~), not K u
        return self.local_total(integrator)


class ContactCircle:
    """The contact nodes of a problem over the ranks of its communicator: how many each rank
    owns (``counts``, ``displs``: its block of the gathered array), and on rank 0 the gathered
    position -> angle order ``perm`` (by global node index) with each node's angle ``theta``
    and arc weight ``ds`` in that order. ``gatherv`` gathers a per-node array to rank 0."""

    def __init__(self, problem) -> None:
        from mpi4py import MPI

        self.comm = problem.comm
        nd = problem.nodes
        self.n_local = nd.dofs_x.size
        self.counts = np.array(self.comm.allgather(self.n_local))
        self.displs = np.concatenate([[0], np.cumsum(self.counts)[:-1]])
        self.n_nodes = int(self.counts.sum())
        self.is_root = self.comm.rank == 0
        root = self.is_root
        order = np.zeros(self.n_nodes, dtype=np.int64) if root else None
        theta_all = np.zeros(self.n_nodes) if root else None
        ds_all = np.zeros(self.n_nodes) if root else None
        self.gatherv(np.asarray(nd.global_node_index, dtype=np.int64), order, MPI.INT64_T)
        self.gatherv(nd.theta, theta_all, MPI.DOUBLE)
        self.gatherv(nd.ds_weight, ds_all, MPI.DOUBLE)
        self.perm = self.theta = self.ds = None
        if root:
            self.perm = np.argsort(order)  # gathered position -> angle order
            self.theta = theta_all[self.perm]
            self.ds = ds_all[self.perm]

    def gatherv(self, local: np.ndarray, recv: np.ndarray | None, mpitype) -> None:
        """Gather the owned contact-node values ``local`` into ``recv`` on rank 0."""
        self.comm.Gatherv(np.ascontiguousarray(local),
                          (recv, self.counts, self.displs, mpitype) if self.is_root else None,
                          root=0)


class Progress:
    """One line every ``interval`` seconds of wall time on rank 0: time, ETA, contact status.

    The ETA is the time loop's own rate over the span it covers, from :meth:`begin` (the
    simulated time the loop starts at: 0, or a continued run's checkpoint) to ``end_time``."""

    def __init__(self, end_time: float, enabled: bool, interval: float = 5.0,
                 stream=sys.stdout) -> None:
        self.end_time, self.enabled, self.interval = end_time, enabled, interval
        self.stream = stream
        self.t0 = time.perf_counter()
        self.last = self.t0
        self.t_begin = 0.0  # the simulated time the loop starts at (``begin``)

    def begin(self, sim_time: float) -> None:
        """The time loop starts now, at ``sim_time``: the wall clock and the span of the ETA
        count from here (not from the set-up, nor from t = 0 for a continued run)."""
        self.t0 = self.last = time.perf_counter()
        self.t_begin = sim_time

    def due(self) -> bool:
        """True when a progress line should be printed now (cheap: one clock read)."""
        return self.enabled and time.perf_counter() - self.last >= self.interval

    def update(self, sim_time: float, step: int, fractions: dict[str, float] | None) -> None:
        """Print one progress line (call when ``due()``)."""
        now = time.perf_counter()
        self.last = now
        elapsed = now - self.t0
        frac = min(1.0, sim_time / self.end_time) if self.end_time > 0 else 0.0
        span = self.end_time - self.t_begin
        done = min(1.0, (sim_time - self.t_begin) / span) if span > 0 else 0.0
        eta = elapsed * (1.0 - done) / done if done > 0 else math.nan
        zones = ""
        if fractions:
            zones = "  sep {separation:.0%} stick {stick:.0%} slip {slip:.0%}".format(**fractions)
        print(
            f"  t = {sim_time:.4g} s ({frac:5.1%})  step {step}  wall {elapsed:.1f} s"
            f"  ETA {eta:.0f} s{zones}",
            file=self.stream,
            flush=True,
        )


@dataclass(frozen=True)
class ProbeChoice:
    """The probes this rank records: each probe is the contact node nearest to its angle
    (``output.probes_deg``; ties broken by the global node order, so the choice does not
    depend on the partition), recorded every step by the rank that owns it. ``slots``: their
    places among the scene's ``n_probes``; ``index``: their nodes (the owned blocked array's
    node index, x dof = 2 index); ``angles`` [deg] and ``phase_conj`` e^{-iθ} of each."""

    slots: list[int]
    index: np.ndarray
    angles: list[float]
    phase_conj: np.ndarray
    n_probes: int

    @classmethod
    def of(cls, problem, projection, probes_deg) -> ProbeChoice:
        """The choice on ``problem``'s ranks (collective)."""
        from mpi4py import MPI

        comm, nd = problem.comm, problem.nodes
        slots, index, angles = [], [], []
        for slot, deg in enumerate(probes_deg):
            target = np.radians(deg) % (2 * np.pi)
            if nd.theta.size:
                dist = np.abs((nd.theta - target + np.pi) % (2 * np.pi) - np.pi)
                j = int(np.lexsort((nd.global_node_index, dist))[0])
                mine = (float(dist[j]), int(nd.global_node_index[j]))
            else:
                j, mine = -1, (np.inf, -1)
            best = comm.allreduce(mine, op=MPI.MIN)
            if mine == best and j >= 0:
                slots.append(slot)
                index.append(j)
                angles.append(float(np.degrees(nd.theta[j])))
        return cls(slots, np.asarray(projection.node_index[index], dtype=np.intp), angles,
                   projection.phase_conj[index].copy(), len(probes_deg))


def gather_probes(comm, slots: list[int], angles: list[float], data: np.ndarray,
                  t: np.ndarray, n_probes: int) -> dict[str, np.ndarray] | None:
    """The probes' histories on rank 0 (None elsewhere): each rank's ``data`` (its probes'
    (probe, step, [u_r, u_theta, v_r, v_theta])) put in its ``slots`` of the ``n_probes``,
    with their angles and the times ``t`` (collective)."""
    gathered = comm.gather((slots, angles, data, t), root=0)
    if comm.rank != 0:
        return None
    n = max(len(g[3]) for g in gathered)
    t = next((g[3] for g in gathered if g[0]), t[:n])
    out = np.zeros((n_probes, n, 4))
    deg = np.zeros(n_probes)
    for slots_r, angles_r, arr, _ in gathered:
        for k, slot in enumerate(slots_r):
            out[slot] = arr[k]
            deg[slot] = angles_r[k]
    return {"probe_t": t, "probe_deg": deg, "probe_data": out}


#: The axis along which each recorded array grows with time (samples.npz's keys); the keys
#: not listed (theta, ds, probe_deg) are the same at every time.
TIME_AXIS = {"t": 0, "u_r": 0, "u_theta": 0, "v_r": 0, "v_theta": 0, "status": 0,
             "energies": 0, "r_r": 0, "r_theta": 0, "probe_t": 0, "probe_data": 1}


class ContinuedRecords:
    """The records of a continued run: the ``n_before`` taken before its checkpoint
    (``before``, read back from the run's samples.npz on rank 0; None elsewhere) followed by
    those of the live records ``live`` (``solver.ensemble_observers.MemberRecords`` or
    ``MemberProbes``).

    ``arrays()`` joins the two along ``TIME_AXIS``; ``n`` is the count of both. Each
    recorded row is computed row by row (``BatchRecorder.sample``, the probes' rotation), so
    the joined arrays are bitwise those of one run straight through.
    Everything else is the live recorder's."""

    def __init__(self, live, before: dict[str, np.ndarray] | None, n_before: int) -> None:
        self.live, self.before, self.n_before = live, before, int(n_before)

    @property
    def n(self) -> int:
        return self.n_before + self.live.n

    def __getattr__(self, name: str):
        return getattr(self.live, name)

    def arrays(self) -> dict[str, np.ndarray] | None:
        """The live recorder's ``arrays()`` with the earlier records in front (None where
        the live one gives None: the ranks other than 0)."""
        now = self.live.arrays()
        if now is None or self.before is None:
            return now
        out = dict(now)
        for key, axis in TIME_AXIS.items():
            if key in now and key in self.before:
                out[key] = np.concatenate([self.before[key], now[key]], axis=axis)
        return out


def blas_energies(v: np.ndarray, mass: np.ndarray, u: np.ndarray, ku: np.ndarray,
                  scratch: np.ndarray) -> tuple[float, float]:
    """(v · M v, u · K u): twice the kinetic and the strain energy over this rank's owned
    dofs, BLAS dots (``scratch`` takes M v: no allocation)."""
    np.multiply(v, mass, out=scratch)
    return float(np.dot(scratch, v)), float(np.dot(u, ku))


class SteppedColumn:
    """A one-scene stepper whose work observers are step hooks (the numpy explicit step,
    ``ImplicitNewmark``) and its contact step, seen as a batch of one by the records
    (``solver.ensemble_observers.BatchRecorder``): the observed level's u_n, v_n, K u_n and
    the contact outputs as (rows, 1) views, the work sums of the scene's work observers
    (``EnergyAccumulator.local_sums``; the damping work W_d of ``damping``'s ``at_sample``,
    which refreshes K u_n first: ``refresh_ku``), and the sampled energies as BLAS dots over
    the owned dofs, 2 E_kin = v · M v and 2 E_strain = u · K u (``sum_energies``)."""

    xp = np
    B = 1
    host_records = True  # numpy arrays: the record is kept whole, in memory
    energy_summed = False
    one_pass_samples = False  # its energies are BLAS dots, not ``sample_one``'s sums

    def __init__(self, stepper, contact, mass: np.ndarray, work: EnergyAccumulator,
                 damping=None) -> None:
        self.stepper, self.contact, self.mass, self.work = stepper, contact, mass, work
        self.damping, self.damped = damping, damping is not None
        self.n, self.m = stepper.u.size, contact.node_index.size
        self.cx = np.asarray(contact.nodes.dofs_x, dtype=np.int64)  # bs x the node
        self.phase_conj = contact.phase_conj
        self.active = np.ones(1, dtype=bool)
        self.columns = self  # the records' copies (``record_copies``)
        self.energy = np.zeros((2, 1))
        self.kin_scratch = np.zeros(self.n)
        self.damping_work = 0.0
        self.full_state_at = None  # every level is stepped in full

    def record_copies(self):  # noqa: ANN201 - the copies module or None
        """The records' compiled copies where numba imports (pure copies: the same values as
        array indexing, in a tenth of the calls), else None."""
        return sample_kernels() if numba_available() else None

    def keep_nodes(self, nodes: np.ndarray) -> None:
        """Every node's v_n, a_n, K u_n is kept at every step."""

    time = property(lambda self: self.stepper.time)
    dt = property(lambda self: self.stepper.dt)
    u_prev = property(lambda self: self.stepper.u_prev[:, None])
    v = property(lambda self: self.stepper.v[:, None])
    ku = property(lambda self: self.stepper.ku[:, None])
    r_r = property(lambda self: self.contact.out.r_r[:, None])
    r_t = property(lambda self: self.contact.out.r_t[:, None])
    status = property(lambda self: self.contact.out.status[:, None])

    def refresh_ku(self) -> None:
        """W_d up to level n (``damping.at_sample``: K u_n refreshed where the step formed
        K w_n)."""
        self.damping_work = self.damping.at_sample(self.stepper)

    def sum_energies(self) -> bool:
        """energy = v · M v and u · K u of level n (``blas_energies``)."""
        st = self.stepper
        self.energy[:, 0] = blas_energies(st.v, self.mass, st.u_prev, st.ku, self.kin_scratch)
        return True

    def work_sums(self) -> np.ndarray:
        """(3, 1): work_contact, work_cylinder, friction_dissipation on this rank."""
        return self.work.local_sums()[:, None]

    def damping_work_totals(self) -> np.ndarray:
        """(1,): W_d on this rank's dofs, taken by ``refresh_ku``."""
        return np.array([self.damping_work])
