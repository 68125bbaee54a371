"""Observers of a batch (``solver.ensemble``): per-scene samples and probes of B scenes,
kept whole in host memory (``spool_dir = None`` on the CPU; the caller checks that the record
fits, ``BatchRecorder.record_bytes``) or spooled to disk in chunks, so that memory does not
grow with the run length. On a GPU the chunks are copied to the host asynchronously
(``_DeviceSpool``) and the energy guard reads them there, so that the loop never waits for
the device on a sample."""

from __future__ import annotations

import time
import warnings
from collections import deque
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from typing import TYPE_CHECKING, Any

import numpy as np

from stickslip.solver.columns import SceneRecords
from stickslip.solver.errors import EnergyGuard
from stickslip.solver.observers import (
    ContactCircle,
    ProbeChoice,
    blas_energies,
    gather_probes,
)

if TYPE_CHECKING:  # pragma: no cover
    from stickslip.solver.ensemble import BatchedExplicit


class _Spool:
    """One recorded field of a batch on the host: rows of shape (B, *inner) in chunks of
    ``chunk`` rows (``_DeviceSpool`` on a GPU).

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
            self.buf.tofile(self.fh)
        else:
            self.mem.append(self.buf.copy())
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


def _pinned(xp: Any, shape: tuple[int, ...], dtype) -> np.ndarray:
    """A numpy array in page-locked host memory (``cupy.cuda.alloc_pinned_memory``): the
    target of an asynchronous device-to-host copy. Where none can be had, a plain array
    (with a warning): the copies are then synchronous for the host, the record the same."""
    nbytes = max(1, int(np.prod(shape)) * np.dtype(dtype).itemsize)
    try:
        mem = xp.cuda.alloc_pinned_memory(nbytes)
    except Exception as err:  # e.g. the page-locked memory is exhausted
        warnings.warn(f"no pinned host memory for a {nbytes / 1e6:.0f} MB spool buffer "
                      f"({type(err).__name__}: {err}): its copies wait for the device",
                      RuntimeWarning, stacklevel=2)
        return np.empty(shape, dtype=dtype)
    return np.ndarray(shape, dtype=dtype, buffer=mem)  # as cupyx.empty_pinned


def _copy_to_host_async(xp: Any, src, dst: np.ndarray, stream) -> None:
    """dst[...] = src, queued on ``stream``; the host goes on at once (``dst`` pinned)."""
    try:
        xp.asnumpy(src, stream=stream, out=dst, blocking=False)
    except TypeError:  # CuPy < 13: a copy on a given stream is asynchronous, no ``blocking``
        xp.asnumpy(src, stream=stream, out=dst)


class _DeviceSpool(_Spool):
    """``_Spool`` for device arrays (CuPy), without a stall of the loop:

    * two device chunk buffers in turn: the rows go into one while the other, full, is copied
      to pinned host memory on its own stream (``non_blocking``: it does not wait for the
      compute stream's kernels), after an event recorded on the compute stream when the
      chunk was full; before its buffer takes rows again, the compute stream waits (on the
      device, not the host) for that copy's event;
    * a chunk whose copy has ended (``Event.done``, polled at every ``row``) goes to
      ``on_host(first_row, chunk)`` on the loop's thread (the energy guard), then to one
      writer thread: appended to the file (``path``; file writes release the GIL) or copied
      into a numpy array kept in memory (``path = None``); a pinned buffer takes a new copy
      only after its writer finished (the one wait of the loop, when the disk is slower
      than the device).

    Only this (the loop's) thread calls CUDA. ``read(b, n)`` and ``close()`` are
    ``_Spool``'s; ``wait_s`` is the time the loop waited for copies and writes."""

    def __init__(self, xp: Any, inner: tuple[int, ...], B: int, chunk: int, dtype,
                 path=None, on_host: Callable[[int, np.ndarray], None] | None = None) -> None:
        self.xp, self.inner, self.B, self.chunk, self.dtype = xp, inner, B, chunk, dtype
        shape = (B, chunk, *inner)
        self.dev = [xp.zeros(shape, dtype=dtype) for _ in range(2)]
        self.host = [_pinned(xp, shape, dtype) for _ in range(2)]
        self.buf = self.dev[0]
        self.stream = xp.cuda.Stream(non_blocking=True)  # the copies
        self.copied: list[Any] = [None, None]  # event: slot k's last copy ended
        self.written: list[Future | None] = [None, None]  # the writer's job on host slot k
        self.pending: deque[int] = deque()  # chunks copied (or copying), not handed over
        self.writer = ThreadPoolExecutor(1, thread_name_prefix="spool-writer")
        self.on_host = on_host
        self.path = path
        self.fh = open(path, "wb") if path is not None else None  # noqa: SIM115
        self.mem: list[np.ndarray] = []
        self.rows = 0
        self.n_chunks = 0
        self.wait_s = 0.0
        self.closed = False

    def row(self):
        self.poll()
        return super().row()

    def poll(self) -> None:
        """Hand over the chunks whose copy has ended (no wait)."""
        if self.pending:
            self._hand_over(wait_through=-1)

    def _rows_of(self, c: int) -> int:
        return min(self.chunk, self.rows - c * self.chunk)

    def _flush(self) -> None:
        """Queue the copy of the full device buffer; the rows go on in the other one."""
        c, k = self.n_chunks, self.n_chunks % 2
        self._free(k)
        compute = self.xp.cuda.get_current_stream()
        self.stream.wait_event(compute.record())  # the chunk's rows are written
        _copy_to_host_async(self.xp, self.dev[k], self.host[k], self.stream)
        self.copied[k] = self.stream.record()
        self.pending.append(c)
        self.n_chunks += 1
        other = 1 - k
        if self.copied[other] is not None:  # its last copy ends before new rows land in it
            compute.wait_event(self.copied[other])
        self.buf = self.dev[other]

    def _hand_over(self, wait_through: int) -> None:
        """Chunks whose copy has ended, oldest first: ``on_host``, then the writer. Chunks up
        to index ``wait_through`` are waited for; later ones only when already copied."""
        while self.pending:
            c = self.pending[0]
            k = c % 2
            event = self.copied[k]
            if not event.done:
                if c > wait_through:
                    return
                t0 = time.perf_counter()
                event.synchronize()
                self.wait_s += time.perf_counter() - t0
            self.pending.popleft()
            if self.on_host is not None:
                self.on_host(c * self.chunk, self.host[k][:, :self._rows_of(c)])
            self.written[k] = self.writer.submit(self._store, k)

    def _store(self, k: int) -> None:
        """The writer thread: host slot k to the file (whole, as ``read`` expects) or to a
        numpy array in memory."""
        if self.fh is not None:
            self.host[k].tofile(self.fh)
        else:
            self.mem.append(self.host[k].copy())

    def _free(self, k: int) -> None:
        """Host slot k's last chunk handed over and written (errors of the write raise)."""
        if any(c % 2 == k for c in self.pending):
            self._hand_over(wait_through=max(c for c in self.pending if c % 2 == k))
        job, self.written[k] = self.written[k], None
        if job is not None:
            t0 = time.perf_counter()
            job.result()
            self.wait_s += time.perf_counter() - t0

    def drain(self) -> None:
        """Wait until every full chunk so far is copied, handed over and written."""
        self._hand_over(wait_through=self.n_chunks)
        for k in (0, 1):
            self._free(k)

    def close(self) -> None:
        """Copy the last (partial) chunk, hand over and write everything; then ``read``."""
        if self.closed:
            return
        try:
            if self.rows > self.n_chunks * self.chunk:
                self._flush()
            self.drain()
        finally:
            self.closed = True
            self.writer.shutdown(wait=True)
            if self.fh is not None:
                self.fh.close()
                self.fh = None
            self.dev, self.host, self.buf = [], [], None  # device and pinned memory back


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

    def tail(self, b: int, last: int) -> np.ndarray:
        """Scene b's last ``last`` rows taken (a view)."""
        return self.data[b, max(0, self.rows - last): self.rows]


def _mpi_type(dtype):
    """The MPI datatype of a record's dtype (float64 or int8)."""
    from mpi4py import MPI

    return MPI.DOUBLE if np.dtype(dtype) == np.float64 else MPI.INT8_T


class _GatheredRows:
    """One recorded field of a batch of one whose contact nodes are spread over the ranks
    of ``circle`` (``solver.observers.ContactCircle``): ``row()`` is this rank's send row
    (1, *lead, m_local), filled in its local contact order, and ``commit()`` (collective)
    gathers it to rank 0 (one Gatherv per leading index), which puts it in angle order
    (``circle.perm``) into its whole record; ``read`` and ``tail`` on rank 0."""

    def __init__(self, circle, lead: tuple[int, ...], rows: int, dtype, mpitype) -> None:
        self.circle, self.mpitype = circle, mpitype
        self.send = np.zeros((1, *lead, circle.n_local), dtype=dtype)
        # (leading rows, m_local): explicit, since a rank may own no contact node (m = 0)
        self.flat = self.send.reshape(int(np.prod(lead, dtype=np.int64)), circle.n_local)
        self.record = self.recv = None
        if circle.is_root:
            self.record = _Record((*lead, circle.n_nodes), 1, rows, dtype)
            self.recv = np.zeros((self.flat.shape[0], circle.n_nodes), dtype=dtype)
        self.rows = 0

    def row(self) -> np.ndarray:
        self.rows += 1
        return self.send

    def commit(self) -> None:
        circle = self.circle
        for k in range(self.flat.shape[0]):
            circle.gatherv(self.flat[k], None if self.recv is None else self.recv[k],
                           self.mpitype)
        if self.record is not None:
            out = self.record.row()[0].reshape(self.recv.shape)  # (1, *lead, m): a view
            for k in range(self.recv.shape[0]):
                out[k] = self.recv[k][circle.perm]

    def close(self) -> None:
        pass

    def read(self, b: int, n: int) -> np.ndarray:
        return self.record.read(b, n)

    def tail(self, b: int, last: int) -> np.ndarray:
        return self.record.tail(b, last)


class BatchRecorder:
    """The records of a batch's columns (``solver.ensemble_run.BatchColumns``), scene by scene.

    Samples (every ``every`` steps, time level n): u_r, u_theta, v_r, v_theta, r_r, r_theta
    and the status at the contact nodes in angle order ``perm``, the energies (kinetic,
    strain, the three works); probes (every step): u_n and v_n (x, y) at the probe nodes.
    ``arrays(b)`` / ``probe_arrays(b)`` return scene b's samples and probes, as a run's
    samples.npz holds them.

    The energy guard (``observe``; ``check_health``): on the CPU every sample is checked as
    it is taken. On a GPU (``xp`` not numpy) a sample stays on the device: the guard checks
    each chunk of samples once its asynchronous copy has reached the host, row by row, each
    blow-up reported at the time of its own sample; ``close()`` returns those of the last
    chunks. A scene is then masked up to two chunks of samples later than on the CPU (its
    record goes on past the blow-up until then); the scenes are independent columns, so no
    other scene's bits change.

    One scene whose dofs are spread over MPI ranks (a batch of one, ``circle``: its
    ``solver.observers.ContactCircle``): each rank takes its own contact nodes in its local
    order (``perm`` the identity) and a sample is gathered to rank 0 (``_GatheredRows``),
    which keeps the record; the energies are this rank's sums, added over the ranks; each
    probe is recorded by the rank that owns it (``probe_slots``: its place among the
    scene's probes) and gathered when read.
    """

    def __init__(self, integ: BatchedExplicit, *, mass: np.ndarray, perm: np.ndarray,
                 theta: np.ndarray, ds: np.ndarray, every: int, max_samples: int,
                 max_steps: int, probe_nodes: np.ndarray, probe_pc: np.ndarray,
                 probe_deg: np.ndarray, spool_dir=None, chunk: int = 16, circle=None,
                 probe_slots: tuple[list[int], int] | None = None, bs: int = 2) -> None:
        xp, B, m = integ.xp, integ.B, integ.m
        self.circle = circle if circle is not None and circle.comm.size > 1 else None
        self.probe_slots = probe_slots
        self.integ, self.xp = integ, xp
        self.every, self.max_samples, self.max_steps = max(1, every), max_samples, max_steps
        self.mass = xp.asarray(mass)[:, None]
        self.scratch = None  # (n, B), for the energies of steps the kernel did not sum
        self.perm = xp.asarray(np.asarray(perm, dtype=np.int64))
        self.theta, self.ds = theta, ds
        pd = bs * np.asarray(probe_nodes, dtype=np.int64)  # bs dofs a node: 2, or 3 in 3D
        self.probe_x = pd  # the probes' x dofs
        self.probe_rows = xp.asarray(np.concatenate([pd, pd + 1]))  # x dofs, then y dofs
        self.probe_scratch = xp.zeros((2 * self.probe_rows.size, B))  # u rows, then v rows
        self.probe_pc, self.probe_deg = probe_pc, probe_deg
        self.n = 0
        self.n_probe = 0
        self.t = np.zeros(max_samples)
        self.probe_t = np.zeros(max_steps + 1)
        npb = len(probe_nodes)
        # the guard on the host copies of the energies (GPU): the clock of each sample (the
        # stepper's time when it was taken), the scenes found, their messages not yet taken
        host = integ.host_records  # numpy arrays, or a device's
        self.deferred = not host
        self.clock = np.zeros(max_samples)
        self.flagged = np.zeros(B, dtype=bool)
        self.blowups: dict[int, str] = {}

        def store(name: str, inner: tuple[int, ...], dtype, rows: int, chunk_rows: int,
                  on_host=None):
            if self.circle is not None:  # a scene over ranks: its samples go to rank 0
                if name in ("fields.f64", "status.i8"):
                    return _GatheredRows(self.circle, inner[:-1], rows, dtype,
                                         _mpi_type(dtype))
                return _Record(inner, B, rows, dtype)  # the ranks' sums; its own probes
            if spool_dir is None and host:  # the whole record, in host memory
                return _Record(inner, B, rows, dtype)
            path = None if spool_dir is None else spool_dir / name  # chunks (file or host)
            if host:
                return _Spool(xp, inner, B, chunk_rows, dtype, path)
            return _DeviceSpool(xp, inner, B, chunk_rows, dtype, path, on_host)

        self.fields = store("fields.f64", (6, m), np.float64, max_samples, chunk)
        self.status = store("status.i8", (m,), np.int8, max_samples, chunk)
        # kinetic, strain, 3 works, the Kelvin-Voigt work W_d (0 undamped), as
        # solver.observers.ENERGY_FIELDS
        self.energies = store("energies.f64", (6,), np.float64, max_samples, chunk,
                              self._guard_chunk)
        self.probes = store("probes.f64", (4, npb), np.float64, max_steps + 1, 16 * chunk)
        self.cx_sorted = integ.cx.astype(np.int64)[self.perm]
        self.cy_sorted = self.cx_sorted + 1  # the y dofs, once (not one launch per sample)
        self.pc_sorted = xp.asarray(integ.phase_conj)[self.perm]
        self.z = xp.zeros((B, m), dtype=np.complex128)
        #: the compiled copies of ``sample`` and ``record_probes`` where the stepper's
        #: kernel has them (``solver._sample_kernels``), else None (array indexing)
        self.copies = integ.columns.record_copies()
        self.zv = xp.zeros((B, m), dtype=np.complex128) if self.copies else None
        #: one scene on one rank, its record whole in host memory: a sample is ONE compiled
        #: pass (``_sample_kernels.sample_one``) that stores u and v Cartesian, turned polar
        #: when read (``_rotate_pending``; rows below ``polar_rows`` are polar)
        self.one = (self.copies is not None and B == 1 and self.circle is None
                    and isinstance(self.fields, _Record) and integ.one_pass_samples)
        self.polar_rows = 0
        if self.one:
            self.node_x = np.ascontiguousarray(self.cx_sorted, dtype=np.intp)
            self.perm_one = np.ascontiguousarray(self.perm, dtype=np.intp)
            self.mass_one = np.ascontiguousarray(mass, dtype=np.float64)
        self.guard = EnergyGuard(B)
        #: the probes' count as a compiled loop advances it (``kernel_buffers``)
        self.count = np.zeros(1, dtype=np.int64)
        self.probe_x_u32 = np.ascontiguousarray(pd, dtype=np.uint32)
        self.kin_scratch = np.zeros(integ.n) if self.circle is not None else None

    @staticmethod
    def record_bytes(B: int, m: int, n_probes: int, max_samples: int, max_steps: int) -> int:
        """Bytes of a whole batch record: the fields (6 x m doubles), status (m bytes) and
        energies (6 doubles) of every sample, and the probes (4 doubles each) of every step.
        A caller keeps the record in memory (``spool_dir = None``) when this fits."""
        per_sample = 8 * 6 * m + m + 8 * 6
        return int(B * (max_samples * per_sample + (max_steps + 1) * 8 * 4 * n_probes))

    def due(self, step: int) -> bool:
        return step % self.every == 0 and self.n < self.max_samples

    def kernel_buffers(self) -> tuple:
        """(x dof of each probe, t, rows (steps, 4, probes), count) of a batch of one whose
        record is whole in host memory, for a compiled loop that records the probes in
        place every step (``solver.ensemble.NumbaColumns.advance_one``: the layout of
        ``record_probes``); ``recorded()`` takes the count back afterwards."""
        self.count[0] = self.n_probe
        return self.probe_x_u32, self.probe_t, self.probes.data[0], self.count

    def recorded(self) -> None:
        """The probes' count after a compiled loop (``kernel_buffers``)."""
        self.n_probe = self.probes.rows = int(self.count[0])

    def record_probes(self) -> None:
        """u_n and v_n at the probe nodes, every step."""
        if self.n_probe >= self.probe_t.size:
            return
        it = self.integ
        self.probe_t[self.n_probe] = it.time - it.dt
        row = self.probes.row()  # (B, 4, n_probes): u_x, u_y, v_x, v_y
        if self.copies is not None:
            self.copies.gather_probes(it.u_prev, it.v, self.probe_x, row)
            self.n_probe += 1
            return
        k2 = self.probe_rows.size
        self.xp.take(it.u_prev, self.probe_rows, axis=0, out=self.probe_scratch[:k2])
        self.xp.take(it.v, self.probe_rows, axis=0, out=self.probe_scratch[k2:])
        row[...] = self.probe_scratch.reshape(4, k2 // 2, it.B).transpose(2, 0, 1)
        self.n_probe += 1

    def observe(self, stepper) -> dict[int, str]:
        """Record time level n (``sample``) and run the energy guard: {b: message} of the
        blow-ups found now (CPU: in this sample; GPU: in the chunks of samples that reached
        the host since the last call, see the class docstring). The caller masks them."""
        energies = self.sample()
        if energies is not None:
            return self.check_health(*energies, stepper.time)
        return self.take_blowups()

    def take_blowups(self) -> dict[int, str]:
        """The blow-ups the guard found on the host copies (GPU) and not yet returned."""
        if isinstance(self.energies, _DeviceSpool):
            self.energies.poll()
        found, self.blowups = self.blowups, {}
        return found

    def _guard_chunk(self, first: int, chunk: np.ndarray) -> None:
        """``check_health`` on samples first, first + 1, ... of a host chunk (B, rows, 6),
        in order, each at its own clock; a scene found is left out of later rows."""
        for j in range(chunk.shape[1]):
            e = chunk[:, j]
            found = self.check_health(e[:, 0], e[:, 1], e[:, 3], float(self.clock[first + j]))
            for b, msg in found.items():
                self.flagged[b] = True
                self.blowups[b] = msg

    def sample(self) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """Record time level n; returns host (kinetic, strain, work_cylinder) per scene on
        the CPU, None on a GPU (no device-to-host copy per sample: ``observe`` runs the
        guard on the host chunks)."""
        if self.one:
            return self._sample_one()
        it, xp = self.integ, self.xp
        cx = self.cx_sorted
        row = self.fields.row()  # (B, 6, m), scene-first
        z = self.z
        # (B, m) complex rows times e^{-i theta}: the same ufunc loop as the single run's
        # ``NodalFrames.polar_at_nodes``, hence the same bits (numpy's SIMD complex multiply
        # may fuse multiply-adds); the copies around it compiled where the step is
        if self.copies is not None:
            self.copies.gather_sample(it.u_prev, it.v, it.r_r, it.r_t, it.status, cx,
                                      self.perm, z, self.zv, row, self.status.row())
            z *= self.pc_sorted
            self.zv *= self.pc_sorted
            self.copies.scatter_polar(z, self.zv, row)
        else:
            for k, arr in ((0, it.u_prev), (2, it.v)):
                z.real[...] = arr[cx].T
                z.imag[...] = arr[self.cy_sorted].T
                z *= self.pc_sorted
                row[:, k] = z.real
                row[:, k + 1] = z.imag
            row[:, 4] = it.r_r[self.perm].T
            row[:, 5] = it.r_t[self.perm].T
            self.status.row()[...] = it.status[self.perm].T
        e = self.energies.row()  # (B, 6): kinetic, strain, the three works (on the device)
        if it.damped:  # the damped step applied K w_n: K u_n for the strain energy and W_d
            it.refresh_ku()
        if self.circle is not None:
            self._rank_sums(e)
        elif it.energy_summed or it.sum_energies():  # the numba kernel's, in row order
            e[:, :2] = it.energy.T
        else:
            if self.scratch is None:
                self.scratch = xp.zeros((it.n, it.B))
            xp.multiply(it.v, self.mass, out=self.scratch)
            e[:, 0] = xp.einsum("ib,ib->b", self.scratch, it.v)
            e[:, 1] = xp.einsum("ib,ib->b", it.u_prev, it.ku)
        e[:, :2] *= 0.5
        e[:, 2:5] = it.work_sums().T
        e[:, 5] = it.damping_work_totals() if it.damped else 0.0
        if self.circle is not None:  # the scene's sums over the ranks; its sample to rank 0
            self._add_over_ranks(e)
            self.fields.commit()
            self.status.commit()
        self.t[self.n] = it.time - it.dt
        self.clock[self.n] = it.time
        self.n += 1
        if self.deferred:
            return None
        return e[:, 0], e[:, 1], e[:, 3]

    def _sample_one(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``sample`` of one scene on one rank in one compiled pass (``self.one``)."""
        it, i = self.integ, self.n
        if it.damped:  # the damped step applied K w_n: K u_n for the strain energy and W_d
            it.refresh_ku(strain=False)
        for record in (self.fields, self.status, self.energies):
            record.row()
        e = self.energies.data[0]
        self.copies.sample_one(i, it.u_prev, it.u, it.v, it.ku, self.mass_one, it.r_r, it.r_t,
                               it.status, self.node_x, self.perm_one, it.work, it.u0_ku0,
                               it.damped, self.fields.data[0], self.status.data[0], e)
        self.t[i] = it.time - it.dt
        self.clock[i] = it.time
        self.n = i + 1
        return e[i, 0:1], e[i, 1:2], e[i, 3:4]

    def _rotate_pending(self) -> None:
        """The Cartesian (x, y) of u and v of the samples ``_sample_one`` took since the last
        call, turned to (r, θ): z e^{-iθ} by numpy's complex multiply, as ``sample`` turns
        each row (element by element: the same bits)."""
        if not self.one or self.polar_rows >= self.n:
            return
        rows = self.fields.data[0, self.polar_rows:self.n]
        z = np.empty((rows.shape[0], rows.shape[2]), dtype=np.complex128)
        for k in (0, 2):
            z.real, z.imag = rows[:, k], rows[:, k + 1]  # exact, whatever the values
            z *= self.pc_sorted
            rows[:, k] = z.real
            rows[:, k + 1] = z.imag
        self.polar_rows = self.n

    def _rank_sums(self, e: np.ndarray) -> None:
        """A scene over ranks: this rank's 2 x kinetic and 2 x strain energy
        (``solver.observers.blas_energies``, as a stepper that is no batch sums them)."""
        it = self.integ
        e[0, :2] = blas_energies(it.v[:, 0], self.mass[:, 0], it.u_prev[:, 0], it.ku[:, 0],
                                 self.kin_scratch)

    def _add_over_ranks(self, e: np.ndarray) -> None:
        """The energy row (1, 6) summed over the ranks, in place (every rank has it)."""
        from mpi4py import MPI

        self.circle.comm.Allreduce(MPI.IN_PLACE, e, op=MPI.SUM)

    def check_health(self, kin: np.ndarray, strain: np.ndarray, w_cyl: np.ndarray,
                     time_now: float) -> dict[int, str]:
        """The energy guard (``solver.errors.EnergyGuard``) on every active scene: {b:
        message} of new blow-ups."""
        return self.guard.check(kin, strain, w_cyl, self.integ.active & ~self.flagged,
                                time_now)

    def recent_status(self, b: int, last: int) -> np.ndarray:
        """Scene b's statuses of the last ``last`` samples (rank 0; a whole record)."""
        return self.status.tail(b, last)

    def close(self) -> dict[int, str]:
        """Write out the record; returns the blow-ups the guard found in its last chunks
        (GPU; ``{}`` on the CPU, which found them at their sample)."""
        errors = []
        for s in (self.fields, self.status, self.energies, self.probes):
            try:  # every spool closes (its file, its writer thread), whatever another did
                s.close()
            except Exception as err:
                errors.append(err)
        if errors:
            raise errors[0]
        return self.take_blowups()

    def drain(self) -> None:
        """GPU: wait until the chunks filled so far are on the host and written (a timed
        block of steps then holds all the work it queued); nothing on the CPU."""
        for s in (self.fields, self.status, self.energies, self.probes):
            if isinstance(s, _DeviceSpool):
                s.drain()

    @property
    def wait_s(self) -> float:
        """Seconds the loop waited for the GPU spools' copies and writes."""
        return sum(getattr(s, "wait_s", 0.0)
                   for s in (self.fields, self.status, self.energies, self.probes))

    def arrays(self, b: int, n: int | None = None) -> dict[str, np.ndarray]:
        """Scene b's samples (its first n): t, theta, u_r, u_theta, v_r, v_theta, status,
        energies, r_r, r_theta, ds."""
        n = self.n if n is None else n
        self._rotate_pending()
        f = self.fields.read(b, n)
        return {"t": self.t[:n].copy(), "theta": self.theta, "u_r": f[:, 0],
                "u_theta": f[:, 1], "v_r": f[:, 2], "v_theta": f[:, 3],
                "status": self.status.read(b, n), "energies": self.energies.read(b, n),
                "r_r": f[:, 4], "r_theta": f[:, 5], "ds": self.ds}

    def probe_arrays(self, b: int, n: int | None = None) -> dict[str, np.ndarray]:
        """Scene b's probes (its first n steps): probe_t, probe_deg and probe_data (probe,
        step, [u_r, u_theta, v_r, v_theta])."""
        n = self.n_probe if n is None else n
        p = self.probes.read(b, n)  # (n, 4, n_probes)
        zu = (p[:, 0] + 1j * p[:, 1]) * self.probe_pc
        zv = (p[:, 2] + 1j * p[:, 3]) * self.probe_pc
        data = np.stack([zu.real, zu.imag, zv.real, zv.imag], axis=-1).transpose(1, 0, 2)
        if self.probe_slots is not None:  # each rank's own probes, to their slots on rank 0
            slots, n_probes = self.probe_slots
            return gather_probes(self.circle.comm, slots, list(self.probe_deg), data,
                                 self.probe_t[:n], n_probes)
        return {"probe_t": self.probe_t[:n].copy(), "probe_deg": self.probe_deg,
                "probe_data": data}


class _Member:
    """Scene b's face of a ``BatchRecorder``: ``n``, the recorder's count (its attribute
    ``COUNT``) until the scene's own is set (the scene ended there)."""

    COUNT = "n"

    def __init__(self, rec: BatchRecorder, b: int) -> None:
        self.rec, self.b = rec, b
        self.taken: int | None = None

    @property
    def n(self) -> int:
        return getattr(self.rec, self.COUNT) if self.taken is None else self.taken

    @n.setter
    def n(self, value: int) -> None:
        self.taken = value


class MemberRecords(_Member):
    """The samples of scene b of a ``BatchRecorder`` as one scene's records (``arrays()``,
    ``n``, ``n_nodes``, ``recent_status``)."""

    def __init__(self, rec: BatchRecorder, b: int, n_nodes: int) -> None:
        super().__init__(rec, b)
        self.n_nodes = n_nodes

    def arrays(self) -> dict[str, np.ndarray]:
        return self.rec.arrays(self.b, self.n)

    def recent_status(self, last: int) -> np.ndarray:
        """The statuses of the last ``last`` samples (rank 0)."""
        return self.rec.recent_status(self.b, last)


class MemberProbes(_Member):
    """The probes of scene b of a ``BatchRecorder`` (``arrays()``, ``n``)."""

    COUNT = "n_probe"

    def arrays(self) -> dict[str, np.ndarray] | None:
        return self.rec.probe_arrays(self.b, self.n)


class ProbeHook:
    """Step hook: the batch's probes every step (``BatchRecorder.record_probes``), or in a
    compiled loop's own pass (``kernel_buffers``, then ``recorded``)."""

    def __init__(self, rec: BatchRecorder) -> None:
        self.rec = rec

    def after_step(self, stepper) -> None:
        self.rec.record_probes()

    def kernel_buffers(self) -> tuple:
        return self.rec.kernel_buffers()

    def recorded(self) -> None:
        self.rec.recorded()


def one_scene_records(source, stepper, problem, projection, probes_deg, every: int,
                      n_steps: int, parts: dict) -> SceneRecords:
    """The records of one scene: a ``BatchRecorder`` of B = 1 on ``source`` (the stepper's
    ``BatchedExplicit``, or a ``solver.observers.SteppedColumn``), its whole record in
    memory, its probes a step hook of ``stepper`` (or recorded by its compiled loop), the
    levels it samples stepped with their full state (``full_state_at``). Over several ranks
    each rank takes its own contact nodes and probes and the samples gather to rank 0
    (``ContactCircle``). ``parts``: the work observers a checkpoint keeps, by name."""
    circle = ContactCircle(problem)
    owned = ProbeChoice.of(problem, projection, probes_deg)  # the probes this rank records
    several = problem.comm.size > 1
    rec = BatchRecorder(
        source, mass=problem.mass, perm=np.arange(circle.n_local) if several else circle.perm,
        theta=circle.theta, ds=circle.ds, every=every, max_samples=n_steps // every + 2,
        max_steps=n_steps, probe_nodes=owned.index, probe_pc=owned.phase_conj,
        probe_deg=np.asarray(owned.angles), circle=circle,
        probe_slots=(owned.slots, owned.n_probes) if several else None,
        bs=problem.V.dofmap.index_map_bs)
    source.keep_nodes(owned.index)
    source.full_state_at = rec.due
    stepper.attach(ProbeHook(rec))
    return SceneRecords(rec, MemberRecords(rec, 0, circle.n_nodes), MemberProbes(rec, 0),
                        parts)
