"""``stickslip flutter-fe SCENE``: complex eigenvalue analysis of FE steady sliding."""


from __future__ import annotations

import argparse
import json
import math
import sys
import time
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:

    pass

from studies.flutter_fe.cea import CEAResult, build_operators, complex_eigenvalue_analysis
from studies.flutter_fe.plots import _distinct, plot_cea_diagram, plot_spectrum
from studies.flutter_fe.references import reduced_model_flutter

# --------------------------------------------------------------------------------- CLI


def parse_f_sweep(text: str) -> np.ndarray:
    """``"start:stop:num"`` (inclusive linspace) or a comma list ``"0,0.3,0.7"``."""
    try:
        if ":" in text:
            a, b, n = text.split(":")
            vals = np.linspace(float(a), float(b), int(n))
        else:
            vals = np.array([float(x) for x in text.split(",") if x.strip()])
    except ValueError as err:
        raise ValueError(f"--f-sweep {text!r}: use start:stop:num or a comma list") from err
    if vals.size == 0 or np.any(vals < 0) or not np.all(np.isfinite(vals)):
        raise ValueError(f"--f-sweep {text!r}: need finite friction coefficients >= 0")
    return vals


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``flutter-fe SCENE`` to the ``stickslip`` subcommands."""
    p = sub.add_parser(
        "flutter-fe",
        help="complex eigenvalue analysis (CEA) of FE steady sliding (SLEPc)",
        description=(
            "Linearise the FE system about discrete steady sliding (contact nodes stay in "
            "contact, tangential force = f x normal reaction), solve (K + K_f) phi = w^2 M phi "
            "with SLEPc shift-and-invert and list the unstable (flutter) modes: growth rate, "
            "frequency, wavenumber k, propagation direction. Works under mpirun."
        ),
    )
    p.add_argument("scene", help="scene TOML file, or the name of a scene in scenes/")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scene field, e.g. --set loading.f=0.5 (repeatable)")
    p.add_argument("--fmax-hz", type=float, default=10_000.0,
                   help="upper end of the frequency band (Hz, default 10000)")
    p.add_argument("--mass", choices=("lumped", "consistent"), default="lumped",
                   help="mass matrix: the explicit solver's lumped one (default) or consistent")
    p.add_argument("--friction", choices=("nodal", "1-2-1"), default="nodal",
                   help="friction force of node i: f x its nodal reaction (default, the "
                        "transient's law) or f x the 1-2-1 filtered reactions of i-1, i, i+1 "
                        "(removes the spurious mesh-scale branch, docs/continuum.md)")
    p.add_argument("--f-sweep", default=None, metavar="A:B:N|F1,F2,...",
                   help="also sweep the friction coefficient (CEA diagram with --plot)")
    p.add_argument("--kmax", type=int, default=12, help="reduced-model modes to compare (k<=)")
    p.add_argument("--k-detail", type=int, default=4,
                   help="wavenumber whose branches the CEA diagram details (default 4)")
    p.add_argument("--top", type=int, default=20, help="unstable modes listed (table output)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--plot", metavar="PNG", default=None,
                   help="growth vs frequency (or the CEA diagram with --f-sweep) to this file")
    p.set_defaults(func=flutter_fe_command)


def flutter_fe_command(args: argparse.Namespace) -> int:
    """Handler of ``stickslip flutter-fe``."""
    from mpi4py import MPI

    from solver.scene import SceneError, load_scene

    comm = MPI.COMM_WORLD
    rank0 = comm.rank == 0

    def fail(msg: str) -> int:
        if rank0:
            print(f"error: {msg}", file=sys.stderr)
        return 2

    try:
        scene = load_scene(args.scene, args.overrides)
        fs = parse_f_sweep(args.f_sweep) if args.f_sweep else None
    except (SceneError, FileNotFoundError, ValueError) as err:
        return fail(str(err))
    if not (math.isfinite(args.fmax_hz) and args.fmax_hz > 0):
        return fail(f"--fmax-hz {args.fmax_hz!r} is out of range: need a frequency > 0 (Hz)")
    from solver.problem import build_problem

    t0 = time.perf_counter()
    problem = build_problem(scene, comm)
    t_build = time.perf_counter() - t0
    ops = build_operators(problem, args.mass, args.friction)
    res = complex_eigenvalue_analysis(problem, None, args.fmax_hz, ops=ops)
    res.timings["mesh+assembly"] = t_build
    sweep = None
    if fs is not None:
        sweep = [complex_eigenvalue_analysis(problem, float(f), args.fmax_hz, ops=ops)
                 for f in fs]
    ops.destroy()
    reduced = reduced_model_flutter(scene, args.kmax)
    if not rank0:
        return 0
    out = res.to_dict()
    out["friction"] = args.friction
    out["reduced_model"] = reduced
    if sweep is not None:
        out["f_sweep"] = [
            {"f": r.f, "max_growth_rate_per_s": (r.unstable()[0].growth_rate
                                                 if r.unstable() else 0.0),
             "modes": [[m.frequency_hz, m.growth_rate, m.k] for m in r.modes]}
            for r in sweep
        ]
    if args.plot:
        if sweep is not None:
            red = {float(f): reduced_model_flutter(scene.with_overrides(f"loading.f={f}"),
                                                   args.kmax) for f in fs if f > 0}
            plot_cea_diagram(sweep, args.plot, k_detail=args.k_detail, kmax=args.kmax,
                             reduced=red, title=f"CEA of steady sliding: {scene.name} "
                             f"({res.n_free} free dofs, {res.mass} mass, up to "
                             f"{args.fmax_hz:g} Hz)")
        else:
            plot_spectrum(res, args.plot, reduced=reduced)
    if args.json:
        print(json.dumps(out, indent=2))
    else:
        _print_table(res, reduced, args.top, args.plot)
    return 0


def _print_table(res: CEAResult, reduced: list[dict], top: int, plot: str | None) -> None:
    uns = res.unstable()
    lines = [
        f"CEA of steady sliding: scene '{res.scene}', f = {res.f:g}, {res.mass} mass, "
        f"{res.n_free} free dofs",
        f"{len(res.modes)} modes up to {res.fmax_hz:g} Hz, {len(uns)} unstable; "
        f"eigensolve {res.timings['eigensolve']:.2f} s ({res.stats.slices} slices)",
        f"{'freq (Hz)':>10} {'growth (1/s)':>12} {'k':>4} {'direction':>9} "
        f"{'speed (m/s)':>11} {'purity':>6}",
    ]
    for m in uns[:top]:
        lines.append(f"{m.frequency_hz:10.1f} {m.growth_rate:12.2f} {m.wavenumber:4d} "
                     f"{m.direction:>9} {m.phase_speed_m_s:11.1f} {m.purity:6.3f}")
    lines.append("per k (Hz, 1/s, m/s; speed + = rotation sense):")
    lines.append(f"{'k':>4} | {'FE lowest branch':^28} | {'FE most unstable':^28} | "
                 f"{'reduced model eq. [2]':^28}")
    red = {r["k"]: r for r in reduced}
    best = res.by_wavenumber()
    for k in sorted(best):
        if k == 0 or k not in red:
            continue
        low = _distinct(m for m in res.modes if m.wavenumber == k)[0]
        cells = [(m.frequency_hz, m.growth_rate, m.phase_speed_m_s) for m in (low, best[k])]
        cells.append((red[k]["frequency_hz"], red[k]["growth_rate_per_s"],
                      red[k]["phase_speed_m_s"]))
        lines.append(f"{k:4d} | " + " | ".join(f"{a:8.1f} {b:8.1f} {c:+9.1f}" for a, b, c in cells))
    if plot:
        lines.append(f"figure: {plot}")
    print("\n".join(lines))
