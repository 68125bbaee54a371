"""Observers of the time loop: sampled diagnostics on the inner circle, energies, progress.

Two kinds, as Dedalus' file handlers:

* observers with a ``Cadence`` (``every`` time levels, from a sim-time interval): the time
  loop (``solver.run.Simulation.proceed``) advances the stepper to the next level at which one
  is due and calls ``observe(stepper)`` on each that is (the ``Observer`` protocol);
* step hooks, which need every step (the probes, the work of the contact forces and of the
  damping): attached to the stepper (``solver.stepper.StepHook``).

Arrays are preallocated for the whole run on rank 0.
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np

from stickslip.solver.columns import SceneRecords
from stickslip.solver.errors import EnergyGuard

if TYPE_CHECKING:  # imported where a recorder talks to other ranks: the module loads without
    from mpi4py import MPI


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


class EnergyAccumulator:
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

    def __init__(self, projection, with_friction: bool, u0: np.ndarray,
                 exact_work: bool = False) -> None:
        self.p = projection
        self.with_friction = with_friction
        n = projection.node_index.size
        self.z_prev = np.zeros(n, dtype=complex)  # u_{n-1} (x + i y)
        self.z_now = np.zeros(n, dtype=complex)  # u_n
        self.z_next = np.zeros(n, dtype=complex)  # u_{n+1}
        self.dz = np.zeros(n, dtype=complex)
        np.take(projection.complex_view(u0), projection.node_index, out=self.z_now)
        self.z_prev[:] = self.z_now
        self.work_contact = 0.0
        self.work_cylinder = 0.0
        self.friction_dissipation = 0.0
        # the implicit scheme's contact solve keeps exact work sums (``work_totals``)
        self._exact_work = exact_work

    def state(self) -> dict[str, np.ndarray]:
        """The checkpoint: u_n, u_{n+1} at the nodes and the three sums (after a step)."""
        return {"z_prev": self.z_prev.copy(), "z_now": self.z_now.copy(),
                "sums": np.array([self.work_contact, self.work_cylinder,
                                  self.friction_dissipation])}

    def restore(self, state: dict[str, np.ndarray]) -> None:
        """Continue from ``state()``."""
        self.z_prev[:] = state["z_prev"]
        self.z_now[:] = state["z_now"]
        self.work_contact, self.work_cylinder, self.friction_dissipation = (
            float(x) for x in state["sums"])

    def after_step(self, stepper) -> None:
        """Accumulate the work of r_n with the centred increment (u_{n+1} - u_{n-1}) / 2."""
        p = self.p
        p.complex_view(stepper.u).take(p.node_index, out=self.z_next, mode="clip")
        np.subtract(self.z_next, self.z_prev, out=self.dz)
        self.work_contact += 0.5 * np.vdot(p.r_xy, self.dz).real
        if self.with_friction:
            self.dz *= p.phase_conj  # polar increment: Delta u_r + i Delta u_theta
            wt = 0.5 * float(np.dot(p.out.r_t, self.dz.imag))
            wc = float(p.out.r_t.sum()) * p.slide
            self.work_cylinder += wc
            self.friction_dissipation += wc - wt
        # roll: (n-1, n, n+1) <- (n, n+1, reuse)
        self.z_prev, self.z_now, self.z_next = self.z_now, self.z_next, self.z_prev

    def totals(self, comm: MPI.Comm) -> tuple[float, float, float]:
        """(work_contact, work_cylinder, friction_dissipation) summed over ranks. Collective.

        A projection that keeps its own exact work bookkeeping (the implicit scheme's
        ``work_totals``, whose energy identity is exact) supplies the first two.
        """
        if comm.size == 1:  # one rank: the sum is the local value (no Allreduce)
            total = [self.work_contact, self.work_cylinder, self.friction_dissipation]
        else:
            from mpi4py import MPI

            local = np.array([self.work_contact, self.work_cylinder, self.friction_dissipation])
            total = np.zeros(3)
            comm.Allreduce(local, total, op=MPI.SUM)
        if self._exact_work:
            total[0], total[1] = self.p.work_totals(exposed=True)
        return float(total[0]), float(total[1]), float(total[2])


class DampingWork:
    """Work dissipated by the Kelvin-Voigt damping of ``DampedNewmark`` (scene ``[damping]``).

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
        integrator._mult(u0, ku0)
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


class InnerCircleRecorder:
    """Samples u_r(theta), u_theta(theta), velocities and contact status on the inner circle
    (the numpy and implicit steppers; a batch's, of any B, are ``solver.ensemble_observers.
    BatchRecorder``'s).

    Every ``every`` steps the owned contact-node values are gathered to rank 0 (one Gatherv
    each) and stored, ordered by angle, in preallocated arrays. Energies are sampled at the
    same times; ``observe`` runs the energy guard (``solver.errors.EnergyGuard``) on them.
    """

    def __init__(self, problem, projection, energy: EnergyAccumulator, every: int,
                 max_samples: int) -> None:
        self.problem, self.p, self.energy = problem, projection, energy
        self.every = max(1, every)
        self.comm = problem.comm
        circle = self.circle = ContactCircle(problem)
        self.n_nodes, self.is_root = circle.n_nodes, circle.is_root
        self.perm, self.theta, self.ds = circle.perm, circle.theta, circle.ds
        n_local = circle.n_local
        self.max_samples = max_samples
        self.n = 0
        # send buffers (owned): u_r, u_theta, v_r, v_theta, r_r, r_theta and the status
        self.send = np.zeros((6, n_local))
        if self.is_root:
            self.recv = np.zeros((6, self.n_nodes))
            self.recv_status = np.zeros(self.n_nodes, dtype=np.int8)
            self.t = np.zeros(max_samples)
            self.u_r = np.zeros((max_samples, self.n_nodes))
            self.u_t = np.zeros((max_samples, self.n_nodes))
            self.v_r = np.zeros((max_samples, self.n_nodes))
            self.v_t = np.zeros((max_samples, self.n_nodes))
            self.r_r = np.zeros((max_samples, self.n_nodes))
            self.r_t = np.zeros((max_samples, self.n_nodes))
            self.status = np.zeros((max_samples, self.n_nodes), dtype=np.int8)
            self.energies = np.zeros((max_samples, len(ENERGY_FIELDS)))
        self.single = self.comm.size == 1
        if self.single:  # one rank: gathered order = local order; sort while taking
            self.idx_sorted = np.asarray(projection.node_index, dtype=np.intp)[self.perm]
            self.phase_sorted = np.ascontiguousarray(projection.phase_conj[self.perm])
            self.z_sorted = np.zeros((2, n_local), dtype=complex)  # (u, v) as u_r + i u_theta
            z = self.z_sorted  # the four real views, made once
            self.z_parts = (z[0].real, z[0].imag, z[1].real, z[1].imag)
        self.last_work = (0.0, 0.0, 0.0, 0.0)
        self.kin_scratch = np.zeros(problem.n_owned)
        self.e_local = np.zeros(3)  # kinetic, strain, damping work (local)
        self.e_total = np.zeros(3)
        #: the damping-work observer of a damped scene (``at_sample``), set by the run
        self.damping = None
        self.guard = EnergyGuard(1)

    def due(self, step: int) -> bool:
        return step % self.every == 0 and self.n < self.max_samples

    def observe(self, integrator) -> dict[int, str]:
        """Record time level n (``sample``) and run the energy guard on it: {0: message} on a
        blow-up (the same on every rank: the energies are sums over the ranks)."""
        kinetic, strain = self.sample(integrator)
        return self.guard.check(np.array([kinetic]), np.array([strain]),
                                np.array([self.last_work[1]]), np.ones(1, dtype=bool),
                                integrator.time)

    def sample(self, integrator) -> tuple[float, float]:
        """Record time level n (u_prev, v, a, K u_n, r_n). Returns (kinetic, strain) energy."""
        p = self.p
        if self.damping is not None:  # the scheme's damping-work observer
            self.e_local[2] = self.damping.at_sample(integrator)
        np.multiply(integrator.v, self.problem.mass, out=self.kin_scratch)  # no allocation
        self.e_local[0] = 0.5 * float(np.dot(self.kin_scratch, integrator.v))
        self.e_local[1] = 0.5 * float(np.dot(integrator.u_prev, integrator.ku))
        if self.single:
            self._record_single(integrator, p)
        else:
            self._record_gathered(integrator, p)
        self.n += 1
        return float(self.e_total[0]), float(self.e_total[1])

    def _record_single(self, integrator, p) -> None:
        """One rank: take the nodes already in angle order straight into the sample rows.

        Same products z e^{-i theta} as ``ContactProjection.polar_at_nodes``, node by node,
        so every recorded value is bitwise the one of the gathered path; no MPI call.
        """
        i, z, idx, perm, out = self.n, self.z_sorted, self.idx_sorted, self.perm, p.out
        ur, ut, vr, vt = self.z_parts
        np.copyto(self.e_total, self.e_local)  # the sum over one rank
        work = (*self.energy.totals(self.comm), float(self.e_total[2]))
        self.last_work = work
        # mode="clip": the indices are valid, and "raise" would copy through a buffer
        p.complex_view(integrator.u_prev).take(idx, out=z[0], mode="clip")
        p.complex_view(integrator.v).take(idx, out=z[1], mode="clip")
        z *= self.phase_sorted
        self.t[i] = integrator.time - integrator.dt
        np.copyto(self.u_r[i], ur)
        np.copyto(self.u_t[i], ut)
        np.copyto(self.v_r[i], vr)
        np.copyto(self.v_t[i], vt)
        out.r_r.take(perm, out=self.r_r[i], mode="clip")
        out.r_t.take(perm, out=self.r_t[i], mode="clip")
        out.status.take(perm, out=self.status[i], mode="clip")
        self.energies[i] = (self.e_total[0], self.e_total[1], *work)

    def _record_gathered(self, integrator, p) -> None:
        """Several ranks: polar values of the owned nodes, one Gatherv each, sorted on rank 0."""
        from mpi4py import MPI

        p._polar(integrator.u_prev, self.send[0], self.send[1])
        p._polar(integrator.v, self.send[2], self.send[3])
        self.send[4] = p.out.r_r
        self.send[5] = p.out.r_t
        self.comm.Allreduce(self.e_local, self.e_total, op=MPI.SUM)
        work = (*self.energy.totals(self.comm), float(self.e_total[2]))
        self.last_work = work  # on every rank (collective above)
        for k in range(6):
            self.circle.gatherv(self.send[k], self.recv[k] if self.is_root else None,
                                MPI.DOUBLE)
        self.circle.gatherv(p.out.status, self.recv_status if self.is_root else None,
                            MPI.INT8_T)
        if self.is_root:
            i, perm = self.n, self.perm
            self.t[i] = integrator.time - integrator.dt
            self.u_r[i] = self.recv[0][perm]
            self.u_t[i] = self.recv[1][perm]
            self.v_r[i] = self.recv[2][perm]
            self.v_t[i] = self.recv[3][perm]
            self.r_r[i] = self.recv[4][perm]
            self.r_t[i] = self.recv[5][perm]
            self.status[i] = self.recv_status[perm]
            self.energies[i] = (self.e_total[0], self.e_total[1], *work)

    def arrays(self) -> dict[str, np.ndarray]:
        """The recorded samples (rank 0), trimmed to the samples actually taken."""
        n = self.n
        out = {
            "t": self.t[:n], "theta": self.theta, "u_r": self.u_r[:n], "u_theta": self.u_t[:n],
            "v_r": self.v_r[:n], "v_theta": self.v_t[:n], "status": self.status[:n],
            "energies": self.energies[:n], "r_r": self.r_r[:n], "r_theta": self.r_t[:n],
            "ds": self.ds,
        }
        return out

    def recent_status(self, last: int) -> np.ndarray:
        """Statuses of the last ``last`` samples (rank 0), e.g. for ``analysis.zone_fractions``."""
        return self.status[max(0, self.n - last): self.n]


class Progress:
    """One line every ``interval`` seconds of wall time on rank 0: time, ETA, contact status."""

    def __init__(self, end_time: float, enabled: bool, interval: float = 5.0,
                 stream=sys.stdout) -> None:
        self.end_time, self.enabled, self.interval = end_time, enabled, interval
        self.stream = stream
        self.t0 = time.perf_counter()
        self.last = self.t0

    def due(self) -> bool:
        """True when a progress line should be printed now (cheap: one clock read)."""
        return self.enabled and time.perf_counter() - self.last >= self.interval

    def update(self, sim_time: float, step: int, fractions: dict[str, float] | None) -> None:
        """Print one progress line (call when ``due()``)."""
        now = time.perf_counter()
        self.last = now
        elapsed = now - self.t0
        frac = min(1.0, sim_time / self.end_time) if self.end_time > 0 else 0.0
        eta = elapsed * (1.0 - frac) / frac if frac > 0 else math.nan
        zones = ""
        if fractions:
            zones = "  sep {separation:.0%} stick {stick:.0%} slip {slip:.0%}".format(**fractions)
        print(
            f"  t = {sim_time:.4g} s ({frac:5.1%})  step {step}  wall {elapsed:.1f} s"
            f"  ETA {eta:.0f} s{zones}",
            file=self.stream,
            flush=True,
        )


class ProbeRecorder:
    """Time histories (every step) of u_r, u_theta, v_r, v_theta at probe angles.

    Each probe is the contact node nearest to its angle (ties broken by the global node
    order, so the choice does not depend on the partition). The owning rank records it
    locally every step, without communication; ``arrays()`` gathers the histories to rank 0.
    """

    def __init__(self, problem, projection, probes_deg, max_steps: int) -> None:
        from mpi4py import MPI

        self.comm = problem.comm
        self.p = projection
        nd = problem.nodes
        slots, index, angles = [], [], []
        for slot, deg in enumerate(probes_deg):
            target = np.radians(deg) % (2 * np.pi)
            if nd.theta.size:
                dist = np.abs((nd.theta - target + np.pi) % (2 * np.pi) - np.pi)
                j = int(np.lexsort((nd.global_node_index, dist))[0])
                mine = (float(dist[j]), int(nd.global_node_index[j]))
            else:
                j, mine = -1, (np.inf, -1)
            best = self.comm.allreduce(mine, op=MPI.MIN)
            if mine == best and j >= 0:
                slots.append(slot)
                index.append(j)
                angles.append(float(np.degrees(nd.theta[j])))
        self.slots, self.angles = slots, angles
        self.index = np.asarray(projection.node_index[index], dtype=np.intp)
        self.phase_conj = projection.phase_conj[index].copy()
        self.n_probes = len(probes_deg)
        # (x + i y) of u_n and v_n per step; rotated to (r, theta) once, in ``arrays()``
        self.zu = np.zeros((max_steps + 1, len(slots)), dtype=complex)
        self.zv = np.zeros((max_steps + 1, len(slots)), dtype=complex)
        self.t = np.zeros(max_steps + 1)
        self.n = 0

    def after_step(self, integrator) -> None:
        """Record time level n (u_prev = u_n, v = v_n) after a step: two ``take`` calls."""
        i = self.n
        if i >= self.t.size:
            return
        self.t[i] = integrator.time - integrator.dt
        if self.slots:  # mode="clip": valid indices, no buffered copy ("raise" buffers out)
            self.p.complex_view(integrator.u_prev).take(self.index, out=self.zu[i], mode="clip")
            self.p.complex_view(integrator.v).take(self.index, out=self.zv[i], mode="clip")
        self.n = i + 1

    @property
    def data(self) -> np.ndarray:
        """(probe, step, [u_r, u_theta, v_r, v_theta]) of the recorded steps (local probes)."""
        zu = self.zu[: self.n] * self.phase_conj
        zv = self.zv[: self.n] * self.phase_conj
        return np.stack([zu.real, zu.imag, zv.real, zv.imag], axis=-1).transpose(1, 0, 2)

    def arrays(self) -> dict[str, np.ndarray] | None:
        """Gathered histories on rank 0 (None elsewhere): probe_t, probe_deg, probe_data."""
        return gather_probes(self.comm, self.slots, self.angles, self.data,
                             self.t[: self.n], self.n_probes)


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
    those of the live recorder ``live`` (an ``InnerCircleRecorder``, a ``ProbeRecorder`` or
    a batch member's face of them).

    ``arrays()`` joins the two along ``TIME_AXIS``; ``n`` is the count of both. Each
    recorded row is computed row by row (``InnerCircleRecorder._record_single``, the
    probes' rotation), so the joined arrays are bitwise those of one run straight through.
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


def observer_records(problem, projection, stepper, energy, damping, probes_deg,
                     every: int, n_steps: int) -> SceneRecords:
    """The records of a scene stepped by the numpy or implicit stepper: its samples
    (``InnerCircleRecorder``, reading the contact work ``energy`` and the damping work
    ``damping`` or None), its probes (``ProbeRecorder``, a step hook after the work
    observers), and the work observers as checkpoint parts."""
    recorder = InnerCircleRecorder(problem, projection, energy, every,
                                   max_samples=n_steps // every + 2)
    recorder.damping = damping
    probes = ProbeRecorder(problem, projection, probes_deg, n_steps)
    stepper.attach(probes)
    parts = {"energy": energy} if damping is None else {"energy": energy, "damping": damping}
    return SceneRecords(recorder, recorder, probes, parts)
