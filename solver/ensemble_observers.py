"""Observers of a batch (``solver.ensemble``): per-scene samples and probes of B scenes,
kept whole in host memory (``spool_dir = None`` on the CPU; the caller checks that the record
fits, ``BatchRecorder.record_bytes``) or spooled to disk in chunks, so that memory does not
grow with the run length."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from solver.errors import blown_up, blowup_message, energy_bound

if TYPE_CHECKING:  # pragma: no cover
    from solver.ensemble import BatchedExplicit


class _Spool:
    """One recorded field of a batch: rows of shape (B, *inner) in chunks of ``chunk`` rows.

    The chunk buffer is scene-major, (B, chunk, *inner): a row is a (B, *inner) view whose
    scene rows are contiguous (a row written scene-last, the scene index innermost, cost ~4x
    more per sample), and a full chunk is appended to a file (``path``) or kept in memory
    (``path = None``) as it is, without a transposed copy; ``read(b, n)`` returns scene b's
    first n rows, (n, *inner). Memory stays O(chunk x inner x B) with a file, whatever the
    run length.
    """

    def __init__(self, xp: Any, inner: tuple[int, ...], B: int, chunk: int, dtype,
                 path=None) -> None:
        self.xp, self.inner, self.B, self.chunk, self.dtype = xp, inner, B, chunk, dtype
        self.buf = xp.zeros((B, chunk, *inner), dtype=dtype)  # scene-major: no transpose
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
        return self.buf[:, i]

    def _flush(self) -> None:
        if self.fh is not None:
            (self.buf.get() if hasattr(self.buf, "get") else self.buf).tofile(self.fh)
        else:
            self.mem.append(self.buf.get() if hasattr(self.buf, "get") else self.buf.copy())
        self.n_chunks += 1  # rows of a partial last chunk past ``rows`` are never read

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


class _Record:
    """One recorded field of a batch, whole and in host memory, scene-major:
    (B, rows, *inner). ``row()`` is a (B, *inner) view of the next row, the layout of
    ``_Spool.row``, so the observers write straight into each scene's own block: no chunk,
    no flush, no transposed copy; ``read(b, n)`` is one contiguous slice."""

    def __init__(self, inner: tuple[int, ...], B: int, rows: int, dtype) -> None:
        self.data = np.zeros((B, rows, *inner), dtype=dtype)  # untouched pages cost nothing
        self.rows = 0

    def row(self) -> np.ndarray:
        view = self.data[:, self.rows]
        self.rows += 1
        return view

    def close(self) -> None:
        pass

    def read(self, b: int, n: int) -> np.ndarray:
        return np.array(self.data[b, :n])


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
        self.scratch = None  # (n, B), for the energies of steps the kernel did not sum
        self.perm = xp.asarray(np.asarray(perm, dtype=np.int64))
        self.theta, self.ds = theta, ds
        pd = 2 * np.asarray(probe_nodes, dtype=np.int64)
        self.probe_rows = xp.asarray(np.concatenate([pd, pd + 1]))  # x dofs, then y dofs
        self.probe_scratch = xp.zeros((2 * self.probe_rows.size, B))  # u rows, then v rows
        self.probe_pc, self.probe_deg = probe_pc, probe_deg
        self.n = 0
        self.n_probe = 0
        self.t = np.zeros(max_samples)
        self.probe_t = np.zeros(max_steps + 1)
        npb = len(probe_nodes)

        def store(name: str, inner: tuple[int, ...], dtype, rows: int, chunk_rows: int):
            if spool_dir is None and xp is np:  # the whole record, in host memory
                return _Record(inner, B, rows, dtype)
            path = None if spool_dir is None else spool_dir / name  # chunks (file or host)
            return _Spool(xp, inner, B, chunk_rows, dtype, path)

        self.fields = store("fields.f64", (6, m), np.float64, max_samples, chunk)
        self.status = store("status.i8", (m,), np.int8, max_samples, chunk)
        # kinetic, strain, 3 works, the Kelvin-Voigt work W_d (0 undamped), as
        # solver.observers.ENERGY_FIELDS
        self.energies = store("energies.f64", (6,), np.float64, max_samples, chunk)
        self.probes = store("probes.f64", (4, npb), np.float64, max_steps + 1, 16 * chunk)
        self.cx_sorted = integ.cx.astype(np.int64)[self.perm]
        self.pc_sorted = xp.asarray(integ.phase_conj)[self.perm]
        self.z = xp.zeros((B, m), dtype=np.complex128)
        self.initial = np.full(B, np.nan)
        self.bound = np.full(B, np.inf)

    @staticmethod
    def record_bytes(B: int, m: int, n_probes: int, max_samples: int, max_steps: int) -> int:
        """Bytes of a whole batch record: the fields (6 x m doubles), status (m bytes) and
        energies (6 doubles) of every sample, and the probes (4 doubles each) of every step.
        A caller keeps the record in memory (``spool_dir = None``) when this fits."""
        per_sample = 8 * 6 * m + m + 8 * 6
        return int(B * (max_samples * per_sample + (max_steps + 1) * 8 * 4 * n_probes))

    def due(self, step: int) -> bool:
        return step % self.every == 0 and self.n < self.max_samples

    def record_probes(self) -> None:
        """u_n and v_n at the probe nodes, every step (ProbeRecorder.record)."""
        if self.n_probe >= self.probe_t.size:
            return
        it = self.integ
        self.probe_t[self.n_probe] = it.time - it.dt
        row = self.probes.row()  # (B, 4, n_probes): u_x, u_y, v_x, v_y
        k2 = self.probe_rows.size
        self.xp.take(it.u_prev, self.probe_rows, axis=0, out=self.probe_scratch[:k2])
        self.xp.take(it.v, self.probe_rows, axis=0, out=self.probe_scratch[k2:])
        row[...] = self.probe_scratch.reshape(4, k2 // 2, -1).transpose(2, 0, 1)
        self.n_probe += 1

    def sample(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Record time level n; returns host (kinetic, strain, work_cylinder) per scene."""
        it, xp = self.integ, self.xp
        cx = self.cx_sorted
        row = self.fields.row()  # (B, 6, m), scene-first
        z = self.z
        for k, arr in ((0, it.u_prev), (2, it.v)):
            # (B, m) complex rows times e^{-i theta}: the same ufunc loop as the single run's
            # ``NodalFrames.polar_at_nodes``, hence the same bits (numpy's SIMD complex
            # multiply may fuse multiply-adds)
            z.real[...] = arr[cx].T
            z.imag[...] = arr[cx + 1].T
            z *= self.pc_sorted
            row[:, k] = z.real
            row[:, k + 1] = z.imag
        row[:, 4] = it.r_r[self.perm].T
        row[:, 5] = it.r_t[self.perm].T
        self.status.row()[...] = it.status[self.perm].T
        e = self.energies.row()  # (B, 6): kinetic, strain, the three works (on the device)
        if it.damped:  # the damped step applied K w_n: K u_n for the strain energy and W_d
            it.refresh_ku()
        if it.energy_summed:  # the numba kernel summed them on this step, in row order
            e[:, :2] = it.energy.T
        else:
            if self.scratch is None:
                self.scratch = xp.zeros((it.n, it.B))
            xp.multiply(it.v, self.mass, out=self.scratch)
            e[:, 0] = xp.einsum("ib,ib->b", self.scratch, it.v)
            e[:, 1] = xp.einsum("ib,ib->b", it.u_prev, it.ku)
        e[:, :2] *= 0.5
        e[:, 2:5] = (it.work[:3] if it.work.ndim == 2 else it.work.sum(axis=1)).T
        e[:, 5] = it.damping_work_totals() if it.damped else 0.0
        self.t[self.n] = it.time - it.dt
        self.n += 1
        host = e[:, :4].get() if hasattr(e, "get") else e[:, :4]  # one device -> host copy
        return host[:, 0], host[:, 1], host[:, 3]

    def check_health(self, kin: np.ndarray, strain: np.ndarray, w_cyl: np.ndarray,
                     time_now: float) -> dict[int, str]:
        """``Simulation._check_health`` for every active scene: {b: message} of new blow-ups."""
        total = kin + strain
        active = self.integ.active
        finite = np.isfinite(total)
        first = active & finite & np.isnan(self.initial)  # a scene's first sample: its scale
        self.initial[first] = total[first]
        self.bound[first] = energy_bound(total[first])
        fed = self.initial + np.abs(w_cyl)
        blown = active & finite & ~first & blown_up(total, self.bound, fed)
        out: dict[int, str] = {}
        for b in np.flatnonzero(active & (~finite | blown)):  # none, nearly always
            if not finite[b]:
                out[int(b)] = f"non-finite energy at t = {time_now:.6g} s"
            else:
                out[int(b)] = blowup_message(float(total[b]), float(fed[b]), time_now)
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
