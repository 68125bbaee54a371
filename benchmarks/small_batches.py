"""Small batches (B = 1 to 8): today's batched stepper against an earlier kernel, per scene-step.

A census continues its unsettled starts in legs, a few starts per rank, so most of its
scene-steps run in batches of 1 to 4 columns. This measures them side by side in ONE
process, interleaved (this VM's timings drift by up to 1.5x between runs)::

    git show 9de752b:solver/_fused_kernels.py > /tmp/kernels_before.py
    ./dev python3 benchmarks/small_batches.py --old /tmp/kernels_before.py [--n 132 528]

Per N (the damped tutorial scene, ``figure1_n132_damped``) and B it prints microseconds per
scene-step (lean steps, as a leg runs between samples) of:

* ``alone``: the single-scene stepper ``SceneExplicit`` (``time.kernel = "numba"``, a batch
  of one seen as one scene), B = 1;
* ``today``: ``BatchedExplicit`` with the kernel ``batched_kernel_name`` picks (a batch of
  one runs ``single_step``; the rest of a batch after its 4-scene register passes runs in
  2-scene passes, then one alone);
* ``before``: ``batched_step`` of ``--old`` on a copy of the batch, compiled with the SLP
  vectoriser as today's (numba compiles a kernel of a new file on its first call);

the ratio before/today, and whether both end on the same bits. Targets: today at B = 1
within 10 % of ``alone``; at B = 2 and 3 no slower per scene-step than ``alone``.
"""

from __future__ import annotations

import argparse
import importlib
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

from stickslip.solver.ensemble import BatchedExplicit, BatchedProblem
from stickslip.solver.fused import friction_bound, slp_vectorize
from stickslip.solver.run import Simulation
from stickslip.solver.scene import load_scene


def _old_batched_step(path: Path):
    """``batched_step`` of the kernel file ``path``, copied into a fresh folder so that numba
    compiles it here (with the SLP vectoriser, ``measure``) rather than loading a cached
    compile of another run, made with or without it."""
    folder = Path(tempfile.mkdtemp(prefix="kernels-before-"))
    shutil.copy(path, folder / "kernels_before.py")
    sys.path.insert(0, str(folder))
    return importlib.import_module("kernels_before").batched_step


def _args(st: BatchedExplicit, diag: bool) -> tuple:
    """``batched_step``'s arguments (the signature of ``NumbaColumns.step``)."""
    dt, b2 = st.dt, st.beta2
    return (st.indptr, st.indices, st.data, st.u_levels[st.cur], st.u_levels[1 - st.cur],
            st.v, st.v_pred,
            st.a, st.ku, st.nim, b2 * dt, 0.5 * dt, (0.5 - b2) * dt, b2 == 0.5, dt, st.kappa,
            1.0 / st.kappa, st.cx, st.ph_re, st.ph_im, st.pc_re, st.pc_im, st.cmass, st.cinv,
            st.d, st.slide, st.f, st.r_r, st.r_t, st.r_x, st.r_y, st.status, st.zprev,
            st.work, st.acc, st.cslot, diag, st.keep, st.mass, st.energy, st.w_levels[st.cur],
            st.w_levels[1 - st.cur], st.tau, st.dsum, st.reg, st.sigma, st.ut_last, st.rate_slip,
            st.rate_base, st.started)


def _batch(bp: BatchedProblem, law, tau: float, B: int, u0: np.ndarray,
           v0: np.ndarray) -> BatchedExplicit:
    """B copies of the scene ``law`` from (u0, v0), on the numba kernel."""
    st = BatchedExplicit(bp, np.full(B, law.d), np.full(B, law.slide), np.full(B, law.f),
                         kernel="numba", tau=tau, bound=friction_bound(law.law))
    st.set_state(np.repeat(u0[:, None], B, 1), np.repeat(v0[:, None], B, 1))
    return st


def _stepper_of(old, st: BatchedExplicit):
    """One lean step of ``st`` by the earlier kernel ``old``."""
    def step() -> None:
        old(*_args(st, False))
        st.cur = 1 - st.cur
        st.step_count += 1
    return step


def _timed(paths: dict, steps: int, rounds: int, B: int) -> dict[str, float]:
    """Median microseconds per scene-step of each path, in rounds whose order rotates."""
    times: dict[str, list[float]] = {k: [] for k in paths}
    names = list(paths)
    for r in range(rounds):
        for k in names[r % len(names):] + names[:r % len(names)]:
            fn = paths[k]
            t0 = time.perf_counter()
            for _ in range(steps):
                fn()
            times[k].append((time.perf_counter() - t0) / (steps * B) * 1e6)
    return {k: statistics.median(v) for k, v in times.items()}


def measure(n_inner: int, batches: list[int], old, steps: int, rounds: int) -> None:
    scene = load_scene("scenes/figure1_n132_damped.toml",
                       [f"mesh.n_inner={n_inner}", "output.progress=false",
                        'time.kernel="numba"'])
    sim = Simulation(scene, MPI.COMM_SELF)
    alone = sim.integrator
    bp = BatchedProblem.from_problem(sim.problem, alone.dt, alone.beta2)
    u0, v0 = alone.u.copy(), alone.v_pred.copy()
    alone.step()
    for B in batches:
        today = _batch(bp, sim.columns.projection, alone.tau, B, u0, v0)
        before = _batch(bp, sim.columns.projection, alone.tau, B, u0, v0)
        today.step(diag=False)
        step_before = _stepper_of(old, before)
        with slp_vectorize():  # compiled as today's is (``NumbaColumns``)
            step_before()
        paths = {"today": lambda st=today: st.step(diag=False), "before": step_before}
        if B == 1:
            paths["alone"] = alone.step
        med = _timed(paths, steps, rounds, B)
        same = bool(np.array_equal(today.u, before.u))
        extra = f"  alone {med['alone']:7.1f}" if B == 1 else ""
        print(f"N = {n_inner:4d}  B = {B}  {today.columns.name:>17}  today {med['today']:7.1f}  "
              f"before {med['before']:7.1f} us/scene-step  before/today "
              f"{med['before'] / med['today']:4.2f}{extra}  same bits: {same}", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old", type=Path, required=True, help="_fused_kernels.py of an earlier "
                    "commit (git show COMMIT:solver/_fused_kernels.py > FILE)")
    ap.add_argument("--n", type=int, nargs="+", default=[132, 528])
    ap.add_argument("--B", type=int, nargs="+", default=[1, 2, 3, 4, 6, 8])
    ap.add_argument("--steps", type=int, default=0, help="steps per round (0: 3000 / (N/132)^2)")
    ap.add_argument("--rounds", type=int, default=5)
    args = ap.parse_args()
    if not args.old.is_file():
        raise SystemExit(f"error: --old {args.old}: no such file (git show "
                         "COMMIT:solver/_fused_kernels.py > FILE makes one)")
    old = _old_batched_step(args.old)
    for n in args.n:
        steps = args.steps or max(50, int(3000 / (n / 132) ** 2))
        measure(n, args.B, old, steps, args.rounds)


if __name__ == "__main__":
    main()
