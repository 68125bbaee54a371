"""Subcommands of ``stickslip`` that use the FE solver: ``run`` and ``plot``.

dolfinx and PETSc load when a run builds its problem (``studies.rundir.run_scene``), after
the command line and the environment are checked.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from stickslip.cli.commands import command_help
from stickslip.postprocess.plotting import DEFAULT_WINDOW, parse_window, plot_run
from stickslip.solver.scene import SceneError, load_scene
from stickslip.studies.output import output_root
from stickslip.studies.resources import ResourceError
from stickslip.studies.rundir import EXIT_CODES, RunDirError, run_scene
from stickslip.studies.rundir.readers import samples_problem
from stickslip.studies.sweep import is_sweep_dir, plot_sweep


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "run",
        help=command_help("run"),
        description=(
            "Run a scene: gmsh tube, discrete steady sliding state plus the scene's "
            "perturbation, explicit Newmark with the contact/friction projection. Writes "
            "RUN_DIR/scene.toml (resolved), samples.npz (inner-circle u_r, u_theta, "
            "velocities, status, energies) and summary.json. Works under mpirun."
        ),
    )
    p.add_argument("scene", help="scene TOML file, or the name of a scene in scenes/")
    p.add_argument("-o", "--output", help="run directory (default: $STICKSLIP_OUTPUT/<name>)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scene field, e.g. --set mesh.n_inner=264 (repeatable)")
    p.add_argument("--force", action="store_true",
                   help="replace an existing run directory that stickslip made (its "
                        ".stickslip marker); a live run, a folder that is not stickslip's or "
                        "one holding files stickslip did not write is refused. The new run is "
                        "built beside it and swapped in when it ends; if it fails or is "
                        "interrupted, the old run is kept")
    p.add_argument("--yes-i-know", dest="yes_i_know", action="store_true",
                   help="run even if the estimated memory or output exceeds what this "
                        "machine has (the estimate is printed before meshing), or the "
                        "samples cannot resolve the expected wave (output.sample_interval "
                        "above half its period)")
    p.add_argument("--plot", action="store_true", help="draw the run's figures when done")
    _window_option(p)
    p.add_argument("--profile", action="store_true", help="print where the time went")
    p.set_defaults(func=_run)

    p = sub.add_parser("plot", help=command_help("plot"),
                       description="The figures of a run directory, as PNG files: space-time "
                                   "maps of u_r - d and the contact status (last periods, "
                                   "--window), final profile, phase diagrams, energy balance, "
                                   "one period of the wave, iso-map on the deformed tube.")
    p.add_argument("run_dir", help="a run directory (`stickslip run`) or a sweep directory "
                   "(`stickslip sweep`: draws the regime map)")
    _window_option(p)
    p.set_defaults(func=_plot)


def _window_option(p: argparse.ArgumentParser) -> None:
    p.add_argument("--window", type=parse_window, default=DEFAULT_WINDOW,  # parsed by argparse
                   metavar="5T|4ms|0.01s|all",
                   help="time window of the space-time maps: a number of wave periods at a "
                        f"fixed point (nT), a duration (ms, s) or all (default {DEFAULT_WINDOW})")


def _run(args: argparse.Namespace) -> int:
    """``stickslip run``: exit status from the run's status (README: "Exit codes")."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    try:
        scene = load_scene(args.scene, args.overrides)
    except (SceneError, FileNotFoundError) as err:
        if comm.rank == 0:
            print(f"error: {err}", file=sys.stderr)
        return 2
    run_dir = Path(args.output) if args.output else output_root() / scene.name
    try:
        summary = run_scene(scene, run_dir, force=args.force, comm=comm, profile=args.profile,
                            check_resources=not args.yes_i_know,
                            check_sampling=not args.yes_i_know, plot=args.plot,
                            window=args.window)
    except (RunDirError, ResourceError, SceneError) as err:
        if comm.rank == 0:
            print(f"error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:  # a signal during the final save, honoured after it
        return EXIT_CODES["interrupted"]
    status = comm.bcast(summary.get("status") if comm.rank == 0 else None, root=0)
    return EXIT_CODES.get(status, 1)


def _plot(args: argparse.Namespace) -> int:
    run_dir = Path(args.run_dir)
    if is_sweep_dir(run_dir):
        for path in plot_sweep(run_dir):
            print(f"figure: {path}")
        return 0

    problem = samples_problem(run_dir, need=2)  # a map, a profile in time: two at least
    if problem:
        print(f"error: {problem}", file=sys.stderr)
        return 2
    for path in plot_run(run_dir, window=args.window):
        print(f"figure: {path}")
    return 0
