"""The ``stickslip`` command line.

``stickslip COMMAND`` imports the module of COMMAND alone (``cli.commands.COMMANDS``), and
that module imports what the command runs; ``stickslip --help`` lists the commands without
importing any. The FE stack loads when a command builds a problem: ``stickslip wave`` never
touches dolfinx, ``stickslip run`` never imports pyvista unless it plots.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import os
import signal
import sys
import threading
import traceback
from collections.abc import Collection, Sequence

from stickslip.cli.checks import environment_problem
from stickslip.cli.commands import COMMANDS
from stickslip.cli.pipes import reader_tolerant_stdout
from stickslip.solver import __version__
from stickslip.studies.output import output_root
from stickslip.studies.rundir.ownership import normal_path


def _info(args: argparse.Namespace) -> int:
    """Print versions of the stack and where outputs go."""
    import platform

    lines = [f"stickslip {__version__}", f"python {platform.python_version()}"]
    try:
        import dolfinx
        from mpi4py import MPI
        from petsc4py import PETSc

        petsc = ".".join(str(v) for v in PETSc.Sys.getVersion())
        comm = MPI.COMM_WORLD
        lines += [
            f"dolfinx {dolfinx.__version__}",
            f"PETSc {petsc} (scalar {PETSc.ScalarType.__name__})",
            f"MPI {MPI.Get_library_version().splitlines()[0].strip()}",
            f"MPI size {comm.size}",
        ]
        rank = comm.rank
    except ImportError as err:
        lines.append(f"dolfinx: not importable here ({err}); run through ./dev or Docker")
        rank = 0
    try:
        import gmsh

        lines.append(f"gmsh {gmsh.__version__}")
    except ImportError:
        lines.append("gmsh: not importable")
    import numpy
    import scipy

    lines += [f"numpy {numpy.__version__}", f"scipy {scipy.__version__}"]
    lines.append(f"outputs: {output_root().resolve()}  (set STICKSLIP_OUTPUT or use -o)")
    if rank == 0:
        print("\n".join(lines))
    return 0


def build_parser(commands: Collection[str] | None = None) -> argparse.ArgumentParser:
    """The parser of ``stickslip``: every command's (``commands`` None), or the full parsers
    of ``commands`` only, with every other command listed by its line of
    ``cli.commands.COMMANDS`` (its module is not imported)."""
    parser = argparse.ArgumentParser(
        prog="stickslip",
        description=(
            "Friction-induced stick-slip(-separation) waves of an elastic tube on a rotating "
            "rigid cylinder: FEniCSx transient solver and the semi-analytical reduced model."
        ),
    )
    parser.add_argument("--version", action="version", version=f"stickslip {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    p = sub.add_parser("info", help="versions of dolfinx, PETSc, MPI; where outputs go",
                       description="Print the versions of stickslip, Python, dolfinx, PETSc, "
                                   "MPI, gmsh, numpy and scipy, the MPI size, and the folder "
                                   "where run directories go by default ($STICKSLIP_OUTPUT or "
                                   "./runs).")
    p.set_defaults(func=_info)

    wanted = None if commands is None else {COMMANDS[c][0] for c in commands if c in COMMANDS}
    registered: set[str] = set()
    for name, (module, line) in COMMANDS.items():
        if wanted is not None and module not in wanted:
            sub.add_parser(name, help=line)  # listed; its module is not imported
        elif module not in registered:  # adds every command of the module
            registered.add(module)
            importlib.import_module(module).register(sub)
    return parser


def _command_named(argv: Sequence[str]) -> str | None:
    """The command of a command line: its first word that is not an option (``stickslip``'s
    own options, ``-h`` and ``--version``, take no value)."""
    return next((word for word in argv if not word.startswith("-")), None)


#: The arguments that name a directory: ``-o`` (run, continue, sweep, travel, attractors), a
#: run or sweep directory (continue, plot, compare), ``--from``, ``--bundle``, ``--modes``.
DIRECTORY_ARGUMENTS = ("output", "run_dir", "from_run", "bundle", "modes")


def _normal_directories(args: argparse.Namespace) -> None:
    """Every directory argument as ``studies.rundir.ownership.normal_path`` names it (absolute,
    ``.``, ``..`` and ``//`` resolved): ``R/../R``, ``R/.``, ``R//`` and ``./R`` are ``R``
    for every command, in its messages and in the claim, the swap and the checks alike."""
    for name in DIRECTORY_ARGUMENTS:
        value = getattr(args, name, None)
        if value:
            setattr(args, name, str(normal_path(value)))


def _last_resort(err: BaseException) -> str:
    """One line for an error no handler foresaw (errors, not tracebacks)."""
    if isinstance(err, MemoryError):
        return ("out of memory; reduce the problem (mesh.n_inner, time.end_time, "
                "output.sample_interval) or use a machine with more memory")
    if isinstance(err, UnicodeDecodeError):
        return f"a file is not UTF-8 text ({err.reason} at byte {err.start}); check the inputs"
    where = f" {err.filename}" if getattr(err, "filename", None) else ""
    what = err.strerror or str(err)  # type: ignore[union-attr]
    return f"cannot use{where}: {what}; check the path, its permissions and the free space"


def _end_all_ranks(code: int) -> None:
    """Under mpirun an error seen by one rank must end every rank (no hang): Abort."""
    mpi = sys.modules.get("mpi4py.MPI")
    if mpi is not None and mpi.Is_initialized() and not mpi.Is_finalized() \
            and mpi.COMM_WORLD.size > 1:
        sys.stderr.flush()
        mpi.COMM_WORLD.Abort(code)


#: Signals that stop a command as Ctrl-C does: a batch system's stop, a closed terminal.
STOP_SIGNALS = ("SIGTERM", "SIGHUP")


@contextlib.contextmanager
def _stops_as_interrupt():  # noqa: ANN202
    """SIGTERM and SIGHUP raise KeyboardInterrupt, as SIGINT does, so every command saves
    what it has done and exits 130 (their default is to die at once: exit 143 or 129, with
    nothing saved). A command that handles them itself (``run``, ``sweep``) installs its
    own handlers inside; the previous ones are restored at the end."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def stop(signum, frame):  # noqa: ANN001, ARG001
        raise KeyboardInterrupt(f"by {signal.Signals(signum).name}")

    previous = {name: signal.signal(getattr(signal, name), stop) for name in STOP_SIGNALS}
    # SIGINT raises KeyboardInterrupt while the command runs, whatever handler the caller
    # left (an embedding program's, one that only records it); an ignored SIGINT (a job
    # started in the background) stays ignored
    if signal.getsignal(signal.SIGINT) is not signal.SIG_IGN:
        previous["SIGINT"] = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        for name, handler in previous.items():
            signal.signal(getattr(signal, name), handler)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point: the handler's exit status; 2 with one line for a foreseen error class."""
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser([name] if (name := _command_named(argv)) else [])
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2

    problem = environment_problem()
    for flag, value in (("-o", getattr(args, "output", None)), ("--plot", getattr(
            args, "plot", None)), ("--json", getattr(args, "json", None))):
        if value == "":  # `-o "$UNSET"`: never the default place in its stead
            problem = problem or (f"{flag} is empty: give a path (is a shell variable unset?), "
                                  f"or leave {flag} out")
    if problem:  # before MPI starts; under mpirun every rank ends, rank 0 says why
        # and sets mpirun's exit status (its first non-zero rank's). The other ranks end with
        # 0: an exit 2 there made mpirun kill rank 0 before its line was out.
        if os.environ.get("OMPI_COMM_WORLD_RANK", os.environ.get("PMIX_RANK", "0")) == "0":
            print(f"error: {problem}", file=sys.stderr, flush=True)
            return 2
        return 0
    try:
        return _dispatch(args)
    except Exception:  # a bug: under mpirun every rank ends with it, never a hang
        _abort_job_after_bug()
        raise


def _abort_job_after_bug() -> None:
    """An exception no handler expects, on one rank of an MPI job: its traceback, then the
    whole job ends (MPI Abort, exit 1). Left to Python, the rank would end in MPI's
    finalisation and wait there for ranks that wait for it: a job that never ends."""
    mpi = sys.modules.get("mpi4py.MPI")
    if mpi is not None and mpi.Is_initialized() and not mpi.Is_finalized() \
            and mpi.COMM_WORLD.size > 1:
        traceback.print_exc()
        _end_all_ranks(1)


def _dispatch(args: argparse.Namespace) -> int:
    """Run the command's handler; the errors a user can meet end in one line (exit 2)."""
    try:
        _normal_directories(args)
        with _stops_as_interrupt(), reader_tolerant_stdout():
            return int(args.func(args) or 0)
    except KeyboardInterrupt as stop:  # a handler may say what it kept (its message)
        print(f"stickslip: interrupted{f' {stop}' if str(stop) else ''}", file=sys.stderr)
        return 130
    except (OSError, UnicodeDecodeError, MemoryError) as err:
        print(f"error: {_last_resort(err)}", file=sys.stderr, flush=True)
        _end_all_ranks(2)
        return 2
    except RecursionError:  # a scene or sweep file with arrays nested thousands deep
        print("error: an input file is nested too deeply to be a scene or sweep file "
              "(RecursionError); check the file given", file=sys.stderr, flush=True)
        _end_all_ranks(2)
        return 2
    except ValueError as err:  # a file read back that is corrupt, truncated or edited
        readers = sys.modules.get("stickslip.studies.rundir.readers")
        if readers is None or not isinstance(err, readers.ReadError):
            raise
        print(f"error: {err}", file=sys.stderr, flush=True)
        _end_all_ranks(2)
        return 2


if __name__ == "__main__":
    try:
        sys.exit(main())
    except KeyboardInterrupt:  # while Python was still importing: nothing started, nothing lost
        print("stickslip: interrupted", file=sys.stderr)
        sys.exit(130)
