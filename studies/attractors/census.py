"""The census of one scene point: every start a scene of a generated sweep, then the answer.

``run_census`` (collective over MPI) writes ``DIR/base.toml`` (the scene with ``--set`` and
the end time applied) and ``DIR/census.toml``, a sweep file with one ``[[points]]`` entry per
start and mesh, and runs it with ``studies.sweep.run_sweep`` into ``DIR/starts`` (batched
where the scenes allow it, resumable: a finished start is never run again, a killed one is).
DIR is claimed as kind ``attractors`` (``studies.rundir.ownership``).

**Settle or extend** (``settle``): the sweep runs every start to the first leg's end time
T₀ (``--end-time``). A start whose features still differ between its last two windows of
length W = T₀/3, or whose shares still drift across its last leg (``classify``:
unsettled) is continued from its checkpoint, in place
(``studies.rundir.continuation.continue_batch``: the starts of one batch go on as one
batch; never from t = 0), to min(``GROWTH`` × T, T_max), and classified again, until every
start is settled, steady sliding, diverged or at the cap T_max (``max_time``, default
``DEFAULT_MAX_TIME``): only then is it "unsettled". Geometric legs cost log(T_max/T₀) /
log(1.5) rounds (7 from 0.3 s to 4 s) and run at most half again as long as a start
needed, while its settle time is read from the samples to one window W anyway
(``features.settle_scan``). Under MPI each rank continues its share (balanced by the cost
N³ × the time added), rank 0 classifies. A start continued beyond T₀ counts as done when
the census is resumed (``studies.sweep.table``: a run continued past the sweep's end time
is the sweep's run, and more).

**Every start accounted for.** The settled members are then certified (``certify_now``:
the direct solver's stability of a rigid wave, the kick test of every member). A member
that fails a certificate it got (``certify.failures``) is no attractor: its starts below
the cap are continued by the same legs from their own checkpoints, unperturbed (the kick
runs in ``kicks/``, apart), and their new end states certified, until each reaches a
state that passes or the cap. One still failing at the cap is a ``transient`` with its
``rejected_because``; each mesh's headline counts the starts that reach an attractor and
says where the others are (``statistics.accounting``, ``report.elsewhere_text``).

Rank 0 then reads every start's ``summary.json`` and samples, classifies the end states, groups them
into members, computes the statistics and writes ``attractors.json``, ``attractors.csv`` (one
row per start) and ``members.csv`` (one row per mesh and member of the random starts).

A census directory holds one definition (scene + start distribution, in ``census.json``);
another definition in the same directory is refused unless ``force``, and then every start
whose resolved scene changed runs again (the sweep's own rule). A ``census.json`` that is not
a definition (truncated, edited, another JSON type) is refused alike, naming the file.
Starts left over from a larger earlier census stay on disk and are not counted.

**Rungs.** The ladder's rungs are (N, p): N contact nodes at element degree p
(``starts.parse_rungs``: ``--meshes 132,264 --degrees 1,2`` or ``--meshes 264p1,132p2``). A
start of a rung whose degree is not the base scene's sets ``mesh.degree`` too (its folder
name then holds ``degree-2``); a degree-1 ladder's starts, keys (``"132"``) and files are
those of a plain-N ladder. Along the ladder the rungs go by their dofs, fewest first
(``ladder_order``; equal dofs: the lower degree first), so the ladder's matching, its
tests and ``stable_from`` read each rung against the next coarser one in dofs. The rows
(``attractors.csv``) and member rows (``members.csv``) carry ``n_inner`` and, last,
``degree``.

**Finished or not.** An answer is final only when every leg finished: no start is pending,
running, interrupted, crashed or unanalysed, none is unsettled below the cap (``SETTLING``:
its next leg did not run, or failed), and the session that wrote it was not stopped by a
signal or an error in a leg (``collect``'s ``stopped``). Otherwise the answer says
``NOT FINISHED`` (``attractors.json``: ``"finished": false``; ``attractors.csv``: those
starts' class ``settling``), the command exits 130 (a signal) or 1 (an error) and the same
command resumes it: a failed or interrupted leg leaves its start where its last whole leg
ended. Re-reading a census directory (``collect(reading=True)``) writes nothing it does not
have to: the caches ``features.json`` and ``certificates.json`` (which are only caches: a
file of another JSON type is read as empty) and the answer files are written only where
their text changed and the directory takes them.

**Cost guard of the cap.** A start unsettled at every leg runs to T_max, so the census's
worst case is every start at T_max: ``cap_problem`` estimates it (``studies.resources
.estimate`` at ``time.end_time = T_max``) and refuses, in one line with the bound and the
fix, a cap whose starts would take more than ``studies.resources.MAX_SECONDS`` on the ranks
given or write more samples than the disk under the census directory has free, unless
``--yes-i-know``; a cap that is not finite is refused always.
"""

from __future__ import annotations

import csv
import io
import json
import math
import re
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

from stickslip.solver.atomic import atomic_write_text
from stickslip.solver.scene import Scene, SceneError, load_scene, scene_to_dict, write_scene
from stickslip.solver.schemes import unsteppable
from stickslip.studies.attractors.certify import certify_member, failures, kick_members
from stickslip.studies.attractors.chaos import (
    Pair,
    classify_at_cap,
    statistics_verdict,
    with_lyapunov,
)
from stickslip.studies.attractors.classify import (
    CELERITY_TOL,
    SETTLED,
    SPREAD_TOL,
    group_members,
    row_cache,
    start_row,
)
from stickslip.studies.attractors.features import (
    AMPLITUDE_TOL,
    DEFAULT_TOLERANCES,
    HARMONIC_BINS,
    LEG_GROWTH,
    SHARE_TOL,
    Tolerances,
)
from stickslip.studies.attractors.report import summary_text
from stickslip.studies.attractors.starts import (
    StartDistribution,
    as_rung,
    parse_rung_key,
    rung_key,
    rung_label,
)
from stickslip.studies.attractors.statistics import (
    SETTLING,
    UNFINISHED,
    accounting,
    ladder,
    mesh_members,
)
from stickslip.studies.attractors.step_check import half_step_members
from stickslip.studies.output import output_root
from stickslip.studies.resources import (
    MAX_SECONDS,
    MAX_STEPS,
    ResourceError,
    _bytes,
    _duration,
    _free_disk,
    estimate,
)
from stickslip.studies.rundir import continue_batch
from stickslip.studies.rundir.directory import is_run_dir
from stickslip.studies.rundir.ownership import OwnershipError, claim, register_kind, user_entries
from stickslip.studies.rundir.readers import ReadError
from stickslip.studies.sweep import SweepError, load_sweep, run_sweep
from stickslip.studies.sweep.schedule import wait_quietly
from stickslip.studies.sweep.table import _read_json, live_status

KIND = "stickslip-attractors"
#: The census directory's own entries (``studies.rundir.ownership``); the starts are a sweep
#: directory of their own, ``starts/``.
ENTRIES = ("census.json", "census.toml", "base.toml", "attractors.json", "attractors.csv",
           "members.csv", "certificates.json", "cea.json", "features.json", "chaos.json",
           "starts", "kicks", "settle-rank*.log", "*.png")
#: Every completed start's features, by start and summary time (read once).
FEATURES = "features.json"
#: The chaos test of every start unsettled at the cap (``chaos.classify_at_cap``), keyed as
#: ``features.json`` (a continued start is tested again).
CHAOS = "chaos.json"
STARTS = "starts"
ROW_FIELDS = ("id", "n_inner", "start", "seed", "start_mode", "status", "class",
              "member", "name", "type", "n_components", "components", "unsettled_because",
              "rejected_because", "settle_time_s", "sim_time_s", "k",
              "direction", "regime", "celerity_m_s", "frequency_hz", "fraction_separation",
              "fraction_stick", "fraction_slip", "psi1", "psi2", "amplitude_m",
              "rms_amplitude_m", "limit_cycle", "frame_spread", "spread_trend", "dt_s", "steps",
              "wall_time_s", "message", "run_dir", "degree")
MEMBER_FIELDS = ("n_inner", "member", "class", "name", "n_components", "k",
                 "direction", "regime", "count", "starts", "settle_time_s", "settle_time_s_max",
                 "share", "share_lo", "share_hi", "celerity_m_s", "celerity_m_s_sd",
                 "frequency_hz", "frequency_hz_sd", "fraction_separation",
                 "fraction_separation_sd", "fraction_stick", "fraction_stick_sd",
                 "fraction_slip", "fraction_slip_sd", "psi1", "psi1_sd", "psi2", "psi2_sd",
                 "amplitude_m", "amplitude_m_sd", "rms_amplitude_m", "rms_amplitude_m_sd",
                 "degree")


#: The default cap T_max of settle-or-extend (s of simulated time): the slowest settlers
#: measured on the damped paper scenes (N = 528, k = 14 against the rotation) settle
#: between 2 and 4 s; the tutorial point's N = 264 starts settle by about 2 s.
DEFAULT_MAX_TIME = 4.0
#: Each leg of settle-or-extend takes an unsettled start from T to GROWTH × T.
GROWTH = LEG_GROWTH
#: What ``census.json`` must hold (key: its JSON types): the rest is read with defaults.
META_TYPES = {"definition": (dict,), "scene_file": (str,), "overrides": (list,),
              "meshes": (list,), "distribution": (dict,), "celerity_tol": (int, float),
              "spread_tol": (int, float)}


class CensusError(ValueError):
    """A census that cannot start (the message names the value and the fix)."""


@dataclass(frozen=True)
class Census:
    """What a census computes: a scene point, a ladder of rungs (N, p) in ladder order
    (``ladder_order``; an int N is the rung (N, 1)), a start distribution."""

    scene: Path
    meshes: tuple[tuple[int, int], ...]
    distribution: StartDistribution
    overrides: tuple[str, ...] = ()
    celerity_tol: float = CELERITY_TOL
    spread_tol: float = SPREAD_TOL
    max_time: float | None = None  # the cap of settle-or-extend (None: DEFAULT_MAX_TIME)
    #: the half-step test of every multi-wave member (``step_check``; a certificate option,
    #: kept in census.json, not in its definition)
    half_step: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "meshes", tuple(as_rung(r) for r in self.meshes))
        if self.max_time is not None and not math.isfinite(self.max_time):
            raise CensusError(f"--max-time {self.max_time}: give a finite time (s); every "
                              "unsettled start runs on to it")

    def cap(self, base: Scene) -> float:
        """T_max: ``max_time`` (default ``DEFAULT_MAX_TIME``), at least the first leg."""
        wanted = DEFAULT_MAX_TIME if self.max_time is None else self.max_time
        return max(float(wanted), float(base.time.end_time))

    def base_scene(self) -> Scene:
        try:
            scene = load_scene(self.scene, self.overrides)
            scene = scene.with_overrides(
                f"initial.amplitude={self.distribution.amplitude!r}",
                f"initial.n_modes={self.distribution.n_modes}")
            for rung in self.meshes:  # every start's scene must be valid before anything runs
                for point in self.distribution.points((rung,), scene.mesh.degree):
                    scene.with_overrides(*(f"{k}={json.dumps(v)}" for k, v in point.items()))
        except SceneError as err:
            raise CensusError(str(err)) from None
        return scene

    def points(self, base: Scene) -> list[dict]:
        """The starts' sweep points on every rung (``StartDistribution.points``)."""
        return self.distribution.points(self.meshes, base.mesh.degree)

    def labels(self) -> list[int | str]:
        """The rungs as ``census.json`` and ``attractors.json`` list them (``rung_label``)."""
        return [rung_label(n, p) for n, p in self.meshes]

    def definition(self, base: Scene) -> dict:
        """What must match for two runs of the census to share a directory."""
        d = self.distribution
        return {"scene": scene_to_dict(base), "n_modes": d.n_modes, "amplitude": d.amplitude}


def ladder_order(base: Scene, rungs: tuple[tuple[int, int], ...]
                 ) -> tuple[tuple[int, int], ...]:
    """The rungs (N, p) along the ladder: by dofs (``studies.resources.estimate`` of the base
    scene at N and p), fewest first, then the lower degree; rungs of one degree by N (their
    dofs grow with N). CensusError where a rung's scene is not valid."""

    if len({p for _, p in rungs}) <= 1:
        return tuple(sorted(rungs))
    dofs = {}
    for n, p in rungs:
        try:
            dofs[n, p] = estimate(base.with_overrides(f"mesh.n_inner={n}",
                                                      f"mesh.degree={p}")).dofs
        except (SceneError, ValueError) as err:  # ResourceError: more steps than counted
            raise CensusError(f"--meshes: the rung {rung_key(n, p)}: {err}") from None
    return tuple(sorted(rungs, key=lambda r: (dofs[r], r[1], r[0])))


def row_rung(row: dict) -> tuple[int, int]:
    """(N, p) of a start's row (``degree`` 1 where the row has none)."""
    return int(row["n_inner"]), int(row.get("degree") or 1)


def row_key(row: dict) -> str:
    """The rung key (``starts.rung_key``) of a start's row."""
    return rung_key(*row_rung(row))


def default_dir(scene: Scene) -> Path:
    return output_root() / "attractors" / _slug(scene.name)


def cap_problem(census: Census, out_dir: Path, ranks: int = 1) -> str | None:
    """Why the census's cap is too costly to start without ``--yes-i-know`` (the cost guard
    of the module docstring: every start run to T_max), or None."""

    base = census.base_scene()
    cap = census.cap(base)
    if cap <= base.time.end_time:  # no leg beyond the first: the sweep's own guard
        return None
    smaller = (f"give a smaller --max-time (the first leg ends at {base.time.end_time:g} "
               "s), fewer --starts or --meshes")
    fix = f"{smaller}, or pass --yes-i-know to run anyway"
    seconds = output = 0.0
    starts = 0
    try:
        for n, p in census.meshes:
            est = estimate(base.with_overrides(f"mesh.n_inner={n}", f"mesh.degree={p}",
                                               f"time.end_time={cap!r}"))
            count = len(census.distribution.points(((n, p),), base.mesh.degree))
            starts += count
            seconds += count * est.seconds
            output += count * est.output_bytes
    except ResourceError:  # more steps than a counter holds: no estimate at all
        return (f"--max-time {cap:g}: more than {MAX_STEPS:.0e} time steps (the step "
                f"counters are 64-bit): {smaller}")
    except SceneError as err:
        return f"--max-time {cap:g}: {err}"
    wall = seconds / max(1, ranks)
    if wall > MAX_SECONDS:
        return (f"--max-time {cap:g}: {starts} start(s) continued to {cap:g} s would take "
                f"about {_duration(wall)} on {ranks} rank(s) (estimate; the bound is "
                f"{_duration(MAX_SECONDS)}): {fix}")
    free = _free_disk(out_dir)
    if output > free:
        return (f"--max-time {cap:g}: {starts} start(s) continued to {cap:g} s would write "
                f"about {_bytes(output)} of samples but {_bytes(free)} is free under "
                f"{out_dir}: {fix}")
    return None


def read_meta(out_dir: Path) -> dict:
    """``out_dir/census.json``, the census's definition; CensusError (naming the file and
    the fix) where it is not one: unreadable, not UTF-8, not JSON, or of other types."""
    path = Path(out_dir) / "census.json"
    try:
        meta = json.loads(path.read_text())
    except UnicodeDecodeError:
        why = "not UTF-8 text"
    except (OSError, ValueError) as err:  # JSONDecodeError included
        why = _first_line(str(err)) or type(err).__name__
    else:
        if not isinstance(meta, dict):
            why = "not a JSON object"
        else:
            wrong = [k for k, types in META_TYPES.items() if not isinstance(meta.get(k), types)]
            if not wrong and not isinstance(meta["definition"].get("scene"), dict):
                wrong = ["definition.scene"]
            if not wrong:
                return meta
            why = "wrong or missing " + ", ".join(wrong)
    raise CensusError(f"{path} is not a census definition ({why}); run the census again "
                      f"with -o {out_dir} --force to write it again (only its starts whose "
                      "scene changed run again)")


def read_cache(path: Path, entry: type = dict) -> dict:
    """A cache file (``features.json``, ``certificates.json``: entries ``dict``;
    ``cea.json``: ``list``): its entries of type ``entry``; {} where it is missing,
    unreadable or of another JSON type (a cache is computed again, never trusted)."""
    try:
        data = json.loads(Path(path).read_text())
    except (OSError, ValueError):
        return {}
    if not isinstance(data, dict):
        return {}
    return {k: v for k, v in data.items() if isinstance(v, entry)}


def write_if_changed(path: Path, text: str, required: bool = True) -> bool:
    """Write ``text`` to ``path`` (atomically) unless it holds that text already; returns
    whether it was written. ``required`` False (a cache, or an answer only re-read): a
    directory that does not take the write (read-only, full) is left as it is."""
    try:
        if path.read_text() == text:
            return False
    except (OSError, ValueError):
        pass
    try:
        atomic_write_text(path, text)
    except OSError:
        if required:
            raise
        return False
    return True


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.\-]", "_", text) or "census"


def sweep_text(census: Census, base: Scene) -> str:
    """The generated sweep file: base.toml plus one point per start and mesh; the starts'
    samples stored, not deflated (``compress = false``): settle-or-extend rewrites each
    unsettled start's whole record at every leg, where zlib took about half of an N = 264
    leg's time."""
    lines = [f'name = "{_slug(base.name)}-census"',
             f'description = "attractor census: {census.distribution.describe()}"',
             'base = "base.toml"', 'batch = "auto"', "compress = false", ""]
    for point in census.points(base):
        lines.append("[[points]]")
        lines += [f'"{k}" = {json.dumps(v)}' for k, v in point.items()]
        lines.append("")
    return "\n".join(lines)


def prepare(census: Census, out_dir: Path, force: bool,  # noqa: ANN201 - a Claim
            check_cost: bool = True, ranks: int = 1):
    """Rank 0: claim the directory, write base.toml, census.toml and census.json.

    The directory is claimed as kind ``attractors`` (``studies.rundir.ownership``: a new or
    empty one, or a census directory to resume; a live or foreign one is refused). The claim
    (its lock) is returned and held until the census ends. ``check_cost``: the cap's cost
    guard (``cap_problem`` on ``ranks``) first, before anything is made, and before that a
    base scene that its scheme cannot step (``unsteppable``)."""

    base = census.base_scene()
    if why := unsteppable(base):
        raise CensusError(f"{census.scene}: {why}")
    definition = census.definition(base)
    if check_cost and (problem := cap_problem(census, out_dir, ranks)):
        raise CensusError(problem)
    register_kind("attractors", ENTRIES)
    try:
        owned = claim(out_dir, "attractors", reuse=True)
    except OwnershipError as err:
        raise CensusError(str(err)) from None
    try:
        meta_path = out_dir / "census.json"
        if meta_path.exists() and not force \
                and read_meta(out_dir).get("definition") != definition:
            raise CensusError(f"{out_dir} holds a census of another scene or start "
                              "distribution; use another -o, or --force to rerun its starts")
        clear_unstarted(out_dir / STARTS)
        write_scene(base, out_dir / "base.toml")
        atomic_write_text(out_dir / "census.toml", sweep_text(census, base))
        meta = {"kind": KIND, "definition": definition, "scene_file": str(census.scene),
                "overrides": list(census.overrides), "meshes": census.labels(),
                "distribution": census.distribution.to_dict(),
                "celerity_tol": census.celerity_tol, "spread_tol": census.spread_tol,
                "window_s": base.time.end_time / 3.0, "max_time_s": census.cap(base),
                "half_step": census.half_step}
        atomic_write_text(meta_path, json.dumps(meta, indent=1) + "\n")
    except BaseException:
        owned.release()
        raise
    return owned


def clear_unstarted(out_dir: Path) -> list[Path]:
    """Empty the start directories (``out_dir/runs/*``) killed before their first summary.

    A start killed (SIGKILL) while its directory was being made holds no ``summary.json``,
    only ``scene.toml`` and/or half-written temporaries (``.NAME.PID.*.tmp``); a run
    directory refuses to be reused as such. Only directories under ``runs/`` whose every
    entry is one of those are emptied; anything else is left for the sweep to report.
    """

    cleared = []
    runs = out_dir / "runs"
    for run in sorted(runs.glob("*/")) if runs.is_dir() else []:
        if is_run_dir(run):
            continue
        entries = list(run.iterdir())
        if entries and all(e.is_file() and (e.name == "scene.toml" or (
                e.name.startswith(".") and e.name.endswith(".tmp"))) for e in entries):
            for e in entries:
                e.unlink()
            cleared.append(run)
    return cleared


def claim_on_rank0(comm, take, refusals: tuple[type[Exception], ...]):  # noqa: ANN001, ANN201
    """Collective: ``take()`` (claim a directory) on rank 0 only. Returns (its claim, False)
    on rank 0 and (None, False) elsewhere; where it raised one of ``refusals``, the message
    is printed on rank 0 as one line and every rank gets (None, True)."""
    err, owned = None, None
    if comm.rank == 0:
        try:
            owned = take()
        except refusals as e:
            err = str(e)
    err = comm.bcast(err, root=0)
    if err and comm.rank == 0:
        print(f"error: {err}", file=sys.stderr, flush=True)
    return owned, bool(err)


def _certify_and_continue(out_dir: Path, comm, stream: TextIO, dt_limit: bool,  # noqa: ANN001
                          kick: bool, shared: dict) -> tuple[int, int]:
    """Certify the members; continue the starts of every member that failed a certificate
    (``settle``); certify the new end states; until no leg is due. Returns (the census's
    status so far: 0, 1 after a failed leg, 130 interrupted; the settle legs' own status)."""
    rc = settled = 0
    while rc == 0:
        if certify_now(out_dir, comm, dt_limit=dt_limit, kick=kick, timing=shared,
                       stream=stream):
            return 130, settled
        if not _legs_due(out_dir, comm):
            break
        settled = max(settled, settle(out_dir, comm, stream))
        rc = max(rc, settled)
    return rc, settled


def chaos_due(out_dir: Path) -> list[dict]:
    """Rank 0: the starts unsettled at the cap whose chaos test is not in ``chaos.json``:
    {"id", "run_dir", "key", "cost"} (cost N² × the twin's time, about the leg's)."""
    meta = read_meta(out_dir)
    cap = meta.get("max_time_s")
    window = meta.get("window_s")
    rows = start_rows(out_dir, meta["spread_tol"], tolerances(meta), window)
    tasks = {t.id: t for t in load_sweep(out_dir / "census.toml").tasks}
    due = []
    for r in rows:
        if r["class"] != "unsettled" or r.get("status") != "completed" or below_cap(r, cap) \
                or r["chaos"] is not None:
            continue
        key = _start_state(out_dir, tasks[r["id"]], window)[3]  # its key in chaos.json
        if key:
            due.append({"id": r["id"], "run_dir": r["run_dir"], "key": key,
                        "cost": float(r["n_inner"]) ** 2 * float(r.get("sim_time_s") or 0.0)})
    return due


def _chaos_tests(out_dir: Path, due: list[dict], comm=None) -> dict:  # noqa: ANN001
    """{chaos.json key: ``chaos.classify_at_cap`` of the start, its series left out}; a start
    whose test raises gets class ``unsettled`` with the error as its reason. An item with a
    ``partner`` (``twin_shares``) has stationary statistics (its ``verdict``) and takes its
    λ₁ on this rank and its partner's of ``comm`` together (``chaos.SplitTwin``); only the
    reference's rank (role 0) reports it."""
    window = float(read_meta(out_dir)["window_s"])
    found = {}
    for item in due:
        paired = "partner" in item
        try:
            if "verdict" in item:  # its statistics taken (``chaos_shared``): λ₁ only
                pair = Pair(comm, item["partner"], item["role"]) if paired else None
                verdict = with_lyapunov(item["verdict"], item["run_dir"], window,
                                        item["windows"], pair=pair)
            else:
                verdict = classify_at_cap(item["run_dir"], window)
        except (OSError, ValueError, KeyError) as err:
            verdict = _failed_test(err, item.get("verdict"))
        if not paired or item["role"] == 0:
            found[item["key"]] = verdict
    return found


def _failed_test(err: BaseException, verdict: dict | None = None) -> dict:
    """The verdict of a start whose chaos test raised: ``unsettled``, with the error."""
    return {"class": "unsettled", "why": [f"chaos test failed: {err}"],
            "stationarity": (verdict or {}).get("stationarity"), "lyapunov": None}


def twin_shares(tests: list[dict], ranks: int) -> list[list[dict]]:
    """The λ₁ tests shared over ``ranks``: each on a pair of ranks (2i, 2i + 1; the
    reference on the first, the twin on the second: ``chaos.SplitTwin``, twice as fast)
    while there are ranks for every test to have two, otherwise one rank each
    (``balanced_shares``): a census's tail has the others idle by then."""
    if not 0 < 2 * len(tests) <= ranks:
        return balanced_shares(tests, ranks)
    shares: list[list[dict]] = [[] for _ in range(ranks)]
    for i, test in enumerate(tests):
        for role in (0, 1):
            shares[2 * i + role].append(dict(test, partner=2 * i + 1 - role, role=role))
    return shares


def chaos_shared(out_dir: Path, comm, stream: TextIO | None = None) -> bool:  # noqa: ANN001
    """Collective: the chaos test (``chaos.classify_at_cap``: stationary statistics over
    the last leg's windows, then Benettin's λ₁ from a twin column) of every start unsettled
    at the cap not yet in ``chaos.json``. Rank 0 takes the statistics of each (reading its
    samples) and writes the verdicts of those that drift; the λ₁ tests of the others are
    shared over the ranks (``twin_shares``). Rank 0 tests what a rank could not and writes
    the file. Returns whether a rank was interrupted."""
    def merge(parts: list[dict]) -> None:
        merge_into_cache(out_dir / CHAOS, parts)

    def plan() -> list[list[dict]] | None:
        try:
            window = float(read_meta(out_dir)["window_s"])
            due = chaos_due(out_dir)
        except (OSError, ValueError, KeyError):  # rank 0's own pass below says why
            return None
        drifting, tests = {}, []
        for item in due:
            try:
                verdict, windows = statistics_verdict(item["run_dir"], window)
            except (OSError, ValueError, KeyError) as err:
                verdict, windows = _failed_test(err), 0
            if verdict["stationarity"] and verdict["stationarity"]["stationary"]:
                tests.append(dict(item, verdict=verdict, windows=windows))
            else:
                drifting[item["key"]] = verdict
        try:
            if drifting:
                merge([drifting])
        except (OSError, ValueError):  # left due: rank 0's own pass below tests them again
            pass
        shares = twin_shares(tests, comm.size) if tests else None
        if due and stream is not None:
            paired = any("partner" in test for share in shares or [] for test in share)
            pairs = " (reference and twin on two ranks)" if paired else ""
            what = f"{len(tests)} with stationary statistics: their λ₁{pairs}" if tests \
                else "none with stationary statistics (no λ₁ to take)"
            print(f"chaos: {len(due)} start(s) unsettled at the cap, {what}", file=stream,
                  flush=True)
        return shares

    interrupted = on_ranks(comm, plan, lambda share: _chaos_tests(out_dir, share, comm), merge)
    if comm.rank == 0 and not interrupted:
        try:
            left = chaos_due(out_dir)
            if left and stream is not None:
                print(f"chaos: {len(left)} start(s) unsettled at the cap: their statistics, "
                      "and λ₁ where they are stationary", file=stream, flush=True)
            if left:
                merge([_chaos_tests(out_dir, left)])
        except KeyboardInterrupt:
            interrupted = True
    return bool(comm.bcast(interrupted, root=0))


def run_census(census: Census, out_dir: str | Path, *, comm=None, force: bool = False,  # noqa: ANN001
               progress: str = "auto", backend: str = "cpu", certify: bool = True,
               dt_limit: bool = False, kick: bool = True, stream: TextIO | None = None,
               read_starts: Callable[..., int] | None = None, check_cost: bool = True,
               answer: dict | None = None) -> int:
    """Run (or resume) the census into ``out_dir`` and write its answer; collective.

    ``read_starts(spec, starts_dir, stream)``: the starts' first legs are not run here but
    read (``studies.attractors.bundle.import_results``: a bundle a node ran); the rest is
    the same.

    ``check_cost``: refuse starts too long or too large for the machine, as a sweep does
    (``studies.sweep.schedule.run_sweep``), and a cap too costly (``cap_problem``);
    ``--yes-i-know``: False.

    ``certify``: certify every member (``studies.attractors.certify``); ``dt_limit``: also the
    rigid waves' Δt → 0 ladder (several Newton solves on finer levels; off by default);
    ``kick``: the kick test of every member (``certify.kick_members``). ``stream``: where
    the lines go (sys.stdout as the call finds it by default).

    Every unsettled start is continued up to the census's cap (``settle``, module
    docstring); then the members are certified (``certify_now``), the starts of every
    member that failed a certificate are continued the same way, and the new end states
    certified, until none is due. ``answer``: filled on rank 0 with the answer written
    (``collect``), if any.

    Returns 0 (the answer is finished: every leg ran, no start failed), 1 (some start
    failed, counted and shown; or a leg or the answer's files failed: not finished, said
    in one line), 2 (the census cannot start), 130 (interrupted: not finished; run the same
    command again).
    """
    from mpi4py import MPI


    comm = MPI.COMM_WORLD if comm is None else comm
    stream = sys.stdout if stream is None else stream
    out_dir = Path(out_dir)
    owned, refused = claim_on_rank0(
        comm, lambda: prepare(census, out_dir, force, check_cost, comm.size),
        (CensusError, OSError))
    if refused:
        return 2
    try:
        spec = load_sweep(out_dir / "census.toml")
    except SweepError as e:
        if comm.rank == 0:
            print(f"error: {e}", file=sys.stderr, flush=True)
        return 2
    try:
        t0 = time.perf_counter()
        if read_starts is None:
            rc = run_sweep(spec, out_dir / STARTS, comm=comm, stream=stream,
                           progress=progress, batch="auto", backend=backend,
                           check_cost=check_cost)
        else:
            rc = comm.bcast(_read(read_starts, spec, out_dir, stream)
                            if comm.rank == 0 else None, root=0)
        if rc == 2 and owned is not None:
            _drop_if_unstarted(owned, out_dir)
        settled = settle(out_dir, comm, stream) if rc in (0, 1) else 0
        rc = max(rc, settled)
        shared: dict = {}
        if certify and rc == 0:
            rc, settled = _certify_and_continue(out_dir, comm, stream, dt_limit, kick, shared)
        if certify and rc == 0:
            t_chaos = time.perf_counter()
            rc = 130 if chaos_shared(out_dir, comm, stream if comm.rank == 0 else None) else 0
            shared["chaos_s"] = time.perf_counter() - t_chaos
        sweep_s = (time.perf_counter() - t0 - shared.get("certification_s", 0.0)
                   - shared.get("chaos_s", 0.0))
        if comm.rank == 0 and rc != 2:
            stopped = "interrupted" if rc == 130 else "a leg failed" if settled else None
            rc = _answer(out_dir, rc, stopped, stream, answer if answer is not None else {},
                         certify="run" if certify and rc == 0 else "cached",
                         dt_limit=dt_limit, sweep_s=sweep_s, kick=kick, shared=shared)
        wait_quietly(comm)  # the other ranks sleep while rank 0 analyses and certifies
    finally:
        if owned is not None:
            owned.release()
    return rc


def certify_now(out_dir: Path, comm, *, dt_limit: bool = False, kick: bool = True,  # noqa: ANN001
                timing: dict | None = None, stream: TextIO | None = None) -> bool:
    """Collective: the certificates (and kick tests) not yet in ``certificates.json``, on
    the ranks (``certify_shared``) or, on one rank, here (``certify_members``), so that the
    starts of the members that fail one can be continued before the answer; ``timing``
    accumulates ``certification_s`` and ``kick_s``. Returns whether it was interrupted. A
    census that cannot be read is left to ``collect`` to say why."""
    spent: dict = {}
    t0 = time.perf_counter()
    interrupted = False
    if comm.size > 1:
        interrupted = certify_shared(out_dir, comm, dt_limit=dt_limit, kick=kick, timing=spent,
                                     stream=stream)
    else:
        try:
            meta = read_meta(out_dir)
            tol = tolerances(meta)
            rows = grouped(meta, start_rows(out_dir, meta["spread_tol"], tol,
                                            meta.get("window_s")))
            todo = _uncertified(out_dir, rows, dt_limit, kick)
            _say_certifying([{"id": n, "rows": g} for n, g in todo.items()], kick, stream)
            certify_members(out_dir, rows, dt_limit=dt_limit, window=meta.get("window_s"),
                            kick=kick, tol=tol, timing=spent)
        except KeyboardInterrupt:
            interrupted = True
        except (OSError, ValueError, KeyError):
            pass
        spent["certification_s"] = time.perf_counter() - t0
    if timing is not None:
        for key, seconds in spent.items():
            timing[key] = timing.get(key, 0.0) + seconds
    return interrupted


def _legs_due(out_dir: Path, comm) -> bool:  # noqa: ANN001
    """Collective: whether a start has a leg due (``extension_legs``: after ``settle``,
    the starts of members that failed a certificate); rank 0 reads, every rank gets it."""
    due = False
    if comm.rank == 0:
        try:
            due = bool(extension_legs(out_dir))
        except (OSError, ValueError, KeyError):
            due = False
    return bool(comm.bcast(due, root=0))


def _answer(out_dir: Path, rc: int, stopped: str | None, stream: TextIO, answer: dict,
            **options) -> int:  # noqa: ANN003
    """Rank 0: ``collect`` the answer (``options``) into ``answer``, print it, and return
    the census's status: ``rc``, 130 where a signal stops the answer itself (the answer is
    then collected again from the caches, marked not finished), 1 where its files cannot
    be written (said in one line) or it is not finished or counts a failed start."""
    try:
        try:
            answer.update(collect(out_dir, stopped=stopped, **options))
        except KeyboardInterrupt:
            rc, stopped = 130, "interrupted"
            answer.update(collect(out_dir, certify="cached", stopped=stopped))
    except (OSError, CensusError) as err:
        print(f"error: the census's answer could not be written: {err}", file=sys.stderr,
              flush=True)
        return max(rc, 1)
    print(answer["text"], file=stream, flush=True)
    if rc == 0 and (answer["counts"].get("failed") or not answer["finished"]):
        rc = 1
    return rc


def _drop_if_unstarted(owned, out_dir: Path) -> None:  # noqa: ANN001 - a Claim
    """Rank 0: a census refused before any start ran (its cost, a bad start list) in a
    directory this command made leaves nothing behind: the directory holds only the census's
    own definition files, which the same command writes again."""
    import shutil


    if owned.created and set(user_entries(out_dir)) <= {"base.toml", "census.toml",
                                                        "census.json"}:
        owned.release()
        shutil.rmtree(out_dir, ignore_errors=True)


def _read(read_starts: Callable[..., int], spec, out_dir: Path, stream: TextIO) -> int:  # noqa: ANN001
    """Rank 0: ``read_starts`` into the census's start directories; 2 (said in one line)
    where they cannot be read."""
    try:
        return read_starts(spec, out_dir / STARTS, stream)
    except (ValueError, OSError) as err:
        print(f"error: {err}", file=sys.stderr, flush=True)
        return 2


# ========================================================================= settle or extend


def settle(out_dir: Path, comm, stream: TextIO | None = None) -> int:  # noqa: ANN001
    """Continue the unsettled starts of the census in ``out_dir`` in legs until each is
    settled or at the cap (module docstring); collective. Returns 0 (every leg ran), 1 (a
    leg failed, said on stderr with its start, which stays where its last whole leg ended;
    or the census could not be read) or 130 (interrupted: every start stands at its last
    whole leg). Either way the same command goes on from there. ``stream``: where the
    lines go (sys.stdout as the call finds it by default)."""
    import signal

    stream = sys.stdout if stream is None else stream

    refused: dict[str, str] = {}  # start id -> why it cannot be continued (rank 0)
    reached: dict[str, float] = {}  # start id -> the time its last leg started from
    previous = signal.signal(signal.SIGTERM, _raise_interrupt)
    try:
        while True:
            if featurise_shared(out_dir, comm):
                return 130
            shares = _plan_legs(out_dir, comm, refused, reached, stream)
            if not shares or isinstance(shares, int):
                return shares or 0
            log = out_dir / f"settle-rank{comm.rank}.log"  # the continuations' lines
            failed, interrupted = continue_legs(shares[comm.rank], log)
            wait_quietly(comm)  # a rank done first sleeps until the slowest is done
            results = comm.gather((failed, interrupted), root=0)
            stop = None
            if comm.rank == 0:
                for start, message in (kv for why, _ in results for kv in why.items()):
                    refused[start] = message
                    _say_refused(start, message)
                stop = any(flag for _, flag in results)
            if comm.bcast(stop, root=0):
                return 130
    except KeyboardInterrupt:  # between legs (a leg's own is continue_legs')
        return 130
    finally:
        signal.signal(signal.SIGTERM, previous)


def _plan_legs(out_dir: Path, comm, refused: dict[str, str], reached: dict[str, float],  # noqa: ANN001
               stream: TextIO) -> list | int | None:
    """Collective: rank 0 finds the next legs (``_next_legs``) and shares them; every rank
    gets the shares, None (no leg left, none refused), 1 (none left, but some start was
    refused, or the census could not be read) or 130 (interrupted)."""

    shares: list | int | None = None
    if comm.rank == 0:
        try:
            legs = _next_legs(out_dir, refused, reached, stream)
            shares = balanced_shares(legs, comm.size) if legs else (1 if refused else None)
        except KeyboardInterrupt:
            shares = 130
        except (OSError, ValueError, KeyError) as err:  # an unreadable census
            print(f"error: settle: {err}", file=sys.stderr, flush=True)
            shares = 1
    wait_quietly(comm)  # the others sleep while rank 0 classifies
    return comm.bcast(shares, root=0)


def _say_refused(start: str, message: str) -> None:
    print(f"error: settle: {start} not continued: {message} (it stays where its last "
          "whole leg ended; run the same command again to go on)", file=sys.stderr,
          flush=True)


def _next_legs(out_dir: Path, refused: dict[str, str], reached: dict[str, float],
               stream: TextIO) -> list[dict]:
    """Rank 0: ``extension_legs``, less the starts whose last leg did not advance them
    (refused from now on: a loop that cannot end otherwise; said on stderr)."""
    legs = extension_legs(out_dir, refused)
    for leg in [g for g in legs if reached.get(g["id"]) == g["from"]]:
        refused[leg["id"]] = f"its last leg ended at {leg['from']:g} s, not later"
        _say_refused(leg["id"], refused[leg["id"]])
    legs = [g for g in legs if g["id"] not in refused]
    reached.update({g["id"]: g["from"] for g in legs})
    if legs:
        _say_legs(legs, stream)
    return legs


def _raise_interrupt(signum, frame):  # noqa: ANN001, ANN202, ARG001
    raise KeyboardInterrupt


def extension_legs(out_dir: Path, refused: dict[str, str] | None = None) -> list[dict]:
    """Rank 0: the next leg of every start to continue: completed, below the cap, not
    ``refused``, and unsettled or on a member that failed a certificate
    (``failing_starts``): {"id", "run_dir", "from", "until", "cost"} (cost: N³ × the time
    added, the relative work of the leg: N² unknowns, N/R steps per second)."""
    meta = read_meta(out_dir)
    cap = float(meta.get("max_time_s") or 0.0)
    rows = start_rows(out_dir, meta["spread_tol"], tolerances(meta), meta.get("window_s"))
    failing = failing_starts(out_dir, meta, rows)
    legs = []
    for r in rows:
        if not below_cap(r, cap, failing=r["id"] in failing) or (refused or {}).get(r["id"]):
            continue
        t = float(r.get("sim_time_s") or 0.0)
        until = min(cap, GROWTH * t)
        legs.append({"id": r["id"], "run_dir": r["run_dir"], "from": t, "until": until,
                     "cost": float(r["n_inner"]) ** 3 * (until - t)})
    return legs


def below_cap(row: dict, cap: float | None, failing: bool = False) -> bool:
    """Whether a start's row is unsettled (or, ``failing``, on a member that failed a
    certificate) below the cap ``cap`` (s): a leg is still due (``extension_legs``), so it
    is no end state (``SETTLING``, ``answer_of``)."""
    t = float(row.get("sim_time_s") or 0.0)
    return ((failing or row.get("class") == "unsettled") and row.get("status") == "completed"
            and cap is not None and t < float(cap) * (1.0 - 1e-9))


def failing_starts(out_dir: Path, meta: dict, rows: list[dict]) -> dict[str, str]:
    """Rank 0: {start id: why} of the starts whose settled member failed a certificate
    cached in ``certificates.json`` (``certify.failures``, either Δt mode); ``rows`` are
    grouped into members on the way (as ``answer_of`` groups them). A continued start has
    a new summary and so no cached certificate: it is certified again once settled."""
    grouped(meta, rows)
    cache = read_cache(out_dir / "certificates.json")
    out: dict[str, str] = {}
    for group in settled_members(rows).values():
        why = [w for mode in (False, True)
               for w in failures(cache.get(certificate_key(group, mode)))]
        if why:
            out.update({r["id"]: "; ".join(dict.fromkeys(why)) for r in group})
    return out


def grouped(meta: dict, rows: list[dict]) -> list[dict]:
    """``rows`` grouped into members per rung (``classify.group_members``, in place)."""
    for rung in ladder_rungs(meta, rows):
        group_members([r for r in rows if row_rung(r) == rung], meta["celerity_tol"],
                      tol=tolerances(meta))
    return rows


def balanced_shares(legs: list[dict], ranks: int) -> list[list[dict]]:
    """The legs shared over ``ranks``: the costliest first, each to the least loaded rank
    (longest processing time first; within 4/3 of the best split)."""
    shares: list[list[dict]] = [[] for _ in range(ranks)]
    load = [0.0] * ranks
    for leg in sorted(legs, key=lambda g: -g["cost"]):
        i = load.index(min(load))
        shares[i].append(leg)
        load[i] += leg["cost"]
    return shares


def _say_legs(legs: list[dict], stream: TextIO) -> None:
    spans = sorted({(round(g["from"], 6), round(g["until"], 6)) for g in legs})
    print(f"settle: continuing {len(legs)} start(s) (unsettled, or on a state that failed "
          "a certificate) "
          + ", ".join(f"{a:g} -> {b:g} s" for a, b in spans), file=stream, flush=True)


def continue_legs(legs: list[dict], log: Path) -> tuple[dict[str, str], bool]:
    """Continue this rank's legs in place (``continue_batch`` per end time: one batch per
    batch of starts); ({start id: why not continued}, interrupted). A leg that raised, or
    whose run did not end ``completed`` or ``diverged`` (a run that could not write its
    files ends ``failed`` and keeps the earlier one), is not continued: its first line of
    why; a leg stopped by a signal is an interruption."""
    refused: dict[str, str] = {}
    by_until: dict[float, list[dict]] = {}
    for leg in legs:
        by_until.setdefault(leg["until"], []).append(leg)
    log.parent.mkdir(parents=True, exist_ok=True)
    with open(log, "a") as fh:
        try:
            for until, group in by_until.items():
                for g in group:
                    fh.write(f"continuing {g['id']} from t = {g['from']!r} s to {until!r} s\n")
                fh.flush()
                for g, outcome in zip(group, _continue_group(group, until, fh), strict=True):
                    status = outcome.get("status") if isinstance(outcome, dict) else None
                    if status == "interrupted":
                        return refused, True
                    if status not in ("completed", "diverged"):
                        refused[g["id"]] = outcome if isinstance(outcome, str) else \
                            _first_line(outcome.get("message")) or f"its leg ended {status}"
        except KeyboardInterrupt:
            return refused, True
    return refused, False


def _continue_group(group: list[dict], until: float, fh: TextIO) -> list[dict | str]:
    """Continue the starts of ``group`` to ``until`` as one batch; where that raises, one
    by one (which start refuses, the others go on). Per start its summary, or why it
    could not be continued (the error's first line)."""

    errors = (ReadError, ValueError, OSError, RuntimeError)
    try:
        return continue_batch([g["run_dir"] for g in group], until, stream=fh, compress=False,
                              progress=True)
    except errors:
        pass
    out: list[dict | str] = []
    for g in group:
        try:
            out += continue_batch([g["run_dir"]], until, stream=fh, compress=False,
                                  progress=True)
        except errors as err:
            out.append(_first_line(str(err)) or type(err).__name__)
    return out


def _first_line(text: str | None) -> str:
    return (text or "").strip().splitlines()[0] if (text or "").strip() else ""


# ============================================================================ the answer


def start_rows(out_dir: Path, spread_tol: float = SPREAD_TOL,
               tol: Tolerances = DEFAULT_TOLERANCES, window: float | None = None
               ) -> list[dict]:
    """One row per start of the census (every start, whatever its state), with its rung's
    ``degree`` (its point's ``mesh.degree``, else the base scene's); ``window``: the
    length W of the windows compared (``census.json``'s ``window_s``)."""

    spec = load_sweep(out_dir / "census.toml")
    base_degree = read_meta(out_dir)["definition"]["scene"].get("mesh", {}).get("degree", 1)
    cache_path = out_dir / FEATURES
    cache = read_cache(cache_path)
    verdicts = read_cache(out_dir / CHAOS)
    rows, kept = [], {}
    for task in spec.tasks:
        run_dir, summary, status, key = _start_state(out_dir, task, window)
        row = start_row(run_dir, task.params, summary, status, spread_tol, tol,
                        cached=cache.get(key), window=window)
        row["degree"] = int(task.params.get("mesh.degree", base_degree))
        row["chaos"] = verdicts.get(key) if key else None
        rows.append(row)
        if key and row.get("features"):
            kept[key] = row_cache(row)
    write_if_changed(cache_path, json.dumps(_json_safe(kept)) + "\n", required=False)
    return rows


def _start_state(out_dir: Path, task, window: float | None  # noqa: ANN001 - a sweep Task
                 ) -> tuple[Path, dict | None, str, str | None]:
    """(run directory, summary, status, key of its features in ``features.json``) of one
    start; the key (None unless completed) names the summary's write, so a continued start
    is featurised again."""

    run_dir = out_dir / STARTS / "runs" / task.id
    summary = _read_json(run_dir / "summary.json")
    status = live_status(summary) if summary else "pending"
    key = None
    if status == "completed":
        stamp = (run_dir / "summary.json").stat().st_mtime_ns
        key = f"{task.id}@{stamp}@{window}@share-drift"
    return run_dir, summary, status, key


def merge_into_cache(path: Path, parts: list[dict], required: bool = True) -> None:
    """Rank 0: the ranks' results ``parts`` (dicts by cache key) added to the JSON cache at
    ``path`` (``features.json``, ``chaos.json``), written only where it changed."""
    cache = read_cache(path)
    for part in parts:
        cache.update(part)
    write_if_changed(path, json.dumps(_json_safe(cache)) + "\n", required=required)


def featurise_shared(out_dir: Path, comm) -> bool:  # noqa: ANN001
    """Collective: featurise the completed starts not yet in ``features.json`` on every
    rank (shared as ``balanced_shares``, cost N² × the simulated time: the samples read and
    transformed) and add them to it on rank 0, whose ``start_rows`` then only reads them.
    The same ``start_row`` on the same samples: the same rows as rank 0 alone. A start a
    rank cannot featurise is left to rank 0's ``start_rows``. Returns whether a rank was
    interrupted (SIGINT/SIGTERM; on every rank: run the census again)."""
    def merge(parts: list[dict]) -> None:
        merge_into_cache(out_dir / FEATURES, parts, required=False)

    return on_ranks(comm, lambda: _unfeaturised_shares(out_dir, comm.size),
                    lambda share: _featurise(out_dir, [item["id"] for item in share]), merge)


def on_ranks(comm, plan, work, merge) -> bool:  # noqa: ANN001
    """Collective: ``plan()`` on rank 0 gives one share per rank (None: nothing to do),
    ``work(share)`` runs on every rank, ``merge(results)`` on rank 0. A waiting rank sleeps
    (``wait_quietly``); a rank whose ``work`` raises gives no result (rank 0 does that work
    itself later). Returns whether a rank was interrupted (KeyboardInterrupt: SIGINT, or
    SIGTERM where a handler raises it), on every rank once all have arrived."""

    if comm.size == 1:
        return False
    shares, interrupted = None, False
    try:
        if comm.rank == 0:
            shares = plan()
        wait_quietly(comm)
    except KeyboardInterrupt:
        interrupted = True
    shares, stop = comm.bcast((shares, interrupted) if comm.rank == 0 else None, root=0)
    if stop or not shares:
        return bool(stop)
    result = None
    try:
        result = work(shares[comm.rank])
    except KeyboardInterrupt:
        interrupted = True
    except Exception:  # noqa: BLE001 - left to rank 0 (module docstring of the callers)
        result = None
    try:
        wait_quietly(comm)
    except KeyboardInterrupt:
        interrupted = True
    gathered = comm.gather((result, interrupted), root=0)
    if comm.rank == 0:
        merge([r for r, _ in gathered if r is not None])
        interrupted = any(flag for _, flag in gathered)
    return bool(comm.bcast(interrupted, root=0))


def _unfeaturised_shares(out_dir: Path, ranks: int) -> list[list[dict]] | None:
    """Rank 0: the completed, not steady starts missing from ``features.json``, shared over
    ``ranks`` (``balanced_shares``); None if none (or the census cannot be read: rank 0's
    ``start_rows`` says why)."""

    try:
        meta = read_meta(out_dir)
        cache = read_cache(out_dir / FEATURES)
        todo = []
        for task in load_sweep(out_dir / "census.toml").tasks:
            _, summary, _, key = _start_state(out_dir, task, meta.get("window_s"))
            if key and key not in cache and (summary or {}).get("regime") not in (
                    None, "steady-sliding"):
                todo.append({"id": task.id, "cost": float(task.params["mesh.n_inner"]) ** 2
                             * float(summary.get("sim_time_s") or 0.0)})
    except (OSError, ValueError, KeyError):
        return None
    return balanced_shares(todo, ranks) if todo else None


def _featurise(out_dir: Path, ids: list[str]) -> dict:
    """{features.json key: ``row_cache``} of the starts ``ids`` (``start_row``)."""

    meta = read_meta(out_dir)
    window = meta.get("window_s")
    tasks = {t.id: t for t in load_sweep(out_dir / "census.toml").tasks}
    found = {}
    for start in ids:
        task = tasks[start]
        run_dir, summary, status, key = _start_state(out_dir, task, window)
        row = start_row(run_dir, task.params, summary, status, meta["spread_tol"],
                        tolerances(meta), window=window)
        if key and row.get("features"):
            found[key] = row_cache(row)
    return found


def collect(out_dir: str | Path, *, certify: str | bool = "cached", dt_limit: bool = False,
            sweep_s: float | None = None, kick: bool = True, shared: dict | None = None,
            stopped: str | None = None, reading: bool = False) -> dict:
    """Rank 0: featurise, classify, group, count; write attractors.{json,csv}, members.csv.

    ``certify``: ``"run"`` (certify the members whose certificate is not cached in
    ``certificates.json``), ``"cached"`` (show the cached ones only) or False.
    ``sweep_s``: the wall time of the runs of this session, for the time shares. ``kick``:
    with ``"run"``, the members' kick tests too. ``shared``: the wall times of
    ``certify_shared`` (``certification_s``, ``kick_s``), added to this call's.
    ``stopped``: why this session stopped early ("interrupted", "a leg failed"): the
    answer is not finished. ``reading``: an existing answer re-read (nothing runs): its
    timing is the session's that ran it, and its files are written only where they changed
    and the directory takes them (module docstring). CensusError: ``census.json`` is not a
    census definition."""

    out_dir = Path(out_dir)
    meta = read_meta(out_dir)
    t0 = time.perf_counter()
    rows = start_rows(out_dir, meta["spread_tol"], tolerances(meta), meta.get("window_s"))
    features_s = time.perf_counter() - t0
    mode = "run" if certify is True else certify
    answer = answer_of(meta, rows, out_dir if mode else None, compute=mode == "run",
                       dt_limit=dt_limit, kick=kick,
                       timing={"sweep_s": sweep_s, "features_s": features_s},
                       shared=shared, stopped=stopped)
    if reading:
        answer["timing"] = _stored_timing(out_dir)
        answer["text"] = summary_text(answer)
    write_outputs(out_dir, answer, required=not reading)
    return answer


def _stored_timing(out_dir: Path) -> dict:
    """The timing of the answer in ``out_dir/attractors.json`` ({} where there is none)."""
    try:
        timing = json.loads((out_dir / "attractors.json").read_text()).get("timing")
    except (OSError, ValueError, AttributeError):
        return {}
    return timing if isinstance(timing, dict) else {}


def tolerances(meta: dict) -> Tolerances:
    """The grouping tolerances of a census definition (``census.json``)."""
    return Tolerances(celerity=meta.get("celerity_tol", CELERITY_TOL))


def answer_of(meta: dict, rows: list[dict], certify_in: Path | None = None, *,
              compute: bool = True, dt_limit: bool = False, timing: dict | None = None,
              kick: bool = False, shared: dict | None = None,
              stopped: str | None = None) -> dict:
    """The census's answer from its definition (``census.json``) and one row per start
    (``classify.start_row`` or ``classify.end_state_row``): members per mesh, structured
    starts apart, the ladder, the counts, and (with ``certify_in``, the census directory)
    the certificates (``compute``: those not cached yet are computed; ``kick``: with their
    kick tests, ``certify_members``). A member that fails a certificate it got
    (``certify.failures``: unstable in the direct solver, not returned after its kick) is
    no attractor: its rows take ``rejected_because`` (the reasons) and the class
    ``transient`` at the cap, ``SETTLING`` below it (``settle`` continues them). A start
    unsettled below the cap (``below_cap``) is ``SETTLING``, no end state; ``finished``:
    none is, no start is left to run, and ``stopped`` (why the session stopped early) is
    None (module docstring)."""
    cap = meta.get("max_time_s")
    for r in rows:
        if below_cap(r, cap):
            r["class"] = SETTLING
        elif r["class"] == "unsettled" and (r.get("chaos") or {}).get("class") == "chaotic":
            r["class"] = "chaotic"
    meshes = ladder_rungs(meta, rows)
    for rung in meshes:
        group_members([r for r in rows if row_rung(r) == rung], meta["celerity_tol"],
                      tol=tolerances(meta))
    timing = dict(timing or {})
    certificates: dict = {}
    if certify_in:
        t0 = time.perf_counter()
        certificates = certify_members(certify_in, rows, compute=compute, dt_limit=dt_limit,
                                        window=meta.get("window_s"), kick=kick,
                                        tol=tolerances(meta), timing=timing)
        timing["certification_s"] = time.perf_counter() - t0
        for key, seconds in (shared or {}).items():  # certify_shared's, before
            timing[key] = timing.get(key, 0.0) + seconds
        for key, cert in certificates.items():
            why = failures(cert)
            if not why:
                continue
            n, member = key.split(":", 1)
            for r in rows:
                if row_key(r) == n and r["member"] == member:
                    r["rejected_because"] = "; ".join(why)
                    r["class"] = SETTLING if below_cap(r, cap, failing=True) else "transient"
    per_mesh, structured = {}, {}  # by rung label, in ladder order
    for rung in meshes:
        mine = [r for r in rows if row_rung(r) == rung]
        per_mesh[rung_label(*rung)] = mesh_members([r for r in mine if r["start"] == "random"])
        structured[rung_label(*rung)] = [r for r in mine if r["start"] == "mode"]
    lad = ladder(per_mesh)
    counts: dict[str, int] = {}
    for r in rows:
        counts[r["class"]] = counts.get(r["class"], 0) + 1
    left = {k: v for k, v in counts.items() if k in UNFINISHED}
    answer = {"kind": KIND, "finished": not left and not stopped, "stopped": stopped,
              "max_time_s": cap,
              **{k: meta[k] for k in ("scene_file", "overrides", "meshes", "distribution",
                                      "celerity_tol", "spread_tol")},
              "tolerances": _tolerance_facts(tolerances(meta)),
              "scene": meta["definition"]["scene"], "counts": counts,
              "members": {str(n): ms for n, ms in per_mesh.items()},
              "structured": {str(n): [_brief(r) for r in rs] for n, rs in structured.items()},
              "accounting": {str(n): accounting(ms) for n, ms in per_mesh.items()},
              "ladder": lad, "certificates": certificates, "timing": timing, "starts": rows}

    answer["text"] = summary_text(answer)
    return answer


def ladder_rungs(meta: dict, rows: list[dict]) -> list[tuple[int, int]]:
    """The rungs (N, p) of ``rows`` in ladder order: as ``census.json`` lists them
    (``ladder_order``), then any other by (N, p)."""
    found = {row_rung(r) for r in rows}
    listed = []
    for label in meta.get("meshes") or []:
        try:
            listed.append(parse_rung_key(label))
        except ValueError:  # an edited census.json: its rows still have their rungs
            continue
    ordered = [r for r in dict.fromkeys(listed) if r in found]
    return ordered + sorted(found - set(ordered))


def _tolerance_facts(tol: Tolerances) -> dict:
    return {"share_listed": SHARE_TOL, "celerity_rel": tol.celerity,
            "share_rel": tol.share_rel, "share_abs": tol.share_abs,
            "fraction_abs": tol.fraction, "amplitude_rel_between_windows": AMPLITUDE_TOL,
            "harmonic_bins": HARMONIC_BINS}


def _brief(row: dict) -> dict:
    return {k: row[k] for k in ("start_mode", "class", "member", "name", "k", "direction",
                                "regime", "celerity_m_s", "frequency_hz", "psi1", "psi2",
                                "rms_amplitude_m", "frame_spread")}


def certify_members(out_dir: Path, rows: list[dict], *, compute: bool = True,
                    dt_limit: bool = False, window: float | None = None, kick: bool = False,
                    tol: Tolerances = DEFAULT_TOLERANCES, timing: dict | None = None,
                    write: bool = True) -> dict:
    """Per rung and settled member (``"N:member"``, N the rung key ``"132"`` or
    ``"132p2"``): its certificate
    (``studies.attractors.certify.certify_member``), cached in ``certificates.json`` by its
    first run and that run's summary time; with ``compute`` False only cached ones. The end
    state is read over the last ``window`` seconds (the census's W). ``kick`` (with
    ``compute`` and ``window``): the kick tests of the members whose certificate has none,
    all in one call (``certify.kick_members``: one batch per mesh and step), their wall
    time in ``timing["kick_s"]``; with them, where census.json asks (``--half-step``), the
    half-step test of every multi-wave member (``step_check.half_step_members``). ``write``:
    False leaves ``certificates.json`` as it was (``certify_shared``: rank 0 writes what the
    ranks computed)."""

    cache_path = out_dir / "certificates.json"
    cache = read_cache(cache_path)
    out: dict = {}
    members = settled_members(rows)
    keys: dict[str, str] = {}  # "N:member" -> its cache key (N: the rung key)
    named = {f"{n}:{member}": (n, member) for n, member in members}
    for (n, member), group in sorted(members.items(), key=lambda kv: (kv[0][0], kv[0][1])):
        key = certificate_key(group, dt_limit)
        if key not in cache:
            if not compute:
                continue
            cache[key] = certify_member(group, dt_limit=dt_limit, window=window)
            if write:
                write_if_changed(cache_path, _cache_text(cache), required=False)
        out[f"{n}:{member}"] = cache[key]
        keys[f"{n}:{member}"] = key
    unkicked = {name: members[tuple_key] for name, tuple_key in named.items()
                if name in out and not isinstance(out[name].get("kick"), dict)}
    if kick and compute and window and unkicked:
        t0 = time.perf_counter()
        kicks = kick_members(out_dir, unkicked, float(window), tol)
        if timing is not None:
            timing["kick_s"] = time.perf_counter() - t0
        for name, result in kicks.items():
            cache[keys[name]] = out[name] = {**out[name], "kick": result}
        if write:
            write_if_changed(cache_path, _cache_text(cache), required=False)
    unchecked = {name: members[tuple_key] for name, tuple_key in named.items()
                 if name in out and members[tuple_key][0]["class"] == "multi-wave"
                 and not isinstance(out[name].get("half_step"), dict)}
    if kick and compute and window and unchecked and read_meta(out_dir).get("half_step"):
        for name, result in half_step_members(unchecked, float(window), tol).items():
            cache[keys[name]] = out[name] = {**out[name], "half_step": result}
        if write:
            write_if_changed(cache_path, _cache_text(cache), required=False)
    return out


def settled_members(rows: list[dict]) -> dict[tuple, list[dict]]:
    """{(rung key, member): its rows, in row order} of the settled members
    (``SETTLED``)."""
    members: dict[tuple, list[dict]] = {}
    for r in rows:
        if r["class"] in SETTLED and r["member"]:
            members.setdefault((row_key(r), r["member"]), []).append(r)
    return members


def certificate_key(group: list[dict], dt_limit: bool) -> str:
    """A member's key in ``certificates.json``: its first start, that start's summary
    write, the Δt mode and the number of its starts."""
    first = group[0]
    stamp = (Path(first["run_dir"]) / "summary.json").stat().st_mtime
    return f"{first['id']}@{stamp}@{'dt-limit' if dt_limit else 'run-dt'}@{len(group)}"


def certify_shared(out_dir: Path, comm, *, dt_limit: bool = False,  # noqa: ANN001
                   kick: bool = True, timing: dict | None = None,
                   stream: TextIO | None = None) -> bool:
    """Collective: the members' certificates (and kick tests) not yet in
    ``certificates.json``, ``certify_members`` on the ranks, a mesh per rank
    (``balanced_shares``, cost N³ × its starts: one batch of kicks per mesh stays whole),
    written into it by rank 0; rank 0's ``collect`` then finds them cached. The same
    functions on the same runs: the certificates of rank 0 alone. ``timing`` gets the wall
    time (``certification_s``) and the slowest rank's kicks (``kick_s``). Returns whether
    a rank was interrupted (run the census again)."""
    t0 = time.perf_counter()
    jobs: dict = {}

    def plan() -> list[list[dict]] | None:
        found = _certificate_jobs(out_dir, comm.size, dt_limit, kick)
        if found is None:
            return None
        window, tol, shares = found
        _say_certifying([job for share in shares for job in share], kick, stream)
        return [[{"window": window, "tol": tol, **job} for job in share] for share in shares]

    def work(share: list[dict]) -> tuple[dict, float]:
        mine = [r for job in share for r in job["rows"]]
        if not mine:
            return {}, 0.0
        spent: dict = {}
        certs = certify_members(out_dir, mine, dt_limit=dt_limit, window=share[0]["window"],
                                kick=kick, tol=share[0]["tol"], timing=spent, write=False)
        groups = settled_members(mine)
        return ({certificate_key(groups[(n, m)], dt_limit): certs[f"{n}:{m}"]
                 for n, m in groups if f"{n}:{m}" in certs}, spent.get("kick_s", 0.0))

    def merge(parts: list[tuple[dict, float]]) -> None:
        path = out_dir / "certificates.json"
        cache = read_cache(path)
        for found, _ in parts:
            cache.update(found)
        write_if_changed(path, _cache_text(cache), required=False)
        jobs["kick_s"] = max((k for _, k in parts), default=0.0)

    interrupted = on_ranks(comm, plan, work, merge)
    if timing is not None and comm.rank == 0 and "kick_s" in jobs:
        timing.update(certification_s=time.perf_counter() - t0, kick_s=jobs["kick_s"])
    return interrupted


def _say_certifying(jobs: list[dict], kick: bool, stream: TextIO | None) -> None:
    """Rank 0: one progress line before the certificates of ``jobs`` (per mesh, the rows of
    the members whose certificate is not cached) are computed; none if there are none."""
    if stream is None or not jobs:
        return
    members = sum(len({r["member"] for r in job["rows"]}) for job in jobs)
    meshes = ", ".join(f"N = {job['id']}" for job in jobs)
    print(f"certify: {members} member(s) ({meshes}): reproduced, persistent, the direct "
          f"solver for a rigid wave{', a kick' if kick else ''}", file=stream, flush=True)


def _certificate_jobs(out_dir: Path, ranks: int, dt_limit: bool, kick: bool
                      ) -> tuple[float | None, Tolerances, list[list[dict]]] | None:
    """Rank 0: (W, tolerances, per rank the meshes {"id": N, "cost", "rows": the rows of
    its members whose certificate or kick is not cached}) for ``certify_shared``; None
    if nothing is missing (or the census cannot be read: ``collect`` says why)."""
    try:
        meta = read_meta(out_dir)
        tol = tolerances(meta)
        rows = start_rows(out_dir, meta["spread_tol"], tol, meta.get("window_s"))
    except (OSError, ValueError, KeyError):
        return None
    grouped(meta, rows)  # as answer_of groups them
    todo = _uncertified(out_dir, rows, dt_limit, kick)
    if not todo:
        return None
    jobs = [{"id": n, "cost": float(parse_rung_key(n)[0]) ** 3 * len(g), "rows": g}
            for n, g in todo.items()]
    return meta.get("window_s"), tol, balanced_shares(jobs, ranks)


def _uncertified(out_dir: Path, rows: list[dict], dt_limit: bool,
                 kick: bool) -> dict[str, list[dict]]:
    """Rank 0: per mesh, the rows (grouped into members) of the members whose certificate,
    or with ``kick`` whose kick test, is not in ``certificates.json``."""
    cache = read_cache(out_dir / "certificates.json")
    todo: dict[str, list[dict]] = {}
    for (n, _), group in settled_members(rows).items():
        entry = cache.get(certificate_key(group, dt_limit))
        if entry is None or (kick and not isinstance(entry.get("kick"), dict)):
            todo.setdefault(n, []).extend(group)
    return todo


def _cell(v: object) -> object:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return ""
    return v


def _csv(fields: tuple[str, ...], rows: list[dict]) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(fields), lineterminator="\n", extrasaction="ignore")
    w.writeheader()
    for r in rows:
        w.writerow({k: _cell(r.get(k)) for k in fields})
    return buf.getvalue()


def _json_safe(value):  # noqa: ANN001, ANN202
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {str(k): _json_safe(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_json_safe(v) for v in value]
    return value


def _cache_text(cache: dict) -> str:
    return json.dumps(_json_safe(cache), indent=1, default=str)


def answer_json(answer: dict) -> str:
    """The answer as ``attractors.json`` holds it (non-finite numbers as null)."""
    return json.dumps(_json_safe(answer), indent=1, default=str) + "\n"


def write_outputs(out_dir: Path, answer: dict, required: bool = True) -> None:
    """attractors.json, attractors.csv and members.csv (atomic writes, each only where its
    text changed); ``required`` False (an answer re-read): a directory that does not take
    them keeps the files it has (``write_if_changed``)."""
    members = [{"n_inner": parse_rung_key(n)[0], "degree": parse_rung_key(n)[1], **m}
               for n, ms in answer["members"].items() for m in ms]
    for name, text in (("attractors.json", answer_json(answer)),
                       ("attractors.csv", _csv(ROW_FIELDS, answer["starts"])),
                       ("members.csv", _csv(MEMBER_FIELDS, members))):
        write_if_changed(out_dir / name, text, required)
