"""GPU backend of the batched ensemble (solver/ensemble.py, CuPy): skipped without CuPy.

The CUDA kernel is compiled with --fmad=false and sums K u in the CPU kernels' order, so its
state is bitwise the numba kernel's; the plain CuPy path (cuSPARSE SpMM) agrees to round-off.
Runs from a problem built here (dolfinx) or, without dolfinx, from benchmarks/ensemble.py's
npz dump (``STICKSLIP_GPU_NPZ=path/problem_n132.npz``).
"""

from __future__ import annotations

import os

import numpy as np
import pytest

cupy = pytest.importorskip("cupy")
pytestmark = pytest.mark.gpu


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
