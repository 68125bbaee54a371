"""``stickslip travel SCENE --k K``: a travelling wave computed directly in its frame (issue 14).

Heavy imports (dolfinx, matplotlib) stay inside the handler.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "travel",
        help="compute a travelling wave on the FE mesh in the wave's frame (Newton)",
        description=(
            "Travelling wave u = Q(wt) w(Q(wt)^T x) of the scene's FE tube: K - w^2 G condensed "
            "on the contact nodes, nodal contact law, semismooth Newton for (w, omega) with a "
            "phase condition. Writes OUT/summary.json (keys of `stickslip run` + residual and "
            "inequality margins) and OUT/profiles.npz (U, V, P, Q over one period). "
            "docs/travelling_waves.md"
        ),
    )
    p.add_argument("scene", help="scene TOML file, or the name of a scene in scenes/")
    p.add_argument("--k", type=int, required=True, help="wavenumber (waves per turn), >= 1")
    p.add_argument("--from", dest="from_run", metavar="RUN_DIR",
                   help="start from the last sample of a transient run directory")
    p.add_argument("--start", choices=("auto", "reduced"), default="auto",
                   help="start without --from: the reduced model's wave at k (default)")
    p.add_argument("--continue", dest="cont", metavar="KEY=A:B:N",
                   help="follow the branch over N values of a scene key, e.g. "
                        "loading.omega=50:1000:40")
    p.add_argument("--damping", type=float, default=None, metavar="TAU",
                   help="Kelvin-Voigt retardation time (s) in the wave frame (default: the "
                        "scene's [damping], the same physics as `stickslip run`)")
    p.add_argument("--celerity", type=float, metavar="M_PER_S",
                   help="start speed (signed, m/s) instead of the start's own")
    p.add_argument("--fixed-omega", action="store_true",
                   help="hold omega at the start's value (no phase condition)")
    p.add_argument("--band", action="store_true",
                   help="also measure the band of speeds over which the wave stays admissible "
                        "(warm-started fixed-omega solves, steps of 0.2 %%)")
    p.add_argument("--rate", default=None, metavar="SCHEME",
                   help="material derivative in the contact law, upwind over node passages: "
                        "bdf2 (second order, default) or bdf1 (first order: what the transient "
                        "sees on a rigidly travelling P1 wave; the default, and the only "
                        "choice, with --time-scheme central)")
    p.add_argument("--inertia", default="rotation", metavar="OPERATOR",
                   help="wave-frame operator: rotation (K - w^2 G - w D, the continuous "
                        "rotation, default) or shift (the transient's own travelling "
                        "operator per discrete harmonic, lumped mass; docs/travelling_waves.md)")
    p.add_argument("--samples", type=int, default=1, metavar="S",
                   help="contact points per mesh node with --inertia shift: the node's history "
                        "between node passages (default 1; docs/travelling_waves.md, Samples)")
    p.add_argument("--time-scheme", default="exact", choices=("exact", "central"),
                   help="with --inertia shift: exact in time (default) or the transient's "
                        "explicit central-difference step h = node passage / samples (its own "
                        "discrete travelling wave; docs/travelling_waves.md)")
    p.add_argument("--max-iter", type=int, default=60, help="Newton iterations (default 60)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scene field (repeatable)")
    p.add_argument("--plot", action="store_true", help="draw the profiles / the branch (PNG)")
    p.add_argument("--json", action="store_true", help="print summary.json to stdout")
    p.add_argument("-o", "--output", help="output directory (default: $STICKSLIP_OUTPUT/"
                   "<scene>_travel_k<K>)")
    p.add_argument("--force", action="store_true", help="overwrite the output directory")
    p.set_defaults(func=_travel)


def _err(msg: str) -> int:
    print(f"error: {msg}", file=sys.stderr)
    return 2


def parse_continue(text: str) -> tuple[str, list[float]]:
    """``key=a:b:n`` -> (key, n values from a to b)."""
    import numpy as np

    if "=" not in text:
        raise ValueError(f"--continue {text!r}: expected KEY=A:B:N, e.g. loading.omega=50:1000:40")
    key, rng = text.split("=", 1)
    parts = rng.split(":")
    try:
        a, b, n = float(parts[0]), float(parts[1]), int(parts[2])
    except (ValueError, IndexError):
        raise ValueError(f"--continue {text!r}: expected KEY=A:B:N with numbers A, B and an "
                         "integer N >= 2") from None
    if len(parts) != 3 or n < 2:
        raise ValueError(f"--continue {text!r}: N = {parts[-1]} must be an integer >= 2")
    return key.strip(), [float(v) for v in np.linspace(a, b, n)]


def _import_dolfinx_without_numba() -> None:
    """Import dolfinx with numba hidden (issue 14's speed target). ``dolfinx.utils`` imports
    numba and LLVM at import time for its numba helpers only. ``travel`` runs no compiled
    kernel, and that import is 0.2-0.3 s of the command's ~2 s of CPU (docs/
    travelling_waves.md, "Speed"). numba is importable again afterwards; only dolfinx's
    numba helpers stay undefined in this process. A no-op when either is imported already."""
    if "dolfinx" in sys.modules or "numba" in sys.modules:
        return
    sys.modules["numba"] = None  # type: ignore[assignment]  # import numba -> ImportError
    try:
        import dolfinx.fem.petsc  # noqa: F401
    finally:
        del sys.modules["numba"]


def _travel(args: argparse.Namespace) -> int:
    from solver.scene import SceneError, load_scene
    from studies.output import output_root

    t0 = time.perf_counter()
    if args.k < 1:
        return _err(f"--k {args.k}: the wavenumber must be an integer >= 1")
    if args.damping is not None and args.damping < 0:
        return _err(f"--damping {args.damping}: the retardation time must be >= 0")
    if args.celerity is not None and args.celerity == 0.0:
        return _err("--celerity 0: a travelling wave needs a non-zero speed (sign = sense)")
    if args.max_iter < 1:
        return _err(f"--max-iter {args.max_iter}: must be >= 1")
    _import_dolfinx_without_numba()
    from studies.travel.frame import INERTIAS
    from studies.travel.newton import RATES

    if args.rate is None:
        args.rate = "bdf1" if args.time_scheme == "central" else "bdf2"
    if args.time_scheme == "central" and args.rate != "bdf1":
        return _err(f"--rate {args.rate}: the central time scheme is the transient's step, whose "
                    "contact law is first order (bdf1); drop --rate")
    if args.inertia not in INERTIAS:
        return _err(f"--inertia {args.inertia}: use {' or '.join(INERTIAS)}")
    if args.rate not in RATES:
        return _err(f"--rate {args.rate}: the material-derivative scheme must be one of "
                    f"{', '.join(RATES)}")
    if args.samples < 1 or (args.samples > 1 and args.inertia != "shift"):
        return _err(f"--samples {args.samples}: give a whole number >= 1; more than 1 needs "
                    "--inertia shift")
    if args.time_scheme != "exact" and args.inertia != "shift":
        return _err(f"--time-scheme {args.time_scheme}: needs --inertia shift")
    try:
        scene = load_scene(args.scene, args.overrides)
        cont = parse_continue(args.cont) if args.cont else None
        if cont:
            scene.with_overrides(f"{cont[0]}={cont[1][0]}")  # validates the key early
    except (SceneError, FileNotFoundError, ValueError) as err:
        return _err(str(err))
    if args.damping is None:  # same physics as the transient: the scene's Kelvin-Voigt tau
        args.damping = float(scene.damping.tau)
    from cli.checks import samples_problem

    if args.from_run and (problem := samples_problem(args.from_run)):
        return _err(f"--from: {problem}")
    out = Path(args.output) if args.output else output_root() / f"{scene.name}_travel_k{args.k}"
    from studies.travel.output import prepare_dir

    try:
        prepare_dir(out, args.force)
    except FileExistsError as err:
        return _err(str(err))
    if cont:
        from studies.travel.continuation import run_continuation

        return run_continuation(scene, args, cont[0], cont[1], out, t0)
    return _one_wave(scene, args, out, t0)


def _one_wave(scene, args: argparse.Namespace, out: Path, t0: float) -> int:
    import json

    from studies.travel import driver as D
    from studies.travel.newton import NotConverged
    from studies.travel.output import plot_profiles, write_failure, write_wave

    try:
        st = D.setup(scene, args.damping, rate=args.rate, inertia=args.inertia,
                     samples=args.samples, time_scheme=args.time_scheme)
        if args.from_run:
            W0, om0, info = D.start_from_run(Path(args.from_run), st)
        else:
            W0, om0, info = D.start_from_reduced(st, args.k)
    except ValueError as err:
        return _err(str(err))
    if args.celerity is not None:
        om0 = args.celerity / scene.geometry.R
        info["start_celerity_m_s"] = args.celerity
    t_setup = time.perf_counter() - t0
    try:
        sol = D.solve_scene(st, args.k, W0, om0, max_iter=args.max_iter,
                            free_omega=not args.fixed_omega)
    except NotConverged as err:
        summary = {"status": "failed", "reason": str(err), "k": args.k,
                   "last_residual": err.info.get("residual"),
                   "violated": err.info.get("violated"), "margins": err.info.get("margins"),
                   "residual_history": err.info.get("hist"), **info,
                   "damping_s": args.damping, "rate": args.rate, "inertia": args.inertia,
                   "samples_per_node": args.samples, "time_scheme": args.time_scheme,
                   "wall_time_s": time.perf_counter() - t0}
        write_failure(out, scene, summary)
        res = err.info.get("residual")
        print(f"error: travel did not find a wave: {err} [last residual "
              f"{res if res is None else f'{res:.3e}'}, violated inequality: "
              f"{err.info.get('violated') or 'none'}]", file=sys.stderr)
        print(f"(summary: {out / 'summary.json'}; no wave written)", file=sys.stderr)
        return 1
    summary, profiles = D.measure(st, sol, args.k)
    if args.band:
        summary["band"] = D.band(st, sol, args.k)
    summary.update(info, damping_s=args.damping, inertia=args.inertia, setup_time_s=t_setup,
                   wall_time_s=time.perf_counter() - t0)
    write_wave(out, scene, summary, profiles)
    if args.plot:
        print(f"figure: {plot_profiles(out, profiles, summary)}")
    if args.json:
        print(json.dumps(summary, indent=2, default=float))
    else:
        print(f"travel: {summary['regime']}, mode k = {summary['mode']}, celerity "
              f"{summary['celerity_m_s']:.1f} m/s (+ = rotation sense), frequency "
              f"{summary['frequency_hz']:.1f} Hz")
        print(f"zones: psi1 {summary['psi1_subnode']:.4f}, psi2 {summary['psi2_subnode']:.4f} "
              f"(sub-node); amplitude {summary['amplitude_m']:.4g} m; residual "
              f"{summary['residual']:.1e} in {summary['iterations']} iterations; "
              f"inequalities: all satisfied")
        if "band" in summary:
            b = summary["band"]
            print(f"band: admissible for {b['celerity_m_s'][0]:.1f} ... "
                  f"{b['celerity_m_s'][1]:.1f} m/s; psi1 {b['psi1'][0]:.3f} ... "
                  f"{b['psi1'][1]:.3f}, psi2 {b['psi2'][0]:.3f} ... {b['psi2'][1]:.3f}, "
                  f"amplitude {b['amplitude_m'][0]:.3g} ... {b['amplitude_m'][1]:.3g} m")
        print(f"-> {out}  ({summary['wall_time_s']:.2f} s)")
    return 0
