"""``stickslip continue RUN --until T [-o DIR]``: a run continued from its checkpoint.

dolfinx and PETSc load when the continued run builds its problem, after the command line
and the environment are checked.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from stickslip.cli.checks import fail
from stickslip.cli.commands import command_help
from stickslip.studies.resources import ResourceError
from stickslip.studies.rundir import EXIT_CODES, RunDirError, continue_run
from stickslip.studies.rundir.readers import ReadError


def _time(text: str) -> float:
    """``--until`` value: a finite time in seconds > 0 (argparse prints the error)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a time in seconds") from None
    if not (math.isfinite(value) and value > 0.0):
        raise argparse.ArgumentTypeError(f"{text!r}: give a finite time > 0 (s)")
    return value


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "continue",
        help=command_help("continue"),
        description=(
            "Continue a run directory (of `stickslip run`, or a scene of a batched sweep or "
            "census) from its checkpoint.npz to the time --until: the samples, final field "
            "and summary are those of one run straight to that time. Without -o the run "
            "directory is extended in place (atomically: an interrupted or failed "
            "continuation leaves it as it was). An MPI run continues under mpirun with the "
            "same number of ranks."
        ),
    )
    p.add_argument("run_dir", help="a run directory with a checkpoint.npz")
    p.add_argument("--until", type=_time, required=True, metavar="T",
                   help="the new end time (s), beyond the run's current time")
    p.add_argument("-o", "--output", help="write the continued run here instead (the "
                   "original is not touched)")
    p.add_argument("--force", action="store_true",
                   help="replace an earlier run directory at -o (as `stickslip run --force`)")
    p.add_argument("--yes-i-know", dest="yes_i_know", action="store_true",
                   help="continue even if the estimated memory or output exceeds what this "
                        "machine has")
    p.set_defaults(func=_continue)


def _continue(args: argparse.Namespace) -> int:
    """Exit status from the continued run's status (as ``stickslip run``); 2 with one line
    when the run cannot be continued."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    try:
        summary = continue_run(Path(args.run_dir), args.until,
                               None if args.output is None else Path(args.output),
                               force=args.force, comm=comm,
                               check_resources=not args.yes_i_know, progress=True)
    except (ReadError, RunDirError, ResourceError) as err:
        return fail(str(err), comm.rank)
    except KeyboardInterrupt:  # a signal during the final save, honoured after it
        return EXIT_CODES["interrupted"]
    status = comm.bcast(summary.get("status") if comm.rank == 0 else None, root=0)
    return EXIT_CODES.get(status, 1)
