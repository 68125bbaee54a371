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

Backends (``kernel``):

* ``"numba"`` (CPU default): ``solver._fused_kernels.batched_step`` (short batches: 4-scene
  register passes) or ``batched_step_long`` (B-long vector loops; ``batched_kernel_name``
  picks by B and the size of K), the single-scene
  kernel's arithmetic in the same order, so a scene's numbers are *bitwise* those of
  ``stickslip run`` with ``time.kernel = "numba"``, whatever B;
* ``"cuda"`` (``xp = cupy``): one CUDA kernel per step, thread per (node, scene), compiled with
  ``--fmad=false`` and the same summation order: the state is bitwise the CPU one as well
  (only the contact-work sums are ordered differently: round-off);
* ``"xp"``: plain array operations written against the namespace ``xp`` (numpy or cupy), the
  readable reference of the two kernels (tests/test_ensemble.py).

A scene whose energy check fails is *masked*: its columns are zeroed and its d set to 0 (no
contact force), so it stays at rest at no risk to the others; the caller records it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from solver.contact.law import SEPARATION, SLIP, STICK, forward_increment_factor
from solver.ensemble_cuda import CUDA_SOURCE
from solver.schemes.protocol import HookedStepper, copy_state, put_state

#: The batched stepper's implementations of one step (not the scene's ``time.kernel`` choice).
BATCH_KERNELS = ("numba", "cuda", "xp")


def array_namespace(backend: str) -> Any:
    """numpy for ``backend = "cpu"``, cupy for ``"gpu"`` (ImportError names the fix)."""
    if backend == "cpu":
        return np
    if backend == "gpu":
        try:
            import cupy
        except ImportError as err:  # pragma: no cover - depends on the machine
            raise ImportError("backend = \"gpu\" needs CuPy: pip install cupy-cuda12x (CUDA 12) "
                              "or cupy-cuda13x (CUDA 13); see docs/gpu.md") from err
        return cupy
    raise ValueError(f"backend = {backend!r}: use \"cpu\" or \"gpu\"")


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

    @property
    def n(self) -> int:
        return int(self.inv_mass.size)

    @classmethod
    def from_problem(cls, problem, dt: float, beta2: float) -> BatchedProblem:
        from solver.fused import local_csr

        if problem.comm.size != 1:
            raise ValueError("a batch runs on one rank (group_size = 1)")
        indptr, indices, data, _ = local_csr(problem)
        nd = problem.nodes
        return cls(indptr=indptr, indices=indices, data=data, mass=problem.mass,
                   inv_mass=problem.inv_mass, cx=nd.dofs_x, theta=nd.theta,
                   cmass=problem.mass[nd.dofs_x], dt=dt, beta2=beta2)

    def save(self, path, **extra: np.ndarray) -> None:
        np.savez(path, **{k: getattr(self, k) for k in self.FIELDS}, **extra)

    @classmethod
    def load(cls, path) -> BatchedProblem:
        with np.load(path) as z:
            return cls(**{k: z[k] for k in z.files})


class BatchedExplicit(HookedStepper):
    """Explicit Newmark + forward-increment contact on (n, B) arrays (column b = scene b).

    A ``solver.schemes.protocol.Stepper``. After ``step()``: ``u`` is u_{n+1}; ``u_prev``,
    ``v``, ``a``, ``ku``, ``r_r``, ``r_t``, ``status`` are time level n (as
    ``solver.newmark.Newmark``); ``work`` (4, B) holds [work_contact, work_cylinder,
    friction_dissipation] (``work_totals()``) and the damping work's step sum (``tau`` > 0,
    ``damping_work_totals()``; ``ku`` is K u_n only after ``refresh_ku``). ``advance``
    writes v_n, a_n and K u_n in full only at the levels ``full_state_at(level)`` names (the
    sampled ones), see ``step``.
    """

    def __init__(self, bp: BatchedProblem, d: np.ndarray, slide: np.ndarray, f: np.ndarray,
                 xp: Any = np, kernel: str = "numba", tau: float = 0.0,
                 bound: tuple[int, float, float] = (0, 0.0, 0.0)) -> None:
        if kernel not in BATCH_KERNELS:
            raise ValueError(f"kernel = {kernel!r}: use one of {BATCH_KERNELS}")
        if kernel == "numba" and xp is not np:
            raise ValueError("the numba kernel runs on numpy arrays (backend cpu)")
        if not (math.isfinite(tau) and tau >= 0.0):
            raise ValueError(f"damping tau = {tau} must be a finite number >= 0 (s)")
        self.tau = float(tau)
        self.damped = self.tau > 0.0
        # the friction bound (``solver.fused.friction_bound``): regularised in numba only
        self.reg, self.rate_slip, self.rate_base = bound
        if self.reg and kernel != "numba":
            raise ValueError(f"kernel = {kernel!r} has no regularised friction bound "
                             "(friction.regularization): run these scenes on the CPU")
        self.xp, self.kernel, self.bp = xp, kernel, bp
        n, B, m = bp.n, int(np.size(d)), int(bp.cx.size)
        self.B, self.n, self.m = B, n, m
        self.dt, self.beta2 = bp.dt, bp.beta2
        self.beta1 = 0.0
        self.kappa = forward_increment_factor(bp.beta2, bp.dt)
        dev = xp.asarray
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
        z = lambda *shape: xp.zeros(shape)  # noqa: E731
        self._u = [z(n, B), z(n, B)]
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
        self._w = [z(n, B), z(n, B)] if self.damped else [z(0, B)] * 2
        self.dsum = z(2, B)
        # a regularised bound's per-node state (sigma_eff, the last u_theta), (m, B)
        self.sigma, self.ut_last = (z(m, B), z(m, B)) if self.reg else (z(0, B), z(0, B))
        self._started = np.zeros(1, dtype=np.int64)  # 0 until the first step
        self._first_call = True  # of the kernel by this stepper
        self.u0_ku0 = np.zeros(B)
        self._dots = np.zeros(B)
        self.mass = dev(bp.mass)
        self.energy = z(2, B)  # numba kernels, sampled steps: Σ m v², Σ u K u (x 2 energies)
        self.energy_summed = False  # True after a numba step that summed ``energy``
        self.acc = z(4, B)  # the numba kernels' scratch (a*_n of a block of nodes, sums)
        self.time = 0.0
        self.step_count = 0
        self.compile_s = 0.0
        self.active = np.ones(B, dtype=bool)
        self._init_hooks()
        #: levels whose v_n, a_n, K u_n ``advance`` writes in full (every level by default)
        self.full_state_at: Callable[[int], bool] = lambda level: True
        slot = -np.ones(n // 2, dtype=np.int64)
        slot[bp.cx // 2] = np.arange(m)
        self.cslot = dev(slot)  # contact index of each node, -1 off the contact circle
        self.keep = xp.zeros(n // 2, dtype=np.int8)  # nodes whose v, a, K u are always stored
        if kernel == "numba":
            from solver.fused import _kernels
            from solver.fused import kernel as get_kernel

            # short batches: 4-scene register passes; long ones: B-long vector loops (same
            # bits either way; solver._fused_kernels.batched_kernel_name)
            k_bytes = int(bp.data.nbytes + bp.indices.nbytes)
            self._name = _kernels().batched_kernel_name(B, k_bytes)
            self._fn = get_kernel(self._name)
            self.acc = z(max(6, (4 if self.damped else 2) * _kernels().NODE_BLOCK), B)
            self._product = get_kernel("stiffness_product_cols")  # K u_n, damped samples
            self._dots_fn = get_kernel("column_dots")
            self._first_product = True  # compiled with the SLP vectoriser (register passes)
        elif kernel == "cuda":
            self._cuda_setup()
        else:
            self._xp_setup()

    # -------------------------------------------------------------------------------- state
    @property
    def host_records(self) -> bool:
        """The arrays live in host memory (numpy): a batch's record may stay whole there; a
        device's is spooled in chunks (``solver.ensemble_run.BatchSimulation``)."""
        return self.xp is np

    @property
    def u(self):
        return self._u[self.cur]

    @property
    def u_prev(self):
        return self._u[1 - self.cur]

    @property
    def u_tau(self):
        """w_n = u_n + tau v~_n before a step (damped; the argument of K)."""
        return self._w[self.cur]

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
            self._stiffness(self.u, ku0)
            self.u0_ku0 = self._column_dots(self.u, ku0).copy()

    def _state_names(self) -> tuple[str, ...]:
        """What the next step reads, per column (the last axis is the scene): u_{n+1}, u_n
        (a damped step's u_{n-1}), v~_{n+1}, u_n at the contact nodes, the work sums, a
        regularised bound's state, d (0 once masked) and, damped, w_{n+1} (and the CUDA
        kernel's per-node damping sums)."""
        names = ("u", "u_prev", "v_pred", "zprev", "work", "sigma", "ut_last", "d")
        if self.damped:
            names += ("u_tau", "u0_ku0") + (("dwork",) if self.kernel == "cuda" else ())
        return names

    def state(self, b: int) -> dict[str, np.ndarray]:
        """Scene ``b``'s checkpoint: its column of every array of ``_state_names`` (host
        copies), the clock and the kernel; ``restore`` stacks such columns into a batch of
        any size (the scenes are independent columns: the same bits)."""
        out = {name: value[..., b].copy()
               for name, value in copy_state(self, self._state_names()).items()}
        out.update(time=np.float64(self.time), step_count=np.int64(self.step_count),
                   kernel=np.array(self.kernel))
        return out

    def restore(self, states: list[dict[str, np.ndarray]]) -> None:
        """Continue the columns from ``states`` (one ``state(b)`` per column, all at the same
        step and of this kernel; ValueError otherwise) after ``set_state``."""
        if len(states) != self.B:
            raise ValueError(f"{len(states)} checkpoints for a batch of {self.B} scenes")
        steps = {(int(s["step_count"]), float(s["time"])) for s in states}
        kernels = {str(s["kernel"]) for s in states}
        if len(steps) != 1 or kernels != {self.kernel}:
            raise ValueError(f"the checkpoints are at steps {sorted(steps)} of kernels "
                             f"{sorted(kernels)}: a batch continues scenes at one step of "
                             f"the {self.kernel!r} kernel")
        names = self._state_names()
        stacked = {name: np.stack([s[name] for s in states], axis=-1) for name in names}
        step, time = steps.pop()
        put_state(self, dict(stacked, time=np.float64(time), step_count=np.int64(step)),
                  names)
        self._started[0] = int(step > 0)

    def mask(self, b: int) -> None:
        """Take scene ``b`` out of the batch: zero state and no contact (stays at rest)."""
        self.active[b] = False
        for arr in (*self._u, self.v, self.v_pred, self.a, self.ku, self.zprev, *self._w,
                    *([self.dwork] if self.kernel == "cuda" else [])):
            arr[..., b] = 0.0
        self.d[b] = 0.0

    def facts(self) -> dict:
        """Scheme facts of every scene of the batch (``solver.schemes.protocol.Stepper``)."""
        return {"scheme": "explicit", "beta1": 0.0, "beta2": self.beta2,
                "damping_tau_s": self.tau, "contact_s": 0.0, "kernel": f"batched-{self.kernel}",
                "kernel_first_call_s": self.compile_s}

    def work_totals(self) -> np.ndarray:
        """(3, B) host array: work_contact, work_cylinder, friction_dissipation."""
        w = self.work if self.work.ndim == 2 else self.work.sum(axis=1)
        return np.asarray(w.get() if hasattr(w, "get") else w)[:3]

    # ------------------------------------------------------------------- Kelvin-Voigt
    def _stiffness(self, u, out) -> None:
        """out = K u per column, in the fused kernels' order (numba, CUDA) or scipy's (xp)."""
        if self.kernel == "cuda":  # pragma: no cover - GPU (or its CPU emulation)
            self._kern_k((self._blocks,), (self._threads,), (
                self.indptr, self.indices, self.data, u, out, np.int32(self.n // 2),
                np.int32(self.B)))
        elif self.kernel == "numba":
            if self._first_product:
                from solver.fused import slp_vectorize

                self._first_product = False
                with slp_vectorize():
                    self._product(self.indptr, self.indices, self.data, u, out)
                return
            self._product(self.indptr, self.indices, self.data, u, out)
        else:
            out[...] = self.K @ u

    def _column_dots(self, x, y) -> np.ndarray:
        """Σ_i x[i, b] y[i, b] per column (numba: in row order, the bits of a single scene's
        ``sequential_dot``)."""
        if self.kernel == "numba":
            self._dots_fn(x, y, self._dots)
            return self._dots
        return self.xp.einsum("ib,ib->b", x, y)

    def refresh_ku(self) -> None:
        """ku = K u_n (u_n is ``u_prev`` after a step; the damped step applies K w_n) and the
        strain sums energy[1] = Σ_i u_i (K u)_i of it: what the samples read."""
        self._stiffness(self.u_prev, self.ku)
        self.energy[1] = self._column_dots(self.u_prev, self.ku)

    def damping_work_totals(self) -> np.ndarray:
        """(B,) W_d of every scene, as ``solver.fused.FusedDampingWork`` (needs
        ``refresh_ku``): work[3] - 1/2 (u_{n+1} . K u_n - u_0 . K u_0)."""
        dots = self._column_dots(self.u, self.ku)
        step_sum = self.work[3] if self.work.ndim == 2 else self.dwork.sum(axis=0)
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
        if self.kernel == "numba":
            from solver.fused import slp_vectorize, timed_first_call

            dt, b2 = self.dt, self.beta2
            args = (self.indptr, self.indices, self.data, self._u[cur], self._u[nxt], self.v,
                    self.v_pred, self.a, self.ku, self.nim, b2 * dt, 0.5 * dt,
                    (0.5 - b2) * dt, b2 == 0.5, dt, self.kappa, 1.0 / self.kappa, self.cx,
                    self.ph_re, self.ph_im, self.pc_re, self.pc_im, self.cmass, self.cinv,
                    self.d, self.slide, self.f, self.r_r, self.r_t, self.r_x, self.r_y,
                    self.status, self.zprev, self.work, self.acc, self.cslot, bool(diag),
                    self.keep, self.mass, self.energy, self._w[cur], self._w[nxt], self.tau,
                    self.dsum, self.reg, self.sigma, self.ut_last, self.rate_slip,
                    self.rate_base, self._started)
            if self._first_call:  # compiled (or loaded) here, with SLP, even when continued
                self._first_call = False
                with slp_vectorize():
                    timed_first_call(self._name, self._fn, *args)
                from solver.fused import COMPILE_SECONDS

                self.compile_s = COMPILE_SECONDS[self._name]
            else:
                self._fn(*args)
            self.energy_summed = bool(diag)
        elif self.kernel == "cuda":
            self._cuda_step(self._u[cur], self._u[nxt], diag)
        else:
            self._xp_step(self._u[cur], self._u[nxt])
        self.cur = nxt
        self.time += self.dt
        self.step_count += 1

    # ---------------------------------------------------------------------- xp reference
    def _xp_setup(self) -> None:
        xp = self.xp
        if xp is np:
            import scipy.sparse as sp
        else:  # pragma: no cover - GPU only
            import cupyx.scipy.sparse as sp
        self.K = sp.csr_matrix((self.data, self.indices.astype(np.int32),
                                self.indptr.astype(np.int32)), shape=(self.n, self.n))
        self._ix = self.cx.astype(np.int64)

    def _xp_step(self, u, u_next) -> None:
        """The step as array operations (readable reference; allocates temporaries)."""
        xp, dt, b2, kappa = self.xp, self.dt, self.beta2, self.kappa
        ix, iy = self._ix, self._ix + 1
        pcr, pci = self.pc_re[:, None], self.pc_im[:, None]
        if self.damped:  # K w_n, w_n = u_n + tau v~_n (DampedNewmark)
            w = self.u_tau
            xp.multiply(self.v_pred, self.tau, out=w)
            w += u
            self.ku[...] = self.K @ w
        else:
            self.ku[...] = self.K @ u
        xp.multiply(self.ku, self.nim[:, None], out=self.a)
        a = self.a
        ux, uy = u[ix], u[iy]
        now_r = ux * pcr - uy * pci
        now_t = ux * pci + uy * pcr
        tx = self.v_pred[ix] * dt + a[ix] * kappa
        ty = self.v_pred[iy] * dt + a[iy] * kappa
        tr = (tx * pcr - ty * pci) + now_r
        tt = (tx * pci + ty * pcr) + now_t
        stiff = (self.cmass * (1.0 / kappa))[:, None]
        rr = xp.maximum(self.d[None, :] - tr, 0.0) * stiff
        inc = rr > 0.0
        rt = ((now_t + self.slide[None, :]) - tt) * stiff
        cone = rr * self.f[None, :]
        slip = xp.abs(rt) > cone
        rt = xp.where(slip, xp.copysign(cone, rt), rt)
        frictionless = (self.f == 0.0)[None, :]
        rt = xp.where(frictionless, 0.0, rt)
        self.status[...] = xp.where(inc, xp.where(slip | frictionless, SLIP, STICK), SEPARATION)
        self.r_r[...] = rr
        self.r_t[...] = rt
        self.r_x[...] = rr * self.ph_re[:, None] - rt * self.ph_im[:, None]
        self.r_y[...] = rr * self.ph_im[:, None] + rt * self.ph_re[:, None]
        a[ix] = a[ix] + self.r_x * self.cinv[:, None]
        a[iy] = a[iy] + self.r_y * self.cinv[:, None]
        self.v[...] = a * (b2 * dt) + self.v_pred
        w = a * (0.5 * dt) + self.v
        if self.damped:  # u_next holds u_{n-1} until it is overwritten
            self.work[3] += 0.5 * (xp.einsum("ib,ib->b", self.ku, w * dt + u)
                                   - xp.einsum("ib,ib->b", self.ku, u_next))
        u_next[...] = w * dt + u
        self.v_pred[...] = w if b2 == 0.5 else w + a * ((0.5 - b2) * dt)
        dzx = u_next[ix] - self.zprev[:, 0]
        dzy = u_next[iy] - self.zprev[:, 1]
        self.zprev[:, 0] = ux
        self.zprev[:, 1] = uy
        self.work[0] += 0.5 * (self.r_x * dzx + self.r_y * dzy).sum(axis=0)
        wc = self.r_t.sum(axis=0) * self.slide
        wt = 0.5 * (self.r_t * (dzx * pci + dzy * pcr)).sum(axis=0)
        fr = self.f > 0.0
        self.work[1] += xp.where(fr, wc, 0.0)
        self.work[2] += xp.where(fr, wc - wt, 0.0)

    # ------------------------------------------------------------------------ CUDA kernel
    def _cuda_setup(self) -> None:  # pragma: no cover - GPU only
        import cupy

        self._module = cupy.RawModule(code=CUDA_SOURCE, options=("--fmad=false",))
        self._kern = self._module.get_function("fused_step_damped" if self.damped
                                                else "fused_step")
        self._kern_w = self._module.get_function("kelvin_voigt_argument")
        self._kern_k = self._module.get_function("stiffness_product")
        nodes = self.n // 2
        self.cslot = self.cslot.astype(np.int32)
        self.keep = cupy.zeros(nodes, dtype=np.int8)
        self.work = cupy.zeros((3, self.m, self.B))  # per (node, scene): no atomics
        # damped: the damping work's step sum per (node, scene)
        self.dwork = cupy.zeros((nodes, self.B))
        self._threads = 128
        self._blocks = (nodes * self.B + self._threads - 1) // self._threads

    def _cuda_step(self, u, u_next, diag: bool) -> None:  # pragma: no cover - GPU only
        dt, b2 = self.dt, self.beta2
        f64 = np.float64
        damped = ()
        if self.damped:  # w_n = u_n + tau v~_n first: the step overwrites v~
            count = self.n * self.B
            self._kern_w(((count + self._threads - 1) // self._threads,), (self._threads,),
                         (u, self.v_pred, self.u_tau, f64(self.tau), np.int32(count)))
            damped = (self.u_tau, self.dwork)
        self._kern((self._blocks,), (self._threads,), (
            self.indptr, self.indices, self.data, u, u_next, self.v, self.v_pred, self.a,
            self.ku, self.nim, self.cslot, self.ph_re, self.ph_im, self.pc_re, self.pc_im,
            self.cmass, self.cinv, self.d, self.slide, self.f, self.r_r, self.r_t, self.r_x,
            self.r_y, self.status, self.zprev, self.work, f64(b2 * dt), f64(0.5 * dt),
            f64((0.5 - b2) * dt), np.int32(b2 == 0.5), f64(dt), f64(self.kappa),
            f64(1.0 / self.kappa), np.int32(self.n // 2), np.int32(self.B), np.int32(self.m),
            np.int32(diag), self.keep, *damped))
