"""GPU backend of the batched ensemble (solver/ensemble.py, CuPy).

The CUDA kernel is compiled with --fmad=false and sums K u in the CPU kernels' order, so its
state is bitwise the numba kernel's; the plain CuPy path (cuSPARSE SpMM) agrees to round-off.
Tests marked ``gpu`` skip without CuPy; the CUDA kernel's *source* is still checked on every
machine with a C++ compiler, compiled for the CPU and run thread by thread.
Runs from a problem built here (dolfinx) or, without dolfinx, from benchmarks/ensemble.py's
npz dump (``STICKSLIP_GPU_NPZ=path/problem_n132.npz``).
"""

from __future__ import annotations

import os

import numpy as np
import pytest

try:
    import cupy
except ImportError:  # the device tests skip; the CPU emulation of the kernel below runs
    cupy = None


def _problem():
    from solver.ensemble import BatchedProblem

    path = os.environ.get("STICKSLIP_GPU_NPZ")
    if path:
        bp = BatchedProblem.load(path)
        with np.load(path) as z:
            return bp, z["u0"], z["d"], z["slide"], z["f"]
    pytest.importorskip("dolfinx")
    from mpi4py import MPI

    from solver.run import Simulation
    from solver.scene import load_scene

    sims = [Simulation(load_scene("scenes/smoke.toml", ["output.progress=false", o]),
                       MPI.COMM_SELF)
            for o in ("loading.omega=50.0", "loading.omega=20.0", "loading.f=0.0")]
    s0 = sims[0]
    bp = BatchedProblem.from_problem(s0.problem, s0.dt, s0.scene.time.beta2)
    return (bp, np.stack([s.integrator.u for s in sims], axis=1),
            np.array([s.scene.geometry.d for s in sims]),
            np.array([s.scene.geometry.R * s.scene.loading.omega * s.dt for s in sims]),
            np.array([s.scene.loading.f for s in sims]))


@pytest.mark.gpu
@pytest.mark.skipif(cupy is None, reason="CuPy is not installed (optional GPU extra)")
@pytest.mark.parametrize("kernel", ["cuda", "xp"])
def test_gpu_batch_equals_the_cpu_kernel(kernel):
    """200 steps: cuda bitwise (same operations, same order, no fused multiply-add), xp to
    1e-12 of max|u| (cuSPARSE's sum order; round-off amplified by the flutter of steady
    sliding); statuses equal; contact work to 1e-9 relative (per-node partial sums on the GPU)."""
    from solver.ensemble import BatchedExplicit

    bp, u0, d, slide, f = _problem()
    cpu = BatchedExplicit(bp, d, slide, f, kernel="numba")
    gpu = BatchedExplicit(bp, d, slide, f, xp=cupy, kernel=kernel)
    for integ in (cpu, gpu):
        integ.set_state(u0, np.zeros_like(u0))
        for _ in range(200):
            integ.step()
    u = cupy.asnumpy(gpu.u)
    if kernel == "cuda":
        np.testing.assert_array_equal(u, cpu.u)
    else:
        assert np.max(np.abs(u - cpu.u)) < 1e-12 * np.max(np.abs(cpu.u))
    np.testing.assert_array_equal(cupy.asnumpy(gpu.status), cpu.status)
    assert np.allclose(gpu.work_totals(), cpu.work_totals(), rtol=1e-9, atol=1e-30)


# ------------------------------------------------------------------------------------------
# The CUDA kernel's logic without a GPU: its source compiled as C++ for the CPU and run
# thread by thread (threads of one step are independent: each writes only its own node).

_EMULATOR = r"""
#include <cmath>
#include <cstddef>
struct Dim { unsigned int x; };
static Dim blockIdx, blockDim, threadIdx;
#define __global__
using std::copysign;
using std::fabs;
%(source)s
extern "C" void emulate(int blocks, int threads, %(params)s) {
    blockDim.x = threads;
    for (int b = 0; b < blocks; ++b) {
        blockIdx.x = b;
        for (int t = 0; t < threads; ++t) {
            threadIdx.x = t;
            fused_step(%(names)s);
        }
    }
}
"""


def _emulated_kernel(tmp_path):
    import ctypes
    import re
    import shutil
    import subprocess

    from solver.ensemble import CUDA_SOURCE

    cxx = shutil.which("g++") or shutil.which("c++")
    if cxx is None:
        pytest.skip("no C++ compiler")
    head = CUDA_SOURCE[CUDA_SOURCE.index("fused_step(") + len("fused_step("):]
    params = head[: head.index(")")]
    names = ", ".join(re.findall(r"(\w+)\s*(?:,|$)", params.replace("\n", " ")))
    src = tmp_path / "emu.cpp"
    src.write_text(_EMULATOR % {"source": CUDA_SOURCE, "params": params, "names": names})
    lib = tmp_path / "emu.so"
    # -ffp-contract=off: no fused multiply-add, as nvcc --fmad=false
    subprocess.run([cxx, "-O2", "-ffp-contract=off", "-shared", "-fPIC", "-o", str(lib),
                    str(src)], check=True)
    return ctypes.CDLL(str(lib)).emulate


@pytest.mark.parametrize("diag", [True, False])
def test_cuda_kernel_source_equals_the_numba_kernel_on_the_cpu(tmp_path, diag):
    """The CUDA kernel (solver.ensemble.CUDA_SOURCE), emulated on the CPU, gives the numba
    kernel's state bitwise over 120 steps; with ``diag = False`` (v, a, K u written only at
    the probe nodes) the state u, v~ and the contact statuses are unchanged."""
    import ctypes

    from solver.ensemble import BatchedExplicit

    pytest.importorskip("numba")
    emulate = _emulated_kernel(tmp_path)
    bp, u0, d, slide, f = _problem()
    ref = BatchedExplicit(bp, d, slide, f, kernel="numba")
    emu = BatchedExplicit(bp, d, slide, f, kernel="numba")  # arrays only; stepped below
    for integ in (ref, emu):
        integ.set_state(u0, np.zeros_like(u0))
    nodes, B, m = bp.n // 2, u0.shape[1], bp.cx.size
    cslot = emu.cslot.astype(np.int32)
    keep = np.zeros(nodes, dtype=np.int8)
    keep[int(bp.cx[0]) // 2] = 1
    work = np.zeros((3, m, B))
    P = ctypes.c_void_p

    def ptr(a):
        return P(a.ctypes.data)

    threads = 64
    blocks = (nodes * B + threads - 1) // threads
    dt, b2, kappa = emu.dt, emu.beta2, emu.kappa
    for _ in range(120):
        ref.step()
        cur, nxt = emu.cur, 1 - emu.cur
        emulate(ctypes.c_int(blocks), ctypes.c_int(threads), *map(ptr, (
            emu.indptr, emu.indices, emu.data, emu._u[cur], emu._u[nxt], emu.v, emu.v_pred,
            emu.a, emu.ku, emu.nim, cslot, emu.ph_re, emu.ph_im, emu.pc_re, emu.pc_im,
            emu.cmass, emu.cinv, emu.d, emu.slide, emu.f, emu.r_r, emu.r_t, emu.r_x, emu.r_y,
            emu.status, emu.zprev, work)),
            ctypes.c_double(b2 * dt), ctypes.c_double(0.5 * dt),
            ctypes.c_double((0.5 - b2) * dt), ctypes.c_int(int(b2 == 0.5)),
            ctypes.c_double(dt), ctypes.c_double(kappa), ctypes.c_double(1.0 / kappa),
            ctypes.c_int(nodes), ctypes.c_int(B), ctypes.c_int(m), ctypes.c_int(int(diag)),
            ptr(keep))
        emu.cur = nxt
    np.testing.assert_array_equal(emu.u, ref.u)
    np.testing.assert_array_equal(emu.v_pred, ref.v_pred)
    np.testing.assert_array_equal(emu.status, ref.status)
    np.testing.assert_array_equal(emu.r_t, ref.r_t)
    if diag:
        np.testing.assert_array_equal(emu.v, ref.v)
        np.testing.assert_array_equal(emu.ku, ref.ku)
    else:
        k = int(bp.cx[0])
        np.testing.assert_array_equal(emu.v[k:k + 2], ref.v[k:k + 2])
    assert np.allclose(work.sum(axis=1), ref.work_totals(), rtol=1e-9, atol=1e-30)
