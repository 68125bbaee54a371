"""``stickslip wave`` and ``stickslip flutter`` subcommands (section 6).

``cli.main`` calls :func:`register` with its ``subparsers``. Handlers return
the exit code: 0 on success, 2 on bad input (one ``error: ...`` line on stderr naming the
bad value and the allowed range).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import warnings
from typing import TYPE_CHECKING, Any

import numpy as np

from stickslip.cli.checks import fail, output_file_problem
from stickslip.cli.commands import command_help
from stickslip.postprocess.style import STATUS_COLORS
from stickslip.semianalytic.coefficients import coefficients, gamma_from_physical
from stickslip.semianalytic.flutter import flutter_modes, mode_physical
from stickslip.semianalytic.plotting import plot_wave
from stickslip.semianalytic.waves import find_waves
from stickslip.solver.scene import RANGES, SceneError, check_speed_ratio

if TYPE_CHECKING:
    from stickslip.semianalytic.coefficients import Coefficients
    from stickslip.semianalytic.waves import TravellingWave

__all__ = ["register", "wave_command", "flutter_command"]


class InputError(ValueError):
    """Bad command-line value (message names the flag, the value and the allowed range)."""


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--nu", type=float, default=0.3, help="Poisson ratio, 0 <= nu < 0.5")
    p.add_argument("--xi", type=float, default=1.25, help="R*/R, > 1")
    p.add_argument("--f", type=float, default=0.7, help="friction coefficient, 0 <= f <= 1e3")
    p.add_argument("--omega", type=float, default=40.0, help="rotation speed (rad/s), > 0")
    p.add_argument("--wave-speed", type=float, default=1000.0, help="sqrt(E/rho) (m/s)")
    p.add_argument("--radius", type=float, default=1.0, help="inner radius R (m)")
    p.add_argument("--json", action="store_true", help="print one JSON object")


def register(subparsers: Any) -> None:
    """Add the ``wave`` and ``flutter`` subcommands to an argparse ``subparsers`` object."""
    pw = subparsers.add_parser(
        "wave",
        help=command_help("wave"),
        description="Solve eqs. [4]-[7] of the paper for travelling waves (semi-analytical).",
        allow_abbrev=False,
    )
    _common(pw)
    pw.add_argument("--k", type=int, default=4, help="mode number (waves per turn), >= 1")
    pw.add_argument("--delta", type=float, default=0.001, help="mismatch d/R, > 0")
    pw.add_argument("--plot", metavar="PNG", default=None, help="draw Figure 1 to this file")
    pw.add_argument(
        "--regime",
        choices=("auto", "stick-slip", "stick-slip-separation"),
        default="auto",
        help="which kind of wave to look for (default: both)",
    )
    pw.add_argument(
        "--junction",
        choices=("both", "impact", "smooth"),
        default="both",
        help="matching conditions for separation waves (docs/semianalytic.md)",
    )
    pw.set_defaults(func=wave_command)
    pf = subparsers.add_parser(
        "flutter",
        help=command_help("flutter"),
        description="Growth rate, phase speed and direction of the modes exp(i(k theta - w t)).",
        allow_abbrev=False,  # `--k 0` must not be read as `--kmax 0`
    )
    _common(pf)
    pf.add_argument("--kmax", type=int, default=8, help=f"largest mode number, 1..{KMAX_LIMIT}")
    pf.set_defaults(func=flutter_command)


#: Command-line flag -> scene key: one set of ranges for scenes and this CLI (solver.scene).
_FLAG_KEYS = (
    ("nu", "nu", "material.nu"),
    ("xi", "xi", "geometry.xi"),
    ("f", "f", "loading.f"),
    ("omega", "omega", "loading.omega"),
    ("wave-speed", "wave_speed", "material.wave_speed"),
    ("radius", "radius", "geometry.R"),
    ("delta", "delta", "geometry.delta"),
    ("k", "k", "initial.mode"),
)
#: Largest ``flutter --kmax``: k = 1..kmax costs ~1 ms per mode; beyond 10^4 waves per turn
#: the reduced model's ansatz (one radial shape X(r)) has long lost its meaning.
KMAX_LIMIT = 10_000


def _validate(args: argparse.Namespace) -> None:
    def bad(flag: str, value: Any, allowed: str) -> InputError:
        return InputError(f"--{flag} {value!r} is out of range: need {allowed}")

    for flag, attr, key in _FLAG_KEYS:
        if not hasattr(args, attr):
            continue
        val = getattr(args, attr)
        if not math.isfinite(val):
            raise bad(flag, val, "a finite number")
        if not RANGES[key].ok(val):
            raise bad(flag, val, RANGES[key].rule)
    try:
        check_speed_ratio(args.radius, args.omega, args.wave_speed,
                          f"--omega {args.omega!r}, --wave-speed {args.wave_speed!r}, "
                          f"--radius {args.radius!r}")
    except SceneError as err:
        raise InputError(str(err).replace("loading.omega and material.wave_speed",
                                          "--omega and --wave-speed")) from None
    if hasattr(args, "kmax") and not 1 <= args.kmax <= KMAX_LIMIT:
        raise bad("kmax", args.kmax, f"an integer 1 <= kmax <= {KMAX_LIMIT}")

    try:  # eqs. [3]-[5] at extreme ratios (xi = 1e300) overflow or give a singular system
        with np.errstate(all="ignore"):
            co = coefficients(args.nu, args.xi,
                              gamma_from_physical(args.wave_speed, args.radius, args.omega))
        finite = all(np.all(np.isfinite(np.asarray(v, dtype=float)))
                     for v in vars(co).values() if isinstance(v, (float, np.ndarray)))
    except (np.linalg.LinAlgError, ArithmeticError, ValueError):
        finite = False
    if not finite:
        raise InputError(f"--nu {args.nu!r}, --xi {args.xi!r}: the reduced model's "
                         "coefficients (paper eqs. 3-5) are not finite numbers there; use "
                         "a radius ratio xi of order 1 (the paper: 1.25)")


def _jsonable(d: dict[str, Any]) -> dict[str, Any]:
    return {k: (float(v) if isinstance(v, float) else v) for k, v in d.items()}


def wave_command(args: argparse.Namespace) -> int:
    """Handler of ``stickslip wave``: solve, print JSON or a table, optionally plot."""
    try:
        _validate(args)
    except InputError as err:
        return fail(str(err))
    if args.plot:
        problem = output_file_problem(args.plot, "--plot")
        if problem:
            return fail(problem)

    gamma = gamma_from_physical(args.wave_speed, args.radius, args.omega)
    co = coefficients(args.nu, args.xi, gamma)
    try:
        waves = _find_waves(args, co)
    except (np.linalg.LinAlgError, ArithmeticError, ValueError):  # no finite numbers there
        print(f"error: --f {args.f!r}, --k {args.k!r}, --delta {args.delta!r}: the "
              "reduced model's wave equations give no finite numbers there; use values "
              "of order 1 (the paper: f = 0.7, k = 4, delta = 0.001)", file=sys.stderr)
        return 2
    best = next((w for w in waves if w.admissible), None)
    out = _wave_summary(args, gamma, co, waves, best)
    if args.plot:
        target = best or (waves[0] if waves else None)
        if target is None:
            print("error: --plot: no wave solution was found to draw", file=sys.stderr)
            return 1

        plot_wave(target, args.plot, zone_colours=STATUS_COLORS, R=args.radius,
                  omega=args.omega)
    if args.json:
        print(json.dumps(out, indent=2))
        return 0
    _print_waves(gamma, co, out)
    return 0


def _find_waves(args: argparse.Namespace, co: Coefficients) -> list[TravellingWave]:
    """The reduced model's travelling waves of mode k (eqs. [3]-[7]) for the chosen regime
    and junction closures; none at f = 0."""
    junctions = ("impact", "smooth") if args.junction == "both" else (args.junction,)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        # f = 0 (allowed, as in scenes): no friction, no stick zone, steady sliding is neutral
        # (flutter growth 0): the reduced model has no travelling stick-slip wave to find.
        return (find_waves(co, args.f, args.k, args.delta, regime=args.regime,
                           junctions=junctions) if args.f > 0 else [])


#: The selected wave's fields copied to the top level of ``stickslip wave --json``.
WAVE_KEYS = ("junction", "c", "celerity_m_s", "frequency_hz", "angular_frequency_rad_s",
             "psi1", "psi2", "amplitude", "v_amplitude")


def _wave_summary(args: argparse.Namespace, gamma: float, co: Coefficients,
                  waves: list[TravellingWave], best: TravellingWave | None) -> dict[str, Any]:
    """The JSON object: the selected (first admissible) wave's regime and fields, the
    inputs, the coefficients and every solution found."""
    sols = [_jsonable(w.summary(args.radius, args.omega)) for w in waves]
    out: dict[str, Any] = {
        "regime": best.regime if best else "none",
        "inputs": {
            "nu": args.nu,
            "xi": args.xi,
            "f": args.f,
            "k": args.k,
            "delta": args.delta,
            "omega": args.omega,
            "wave_speed": args.wave_speed,
            "radius": args.radius,
            "gamma": gamma,
        },
        "coefficients": {"a": co.a, "b": co.b, "g": co.g, "h": co.h, "D": co.D},
    }
    bsum = sols[waves.index(best)] if best else {}
    for key in WAVE_KEYS:
        out[key] = bsum.get(key)
    out["solutions"] = sols
    return out


def _print_waves(gamma: float, co: Coefficients, out: dict[str, Any]) -> None:
    """The table of ``stickslip wave``: coefficients, selected regime, one row per wave."""
    sols = out["solutions"]
    print(
        f"gamma = {gamma:.6g}   a = {co.a:.6g}  b = {co.b:.6g}  g = {co.g:.6g}  "
        f"h = {co.h:.6g}  D = {co.D:.6g}"
    )
    print(f"selected regime: {out['regime']}")
    hdr = (
        f"{'regime':<22}{'junction':<15}{'c':>10}{'m/s':>10}{'Hz':>9}{'psi1':>8}"
        f"{'psi2':>8}{'max U-d':>10}  admissible / violated"
    )
    print(hdr)
    print("-" * len(hdr))
    for s in sols:
        print(
            f"{s['regime']:<22}{s['junction']:<15}{s['c']:>10.4g}{s['celerity_m_s']:>10.1f}"
            f"{s['frequency_hz']:>9.1f}{s['psi1']:>8.4f}{s['psi2']:>8.4f}"
            f"{s['amplitude']:>10.3g}  {'yes' if s['admissible'] else 'no: ' + s['violated']}"
        )
    if not sols:
        print("(no solution found)")


def flutter_command(args: argparse.Namespace) -> int:
    """Handler of ``stickslip flutter``: modes k = 1..kmax in physical units."""
    try:
        _validate(args)
    except InputError as err:
        return fail(str(err))

    co = coefficients(
        args.nu, args.xi, gamma_from_physical(args.wave_speed, args.radius, args.omega)
    )
    modes = [
        mode_physical(m, args.radius, args.omega) for m in flutter_modes(co, args.f, args.kmax)
    ]
    if args.json:
        print(json.dumps({"D": co.D, "modes": modes}, indent=2))
        return 0
    print(f"D = {co.D:.6g} (exploding wave {'with' if co.D > 0 else 'against'} the rotation)")
    print(f"{'k':>3}{'growth 1/s':>14}{'phase m/s':>14}{'freq Hz':>12}  direction")
    for m in modes:
        print(
            f"{m['k']:>3}{m['growth_rate_per_s']:>14.4g}{m['phase_speed_m_s']:>14.2f}"
            f"{m['frequency_hz']:>12.2f}  {m['direction']}"
        )
    return 0
