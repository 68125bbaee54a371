"""One scene's explicit step as the batch of one it is: ``BatchedExplicit`` with B = 1 seen as
a single-scene stepper (``solver.stepper.Stepper``), for ``solver.scene_column.SceneColumn``,
recorded as a batch is (``solver.ensemble_observers.one_scene_records``).

The arithmetic is the batch's (``solver.ensemble.NumbaColumns``: ``single_step`` on column 0),
so a scene alone and in a batch step with the same code and the same bits. What this module
adds is what one scene has that a batch member does not:

* **its dofs over MPI ranks.** The batch's u and w hold the owned rows, then the ghosts (the
  columns of K's owned rows that other ranks own); ``GhostRows`` refreshes them through PETSc
  (``Vec.ghostUpdate``) before K reads them;
* **its contact step's arrays.** The batch writes r_r, r_t, r_x, r_y, the statuses and a
  regularised bound's state into the scene's ``solver.contact.ContactProjection``, which its
  observers, field output and checkpoint read;
* **the single-run view**: u, u_prev, v, a, ku and v~ as 1-D arrays of the owned dofs, the
  single-run checkpoint (u, u_prev, v~, u_{n-1} at the contact nodes, the work sums), a start
  with a known a_0 (v~_0 = v_0 − β₂ Δt a_0), and one compiled call for the steps between two
  samples on one rank (the probes recorded in it).

The kernel sums the work of the contact forces and the damping itself (``work``); the
records read them at a sample (``BatchRecorder.sample``).
"""

from __future__ import annotations

import math

import numpy as np

from stickslip.solver.ensemble import BatchedExplicit, BatchedProblem
from stickslip.solver.fused import friction_bound
from stickslip.solver.stepper import HookedStepper, copy_state, put_state

__all__ = ["DampingStart", "GhostRows", "SceneExplicit", "scene_explicit"]


class GhostRows:
    """Refresh the ghost rows of an (n_owned + ghosts,) array from their owners (PETSc
    ghosted vectors over the array's memory, made once per array)."""

    def __init__(self, ghosts: np.ndarray, n_owned: int, n_global: int, comm) -> None:
        self.ghosts, self.n_owned, self.n_global, self.comm = ghosts, n_owned, n_global, comm
        self.vectors: dict[int, object] = {}

    def __call__(self, column: np.ndarray) -> None:
        from petsc4py import PETSc

        key = column.__array_interface__["data"][0]
        vec = self.vectors.get(key)
        if vec is None:
            vec = PETSc.Vec().createGhostWithArray(
                self.ghosts.astype(PETSc.IntType), column,
                size=(self.n_owned, self.n_global), comm=self.comm)
            self.vectors[key] = vec
        vec.ghostUpdate(PETSc.InsertMode.INSERT, PETSc.ScatterMode.FORWARD)


def scene_explicit(problem, law, projection, tau: float) -> SceneExplicit:
    """The numba explicit stepper of one scene on ``problem``'s ranks: a batch of one on
    this rank's dofs, writing into ``projection``'s arrays (module docstring)."""
    bp = BatchedProblem.from_problem(problem, law.dt, law.beta2, distributed=True)
    m = int(bp.cx.size)
    r_pol, r_xy = projection.r_polar.view(np.float64), projection.r_xy.view(np.float64)
    contact = {"r_r": r_pol[0::2], "r_t": r_pol[1::2], "r_x": r_xy[0::2],
               "r_y": r_xy[1::2], "status": projection.out.status}
    if projection.effective is not None:
        contact.update(sigma=projection.effective.sigma, ut_last=projection.effective.u_t_last)
    ghosts = None
    if bp.ghosts.size or problem.comm.size > 1:
        ghosts = GhostRows(bp.ghosts, bp.n, int(problem.n_global_dofs), problem.comm)
    batch = BatchedExplicit(
        bp, d=np.array([law.d]), slide=np.array([law.slide]), f=np.array([law.f]),
        kernel="numba", tau=tau, bound=friction_bound(law),
        contact={k: v.reshape(m, 1) for k, v in contact.items()}, ghost_update=ghosts)
    return SceneExplicit(batch, several_ranks=problem.comm.size > 1)


class SceneExplicit(HookedStepper):
    """A ``BatchedExplicit`` of one column as one scene's stepper (module docstring).

    After a step ``u`` is u_{n+1} and ``u_prev``, ``v``, ``a``, ``ku`` time level n (K u_n
    after ``refresh_ku`` when damped: the step applies K w_n, w_n = u_n + τ v~_n); ``work``
    holds [work_contact, work_cylinder, friction_dissipation, the damping work's step sum]
    of this rank's contact nodes and dofs. ``advance`` runs the steps between two samples as
    one compiled call when its only step hook is the probe recorder and the run has one rank.
    """

    kernel = "numba"
    #: What the next step reads: u_{n+1}, u_n, v~_{n+1}, u_{n-1}... at the contact nodes as
    #: (x, y) pairs, and the work sums (a regularised bound's state is the contact step's).
    STATE = ("u", "u_prev", "v_pred", "zprev", "work")

    def __init__(self, batch: BatchedExplicit, several_ranks: bool = False) -> None:
        self.batch = batch
        self.several_ranks = several_ranks  # its dofs over MPI ranks: a ghost update a step
        self.dt, self.beta1, self.beta2 = batch.dt, 0.0, batch.beta2
        self.tau, self.damped, self.kappa = batch.tau, batch.damped, batch.kappa
        self.work = batch.work[:, 0]
        self.zprev = batch.zprev.reshape(-1)
        self._u = [x[:, 0] for x in batch._u]
        self.v, self.a, self.ku, self.v_pred = (x[:, 0] for x in (batch.v, batch.a, batch.ku,
                                                                  batch.v_pred))
        self._init_hooks()

    # the arrays of the last level: 1-D views of the batch's column (owned dofs), made once
    # (an observer may cache its own views of them by identity)
    @property
    def u(self) -> np.ndarray:
        return self._u[self.batch.cur]

    @property
    def u_prev(self) -> np.ndarray:
        return self._u[1 - self.batch.cur]

    @property
    def time(self) -> float:
        return self.batch.time

    @time.setter
    def time(self, value: float) -> None:
        self.batch.time = value

    @property
    def step_count(self) -> int:
        return self.batch.step_count

    @step_count.setter
    def step_count(self, value: int) -> None:
        self.batch.step_count = value

    def set_state(self, u: np.ndarray, v: np.ndarray, a0: np.ndarray | None = None) -> None:
        """u_0 and v_0 (at rest where a scene starts from steady sliding); with a known a_0
        the predictor v~_0 = v_0 − β₂ Δt a_0 (``solver.newmark.Newmark.set_state``),
        else v~_0 = v_0. Also u_{-1} := u_0 and, damped, w_0 = u_0 + τ v~_0 and u_0·K u_0
        (``BatchedExplicit.set_state``)."""
        v_pred = np.array(v, dtype=float)
        if a0 is not None:
            v_pred -= self.beta2 * self.dt * np.asarray(a0)
        self.batch.set_state(np.asarray(u, dtype=float)[:, None], v_pred[:, None])
        self.v[:] = v

    def kick(self, b: int, du: np.ndarray, dv: np.ndarray) -> None:
        """Perturb the scene where it stands (``BatchedExplicit.kick`` of its column)."""
        self.batch.kick(b, du, dv)

    def step(self) -> None:
        """u_n -> u_{n+1}: the ghost rows K reads refreshed (several ranks), one kernel call."""
        self.batch.step(False)

    def state(self) -> dict[str, np.ndarray]:
        """The single-run checkpoint (``solver.stepper.Stepper.state``)."""
        return copy_state(self, self.STATE, clock=True)

    def restore(self, state: dict[str, np.ndarray]) -> None:
        """Continue from ``state()``; damped, w = u + τ v~ formed as ``set_state`` forms it."""
        put_state(self, state, self.STATE)
        batch = self.batch
        batch._started[0] = int(self.step_count > 0)
        if self.damped:
            np.multiply(batch.v_pred, self.tau, out=batch.u_tau)
            batch.u_tau[...] += batch.u

    def refresh_ku(self) -> None:
        """ku = K u_n (u_n is ``u_prev`` after a step), its ghost rows refreshed first."""
        self.batch.refresh_ku()

    def facts(self) -> dict:
        """Scheme facts for the run summary (``solver.stepper.Stepper``)."""
        return {"scheme": "explicit", "beta1": 0.0, "beta2": self.beta2,
                "damping_tau_s": self.tau, "contact_s": 0.0, "kernel": "numba",
                "kernel_first_call_s": self.batch.compile_s}

    @property
    def compiled_loop(self) -> bool:
        """``advance`` runs as one compiled call: one rank (several need a ghost update per
        step) and no step hook but the probe recorder, which the kernel records."""
        hooks = self.hooks
        return not self.several_ranks and (len(hooks) == 1
                                           and hasattr(hooks[0], "kernel_buffers"))

    def advance(self, n: int, t_stop: float = math.inf) -> int:
        """Up to ``n`` steps, stopping before a step once ``time >= t_stop``: with
        ``compiled_loop`` ONE call (``NumbaColumns.advance_one``; the probes recorded in
        it, as ``ProbeHook.after_step`` would), else step by step with the hooks."""
        if not self.compiled_loop:
            return super().advance(n, t_stop)
        probes = self.hooks[0]
        taken = self.batch.columns.advance_one(self.batch, n, t_stop, probes.kernel_buffers())
        probes.recorded()
        return taken


class DampingStart:
    """The checkpoint part of a damped ``SceneExplicit``'s Kelvin–Voigt work W_d that is not
    the stepper's: u_0 · K u_0 of the run's start (W_d = work[3] − 1/2 (u_{n+1} · K u_n −
    u_0 · K u_0), ``BatchedExplicit.damping_work_totals``; the step sums are the stepper's
    ``work``)."""

    def __init__(self, stepper: SceneExplicit) -> None:
        self.integ = stepper

    def state(self) -> dict[str, np.ndarray]:
        return {"u0_ku0": np.float64(self.integ.batch.u0_ku0[0])}

    def restore(self, state: dict[str, np.ndarray]) -> None:
        self.integ.batch.u0_ku0[0] = float(state["u0_ku0"])

    def kicked(self, du: np.ndarray) -> None:
        """A kick moves nothing this part holds (the stepper's ``kick`` moves its sums')."""
