"""``stickslip sweep``: run a sweep file under mpirun, list its scenes, draw its regime map."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from stickslip.cli.checks import fail
from stickslip.cli.commands import command_help
from stickslip.solver.schemes.select import check_backend
from stickslip.studies.attractors.maps import run_map
from stickslip.studies.output import output_root
from stickslip.studies.sweep.batch import parse_batch
from stickslip.studies.sweep.regime_map import plot_sweep
from stickslip.studies.sweep.schedule import run_sweep
from stickslip.studies.sweep.spec import SweepError, SweepSpec, load_sweep
from stickslip.studies.sweep.table import recorded_failures, task_state

# ============================================================================ CLI


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "sweep",
        help=command_help("sweep"),
        description=(
            "Run every scene of a sweep file (base scene + [grid]/[[points]] of dotted-key "
            "overrides) into SWEEP_DIR/runs/<id>/, with a table SWEEP_DIR/sweep.{csv,json}. "
            "Under `mpirun -n P`, groups of group_size ranks take scenes from a shared "
            "counter. Re-running resumes: finished scenes are skipped. "
            "`stickslip sweep --plot SWEEP_DIR` draws the regime map of a sweep directory."
        ),
    )
    p.add_argument("target", help="sweep file (TOML), or a sweep directory with --plot")
    p.add_argument("-o", "--output", help="sweep directory (default: the file's `output`, "
                   "else $STICKSLIP_OUTPUT/sweeps/<name>)")
    p.add_argument("--group-size", type=int, help="ranks per scene (overrides the file)")
    p.add_argument("--retry-failed", action="store_true",
                   help="run scenes that failed or diverged again")
    p.add_argument("--plot", action="store_true",
                   help="draw the regime map (after the sweep, or of an existing SWEEP_DIR)")
    p.add_argument("--yes-i-know", dest="yes_i_know", action="store_true",
                   help="run even if the pending scenes' estimated time exceeds two days, or a "
                        "scene's memory or output exceeds what this machine has")
    p.add_argument("--list", action="store_true",
                   help="list the scenes and their state; run nothing")
    p.add_argument("--batch", default=None, metavar="off|auto|B",
                   help="advance scenes that share mesh, material, dt and scheme as batches "
                        "(one sparse matrix x block product per step, solver/ensemble.py): "
                        "off, auto (size from memory and ranks) or a size B; default: the "
                        "sweep file's `batch`, else off")
    p.add_argument("--backend", choices=("cpu", "gpu"), default=None,
                   help="batched integrator on the CPU (numba) or on a GPU (CuPy, optional "
                        "extra; see README); default: the sweep file's `backend`, else cpu")
    p.add_argument("--progress", choices=("auto", "live", "lines"), default="auto",
                   help="live status line (TTY) or one line per finished scene (auto: live "
                        "only on a terminal outside mpirun)")
    p.set_defaults(func=_sweep)


def _out_dir(spec: SweepSpec, args: argparse.Namespace) -> Path:
    if args.output:
        return Path(args.output)
    if spec.output is not None:
        return spec.output
    return output_root() / "sweeps" / spec.name


def _sweep(args: argparse.Namespace) -> int:
    target = Path(args.target)
    if target.is_dir():
        if not args.plot:
            print(f"error: {target} is a directory; use `stickslip sweep --plot {target}` to "
                  "draw its map, or give a sweep file", file=sys.stderr)
            return 2
        try:
            for path in plot_sweep(target):
                print(f"figure: {path}")
        except SweepError as err:
            return fail(str(err))
        return 0
    # Only an atomic counter is needed (one operation per scene): keep OpenMPI's UCX one-sided
    # component, which warns on hosts without UCX devices, out of the way unless asked for.
    os.environ.setdefault("OMPI_MCA_osc", "^ucx")
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    try:
        spec = load_sweep(target, large=args.yes_i_know)
    except SweepError as err:
        return fail(str(err), comm.rank)
    out_dir = _out_dir(spec, args)
    if args.group_size is not None and args.group_size < 1:
        if comm.rank == 0:
            print("error: --group-size must be >= 1", file=sys.stderr)
        return 2

    backend = args.backend or spec.backend
    try:
        batch = parse_batch(args.batch if args.batch is not None else spec.batch)
        check_backend(backend, batched=batch != "off")
    except (ValueError, ImportError) as err:
        return fail(str(err), comm.rank)
    if args.list:
        if comm.rank == 0:
            failures = recorded_failures(out_dir)
            for task in spec.tasks:
                print(f"{task.id:40s} {task_state(out_dir, spec, task, failures=failures)}")
        return 0
    if spec.attractors:  # a census at every point (studies/attractors/maps.py)
        rc = run_map(spec, out_dir, comm=comm, group_size=args.group_size,
                     retry_failed=args.retry_failed, progress=args.progress, batch=batch,
                     backend=backend)
        if args.plot and rc in (0, 1) and comm.rank == 0:
            for path in plot_sweep(out_dir):  # the census's regime map
                print(f"figure: {path}")
        return rc
    rc = run_sweep(spec, out_dir, comm=comm, group_size=args.group_size,
                   retry_failed=args.retry_failed, progress=args.progress, batch=batch,
                   backend=backend, check_cost=not args.yes_i_know)
    if args.plot and rc in (0, 1) and comm.rank == 0:
        for path in plot_sweep(out_dir):
            print(f"figure: {path}")
    return rc
