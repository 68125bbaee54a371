"""The chaos test's λ₁ of one census start on one rank and on a pair of ranks, side by side.

    ./dev mpirun -n 2 python3 benchmarks/chaos_pair.py RUN_DIR [--windows 10] [--window W]

Rank 0 takes λ₁ with the two-column twin (``chaos.BatchTwin``) alone while rank 1 sleeps,
then both take it with the reference on rank 0 and the twin on rank 1 (``chaos.SplitTwin``):
``--windows`` × W of twin steps renormalised every W/20 (W: ``--window``, default the
census's 0.1 s). Prints both wall times, their ratio and whether every interval's
ln(d/d₀) is the same bits.
"""

from __future__ import annotations

import argparse
import time

import dolfinx  # noqa: F401 - PETSc initialises collectively: every rank, before rank 0 works alone
from mpi4py import MPI

from stickslip.studies.attractors import chaos
from stickslip.studies.sweep.schedule import wait_quietly


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir")
    ap.add_argument("--windows", type=float, default=10.0)
    ap.add_argument("--window", type=float, default=0.1)
    args = ap.parse_args()
    comm = MPI.COMM_WORLD
    if comm.size != 2:
        raise SystemExit("error: run it under mpirun -n 2")
    duration, tau = args.windows * args.window, args.window / 20
    if comm.rank == 0:
        t0 = time.perf_counter()
        whole = chaos.fe_lyapunov(args.run_dir, duration, tau)
        t_whole = time.perf_counter() - t0
    wait_quietly(comm)
    t0 = time.perf_counter()
    split = chaos.fe_lyapunov(args.run_dir, duration, tau,
                              pair=chaos.Pair(comm, 1 - comm.rank, comm.rank))
    t_split = time.perf_counter() - t0
    if comm.rank == 0:
        print(f"one rank {t_whole:.1f} s, two ranks {t_split:.1f} s "
              f"({t_whole / t_split:.2f}x); same ln(d/d0) bits: {split.logs == whole.logs}; "
              f"lambda1 = {whole.exponent:.4g} +- {whole.error:.2g} 1/s")


if __name__ == "__main__":
    main()
