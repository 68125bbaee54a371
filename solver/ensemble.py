"""Batched explicit integrator: B scenes that share K, M and dt advance as one (n, B) block.

A regime map is hundreds of scenes on one mesh and one material: dt depends on those only,
not on Omega, delta, f or the seed. So the scenes of such a group are the columns of (n, B)
arrays and each step reads the stiffness matrix once for all of them (one sparse matrix x
dense block product). Per-scene data: the contact parameters d, R Omega dt, f (vectors of
length B) and the initial state. Everything else is solver/fused.py's step, column by column:

    a*_n = -M^{-1} K u_n,  trial = u_n + dt v~_n + kappa a*_n,  r_n = project(trial; d, slide, f)
    a_n = a*_n + M^{-1} r_n,  v_n = v~_n + beta_2 dt a_n,  u_{n+1} = u_n + dt (v_n + dt/2 a_n)

With Kelvin-Voigt damping (``tau`` > 0, the same for the whole batch: it sets dt) K acts on
w_n = u_n + tau v~_n instead of u_n, and the damping work is summed as in the fused step
(``damping_work_totals``; the samples refresh K u_n, ``refresh_ku``).

Backends (``kernel``: a strategy, ``BATCH_KERNELS``, chosen once by the constructor):

* ``"numba"`` (CPU default): ``solver._fused_kernels.batched_step`` (short batches: 4-scene
  register passes) or ``batched_step_long`` (B-long vector loops; ``batched_kernel_name``
  picks by B and the size of K), the single-scene
  kernel's arithmetic in the same order, so a scene's numbers are *bitwise* those of
  ``stickslip run`` with ``time.kernel = "numba"``, whatever B;
* ``"cuda"`` (``xp = cupy``): one CUDA kernel per step, thread per (node, scene), compiled with
  ``--fmad=false`` and the same summation order: the state is bitwise the CPU one as well
  (only the contact-work sums are ordered differently: round-off);
* ``"xp"``: plain array operations written against the namespace ``xp`` (numpy or cupy), the
  readable reference of the two kernels (tests/test_ensemble.py);
* ``"numpy"``: one scene (B = 1) with its own K product and contact step
  (``SceneArrayColumns``: every friction variant, the 3D tube, MPI through PETSc's MatMult),
  the ``"xp"`` step's ``internal_force`` and ``newmark_update`` on its column.

A scene whose energy check fails is *masked*: its columns are zeroed and its d set to 0 (no
contact force), so it stays at rest at no risk to the others; the caller records it.
"""

from __future__ import annotations

import importlib
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from stickslip.solver.contact.law import SEPARATION, SLIP, STICK, forward_increment_factor
from stickslip.solver.ensemble_cuda import CUDA_SOURCE
from stickslip.solver.fused import (
    COMPILE_SECONDS,
    _kernels,
    local_csr,
    sample_kernels,
    slp_vectorize,
    timed_first_call,
)
from stickslip.solver.fused import kernel as get_kernel
from stickslip.solver.stepper import HookedStepper, copy_state, put_state, to_host

#: One scene's own operators (``SceneArrayColumns``): ``mult(u, out)``, out = K u on the
#: owned dofs, and its contact step ``contact(u_n, v~_n, a)`` (``solver.newmark.ContactStep``:
#: it adds M⁻¹ r_n to a*_n at the contact dofs), or None without contact.
SceneOperators = tuple[Callable[[np.ndarray, np.ndarray], None], Callable | None]

#: The array module of each backend (``solver.schemes.select.BACKENDS`` names its kernel).
ARRAY_MODULES = {"cpu": "numpy", "gpu": "cupy"}


def array_namespace(backend: str) -> Any:
    """numpy for ``backend = "cpu"``, cupy for ``"gpu"`` (ImportError names the fix)."""
    if backend not in tuple(ARRAY_MODULES):
        raise ValueError(f"backend = {backend!r}: use \"cpu\" or \"gpu\"")
    try:
        return importlib.import_module(ARRAY_MODULES[backend])
    except ImportError as err:  # pragma: no cover - depends on the machine
        raise ImportError(f"backend = {backend!r} needs CuPy: pip install cupy-cuda12x "
                          "(CUDA 12) or cupy-cuda13x (CUDA 13); see docs/gpu.md") from err


class BatchedProblem:
    """The shared, scene-independent data of a batch, as plain host arrays (npz-able).

    ``indptr, indices, data``: K's rows in local numbering (paired x/y rows, unsigned ints,
    see ``solver.fused.local_csr``); ``inv_mass`` (0 on clamped dofs) and ``mass``; the
    contact nodes' x dofs ``cx``, angles ``theta``, lumped masses ``cmass``; ``dt``, ``beta2``.
    ``from_problem`` builds it from a dolfinx ``TubeProblem``; ``save``/``load`` let a machine
    without dolfinx (a GPU node) run the batch from a file (benchmarks/ensemble.py).
    """

    FIELDS = ("indptr", "indices", "data", "mass", "inv_mass", "cx", "theta", "cmass",
              "dt", "beta2")

    def __init__(self, **arrays: Any) -> None:
        for k in self.FIELDS:
            setattr(self, k, arrays[k])
        self.dt = float(self.dt)
        self.beta2 = float(self.beta2)
        self.indptr = np.ascontiguousarray(self.indptr, dtype=np.uint32)
        self.indices = np.ascontiguousarray(self.indices, dtype=np.uint32)
        self.cx = np.ascontiguousarray(self.cx, dtype=np.uint32)
        self.extra = {k: v for k, v in arrays.items() if k not in self.FIELDS}
        #: global indices of K's columns past the owned rows (a scene distributed over MPI
        #: ranks, ``from_problem(distributed=True)``), which u and w hold after their owned
        #: rows; none on one rank
        self.ghosts = np.zeros(0, dtype=np.int64)

    @property
    def n(self) -> int:
        return int(self.inv_mass.size)

    @property
    def n_local(self) -> int:
        """Rows of u and w: the owned dofs, then the ghosts."""
        return self.n + int(self.ghosts.size)

    @classmethod
    def from_problem(cls, problem, dt: float, beta2: float,
                     distributed: bool = False) -> BatchedProblem:
        """The arrays of a dolfinx ``TubeProblem`` on one rank, or with ``distributed`` this
        rank's part of one scene spread over the ranks of ``problem.comm`` (``ghosts``)."""
        if problem.comm.size != 1 and not distributed:
            raise ValueError("a batch runs on one rank (group_size = 1)")
        indptr, indices, data, ghosts = local_csr(problem)
        nd = problem.nodes
        bp = cls(indptr=indptr, indices=indices, data=data, mass=problem.mass,
                 inv_mass=problem.inv_mass, cx=nd.dofs_x, theta=nd.theta,
                 cmass=problem.mass[nd.dofs_x], dt=dt, beta2=beta2)
        bp.ghosts = np.asarray(ghosts, dtype=np.int64)
        return bp

    @classmethod
    def without_matrix(cls, mass: np.ndarray, inv_mass: np.ndarray, dt: float,
                       beta2: float) -> BatchedProblem:
        """A problem whose K and contact step are the system's own (``SceneArrayColumns``):
        the masses, no CSR and no contact nodes of the batch's law (its contact step keeps
        its own nodes, forces and work)."""
        return cls(indptr=np.zeros(1), indices=np.zeros(0), data=np.zeros(0), mass=mass,
                   inv_mass=inv_mass, cx=np.zeros(0, dtype=np.int64), theta=np.zeros(0),
                   cmass=np.zeros(0), dt=dt, beta2=beta2)

    def save(self, path, **extra: np.ndarray) -> None:
        np.savez(path, **{k: getattr(self, k) for k in self.FIELDS}, **extra)

    @classmethod
    def load(cls, path) -> BatchedProblem:
        with np.load(path) as z:
            return cls(**{k: z[k] for k in z.files})


def _require(b: int, state: dict[str, np.ndarray], names: tuple[str, ...]) -> None:
    """Column ``b``'s checkpoint ``state`` holds every one of ``names``; else ValueError
    naming the first missing (a checkpoint of another scheme, or edited)."""
    missing = [name for name in names if name not in state]
    if missing:
        raise ValueError(f"the checkpoint of column {b} has no {missing[0]!r}: not a state "
                         "of this batch's scheme (edited, or of another scene)")


class BatchedExplicit(HookedStepper):
    """Explicit Newmark + forward-increment contact on (n, B) arrays (column b = scene b).

    A ``solver.stepper.Stepper``. After ``step()``: ``u`` is u_{n+1}; ``u_prev``,
    ``v``, ``a``, ``ku``, ``r_r``, ``r_t``, ``status`` are time level n (as
    ``solver.scene_explicit.SceneExplicit``); ``work`` (4, B) holds [work_contact, work_cylinder,
    friction_dissipation] (``work_totals()``) and the damping work's step sum (``tau`` > 0,
    ``damping_work_totals()``; ``ku`` is K u_n only after ``refresh_ku``). ``advance``
    writes v_n, a_n and K u_n in full only at the levels ``full_state_at(level)`` names (the
    sampled ones), see ``step``.
    """

    #: a batch of one on one rank may be sampled in one compiled pass
    #: (``solver.ensemble_observers.BatchRecorder``, ``_sample_kernels.sample_one``)
    one_pass_samples = True

    def __init__(self, bp: BatchedProblem, d: np.ndarray, slide: np.ndarray, f: np.ndarray,
                 xp: Any = np, kernel: str = "numba", tau: float = 0.0,
                 bound: tuple[int, float, float] = (0, 0.0, 0.0),
                 contact: dict[str, np.ndarray] | None = None,
                 ghost_update: Callable[[np.ndarray], None] | None = None,
                 operators: SceneOperators | None = None) -> None:
        #: one scene's own K product and contact step (``SceneArrayColumns``: kernel numpy)
        self.operators = operators
        self.beta2 = bp.beta2
        columns = self._checked_kernel(kernel, xp, tau, bound)
        self.xp, self.kernel, self.bp = xp, kernel, bp
        n, B, m = bp.n, int(np.size(d)), int(bp.cx.size)
        self.B, self.n, self.m = B, n, m
        if bp.ghosts.size and not (B == 1 and columns.ghost_rows):
            raise ValueError(f"a scene distributed over ranks steps alone and with a kernel "
                             f"that refreshes ghost rows (numba), not B = {B}, {kernel}")
        self.dt = bp.dt
        self.beta1 = 0.0
        self.kappa = forward_increment_factor(bp.beta2, bp.dt)
        self._put_problem(bp, d, slide, f)
        self._allocate_state(n, m, B)
        #: (m, B) arrays the step writes its contact outputs (r_r, r_t, r_x, r_y, status) and
        #: a regularised bound's state (sigma, ut_last) into instead of its own: a scene's
        #: contact step (``solver.contact.ContactProjection``), which its observers read
        for name, array in (contact or {}).items():
            if getattr(self, name).shape != array.shape:
                raise ValueError(f"contact array {name!r}: shape {array.shape}, the batch's "
                                 f"{getattr(self, name).shape}")
            setattr(self, name, array)
        #: ``ghost_update(column)``: refresh the ghost rows of an (n_local,) column of u or
        #: w before K reads it (a distributed scene: ``solver.scene_explicit``)
        self.ghost_update = ghost_update
        self.time = 0.0
        self.step_count = 0
        self.compile_s = 0.0
        self.active = np.ones(B, dtype=bool)
        self._init_hooks()
        #: levels whose v_n, a_n, K u_n ``advance`` writes in full (every level by default)
        self.full_state_at: Callable[[int], bool] = lambda level: True
        #: the step's implementation, chosen once (``BATCH_KERNELS``)
        self.columns = columns(self)
        if getattr(self.columns, "single", False):
            self.columns.columns_of_one(self)
        self.clock = np.zeros(1)  # the time as a compiled loop accumulates it (time += dt)

    def _checked_kernel(self, kernel: str, xp: Any, tau: float,
                        bound: tuple[int, float, float]) -> type:
        """The kernel's strategy from ``BATCH_KERNELS``, after checking that it runs on
        ``xp`` and has the friction bound; sets the damping (``tau``, ``damped``) and the
        bound (``reg``, ``rate_slip``, ``rate_base``: ``solver.fused.friction_bound``)."""
        if kernel not in BATCH_KERNELS:
            raise ValueError(f"kernel = {kernel!r}: use one of {tuple(BATCH_KERNELS)}")
        columns = BATCH_KERNELS[kernel]
        if columns.scene_operators != (self.operators is not None):
            raise ValueError(f"kernel = {kernel!r} "
                             + ("steps one scene with its own K product and contact step "
                                "(operators)" if columns.scene_operators else
                                "has its own K product and contact law (no operators)"))
        if columns.host_only and xp is not np:
            raise ValueError(f"the {kernel} kernel runs on numpy arrays (backend cpu)")
        if not (math.isfinite(tau) and tau >= 0.0):
            raise ValueError(f"damping tau = {tau} must be a finite number >= 0 (s)")
        if not 0.5 <= self.beta2 <= 1.0:
            raise ValueError(f"time.beta2 = {self.beta2} must be in [0.5, 1]")
        self.tau = float(tau)
        self.damped = self.tau > 0.0
        # the friction bound (``solver.fused.friction_bound``): regularised in numba only
        self.reg, self.rate_slip, self.rate_base = bound
        if self.reg and not columns.regularised:
            raise ValueError(f"kernel = {kernel!r} has no regularised friction bound "
                             "(friction.regularization): run these scenes on the CPU")
        return columns

    def _put_problem(self, bp: BatchedProblem, d: np.ndarray, slide: np.ndarray,
                     f: np.ndarray) -> None:
        """The shared operators on the array module: K (CSR), −M⁻¹, the contact nodes'
        phases e^{iθ} and masses; each scene's d, R Ω Δt and f (one column each)."""
        dev = self.xp.asarray
        self.indptr, self.indices, self.data = dev(bp.indptr), dev(bp.indices), dev(bp.data)
        self.nim = dev(-bp.inv_mass)
        phase = np.exp(1j * bp.theta)
        pconj = np.conj(phase)  # as ContactProjection.phase_conj (same bits)
        self.phase_conj = pconj
        self.ph_re, self.ph_im = dev(phase.real.copy()), dev(phase.imag.copy())
        self.pc_re, self.pc_im = dev(pconj.real.copy()), dev(pconj.imag.copy())
        self.cmass = dev(bp.cmass)
        self.cinv = dev(1.0 / bp.cmass)
        self.cx = dev(bp.cx)
        self.d = dev(np.asarray(d, dtype=float).copy())
        self.slide = dev(np.asarray(slide, dtype=float).copy())
        self.f = dev(np.asarray(f, dtype=float).copy())
        self.mass = dev(bp.mass)
        slot = -np.ones(self.n // 2, dtype=np.int64)
        slot[bp.cx // 2] = np.arange(self.m)
        self.cslot = dev(slot)  # contact index of each node, -1 off the contact circle

    def _allocate_state(self, n: int, m: int, B: int) -> None:
        """The state (n, B) and contact (m, B) arrays, the work and energy sums, the kernels'
        scratch, all zero."""
        xp = self.xp
        z = lambda *shape: xp.zeros(shape)  # noqa: E731
        rows = self.bp.n_local  # owned, then ghost rows: what K reads
        # u_n and u_{n-1}, alternating (``cur``): with the ghost rows that K reads, and their
        # owned rows, the state (the kernel strategies read both)
        self.u_rows = [z(rows, B), z(rows, B)]
        self.u_levels = [x[:n] for x in self.u_rows]
        self.cur = 0
        self.v, self.v_pred, self.a, self.ku = z(n, B), z(n, B), z(n, B), z(n, B)
        self.r_r, self.r_t, self.r_x, self.r_y = z(m, B), z(m, B), z(m, B), z(m, B)
        self.status = xp.zeros((m, B), dtype=np.int8)
        self.zprev = z(m, 2, B)
        # contact work, cylinder work, friction dissipation, the damping work's step sum
        self.work = z(4, B)
        # damped: w_n = u_n + tau v~_n (the argument of K), the kernels' two damping sums,
        # and u_0 . K u_0 per scene (``damping_work_totals``)
        # w_n and w_{n+1}, alternating as u (the numba kernels write w_{n+1} in the pass)
        self.w_rows = [z(rows, B), z(rows, B)] if self.damped else [z(0, B)] * 2
        self.w_levels = [x[:n] for x in self.w_rows]
        self.dsum = z(2, B)
        # a regularised bound's per-node state (sigma_eff, the last u_theta), (m, B)
        self.sigma, self.ut_last = (z(m, B), z(m, B)) if self.reg else (z(0, B), z(0, B))
        self.started = np.zeros(1, dtype=np.int64)  # 0 until the first step
        self.u0_ku0 = np.zeros(B)
        self.energy = z(2, B)  # numba kernels, sampled steps: Σ m v², Σ u K u (x 2 energies)
        self.energy_summed = False  # True after a numba step that summed ``energy``
        self.acc = z(4, B)  # the numba kernels' scratch (a*_n of a block of nodes, sums)
        self.keep = xp.zeros(n // 2, dtype=np.int8)  # nodes whose v, a, K u are always stored

    # -------------------------------------------------------------------------------- state
    @property
    def host_records(self) -> bool:
        """The arrays live in host memory (numpy): a batch's record may stay whole there; a
        device's is spooled in chunks (``solver.ensemble_run.BatchColumns``)."""
        return self.xp is np

    @property
    def u(self):
        return self.u_levels[self.cur]

    @property
    def u_prev(self):
        return self.u_levels[1 - self.cur]

    @property
    def u_tau(self):
        """w_n = u_n + tau v~_n before a step (damped; the argument of K)."""
        return self.w_levels[self.cur]

    def set_state(self, u0: np.ndarray, v0: np.ndarray, a0: np.ndarray | None = None) -> None:
        """(n, B) initial displacement and velocity (predictor v~_0 = v_0: a start at rest)."""
        if a0 is not None:
            raise NotImplementedError("a batch starts at rest: v~_0 = v_0, no a_0")
        xp = self.xp
        self.u[...] = xp.asarray(u0)
        self.v[...] = xp.asarray(v0)
        self.v_pred[...] = self.v
        self.a.fill(0.0)
        # u_{-1} := u_0 in the spare half of the double buffer: the damped step reads it as
        # u_{n-1} before it writes u_{n+1} there (``solver.observers.DampingWork``)
        self.u_prev[...] = self.u
        cx = self.cx.astype(np.int64)
        self.zprev[:, 0, :] = self.u[cx]
        self.zprev[:, 1, :] = self.u[cx + 1]
        if self.damped:
            xp.multiply(self.v_pred, self.tau, out=self.u_tau)  # the kernels' w_n, bitwise
            self.u_tau[...] += self.u
            ku0 = xp.zeros_like(self.u)
            self._stiffness(self.u_rows[self.cur], ku0)
            self.u0_ku0 = self._column_dots(self.u, ku0).copy()

    def _state_names(self) -> tuple[str, ...]:
        """What the next step reads, per column (the last axis is the scene): u_{n+1}, u_n
        (a damped step's u_{n-1}), v~_{n+1}, u_n at the contact nodes, the work sums, a
        regularised bound's state, d (0 once masked) and, damped, w_{n+1} (and the CUDA
        kernel's per-node damping sums)."""
        names = ("u", "u_prev", "v_pred", "zprev", "work", "sigma", "ut_last", "d")
        if self.damped:
            names += ("u_tau", "u0_ku0", *self.columns.damping_state)
        return names

    def host_state(self) -> dict[str, np.ndarray]:
        """Every array of ``_state_names``, all columns, copied to the host once (a GPU's
        arrays in one transfer each): what ``state`` takes its columns from."""
        return copy_state(self, self._state_names())

    def host_column(self, name: str, b: int) -> np.ndarray:
        """Scene ``b``'s column of the array ``name`` (u, v_pred, ...), copied to the host."""
        return np.array(to_host(getattr(self, name)[:, b]))

    def state(self, b: int, host: dict[str, np.ndarray] | None = None
              ) -> dict[str, np.ndarray]:
        """Scene ``b``'s checkpoint: its column of every array of ``_state_names`` (of
        ``host``, a ``host_state()`` of this step, else copied now), the clock and the
        kernel; ``restore`` stacks such columns into a batch of any size (the scenes are
        independent columns: the same bits)."""
        host = self.host_state() if host is None else host
        out = {name: value[..., b].copy() for name, value in host.items()}
        out.update(time=np.float64(self.time), step_count=np.int64(self.step_count),
                   kernel=np.array(self.kernel))
        return out

    def restore(self, states: list[dict[str, np.ndarray]]) -> None:
        """Continue the columns from ``states`` (one ``state(b)`` per column, all at the same
        step, each with every array of this batch's layout once adopted; ValueError naming
        the first that is not) after ``set_state``."""
        if len(states) != self.B:
            raise ValueError(f"{len(states)} checkpoints for a batch of {self.B} scenes")
        names = self._state_names()
        for b, state in enumerate(states):
            _require(b, state, ("time", "step_count", "kernel"))
        steps = {(int(s["step_count"]), float(s["time"])) for s in states}
        if len(steps) != 1:
            raise ValueError(f"the checkpoints are at steps {sorted(steps)}: a batch "
                             "continues scenes at one step")
        states = [self._adopt(s) for s in states]
        for b, state in enumerate(states):
            _require(b, state, names)
        stacked = {name: np.stack([s[name] for s in states], axis=-1) for name in names}
        step, time = steps.pop()
        put_state(self, dict(stacked, time=np.float64(time), step_count=np.int64(step)),
                  names)
        self.started[0] = int(step > 0)

    def _adopt(self, state: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """A column's checkpoint of any kernel in this kernel's layout. The dynamics' arrays
        (u, u_n, v~, the contact state) are the same bits on every kernel; the work and
        damping sums are kept as totals by numba and numpy and per node by CUDA
        (``totals``, ``from_totals``), and w_{n+1} = u_{n+1} + tau v~_{n+1} is rebuilt as
        ``set_state`` forms it. A continued run's dynamics are then those of one run on
        either kernel; its sums carry the last bits of the other's order."""
        kernel = str(state["kernel"])
        if kernel == self.kernel:
            return state
        if kernel not in BATCH_KERNELS:
            raise ValueError(f"a checkpoint of kernel {kernel!r}: this batch continues "
                             f"checkpoints of {sorted(BATCH_KERNELS)}")
        out = BATCH_KERNELS[kernel].totals(dict(state), self.damped)
        if self.damped:
            out["u_tau"] = out["v_pred"] * self.tau + out["u"]
        out = type(self.columns).from_totals(out, self.damped)
        out["kernel"] = np.array(self.kernel)
        return out

    def kick(self, b: int, du: np.ndarray, dv: np.ndarray) -> None:
        """Perturb scene ``b`` at its level: u_{n+1} and u_n (with u_n at the contact nodes,
        ``zprev``) both move by ``du``, so the displacement kick leaves the velocity alone;
        the velocity predictor v~_{n+1} moves by ``dv``; damped, w_{n+1} = u_{n+1} + τ v~_{n+1}
        by du + τ dv. ``du`` and ``dv`` (n,) vanish on the clamped dofs."""
        xp = self.xp
        du, dv = xp.asarray(du), xp.asarray(dv)
        self.u[:, b] += du
        self.u_prev[:, b] += du
        self.v_pred[:, b] += dv
        cx = self.cx.astype(np.int64)
        self.zprev[:, 0, b] += du[cx]
        self.zprev[:, 1, b] += du[cx + 1]
        if self.damped:
            self.u_tau[:, b] += du + self.tau * dv

    def mask(self, b: int) -> None:
        """Take scene ``b`` out of the batch: zero state and no contact (stays at rest)."""
        self.active[b] = False
        for arr in (*self.u_levels, self.v, self.v_pred, self.a, self.ku, self.zprev,
                    *self.w_levels,
                    *(getattr(self, name) for name in self.columns.damping_state)):
            arr[..., b] = 0.0
        self.d[b] = 0.0

    def facts(self) -> dict:
        """Scheme facts of every scene of the batch (``solver.stepper.Stepper``)."""
        return {"scheme": "explicit", "beta1": 0.0, "beta2": self.beta2,
                "damping_tau_s": self.tau, "contact_s": 0.0, "kernel": f"batched-{self.kernel}",
                "kernel_first_call_s": self.compile_s}

    def work_sums(self):
        """(3, B) array (on the device): work_contact, work_cylinder, friction_dissipation."""
        return self.columns.work_sums(self)

    def work_totals(self) -> np.ndarray:
        """(3, B) host array: work_contact, work_cylinder, friction_dissipation."""
        return np.asarray(to_host(self.work_sums()))

    # ------------------------------------------------------------------- Kelvin-Voigt
    def _stiffness(self, u, out) -> None:
        """out = K u per column (``u`` with its ghost rows), in the fused kernels' order
        (numba, CUDA) or scipy's (xp)."""
        self.columns.stiffness(self, u, out)

    def _column_dots(self, x, y) -> np.ndarray:
        """Σ_i x[i, b] y[i, b] per column (numba: in row order from 0.0, ``column_dots``)."""
        return self.columns.column_dots(self, x, y)

    def refresh_ku(self, strain: bool = True) -> None:
        """ku = K u_n (u_n is ``u_prev`` after a step; the damped step applies K w_n) and,
        with ``strain``, the strain sums energy[1] = Σ_i u_i (K u)_i of it: what the samples
        read."""
        self._stiffness(self.u_rows[1 - self.cur], self.ku)
        if strain:
            self.energy[1] = self._column_dots(self.u_prev, self.ku)

    def sum_energies(self) -> bool:
        """The kernel's own sums of the sampled energies into ``energy`` (numba: row order,
        True), or False where the recorder sums them (``BatchRecorder.sample``)."""
        self.energy_summed = self.columns.sum_energies(self)
        return self.energy_summed

    def damping_work_totals(self) -> np.ndarray:
        """(B,) W_d of every scene (needs ``refresh_ku``): work[3] - 1/2 (u_{n+1} . K u_n -
        u_0 . K u_0), the telescoped sum of ``solver.observers.DampingWork``."""
        dots = self._column_dots(self.u, self.ku)
        step_sum = self.columns.damping_step_sum(self)
        return step_sum - 0.5 * (dots - self.xp.asarray(self.u0_ku0))

    # -------------------------------------------------------------------------------- step
    def keep_nodes(self, nodes: np.ndarray) -> None:
        """Nodes whose v_n, a_n, K u_n are needed after every step (probes); see ``step``."""
        keep = np.zeros(self.n // 2, dtype=np.int8)
        keep[np.asarray(nodes, dtype=np.int64)] = 1
        self.keep = self.xp.asarray(keep)

    def step(self, diag: bool | None = None) -> None:
        """One step. ``diag = False`` lets the numba and CUDA kernels skip writing v_n, a_n
        and K u_n (3 of the 6 (n, B) arrays a step writes) except at the ``keep_nodes``: the
        state u, v~ and the contact outputs are the same bits; pass True before a step whose
        time level is sampled (``BatchRecorder.due``). By default ``full_state_at`` decides
        (every level unless the owner set it), so the protocol's ``advance`` needs nothing
        of its own. The xp reference always writes."""
        if diag is None:
            diag = self.full_state_at(self.step_count)
        cur, nxt = self.cur, 1 - self.cur
        self.columns.step(self, self.u_rows[cur], self.u_rows[nxt], bool(diag))
        self.cur = nxt
        self.time += self.dt
        self.step_count += 1


# ------------------------------------------------------------------------------ kernels


def internal_force(xp: Any, product: Callable, u, v_pred, tau: float, w, ku, nim, a) -> None:
    """a*_n = −M⁻¹ K u_n, or with Kelvin–Voigt damping (``tau`` > 0) a*_n = −M⁻¹ K w_n with
    w_n = u_n + τ v~_n (one product: the damping force τ K v~_n rides on the predictor).
    ``product(x, out)``: out = K x; ``ku`` keeps K u_n (K w_n), ``nim`` = −M⁻¹."""
    if tau > 0.0:
        xp.multiply(v_pred, tau, out=w)
        w += u
        product(w, ku)
    else:
        product(u, ku)
    xp.multiply(ku, nim, out=a)


def newmark_update(xp: Any, dt: float, beta2: float, a, v, v_pred, u, u_next,
                   scratch) -> None:
    """The paper's explicit Newmark update once a_n = a*_n + M⁻¹ r_n is known, in place,
    with w = v_n + Δt/2 a_n kept in ``v_pred``:

        v_n = v~_n + β₂ Δt a_n,  u_{n+1} = u_n + Δt w,  v~_{n+1} = w + (1/2 − β₂) Δt a_n.

    ``scratch`` (shaped as ``a``) is read only for β₂ ≠ 1/2."""
    xp.multiply(a, beta2 * dt, out=v)
    v += v_pred
    xp.multiply(a, 0.5 * dt, out=v_pred)
    v_pred += v
    xp.multiply(v_pred, dt, out=u_next)
    u_next += u
    if beta2 != 0.5:
        xp.multiply(a, (0.5 - beta2) * dt, out=scratch)
        v_pred += scratch


class ArrayColumns:
    """The readable reference step: plain array operations on the namespace ``xp`` (numpy or
    cupy), allocating temporaries; K u by scipy's (or cupyx's) sparse product."""

    host_only = False
    regularised = False
    ghost_rows = False  # steps a scene distributed over ranks (a batch of one)
    scene_operators = False  # steps with a scene's own K product and contact step
    compiled_advance = False  # ``advance_one``: the steps between samples in one call
    #: what a batch of one's next step reads (``solver.scene_explicit.SceneExplicit.state``):
    #: the kernel sums the work, so u_n at the contact nodes and the sums are state
    scene_state: tuple[str, ...] = ("u", "u_prev", "v_pred", "zprev", "work")
    damping_state: tuple[str, ...] = ()
    """The stepper's arrays of this kernel in a damped column's checkpoint."""

    def record_copies(self) -> Any:
        """The compiled copies of the batch's samples and probes
        (``solver._sample_kernels``), or None: the recorder copies by array indexing."""
        return None

    def sum_energies(self, st: BatchedExplicit) -> bool:
        """False: the recorder sums a sample's energies itself (``BatchRecorder.sample``)."""
        return False

    def __init__(self, st: BatchedExplicit) -> None:
        xp = st.xp
        if xp is np:
            import scipy.sparse as sp
        else:  # pragma: no cover - GPU only
            import cupyx.scipy.sparse as sp
        self.K = sp.csr_matrix((st.data, st.indices.astype(np.int32),
                              st.indptr.astype(np.int32)), shape=(st.n, st.n))
        self.ix = st.cx.astype(np.int64)
        self.nim = st.nim[:, None]  # −M⁻¹ as a column
        self.scratch = xp.zeros_like(st.v) if st.beta2 != 0.5 else None

    def stiffness(self, st: BatchedExplicit, u, out) -> None:
        out[...] = self.K @ u

    def column_dots(self, st: BatchedExplicit, x, y):
        return st.xp.einsum("ib,ib->b", x, y)

    def work_sums(self, st: BatchedExplicit):
        return st.work[:3]

    def facts(self, st: BatchedExplicit) -> dict:
        """The scheme facts of a batch of one (``solver.scene_explicit.SceneExplicit``)."""
        return {"scheme": "explicit", "beta1": 0.0, "beta2": st.beta2,
                "damping_tau_s": st.tau, "contact_s": 0.0, "kernel": st.kernel,
                "kernel_first_call_s": st.compile_s}

    @staticmethod
    def totals(state: dict[str, np.ndarray], damped: bool) -> dict[str, np.ndarray]:
        """A column's checkpoint with ``work`` as the 4 totals (contact, cylinder, friction,
        damping step sum): this kernel's own layout."""
        return state

    @staticmethod
    def from_totals(state: dict[str, np.ndarray], damped: bool) -> dict[str, np.ndarray]:
        """The inverse of ``totals`` for this kernel."""
        return state

    def damping_step_sum(self, st: BatchedExplicit):
        return st.work[3]

    def step(self, st: BatchedExplicit, u, u_next, diag: bool) -> None:
        """The step as array operations (always writes v_n, a_n and K u_n: ``diag`` unused):
        the internal force, the contact force, the Newmark update, the work sums."""
        internal_force(st.xp, self.product, u, st.v_pred, st.tau, st.u_tau, st.ku, self.nim,
                       st.a)
        self.contact_force(st, u)
        # damped: Σ K w_n · u_{n−1} per column, before u_{n+1} overwrites u_{n−1}
        before = st.xp.einsum("ib,ib->b", st.ku, u_next) if st.damped else None
        newmark_update(st.xp, st.dt, st.beta2, st.a, st.v, st.v_pred, u, u_next,
                       self.scratch)
        self.sum_work(st, u, u_next, before)

    def product(self, u, out) -> None:
        """out = K u in the step (scipy's or cupyx's sparse product)."""
        out[...] = self.K @ u

    def contact_force(self, st: BatchedExplicit, u) -> None:
        """r_n of the forward-increment law (``solver.contact.nodal``) at every column's
        contact nodes from the trial u_n + Δt v~_n + κ a*_n, and a_n = a*_n + M⁻¹ r_n."""
        xp, dt, kappa, a = st.xp, st.dt, st.kappa, st.a
        ix, iy = self.ix, self.ix + 1
        pcr, pci = st.pc_re[:, None], st.pc_im[:, None]
        ux, uy = u[ix], u[iy]
        now_r = ux * pcr - uy * pci
        now_t = ux * pci + uy * pcr
        tx = st.v_pred[ix] * dt + a[ix] * kappa
        ty = st.v_pred[iy] * dt + a[iy] * kappa
        tr = (tx * pcr - ty * pci) + now_r
        tt = (tx * pci + ty * pcr) + now_t
        stiff = (st.cmass * (1.0 / kappa))[:, None]
        rr = xp.maximum(st.d[None, :] - tr, 0.0) * stiff
        inc = rr > 0.0
        rt = ((now_t + st.slide[None, :]) - tt) * stiff
        cone = rr * st.f[None, :]
        slip = xp.abs(rt) > cone
        rt = xp.where(slip, xp.copysign(cone, rt), rt)
        frictionless = (st.f == 0.0)[None, :]
        rt = xp.where(frictionless, 0.0, rt)
        st.status[...] = xp.where(inc, xp.where(slip | frictionless, SLIP, STICK), SEPARATION)
        st.r_r[...] = rr
        st.r_t[...] = rt
        st.r_x[...] = rr * st.ph_re[:, None] - rt * st.ph_im[:, None]
        st.r_y[...] = rr * st.ph_im[:, None] + rt * st.ph_re[:, None]
        a[ix] = a[ix] + st.r_x * st.cinv[:, None]
        a[iy] = a[iy] + st.r_y * st.cinv[:, None]

    def sum_work(self, st: BatchedExplicit, u, u_next, before) -> None:
        """The step's work sums with the centred increment (u_{n+1} − u_{n−1}) / 2: the
        damping's K w_n · Δu_n (the step sum of ``damping_work_totals``), the contact
        force's r_n · Δu_n, the cylinder's r_θ R Ω Δt and the friction's dissipation."""
        xp, ix = st.xp, self.ix
        if st.damped:
            st.work[3] += 0.5 * (xp.einsum("ib,ib->b", st.ku, u_next) - before)
        dzx = u_next[ix] - st.zprev[:, 0]
        dzy = u_next[ix + 1] - st.zprev[:, 1]
        st.zprev[:, 0] = u[ix]
        st.zprev[:, 1] = u[ix + 1]
        st.work[0] += 0.5 * (st.r_x * dzx + st.r_y * dzy).sum(axis=0)
        wc = st.r_t.sum(axis=0) * st.slide
        wt = 0.5 * (st.r_t * (dzx * st.pc_im[:, None] + dzy * st.pc_re[:, None])).sum(axis=0)
        fr = st.f > 0.0
        st.work[1] += xp.where(fr, wc, 0.0)
        st.work[2] += xp.where(fr, wc - wt, 0.0)


class SceneArrayColumns(ArrayColumns):
    """One scene's numpy step: ``ArrayColumns``' step on column 0 with the scene's own
    operators (``SceneOperators``): K u by its product (a PETSc MatMult, whose ghost
    exchange is PETSc's: a scene over MPI ranks), r_n by its contact step (every friction
    variant of ``solver.contact``: nodal, regularised, filtered, the 3D tube's disc cone).
    The work sums are the scene's work observers' (step hooks), not the step's."""

    host_only = True
    regularised = True
    ghost_rows = True
    scene_operators = True
    #: what the next step reads (``solver.scene_explicit.SceneExplicit.state``)
    scene_state = ("u", "u_prev", "v_pred")

    def __init__(self, st: BatchedExplicit) -> None:
        if st.B != 1:
            raise ValueError(f"the numpy kernel with a scene's operators steps one scene, "
                             f"not B = {st.B}")
        self.mult, self.contact = st.operators
        # 1-D views of column 0, made once: the product and the contact step cache their
        # wrappers of an array by its identity
        col = lambda x: x[:, 0]  # noqa: E731 - (n, 1) -> (n,), a view
        self.u_cols = [col(x) for x in st.u_levels]
        self.w_cols = [col(x) for x in st.w_levels] if st.damped else [None, None]
        self.v, self.v_pred, self.a, self.ku = (col(x) for x in (st.v, st.v_pred, st.a, st.ku))
        self.nim = st.nim
        self.scratch = np.zeros(st.n) if st.beta2 != 0.5 else None
        self.product_out = np.zeros(st.n)  # K u of ``stiffness`` (a sample's K u_n)
        self.views = {id(x): col(x) for x in (*st.u_rows, *st.u_levels)}

    def step(self, st: BatchedExplicit, u, u_next, diag: bool) -> None:
        """``ArrayColumns``' step on the column: the internal force by the scene's product,
        its contact step, the Newmark update (the work: the scene's step hooks)."""
        cur = st.cur
        u_now = self.u_cols[cur]
        internal_force(np, self.mult, u_now, self.v_pred, st.tau, self.w_cols[cur], self.ku,
                       self.nim, self.a)
        if self.contact is not None:
            self.contact(u_now, self.v_pred, self.a)
        newmark_update(np, st.dt, st.beta2, self.a, self.v, self.v_pred, u_now,
                       self.u_cols[1 - cur], self.scratch)

    def stiffness(self, st: BatchedExplicit, u, out) -> None:
        """out = K u for one of the batch's u arrays (a sample's K u_n)."""
        self.mult(self.views[id(u)], self.product_out)
        out[:, 0] = self.product_out

    def facts(self, st: BatchedExplicit) -> dict:
        """The scheme facts of one scene (``contact_s``: its contact step's wall time)."""
        return {"scheme": "explicit", "beta1": 0.0, "beta2": st.beta2,
                "damping_tau_s": st.tau,
                "contact_s": float(getattr(self.contact, "seconds", 0.0)),
                "kernel": "numpy"}


class NumbaColumns(ArrayColumns):
    """The numba kernels on the host: ``solver._fused_kernels.batched_step`` (short batches:
    4-scene register passes) or ``batched_step_long`` (B-long vector loops), picked by B and
    the size of K (``batched_kernel_name``), the single-scene kernel's arithmetic in the same
    order; compiled with the SLP vectoriser (``solver.fused.slp_vectorize``)."""

    host_only = True
    regularised = True
    ghost_rows = True

    def __init__(self, st: BatchedExplicit) -> None:
        # one scene: the single-scene kernel; short batches: 4-scene register passes; long
        # ones: B-long vector loops (same bits each; solver._fused_kernels.batched_kernel_name)
        k_bytes = int(st.bp.data.nbytes + st.bp.indices.nbytes)
        self.name = _kernels().batched_kernel_name(st.B, k_bytes)
        self.fn = get_kernel(self.name)  # the step (a benchmark may swap it)
        self.dots = np.zeros(st.B)  # ``column_dots``' sums
        self.first_call = True  # of the kernel by this stepper
        st.acc = st.xp.zeros((max(6, (4 if st.damped else 2) * _kernels().NODE_BLOCK), st.B))
        self.product = get_kernel("stiffness_product_cols")  # K u_n, damped samples
        self.dots_fn = get_kernel("column_dots")
        self.first_product = True  # compiled with the SLP vectoriser (register passes)
        self.energies = get_kernel("column_energies")
        self.single = self.name == "single_step"
        self.compiled_advance = self.single
        if self.single:
            self.product1 = get_kernel("stiffness_product")
            self.advance_fn = get_kernel("advance")

    def columns_of_one(self, st: BatchedExplicit) -> None:
        """A batch of one: column 0 of every array, as the 1-D views ``single_step`` takes
        (u and w with their ghost rows), taken once the batch's arrays are final (after a
        scene's contact arrays are adopted)."""
        col = lambda x: x[..., 0]  # noqa: E731 - (n, 1) -> (n,), a view
        self.u_cols = [col(x) for x in st.u_rows]
        self.w_cols = [col(x) for x in st.w_rows]
        self.cols = {"v": col(st.v), "v_pred": col(st.v_pred), "a": col(st.a),
                     "ku": col(st.ku), "r_r": col(st.r_r), "r_t": col(st.r_t),
                     "r_x": col(st.r_x), "r_y": col(st.r_y), "status": col(st.status),
                     "work": col(st.work)}
        self.zprev = st.zprev.reshape(-1)  # (m, 2, 1) -> (x, y) pairs

    def record_copies(self) -> Any:
        return sample_kernels()

    def sum_energies(self, st: BatchedExplicit) -> bool:
        """energy = Σ_i m_i v_i², Σ_i u_i (K u)_i of level n in row order
        (``column_energies``: the sums ``batched_step`` takes on a sampled step)."""
        self.energies(st.u_prev, st.v, st.ku, st.mass, st.energy)
        return True

    def stiffness(self, st: BatchedExplicit, u, out) -> None:
        if self.single:  # one column, its ghosts refreshed: ``single_step``'s K u order
            column = u[:, 0]
            if st.ghost_update is not None:
                st.ghost_update(column)
            self.product1(st.indptr, st.indices, st.data, st.n, column, out[:, 0])
            return
        if self.first_product:
            self.first_product = False
            with slp_vectorize():
                self.product(st.indptr, st.indices, st.data, u, out)
            return
        self.product(st.indptr, st.indices, st.data, u, out)

    def column_dots(self, st: BatchedExplicit, x, y):
        self.dots_fn(x, y, self.dots)
        return self.dots

    def step(self, st: BatchedExplicit, u, u_next, diag: bool) -> None:
        """One call of the compiled step; it sums the energies on a ``diag`` step."""
        if self.single:
            self.single_step(st, diag)
            return
        dt, b2 = st.dt, st.beta2
        args = (st.indptr, st.indices, st.data, u, u_next, st.v, st.v_pred, st.a, st.ku,
                st.nim, b2 * dt, 0.5 * dt, (0.5 - b2) * dt, b2 == 0.5, dt, st.kappa,
                1.0 / st.kappa, st.cx, st.ph_re, st.ph_im, st.pc_re, st.pc_im, st.cmass,
                st.cinv, st.d, st.slide, st.f, st.r_r, st.r_t, st.r_x, st.r_y, st.status,
                st.zprev, st.work, st.acc, st.cslot, diag, st.keep, st.mass, st.energy,
                st.w_levels[st.cur], st.w_levels[1 - st.cur], st.tau, st.dsum, st.reg, st.sigma,
                st.ut_last, st.rate_slip, st.rate_base, st.started)
        if self.first_call:  # compiled (or loaded) here, with SLP, even when continued
            self.first_call = False
            with slp_vectorize():
                timed_first_call(self.name, self.fn, *args)

            st.compile_s = COMPILE_SECONDS[self.name]
        else:
            self.fn(*args)
        st.energy_summed = diag

    def single_args(self, st: BatchedExplicit) -> tuple:
        """``single_step``'s arguments for column 0, u_n (and w_n) in buffer ``st.cur``,
        the ghost rows K reads refreshed first (a distributed scene)."""
        dt, b2, c, cur, nxt = st.dt, st.beta2, self.cols, st.cur, 1 - st.cur
        if st.ghost_update is not None:
            st.ghost_update(self.w_cols[cur] if st.damped else self.u_cols[cur])
        return (st.indptr, st.indices, st.data, st.n, self.u_cols[cur], self.u_cols[nxt],
                c["v"], c["v_pred"], c["a"], c["ku"], st.nim, b2 * dt, 0.5 * dt,
                (0.5 - b2) * dt, b2 == 0.5, dt, st.kappa, 1.0 / st.kappa, st.cx, st.ph_re,
                st.ph_im, st.pc_re, st.pc_im, st.cmass, st.cinv, st.d[0], st.slide[0],
                st.f[0], c["r_r"], c["r_t"], c["r_x"], c["r_y"], c["status"], self.zprev,
                c["work"], self.w_cols[cur], self.w_cols[nxt], st.tau, st.reg, st.sigma,
                st.ut_last, st.rate_slip, st.rate_base, st.started)

    def single_step(self, st: BatchedExplicit, diag: bool) -> None:
        """A batch of one: ``single_step`` on column 0 (it writes v_n, a_n and K u_n at
        every step), then on a ``diag`` step the energies in ``batched_step``'s order."""
        args = self.single_args(st)
        if self.first_call:
            self.first_call = False
            timed_first_call(self.name, self.fn, *args)
            st.compile_s = COMPILE_SECONDS[self.name]
        else:
            self.fn(*args)
        if diag:
            self.energies(st.u_levels[st.cur], st.v, st.ku, st.mass, st.energy)
        st.energy_summed = diag

    def advance_one(self, st: BatchedExplicit, n: int, t_stop: float,
                    probes: tuple) -> int:
        """A batch of one on one rank: up to ``n`` steps of ``single_step`` as ONE compiled
        call (``_fused_kernels.advance``), the probes (``BatchRecorder.kernel_buffers``)
        recorded in it every step, stopping before a step once the time reaches
        ``t_stop``; the same arithmetic as ``n`` calls of ``step``. Returns the steps."""
        st.clock[0] = st.time
        taken = timed_first_call("advance", self.advance_fn, n, t_stop, st.clock,
                                 *self.single_args(st), *probes)
        self.first_call = False
        st.energy_summed = False  # ``advance`` sums none: ``sum_energies`` at a sample
        st.compile_s = sum(COMPILE_SECONDS.get(k, 0.0) for k in ("single_step", "advance"))
        st.time = float(st.clock[0])
        st.step_count += taken
        st.cur = (st.cur + taken) % 2
        return taken


class CudaColumns(ArrayColumns):
    """One CUDA kernel per step through CuPy, thread per (node, scene), compiled with
    ``--fmad=false`` and the numba kernels' summation order (``solver.ensemble_cuda``); the
    work sums are kept per (node, scene) (no atomics) and summed when read."""

    def __init__(self, st: BatchedExplicit) -> None:  # pragma: no cover - GPU only
        import cupy

        # the compiled module, its kernels and the launch shape: this strategy's own state
        self.module = cupy.RawModule(code=CUDA_SOURCE, options=("--fmad=false",))
        self.kern = self.module.get_function("fused_step_damped" if st.damped
                                             else "fused_step")
        self.kern_w = self.module.get_function("kelvin_voigt_argument")
        self.kern_k = self.module.get_function("stiffness_product")
        nodes = st.n // 2
        st.cslot = st.cslot.astype(np.int32)
        st.keep = cupy.zeros(nodes, dtype=np.int8)
        st.work = cupy.zeros((3, st.m, st.B))  # per (node, scene): no atomics
        # damped: the damping work's step sum per (node, scene)
        st.dwork = cupy.zeros((nodes, st.B))
        self.threads = 128
        self.blocks = (nodes * st.B + self.threads - 1) // self.threads

    @property
    def damping_state(self) -> tuple[str, ...]:
        return ("dwork",)

    def stiffness(self, st: BatchedExplicit, u, out) -> None:  # pragma: no cover - GPU only
        self.kern_k((self.blocks,), (self.threads,), (
            st.indptr, st.indices, st.data, u, out, np.int32(st.n // 2), np.int32(st.B)))

    def work_sums(self, st: BatchedExplicit):  # pragma: no cover - GPU only
        return st.work.sum(axis=1)

    @staticmethod
    def totals(state: dict[str, np.ndarray], damped: bool) -> dict[str, np.ndarray]:
        """``work`` (3, m) per contact node and ``dwork`` (nodes,) summed into the 4
        totals of the numba layout."""
        dsum = state.pop("dwork").sum() if damped else 0.0
        state["work"] = np.append(state["work"].sum(axis=1), dsum)
        return state

    @staticmethod
    def from_totals(state: dict[str, np.ndarray], damped: bool) -> dict[str, np.ndarray]:
        """The 4 totals put on the first node of the per-node sums (the sums read later
        add every node's share to them)."""
        totals, m, nodes = state["work"], state["zprev"].shape[0], state["u"].shape[0] // 2
        state["work"] = np.zeros((3, m))
        state["work"][:, 0] = totals[:3]
        if damped:
            state["dwork"] = np.zeros(nodes)
            state["dwork"][0] = totals[3]
        return state

    def damping_step_sum(self, st: BatchedExplicit):  # pragma: no cover - GPU only
        return st.dwork.sum(axis=0)

    def step(self, st: BatchedExplicit, u, u_next, diag: bool) -> None:  # pragma: no cover
        dt, b2 = st.dt, st.beta2
        f64 = np.float64
        damped = ()
        if st.damped:  # w_n = u_n + tau v~_n first: the step overwrites v~
            count = st.n * st.B
            self.kern_w(((count + self.threads - 1) // self.threads,), (self.threads,),
                        (u, st.v_pred, st.u_tau, f64(st.tau), np.int32(count)))
            damped = (st.u_tau, st.dwork)
        self.kern((self.blocks,), (self.threads,), (
            st.indptr, st.indices, st.data, u, u_next, st.v, st.v_pred, st.a,
            st.ku, st.nim, st.cslot, st.ph_re, st.ph_im, st.pc_re, st.pc_im,
            st.cmass, st.cinv, st.d, st.slide, st.f, st.r_r, st.r_t, st.r_x,
            st.r_y, st.status, st.zprev, st.work, f64(b2 * dt), f64(0.5 * dt),
            f64((0.5 - b2) * dt), np.int32(b2 == 0.5), f64(dt), f64(st.kappa),
            f64(1.0 / st.kappa), np.int32(st.n // 2), np.int32(st.B), np.int32(st.m),
            np.int32(diag), st.keep, *damped))


#: The batched step's implementations (a strategy of ``BatchedExplicit``, chosen once; the
#: backend's kernel is ``solver.schemes.select.BACKENDS``).
BATCH_KERNELS: dict[str, type[ArrayColumns]] = {
    "numba": NumbaColumns, "cuda": CudaColumns, "xp": ArrayColumns,
    "numpy": SceneArrayColumns}
