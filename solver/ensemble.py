"""Batched explicit integrator: B scenes that share K, M and dt advance as one (n, B) block.

A regime map is hundreds of scenes on one mesh and one material: dt depends on those only,
not on Omega, delta, f or the seed. So the scenes of such a group are the columns of (n, B)
arrays and each step reads the stiffness matrix once for all of them (one sparse matrix x
dense block product). Per-scene data: the contact parameters d, R Omega dt, f (vectors of
length B) and the initial state. Everything else is solver/fused.py's step, column by column:

    a*_n = -M^{-1} K u_n,  trial = u_n + dt v~_n + kappa a*_n,  r_n = project(trial; d, slide, f)
    a_n = a*_n + M^{-1} r_n,  v_n = v~_n + beta_2 dt a_n,  u_{n+1} = u_n + dt (v_n + dt/2 a_n)

Backends (``kernel``):

* ``"numba"`` (CPU default): ``solver._fused_kernels.batched_step``, the single-scene
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

from typing import Any

import numpy as np

KERNELS = ("numba", "cuda", "xp")


def array_namespace(backend: str) -> Any:
    """numpy for ``backend = "cpu"``, cupy for ``"gpu"`` (ImportError names the fix)."""
    if backend == "cpu":
        return np
    if backend == "gpu":
        try:
            import cupy
        except ImportError as err:  # pragma: no cover - depends on the machine
            raise ImportError("backend = \"gpu\" needs CuPy: pip install cupy-cuda12x (CUDA 12) "
                              "or cupy-cuda13x (CUDA 13); see README, 'GPU extra'") from err
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


class BatchedExplicit:
    """Explicit Newmark + forward-increment contact on (n, B) arrays (column b = scene b).

    After ``step()``: ``u`` is u_{n+1}; ``u_prev``, ``v``, ``a``, ``ku``, ``r_r``, ``r_t``,
    ``status`` are time level n (as ``solver.newmark.Newmark``); ``work`` (3, B) holds
    [work_contact, work_cylinder, friction_dissipation] (``work_totals()``).
    """

    def __init__(self, bp: BatchedProblem, d: np.ndarray, slide: np.ndarray, f: np.ndarray,
                 xp: Any = np, kernel: str = "numba") -> None:
        if kernel not in KERNELS:
            raise ValueError(f"kernel = {kernel!r}: use one of {KERNELS}")
        if kernel == "numba" and xp is not np:
            raise ValueError("the numba kernel runs on numpy arrays (backend cpu)")
        self.xp, self.kernel, self.bp = xp, kernel, bp
        n, B, m = bp.n, int(np.size(d)), int(bp.cx.size)
        self.B, self.n, self.m = B, n, m
        self.dt, self.beta2 = bp.dt, bp.beta2
        self.beta1 = 0.0
        self.kappa = (bp.beta2 + 0.5) * bp.dt * bp.dt
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
        self.work = z(3, B)
        self.acc = z(3, B)
        self.time = 0.0
        self.step_count = 0
        self.compile_s = 0.0
        self.active = np.ones(B, dtype=bool)
        slot = -np.ones(n // 2, dtype=np.int64)
        slot[bp.cx // 2] = np.arange(m)
        self.cslot = dev(slot)  # contact index of each node, -1 off the contact circle
        if kernel == "numba":
            from solver.fused import kernel as get_kernel

            self._fn = get_kernel("batched_step")
        elif kernel == "cuda":
            self._cuda_setup()
        else:
            self._xp_setup()

    # -------------------------------------------------------------------------------- state
    @property
    def u(self):
        return self._u[self.cur]

    @property
    def u_prev(self):
        return self._u[1 - self.cur]

    def set_state(self, u0: np.ndarray, v0: np.ndarray) -> None:
        """(n, B) initial displacement and velocity (predictor v~_0 = v_0: a start at rest)."""
        xp = self.xp
        self.u[...] = xp.asarray(u0)
        self.v[...] = xp.asarray(v0)
        self.v_pred[...] = self.v
        self.a.fill(0.0)
        cx = self.cx.astype(np.int64)
        self.zprev[:, 0, :] = self.u[cx]
        self.zprev[:, 1, :] = self.u[cx + 1]

    def mask(self, b: int) -> None:
        """Take scene ``b`` out of the batch: zero state and no contact (stays at rest)."""
        self.active[b] = False
        for arr in (*self._u, self.v, self.v_pred, self.a, self.ku, self.zprev):
            arr[..., b] = 0.0
        self.d[b] = 0.0

    def work_totals(self) -> np.ndarray:
        """(3, B) host array: work_contact, work_cylinder, friction_dissipation."""
        w = self.work if self.work.ndim == 2 else self.work.sum(axis=1)
        return np.asarray(w.get() if hasattr(w, "get") else w)

    # -------------------------------------------------------------------------------- step
    def keep_nodes(self, nodes: np.ndarray) -> None:
        """Nodes whose v_n, a_n, K u_n are needed after every step (probes); see ``step``."""
        keep = np.zeros(self.n // 2, dtype=np.int8)
        keep[np.asarray(nodes, dtype=np.int64)] = 1
        self.keep = self.xp.asarray(keep)

    def step(self, diag: bool = True) -> None:
        """One step. ``diag = False`` lets the CUDA kernel skip writing v_n, a_n and K u_n
        (3 of its 7 array writes) except at the ``keep_nodes``: the state u, v~ is the same;
        pass True before a step whose time level is sampled. The CPU kernels always write."""
        cur, nxt = self.cur, 1 - self.cur
        if self.kernel == "numba":
            from solver.fused import timed_first_call

            dt, b2 = self.dt, self.beta2
            args = (self.indptr, self.indices, self.data, self._u[cur], self._u[nxt], self.v,
                    self.v_pred, self.a, self.ku, self.nim, b2 * dt, 0.5 * dt,
                    (0.5 - b2) * dt, b2 == 0.5, dt, self.kappa, 1.0 / self.kappa, self.cx,
                    self.ph_re, self.ph_im, self.pc_re, self.pc_im, self.cmass, self.cinv,
                    self.d, self.slide, self.f, self.r_r, self.r_t, self.r_x, self.r_y,
                    self.status, self.zprev, self.work, self.acc, self.cslot)
            if self.step_count == 0:
                timed_first_call("batched_step", self._fn, *args)
                from solver.fused import COMPILE_SECONDS

                self.compile_s = COMPILE_SECONDS["batched_step"]
            else:
                self._fn(*args)
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
        self.status[...] = xp.where(inc, xp.where(slip | frictionless, 2, 1), 0)
        self.r_r[...] = rr
        self.r_t[...] = rt
        self.r_x[...] = rr * self.ph_re[:, None] - rt * self.ph_im[:, None]
        self.r_y[...] = rr * self.ph_im[:, None] + rt * self.ph_re[:, None]
        a[ix] = a[ix] + self.r_x * self.cinv[:, None]
        a[iy] = a[iy] + self.r_y * self.cinv[:, None]
        self.v[...] = a * (b2 * dt) + self.v_pred
        w = a * (0.5 * dt) + self.v
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
        self._kern = self._module.get_function("fused_step")
        nodes = self.n // 2
        self.cslot = self.cslot.astype(np.int32)
        self.keep = cupy.zeros(nodes, dtype=np.int8)
        self.work = cupy.zeros((3, self.m, self.B))  # per (node, scene): no atomics
        self._threads = 128
        self._blocks = (nodes * self.B + self._threads - 1) // self._threads

    def _cuda_step(self, u, u_next, diag: bool) -> None:  # pragma: no cover - GPU only
        dt, b2 = self.dt, self.beta2
        f64 = np.float64
        self._kern((self._blocks,), (self._threads,), (
            self.indptr, self.indices, self.data, u, u_next, self.v, self.v_pred, self.a,
            self.ku, self.nim, self.cslot, self.ph_re, self.ph_im, self.pc_re, self.pc_im,
            self.cmass, self.cinv, self.d, self.slide, self.f, self.r_r, self.r_t, self.r_x,
            self.r_y, self.status, self.zprev, self.work, f64(b2 * dt), f64(0.5 * dt),
            f64((0.5 - b2) * dt), np.int32(b2 == 0.5), f64(dt), f64(self.kappa),
            f64(1.0 / self.kappa), np.int32(self.n // 2), np.int32(self.B), np.int32(self.m),
            np.int32(diag), self.keep))


CUDA_SOURCE = r"""
// One explicit step for one (node, scene): the (x, y) rows of K u (even/odd partial sums, as
// solver/_fused_kernels.py), the contact projection when the node is on the contact circle,
// the Newmark update and the contact work. Arrays are (rows, B) row-major: consecutive
// threads are consecutive scenes, so every load is coalesced.
extern "C" __global__ void fused_step(
    const unsigned int* indptr, const unsigned int* indices, const double* data,
    const double* u, double* un, double* v, double* vp, double* a, double* ku,
    const double* nim, const int* cslot, const double* ph_re, const double* ph_im,
    const double* pc_re, const double* pc_im, const double* cmass, const double* cinv,
    const double* d, const double* slide, const double* f,
    double* r_r, double* r_t, double* r_x, double* r_y, signed char* status,
    double* zprev, double* work,
    const double c_v, const double c_w, const double c_p, const int b2_half,
    const double dt, const double kappa, const double inv_kappa,
    const int n_nodes, const int B, const int m, const int diag, const signed char* keep)
{
    long long tid = (long long)blockIdx.x * blockDim.x + threadIdx.x;
    if (tid >= (long long)n_nodes * B) return;
    const int p = (int)(tid / B);
    const int b = (int)(tid % B);
    const int i = 2 * p;
    const unsigned int a0 = indptr[i], a1 = indptr[i + 1];
    const unsigned int ln = a1 - a0;
    double s0e = 0.0, s0o = 0.0, s1e = 0.0, s1o = 0.0;
    unsigned int t = 0;
    for (; t + 1 < ln; t += 2) {
        const double c0 = u[(size_t)indices[a0 + t] * B + b];
        const double c1 = u[(size_t)indices[a0 + t + 1] * B + b];
        s0e += data[a0 + t] * c0;
        s0o += data[a0 + t + 1] * c1;
        s1e += data[a1 + t] * c0;
        s1o += data[a1 + t + 1] * c1;
    }
    if (t < ln) {
        const double c0 = u[(size_t)indices[a0 + t] * B + b];
        s0e += data[a0 + t] * c0;
        s1e += data[a1 + t] * c0;
    }
    const size_t ix = (size_t)i * B + b, iy = (size_t)(i + 1) * B + b;
    const double k0 = s0e + s0o, k1 = s1e + s1o;
    // v_n, a_n, K u_n are read only by the observers: written on sample steps (diag) and at
    // the probe nodes (keep); u_{n+1}, v~_{n+1} (the state) always
    const bool write = diag || keep[p];
    if (write) {
        ku[ix] = k0;
        ku[iy] = k1;
    }
    double ax = k0 * nim[i], ay = k1 * nim[i + 1];
    const int j = cslot[p];
    const double ux = u[ix], uy = u[iy];
    double rx = 0.0, ry = 0.0, rt = 0.0;
    if (j >= 0) {
        const double pr = pc_re[j], pi = pc_im[j];
        const double now_r = ux * pr - uy * pi;
        const double now_t = ux * pi + uy * pr;
        const double tx = vp[ix] * dt + ax * kappa;
        const double ty = vp[iy] * dt + ay * kappa;
        const double tr = (tx * pr - ty * pi) + now_r;
        const double tt = (tx * pi + ty * pr) + now_t;
        const double stiff = cmass[j] * inv_kappa;
        double rr = d[b] - tr;
        if (rr < 0.0) rr = 0.0;
        rr = rr * stiff;
        const bool inc = rr > 0.0;
        signed char st;
        const double fb = f[b];
        if (fb == 0.0) {
            rt = 0.0;
            st = inc ? 2 : 0;
        } else {
            rt = now_t + slide[b];
            rt = rt - tt;
            rt = rt * stiff;
            const double cone = rr * fb;
            if (fabs(rt) > cone) { rt = copysign(cone, rt); st = inc ? 2 : 0; }
            else { st = inc ? 1 : 0; }
        }
        const size_t jb = (size_t)j * B + b;
        r_r[jb] = rr;
        r_t[jb] = rt;
        status[jb] = st;
        rx = rr * ph_re[j] - rt * ph_im[j];
        ry = rr * ph_im[j] + rt * ph_re[j];
        r_x[jb] = rx;
        r_y[jb] = ry;
        ax = ax + rx * cinv[j];
        ay = ay + ry * cinv[j];
    }
    const double vx = ax * c_v + vp[ix], vy = ay * c_v + vp[iy];
    if (write) {
        a[ix] = ax;
        a[iy] = ay;
        v[ix] = vx;
        v[iy] = vy;
    }
    const double wx = ax * c_w + vx, wy = ay * c_w + vy;
    const double unx = wx * dt + ux, uny = wy * dt + uy;
    un[ix] = unx;
    un[iy] = uny;
    vp[ix] = b2_half ? wx : wx + ax * c_p;
    vp[iy] = b2_half ? wy : wy + ay * c_p;
    if (j >= 0) {
        const size_t zx = ((size_t)j * 2) * B + b, zy = ((size_t)j * 2 + 1) * B + b;
        const double dzx = unx - zprev[zx], dzy = uny - zprev[zy];
        zprev[zx] = ux;
        zprev[zy] = uy;
        const size_t jb = (size_t)j * B + b, mb = (size_t)m * B;
        work[jb] += 0.5 * (rx * dzx + ry * dzy);
        if (f[b] > 0.0) {
            const double wc = rt * slide[b];
            work[mb + jb] += wc;
            work[2 * mb + jb] += wc - 0.5 * (rt * (dzx * pc_im[j] + dzy * pc_re[j]));
        }
    }
}
"""


# ------------------------------------------------------------------------------ observers


class _Spool:
    """One recorded field of a batch: rows of shape (*inner, B) in chunks of ``chunk`` rows.

    A full chunk is turned scene-major (B, chunk, *inner) on the host and appended to a file
    (``path``) or kept in memory (``path = None``); ``read(b, n)`` returns scene b's first n
    rows, (n, *inner). Memory stays O(chunk x inner x B) with a file, whatever the run length.
    """

    def __init__(self, xp: Any, inner: tuple[int, ...], B: int, chunk: int, dtype,
                 path=None) -> None:
        self.xp, self.inner, self.B, self.chunk, self.dtype = xp, inner, B, chunk, dtype
        self.buf = xp.zeros((chunk, *inner, B), dtype=dtype)
        self.path = path
        self.fh = open(path, "wb") if path is not None else None  # noqa: SIM115
        self.mem: list[np.ndarray] = []
        self.rows = 0  # rows written (including the ones still in buf)
        self.n_chunks = 0

    def row(self):
        """The buffer row to fill next (flushes a full chunk first)."""
        i = self.rows % self.chunk
        if i == 0 and self.rows:
            self._flush()
        self.rows += 1
        return self.buf[i]

    def _flush(self) -> None:
        blk = self.xp.moveaxis(self.buf, -1, 0)
        host = np.ascontiguousarray(blk.get() if hasattr(blk, "get") else blk)
        if self.fh is not None:
            host.tofile(self.fh)
        else:
            self.mem.append(host)
        self.n_chunks += 1
        self.buf.fill(0)

    def close(self) -> None:
        """Flush the last (partial) chunk; afterwards ``read`` works."""
        if self.rows > self.n_chunks * self.chunk:
            self._flush()
        if self.fh is not None:
            self.fh.close()
            self.fh = None

    def read(self, b: int, n: int) -> np.ndarray:
        if self.n_chunks == 0:
            return np.zeros((0, *self.inner), dtype=self.dtype)
        shape = (self.n_chunks, self.B, self.chunk, *self.inner)
        if self.path is not None:
            data = np.memmap(self.path, dtype=self.dtype, mode="r", shape=shape)[:, b]
        else:
            data = np.stack([c[b] for c in self.mem])
        return np.array(data.reshape(-1, *self.inner)[:n])


class BatchRecorder:
    """The observers of ``solver.run.Simulation`` for a batch, scene by scene.

    Samples (every ``every`` steps, time level n): u_r, u_theta, v_r, v_theta, r_r, r_theta
    and the status at the contact nodes in angle order ``perm``, the energies (kinetic,
    strain, the three works); probes (every step): u_n and v_n (x, y) at the probe nodes.
    ``arrays(b)`` / ``probe_arrays(b)`` return exactly the dictionaries of
    ``InnerCircleRecorder.arrays`` / ``ProbeRecorder.arrays`` for scene b.
    """

    def __init__(self, integ: BatchedExplicit, *, mass: np.ndarray, perm: np.ndarray,
                 theta: np.ndarray, ds: np.ndarray, every: int, max_samples: int,
                 max_steps: int, probe_nodes: np.ndarray, probe_pc: np.ndarray,
                 probe_deg: np.ndarray, spool_dir=None, chunk: int = 16) -> None:
        xp, B, m = integ.xp, integ.B, integ.m
        self.integ, self.xp = integ, xp
        self.every, self.max_samples, self.max_steps = max(1, every), max_samples, max_steps
        self.mass = xp.asarray(mass)[:, None]
        self.scratch = xp.zeros((integ.n, B))
        self.perm = xp.asarray(np.asarray(perm, dtype=np.int64))
        self.theta, self.ds = theta, ds
        pd = 2 * np.asarray(probe_nodes, dtype=np.int64)
        self.probe_rows = xp.asarray(np.concatenate([pd, pd + 1]))  # x dofs, then y dofs
        self.probe_pc, self.probe_deg = probe_pc, probe_deg
        self.n = 0
        self.n_probe = 0
        self.t = np.zeros(max_samples)
        self.probe_t = np.zeros(max_steps + 1)
        path = (lambda name: None) if spool_dir is None else (lambda name: spool_dir / name)
        npb = len(probe_nodes)
        self.fields = _Spool(xp, (6, m), B, chunk, np.float64, path("fields.f64"))
        self.status = _Spool(xp, (m,), B, chunk, np.int8, path("status.i8"))
        # kinetic, strain, 3 works, damping work (0: batched scenes are undamped), as
        # solver.observers.ENERGY_FIELDS
        self.energies = _Spool(xp, (6,), B, chunk, np.float64, path("energies.f64"))
        self.probes = _Spool(xp, (4, npb), B, 16 * chunk, np.float64, path("probes.f64"))
        self.cx_sorted = integ.cx.astype(np.int64)[self.perm]
        self.pc_sorted = xp.asarray(integ.phase_conj)[self.perm]
        self.z = xp.zeros((B, m), dtype=np.complex128)
        self.initial = np.full(B, np.nan)
        self.bound = np.full(B, np.inf)

    def due(self, step: int) -> bool:
        return step % self.every == 0 and self.n < self.max_samples

    def record_probes(self) -> None:
        """u_n and v_n at the probe nodes, every step (ProbeRecorder.record)."""
        if self.n_probe >= self.probe_t.size:
            return
        it = self.integ
        self.probe_t[self.n_probe] = it.time - it.dt
        row = self.probes.row()
        k = row.shape[1]
        self.xp.take(it.u_prev, self.probe_rows, axis=0, out=row[:2].reshape(2 * k, -1))
        self.xp.take(it.v, self.probe_rows, axis=0, out=row[2:].reshape(2 * k, -1))
        self.n_probe += 1

    def sample(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Record time level n; returns host (kinetic, strain, work_cylinder) per scene."""
        it, xp = self.integ, self.xp
        cx = self.cx_sorted
        row = self.fields.row()
        z = self.z
        for k, arr in ((0, it.u_prev), (2, it.v)):
            # (B, m) complex rows times e^{-i theta}: the same ufunc loop as the single run's
            # ``NodalFrames.polar_at_nodes``, hence the same bits (numpy's SIMD complex
            # multiply may fuse multiply-adds)
            z.real[...] = arr[cx].T
            z.imag[...] = arr[cx + 1].T
            z *= self.pc_sorted
            row[k] = z.real.T
            row[k + 1] = z.imag.T
        row[4] = it.r_r[self.perm]
        row[5] = it.r_t[self.perm]
        self.status.row()[...] = it.status[self.perm]
        e = self.energies.row()  # kinetic, strain, the three works (on the device)
        xp.multiply(it.v, self.mass, out=self.scratch)
        e[0] = xp.einsum("ib,ib->b", self.scratch, it.v)
        e[1] = xp.einsum("ib,ib->b", it.u_prev, it.ku)
        e[:2] *= 0.5
        e[2:5] = it.work if it.work.ndim == 2 else it.work.sum(axis=1)
        e[5] = 0.0
        self.t[self.n] = it.time - it.dt
        self.n += 1
        host = e[:4].get() if hasattr(e, "get") else e[:4]  # one device -> host copy
        return host[0], host[1], host[3]

    def check_health(self, kin: np.ndarray, strain: np.ndarray, w_cyl: np.ndarray,
                     time_now: float) -> dict[int, str]:
        """``Simulation._check_health`` for every active scene: {b: message} of new blow-ups."""
        total = kin + strain
        out: dict[int, str] = {}
        for b in np.flatnonzero(self.integ.active):
            tb = float(total[b])
            if not np.isfinite(tb):
                out[int(b)] = f"non-finite energy at t = {time_now:.6g} s"
                continue
            if np.isnan(self.initial[b]):
                self.initial[b] = tb
                self.bound[b] = 1e4 * max(tb, 1e-300)
                continue
            fed = self.initial[b] + abs(float(w_cyl[b]))
            if tb > self.bound[b] and tb > 10.0 * fed:
                out[int(b)] = (
                    f"energy {tb:.3g} J/m exceeds 1e4 x the initial energy and 10 x the energy "
                    f"fed by the cylinder ({fed:.3g} J/m) at t = {time_now:.6g} s: the "
                    "time scheme is unstable here; reduce time.dt_fraction")
        return out

    def close(self) -> None:
        for s in (self.fields, self.status, self.energies, self.probes):
            s.close()

    def arrays(self, b: int, n: int | None = None) -> dict[str, np.ndarray]:
        """Scene b's ``InnerCircleRecorder.arrays()`` (its first n samples)."""
        n = self.n if n is None else n
        f = self.fields.read(b, n)
        return {"t": self.t[:n].copy(), "theta": self.theta, "u_r": f[:, 0],
                "u_theta": f[:, 1], "v_r": f[:, 2], "v_theta": f[:, 3],
                "status": self.status.read(b, n), "energies": self.energies.read(b, n),
                "r_r": f[:, 4], "r_theta": f[:, 5], "ds": self.ds}

    def probe_arrays(self, b: int, n: int | None = None) -> dict[str, np.ndarray]:
        """Scene b's ``ProbeRecorder.arrays()`` (its first n steps)."""
        n = self.n_probe if n is None else n
        p = self.probes.read(b, n)  # (n, 4, n_probes)
        zu = (p[:, 0] + 1j * p[:, 1]) * self.probe_pc
        zv = (p[:, 2] + 1j * p[:, 3]) * self.probe_pc
        data = np.stack([zu.real, zu.imag, zv.real, zv.imag], axis=-1).transpose(1, 0, 2)
        return {"probe_t": self.probe_t[:n].copy(), "probe_deg": self.probe_deg,
                "probe_data": data}
