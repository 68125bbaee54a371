"""One scene's explicit step as the batch of one it is: ``BatchedExplicit`` with B = 1 seen as
a single-scene stepper (``solver.stepper.Stepper``), for ``solver.scene_column.SceneColumn``.

The arithmetic is the batch's, on column 0, with one of two kernels
(``solver.ensemble.BATCH_KERNELS``):

* **numba** (``NumbaColumns``: ``single_step``), so a scene alone and in a batch step with
  the same code and the same bits. The kernel runs the contact law itself and writes r_r,
  r_t, r_x, r_y, the statuses and a regularised bound's state into the scene's
  ``solver.contact.ContactProjection``, which its observers, field output and checkpoint
  read; it sums the work of the contact forces and the damping (``work``), and the scene is
  recorded as a batch is (``solver.ensemble_observers.one_scene_records``);
* **numpy** (``SceneArrayColumns``): ``ArrayColumns``' step with the scene's own operators,
  K u by one PETSc MatMult and r_n by its contact step (every friction variant, the 3D
  tube's surface); the work is summed by the scene's work observers (step hooks:
  ``solver.observers.EnergyAccumulator``, ``DampingWork``).

What this module adds is what one scene has that a batch member does not:

* **its dofs over MPI ranks.** numba: the batch's u and w hold the owned rows, then the
  ghosts (the columns of K's owned rows that other ranks own); ``GhostRows`` refreshes them
  through PETSc (``Vec.ghostUpdate``) before K reads them. numpy: the MatMult exchanges them;
* **the single-run view**: u, u_prev, v, a, ku and v~ as 1-D arrays of the owned dofs, the
  single-run checkpoint, a start with a known a_0 (v~_0 = v_0 − β₂ Δt a_0), and (numba, one
  rank) one compiled call for the steps between two samples (the probes recorded in it).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from time import perf_counter

import numpy as np

from stickslip.solver.ensemble import BatchedExplicit, BatchedProblem
from stickslip.solver.fused import friction_bound
from stickslip.solver.stepper import HookedStepper, copy_state, put_state

__all__ = ["DampingStart", "GhostRows", "SceneExplicit", "TimedContact", "operator_stepper",
           "scene_explicit"]


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


def scene_explicit(problem, law, projection, tau: float, kernel: str) -> SceneExplicit:
    """The explicit stepper of one scene on ``problem``'s ranks, ``kernel`` "numba" or
    "numpy": a batch of one on this rank's dofs, stepping the law of ``projection`` (module
    docstring)."""
    if kernel == "numpy":
        bp = BatchedProblem.without_matrix(problem.mass, problem.inv_mass, law.dt, law.beta2)
        return operator_stepper(bp, problem.stiffness_mult(), TimedContact(projection), tau,
                                several_ranks=problem.comm.size > 1)
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


def operator_stepper(bp: BatchedProblem, mult: Callable[[np.ndarray, np.ndarray], None],
                     contact: Callable | None = None, tau: float = 0.0,
                     several_ranks: bool = False) -> SceneExplicit:
    """The numpy explicit stepper of one system M a + K (u + τ v~) = r given by its
    operators: ``mult(u, out)`` (out = K u), ``contact`` (``solver.newmark.ContactStep``, or
    None) and ``bp``'s masses, step and β₂ (``BatchedProblem.without_matrix``): a scene's
    (``scene_explicit``), the reduced model's θ grid, a test's oscillator."""
    batch = BatchedExplicit(bp, d=np.zeros(1), slide=np.zeros(1), f=np.zeros(1),
                            kernel="numpy", tau=tau, operators=(mult, contact))
    return SceneExplicit(batch, several_ranks=several_ranks)


class TimedContact:
    """The explicit contact step with its wall time summed in ``seconds`` (two clock reads a
    step, ~0.1 us; the numbers the projection computes are unchanged)."""

    def __init__(self, projection) -> None:
        self.projection = projection
        self.seconds = 0.0

    def __call__(self, u_trial, u_now, force) -> None:
        t0 = perf_counter()
        self.projection(u_trial, u_now, force)
        self.seconds += perf_counter() - t0


class SceneExplicit(HookedStepper):
    """A ``BatchedExplicit`` of one column as one scene's stepper (module docstring).

    After a step ``u`` is u_{n+1} and ``u_prev``, ``v``, ``a``, ``ku`` time level n (K u_n
    after ``refresh_ku`` when damped: the step applies K w_n, w_n = u_n + τ v~_n); ``work``
    holds [work_contact, work_cylinder, friction_dissipation, the damping work's step sum]
    of this rank's contact nodes and dofs. ``advance`` runs the steps between two samples as
    one compiled call when its only step hook is the probe recorder and the run has one rank.
    """


    def __init__(self, batch: BatchedExplicit, several_ranks: bool = False) -> None:
        self.batch = batch
        self.several_ranks = several_ranks  # its dofs over MPI ranks: a ghost update a step
        self.dt, self.beta1, self.beta2 = batch.dt, 0.0, batch.beta2
        self.tau, self.damped, self.kappa = batch.tau, batch.damped, batch.kappa
        self.work = batch.work[:, 0]
        self.zprev = batch.zprev.reshape(-1)
        self._u = [x[:, 0] for x in batch.u_levels]
        self.v, self.a, self.ku, self.v_pred = (x[:, 0] for x in (batch.v, batch.a, batch.ku,
                                                                  batch.v_pred))
        #: What the next step reads: u_{n+1}, u_n, v~_{n+1} and, where the kernel sums the
        #: work, u_n at the contact nodes as (x, y) pairs and the sums (a regularised
        #: bound's state is the contact step's)
        self.STATE = batch.columns.scene_state
        self._init_hooks()

    @property
    def kernel(self) -> str:
        """The step kernel: "numba" or "numpy"."""
        return self.batch.kernel

    @property
    def kw(self) -> np.ndarray:
        """K w_n after a damped step (w_n = u_n + τ v~_n: the force it applied), until
        ``refresh_ku`` makes it K u_n (``solver.observers.DampingWork``)."""
        return self.ku

    def stiffness_product(self, u: np.ndarray, out: np.ndarray) -> None:
        """out = K u on the owned dofs (1-D arrays) by the scene's own product: the numpy
        kernel's operators (``solver.observers.DampingWork``'s u_0 · K u_0)."""
        self.batch.operators[0](u, out)

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
        the predictor v~_0 = v_0 − β₂ Δt a_0 (as a run from a known state needs),
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
        batch.started[0] = int(self.step_count > 0)
        if self.damped:
            np.multiply(batch.v_pred, self.tau, out=batch.u_tau)
            batch.u_tau[...] += batch.u

    def refresh_ku(self) -> None:
        """ku = K u_n (u_n is ``u_prev`` after a step), its ghost rows refreshed first."""
        self.batch.refresh_ku()

    def facts(self) -> dict:
        """Scheme facts for the run summary (``solver.stepper.Stepper``)."""
        return self.batch.columns.facts(self.batch)

    @property
    def compiled_loop(self) -> bool:
        """``advance`` runs as one compiled call: one rank (several need a ghost update per
        step) and no step hook but the probe recorder, which the kernel records."""
        hooks = self.hooks
        return (self.batch.columns.compiled_advance and not self.several_ranks
                and len(hooks) == 1 and hasattr(hooks[0], "kernel_buffers"))

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
