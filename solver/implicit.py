"""Implicit Newmark (beta_1 > 0) with an active-set contact/friction solve on a Schur complement.

Scheme (paper's beta_1, beta_2; section 4), lumped mass M, stiffness K, contact forces r, elastic
acceleration a*_n = -M^{-1} K u_n:

    u_{n+1} = u~ + beta_1 dt^2 a*_{n+1} + dt^2/2 M^{-1} r_{n+1},
              u~ = u_n + dt v_n + dt^2/2 (1 - 2 beta_1) a*_n
    v_{n+1} = v_n + dt [(1 - beta_2) a*_n + beta_2 a*_{n+1}] + dt M^{-1} r_{n+1}
    => K_eff u_{n+1} = M u~ / (beta_1 dt^2) + E r_{n+1} / (2 beta_1),  K_eff = M/(beta_1 dt^2) + K.

The elastic forces have the Newmark weights (unconditionally stable for 2 beta_1 >= beta_2 >=
1/2; beta_1 = 1/4, beta_2 = 1/2 is the trapezoidal rule, exactly energy conserving; beta_2 > 1/2
with beta_1 = (beta_2 + 1/2)^2 / 4 damps high frequencies). The contact impulse is applied at
t_{n+1} only, with weights 1/2 (position) and 1 (velocity): the only weights that keep steady
sliding an exact fixed point once r_n is dropped. For beta_1 = 1/4, beta_2 = 1/2 this gives
the exact identity

    E_{n+1} - E_n = r_{n+1} . (u_{n+1} - u_n),   E = 1/2 v.Mv + 1/2 u.Ku,

so the normal contact force only removes energy (impacts), lift-off is free, and without contact
the scheme is the trapezoidal rule. The textbook variant (force averaged over the step,
(r_n + r_{n+1}) / 2) gains r_n . du / 2 at every lift-off, which makes the scheme unstable
(docs/stability.md). The price: the contact force is first order in time, and the normal
velocity of a node in persistent contact alternates in sign (bounded).

Contact (paper section 2, eq. [2] nodal form). E maps the polar nodal forces (p_i, q_i) of the
contact nodes to global dofs. With K_eff factorised ONCE per dt (PETSc KSP ``preonly`` + LU:
PETSc's sparse LU with nested dissection on one rank, MUMPS in parallel; measured in
docs/accuracy.md; PETSc options prefix ``stickslip_implicit_``), the contact displacements at
t_{n+1} are affine in r:

    (u_r, u_theta) = w + S r,  w = E^T K_eff^{-1} b,  S = E^T K_eff^{-1} E / (2 beta_1),

S (2 n_c x 2 n_c, dense SPD, the Schur complement's compliance) is built once per dt by solving
K_eff X = E (blocks of columns, ``KSP.matSolve``). Each step solves on the contact dofs only:

* normal: g_i = u_r,i - d >= 0, p_i >= 0, p_i g_i = 0;
* tangential, for p_i > 0: stick (u_theta,i increment = R Omega dt, the node moves with the
  cylinder, the same rule as the explicit projection) if |q_i| <= f p_i, else slip with
  q_i = +-f p_i against the slip;

by a primal-dual active set (semi-smooth Newton, Hueber-Stadler-Wohlmuth) with
lambda_n = p - c (u_r - d), lambda_t = q - c (u_theta - u_theta_n - R Omega dt), c = 1/S_ii:
contact where lambda_n > 0, stick where |lambda_t| <= f lambda_n, slip otherwise with
sign(lambda_t). For fixed sets the conditions are linear in r (slip: q = sign f p), one dense
solve of the reduced size; the sets are updated until they repeat. Warm-started from the previous
step's sets, the first system is usually the previous step's last one (its LU is reused). If the
sets cycle, a fixed point on the friction bound (Tresca problems with g = f p) takes over; if
that fails too, ``ContactSolveError`` (a ``solver.errors.Diverged``) stops the run with both
reasons. f = 0 drops the tangential unknowns (n_c x n_c system, radial columns of E only).

MPI: every rank owns some contact nodes; S (small) and w are gathered to rank 0, which runs the
active set and scatters (p, q, status) back. The displacement is then u_{n+1} = K_eff^{-1}(b +
E r / (2 beta_1)) (a second triangular solve with the same factorisation).

Diagnostics follow the explicit path's convention (``solver.ensemble.BatchedExplicit``): after
``step()`` the integrator holds ``u`` = u_{n+1}, and ``u_prev``, ``v``, ``a``, ``ku`` = u_n,
v_n, a_n, K u_n
(a_n = a*_n + M^{-1} r_n), and ``ImplicitContact.out`` / ``r_xy`` hold r_n and the statuses at
t_n: one consistent time level for the observers. ``ImplicitContact.work_totals()`` is the
exact contact work sum r_{n+1} . (u_{n+1} - u_n) of the identity above (the observers' centred
formula misses half of every impact's dissipation for this scheme).

Initial contact force r_0 (diagnostics and first active set): nodes with u_r <= d whose elastic
force (K u_0)_r pushes on the cylinder carry p = (K u_0)_r and slip forward (the cylinder moves,
the tube is at rest), q = f p. Steady sliding is then an exact fixed point (test).
"""

from __future__ import annotations

import math
import time

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from stickslip.solver.active_set import ActiveSetSolver, ContactSolveError
from stickslip.solver.contact import SEPARATION, SLIP, ContactArrays, NodalFrames
from stickslip.solver.errors import Diverged
from stickslip.solver.stepper import HookedStepper, copy_state, put_state

OPTIONS_PREFIX = "stickslip_implicit_"  # PETSc options of the K_eff solver
SCHUR_BLOCK = 64  # columns of E per KSP.matSolve (bounds the dense work array)


# ---------------------------------------------------------------------------------------------
# Contact on the tube's inner circle: Schur complement, gather/scatter, diagnostics


class _Level:
    """Contact forces of one time level: polar r_r + i r_t, (x, y) r_x + i r_y, statuses."""

    def __init__(self, n: int) -> None:
        self.r_polar = np.zeros(n, dtype=complex)
        self.r_xy = np.zeros(n, dtype=complex)
        self.out = ContactArrays(n, r_r=self.r_polar.real, r_t=self.r_polar.imag)


class ImplicitContact(NodalFrames):
    """Contact/friction of the implicit scheme on the owned contact nodes.

    Exposes what the observers read, with the same meaning as in
    ``solver.contact.ContactProjection``: ``out`` (r_r, r_t, status), ``r_xy``, ``slide``,
    ``nodes``, ``node_index``, ``phase_conj``, ``complex_view`` and ``polar_at_nodes``;
    ``out`` and ``r_xy`` belong to the exposed time level n (module docstring).
    Nodal values are complex z = u_x + i u_y, z e^{-i theta} = u_r + i u_theta.
    """

    def __init__(self, nodes, d: float, f: float, surface_speed: float, comm: MPI.Comm) -> None:
        super().__init__(nodes)
        self.d, self.f, self.comm = d, f, comm
        self.surface_speed = surface_speed  # R Omega
        self.slide = 0.0  # R Omega dt, set with dt by ImplicitNewmark.set_dt
        n = nodes.dofs_x.size
        self._exposed, self._next = _Level(n), _Level(n)
        self.z = np.zeros(n, dtype=complex)
        counts = np.array(comm.allgather(n))
        self.counts, self.displs = counts, np.concatenate([[0], np.cumsum(counts)[:-1]])
        self.nc = int(counts.sum())
        self.root = comm.rank == 0
        gidx = np.ascontiguousarray(nodes.global_node_index, dtype=np.int64)
        self.order = np.zeros(self.nc, dtype=np.int64) if self.root else None
        comm.Gatherv(gidx, (self.order, counts, self.displs, MPI.INT64_T)
                     if self.root else None, root=0)
        self.send = np.zeros((3, n))  # w_r, w_t, target_t (gather) / p, q, status (scatter)
        self.recv = np.zeros((3, self.nc)) if self.root else None
        self.solver: ActiveSetSolver | None = None
        self.iterations = 0  # of the last step
        self.header = np.zeros(1, dtype=np.int64)
        self.work = np.zeros(2)  # local exact contact work, cylinder work (to level n+1)
        self.work_exposed = np.zeros(2)  # the same up to the exposed level n

    # -- the observers' interface ----------------------------------------------------------------

    @property
    def out(self) -> ContactArrays:
        return self._exposed.out

    @property
    def r_xy(self) -> np.ndarray:
        return self._exposed.r_xy

    def put_force(self, force: np.ndarray, exposed: bool = False) -> None:
        """Nodal forces of the internal (or exposed) level into ``force`` (zero elsewhere)."""
        level = self._exposed if exposed else self._next
        np.put(self.complex_view(force), self.node_index, level.r_xy)

    # -- Schur complement ----------------------------------------------------------------------

    def build_schur(self, ksp: PETSc.KSP, K_eff: PETSc.Mat, scale: float) -> None:
        """S = scale E^T K_eff^{-1} E on rank 0, by KSP.matSolve on blocks of E's columns."""
        nd, comm = self.nodes, self.comm
        per = 2 if self.f > 0.0 else 1
        ncols = per * self.nc
        (n_loc, n_glob), _ = K_eff.getSizes()
        g = np.asarray(nd.global_node_index, dtype=np.int64)
        S_part = np.zeros((ncols, ncols))
        for c0 in range(0, ncols, SCHUR_BLOCK):
            nb = min(SCHUR_BLOCK, ncols - c0)
            B = PETSc.Mat().createDense(((n_loc, n_glob), (PETSc.DECIDE, nb)), comm=comm)
            B.setUp()
            Bl = B.getDenseArray()  # owned rows x nb (a view)
            Bl[:] = 0.0
            # radial columns per*g, tangential per*g + 1 (E: polar unit vectors at the node)
            for comp in range(per):
                col = per * g + comp - c0
                sel = (col >= 0) & (col < nb)
                cx = nd.cos_t if comp == 0 else -nd.sin_t
                cy = nd.sin_t if comp == 0 else nd.cos_t
                Bl[nd.dofs_x[sel], col[sel]] = cx[sel]
                Bl[nd.dofs_y[sel], col[sel]] = cy[sel]
            B.assemble()
            X = B.duplicate()
            ksp.matSolve(B, X)
            Xl = X.getDenseArray(readonly=True)
            xs, ys = Xl[nd.dofs_x], Xl[nd.dofs_y]
            S_part[per * g, c0:c0 + nb] = nd.cos_t[:, None] * xs + nd.sin_t[:, None] * ys
            if per == 2:
                S_part[per * g + 1, c0:c0 + nb] = -nd.sin_t[:, None] * xs \
                    + nd.cos_t[:, None] * ys
            B.destroy()
            X.destroy()
        S = np.zeros_like(S_part) if self.root else None
        comm.Reduce(S_part, S, op=MPI.SUM, root=0)  # each row comes from one rank: exact
        if self.root:
            self.solver = ActiveSetSolver(scale * S, self.d, self.f)

    # -- per step ------------------------------------------------------------------------------

    def _gather(self) -> None:
        for k in range(3):
            self.comm.Gatherv(self.send[k], (self.recv[k], self.counts, self.displs, MPI.DOUBLE)
                              if self.root else None, root=0)

    def _scatter_into_next(self) -> None:
        for k in range(3):
            self.comm.Scatterv((self.recv[k], self.counts, self.displs, MPI.DOUBLE)
                               if self.root else None, self.send[k], root=0)
        lev = self._next
        lev.out.r_r[:] = self.send[0]
        lev.out.r_t[:] = self.send[1]
        lev.out.status[:] = self.send[2]
        np.multiply(lev.r_polar, self.phase, out=lev.r_xy)

    def solve(self, u_free: np.ndarray, u_now: np.ndarray, step: int, t: float) -> None:
        """Contact forces at t_{n+1} (internal level) from the contact-free u_{n+1}."""
        z = self.polar_at_nodes(u_free, self.z)
        self.send[0] = z.real
        self.send[1] = z.imag
        z = self.polar_at_nodes(u_now, self.z)
        np.add(z.imag, self.slide, out=self.send[2])
        self._gather()
        message = ""
        if self.root:
            s = self.solver
            w_r, w_t, tgt = (np.empty(self.nc) for _ in range(3))
            w_r[self.order], w_t[self.order], tgt[self.order] = self.recv
            try:
                self.header[0] = s.solve(w_r, w_t, tgt)
            except ContactSolveError as err:
                self.header[0] = -1
                message = f"{err} (step {step}, t = {t:.6g} s)"
            self.recv[0] = s.p[self.order]
            self.recv[1] = s.q[self.order]
            self.recv[2] = s.status()[self.order]
        self.comm.Bcast(self.header, root=0)
        if self.header[0] < 0:
            raise ContactSolveError(self.comm.bcast(message, root=0))
        self.iterations = int(self.header[0])
        self._scatter_into_next()

    def initial(self, u0: np.ndarray, ku0: np.ndarray) -> None:
        """r_0 at rest into the internal level (module docstring) and the first active set."""
        lev = self._next
        z = self.polar_at_nodes(u0, np.empty_like(self.z))
        k = self.polar_at_nodes(ku0, np.empty_like(self.z))
        touching = (z.real - self.d <= 1e-12 * max(self.d, 1e-300)) & (k.real > 0.0)
        lev.out.r_r[:] = np.where(touching, k.real, 0.0)
        lev.out.r_t[:] = self.f * lev.out.r_r
        lev.out.status[:] = np.where(touching, SLIP, SEPARATION)
        np.multiply(lev.r_polar, self.phase, out=lev.r_xy)
        self.send[2] = touching
        self._gather()
        if self.root:
            C = np.zeros(self.nc, dtype=bool)
            C[self.order] = self.recv[2] > 0.0
            self.solver.set_contact(C)

    def add_work(self, u_next: np.ndarray, u_now: np.ndarray) -> None:
        """Exact work of the step: r_{n+1} . (u_{n+1} - u_n), and the cylinder's R Omega dt q."""
        idx = self.node_index
        np.subtract(self.complex_view(u_next)[idx], self.complex_view(u_now)[idx], out=self.z)
        lev = self._next
        self.work_exposed[:] = self.work
        self.work[0] += np.vdot(lev.r_xy, self.z).real
        self.work[1] += float(lev.out.r_t.sum()) * self.slide

    def work_totals(self, exposed: bool = False) -> tuple[float, float]:
        """(contact work, cylinder work) summed over steps and ranks [J/m], up to the last
        computed level n+1 (or, ``exposed``, up to the observers' level n). Collective. For
        beta1 = 1/4, beta2 = 1/2, E - E_0 equals the contact work to round-off."""
        total = np.zeros(2)
        self.comm.Allreduce(self.work_exposed if exposed else self.work, total, op=MPI.SUM)
        return float(total[0]), float(total[1])

    def state(self) -> dict[str, np.ndarray]:
        """The checkpoint: the forces and statuses of the level computed last (the next
        step exposes them), the work sums and, on rank 0, the active set (its warm start)."""
        lev = self._next
        out = {"r_polar": lev.r_polar.copy(), "r_xy": lev.r_xy.copy(),
               "status": lev.out.status.copy(), "work": self.work.copy(),
               "work_exposed": self.work_exposed.copy()}
        if self.solver is not None:
            out["mode"] = self.solver.mode.copy()
        return out

    def restore(self, state: dict[str, np.ndarray]) -> None:
        """Continue from ``state()``."""
        lev = self._next
        lev.r_polar[:] = state["r_polar"]
        lev.r_xy[:] = state["r_xy"]
        lev.out.status[:] = state["status"]
        self.work[:] = state["work"]
        self.work_exposed[:] = state["work_exposed"]
        if self.solver is not None:
            self.solver.mode[:] = state["mode"]

    def swap(self) -> None:
        """Expose the level computed last (internal) as level n; recycle the other arrays."""
        self._exposed, self._next = self._next, self._exposed


# ---------------------------------------------------------------------------------------------
# The integrator


class ImplicitNewmark(HookedStepper):
    """Implicit Newmark on owned-dof numpy arrays; linear solves by PETSc KSP (LU, see above).

    Args:
        K: Assembled stiffness (PETSc Mat, no boundary conditions).
        mass: Lumped mass per owned dof.
        clamped: Owned local dof indices held at zero (outer circle).
        dt, beta1, beta2: Time step and Newmark parameters (beta1 > 0).
        contact: ``ImplicitContact`` or None (free vibration).
    """

    def __init__(self, K: PETSc.Mat, mass: np.ndarray, clamped: np.ndarray, dt: float,
                 beta1: float, beta2: float, contact: ImplicitContact | None = None,
                 comm: MPI.Comm | None = None, tau: float = 0.0) -> None:
        if not beta1 > 0.0:
            raise ValueError(f"ImplicitNewmark needs beta1 > 0 (got {beta1}); use Newmark")
        if not 0.5 <= beta2 <= 1.0:
            raise ValueError(f"time.beta2 = {beta2} must be in [0.5, 1]")
        self.K, self.mass, self.clamped = K, mass, np.asarray(clamped)
        self.tau = tau  # Kelvin-Voigt retardation time (0: undamped)
        self.damped = tau > 0.0
        self.damping_work_local = 0.0  # damping work up to the exposed level n (this rank)
        self.beta1, self.beta2 = beta1, beta2
        self.contact = contact
        self.comm = comm if comm is not None else K.getComm().tompi4py()
        n = mass.size
        self.n_global = K.getSize()[0]
        self.u, self.u_prev = np.zeros(n), np.zeros(n)  # u_{n+1}, u_n (exposed)
        self.v, self.a, self.ku = np.zeros(n), np.zeros(n), np.zeros(n)  # level n (exposed)
        self.v_next, self.a_next = np.zeros(n), np.zeros(n)  # v_{n+1}, a*_{n+1} (internal)
        self.a_star, self.f_over_m = np.zeros(n), np.zeros(n)
        self.inv_mass = np.where(mass > 0.0, 1.0 / np.where(mass > 0.0, mass, 1.0), 0.0)
        self.inv_mass[self.clamped] = 0.0
        self.u_pred, self.rhs, self.force = np.zeros(n), np.zeros(n), np.zeros(n)
        self.u_free, self.scratch = np.zeros(n), np.zeros(n)
        if tau > 0.0:  # K (g u~ - v~) of the last step, K v^d at level n, u_n - u_{n-1}
            self.kb, self.kvd, self.du = np.zeros(n), np.zeros(n), np.zeros(n)
        self._vecs: dict[int, PETSc.Vec] = {}
        self.time = 0.0
        self.step_count = 0
        self.iterations: list[int] = []
        self.contact_seconds = 0.0  # active set + gather/scatter (the contact's share)
        self.solve_seconds = 0.0  # triangular solves with the factorised K_eff
        self.factor_seconds = 0.0  # K_eff assembly + factorisation + Schur complement
        self.ksp: PETSc.KSP | None = None
        self.K_eff: PETSc.Mat | None = None
        self._init_hooks()
        self.set_dt(dt)

    def _vec(self, array: np.ndarray) -> PETSc.Vec:
        key = array.ctypes.data
        vec = self._vecs.get(key)
        if vec is None:
            vec = self._vecs[key] = PETSc.Vec().createWithArray(
                array, size=(array.size, self.n_global), comm=self.comm)
        return vec

    def set_dt(self, dt: float) -> None:
        """Assemble and factorise K_eff = M / (beta1 dt^2) + K for ``dt`` (once per dt)."""
        t0 = time.perf_counter()
        self.dt = dt
        self.m_eff = self.mass / (self.beta1 * dt * dt)
        self.m_eff[self.clamped] = 0.0
        if self.K_eff is not None:
            self.K_eff.destroy()
            self.ksp.destroy()
        K_eff = self.K.copy()
        if self.tau > 0.0:  # damping tau K v^d, v^d = v~ + beta2/(beta1 dt) (u_{n+1} - u~)
            K_eff.scale(1.0 + self.tau * self.beta2 / (self.beta1 * dt))
        K_eff.setDiagonal(self._vec(self.m_eff), addv=PETSc.InsertMode.ADD_VALUES)
        rstart = K_eff.getOwnershipRange()[0]
        K_eff.zeroRowsColumns((rstart + self.clamped).astype(PETSc.IntType), diag=1.0)
        ksp = PETSc.KSP().create(self.comm)
        ksp.setOptionsPrefix(OPTIONS_PREFIX)
        ksp.setOperators(K_eff)
        ksp.setType("preonly")
        pc = ksp.getPC()
        pc.setType("lu")
        if self.comm.size == 1:  # PETSc's own sparse LU: 3-30x faster solves than MUMPS here
            pc.setFactorSolverType("petsc")
            pc.setFactorOrdering("nd")
        else:
            pc.setFactorSolverType("mumps")
        ksp.setFromOptions()  # e.g. -stickslip_implicit_pc_factor_mat_solver_type mumps
        ksp.setUp()
        self.K_eff, self.ksp = K_eff, ksp
        if self.contact is not None:
            self.contact.slide = self.contact.surface_speed * dt
            self.contact.build_schur(ksp, K_eff, 0.5 / self.beta1)
        self.factor_seconds += time.perf_counter() - t0

    def _solve(self, rhs: np.ndarray, out: np.ndarray) -> None:
        t0 = time.perf_counter()
        self.ksp.solve(self._vec(rhs), self._vec(out))
        reason = self.ksp.getConvergedReason()
        if reason < 0:
            raise Diverged(f"K_eff solve failed (KSP reason {reason})")
        self.solve_seconds += time.perf_counter() - t0

    def _mult(self, u: np.ndarray, out: np.ndarray) -> None:
        self.K.mult(self._vec(u), self._vec(out))

    def kick(self, b: int, du: np.ndarray, dv: np.ndarray) -> None:
        """Not defined: a kick perturbs the explicit scheme's (u, v~) where it stands."""
        raise ValueError("a kick perturbs the explicit scheme's state; the implicit scheme's "
                         "runs are not kicked (run the census with time.beta1 = 0)")

    def set_state(self, u: np.ndarray, v: np.ndarray) -> None:
        """Initial u_0, v_0; r_0 from the nodal law at rest (module docstring)."""
        self.u[:] = u
        self.v_next[:] = v
        if self.tau > 0.0:
            self._mult(self.v_next, self.kvd)  # v^d_0 = v_0
        if self.contact is not None:
            self._mult(self.u, self.ku)
            self.contact.initial(self.u, self.ku)

    def _state_names(self) -> tuple[str, ...]:
        """What the next step reads: u_{n+1}, u_n, v_{n+1}, a*_{n+1} and, damped, the
        K (g u~ - v~) and K v^d of the last step."""
        return ("u", "u_prev", "v_next", "a_next") + (("kb", "kvd") if self.tau > 0.0 else ())

    def state(self) -> dict[str, np.ndarray]:
        """The checkpoint (``solver.stepper.Stepper.state``), with the damping
        work and the active-set iterations of every step so far (the run's facts)."""
        out = copy_state(self, self._state_names(), clock=True)
        out["damping_work_local"] = np.float64(self.damping_work_local)
        out["iterations"] = np.asarray(self.iterations, dtype=np.int32)
        return out

    def restore(self, state: dict[str, np.ndarray]) -> None:
        """Continue from ``state()`` (``solver.stepper.Stepper.restore``)."""
        put_state(self, state, self._state_names())
        self.damping_work_local = float(state["damping_work_local"])
        self.iterations = [int(i) for i in state["iterations"]]

    def step(self) -> None:
        """Advance one step; afterwards ``u`` = u_{n+1} and the exposed level is n."""
        dt, b1, b2 = self.dt, self.beta1, self.beta2
        contact = self.contact
        # expose level n: u_n, v_n, K u_n, a_n = a*_n + M^-1 r_n with a*_n = -M^-1 K u_n
        if self.tau > 0.0 and self.step_count > 0:
            np.subtract(self.u, self.u_prev, out=self.du)  # u_n - u_{n-1}
        self.u_prev[:] = self.u
        self.v[:] = self.v_next
        self._mult(self.u_prev, self.ku)
        if self.tau > 0.0 and self.step_count > 0:
            self._book_damping_work()
        np.multiply(self.ku, self.inv_mass, out=self.a_star)
        np.negative(self.a_star, out=self.a_star)
        if self.tau > 0.0 and self.step_count > 0:  # a*_n also carries the damping force
            self.a_star[:] = self.a_next
        if contact is not None:
            contact.swap()
            contact.put_force(self.force, exposed=True)
            np.multiply(self.force, self.inv_mass, out=self.a)
            self.a += self.a_star
        else:
            self.a[:] = self.a_star
        # predictor u~ = u_n + dt v_n + dt^2/2 (1 - 2 b1) a*_n
        np.multiply(self.v, dt, out=self.u_pred)
        self.u_pred += self.u_prev
        np.multiply(self.a_star, 0.5 * dt * dt * (1.0 - 2.0 * b1), out=self.scratch)
        self.u_pred += self.scratch
        np.multiply(self.m_eff, self.u_pred, out=self.rhs)  # 0 on clamped rows
        if self.tau > 0.0:
            self._damping_rhs()
        if contact is None:
            self._solve(self.rhs, self.u)
            self.force.fill(0.0)
        else:
            # K_eff u_{n+1} = M u~ / (b1 dt^2) + r_{n+1} / (2 b1)
            self._solve(self.rhs, self.u_free)
            t0 = time.perf_counter()
            contact.solve(self.u_free, self.u_prev, self.step_count + 1, self.time + dt)
            self.contact_seconds += time.perf_counter() - t0
            self.iterations.append(contact.iterations)
            contact.put_force(self.force)
            np.multiply(self.force, 0.5 / b1, out=self.scratch)
            self.rhs += self.scratch
            self._solve(self.rhs, self.u)
            contact.add_work(self.u, self.u_prev)
        # a*_{n+1} = (u_{n+1} - u~ - dt^2/2 M^-1 r_{n+1}) / (b1 dt^2)
        np.subtract(self.u, self.u_pred, out=self.scratch)
        self.scratch *= 1.0 / (b1 * dt * dt)
        np.multiply(self.force, self.inv_mass, out=self.f_over_m)
        np.multiply(self.f_over_m, 0.5 / b1, out=self.a_next)
        np.subtract(self.scratch, self.a_next, out=self.a_next)
        # v_{n+1} = v_n + dt [(1 - b2) a*_n + b2 a*_{n+1}] + dt M^-1 r_{n+1}
        np.multiply(self.a_star, (1.0 - b2) * dt, out=self.v_next)
        self.v_next += self.v
        np.multiply(self.a_next, b2 * dt, out=self.scratch)
        self.v_next += self.scratch
        np.multiply(self.f_over_m, dt, out=self.scratch)
        self.v_next += self.scratch
        self.time += dt
        self.step_count += 1

    def _damping_rhs(self) -> None:
        """Kelvin-Voigt damping (scene ``[damping]``): rhs += tau K (g u~ - v~), g = beta2 /
        (beta1 dt), v~ = v_n + (1 - beta2) dt a*_n. With the damping force tau K v^d,
        v^d = v~ + g (u_{n+1} - u~) (= v_{n+1} for beta1 = 1/4, beta2 = 1/2), this and
        K_eff = M/(beta1 dt^2) + (1 + tau g) K solve M a* + tau K v^d + K u = 0 at t_{n+1},
        and the contact forces keep the weight 1 / (2 beta1) (same Schur complement)."""
        dt, b1, b2 = self.dt, self.beta1, self.beta2
        g = b2 / (b1 * dt)
        np.multiply(self.u_pred, g, out=self.u_free)
        self.u_free -= self.v
        np.multiply(self.a_star, (1.0 - b2) * dt, out=self.scratch)
        self.u_free -= self.scratch
        self._mult(self.u_free, self.kb)
        np.multiply(self.kb, self.tau, out=self.scratch)
        self.scratch[self.clamped] = 0.0
        self.rhs += self.scratch

    def _book_damping_work(self) -> None:
        """Damping work of the step n-1 -> n: tau/2 (u_n - u_{n-1}) . K (v^d_{n-1} + v^d_n),
        with K v^d_n = g K u_n - K (g u~ - v~) (no extra MatMult). The damping force has the
        Newmark weights of the elastic force, so for beta1 = 1/4, beta2 = 1/2 this is exactly
        the energy it removes: E_n - E_0 = W_contact - W_damping to round-off."""
        g = self.beta2 / (self.beta1 * self.dt)
        w_old = float(np.dot(self.du, self.kvd))
        np.multiply(self.ku, g, out=self.kvd)
        self.kvd -= self.kb
        self.damping_work_local += 0.5 * self.tau * (w_old + float(np.dot(self.du, self.kvd)))

    def facts(self) -> dict:
        """Scheme facts for the run summary (``solver.stepper.Stepper``)."""
        return self.iteration_stats()

    def iteration_stats(self) -> dict:
        """Active-set iterations per step (mean, max) and the time split of the scheme."""
        its = np.asarray(self.iterations) if self.iterations else np.zeros(1)
        return {
            "scheme": "implicit",
            "beta1": self.beta1,
            "beta2": self.beta2,
            "damping_tau_s": self.tau,
            "active_set_iterations_mean": float(its.mean()),
            "active_set_iterations_max": int(its.max()),
            "factorisation_s": self.factor_seconds,
            "linear_solves_s": self.solve_seconds,
            "contact_s": self.contact_seconds,
        }


class ImplicitDampingWork:
    """The Kelvin-Voigt work of a damped ``ImplicitNewmark``: the stepper books it each step
    (``damping_work_local``, in its checkpoint), so this is no step hook and has no state."""

    def state(self) -> dict[str, np.ndarray]:
        return {}

    def restore(self, state: dict[str, np.ndarray]) -> None:
        pass

    def at_sample(self, integrator: ImplicitNewmark) -> float:
        """W_d up to level n on this rank's dofs."""
        return integrator.damping_work_local

    def kicked(self, du: np.ndarray) -> None:
        """Nothing to move (the implicit scheme is not kicked)."""


def amplification_eigenvalues(omega_dt: float, beta1: float, beta2: float) -> np.ndarray:
    """The two principal eigenvalues of the Newmark amplification matrix of u'' + w^2 u = 0.

    State x = (u, dt v, dt^2 a); L x_{n+1} = R x_n with a_{n+1} = -w^2 u_{n+1}.
    """
    w2 = omega_dt * omega_dt
    L = np.array([[1.0, 0.0, -beta1], [0.0, 1.0, -beta2], [w2, 0.0, 1.0]])
    R = np.array([[1.0, 1.0, 0.5 - beta1], [0.0, 1.0, 1.0 - beta2], [0.0, 0.0, 0.0]])
    lam = np.linalg.eigvals(np.linalg.solve(L, R))
    return lam[np.argsort(-np.abs(lam))[:2]]  # the third root is the spurious 0 (a from u)


def damping_per_period(omega_dt: float, beta1: float, beta2: float) -> float:
    """Amplitude factor over one period of the oscillation at w dt: rho^(2 pi / phase)."""
    lam = amplification_eigenvalues(omega_dt, beta1, beta2)
    k = int(np.argmax(np.abs(lam.imag)))
    rho, phase = abs(lam[k]), abs(np.angle(lam[k]))
    if phase == 0.0:
        return 0.0 if rho < 1.0 else math.inf
    return float(rho ** (2.0 * math.pi / phase))
