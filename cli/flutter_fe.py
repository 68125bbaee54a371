"""``stickslip flutter-fe SCENE``: complex eigenvalue analysis of FE steady sliding."""


from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from stickslip.cli.checks import fail, output_file_problem
from stickslip.cli.commands import command_help
from stickslip.solver.atomic import atomic_write_text
from stickslip.solver.scene import SceneError, load_scene, tube_axial_layers
from stickslip.solver.scene.sections import END_NAMES
from stickslip.studies.flutter_fe.cea import (
    CEAMode,
    CEAResult,
    ContactGrid,
    build_operators,
    cea_problem,
    complex_eigenvalue_analysis,
    contact_grid,
    distinct_modes,
    friction_relaxation_time,
    unrepresented_terms,
)
from stickslip.studies.flutter_fe.doublets import MIN_PURITY, doublet_lines, doublets
from stickslip.studies.flutter_fe.plots import (
    plot_cea_diagram,
    plot_contact_modes,
    plot_spectrum,
)
from stickslip.studies.flutter_fe.references import reduced_model_flutter
from stickslip.studies.flutter_fe.shapes import modes_dir_problem, write_mode_shapes
from stickslip.studies.flutter_fe.tables import csv_text, lock_in_points, mode_rows, sweep_rows
from stickslip.studies.resources import tube_nodes

if TYPE_CHECKING:
    from mpi4py import MPI

    from stickslip.solver.scene import Scene

# --------------------------------------------------------------------------------- CLI


#: Friction values of one ``--f-sweep``: each is a whole CEA (seconds to minutes).
F_SWEEP_MAX = 200


def parse_f_sweep(text: str) -> np.ndarray:
    """``"start:stop:num"`` (inclusive linspace) or a comma list ``"0,0.3,0.7"``."""
    try:
        if ":" in text:
            a, b, n = text.split(":")
            a, b, n = float(a), float(b), int(n)
            if not 1 <= n <= F_SWEEP_MAX:
                raise ValueError(f"--f-sweep {text!r}: {n} values, each a full CEA; give "
                                 f"at least 1 and at most {F_SWEEP_MAX} (a diagram needs a "
                                 "few tens)")
            vals = np.linspace(a, b, n)
        else:
            vals = np.array([float(x) for x in text.split(",") if x.strip()])
    except ValueError as err:
        if str(err).startswith("--f-sweep"):
            raise
        raise ValueError(f"--f-sweep {text!r}: use start:stop:num or a comma list") from err
    if vals.size == 0 or not np.all(np.isfinite(vals) & (vals >= 0) & (vals <= 10)):
        # as flutter-exact's; f = 1e308 made MUMPS fail in the CEA's factorisation
        raise ValueError(f"--f-sweep {text!r}: need friction coefficients in [0, 10]")
    if vals.size > F_SWEEP_MAX:
        raise ValueError(f"--f-sweep {text!r}: {vals.size} values, each a full CEA; at most "
                         f"{F_SWEEP_MAX} (a diagram needs a few tens)")
    return vals


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``flutter-fe SCENE`` to the ``stickslip`` subcommands."""
    p = sub.add_parser(
        "flutter-fe",
        help=command_help("flutter-fe"),
        description=(
            "Linearise the FE system about discrete steady sliding (contact nodes stay in "
            "contact, tangential force = f x normal reaction), with the scene's Kelvin-Voigt "
            "damping C = tau (K + K_f) and friction filter: lambda^2 M + lambda C + K + K_f, "
            "solved exactly through (K + K_f) phi = mu M phi (SLEPc shift-and-invert); with a "
            "regularised friction bound, the quadratic problem with its relaxation state "
            "(SLEPc PEP, one rank). Lists the unstable (flutter) modes: frequency, growth "
            "rate, damping ratio zeta, wavenumber k, direction; mesh-scale modes last. Works "
            "under mpirun (Coulomb friction)."
        ),
    )
    p.add_argument("scene", help="scene TOML file, or the name of a scene in scenes/")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scene field, e.g. --set loading.f=0.5 (repeatable)")
    p.add_argument("--fmax-hz", type=float, default=10_000.0,
                   help="upper end of the frequency band (Hz, default 10000)")
    p.add_argument("--mass", choices=("lumped", "consistent"), default="lumped",
                   help="mass matrix: the explicit solver's lumped one (default) or consistent")
    p.add_argument("--friction", choices=("nodal", "1-2-1"), default=None,
                   help="friction force of node i: f x its nodal reaction or f x the 1-2-1 "
                        "filtered reactions of i-1, i, i+1 (removes the spurious mesh-scale "
                        "branch, docs/friction_filter.md); default: the scene's "
                        "friction.filter, the transient's law")
    p.add_argument("--modes", metavar="DIR", default=None,
                   help="write the unstable mode shapes to DIR: one VTX folder per mode "
                        "(ParaView: one period of the motion), modes.csv (the table) and "
                        "contact.csv (psi on the contact circle; a 3D tube's by ring, z/L)")
    p.add_argument("--f-sweep", default=None, metavar="A:B:N|F1,F2,...",
                   help="also sweep the friction coefficient (CEA diagram with --plot)")
    p.add_argument("--kmax", type=int, default=12, help="reduced-model modes to compare (k<=)")
    p.add_argument("--k-detail", type=int, default=4,
                   help="wavenumber whose branches the CEA diagram details (default 4)")
    p.add_argument("--top", type=int, default=20, help="unstable modes listed (table output)")
    p.add_argument("--csv", metavar="FILE", default=None,
                   help="every computed mode, stable ones too, as CSV (frequency, Re and Im "
                        "of lambda, damping ratio, k, direction, purity); with --f-sweep also "
                        "FILE_f_sweep.csv (each f's modes) and FILE_lock_in.csv (where each k "
                        "starts to grow)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--plot", metavar="PNG", default=None,
                   help="growth vs frequency (or the CEA diagram with --f-sweep) to this file")
    p.add_argument("--mode-plot", metavar="PNG", default=None,
                   help="3D tube: the --mode-count fastest-growing unstable modes, one panel "
                        "each: Re u_theta on the contact surface r = R unrolled in (theta, z) "
                        "(u_r = 0 there: the sliding contact holds it), max |u_theta| = 1")
    p.add_argument("--mode-count", type=int, default=4, metavar="K",
                   help=f"modes drawn by --mode-plot (default 4, at most {MODE_COUNT_MAX})")
    p.add_argument("--length", type=float, default=None, metavar="L",
                   help="the finite tube of this length (m) in 3D instead of plane strain: "
                        "the scene's annulus extruded in hexahedra; each mode also gets its "
                        "axial order m (nodal rings along z); friction on the theta-rows only "
                        "(docs/flutter.md, 'A finite tube'). Overrides the scene's "
                        "geometry.length and sets mesh.dim = 3; a scene with mesh.dim = 3 "
                        "needs no option")
    p.add_argument("--n-axial", type=int, default=None, metavar="NZ",
                   help="3D tube: element layers along z; overrides mesh.n_axial (default: "
                        "the scene's, 0 = cells as long as they are wide on the contact "
                        "surface, round(L N / (2 pi R)))")
    p.add_argument("--ends", choices=END_NAMES, default=None,
                   help="3D tube: the ends z = 0, L: free, roller (u_z = 0; the plane-strain "
                        "modes are then 3D modes) or clamped; overrides boundary.ends "
                        "(default: the scene's, \"free\")")
    p.set_defaults(func=flutter_fe_command)


#: The most panels of ``--mode-plot`` (``--mode-count``): each keeps a whole eigenvector.
MODE_COUNT_MAX = 16
#: The largest wavenumber (``--kmax``, ``--k-detail``) and table length (``--top``) taken:
#: as for ``stickslip flutter --kmax``.
KMAX_LIMIT = 10_000
#: ``--fmax-hz`` up to this many times the mesh's highest frequency is solved (measured:
#: 250 times on the smoke mesh; 2.5e8 times ended in an eigenpair of residual 26).
FMAX_FACTOR = 100.0


def flutter_fe_command(args: argparse.Namespace) -> int:
    """Handler of ``stickslip flutter-fe``."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    try:
        scene = load_scene(args.scene, args.overrides)
        fs = parse_f_sweep(args.f_sweep) if args.f_sweep else None
    except (SceneError, FileNotFoundError, ValueError) as err:
        return fail(str(err), comm.rank)
    scene = _with_tube_options(args, scene)
    if isinstance(scene, str):
        return fail(scene, comm.rank)
    bad = _argument_problem(args, scene, comm.size)
    if bad:
        return fail(bad, comm.rank)
    solved = _analyse(args, scene, comm, fs)
    if isinstance(solved, str):
        return fail(solved, comm.rank)
    res, sweep, written, drawn = solved
    tube_3d = scene.mesh.dim == 3
    reduced = [] if scene.mesh.file or tube_3d else reduced_model_flutter(scene, args.kmax)
    if comm.rank != 0:
        return 0
    out = res.to_dict()
    out["reduced_model"] = reduced
    out["doublets"] = [d.to_dict() for d in doublets(res, args.kmax)]
    out["beta2_note"] = _beta2_note(scene)
    if tube_3d:
        out["tube_3d"] = {"length_m": scene.geometry.length, "n_axial": res.levels - 1,
                          "ends": scene.boundary.ends}
    if written:
        out["mode_shapes"] = written
    if sweep is not None:
        out["f_sweep"] = [
            {"f": r.f, "max_growth_rate_per_s": (r.unstable()[0].growth_rate
                                                 if r.unstable() else 0.0),
             "modes": [[m.frequency_hz, m.growth_rate, m.k] for m in r.modes]}
            for r in sweep
        ]
    if args.plot:  # a relative path is the current directory's; the line names it in full
        args.plot = str(Path(args.plot).resolve())
        _plot(args, scene, res, sweep, fs, reduced)
        out["figure"] = args.plot
    if args.mode_plot:
        args.mode_plot = str(Path(args.mode_plot).resolve())
        plot_contact_modes([m for m, _ in drawn], [g for _, g in drawn], args.mode_plot,
                           title=_mode_plot_title(scene, res))
        out["mode_figure"] = args.mode_plot
    if args.csv:
        out["tables"] = _write_tables(args.csv, res, sweep)
    if args.json:
        print(json.dumps(out, indent=2))
    else:
        if tube_3d:
            layers = res.levels - 1
            print(f"3D tube: length {scene.geometry.length:g} m, {layers} axial "
                  f"layer{'s' if layers != 1 else ''}, "
                  f"{scene.boundary.ends} ends (friction on the theta-rows only: "
                  "docs/flutter.md)")
        _print_table(res, reduced, args.top, args.plot, _beta2_note(scene), written, args.kmax)
        if args.mode_plot:
            print(f"figure: {args.mode_plot} (the {len(drawn)} fastest-growing modes on the "
                  "contact surface)")
        print("\n".join(f"table: {path}" for path in out.get("tables", [])))
    return 0


def _write_tables(path: str, res: CEAResult, sweep: list[CEAResult] | None) -> list[str]:
    """``--csv``: the modes of the scene's f, and with a sweep its modes against f and the
    lock-in points (``studies.flutter_fe.tables``), each written atomically; their paths."""
    base = Path(path).resolve()
    tables = {base: mode_rows(res)}
    if sweep is not None:
        stem = base.with_suffix("")
        tables[stem.with_name(f"{stem.name}_f_sweep.csv")] = sweep_rows(sweep)
        tables[stem.with_name(f"{stem.name}_lock_in.csv")] = lock_in_points(sweep)
    for target, rows in tables.items():
        atomic_write_text(target, csv_text(rows))
    return [str(target) for target in tables]


def _argument_problem(args: argparse.Namespace, scene: Scene, ranks: int) -> str | None:
    """Why the options cannot run (one line), or None: the band, the wavenumbers, the
    output paths, and terms the CEA cannot represent (``unrepresented_terms``)."""
    if not (math.isfinite(args.fmax_hz) and args.fmax_hz > 0):
        return f"--fmax-hz {args.fmax_hz!r} is out of range: need a frequency > 0 (Hz)"
    for flag, value, lo in (("--kmax", args.kmax, 1), ("--k-detail", args.k_detail, 1),
                            ("--top", args.top, 0)):
        if not lo <= value <= KMAX_LIMIT:
            return f"{flag} {value} is out of range: need {lo} <= {flag[2:]} <= {KMAX_LIMIT}"

    if not 1 <= args.mode_count <= MODE_COUNT_MAX:
        return (f"--mode-count {args.mode_count} is out of range: need 1 <= mode-count <= "
                f"{MODE_COUNT_MAX}")
    if args.mode_plot and scene.mesh.dim != 3:
        return ("--mode-plot draws a 3D tube's contact surface in (theta, z): give --length "
                "(or a scene with mesh.dim = 3); for plane strain --modes DIR writes the shapes")
    for flag, target in (("--plot", args.plot), ("--csv", args.csv),
                         ("--mode-plot", args.mode_plot)):
        bad = target and output_file_problem(target, flag)
        if bad:
            return bad
    refused = unrepresented_terms(friction_relaxation_time(scene), args.mass, ranks)
    if refused:
        return refused
    bad = _tube_3d_problem(args, scene)
    if bad:
        return bad
    if args.modes:
        return modes_dir_problem(args.modes) or None
    return None


#: a 3D tube's cells, length along z over width at r = R, within this range (``--length``)
ASPECT = (1e-3, 1e3)
#: the largest 3D tube (dofs) that ``--length`` builds: each slice of the band is one
#: sparse LU of it (a 3D tube of 6912 dofs took 10 min over 2.5 kHz on one core)
MAX_3D_DOFS = 1_000_000


def _with_tube_options(args: argparse.Namespace, scene: Scene) -> Scene | str:
    """``scene`` with ``--length``, ``--n-axial`` and ``--ends`` as overrides of its 3D keys
    (``geometry.length`` and ``mesh.dim = 3``, ``mesh.n_axial``, ``boundary.ends``); or why
    they cannot apply (one line). Without them a scene's own 3D keys describe the tube."""
    if args.length is None and scene.mesh.dim == 2:
        if args.n_axial is not None or args.ends is not None:
            return ("--n-axial and --ends describe the 3D tube: give its --length too (or "
                    "a scene with mesh.dim = 3)")
        return scene
    if args.length is not None and not (math.isfinite(args.length) and args.length > 0):
        return f"--length {args.length!r} is out of range: need a length > 0 (m)"
    if args.n_axial is not None and args.n_axial < 1:
        return f"--n-axial {args.n_axial} is out of range: need at least 1 layer"
    sets = ["mesh.dim=3"]
    if args.length is not None:
        sets.append(f"geometry.length={args.length!r}")
    if args.n_axial is not None:
        sets.append(f"mesh.n_axial={args.n_axial}")
    if args.ends is not None:
        sets.append(f'boundary.ends="{args.ends}"')
    try:
        return scene.with_overrides(*sets)
    except SceneError as err:
        return str(err)


def _tube_3d_problem(args: argparse.Namespace, scene: Scene) -> str | None:
    """Why the 3D scene (its keys, or ``--length``, ``--n-axial``, ``--ends``) cannot run
    (one line), or None: its size, its cells' aspect, and the options it cannot take."""
    if scene.mesh.dim != 3:
        return None
    length = scene.geometry.length
    layers = tube_axial_layers(scene)
    dofs = 3.0 * tube_nodes(scene) * (layers + 1)
    if not dofs <= MAX_3D_DOFS:  # an overflowed count too
        size = (f" would have about {dofs:.3g} dofs" if math.isfinite(dofs)
                else "'s dof count overflows")
        return (f"length {length:g} m: the 3D tube{size}, "
                f"above the {MAX_3D_DOFS:.0e} that a shift-and-invert CEA factorises here; "
                "use a smaller --length, --n-axial or mesh.n_inner")
    arc = 2 * math.pi * scene.geometry.R / scene.mesh.n_inner  # a cell's width at r = R
    aspect = length / layers / arc
    if not ASPECT[0] <= aspect <= ASPECT[1]:
        fix = ("a longer tube" if length / arc < 1.0
               else f"--n-axial about {round(length / arc)}")
        return (f"length {length:g} m makes cells {aspect:.3g} times as long as they are "
                f"wide at r = R: keep it within {ASPECT[0]:g} … {ASPECT[1]:g} ({fix})")
    if args.friction == "1-2-1" or (args.friction is None and scene.friction.filter != "nodal"):
        return "--friction 1-2-1 is for the plane-strain tube; drop it with a 3D tube"
    return None


def _analyse(args: argparse.Namespace, scene: Scene, comm: MPI.Comm, fs: np.ndarray | None
             ) -> tuple[CEAResult, list[CEAResult] | None, dict | None,
                        list[tuple[CEAMode, ContactGrid]]] | str:
    """The CEA at the scene's f (and at each f of ``--f-sweep``), the listed mode shapes
    written with ``--modes``, the ``--mode-plot`` modes on the contact grid; or why the band
    cannot be solved (one line)."""
    # dolfinx (and MPI) start after the command line and the environment are checked
    from stickslip.solver.problem import gershgorin_omega_max

    friction = args.friction or scene.friction.filter
    t0 = time.perf_counter()
    problem = cea_problem(scene, comm)  # plane strain, or the 3D scene's tube
    t_build = time.perf_counter() - t0
    f_top = gershgorin_omega_max(problem) / (2 * math.pi)  # no mode of the mesh above it
    if args.fmax_hz > FMAX_FACTOR * f_top:
        return (f"--fmax-hz {args.fmax_hz:g} is far above the mesh's highest frequency "
                f"({f_top:.4g} Hz, Gershgorin bound): no mode lies there, and the "
                f"eigensolver's shift fails; use --fmax-hz <= {f_top:.4g}")
    ops = build_operators(problem, args.mass, friction)
    # --modes writes every listed unstable mode; --mode-plot alone keeps only the vectors it
    # draws (a 3D tube's are large)
    keep = True if args.modes else (args.mode_count if args.mode_plot else False)
    res = complex_eigenvalue_analysis(problem, None, args.fmax_hz, ops=ops, shapes=keep)
    res.timings["mesh+assembly"] = t_build
    sweep = None
    if fs is not None:
        sweep = [complex_eigenvalue_analysis(problem, float(f), args.fmax_hz, ops=ops)
                 for f in fs]
    written, drawn = None, []
    where = {id(m): i for i, m in enumerate(res.modes)}  # a mode's index, for its shape
    if args.modes:
        resolved, mesh = _listed(res, args.top)
        written = write_mode_shapes(problem, ops, res, args.modes,
                                    [where[id(m)] for m in resolved + mesh])
    if args.mode_plot:
        drawn = [(m, contact_grid(ops, res.shapes[where[id(m)]]))
                 for m in res.unstable()[:args.mode_count] if where[id(m)] in res.shapes]
    ops.destroy()
    return res, sweep, written, drawn


def _mode_plot_title(scene: Scene, res: CEAResult) -> str:
    """The ``--mode-plot`` figure's title: the scene, f, the tube and its mesh."""
    return (f"{scene.name}: f = {res.f:g}, L = {scene.geometry.length:g} m "
            f"(L/R = {scene.geometry.length / scene.geometry.R:g}), {scene.boundary.ends} "
            f"ends, N = {res.n_contact}, {res.levels - 1} axial layers; Re u_θ at r = R")


def _plot(args: argparse.Namespace, scene, res: CEAResult, sweep: list[CEAResult] | None,
          fs: np.ndarray | None, reduced: list[dict]) -> None:
    if sweep is not None and fs is not None:
        red = {float(f): reduced_model_flutter(scene.with_overrides(f"loading.f={f}"),
                                               args.kmax) for f in fs if f > 0}
        plot_cea_diagram(sweep, args.plot, k_detail=args.k_detail, kmax=args.kmax,
                         reduced=red, title=f"CEA of steady sliding: {scene.name} "
                         f"({res.n_free} free dofs, {res.mass} mass, up to "
                         f"{args.fmax_hz:g} Hz)")
    else:
        plot_spectrum(res, args.plot, reduced=reduced)


def _beta2_note(scene) -> str | None:
    """The transient's algorithmic damping is a property of its time step, not of the scene's
    physics: CEA is the dt -> 0 limit (``newmark_exponents`` maps it to a given dt)."""
    b2 = scene.time.beta2
    if b2 <= 0.5:
        return None
    return (f"time.beta2 = {b2:g} > 1/2 also damps the transient (algorithmic, dt-dependent): "
            "not in this continuous-time CEA; studies.flutter_fe.newmark_exponents maps it")


def _listed(res: CEAResult, top: int) -> tuple[list[CEAMode], list[CEAMode]]:
    """The unstable modes the table lists: ``top`` resolved ones, then a few mesh-scale ones
    (most unstable first in each group)."""
    uns = res.unstable()
    resolved = [m for m in uns if not m.mesh_scale]
    mesh = [m for m in uns if m.mesh_scale]
    return resolved[:top], mesh[:max(3, top // 4)]


def _mode_row(m: CEAMode) -> str:
    flag = "  mesh-scale" if m.mesh_scale else ""
    return (f"{m.frequency_hz:10.1f} {m.growth_rate:12.2f} {m.zeta:+9.5f} {m.k:+5d} "
            f"{m.axial_order:3d} {m.direction:>9} {m.phase_speed_m_s:11.1f} "
            f"{m.purity:6.3f}{flag}")


def _print_table(res: CEAResult, reduced: list[dict], top: int, plot: str | None,
                 beta2_note: str | None = None, written: dict | None = None,
                 kmax: int = 12) -> None:
    """The NVH engineer's CEA table: resolved unstable modes first (most unstable first),
    then the mesh-scale ones with the reason; per-k branches against the reduced model."""
    uns = res.unstable()
    resolved = [m for m in uns if not m.mesh_scale]
    mesh = [m for m in uns if m.mesh_scale]
    damping = (f"Kelvin-Voigt tau = {res.tau:.3g} s (C = tau (K + K_f))" if res.tau > 0
               else "no damping (scene has none)")
    law = (f"regularised bound, t* = {res.t_star:.3g} s" if res.t_star > 0 else "Coulomb")
    lines = [
        f"CEA of steady sliding: scene '{res.scene}', f = {res.f:g}, {res.mass} mass, "
        f"friction {res.friction} ({law}), {damping}; {res.n_free} free dofs, "
        f"N = {res.n_contact}",
        f"{len(res.modes)} modes up to {res.fmax_hz:g} Hz: {len(uns)} unstable "
        f"({len(resolved)} resolved, {len(mesh)} mesh-scale); eigensolve "
        f"{res.timings['eigensolve']:.2f} s ({res.stats.slices} slices)",
    ]
    if beta2_note:
        lines.append(f"note: {beta2_note}")
    head = (f"{'freq (Hz)':>10} {'growth (1/s)':>12} {'zeta':>9} {'k':>5} {'m':>3} "
            f"{'direction':>9} {'speed (m/s)':>11} {'purity':>6}")
    lines.append("zeta = -Re(lambda)/|lambda| (< 0: unstable); k > 0 and speed < 0: against "
                 "the rotation; m: nodal rings along a 3D tube (0 in plane strain)")
    shown, shown_mesh = _listed(res, top)
    lines.append(f"unstable modes resolved by the mesh (most unstable first, {top} at most):")
    lines.append(head)
    lines += [_mode_row(m) for m in shown]
    if len(resolved) > len(shown):
        lines.append(f"  ... {len(resolved) - len(shown)} more (--top, --json)")
    if mesh:
        lines.append(f"{len(mesh)} unstable {res.mesh_scale_reason()}; "
                     f"the {len(shown_mesh)} fastest:")
        lines += [_mode_row(m) for m in shown_mesh]
    lines += _per_k_lines(res, reduced, kmax)
    lines += doublet_lines(res, kmax)
    if plot:
        lines.append(f"figure: {plot}")
    if written:
        lines.append(f"mode shapes of the {written['count']} modes listed above: "
                     f"{written['dir']} (modes.csv, contact.csv, mode_NN.bp for ParaView)")
    print("\n".join(lines))


def _per_k_lines(res: CEAResult, reduced: list[dict], kmax: int) -> list[str]:
    """Per wavenumber k: the lowest and the most unstable FE mode whose power on the contact
    circle is mostly in ±k (purity >= ``MIN_PURITY``, as the doublet table), beside the
    reduced model's mode (axisymmetric tubes only: ``reduced`` is empty for a user's mesh)."""
    head = f"{'k':>4} | {'FE lowest branch':^28} | {'FE most unstable':^28}"
    lines = ["per k (Hz, 1/s, m/s; speed + = rotation sense; modes of purity >= "
             f"{MIN_PURITY:g}):", head + (f" | {'reduced model eq. [2]':^28}" if reduced else "")]
    red = {r["k"]: r for r in reduced}
    for k in range(1, kmax + 1):
        family = [m for m in res.modes if m.wavenumber == k and m.purity >= MIN_PURITY]
        if not family:
            continue
        low = distinct_modes(family)[0]
        best = max(family, key=lambda m: m.growth_rate)
        cells = [(m.frequency_hz, m.growth_rate, m.phase_speed_m_s) for m in (low, best)]
        if k in red:
            cells.append((red[k]["frequency_hz"], red[k]["growth_rate_per_s"],
                          red[k]["phase_speed_m_s"]))
        lines.append(f"{k:4d} | " + " | ".join(f"{a:8.1f} {b:8.1f} {c:+9.1f}" for a, b, c in cells))
    if not reduced:
        lines.append("(no reduced-model column: eq. [2] describes the paper's axisymmetric "
                     "tube, not a user's cross-section)")
    if res.tau > 0 and reduced:
        lines.append("(the reduced model of eq. [2] has no damping)")
    return lines
