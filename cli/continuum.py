"""``stickslip flutter-exact``: exact continuum flutter of steady sliding.

Every branch (growth rate, frequency, direction) of the clamped annulus in linearised
sliding per circumferential order n (``exact.sliding_flutter``), optionally with Kelvin-Voigt
damping and linearised Prakash-Clifton friction, and the half-space threshold
(``exact.halfspace``). dolfinx-free. Documentation: docs/continuum.md.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from typing import Any

from stickslip.cli.checks import fail
from stickslip.cli.commands import command_help
from stickslip.exact import halfspace
from stickslip.exact.annulus import Elastic
from stickslip.exact.sliding_flutter import Dissipation, sliding_branches
from stickslip.solver.scene import load_scene

__all__ = ["flutter_exact_command", "register"]

NMAX_LIMIT = 2000  # orders above this need collocation matrices > 4000² (minutes per n)
REGULARIZATIONS = ("none", "prakash-clifton", "constant-time")


class InputError(ValueError):
    """A bad option: the message names the flag, the value and the allowed range."""


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``flutter-exact [SCENE]`` to the ``stickslip`` subcommands."""
    p = sub.add_parser(
        "flutter-exact",
        help=command_help("flutter-exact"),
        description=(
            "Linearised steady sliding of the plane-strain annulus R <= r <= xi R (clamped "
            "outside; u_r = 0 and sigma_rt = f sigma_rr at r = R): growth rate and frequency of "
            "every branch of each order n, exact (Bessel determinant; all roots seeded by a "
            "Chebyshev collocation). Optional Kelvin-Voigt damping and linearised "
            "Prakash-Clifton friction. The N -> infinity reference of flutter-fe."
        ),
    )
    p.add_argument("scene", nargs="?", default=None,
                   help="scene TOML (material, geometry, f, Omega, [damping], [friction]); "
                        "the options below override it")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scene field (with SCENE)")
    p.add_argument("--nu", type=float, default=None, help="Poisson ratio, 0 <= nu < 0.5 (0.3)")
    p.add_argument("--xi", type=float, default=None, help="outer/inner radius, 1 < xi <= 10 (1.25)")
    p.add_argument("--R", "--radius", dest="R", type=float, default=None,
                   help="inner radius R (m, default 1)")
    p.add_argument("--E", type=float, default=None, help="Young's modulus (Pa, default 1e9)")
    p.add_argument("--wave-speed", type=float, default=None,
                   help="sqrt(E/rho) (m/s, default 1000): sets rho = E / wave_speed^2")
    p.add_argument("--f", type=float, default=None, help="friction coefficient, 0..10 (0.7)")
    p.add_argument("--f-sweep", default=None, metavar="A:B:N|F1,F2,...",
                   help="several friction coefficients (replaces --f)")
    p.add_argument("--nmax", type=int, default=200, help=f"largest order n (0..{NMAX_LIMIT})")
    p.add_argument("--nmin", type=int, default=0, help="smallest order n (default 0)")
    p.add_argument("--n", dest="n_list", default=None, metavar="N1,N2,...",
                   help="explicit orders instead of nmin..nmax")
    p.add_argument("--fmax-hz", type=float, default=3000.0,
                   help="band: every branch below max(fmax, speed-factor c_p n / 2 pi R) (Hz)")
    p.add_argument("--speed-factor", type=float, default=1.2,
                   help="band in phase speed, multiple of c_p (default 1.2; 0 = fmax only)")
    p.add_argument("--loss-factor", type=float, default=None,
                   help="Kelvin-Voigt loss factor eta at --reference-frequency-hz (0..10)")
    p.add_argument("--reference-frequency-hz", type=float, default=None,
                   help="frequency of the loss factor (Hz): tau = eta / (2 pi f_ref)")
    p.add_argument("--retardation-time", type=float, default=None,
                   help="Kelvin-Voigt retardation time tau (s), instead of the loss factor")
    p.add_argument("--regularization", choices=REGULARIZATIONS, default=None,
                   help="friction law: none (Coulomb), prakash-clifton, constant-time")
    p.add_argument("--slip-length", type=float, default=None, help="Prakash-Clifton L (m)")
    p.add_argument("--reference-velocity", type=float, default=None,
                   help="Prakash-Clifton V* (m/s, default 0)")
    p.add_argument("--relaxation-time", type=float, default=None,
                   help="constant-time variant: t* (s)")
    p.add_argument("--omega", type=float, default=None,
                   help="rotation speed (rad/s): steady slip rate R|Omega| of Prakash-Clifton")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--yes-i-know", action="store_true",
                   help=f"run a costly case anyway (nu > {NU_COST_LIMIT})")
    p.set_defaults(func=flutter_exact_command)


#: Above this Poisson ratio the continuum's root search slows down sharply (c_p / c_s > 22).
NU_COST_LIMIT = 0.499


def _finite(flag: str, value: float, lo: float, hi: float, *, lo_open: bool = False,
            hi_open: bool = False) -> float:
    ok = math.isfinite(value) and (value > lo if lo_open else value >= lo) \
        and (value < hi if hi_open else value <= hi)
    if not ok:
        rng = f"{'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"
        raise InputError(f"--{flag} {value!r} is out of range: need a value in {rng}")
    return float(value)


def _scene_values(args: argparse.Namespace) -> dict[str, Any]:
    """Defaults, then the scene's values, then the options."""
    v: dict[str, Any] = {"E": 1.0e9, "rho": 1000.0, "nu": 0.3, "R": 1.0, "xi": 1.25, "f": 0.7,
                         "omega": 50.0, "tau": 0.0, "reg": "none", "L": None, "vstar": 0.0,
                         "tstar": None, "source": "defaults"}
    if args.scene is not None:
        sc = load_scene(args.scene, args.overrides)
        v.update(E=sc.material.E, rho=sc.material.rho, nu=sc.material.nu, R=sc.geometry.R,
                 xi=sc.geometry.xi, f=sc.loading.f, omega=sc.loading.omega, source=sc.name)
        fr = sc.friction  # the scene's own [damping] tau and [friction] keys (solver.scene)
        v.update(tau=sc.damping.tau, reg=fr.regularization, L=fr.slip_length,
                 vstar=fr.reference_velocity, tstar=fr.relaxation_time)
    elif args.overrides:
        raise InputError("--set needs a SCENE: give a scene file or use the options")
    for key, opt in (("E", args.E), ("nu", args.nu), ("R", args.R), ("xi", args.xi),
                     ("f", args.f), ("omega", args.omega)):
        if opt is not None:
            v[key] = opt
    if args.wave_speed is not None:
        c0 = _finite("wave-speed", args.wave_speed, 0.0, 1e6, lo_open=True)
        v["rho"] = v["E"] / c0**2 if c0**2 > 0 else math.inf
        if not 0 < v["rho"] < math.inf:
            raise InputError(f"--wave-speed {c0!r} gives the density E / wave_speed^2 = "
                             f"{v['rho']:g} kg/m^3: need a finite, non-zero density (the "
                             "reference material has 1000 m/s)")
    if args.regularization is not None:
        v["reg"] = args.regularization
    if args.slip_length is not None:
        v["L"] = args.slip_length
    if args.reference_velocity is not None:
        v["vstar"] = args.reference_velocity
    if args.relaxation_time is not None:
        v["tstar"] = args.relaxation_time
    return v


def _parse(args: argparse.Namespace) -> tuple[Any, list[float], list[int], Any, dict]:
    v = _scene_values(args)
    _finite("E", v["E"], 0.0, 1e13, lo_open=True)
    _finite("nu", v["nu"], 0.0, 0.5, hi_open=True)
    if v["nu"] > NU_COST_LIMIT and not args.yes_i_know:
        raise InputError(
            f"--nu {v['nu']!r}: near incompressibility the pressure waves are "
            f"{math.sqrt(2 * (1 - v['nu']) / (1 - 2 * v['nu'])):.0f} x faster than the shear "
            "waves and the root search takes minutes; use nu <= "
            f"{NU_COST_LIMIT}, or --yes-i-know to wait")
    _finite("R", v["R"], 0.0, 1e3, lo_open=True)
    _finite("xi", v["xi"], 1.0, 10.0, lo_open=True)
    mat = Elastic(E=v["E"], rho=v["rho"], nu=v["nu"], R=v["R"], xi=v["xi"])
    if args.f_sweep:
        fs = _f_sweep(args.f_sweep)
    else:
        fs = [_finite("f", v["f"], 0.0, 10.0)]
    if args.n_list:
        try:
            ns = sorted({int(x) for x in args.n_list.split(",") if x.strip()})
        except ValueError as err:
            raise InputError(f"--n {args.n_list!r}: use a comma list of integers") from err
        if not ns or ns[0] < 0 or ns[-1] > NMAX_LIMIT:
            raise InputError(f"--n {args.n_list!r} is out of range: need 0 <= n <= {NMAX_LIMIT}")
    else:
        if not 0 <= args.nmax <= NMAX_LIMIT:
            raise InputError(f"--nmax {args.nmax} is out of range: need 0..{NMAX_LIMIT}")
        if not 0 <= args.nmin <= args.nmax:
            raise InputError(f"--nmin {args.nmin} is out of range: need 0..nmax ({args.nmax})")
        ns = list(range(args.nmin, args.nmax + 1))
    _finite("fmax-hz", args.fmax_hz, 0.0, 1e8)
    _finite("speed-factor", args.speed_factor, 0.0, 10.0)
    if args.fmax_hz == 0 and args.speed_factor == 0:
        raise InputError("--fmax-hz 0 with --speed-factor 0 is an empty band: raise one of them")
    # Kelvin-Voigt
    tau = v["tau"]
    if args.loss_factor is not None or args.reference_frequency_hz is not None:
        if args.retardation_time is not None:
            raise InputError("--loss-factor and --retardation-time both given: use one")
        eta = _finite("loss-factor", args.loss_factor if args.loss_factor is not None
                      else float("nan"), 0.0, 10.0)
        fref = _finite("reference-frequency-hz", args.reference_frequency_hz
                       if args.reference_frequency_hz is not None else float("nan"),
                       0.0, 1e8, lo_open=True)
        tau = Dissipation.from_loss_factor(eta, fref)
    elif args.retardation_time is not None:
        tau = _finite("retardation-time", args.retardation_time, 0.0, 1.0)
    # friction law
    t_star = 0.0
    if v["reg"] == "prakash-clifton":
        if v["L"] is None:
            raise InputError("--regularization prakash-clifton needs --slip-length L > 0 (m)")
        L = _finite("slip-length", v["L"], 0.0, 1.0, lo_open=True)
        vstar = _finite("reference-velocity", v["vstar"], 0.0, 1e4)
        speed = mat.R * abs(_finite("omega", v["omega"], -1e6, 1e6))
        if speed + vstar <= 0:
            raise InputError("Prakash-Clifton with Omega = 0 and V* = 0 never relaxes: "
                             "give --omega or --reference-velocity > 0")
        t_star = Dissipation.prakash_clifton_time(L, speed, vstar)
    elif v["reg"] == "constant-time":
        if v["tstar"] is None:
            raise InputError("--regularization constant-time needs --relaxation-time t* > 0 (s)")
        t_star = _finite("relaxation-time", v["tstar"], 0.0, 1.0, lo_open=True)
    diss = Dissipation(tau=tau, t_star=t_star)
    info = {"source": v["source"], "omega_rad_s": v["omega"], "regularization": v["reg"]}
    return mat, fs, ns, diss, info


def _f_sweep(text: str) -> list[float]:
    try:
        if ":" in text:
            a, b, n = text.split(":")
            num = int(n)
            if not 1 <= num <= 1000:
                raise InputError(f"--f-sweep {text!r}: need 1..1000 values")
            vals = [float(a) + (float(b) - float(a)) * i / max(num - 1, 1) for i in range(num)]
        else:
            vals = [float(x) for x in text.split(",") if x.strip()]
    except ValueError as err:
        raise InputError(f"--f-sweep {text!r}: use start:stop:num or a comma list") from err
    if not vals or not all(math.isfinite(x) and 0.0 <= x <= 10.0 for x in vals):
        raise InputError(f"--f-sweep {text!r} is out of range: need friction values in [0, 10]")
    return vals


def flutter_exact_command(args: argparse.Namespace) -> int:
    """Handler of ``stickslip flutter-exact``."""
    try:
        mat, fs, ns, diss, info = _parse(args)
    except (InputError, ValueError, FileNotFoundError) as err:
        return fail(str(err))
    t0 = time.perf_counter()
    results = []
    for f in fs:
        orders = [sliding_branches(n, f, mat, fmax_hz=args.fmax_hz,
                                   speed_factor=args.speed_factor, diss=diss) for n in ns]
        hs = halfspace.growing_roots(f, mat.nu)
        results.append({
            "f": f,
            "halfspace_growing_root_c_over_cs": [[z.real, z.imag] for z in hs],
            "halfspace_growth_per_n_per_s": (float(hs[0].imag * mat.cs / mat.R)
                                             if hs.size else 0.0),
            "orders": [{"n": o.n, "band_hz": o.band_hz, "collocation_points":
                        o.collocation_points, "branches": [b.to_dict() for b in o.branches]}
                       for o in orders],
        })
        if any(not b.polished for o in orders for b in o.branches):
            print(f"warning: f = {f:g}: some roots kept their collocation value (Bessel polish "
                  "did not converge; 'polished': false)", file=sys.stderr)
    out = {
        "material": {"E": mat.E, "rho": mat.rho, "nu": mat.nu, "R": mat.R, "xi": mat.xi,
                     "cp": mat.cp, "cs": mat.cs},
        "dissipation": {"retardation_time_s": diss.tau, "friction_relaxation_time_s":
                        diss.t_star, **info},
        "halfspace_threshold_f_c": halfspace.threshold(mat.nu),
        "conventions": "wave exp(i(n theta - omega t)); growth = Im omega (1/s); direction "
                       "'rotation' = travels with the cylinder (+theta)",
        "wall_time_s": time.perf_counter() - t0,
        "results": results,
    }
    if args.json:
        print(json.dumps(out, indent=1))
        return 0
    print(f"exact flutter of steady sliding: E = {mat.E:g} Pa, rho = {mat.rho:g} kg/m^3, "
          f"nu = {mat.nu:g}, R = {mat.R:g} m, xi = {mat.xi:g} (c_s = {mat.cs:.1f}, "
          f"c_p = {mat.cp:.1f} m/s); tau = {diss.tau:g} s, t* = {diss.t_star:g} s")
    print(f"half-space threshold f_c(nu = {mat.nu:g}) = {out['halfspace_threshold_f_c']:.6f}")
    for r in results:
        print(f"\nf = {r['f']:g}: half-space growth/n = {r['halfspace_growth_per_n_per_s']:.2f}"
              " /s (0: stable)")
        print(f"{'n':>4} {'branches':>8} {'unstable':>8} {'max growth':>11} {'freq (Hz)':>10} "
              f"{'direction':>9} {'speed (m/s)':>11} {'growth/n':>9}")
        for o in r["orders"]:
            br = o["branches"]
            uns = [b for b in br if b["growth_rate"] > 1e-9 * 2 * math.pi * b["frequency_hz"]]
            if not br:
                print(f"{o['n']:4d} {0:8d}")
                continue
            b = max(br, key=lambda x: x["growth_rate"])
            print(f"{o['n']:4d} {len(br):8d} {len(uns):8d} {b['growth_rate']:11.2f} "
                  f"{b['frequency_hz']:10.1f} {b['direction']:>9} {b['phase_speed_m_s']:11.1f} "
                  f"{b['growth_rate'] / max(o['n'], 1):9.3f}")
    print(f"\n({out['wall_time_s']:.1f} s; --json lists every branch)")
    return 0
