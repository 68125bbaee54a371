"""``stickslip travel SCENE [--from RUN]``: a travelling wave computed directly in its frame.

The handler imports dolfinx itself, without numba (``_import_dolfinx_without_numba``);
matplotlib loads where a figure is drawn.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

from stickslip.cli.checks import fail
from stickslip.cli.commands import command_help
from stickslip.solver.scene import SceneError, load_scene, require_plane_strain
from stickslip.studies.output import output_root
from stickslip.studies.travel import command
from stickslip.studies.travel.continuation import run_continuation
from stickslip.studies.travel.from_run import NotRigidWave
from stickslip.studies.travel.newton import NotConverged
from stickslip.studies.travel.output import (
    plot_profiles,
    prepare_dir,
    shown,
    write_failure,
    write_wave,
)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "travel",
        help=command_help("travel"),
        description=(
            "Travelling wave of the scene's FE tube, solved in the wave's frame by a "
            "semismooth Newton for (W, omega). By default the transient's own discrete wave: "
            "the explicit scheme's step h = node passage / S with S = round(node passage / dt), "
            "dt the run's (--from) or the one `stickslip run` uses for the scene, so the "
            "wave is the one `stickslip run` computes. --dt-limit: the dt -> 0 wave on the "
            "same mesh; --inertia rotation or --time-scheme exact: the continuum routes "
            "(exact in time). Writes OUT/summary.json (keys of `stickslip run` + residual, "
            "inequality margins, the run's values) and OUT/profiles.npz. "
            "docs/travelling_waves.md"
        ),
    )
    p.add_argument("scene", help="scene TOML file, or the name of a scene in scenes/")
    p.add_argument("--k", type=int, default=None,
                   help="wavenumber (waves per turn), >= 1 (default with --from: the run's)")
    p.add_argument("--from", dest="from_run", metavar="RUN_DIR",
                   help="solve the wave of a finished `stickslip run` directory: its k, its "
                        "time step, its probe history as the start; refused (exit 1) when "
                        "its end state is not a rigidly travelling wave")
    p.add_argument("--dt-limit", action="store_true",
                   help="also solve the dt -> 0 wave on the same mesh (the waves at 2S and 4S "
                        "extrapolated in the step; default route only)")
    p.add_argument("--start", choices=("auto", "reduced"), default="auto",
                   help="start without --from: the reduced model's wave at k (default)")
    p.add_argument("--continue", dest="cont", metavar="KEY=A:B:N",
                   help="follow the branch over N values of a scene key, e.g. "
                        "loading.omega=50:1000:40; a point whose wave jumps off the branch's "
                        "trend is marked jumped and ends it")
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
                        "bdf2 (second order) or bdf1 (first order: what the transient sees on "
                        "a rigidly travelling P1 wave); default: bdf1 with --time-scheme "
                        "central (its only choice), else bdf2")
    p.add_argument("--inertia", default="shift", metavar="OPERATOR",
                   help="wave-frame operator: shift (the transient's own travelling operator "
                        "per discrete harmonic, lumped mass; default) or rotation (K - w^2 G - "
                        "w D, the continuous rotation: a continuum route, exact in time)")
    p.add_argument("--samples", type=int, default=None, metavar="S",
                   help="contact points per mesh node with --inertia shift: the node's history "
                        "between node passages (default: the matched S = round(node passage "
                        "/ dt) with the central scheme, 1 with --time-scheme exact)")
    p.add_argument("--time-scheme", default=None, choices=("exact", "central"),
                   help="with --inertia shift: the transient's explicit central-difference "
                        "step h = node passage / S (default: its own discrete wave) or exact "
                        "in time (a continuum route, the dt -> 0 limit at large S)")
    p.add_argument("--max-iter", type=int, default=60, help="Newton iterations (default 60)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scene field (repeatable)")
    p.add_argument("--plot", action="store_true", help="draw the profiles / the branch (PNG)")
    p.add_argument("--json", action="store_true", help="print summary.json to stdout")
    p.add_argument("-o", "--output", help="output directory (default: $STICKSLIP_OUTPUT/"
                   "<scene>_travel_k<K>)")
    p.add_argument("--force", action="store_true", help="overwrite the output directory")
    p.set_defaults(func=_travel)


#: Points of one ``--continue`` branch (each a Newton solve, about a second).
CONTINUE_MAX = 2000


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
    if n > CONTINUE_MAX:
        raise ValueError(f"--continue {text!r}: N = {n} points, each a Newton solve; at most "
                         f"{CONTINUE_MAX} (a branch needs a few tens)")
    if not (math.isfinite(a) and math.isfinite(b)):
        raise ValueError(f"--continue {text!r}: A and B must be finite numbers")
    return key.strip(), [float(v) for v in np.linspace(a, b, n)]


def _import_dolfinx_without_numba() -> None:
    """Import dolfinx with numba hidden (the speed target). ``dolfinx.utils`` imports
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


def _options(args: argparse.Namespace):  # noqa: ANN202
    """The command line's options (``studies.travel.command.DEFAULTS``' names)."""
    return command.options(**{name: getattr(args, name) for name in command.DEFAULTS})


def _travel(args: argparse.Namespace) -> int:
    t0 = time.perf_counter()
    _import_dolfinx_without_numba()
    opts = _options(args)
    bad = command.check(opts)
    if bad:
        return fail(bad)
    try:
        scene = load_scene(args.scene, args.overrides)
        require_plane_strain(scene)
        # dolfinx after _import_dolfinx_without_numba (no numba: the command's speed)
        from stickslip.studies.travel.frame import require_rotational_symmetry

        require_rotational_symmetry(scene)
        cont = parse_continue(args.cont) if args.cont else None
        if cont:
            for value in cont[1]:  # the key and every value of the branch, before solving
                scene.with_overrides(f"{cont[0]}={value!r}")
    except (SceneError, FileNotFoundError, ValueError) as err:
        return fail(str(err))

    try:
        bad = command.resolve(scene, opts)
    except NotRigidWave as err:
        print(f"error: {err}", file=sys.stderr)
        return 1
    if bad:
        return fail(bad)
    out = Path(args.output) if args.output else output_root() / f"{scene.name}_travel_k{opts.k}"

    try:
        claim = prepare_dir(out, args.force)
    except FileExistsError as err:
        return fail(str(err))
    opts.json = args.json
    try:  # results go to claim.work; a replacement is swapped in only once written
        if cont:
            rc = run_continuation(scene, opts, cont[0], cont[1], claim.work, t0)
        else:
            rc = _one_wave(scene, opts, claim.work, t0)
    except KeyboardInterrupt as stop:
        replacing = claim.replacing
        claim.discard()
        claim.release()
        if replacing:  # a --force rerun cut short keeps the earlier result whole
            raise KeyboardInterrupt(f"interrupted; the earlier {out} is kept") from stop
        raise
    except BaseException:
        claim.discard()
        claim.release()
        raise
    claim.commit()
    claim.release()
    return rc


def _one_wave(scene, args, out: Path, t0: float) -> int:  # noqa: ANN001
    """Solve (``studies.travel.command.solve``), write and print one wave; ``args``: the
    resolved options."""
    import json

    try:
        summary, profiles = command.solve(scene, args, t0)
    except ValueError as err:
        return fail(str(err))
    except NotConverged as err:
        summary = {"status": "failed", "reason": str(err), "k": args.k,
                   "last_residual": err.info.get("residual"),
                   "violated": err.info.get("violated"), "margins": err.info.get("margins"),
                   "residual_history": err.info.get("hist"), **err.start_info,
                   "damping_s": args.damping, "rate": args.rate, "inertia": args.inertia,
                   "samples_per_node": args.samples, "time_scheme": args.time_scheme,
                   "wall_time_s": time.perf_counter() - t0}
        write_failure(out, scene, summary)
        res = err.info.get("residual")
        print(f"error: travel did not find a wave: {err} [last residual "
              f"{res if res is None else f'{res:.3e}'}, violated inequality: "
              f"{err.info.get('violated') or 'none'}]", file=sys.stderr)
        print(f"(summary: {shown(out) / 'summary.json'}; no wave written)", file=sys.stderr)
        return 1
    write_wave(out, scene, summary, profiles)
    if args.plot:
        print(f"figure: {shown(plot_profiles(out, profiles, summary))}")
    if args.json:
        print(json.dumps(summary, indent=2, default=float))
    else:
        print(f"travel: {summary['regime']}, mode k = {summary['mode']}, celerity "
              f"{summary['celerity_m_s']:.1f} m/s (+ = rotation sense), frequency "
              f"{summary['frequency_hz']:.1f} Hz")
        if "celerity_note" in summary:
            print(f"note: {summary['celerity_note']}")
        print(f"zones: psi1 {summary['psi1_subnode']:.4f}, psi2 {summary['psi2_subnode']:.4f} "
              f"(sub-node); amplitude {summary['amplitude_m']:.4g} m; residual "
              f"{summary['residual']:.1e} in {summary['iterations']} iterations; "
              f"inequalities: all satisfied")
        if "from_run" in summary:
            print(f"against the run: {summary['from_run']['message']}")
        if "dt_limit" in summary:
            lim = summary["dt_limit"]
            order = "no asymptotic range" if lim["order"] is None else f"order {lim['order']:.2f}"
            print(f"dt -> 0 wave: celerity {lim['celerity_m_s']:.1f} m/s, amplitude "
                  f"{lim['amplitude_m']:.4g} m (S = "
                  f"{', '.join(str(v['samples']) for v in lim['levels'])}, {order})"
                  + (f"; the run's dt error {lim['run_dt_error']:+.2%}"
                     if lim.get("run_dt_error") is not None else ""))
        if "band" in summary:
            b = summary["band"]
            print(f"band: admissible for {b['celerity_m_s'][0]:.1f} ... "
                  f"{b['celerity_m_s'][1]:.1f} m/s; psi1 {b['psi1'][0]:.3f} ... "
                  f"{b['psi1'][1]:.3f}, psi2 {b['psi2'][0]:.3f} ... {b['psi2'][1]:.3f}, "
                  f"amplitude {b['amplitude_m'][0]:.3g} ... {b['amplitude_m'][1]:.3g} m")
        print(f"-> {shown(out)}  ({summary['wall_time_s']:.2f} s)")
    return 0
