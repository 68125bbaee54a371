"""``stickslip rpo RUN_DIR``: the relative periodic orbit where a run's checkpoint stands."""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

from stickslip.cli.checks import fail, run_dir_dimension_problem
from stickslip.solver.atomic import atomic_write_text
from stickslip.solver.scene import SceneError
from stickslip.studies.rpo.birth import (
    MAX_LEG,
    MAX_VALUES,
    along,
    census_generators,
    scan_line,
)
from stickslip.studies.rpo.certificate import rpo_certificate
from stickslip.studies.rundir.ownership import OwnershipError, claim, register_kind


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "rpo",
        help="solve a relative periodic orbit u(θ, t + T) = u(θ − s, t) from a run (Newton)",
        description=(
            "Relative periodic orbit of the scene's explicit scheme from the state where a "
            "run's checkpoint stands (a census start): Newton-Krylov with a hookstep on "
            "R_-s F_T(x) - x = 0, T and s free with two phase conditions, then the leading "
            "Floquet multipliers. The guess T, s comes from the census's generators of the "
            "start (attractors.json above RUN_DIR) or from --period and --shift. Prints T, "
            "s, the residual, the multipliers and the orbit's components; -o writes one "
            "period of samples (samples.npz, a run's layout) and rpo.json. "
            "docs/howto/rpo.md"),
    )
    p.add_argument("run_dir", help="a run directory with a checkpoint (a census start)")
    p.add_argument("--period", type=float, metavar="T", help="guess of the period (s)")
    p.add_argument("--shift", type=float, metavar="S",
                   help="guess of the shift (degrees, + with the rotation)")
    p.add_argument("--nodes", type=int, metavar="M",
                   help="instead of --shift: a shift of M whole node passages (+ with the "
                        "rotation), held, so that the rotation is the mesh's own symmetry "
                        "(a rigid wave: T = M node passages; its multipliers are then the "
                        "scheme's)")
    p.add_argument("--krylov", type=int, default=60,
                   help="Arnoldi vectors of the multipliers (default 60; the verdict "
                        "says when a growing Ritz value has not converged: give more)")
    p.add_argument("--max-iter", type=int, default=20, help="Newton iterations (default 20)")
    p.add_argument("--tol", type=float, default=1e-10,
                   help="residual (relative RMS of the state) to stop at (default 1e-10)")
    p.add_argument("--multipliers", type=int, default=12,
                   help="leading Floquet multipliers to compute (0: none; default 12)")
    p.add_argument("--along", metavar="KEY=A:B:M",
                   help="instead of solving, follow the start along a scene key: M values "
                        "from A to B (or KEY=V1,V2,...), each --leg s from the end of the one "
                        "before; per value the second generator's growth rate sigma (1/s) and "
                        "its frequency in the first's frame: where sigma crosses 0 the "
                        "two-wave state is born (docs/theory/rpo.md)")
    p.add_argument("--leg", type=float, default=1.0,
                   help="with --along: seconds run at each value (default 1; sigma is "
                        "fitted over its second half)")
    p.add_argument("--wave", type=int, metavar="K",
                   help="with --along: the wave's wavenumber (default: the census member's "
                        "first generator)")
    p.add_argument("--sideband", type=int, metavar="K",
                   help="with --along: the sideband's wavenumber (default: the census "
                        "member's second generator)")
    p.add_argument("--seed", type=float, metavar="EPS",
                   help="with --along: add EPS d cos(K theta) (K = --sideband) at each "
                        "value's start and fit sigma where the sideband is below 1 %% of the "
                        "wave (its linear range): a rigid wave's eigenvalue")
    p.add_argument("--json", action="store_true", help="print the certificate as JSON")
    p.add_argument("-o", "--output", metavar="ORBIT_DIR",
                   help="write one period of samples (samples.npz) and rpo.json here (a new "
                        "or empty directory, or an earlier orbit's with --force)")
    p.add_argument("--force", action="store_true", help="replace an earlier orbit's -o")
    p.set_defaults(func=_rpo)


#: What an orbit directory holds (``studies.rundir.ownership``: -o is claimed as kind rpo).
ORBIT_ENTRIES = ("samples.npz", "rpo.json")


def option_problem(args: argparse.Namespace) -> str | None:
    """One line naming a bad option value and its fix, or None."""
    checks = (("--period", args.period, lambda x: x is None or (math.isfinite(x) and x > 0),
               "a positive number of seconds"),
              ("--shift", args.shift, lambda x: x is None or math.isfinite(x),
               "a finite angle in degrees"),
              ("--max-iter", args.max_iter, lambda x: x >= 0, "0 or more"),
              ("--tol", args.tol, lambda x: math.isfinite(x) and x > 0, "a positive number"),
              ("--multipliers", args.multipliers, lambda x: x >= 0, "0 (none) or more"),
              ("--nodes", args.nodes, lambda x: x is None or x != 0,
               "a nonzero number of node passages"),
              ("--krylov", args.krylov, lambda x: x >= max(2, args.multipliers),
               f"at least --multipliers ({args.multipliers}) and 2"))
    if args.leg is not None and not (math.isfinite(args.leg) and 0 < args.leg <= MAX_LEG):
        return (f"--leg {args.leg}: give a positive number of seconds up to {MAX_LEG:g} (a "
                "census's cap is 4 s)")
    if args.seed is not None and not (math.isfinite(args.seed) and args.seed > 0):
        return f"--seed {args.seed}: give a positive fraction of d, e.g. 1e-2"
    for flag, value in (("--wave", args.wave), ("--sideband", args.sideband)):
        if value is not None and value < 1:
            return f"{flag} {value}: give a wavenumber >= 1"
    if args.along is None and any(x is not None for x in (args.wave, args.sideband,
                                                           args.seed)):
        return "--wave, --sideband and --seed go with --along KEY=A:B:M"
    if args.nodes is not None and args.shift is not None:
        return f"--nodes {args.nodes} and --shift {args.shift}: give one of them"
    for flag, value, ok, want in checks:
        if not ok(value):
            return f"{flag} {value}: give {want}"
    return None


def parse_values(text: str) -> tuple[str, list[float]]:
    """``--along``: ``KEY=A:B:M`` (2 <= M <= ``MAX_VALUES`` values from A to B) or
    ``KEY=V1,V2,...`` -> (key, values); ValueError naming the fix."""
    key, sep, spec = text.partition("=")
    fix = f"give KEY=A:B:M (2 <= M <= {MAX_VALUES} values from A to B) or KEY=V1,V2,..."
    try:
        if not sep or "." not in key:
            raise ValueError
        if ":" in spec:
            a, b, m = spec.split(":")
            count, lo, hi = int(m), float(a), float(b)
            if not 2 <= count <= MAX_VALUES:
                raise ValueError
            values = [lo + (hi - lo) * i / (count - 1) for i in range(count)]
        else:
            values = [float(v) for v in spec.split(",")]
        if not 0 < len(values) <= MAX_VALUES or not all(math.isfinite(v) for v in values):
            raise ValueError
    except ValueError:
        raise ValueError(f"--along {text!r}: {fix}, e.g. loading.omega=60:70:5") from None
    return key.strip(), values


def _along(args: argparse.Namespace, run_dir: Path) -> int:
    """``--along``: ``studies.rpo.birth.along`` from the start's checkpoint, one line per
    value (or the result as JSON)."""
    try:
        key, values = parse_values(args.along)
    except ValueError as err:
        return fail(str(err))
    report = None if args.json else (lambda row: print(scan_line(row, key), flush=True))
    try:
        out = along(run_dir, key, values, leg=args.leg, wave=args.wave,
                    sideband=args.sideband, seed=args.seed, report=report)
    except SceneError as err:  # the key or a value of --along
        return fail(f"--along {args.along!r}: {err}")
    except ValueError as err:
        return fail(str(err))
    if args.json:
        print(json.dumps(out, indent=1))
    else:
        print(f"rpo --along {key}: k = {out['k_wave']} and its sideband k = {out['k_side']}, "
              f"{args.leg:g} s per value, from {run_dir}")
    return 0


def _print(cert: dict) -> None:
    state = "converged" if cert["converged"] else f"NOT converged ({cert['message']})"
    print(f"rpo: {state} after {cert['iterations']} Newton iterations, residual "
          f"{cert['residual']:.3e} (start {cert['guess']['residual']:.3e}; commutation "
          f"defect of a half-node shift {cert['commutation_defect']:.2e})")
    print(f"  T = {cert['period_s']:.9g} s ({cert['steps']} steps of {cert['step_s']:.6g} s; "
          f"the run's {cert['run_step_s']:.6g} s), s = {cert['shift_deg']:.6f} deg")
    if cert["floquet"] is not None:
        detail = cert["floquet_detail"]
        mods = ", ".join(f"{m:.6f}" for m in cert["floquet"])
        tol = detail["growth_tol_per_s"]
        verdict = {True: f"stable (no mode grows faster than {tol:g} 1/s)", False: "UNSTABLE",
                   None: "no verdict: no orbit, or a growing Ritz value unconverged"}[
                       cert["stable"]]
        excluded = sum(detail["neutral"])
        print(f"  Floquet |mu|: {mods} over T; {verdict}; fastest non-neutral growth "
              f"{detail['fastest_growth_per_s']:.3g} 1/s ({excluded} neutral set aside, "
              f"{detail['krylov']} Arnoldi vectors)")
        if cert.get("held_shift"):
            print(f"  (the orbit locked to {cert['steps']} steps per T: its multipliers "
                  "change with that number; the run's own stability is λ₁ at its step, "
                  "docs/howto/rpo.md)")
    for line in cert["components"][:8]:
        print(f"  component k = {line['k']:>3} {line['direction']:<8} "
              f"{line['frequency_hz']:+11.3f} Hz  share {line['share']:.3f}")
    for d in cert["differences"]:
        if d.get("orbit_frequency_hz") is not None:
            print(f"  vs census k = {d['k']:>3}: {d['frequency_hz']:+.3f} Hz, orbit "
                  f"{d['orbit_frequency_hz']:+.3f} Hz ({d['relative']:+.2e})")


def _rpo(args: argparse.Namespace) -> int:
    run_dir = Path(args.run_dir)
    problem = option_problem(args) or run_dir_dimension_problem(run_dir)
    if problem:
        return fail(problem)
    if not (run_dir / "checkpoint.npz").is_file():
        return fail(f"{run_dir}: no checkpoint.npz (give a finished run or census start)")
    if args.along is not None:
        return _along(args, run_dir)
    generators, components = census_generators(run_dir)
    given = args.shift is not None or args.nodes is not None
    if (args.period is None or not given) and len(generators) < 2:
        return fail(f"{run_dir}: no census member with two generators above it; give "
                     "--period T and --shift S (or --nodes M)")
    owned = None
    if args.output:
        register_kind("rpo", ORBIT_ENTRIES)
        try:
            owned = claim(args.output, "rpo", force=args.force)
        except OwnershipError as err:
            return fail(str(err))
    try:
        shift = None if args.shift is None else math.radians(args.shift)
        cert = rpo_certificate(run_dir, generators, components=components or None,
                               period=args.period, shift=shift, tol=args.tol,
                               max_iter=args.max_iter, floquet=args.multipliers,
                               nodes=args.nodes, krylov=args.krylov,
                               orbit_dir=None if owned is None else owned.work,
                               log=None if args.json else print)
        if owned is not None:
            atomic_write_text(owned.work / "rpo.json", json.dumps(cert, indent=1) + "\n")
            owned.commit()
    except BaseException:
        if owned is not None:
            owned.discard()
        raise
    finally:
        if owned is not None:
            owned.release()
    if args.json:
        print(json.dumps(cert, indent=1))
    else:
        _print(cert)
    return 0 if cert["converged"] else 1
