"""The ``stickslip`` command line.

Every subcommand imports what it needs only when it runs: ``stickslip wave`` never touches
dolfinx, ``stickslip run`` never imports pyvista unless it plots.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from solver import __version__
from studies.output import output_root


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


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="stickslip",
        description=(
            "Friction-induced stick-slip(-separation) waves of an elastic tube on a rotating "
            "rigid cylinder: FEniCSx transient solver and the semi-analytical reduced model."
        ),
    )
    parser.add_argument("--version", action="version", version=f"stickslip {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    p = sub.add_parser("info", help="versions of dolfinx, PETSc, MPI; where outputs go")
    p.set_defaults(func=_info)

    for module in COMMAND_MODULES:
        _register(sub, module)
    return parser


# Modules that add subcommands through ``register(subparsers)``. Each keeps its heavy imports
# (dolfinx, PETSc, matplotlib, pyvista) inside its handlers.
COMMAND_MODULES = (
    "cli.run",  # run, plot
    "cli.semianalytic",  # wave, flutter
    "cli.compare",  # compare
    "cli.sweep",  # sweep
    "cli.flutter_fe",  # flutter-fe
    "cli.continuum",  # flutter-exact (issue 13)
)


def _register(sub: argparse._SubParsersAction, module: str) -> None:
    import importlib

    try:
        mod = importlib.import_module(module)
    except ModuleNotFoundError as err:  # a feature module not present in this version
        if err.name != module:
            raise
        return
    mod.register(sub)


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    return int(args.func(args) or 0)


if __name__ == "__main__":
    sys.exit(main())
