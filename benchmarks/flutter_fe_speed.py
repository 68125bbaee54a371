"""Timings of the FE complex eigenvalue analysis on ONE core.

Run: ``./dev python3 benchmarks/flutter_fe_speed.py`` (repository root on PYTHONPATH).
Target: the unstable spectrum of scenes/figure3_n132 (N = 132, 1188 free dofs) up to
10 kHz in under 30 s. BLAS/OpenMP threads are pinned to 1 before numpy loads. Prints the
wall and CPU time of each phase, the slices and the most unstable modes; exit code 1 if the
target is missed.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from mpi4py import MPI  # noqa: E402

from stickslip.solver.problem import build_problem  # noqa: E402
from stickslip.solver.scene import load_scene  # noqa: E402
from stickslip.studies.flutter_fe import build_operators, complex_eigenvalue_analysis  # noqa: E402

TARGET_S = 30.0


def _case(name: str, overrides: list[str], fmax: float) -> tuple[float, float]:
    comm = MPI.COMM_SELF
    w0, c0 = time.perf_counter(), time.process_time()
    problem = build_problem(load_scene(name, overrides), comm)
    w1, c1 = time.perf_counter(), time.process_time()
    ops = build_operators(problem)
    w2, c2 = time.perf_counter(), time.process_time()
    res = complex_eigenvalue_analysis(problem, None, fmax, ops=ops)
    w3, c3 = time.perf_counter(), time.process_time()
    ops.destroy()
    uns = res.unstable()
    label = f"{name} {' '.join(overrides)}".strip()
    print(f"{label}: {res.n_free} free dofs, {len(res.modes)} modes <= {fmax:g} Hz, "
          f"{len(uns)} unstable ({res.stats.slices} slices, {res.stats.solves} solves)")
    print(f"  mesh+assembly {w1 - w0:6.2f} s wall ({c1 - c0:6.2f} s CPU)")
    print(f"  CEA operators {w2 - w1:6.2f} s wall ({c2 - c1:6.2f} s CPU)")
    print(f"  eigensolve    {w3 - w2:6.2f} s wall ({c3 - c2:6.2f} s CPU)")
    for m in uns[:3]:
        print(f"    {m.frequency_hz:8.1f} Hz  growth {m.growth_rate:8.1f} /s  k = {m.wavenumber:3d}"
              f"  {m.direction}")
    return w3 - w0, c3 - c0


def main() -> int:
    _case("smoke", [], 10_000.0)
    _case("figure3_n36", ["mesh.n_inner=72"], 10_000.0)
    wall, cpu = _case("figure3_n132", [], 10_000.0)
    ok = wall < TARGET_S
    print(f"N = 132 unstable spectrum up to 10 kHz: {wall:.2f} s wall, {cpu:.2f} s CPU "
          f"(target {TARGET_S:g} s): {'OK' if ok else 'MISSED'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
