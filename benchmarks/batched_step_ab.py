"""A/B timing of the batched kernel in ONE process: an earlier ``batched_step`` against today's.

This VM's timings drift by up to 1.5x from run to run (placement of the arrays, the shared
L3), far more than a kernel change, so comparing two runs says little. Here both kernels
step the same (n, B) arrays in the same process, in alternating rounds of ``--steps`` steps
(order rotated each round), and the median per kernel is printed. Variants:

* ``old``: the kernel of an earlier commit, from a file (``--old``), called with its own
  arguments: before the lean steps (36 arguments) it stores v_n, a_n, K u_n at every step;
  a later one (38 arguments: ``diag``, ``keep``) runs as ``old full`` and ``old lean``.
  It is compiled as numba compiles by default (SLP vectoriser off);
* ``full``: today's kernel with ``diag = True`` at every step (a sampled step);
* ``lean``: today's kernel with ``diag = False`` (an unsampled step: v_n, a_n, K u_n not
  stored). Today's kernel is compiled as the sweep compiles it (``BatchedExplicit.step``:
  SLP on for its first call, ``solver.fused.slp_vectorize``).

All compute the same state bitwise (checked at the end against a fresh run of today's
kernel), so they may share the arrays. Examples (run two at once for the 2-rank case)::

    git show 202fb9c:solver/_fused_kernels.py > /tmp/old_kernels.py     # before lean steps
    git show main:solver/_fused_kernels.py > /tmp/main_kernels.py       # lean steps, main
    ./dev python3 benchmarks/batched_step_ab.py DIR/problem_n528 --old /tmp/old_kernels.py --B 8
    ./dev python3 benchmarks/batched_step_ab.py DIR/problem_n132 --both --B 32   # LONG_B
"""

from __future__ import annotations

import argparse
import importlib
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def _old_kernel(path: Path):
    """``batched_step`` of the file ``path``, imported by its name (so numba's cache works)."""
    sys.path.insert(0, str(path.resolve().parent))
    return importlib.import_module(path.stem).batched_step


def main() -> None:
    from benchmarks.gpu_bench import load, tiled
    from stickslip.solver.contact import ContactLaw
    from stickslip.solver.ensemble import BatchedExplicit

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("bundle", type=Path, help="a bundle of benchmarks/gpu_bench.py prepare")
    ap.add_argument("--old", type=Path, help="_fused_kernels.py of an earlier commit")
    ap.add_argument("--B", type=int, default=8)
    ap.add_argument("--steps", type=int, default=100, help="steps per round and kernel")
    ap.add_argument("--rounds", type=int, default=9)
    ap.add_argument("--tag", default="", help="label printed with each line")
    ap.add_argument("--today", choices=("auto", "batched_step", "batched_step_long"),
                    default="auto", help="today's kernel: as the sweep picks it by B, or forced")
    ap.add_argument("--both", action="store_true",
                    help="time batched_step against batched_step_long (lean and full steps)")
    args = ap.parse_args()

    data = load(args.bundle)
    bp = data[1].problem
    columns, starts = tiled(data, args.B, 1, 1)  # the bundle's starts, tiled to B columns
    laws = [ContactLaw.from_scene(sc, bp.dt) for sc in columns]
    u0, B = starts.u0, args.B
    scenes = tuple(np.array([getattr(law, k) for law in laws]) for k in ("d", "slide", "f"))
    it = BatchedExplicit(bp, *scenes)
    if args.today != "auto":
        from stickslip.solver.fused import kernel

        it.columns.name, it.columns.fn = args.today, kernel(args.today)
    it.set_state(u0, np.zeros_like(u0))
    it.step()  # load / compile today's kernel
    old = _old_kernel(args.old) if args.old else None
    dt, b2 = it.dt, it.beta2
    coef = (b2 * dt, 0.5 * dt, (0.5 - b2) * dt, b2 == 0.5, dt, it.kappa, 1.0 / it.kappa)

    # an old kernel from before the lean steps takes 36 arguments, a later one 38 (diag, keep)
    lean_old = old is not None and old.py_func.__code__.co_argcount == 38

    def old_step(diag: bool = True) -> None:
        cur, nxt = it.cur, 1 - it.cur
        tail = (diag, it.keep) if lean_old else ()
        old(it.indptr, it.indices, it.data, it.u_levels[cur], it.u_levels[nxt], it.v,
            it.v_pred, it.a,
            it.ku, it.nim, *coef, it.cx, it.ph_re, it.ph_im, it.pc_re, it.pc_im, it.cmass,
            it.cinv, it.d, it.slide, it.f, it.r_r, it.r_t, it.r_x, it.r_y, it.status,
            it.zprev, it.work, it.acc, it.cslot, *tail)
        it.cur = nxt
        it.step_count += 1

    variants = {"full": lambda: it.step(diag=True), "lean": lambda: it.step(diag=False)}
    if args.both:  # today's two kernels on the same arrays, interleaved (the LONG_B choice)
        from stickslip.solver.fused import kernel

        fns = {name: kernel(name) for name in ("batched_step", "batched_step_long")}

        def pick(name: str, diag: bool):
            def run() -> None:
                it.columns.name, it.columns.fn = name, fns[name]
                it.step(diag=diag)
            return run

        variants = {f"{name} {'full' if diag else 'lean'}": pick(name, diag)
                    for name in fns for diag in (False, True)}
    if old is not None:
        old_step()  # load / compile
        olds = ({"old full": old_step, "old lean": lambda: old_step(False)} if lean_old
                else {"old": old_step})
        variants = {**olds, **variants}
    times: dict[str, list[float]] = {k: [] for k in variants}
    names = list(variants)
    for r in range(args.rounds):
        for k in names[r % len(names):] + names[:r % len(names)]:
            fn = variants[k]
            t0 = time.perf_counter()
            for _ in range(args.steps):
                fn()
            times[k].append((time.perf_counter() - t0) / (args.steps * B) * 1e6)
    ref = BatchedExplicit(bp, *scenes)
    ref.set_state(u0, np.zeros_like(u0))
    for _ in range(it.step_count):
        ref.step()
    same = bool(np.array_equal(ref.u, it.u))
    for k, x in times.items():
        name = k if k.startswith("old") or args.both else f"{k} ({it.columns.name})"
        print(f"{args.tag} {args.bundle.name} B={B} {name}: "
              f"median {statistics.median(x):.1f} "
              f"min {min(x):.1f} max {max(x):.1f} us/scene-step ({args.rounds} rounds x "
              f"{args.steps} steps); state same bits as today's kernel alone: {same}",
              flush=True)


if __name__ == "__main__":
    main()
