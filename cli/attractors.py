"""``stickslip attractors``: the census of a scene point (its attractors and their basins)."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from stickslip.cli.checks import fail
from stickslip.cli.commands import command_help
from stickslip.solver.scene import SceneError
from stickslip.studies.attractors.along import plot_along, run_along
from stickslip.studies.attractors.bundle import (
    BundleError,
    bundle_state,
    import_results,
    write_bundle,
)
from stickslip.studies.attractors.census import CensusError, collect, run_census
from stickslip.studies.attractors.classify import CELERITY_TOL, SPREAD_TOL
from stickslip.studies.attractors.request import (
    CensusRequest,
    along_values,
    build_census,
    show_answer,
)
from stickslip.studies.attractors.starts import DEFAULT_AMPLITUDE, DEFAULT_N_MODES, DEFAULT_SEED
from stickslip.studies.sweep import SweepError


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "attractors",
        help=command_help("attractors"),
        description=(
            "Run M random starts (and, with --structured, mode-k starts) of SCENE at each "
            "mesh of a ladder, describe every end state by its travelling components "
            "(wavenumber, direction, share, celerity from the space-time spectrum), class it "
            "(rigid wave, multi-wave, unsettled, steady sliding, diverged, failed), group the "
            "settled ones into attractors by those features, and report each attractor's "
            "basin share with a 95 % Wilson interval, its values and their change along the "
            "ladder (docs/attractors.md). Runs under mpirun; rerunning resumes."),
    )
    p.add_argument("scene", help="scene file (TOML) or shipped scene name; or a census "
                   "directory, to read (and --plot) its answer as it stands, running nothing")
    p.add_argument("--starts", type=int, default=16, metavar="M",
                   help="random starts per mesh (default 16)")
    p.add_argument("--meshes", default=None, metavar="N1,N2,...",
                   help="rungs of the ladder: contact-node counts N (default: the scene's "
                   "mesh.n_inner), or N then p then the element degree (264p1,132p2); "
                   "ordered by dofs")
    p.add_argument("--degrees", default=None, metavar="P1,P2",
                   help="element degrees (mesh.degree, 1 or 2) of every plain N of --meshes "
                   "(default: the scene's): --meshes 132,264 --degrees 1,2 is four rungs")
    p.add_argument("--structured", default=None, metavar="K1:K2",
                   help="also run the mode-k starts k = K1..K2 (reported apart)")
    p.add_argument("--end-time", type=float, default=None, metavar="T",
                   help="simulated time of every start's first leg (s; default: the "
                   "scene's); its windows compared are a third of it")
    p.add_argument("--max-time", type=float, default=None, metavar="T",
                   help="continue each unsettled start from where it stopped, in legs of "
                   "x1.5, up to T s (default 4.0; T = --end-time: no extension; finite; "
                   "its cost guard: every start run to T, see --yes-i-know)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scene key (repeatable), as for `stickslip run`")
    p.add_argument("--seed", type=int, default=DEFAULT_SEED, metavar="S",
                   help=f"random start i has seed S + i (default {DEFAULT_SEED})")
    p.add_argument("--n-modes", type=int, default=DEFAULT_N_MODES, metavar="K",
                   help=f"random starts mix modes 1..K (default {DEFAULT_N_MODES})")
    p.add_argument("--amplitude", type=float, default=DEFAULT_AMPLITUDE, metavar="A",
                   help=f"start amplitude in units of d (default {DEFAULT_AMPLITUDE})")
    p.add_argument("--celerity-tol", type=float, default=CELERITY_TOL, metavar="TOL",
                   help=f"relative celerity gap within one member (default {CELERITY_TOL})")
    p.add_argument("--spread-tol", type=float, default=SPREAD_TOL, metavar="TOL",
                   help=f"frame spread of a rigid wave, for rows without features (default "
                   f"{SPREAD_TOL})")
    p.add_argument("-o", "--output", help="census directory (default "
                   "$STICKSLIP_OUTPUT/attractors/<scene name>)")
    p.add_argument("--force", action="store_true",
                   help="use a directory that holds another census (its starts run again)")
    p.add_argument("--yes-i-know", dest="yes_i_know", action="store_true",
                   help="run even if the starts' estimated time (each to --max-time) "
                   "exceeds two days, or their memory or output what this machine has")
    _checks_and_outputs(p)
    p.set_defaults(func=_attractors)


def _checks_and_outputs(p: argparse.ArgumentParser) -> None:
    """The census's options beyond its definition: the certificates, the CEA, the backend
    and the outputs."""
    p.add_argument("--no-certify", action="store_true",
                   help="skip the certificates (reproducibility, persistence, the direct "
                   "travelling-wave solver for rigid waves)")
    p.add_argument("--dt-limit", action="store_true",
                   help="certificates of rigid waves also solve the Δt → 0 ladder (costly)")
    p.add_argument("--no-kick", action="store_true",
                   help="skip the kick test (one start per attractor perturbed by 1 %% and "
                   "run on for two windows: does it return?)")
    p.add_argument("--half-step", action="store_true",
                   help="also restart each multi-wave member's first start at half the time "
                   "step (4 windows): is it an end state of the finer scheme too?")
    p.add_argument("--cea", action="store_true",
                   help="also print the CEA's resolved unstable modes of steady sliding per "
                   "mesh and the share of starts ending on each (dominant or companion)")
    p.add_argument("--cea-fmax-hz", type=float, default=10_000.0, metavar="F",
                   help="upper end of the CEA's frequency band (default 10000 Hz)")
    p.add_argument("--backend", choices=("cpu", "gpu"), default="cpu",
                   help="batched integrator backend (where the scenes can be batched); gpu "
                   "needs CuPy and a CUDA device")
    p.add_argument("--bundle", default=None, metavar="DIR",
                   help="a GPU node without dolfinx runs the starts: the first call writes "
                   "DIR, `python3 -m stickslip.node DIR` runs it there, the same command "
                   "again (DIR/results copied back) answers (docs/gpu.md)")
    p.add_argument("--progress", choices=("auto", "live", "lines"), default="auto",
                   help="live status line (TTY) or one line per finished start")
    p.add_argument("--along", default=None, metavar="KEY=A:B:M",
                   help="a census at each of M values of KEY from A to B (or KEY=V1,V2,...), "
                   "attractors matched across the values by features; resumable")
    p.add_argument("--plot", action="store_true", help="draw the census figures")
    p.add_argument("--json", action="store_true",
                   help="print attractors.json instead of the summary")


def _attractors(args: argparse.Namespace) -> int:
    os.environ.setdefault("OMPI_MCA_osc", "^ucx")  # as `stickslip sweep`: one atomic counter
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    if (Path(args.scene) / "census.json").is_file():
        return _read(Path(args.scene), args) if comm.rank == 0 else 0
    try:
        census, out = _census(args, comm.size)
    except (SceneError, CensusError, ValueError, ImportError) as err:
        return fail(str(err), comm.rank)
    if args.along:
        if args.bundle:
            return fail("--along runs here: drop --bundle", comm.rank)
        return _along(census, out, args, comm)
    read_starts = None
    if args.bundle:
        from functools import partial

        rc = _prepare_bundle(census, Path(args.bundle), comm)
        if rc is not None:
            return rc
        read_starts = partial(import_results, Path(args.bundle))
    stream = open(os.devnull, "w") if args.json else sys.stdout  # noqa: SIM115
    if not (args.cea_fmax_hz > 0):
        return fail(f"--cea-fmax-hz {args.cea_fmax_hz}: give a frequency > 0 (Hz)", comm.rank)
    answer: dict = {}
    rc = run_census(census, out, comm=comm, force=args.force, progress=args.progress,
                    backend=args.backend, certify=not args.no_certify,
                    dt_limit=args.dt_limit, kick=not args.no_kick, stream=stream,
                    read_starts=read_starts, check_cost=not args.yes_i_know, answer=answer)
    if comm.rank == 0 and answer:
        rc = max(rc, _show(out, args, answer))
    return rc


def _census(args: argparse.Namespace, ranks: int):  # noqa: ANN202 - (Census, Path)
    """The census the arguments ask for and its directory
    (``studies.attractors.request.build_census``: one line where an option is bad, or where
    its cap is too costly without --yes-i-know)."""
    return build_census(CensusRequest(
        scene=args.scene, starts=args.starts, meshes=args.meshes, degrees=args.degrees,
        structured=args.structured,
        end_time=args.end_time, max_time=args.max_time, overrides=tuple(args.set),
        seed=args.seed, n_modes=args.n_modes, amplitude=args.amplitude,
        celerity_tol=args.celerity_tol, spread_tol=args.spread_tol, output=args.output,
        backend=args.backend, bundle=args.bundle is not None,
        check_cost=not args.yes_i_know, half_step=args.half_step), ranks)


def _prepare_bundle(census, bundle: Path, comm) -> int | None:  # noqa: ANN001
    """--bundle: write it where it is new (0), refuse one whose results are missing or that
    is another census's (2); None: its results are there, answer."""
    if comm.size > 1:
        return fail("--bundle prepares and answers in one process: run it without mpirun",
                     comm.rank)
    try:
        state = bundle_state(census, bundle)
        if state == "pending":
            raise BundleError(f"--bundle {bundle}: the node's results are missing; run "
                              f"`python3 -m stickslip.node {bundle}` on the node and copy "
                              f"{bundle / 'results'} back here")
        if state == "ready":
            return None
        write_bundle(census, bundle)
    except (ValueError, OSError) as err:  # BundleError, CensusError: one line
        return fail(str(err), comm.rank)
    print(f"bundle written: copy {bundle} to the GPU node, run `python3 -m stickslip.node "
          f"{bundle}` there, copy {bundle / 'results'} back, then run this command again")
    return 0


def _along(census, out: Path, args: argparse.Namespace, comm) -> int:  # noqa: ANN001

    try:
        key, values = along_values(census, args.along)
    except (ValueError, CensusError) as err:
        return fail(str(err), comm.rank)
    rc = run_along(census, key, values, out, comm=comm, force=args.force,
                   progress=args.progress, backend=args.backend,
                   certify=not args.no_certify, dt_limit=args.dt_limit,
                   kick=not args.no_kick, check_cost=not args.yes_i_know)
    if comm.rank == 0 and args.plot and rc in (0, 1) and (out / "along.json").is_file():
        print(f"figure: {plot_along(out)}")
    return rc


def _read(out: Path, args: argparse.Namespace) -> int:
    """The answer of an existing census directory, as it stands (nothing runs, nothing is
    written that need not be: a read-only directory reads the same). 0 only for a
    finished answer without failed starts, else 1 (its NOT FINISHED line says why)."""
    try:
        answer = collect(out, certify="cached", reading=True)
    except (CensusError, SweepError) as err:
        return fail(str(err), 0)
    if not args.json:
        print(answer["text"])
    rc = 0 if answer["finished"] and not answer["counts"].get("failed") else 1
    return max(rc, _show(out, args, answer))


def _show(out: Path, args: argparse.Namespace, answer: dict) -> int:
    """--json, --cea and --plot of ``answer`` (``request.show_answer``)."""
    return show_answer(out, answer, as_json=args.json,
                       cea_fmax_hz=args.cea_fmax_hz if args.cea else None, plot=args.plot)
