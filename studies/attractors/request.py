"""What a census is asked for, checked in one place for the command (``stickslip attractors``)
and the API (``stickslip.attractors``): the options, the census they define and its folder.

Each check raises ``ValueError`` (``CensusError``, ``SceneError``) with one line that names
the option as the command spells it and the fix.
"""

from __future__ import annotations

import json
import math
import sys
from dataclasses import dataclass
from pathlib import Path

from stickslip.solver.scene import load_scene
from stickslip.solver.schemes.select import check_backend
from stickslip.studies.attractors.along import parse_along, point_census
from stickslip.studies.attractors.cea import cea_lines, cea_table
from stickslip.studies.attractors.census import (
    DEFAULT_MAX_TIME,
    Census,
    CensusError,
    answer_json,
    cap_problem,
    default_dir,
    ladder_order,
)
from stickslip.studies.attractors.classify import CELERITY_TOL, SPREAD_TOL
from stickslip.studies.attractors.plots import plot_census
from stickslip.studies.attractors.starts import (
    DEFAULT_AMPLITUDE,
    DEFAULT_N_MODES,
    DEFAULT_SEED,
    StartDistribution,
    parse_rungs,
    parse_structured,
)


@dataclass(frozen=True)
class CensusRequest:
    """A census's options, each the command's option of the same name (``meshes``,
    ``degrees`` and ``structured`` as the command's text: ``"132,264"`` or
    ``"264p1,132p2"``, ``"1,2"``, ``"1:8"``; ``degrees`` also as a sequence of ints)."""

    scene: str
    starts: int = 16
    meshes: str | None = None
    degrees: str | tuple[int, ...] | None = None
    structured: str | None = None
    end_time: float | None = None
    max_time: float | None = None
    overrides: tuple[str, ...] = ()
    seed: int = DEFAULT_SEED
    n_modes: int = DEFAULT_N_MODES
    amplitude: float = DEFAULT_AMPLITUDE
    celerity_tol: float = CELERITY_TOL
    spread_tol: float = SPREAD_TOL
    output: str | None = None
    backend: str = "cpu"
    bundle: bool = False  # a GPU node runs the starts: the backend is not checked here
    check_cost: bool = True  # False: --yes-i-know
    half_step: bool = False  # every multi-wave member's half-step test (``step_check``)


def build_census(request: CensusRequest, ranks: int = 1) -> tuple[Census, Path]:
    """The census ``request`` asks for and its directory, checked before anything is
    written: the counts, the tolerances, the cap (at least the first leg's end; within the
    cost guard ``census.cap_problem`` unless ``check_cost`` is off), the backend."""
    if request.starts < 1:
        raise ValueError(f"--starts {request.starts}: give M >= 1 random starts per mesh")
    overrides = list(request.overrides)
    if request.end_time is not None:
        if not (math.isfinite(request.end_time) and request.end_time > 0):
            raise ValueError(f"--end-time {request.end_time}: give a time > 0 (s)")
        overrides.append(f"time.end_time={request.end_time!r}")
    scene = load_scene(request.scene, overrides)
    degrees = request.degrees  # the API may give a sequence (or one int)
    if isinstance(degrees, list | tuple):
        degrees = ",".join(str(p) for p in degrees)
    elif degrees is not None:
        degrees = str(degrees)
    rungs = ladder_order(scene, parse_rungs(request.meshes, degrees, scene.mesh.n_inner,
                                            scene.mesh.degree))
    dist = StartDistribution(starts=request.starts, seed=request.seed,
                             n_modes=request.n_modes, amplitude=request.amplitude,
                             structured=parse_structured(request.structured,
                                                         min(n for n, _ in rungs) // 2))
    for name, tol in (("--celerity-tol", request.celerity_tol),
                      ("--spread-tol", request.spread_tol)):
        if not 0 < tol < 1:
            raise ValueError(f"{name} {tol}: give a fraction between 0 and 1")
    if request.max_time is not None and not request.max_time >= scene.time.end_time:
        raise ValueError(f"--max-time {request.max_time}: give a time >= the first leg's "
                         f"end time {scene.time.end_time:g} s")
    census = Census(Path(request.scene), rungs, dist, tuple(overrides),
                    request.celerity_tol, request.spread_tol,
                    DEFAULT_MAX_TIME if request.max_time is None else request.max_time,
                    half_step=request.half_step)
    census.base_scene()
    if not request.bundle:
        check_backend(request.backend)
    out = Path(request.output) if request.output else default_dir(scene)
    if request.check_cost and (problem := cap_problem(census, out, ranks)):
        raise CensusError(problem)
    return census, out


def along_values(census: Census, along: str) -> tuple[str, list[float]]:
    """The key and values of ``--along KEY=A:B:M``, every point's scene checked before
    anything is written (``ValueError``/``CensusError`` with one line)."""
    key, values = parse_along(along)
    for value in values:
        point_census(census, key, value).base_scene()
    return key, values


def show_answer(out: Path, answer: dict, *, as_json: bool = False,
                cea_fmax_hz: float | None = None, plot: bool = False) -> int:
    """What the command prints after a census's answer, for the command and the API: the
    answer as ``attractors.json`` holds it (``as_json``), the CEA's lines (``cea_fmax_hz``)
    and the figures (``plot``). 1 where a figure cannot be written (said in one line on
    stderr), else 0."""
    stored = answer_json(answer)
    if as_json:
        print(stored, end="")
    if cea_fmax_hz is not None:
        for line in cea_lines(cea_table(out, json.loads(stored), cea_fmax_hz)):
            print(line)
    if plot:
        try:
            paths = plot_census(out, json.loads(stored))
        except OSError as err:
            print(f"error: the census figures could not be written: {err}", file=sys.stderr,
                  flush=True)
            return 1
        for path in paths:
            print(f"figure: {path}")
    return 0
