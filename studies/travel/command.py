"""The options of ``stickslip travel`` and of ``stickslip.travel`` / ``travel_branch``: one
table of defaults, one resolution, one solve, so the command and the Python API give the
same wave bit for bit for the same arguments.

The default route is the transient's own discrete wave: ``inertia="shift"``,
``time_scheme="central"`` (step h = node passage / S, S = round(node passage / dt)) and the
first-order material derivative ``rate="bdf1"`` that this step implies; ``inertia="rotation"``
or ``time_scheme="exact"`` are the continuum routes (exact in time, ``rate="bdf2"``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from pathlib import Path
from types import SimpleNamespace

from stickslip.solver.scene.files import scene_difference
from stickslip.studies.rundir.readers import ReadError, check_run_dir, read_scene_file
from stickslip.studies.travel import driver as D
from stickslip.studies.travel.from_run import (
    NotRigidWave,
    compare_with_run,
    dt_limit_scene,
    dt_limit_wave,
    matched_samples,
    read_end_state,
    scene_time_step,
    solve_matched,
)
from stickslip.studies.travel.newton import RATES, NotConverged

#: Every option with its default (None: resolved from the others or from the scene).
DEFAULTS: dict = {"k": None, "from_run": None, "damping": None, "celerity": None,
                  "fixed_omega": False, "rate": None, "inertia": "shift", "samples": None,
                  "time_scheme": None, "max_iter": 60, "dt_limit": False, "band": False,
                  "cont": None, "plot": False}

#: The most contact points per node (S) of the central scheme's matched step: a start speed
#: so slow that one node passage takes more time steps is no travelling wave of the run.
MAX_SAMPLES = 1e5

#: The relative gap between the wave's celerity and the start's above which the result says
#: so: below 0.1 % the start was the wave's speed to the precision a user reads (the fixed-
#: speed search moves in steps of 0.25 %, ``driver.solve_scene``).
START_GAP = 1e-3

#: Command-line flags whose name is not the option's with dashes.
_FLAGS = {"from_run": "--from", "cont": "--continue"}


def cli_flag(name: str) -> str:
    """How ``stickslip travel`` spells option ``name`` (``max_iter`` -> ``--max-iter``)."""
    return _FLAGS.get(name, "--" + name.replace("_", "-"))


def keyword(name: str) -> str:
    """How the Python API spells option ``name`` in an error (``max_iter`` -> ``max_iter=``)."""
    return f"{name}="


def options(**given) -> SimpleNamespace:
    """``DEFAULTS`` updated with ``given``; an unknown name raises ``TypeError``."""
    unknown = sorted(set(given) - set(DEFAULTS))
    if unknown:
        raise TypeError(f"travel: unknown option {unknown[0]!r} (options: {sorted(DEFAULTS)})")
    return SimpleNamespace(**{**DEFAULTS, **given})


def check(opts: SimpleNamespace, flag: Callable[[str], str] = cli_flag) -> str | None:
    """The first bad option as a one-line message (spelt by ``flag``), or None; fills the
    route's defaults (``time_scheme``, ``rate``). Needs no scene."""
    # dolfinx on first use: `stickslip travel` imports it first, without numba
    from stickslip.studies.travel.frame import INERTIAS

    if opts.k is not None and opts.k < 1:
        return f"{flag('k')} {opts.k}: the wavenumber must be an integer >= 1"
    if opts.k is None and not opts.from_run:
        return (f"{flag('k')}: give the wavenumber (or {flag('from_run')} RUN_DIR, whose k is "
                "the default)")
    if opts.damping is not None and not opts.damping >= 0:
        return f"{flag('damping')} {opts.damping}: the retardation time must be >= 0"
    if opts.celerity is not None and not (math.isfinite(opts.celerity) and opts.celerity):
        return (f"{flag('celerity')} {opts.celerity}: a travelling wave needs a finite, "
                "non-zero speed (sign = sense)")
    if opts.max_iter < 1:
        return f"{flag('max_iter')} {opts.max_iter}: must be >= 1"
    if opts.inertia not in INERTIAS:
        return f"{flag('inertia')} {opts.inertia}: use {' or '.join(INERTIAS)}"
    if opts.time_scheme is None:
        opts.time_scheme = "central" if opts.inertia == "shift" else "exact"
    if opts.rate is None:
        opts.rate = "bdf1" if opts.time_scheme == "central" else "bdf2"
    if opts.time_scheme == "central" and opts.rate != "bdf1":
        return (f"{flag('rate')} {opts.rate}: the central time scheme is the transient's step, "
                f"whose contact law is first order (bdf1); drop {flag('rate')}")
    if opts.rate not in RATES:
        return (f"{flag('rate')} {opts.rate}: the material-derivative scheme must be one of "
                f"{', '.join(RATES)}")
    if opts.samples is not None and (opts.samples < 1 or (opts.samples > 1
                                                          and opts.inertia != "shift")):
        return (f"{flag('samples')} {opts.samples}: give a whole number >= 1; more than 1 "
                f"needs {flag('inertia')} shift")
    if opts.samples is not None and opts.samples > MAX_SAMPLES:
        return (f"{flag('samples')} {opts.samples}: at most {MAX_SAMPLES:g} contact points "
                "per node (each a time step of the node's history)")
    if opts.time_scheme != "exact" and opts.inertia != "shift":
        return f"{flag('time_scheme')} {opts.time_scheme}: needs {flag('inertia')} shift"
    if opts.dt_limit and (opts.time_scheme != "central" or opts.cont):
        return (f"{flag('dt_limit')}: the dt -> 0 wave extrapolates the central scheme's step; "
                f"drop {flag('inertia')} rotation / {flag('time_scheme')} exact / "
                f"{flag('cont')}")
    return None


def celerity_note(start: float, celerity: float, solve: str) -> str | None:
    """One line saying how far the wave's ``celerity`` (m/s) is from the ``start`` speed and
    why, when the gap is over ``START_GAP``; None otherwise. ``solve``: the solution's
    ``how`` (``driver.solve_scene``): a fixed-speed search took the nearest admissible speed
    (the discrete waves exist in bands of speed, not at every speed); a free-speed solve
    has the speed as an unknown and converged to the wave's own."""
    gap = (celerity - start) / abs(start)
    if not abs(gap) > START_GAP:
        return None
    why = ("no wave of this family is admissible at the start's speed: the fixed-speed "
           "search took the nearest speed where one is (steps of 0.25 %, up to 5 %; the "
           "discrete waves exist in bands of speed)" if solve.startswith("fixed omega") else
           "the speed is an unknown of the solve, and Newton converged to the wave's own "
           "celerity (the start only seeds it)")
    sense = "faster" if abs(celerity) > abs(start) else "slower"
    return (f"the wave's celerity {celerity:.1f} m/s is {100.0 * abs(gap):.2f} % {sense} than "
            f"the start's {start:.1f} m/s: {why}")


def other_scene(scene, run_dir: str | Path) -> str | None:  # noqa: ANN001
    """Why the run in ``run_dir`` is not of ``scene``'s physics and mesh (the first key that
    differs: a wave solved for one scene is no measure of another's run), or None."""
    differs = scene_difference(read_scene_file(Path(run_dir) / "scene.toml"), scene)
    if differs is None:
        return None
    return (f"{run_dir} is a run of another problem: its {differs} here; give the run's "
            f"own scene ({Path(run_dir) / 'scene.toml'}) or set it")


def resolve(scene, opts: SimpleNamespace,  # noqa: ANN001
            flag: Callable[[str], str] = cli_flag) -> str | None:
    """Fill the options that need the scene (``damping``, the run's end state ``end``, ``k``,
    the matched ``samples``; ``problem`` and ``reduced``, built on the way and reused), or
    return why they cannot be (one line). ``check`` first. A run whose end state is not a
    rigid wave raises ``studies.travel.from_run.NotRigidWave``."""
    if opts.damping is None:  # same physics as the transient: the scene's Kelvin-Voigt tau
        opts.damping = float(scene.damping.tau)
    opts.end = None
    if opts.from_run:
        try:
            check_run_dir(opts.from_run, 1)
        except ReadError as err:
            return f"{flag('from_run')}: {err}"
        if problem := other_scene(scene, opts.from_run):
            return f"{flag('from_run')}: {problem}"
        try:
            opts.end = read_end_state(Path(opts.from_run))
        except NotRigidWave:
            raise
        except ValueError as err:
            return f"{flag('from_run')} {err}"
        if opts.k is None:
            opts.k = opts.end.k
    n = scene.mesh.n_inner
    if opts.k is not None and opts.k > n // 2:
        return (f"{flag('k')} {opts.k} is above the highest wavenumber of mesh.n_inner = "
                f"{n} contact nodes, N/2 = {n // 2} (a wave needs 2 nodes per wavelength): "
                f"use a smaller {flag('k')} or a finer mesh")
    try:
        _matched_step(scene, opts)
    except ValueError as err:
        return str(err)
    return None


def _matched_step(scene, opts: SimpleNamespace) -> None:  # noqa: ANN001
    """``opts.samples`` when not given: 1 for the exact-in-time route; for the central scheme
    S = round(node passage / dt) (``studies.travel.from_run.matched_samples``) with the run's
    dt and speed (``from_run``), else the dt ``stickslip run`` uses for the scene and the
    start's speed (``opts.problem``, ``opts.reduced``: the mesh and the start, reused)."""
    opts.problem, opts.reduced = None, None
    if opts.samples is not None:
        return
    if opts.time_scheme != "central":
        opts.samples = 1
        return
    if opts.end is not None and scene.mesh.n_inner == opts.end.samples["theta"].size:
        opts.samples = matched_samples(opts.end.node_passage, opts.end.dt)
        return
    # dolfinx on first use: `stickslip travel` imports it first, without numba
    from stickslip.solver.problem import build_problem

    opts.problem = build_problem(scene)
    dt = scene_time_step(scene, opts.problem)
    if opts.celerity is not None:
        omega = opts.celerity / scene.geometry.R
    elif opts.end is not None:
        omega = opts.end.omega
    else:
        opts.reduced = D.reduced_start(scene, opts.k)
        omega = opts.reduced[1]
    n = opts.problem.nodes.theta.size // scene.mesh.degree  # contact edges: the symmetry step
    passage = 2.0 * math.pi / (n * abs(omega))
    if not passage > 0.0:  # |omega| so large (--celerity 1e308) that n |omega| overflows
        raise ValueError(f"a start speed of {omega * scene.geometry.R:.3g} m/s passes a "
                         "contact node in no time; give a celerity of the order of the wave "
                         "speed (m/s)")
    if not passage / dt < MAX_SAMPLES:  # S = passage / dt contact points per node
        raise ValueError(f"a start speed of {omega * scene.geometry.R:.3g} m/s passes one "
                         f"contact node every {passage:.3g} s, {passage / dt:.3g} time steps: "
                         f"the matched step needs at most {MAX_SAMPLES:g}; give a faster "
                         "celerity, or samples")
    opts.samples = matched_samples(passage, dt)


def solve(scene, opts: SimpleNamespace, t0: float) -> tuple[dict, dict]:  # noqa: ANN001
    """The wave of ``resolve``d options: ``(summary, profiles)`` (``studies.travel.driver.
    measure`` plus the comparisons asked for). A failed solve raises ``NotConverged`` with
    ``start_info`` (the start's description) attached; a bad start raises ``ValueError``."""
    import numpy as np

    matched = (opts.end is not None and opts.time_scheme == "central"
               and opts.celerity is None and not opts.fixed_omega)
    if matched:  # the run's own wave: its fallbacks (studies.travel.from_run)
        W0 = om0 = None
        info = {"start": "run", "from": str(opts.from_run)}
    else:
        st = D.setup(scene, opts.damping, rate=opts.rate, inertia=opts.inertia,
                     samples=opts.samples, time_scheme=opts.time_scheme, problem=opts.problem)
        if opts.from_run:
            W0, om0, info = D.start_from_run(Path(opts.from_run), st)
        else:
            W0, om0, info = D.start_from_reduced(st, opts.k, opts.reduced)
    if opts.celerity is not None:
        om0 = opts.celerity / scene.geometry.R
        info["start_celerity_m_s"] = opts.celerity
    t_setup = time.perf_counter() - t0
    try:
        if matched:
            opts.end.scene = scene  # the physics of the options (overrides apply)
            st, sol, info["start"] = solve_matched(opts.end, opts.samples, opts.max_iter)
        else:
            sol = D.solve_scene(st, opts.k, W0, om0, max_iter=opts.max_iter,
                                free_omega=not opts.fixed_omega)
    except NotConverged as err:
        err.start_info = info
        raise
    summary, profiles = D.measure(st, sol, opts.k)
    if opts.end is not None:
        summary["from_run"] = compare_with_run(opts.end, st, sol, summary)
        if opts.dt_limit:
            summary["dt_limit"] = dt_limit_wave(opts.end, opts.samples,
                                                np.r_[sol.W_r, sol.W_t], sol.omega)
    elif opts.dt_limit:
        summary["dt_limit"] = dt_limit_scene(st, opts.k, np.r_[sol.W_r, sol.W_t], sol.omega)
    if opts.band:
        summary["band"] = D.band(st, sol, opts.k)
    summary.update(info, damping_s=opts.damping, inertia=opts.inertia, setup_time_s=t_setup,
                   wall_time_s=time.perf_counter() - t0)
    if "start_celerity_m_s" in info:
        note = celerity_note(info["start_celerity_m_s"], summary["celerity_m_s"],
                             summary["solve"])
        if note:
            summary["celerity_note"] = note
    return summary, profiles
