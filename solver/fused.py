"""Fused explicit step: K u, the Newmark update, the contact projection and the contact work
in one compiled pass (numba), for one scene (``FusedNewmark``) and for a batch of scenes that
share K and M (``batched_step``, used by ``solver.ensemble``).

The arithmetic is the one of the numpy reference (``solver.newmark.Newmark`` +
``solver.contact.ContactProjection`` + ``solver.contact.project_contact`` +
``solver.observers.EnergyAccumulator``), element by element, with beta_2 and kappa of the
paper's explicit scheme (solver/newmark.py docstring):

    a*_n   = -M^{-1} K u_n
    trial  = u_n + dt v~_n + kappa a*_n                    (contact nodes, polar frame)
    r_n    = project(trial; d, R Omega dt, f)              (paper section 2, [CAR 91])
    a_n    = a*_n + M^{-1} r_n
    v_n    = v~_n + beta_2 dt a_n,   w = v_n + dt/2 a_n
    u_{n+1} = u_n + dt w,            v~_{n+1} = w + (1/2 - beta_2) dt a_n

With Kelvin-Voigt damping C = tau K (``solver.newmark.DampedNewmark``) the internal force
is K w_n, w_n = u_n + tau v~_n, in place of K u_n (one product), the contact step is
unchanged, and the kernel also sums the damping work's per-step part
1/2 (K w_n . u_{n+1} - K w_n . u_{n-1}) (``solver.observers.DampingWork``; u_{n-1} is the
spare half of the double buffer before u_{n+1} overwrites it); ``FusedDampingWork`` closes
it at the samples with K u_n.

Only the summation order of K u (CSR order here, PETSc's order in MatMult) and of the work
sums (sequential here, BLAS in ``np.vdot``) differ, so the two kernels agree to round-off
(tests/test_fused.py). The single-scene and the batched kernel share the per-node functions
below and sum in the same order, so a scene gives *bitwise* the same numbers alone or in a
batch, whatever the batch size.

MPI: the kernel works on the local arrays (owned + ghost dofs, local column numbering); the
ghost values of u_n are refreshed by PETSc (``Vec.ghostUpdate``) before each step.

numba compiles on the first call (~1-3 s per kernel) and caches the machine code on disk
(``cache=True``): in the package's ``__pycache__`` when it is writable, else in
``$NUMBA_CACHE_DIR``, which ``_cache_dir`` sets to a user cache directory (Docker images with
a read-only package directory). ``COMPILE_SECONDS`` records the cost of the first call.
"""

from __future__ import annotations

import math
import os
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from stickslip.solver.contact.law import forward_increment_factor
from stickslip.solver.newmark import ExplicitStart

COMPILE_SECONDS: dict[str, float] = {}
"""Wall time of the first (compiling or cache-loading) call of each kernel, seconds."""


def _cache_dir() -> None:
    """Point numba's cache to a writable directory when the package directory is not."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return
    here = Path(__file__).resolve().parent
    if os.access(here, os.W_OK):
        return
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    for root in (base, tempfile.gettempdir()):
        path = Path(root) / "stickslip-numba"
        try:
            path.mkdir(parents=True, exist_ok=True)
        except OSError:
            continue
        if os.access(path, os.W_OK):
            os.environ["NUMBA_CACHE_DIR"] = str(path)
            return


def numba_available() -> bool:
    """True when numba imports (Debian's python3-numba is in the apt list)."""
    try:
        _cache_dir()
        import numba  # noqa: F401
    except ImportError:
        return False
    return True


# ------------------------------------------------------------------------------ kernels

def _kernels():
    """The kernels module, imported (and numba with it) on first use."""
    _cache_dir()
    # numba (0.3 s) with the compiled step only: the numpy kernel runs without it
    from stickslip.solver import _fused_kernels

    return _fused_kernels


def sample_kernels():
    """The batch records' copies module (``solver._sample_kernels``), imported on first use
    with numba's cache where ``_kernels`` has it."""
    _cache_dir()
    # numba (0.3 s) with the compiled step only: the numpy kernel runs without it
    from stickslip.solver import _sample_kernels

    return _sample_kernels


def friction_bound(law) -> tuple[int, float, float]:
    """(code, rate_slip, rate_base) of ``law``'s friction bound for the kernels
    (``solver.contact.ContactLaw.kernel_bound``; the 1-2-1 filtered bound is not in them)."""
    return law.kernel_bound()


def kernel(name: str):
    """The compiled kernel ``name`` ("single_step", "batched_step", "batched_step_long")."""
    return getattr(_kernels(), name)


@contextmanager
def slp_vectorize() -> Iterator[None]:
    """Compile inside this block with LLVM's SLP vectoriser on (numba's default is off).

    ``batched_step`` keeps 4 scenes' partial sums in scalar locals (``half_product4``);
    only the SLP vectoriser packs them into 4-wide registers (the loop vectoriser cannot:
    the lanes are not a loop). numba reads ``config.SLP_VECTORIZE`` when it builds the
    pass pipeline of a compilation, so the flag is set around the kernel's first call and
    restored after it; a cache load is unaffected. SLP packs identical scalar operations
    and does not reorder floating-point ones (no fast-math), so the bits cannot change:
    tests/test_ensemble.py checks the batch bitwise against ``single_step``, which is
    compiled without it. (numba turned SLP off by default after LLVM miscompilations,
    numba PR #8852; that bitwise test is the guard here.)
    """
    from numba.core import config

    old = getattr(config, "SLP_VECTORIZE", None)
    if old is None:  # a numba without the flag: compile as it does (slower, same bits)
        yield
        return
    config.SLP_VECTORIZE = 1
    try:
        yield
    finally:
        config.SLP_VECTORIZE = old


def timed_first_call(name: str, fn, *args):
    """``fn(*args)``; the first call of kernel ``name`` is timed (compile or cache load)."""
    if name in COMPILE_SECONDS:
        return fn(*args)
    t0 = time.perf_counter()
    out = fn(*args)
    COMPILE_SECONDS[name] = time.perf_counter() - t0
    return out


# ------------------------------------------------------------------------------ local CSR


def local_csr(problem) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(indptr, indices, data, ghosts) of K's owned rows in LOCAL column numbering.

    Local numbering: owned dofs 0 .. n_owned - 1, then the off-process columns of the owned
    rows ("ghosts", sorted by global index), so the columns index an array of owned + ghost
    values. The ghosts come from K itself, not from the dofmap: with dolfinx's default ghost
    mode, rows on the partition boundary also couple to dofs of cells the rank does not hold.
    ``ghosts`` are their global indices (for ``PETSc.Vec.createGhostWithArray``).
    """
    indptr, cols, data = problem.K.getValuesCSR()
    r0, r1 = problem.K.getOwnershipRange()
    n_owned = problem.n_owned
    if r1 - r0 != n_owned:
        raise RuntimeError(f"K owns {r1 - r0} rows, the space {n_owned} dofs")
    cols = np.asarray(cols, dtype=np.int64)
    local = cols - r0
    outside = (local < 0) | (local >= n_owned)
    ghosts = np.unique(cols[outside])
    local[outside] = n_owned + np.searchsorted(ghosts, cols[outside])
    indptr = np.asarray(indptr, dtype=np.int64)
    lengths = np.diff(indptr)
    paired = n_owned % 2 == 0 and np.array_equal(lengths[0::2], lengths[1::2])
    if paired:
        ln = lengths[0::2]
        offs = np.arange(ln.sum()) - np.repeat(np.cumsum(ln) - ln, ln)
        paired = np.array_equal(local[np.repeat(indptr[0:-1:2], ln) + offs],
                                local[np.repeat(indptr[1::2], ln) + offs])
    if not paired:
        raise RuntimeError("the fused kernel needs the (x, y) rows of a node to share their "
                           "column pattern (a blocked bs = 2 space); use time.kernel = numpy")
    # unsigned indices: numba then skips its negative-index wrap-around test (2x faster K u)
    return (np.ascontiguousarray(indptr, dtype=np.uint32),
            np.ascontiguousarray(local, dtype=np.uint32),
            np.ascontiguousarray(data, dtype=np.float64), ghosts)


# ------------------------------------------------------------------------------ single scene


class FusedNewmark(ExplicitStart):
    """Explicit Newmark + forward-increment contact as ONE compiled call per step.

    A ``solver.stepper.Stepper`` with the arrays of ``solver.newmark.Newmark``
    (``u``, ``u_prev``, ``v``, ``a``, ``ku``, ``kappa``) plus ``work`` = [work_contact,
    work_cylinder, friction_dissipation] of the owned contact nodes (``FusedEnergy`` reads
    it). The contact forces and statuses are written into the ``projection``'s arrays
    (``solver.contact.ContactProjection``), so every observer works unchanged. ``advance``
    runs the steps between two observations as one compiled call when its only step hook is
    the probe recorder and the run has one rank.

    ``tau > 0``: Kelvin-Voigt damping, ``DampedNewmark``'s step (``damped``; ``kw`` = K w_n
    applied, ``ku`` = K u_n after ``refresh_ku``, work[3] the damping work's step sum, which
    ``FusedDampingWork`` reads).
    """

    kernel = "numba"
    #: What the next step reads: ``ExplicitStart``'s arrays, u_{n-1} at the contact nodes
    #: (``zprev``) and the work sums; a regularised bound's state is the projection's.
    STATE = (*ExplicitStart.STATE, "zprev", "work")

    def __init__(self, problem, dt: float, beta2: float, projection, tau: float = 0.0) -> None:
        if not 0.5 <= beta2 <= 1.0:
            raise ValueError(f"time.beta2 = {beta2} must be in [0.5, 1]")
        if not (math.isfinite(tau) and tau >= 0.0):
            raise ValueError(f"damping tau = {tau} must be a finite number >= 0 (s)")
        self.beta1, self.beta2, self.dt = 0.0, beta2, dt
        self.tau = float(tau)
        self.damped = self.tau > 0.0
        self.kappa = forward_increment_factor(beta2, dt)
        self.p = projection
        self.comm = problem.comm
        n = problem.n_owned
        self.indptr, self.indices, self.data, ghosts = local_csr(problem)
        n_local = n + ghosts.size
        self._full = [np.zeros(n_local), np.zeros(n_local)]  # u_n, u_{n+1} (owned + ghosts)
        self._views = [f[:n] for f in self._full]
        # damped: w_n = u_n + tau v~_n, the argument of K, and w_{n+1}, which the kernel
        # writes (owned + ghosts; alternating as u); else unused
        self._w = [np.zeros(n_local if self.damped else 0) for _ in range(2)]
        self._ghosted = self._ghosted_w = None
        if self.comm.size > 1:
            from petsc4py import PETSc

            def ghosted(f):
                return PETSc.Vec().createGhostWithArray(
                    ghosts.astype(PETSc.IntType), f, size=(n, problem.n_global_dofs),
                    comm=self.comm)

            self._ghosted = [ghosted(f) for f in self._full]
            if self.damped:
                self._ghosted_w = [ghosted(f) for f in self._w]
        self.cur = 0
        self.v = np.zeros(n)
        self.a = np.zeros(n)
        self.v_pred = np.zeros(n)
        self.ku = np.zeros(n)  # K u_n (damped: after ``refresh_ku``)
        self.kw = np.zeros(n) if self.damped else self.ku  # the applied K w_n (damped)
        self.nim = -problem.inv_mass
        # contact work, cylinder work, friction dissipation, and the damping work's step sum
        # Σ 1/2 K w_m . (u_{m+1} - u_{m-1}) (``FusedDampingWork``)
        self.work = np.zeros(4)
        p = projection
        self.cx = np.ascontiguousarray(problem.nodes.dofs_x, dtype=np.uint32)
        self.ph_re, self.ph_im = p.phase.real.copy(), p.phase.imag.copy()
        self.pc_re, self.pc_im = p.phase_conj.real.copy(), p.phase_conj.imag.copy()
        self.cmass = np.ascontiguousarray(p.mass)
        self.cinv = np.ascontiguousarray(p.inv_mass)
        # the projection's r_r, r_t, r_x, r_y: strided views of its complex arrays
        r_pol, r_xy = p.r_polar.view(np.float64), p.r_xy.view(np.float64)
        self.reactions = (r_pol[0::2], r_pol[1::2], r_xy[0::2], r_xy[1::2])
        self.zprev = np.zeros(2 * self.cx.size)  # u_{n-1} at the contact nodes (x, y)
        # a regularised friction bound: its per-node state is the projection's own
        # (``EffectivePressure``: sigma_eff, the last u_theta), updated by the kernel
        self.reg, self.rate_slip, self.rate_base = friction_bound(p.law)
        m = self.cx.size
        if self.reg:
            self.sigma = p.effective.sigma.reshape(m, 1)
            self.ut_last = p.effective.u_t_last.reshape(m, 1)
        else:
            self.sigma = self.ut_last = np.zeros((0, 1))
        self._started = np.zeros(1, dtype=np.int64)  # 0 until the first step
        self._first_call = True  # of ``single_step`` by this stepper
        self.time = 0.0
        self.step_count = 0
        self._fn = kernel("single_step")
        self._advance = kernel("advance") if self._ghosted is None else None
        self._product = kernel("stiffness_product")  # K u_n at a damped step's samples
        self._clock = np.zeros(1)  # the time, as the kernel accumulates it (time += dt)
        self.compile_s = 0.0
        self.contact = None
        self._init_hooks()

    @property
    def u(self) -> np.ndarray:
        """u_{n+1} after a step (owned dofs)."""
        return self._views[self.cur]

    @property
    def u_prev(self) -> np.ndarray:
        """u_n after a step (owned dofs)."""
        return self._views[1 - self.cur]

    def set_state(self, u: np.ndarray, v: np.ndarray, a0: np.ndarray | None = None) -> None:
        """As ``Newmark.set_state``; also u_{n-1} := u_0 for the contact work and, in the
        spare half of the double buffer (which the damped step reads as u_{n-1} before it
        writes u_{n+1} there), for the damping work (``DampingWork``'s u_{-1} := u_0)."""
        super().set_state(u, v, a0)
        self.u_prev[:] = u
        cx = self.cx.astype(np.intp)
        self.zprev[0::2] = self.u[cx]
        self.zprev[1::2] = self.u[cx + 1]
        self._form_w()

    def restore(self, state: dict[str, np.ndarray]) -> None:
        """``ExplicitStart.restore``; past the first step the kernel's start flag is set."""
        super().restore(state)
        self._started[0] = int(self.step_count > 0)
        self._form_w()

    def _form_w(self) -> None:
        """Damped: w_n = u_n + tau v~_n on the owned dofs, with the kernel's operations (the
        kernel forms each later w_{n+1} itself)."""
        if self.damped:
            w = self._w[self.cur][:self.nim.size]
            np.multiply(self.v_pred, self.tau, out=w)
            w += self._views[self.cur]

    def _args(self, cur: int) -> tuple:
        """``single_step``'s arguments from the CSR matrix on (same order, same values), with
        u_n (and w_n) in buffer ``cur`` of the double buffers."""
        p, dt, b2, nxt = self.p, self.dt, self.beta2, 1 - cur
        return (self.indptr, self.indices, self.data, self.nim.size, self._full[cur],
                self._full[nxt], self.v, self.v_pred, self.a, self.kw, self.nim, b2 * dt,
                0.5 * dt, (0.5 - b2) * dt, b2 == 0.5, dt, self.kappa, 1.0 / self.kappa,
                self.cx, self.ph_re, self.ph_im, self.pc_re, self.pc_im, self.cmass,
                self.cinv, p.d, p.slide, p.f, *self.reactions, p.out.status, self.zprev,
                self.work, self._w[cur], self._w[nxt], self.tau, self.reg, self.sigma,
                self.ut_last, self.rate_slip, self.rate_base, self._started)

    def step(self) -> None:
        """u_n -> u_{n+1}: one ghost update (MPI) and one kernel call. Damped, the ghosts
        K reads are those of w_n = u_n + tau v~_n, which the previous step (or
        ``set_state``) formed on the owned dofs."""
        cur, nxt = self.cur, 1 - self.cur
        if self._ghosted is not None:
            from petsc4py import PETSc

            ghosted = self._ghosted_w if self.damped else self._ghosted
            ghosted[cur].ghostUpdate(PETSc.InsertMode.INSERT, PETSc.ScatterMode.FORWARD)
        args = self._args(cur)
        if self._first_call:  # timed (a compile or a cache load), also when continued
            self._first_call = False
            timed_first_call("single_step", self._fn, *args)
            self.compile_s = COMPILE_SECONDS["single_step"]
        else:
            self._fn(*args)
        self.cur = nxt
        self.time += self.dt
        self.step_count += 1

    def stiffness_of(self, index: int, out: np.ndarray) -> None:
        """out = K u for the buffer ``index`` of the double buffer (owned rows; its ghosts
        refreshed first on several ranks), in the kernel's summation order. Collective."""
        if self._ghosted is not None:
            from petsc4py import PETSc

            self._ghosted[index].ghostUpdate(PETSc.InsertMode.INSERT,
                                             PETSc.ScatterMode.FORWARD)
        self._product(self.indptr, self.indices, self.data, self.nim.size, self._full[index],
                      out)

    def refresh_ku(self) -> None:
        """ku = K u_n (u_n is ``u_prev`` after a step): the damped step applies K w_n, so the
        strain energy at a sample needs this one extra product (``DampedNewmark``'s)."""
        self.stiffness_of(1 - self.cur, self.ku)

    def facts(self) -> dict:
        """Scheme facts for the run summary (``solver.stepper.Stepper``)."""
        return {"scheme": "explicit", "beta1": 0.0, "beta2": self.beta2,
                "damping_tau_s": self.tau,
                "contact_s": 0.0, "kernel": "numba", "kernel_first_call_s": self.compile_s}

    @property
    def compiled_loop(self) -> bool:
        """``advance`` runs as one compiled call: one rank (several ranks need a ghost update
        per step) and no step hook but the probe recorder, which the kernel records."""
        hooks = self.hooks
        return self._ghosted is None and (len(hooks) == 1
                                          and hasattr(hooks[0], "kernel_buffers"))

    def compiled_recorder(self):
        """``_fused_kernels.record_sample`` while ``compiled_loop`` holds, else None."""
        return kernel("record_sample") if self.compiled_loop else None

    def advance(self, n: int, t_stop: float = math.inf) -> int:
        """Up to ``n`` steps, stopping before a step once ``time >= t_stop``; returns the
        steps taken. With ``compiled_loop`` they are ONE call of ``_fused_kernels.advance``,
        which records the probes every step as ``ProbeRecorder.after_step`` would: the same
        arithmetic as ``n`` calls of ``step`` (bitwise: the kernel calls ``single_step``)."""
        if not self.compiled_loop:
            return super().advance(n, t_stop)
        probes = self.hooks[0]
        n_max = n
        self._clock[0] = self.time
        taken = timed_first_call(
            "advance", self._advance, n_max, t_stop, self._clock,
            *self._args(self.cur),
            *probes.kernel_buffers())
        self.compile_s = sum(COMPILE_SECONDS.get(k, 0.0) for k in ("single_step", "advance"))
        probes.n = int(probes.count[0])
        self.time = float(self._clock[0])
        self.step_count += taken
        self.cur = (self.cur + taken) % 2
        return taken


class FusedEnergy:
    """``EnergyAccumulator`` for ``FusedNewmark``: the kernel accumulates the work itself,
    so this is no step hook; it only reads the kernel's sums."""

    def __init__(self, integrator: FusedNewmark, projection) -> None:
        self.integ = integrator
        self.p = projection

    def state(self) -> dict[str, np.ndarray]:
        """Nothing of its own: the sums are the stepper's ``work``."""
        return {}

    def restore(self, state: dict[str, np.ndarray]) -> None:
        pass

    @property
    def work_contact(self) -> float:
        return float(self.integ.work[0])

    @property
    def work_cylinder(self) -> float:
        return float(self.integ.work[1])

    @property
    def friction_dissipation(self) -> float:
        return float(self.integ.work[2])

    def totals(self, comm) -> tuple[float, float, float]:
        """(work_contact, work_cylinder, friction_dissipation) summed over ranks."""
        if comm.size == 1:  # one rank: the sum is the local value (no Allreduce)
            w = self.integ.work
            return float(w[0]), float(w[1]), float(w[2])
        from mpi4py import MPI

        total = np.zeros(3)
        comm.Allreduce(self.integ.work[:3], total, op=MPI.SUM)
        return float(total[0]), float(total[1]), float(total[2])


class FusedDampingWork:
    """``solver.observers.DampingWork`` for a damped ``FusedNewmark``: the kernel sums
    Σ_m 1/2 K w_m . (u_{m+1} - u_{m-1}) itself (``work[3]``), so this is no step hook and
    the compiled time loop stays. At a sample (``ku`` = K u_n refreshed)

        W_d = work[3] - 1/2 (u_{n+1} . K u_n - u_0 . K u_0)

    on this rank's dofs, with the dot products summed in row order (``sequential_dot``; a
    batch sums each column in the same order: ``BatchedExplicit.damping_work_totals``)."""

    def __init__(self, integrator: FusedNewmark, u0: np.ndarray) -> None:
        self.integ = integrator
        ku0 = np.zeros(integrator.nim.size)
        integrator.stiffness_of(integrator.cur, ku0)  # the buffer holding u_0 before a step
        self._dot = kernel("sequential_dot")
        self.u0_ku0 = float(self._dot(np.ascontiguousarray(u0), ku0))

    def state(self) -> dict[str, np.ndarray]:
        """u_0 . K u_0 of the run's start (the step sums are the stepper's ``work``)."""
        return {"u0_ku0": np.float64(self.u0_ku0)}

    def restore(self, state: dict[str, np.ndarray]) -> None:
        self.u0_ku0 = float(state["u0_ku0"])

    def local_total(self, integrator: FusedNewmark) -> float:
        """W_d up to level n on this rank's dofs; needs ``integrator.ku`` = K u_n."""
        return float(integrator.work[3]) - 0.5 * (
            float(self._dot(integrator.u, integrator.ku)) - self.u0_ku0)

    def at_sample(self, integrator: FusedNewmark) -> float:
        """W_d up to level n on this rank's dofs, K u_n refreshed first."""
        integrator.refresh_ku()  # the damped step forms K (u + tau v~), not K u
        return self.local_total(integrator)
