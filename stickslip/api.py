"""The functions behind ``import stickslip``: thin wrappers over ``solver``, ``studies`` and
``postprocess`` that take a scene (file, shipped name or ``Scene``) and return plain data.

The implementations are imported at the top; none of them loads the FE stack when imported
(dolfinx, PETSc and MPI load when a function that needs them runs; the two that reach
dolfinx's own modules import them in the function), so ``load_scene`` and ``reduced_waves``
work where FEniCSx is not installed. Under ``mpirun`` the FE functions are collective over
``MPI.COMM_WORLD`` (as the CLI is); files are written on rank 0 and the returned summaries
are those of rank 0.
"""

from __future__ import annotations

import contextlib
import io
import json
import re
import sys
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from types import SimpleNamespace
from typing import TYPE_CHECKING, Any

from stickslip.postprocess.analysis import analyse_run
from stickslip.postprocess.analysis import load_run as _load_run
from stickslip.postprocess.plotting import plot_run as _plot_run
from stickslip.semianalytic.coefficients import coefficients, gamma_from_physical
from stickslip.semianalytic.waves import find_waves
from stickslip.solver.contact import STATUS_NAMES
from stickslip.solver.scene import Scene, require_plane_strain
from stickslip.solver.scene import load_scene as _load_scene
from stickslip.studies.attractors.along import plot_along, run_along
from stickslip.studies.attractors.census import run_census
from stickslip.studies.attractors.request import (
    CensusRequest,
    along_values,
    build_census,
    show_answer,
)
from stickslip.studies.flutter_fe import build_operators, complex_eigenvalue_analysis
from stickslip.studies.flutter_fe.cea import cea_problem
from stickslip.studies.output import output_root
from stickslip.studies.rpo.birth import along as _along
from stickslip.studies.rpo.birth import scan_line as _scan_line
from stickslip.studies.rundir import EXIT_CODES, run_scene
from stickslip.studies.rundir import continue_run as _continue_run
from stickslip.studies.sweep import load_sweep, read_table, run_sweep
from stickslip.studies.sweep import plot_sweep as _plot_sweep
from stickslip.studies.sweep.batch import parse_batch
from stickslip.studies.travel import command
from stickslip.studies.travel.continuation import run_continuation
from stickslip.studies.travel.output import prepare_dir, write_wave

if TYPE_CHECKING:
    from stickslip.postprocess.analysis import RunData, WaveSummary
    from stickslip.studies.flutter_fe.cea import CEAResult

__all__ = ["analyse", "attractors", "cea", "cea_friction_sweep", "continue_run", "load_run",
           "load_scene", "plot_run", "plot_sweep", "reduced_waves", "rpo_along", "run", "sweep",
           "travel", "travel_branch"]

Overrides = Mapping[str, Any] | Sequence[str] | None


def __getattr__(name: str) -> Any:
    """The constants, from the one place that defines each (a fresh copy at each access):

    * ``STATUS_CODES``: ``{code: name}`` of the contact status in ``samples.npz["status"]``
      and every other status array (``solver.contact``: 0 separation, 1 stick, 2 slip);
    * ``EXIT_CODES``: the exit status of ``stickslip run`` by the ``status`` of
      ``summary.json`` (``studies.rundir``).
    """
    if name == "STATUS_CODES":
        return dict(enumerate(STATUS_NAMES))
    if name == "EXIT_CODES":
        return dict(EXIT_CODES)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _override_strings(overrides: Overrides) -> list[str]:
    """``{"loading.omega": 40}`` or ``["loading.omega=40"]`` -> ``["loading.omega=40"]``."""
    if not overrides:
        return []
    if isinstance(overrides, str):
        return [overrides]
    if isinstance(overrides, Mapping):
        # JSON renders numbers, strings, booleans and lists as valid TOML values.
        return [f"{key}={json.dumps(value)}" for key, value in overrides.items()]
    return [str(text) for text in overrides]


#: The command line's words in the messages of the shared code, and the keyword arguments
#: that say the same here (``-o`` is the function's output argument, named per call).
_KEYWORDS = (("--force", "force=True"), ("--yes-i-know", "check_resources=False"),
             ("--until", "until="))


@contextlib.contextmanager
def _keyword_errors(out: str) -> Iterator[None]:
    """Errors raised inside name this module's keyword arguments, not the command line's
    flags (``--force`` -> ``force=True``, ``-o`` -> ``out``): the message is the one the
    command prints, in the caller's words."""
    try:
        yield
    except (ValueError, OSError) as err:
        if len(err.args) == 1 and isinstance(err.args[0], str):
            text = err.args[0]
            for flag, word in _KEYWORDS:
                text = text.replace(flag, word)
            err.args = (re.sub(r"(?<![\w-])-o(?![\w-])", out, text),)
        raise


def _refused_as_error(command: Any, what: str) -> int:
    """``command()``'s exit status; its refusal (2: one ``error:`` line on stderr, as the
    command line prints it, nothing run) raised as ``ValueError`` naming the keyword
    arguments. The lines still reach stderr."""
    errors = io.StringIO()
    with contextlib.redirect_stderr(errors):
        rc = command()
    sys.stderr.write(errors.getvalue())
    if rc == 2:
        why = errors.getvalue().strip().splitlines() or ["see the error above"]
        with _keyword_errors("out_dir"):
            raise ValueError(f"{what} could not start: {why[-1].removeprefix('error: ')}")
    return rc


def load_scene(scene: str | Path | Scene, overrides: Overrides = None) -> Scene:
    """A validated scene with overrides applied.

    Args:
        scene: a scene TOML file, the name of a shipped scene (``"figure3_n132"``, from
            ``scenes/``) or a ``Scene``.
        overrides: ``{"dotted.key": value}`` or ``["dotted.key=value", ...]``, the keys of
            the scene reference (``loading.omega``, ``mesh.n_inner``, ...).

    Returns:
        The frozen ``solver.scene.Scene`` (SI units). A bad key or value raises
        ``SceneError`` whose message names the key, the value and the allowed range.

    Example:
        >>> import stickslip
        >>> s = stickslip.load_scene("figure3_n132", {"loading.omega": 40.0})
        >>> s.loading.omega, s.mesh.n_inner
        (40.0, 132)
    """
    texts = _override_strings(overrides)
    if isinstance(scene, Scene):
        return scene.with_overrides(*texts) if texts else scene
    return _load_scene(scene, texts)


def run(scene: str | Path | Scene, run_dir: str | Path | None = None, *,
        overrides: Overrides = None, force: bool = False, plot: bool = False,
        quiet: bool = False, check_resources: bool = True) -> dict:
    """Run one transient (``stickslip run``) into a run directory.

    Args:
        scene: a scene file, shipped scene name or ``Scene`` (see ``load_scene``).
        run_dir: the run directory (default ``$STICKSLIP_OUTPUT/<scene name>``, else
            ``runs/<scene name>``).
        overrides: scene overrides, as for ``load_scene``.
        force: replace an earlier run directory (atomically; kept if the new run fails).
        plot: also draw the run's PNG figures into the directory.
        quiet: do not print the estimate, progress and summary lines.
        check_resources: refuse a scene that needs more memory or disk than the machine has,
            or whose samples cannot resolve its expected wave (``ValueError``, as the
            command's ``--yes-i-know``).

    Returns:
        The run's summary, the contents of ``summary.json``, with ``status`` (completed,
        diverged, stopped, interrupted, failed), ``regime``, ``mode``, ``celerity_m_s``,
        ``frequency_hz``, ``fractions``, ... (reference: "Output files").
        ``EXIT_CODES[status]`` is the exit status the command would give.

    Example:
        >>> summary = stickslip.run("smoke", "/tmp/smoke", force=True, quiet=True)
        >>> summary["status"], summary["contact_nodes"]
        ('completed', 36)
    """
    sc = load_scene(scene, overrides)
    path = Path(run_dir) if run_dir is not None else output_root() / sc.name
    with _keyword_errors("run_dir"):
        return run_scene(sc, path, force=force, check_resources=check_resources,
                         check_sampling=check_resources, plot=plot,
                         stream=io.StringIO() if quiet else sys.stdout)


def continue_run(run_dir: str | Path, until: float, out_dir: str | Path | None = None, *,
                 force: bool = False, quiet: bool = False,
                 check_resources: bool = True) -> dict:
    """Continue a run from its checkpoint to ``until`` seconds (``stickslip continue``).

    Args:
        run_dir: a run directory with a ``checkpoint.npz`` (every run that ended at a whole
            time level writes one: completed, stopped, interrupted; a batch member).
        until: the new end time (s), beyond the run's current time.
        out_dir: where the continued run goes; None extends ``run_dir`` in place,
            atomically (kept as it was if the continuation fails or is interrupted).
        force: replace an earlier run directory at ``out_dir``.
        quiet: do not print the estimate, progress and summary lines.
        check_resources: refuse a continuation beyond the machine's memory or disk.

    Returns:
        The continued run's summary: that of one run straight to ``until``, bit for bit,
        but for the wall-clock keys (``studies.rundir.continuation.WALL_CLOCK_KEYS``).

    Raises:
        ValueError: the run cannot be continued (no checkpoint, ``until`` not later, another
            number of ranks, ...), with the fix in one line.
        FileExistsError: ``out_dir`` is not free (``force`` replaces a run there), or the
            run is in use by a running command.

    Example:
        >>> s = stickslip.run("smoke", "/tmp/smoke", force=True, quiet=True)
        >>> stickslip.continue_run("/tmp/smoke", 0.03, quiet=True)["sim_time_s"] >= 0.03
        True
    """
    with _keyword_errors("out_dir"):
        return _continue_run(run_dir, until, out_dir, force=force,
                             stream=io.StringIO() if quiet else sys.stdout,
                             check_resources=check_resources)


def load_run(run_dir: str | Path) -> RunData:
    """A run directory's ``scene.toml`` (dict), ``summary.json`` (dict) and ``samples.npz``
    (dict of arrays), as ``postprocess.analysis.RunData``.

    Example:
        >>> data = stickslip.load_run("/tmp/smoke")
        >>> data.samples["u_r"].shape == (data.samples["t"].size, data.samples["theta"].size)
        True
    """
    return _load_run(run_dir)


def analyse(run_dir: str | Path, window: float | None = None) -> WaveSummary:
    """Measure the wave of a run directory over its last ``window`` seconds.

    Args:
        run_dir: a run directory written by ``run`` (or ``stickslip run``).
        window: seconds at the end of the record (default: the run's own analysis window,
            the last third of the record).

    Returns:
        ``postprocess.analysis.WaveSummary``: ``regime``, ``mode`` k, ``celerity_m_s``
        (signed, + = the rotation's sense), ``frequency_hz`` = abs(c) k / (2 pi R),
        ``fractions`` of separation / stick / slip, ``psi1``, ``psi2``, ``limit_cycle``.

    Example:
        >>> w = stickslip.analyse("/tmp/smoke")
        >>> w.mode, w.direction
        (4, 'opposite')
    """
    return analyse_run(run_dir, window)


def plot_run(run_dir: str | Path) -> list[Path]:
    """Draw a run directory's figures (space-time map, zones, profile, phase diagram,
    energies); returns the PNG paths."""
    return _plot_run(Path(run_dir))


def sweep(spec: str | Path, out_dir: str | Path | None = None, *, batch: str | None = None,
          plot: bool = False, quiet: bool = False, check_resources: bool = True) -> dict:
    """Run a parameter study (``stickslip sweep``): every scene of a sweep file, resumable.

    Args:
        spec: a sweep TOML file (``sweeps/``).
        out_dir: the sweep directory (default: the file's ``output``, else
            ``$STICKSLIP_OUTPUT/sweeps/<name>``). Running again skips finished scenes.
        batch: ``"off"``, ``"auto"`` or a batch size (scenes that share mesh, material,
            dt and scheme advance together); default: the sweep file's.
        plot: also draw the regime map (``regime_map.png``).
        quiet: do not print the progress lines.
        check_resources: refuse a sweep too large or too long for the machine (as the
            command without ``--yes-i-know``), with ``ValueError``.

    Returns:
        The sweep table, the contents of ``sweep.json``, with its meta data and ``rows``,
        one per scene with the scene's parameters, ``status``, ``regime``, ``mode``,
        ``celerity_m_s``, ...

    Example:
        >>> table = stickslip.sweep("sweeps/smoke4.toml", "/tmp/smoke4", quiet=True)
        >>> sorted({row["status"] for row in table["rows"]})
        ['completed']
    """
    with _keyword_errors("out_dir"):
        s = load_sweep(spec, large=not check_resources)
    path = Path(out_dir) if out_dir is not None else (
        s.output if s.output is not None else output_root() / "sweeps" / s.name)
    _refused_as_error(lambda: run_sweep(
        s, path, batch=parse_batch(batch if batch is not None else s.batch), progress="lines",
        stream=io.StringIO() if quiet else sys.stdout, check_cost=check_resources),
        f"the sweep into {path}")
    if plot:
        _plot_sweep(path)
    return read_table(path)


def attractors(scene: str | Path, out_dir: str | Path | None = None, *, starts: int = 16,
               meshes: Sequence[int | str] | None = None, structured: Sequence[int] = (),
               end_time: float | None = None, max_time: float | None = None,
               overrides: Overrides = None, along: str | None = None, certify: bool = True,
               kick: bool = True, cea: bool = False, cea_fmax_hz: float = 10_000.0,
               plot: bool = False, force: bool = False, quiet: bool = False,
               check_resources: bool = True, **options: Any) -> dict:
    """The attractors of a scene point (``stickslip attractors``): ``starts`` random starts
    (and the mode-k bumps of ``structured``) on each mesh of ``meshes``, classified and grouped
    into members with their basin shares (95 % Wilson intervals) and values. Resumable: the
    same call again runs only the starts not finished.

    Every keyword is the command's option of the same name, checked by the same code
    (``studies.attractors.request``): ``max_time`` (the cap of the settle legs, s),
    ``along`` (``"KEY=A:B:M"``: a census at each value; returns ``along.json``), ``certify``
    and ``kick`` (the certificates and the kick test), ``cea`` and ``cea_fmax_hz`` (print the
    CEA's unstable modes per mesh), ``plot``; ``options`` takes ``seed``, ``n_modes``,
    ``amplitude``, ``celerity_tol``, ``spread_tol``, ``backend``, ``dt_limit``,
    ``half_step``.
    ``check_resources=False`` is ``--yes-i-know``; ``quiet`` prints nothing. The folder
    defaults to ``$STICKSLIP_OUTPUT/attractors/<scene name>`` (else
    ``runs/attractors/<scene name>``).

    Returns:
        The census's answer, the contents of ``attractors.json``: ``finished``, ``starts``
        (one row per start with its class and member), ``members`` per mesh, ``ladder``,
        ``text`` (the printed summary).

    Raises:
        ValueError: the census could not start, with the command's reason in these words.
        RuntimeError: it stopped before its answer (a signal, a failed leg): call again.

    Example:
        >>> answer = stickslip.attractors("smoke", "/tmp/census", starts=2, quiet=True)
        >>> len(answer["starts"]), answer["meshes"]
        (2, [36])
    """
    run = {key: options.pop(key) for key in ("backend", "dt_limit") if key in options}
    request = CensusRequest(
        scene=str(scene), starts=starts, end_time=end_time, max_time=max_time,
        meshes=",".join(str(n) for n in meshes) if meshes else None,  # 132 or "132p2"
        structured=",".join(str(int(k)) for k in structured) or None,
        overrides=tuple(_override_strings(overrides)),
        output=None if out_dir is None else str(out_dir), check_cost=check_resources,
        backend=run.get("backend", "cpu"), **options)
    printed = io.StringIO() if quiet else sys.stdout
    with _keyword_errors("out_dir"), contextlib.redirect_stdout(printed):
        census, path = build_census(request)
        rc = _refused_as_error(lambda: _census_run(
            census, path, along, dict(run, force=force, certify=certify, kick=kick,
                                      check_cost=check_resources), cea_fmax_hz if cea else None,
            plot), f"the census in {path}")
    if rc not in (0, 1):
        raise RuntimeError(f"the census in {path} stopped before its answer (exit {rc}): "
                           "call again with the same arguments to resume it")
    return json.loads((path / ("along.json" if along else "attractors.json")).read_text())


def _census_run(census: Any, path: Path, along: str | None, run: dict,
                cea_fmax_hz: float | None, plot: bool) -> int:
    """Run the census (or the censuses along a key) as the command does; print the CEA's
    lines and draw the figures where asked. The exit status the command would give."""
    if along:
        key, values = along_values(census, along)
        rc = run_along(census, key, values, path, progress="lines", stream=sys.stdout, **run)
        if plot and rc in (0, 1):
            print(f"figure: {plot_along(path)}")
        return rc
    answer: dict = {}
    rc = run_census(census, path, progress="lines", stream=sys.stdout, answer=answer, **run)
    if answer:
        rc = max(rc, show_answer(path, answer, cea_fmax_hz=cea_fmax_hz, plot=plot))
    return rc


def plot_sweep(sweep_dir: str | Path) -> list[Path]:
    """Draw a sweep directory's regime map with the reduced model's existence boundaries."""
    return _plot_sweep(sweep_dir)


def cea(scene: str | Path | Scene, *, overrides: Overrides = None, f: float | None = None,
        fmax_hz: float = 10_000.0, mass: str = "lumped", friction: str | None = None
        ) -> CEAResult:
    """Complex eigenvalue analysis of FE steady sliding (``stickslip flutter-fe``).

    Solves (K + K_f) phi = omega^2 M phi on the free dofs (contact nodes sliding forward,
    tangential force = f x normal reaction), every eigenvalue up to ``fmax_hz``.

    Args:
        scene: scene file, shipped name or ``Scene``; only mesh, material and ``f`` matter
            (and with ``mesh.dim`` = 3 the finite tube's keys, as ``stickslip flutter-fe``).
        overrides: scene overrides, as for ``load_scene``.
        f: the friction coefficient (default: the scene's ``loading.f``).
        fmax_hz: upper end of the frequency band [Hz].
        mass: ``"lumped"`` (the explicit solver's) or ``"consistent"``.
        friction: ``"nodal"`` or ``"1-2-1"`` (filtered reactions); default: the scene's
            ``friction.filter``, the transient's law (as ``stickslip flutter-fe``).

    Returns:
        ``studies.flutter_fe.CEAResult``: ``modes`` (frequency_hz, growth_rate per s, k,
        direction), ``unstable()`` sorted by growth rate, ``to_dict()``.

    Example:
        >>> res = stickslip.cea("smoke", fmax_hz=3000.0)
        >>> top = res.unstable()[0]
        >>> top.growth_rate > 0
        True
    """
    return cea_friction_sweep(scene, [f], overrides=overrides, fmax_hz=fmax_hz, mass=mass,
                              friction=friction)[0]


def cea_friction_sweep(scene: str | Path | Scene, fs: Sequence[float | None], *,
                       overrides: Overrides = None, fmax_hz: float = 10_000.0,
                       mass: str = "lumped", friction: str | None = None
                       ) -> list[CEAResult]:
    """The CEA at each friction coefficient of ``fs`` (operators assembled once): the
    growth rate of each branch against f, the data of a CEA diagram (``--f-sweep``).

    Example:
        >>> results = stickslip.cea_friction_sweep("smoke", [0.0, 0.3, 0.7], fmax_hz=3000.0)
        >>> [len(r.unstable()) > 0 for r in results]
        [False, True, True]
    """
    sc = load_scene(scene, overrides)
    problem = cea_problem(sc)
    ops = build_operators(problem, mass, friction or sc.friction.filter)
    try:
        return [complex_eigenvalue_analysis(problem, None if f is None else float(f), fmax_hz,
                                            ops=ops) for f in fs]
    finally:
        ops.destroy()


def _travel_options(scene: Scene, k: int, from_run: str | Path | None, damping: float | None,
                    celerity: float | None, **options: Any) -> SimpleNamespace:
    """The options of ``stickslip travel``, checked and resolved by the function the command
    uses (``studies.travel.command``: one table of defaults); a bad one raises ``ValueError``
    naming the keyword argument."""
    # dolfinx on first use: load_scene and the reduced model work without it
    from stickslip.studies.travel.frame import require_rotational_symmetry

    require_plane_strain(scene)  # SceneError, one line: the travelling wave is 2D only
    require_rotational_symmetry(scene)
    opts = command.options(k=int(k), from_run=str(from_run) if from_run else None,
                           damping=damping, celerity=celerity, **options)
    bad = command.check(opts, command.keyword) or command.resolve(scene, opts, command.keyword)
    if bad:
        raise ValueError(bad)
    return opts


def travel(scene: str | Path | Scene, k: int, out_dir: str | Path | None = None, *,
           overrides: Overrides = None, from_run: str | Path | None = None,
           damping: float | None = None, celerity: float | None = None,
           force: bool = False, **options: Any) -> tuple[dict, dict]:
    """One travelling wave solved directly in its own frame (``stickslip travel``).

    Semismooth Newton for the nodal displacements W(theta - omega t) and the angular speed
    omega, with the contact law on the inner circle and the interior condensed.

    Args:
        scene: scene file, shipped name or ``Scene``.
        k: wavenumber (waves per turn), >= 1.
        out_dir: where to write ``scene.toml``, ``summary.json`` and ``profiles.npz``
            (``None``: nothing is written).
        overrides: scene overrides, as for ``load_scene``.
        from_run: start from the last sample of this transient run directory (default: the
            reduced model's wave at k, or a mode-k stick-slip guess).
        damping: Kelvin-Voigt retardation time tau [s] (default: the scene's).
        celerity: start speed [m/s] (signed, + = rotation sense).
        force: overwrite ``out_dir``.
        **options: the other options of ``stickslip travel``: ``rate``, ``inertia``,
            ``samples``, ``time_scheme``, ``max_iter``, ``fixed_omega``.

    Returns:
        ``(summary, profiles)``: the summary has the keys of a run's ``summary.json``
        (``regime``, ``mode``, ``celerity_m_s``, ``frequency_hz``, ``psi1``, ``psi2``, ...)
        plus ``residual`` and ``iterations``; ``profiles`` holds arrays over one period.
        A wave that is not found raises ``studies.travel.newton.NotConverged``.

    Example:
        >>> summary, _ = stickslip.travel("figure3_n132_damped", 12, from_run="runs/fig3")
        >>> summary["mode"], summary["regime"]
        (12, 'stick-slip-separation')
    """
    import time

    t0 = time.perf_counter()
    sc = load_scene(scene, overrides)
    opts = _travel_options(sc, k, from_run, damping, celerity, **options)
    summary, profiles = command.solve(sc, opts, t0)
    if out_dir is not None:
        with _keyword_errors("out_dir"), _claimed(out_dir, force) as work:
            write_wave(work, sc, summary, profiles)
    return summary, profiles


def travel_branch(scene: str | Path | Scene, k: int, key: str, values: Sequence[float],
                  out_dir: str | Path, *, overrides: Overrides = None,
                  from_run: str | Path | None = None, damping: float | None = None,
                  celerity: float | None = None, force: bool = False, plot: bool = False,
                  quiet: bool = False, **options: Any) -> list[dict]:
    """Follow a travelling wave in one scene key (``stickslip travel --continue``).

    Each value is one Newton solve started from the previous wave; the branch ends where a
    solve fails (its row names the residual and the inequality that failed) or where it
    jumps to another solution (status ``jumped``: ``studies.travel.continuation``).

    Args:
        scene, k, from_run, damping, celerity, options: as for ``travel``.
        key: the dotted scene key (``loading.omega``, ``loading.f``, ``geometry.delta`` reuse
            the operators; any other key rebuilds them).
        values: the values of ``key``, in order.
        out_dir: where ``branch.json`` and ``branch.csv`` (and ``branch.png``) go.
        force: replace an earlier travel directory at ``out_dir``.
        plot: also draw ``branch.png``.
        quiet: do not print a line per point.

    Returns:
        The rows of ``branch.json``, each with ``value``, ``status`` (converged, jumped, failed,
        error) and,
        where converged, ``celerity_m_s``, ``amplitude_m``, ``psi1``, ``psi2``, ``regime``.

    Example:
        >>> rows = stickslip.travel_branch("figure3_n132_damped", 12, "loading.omega",
        ...                                [50.0, 60.0], "/tmp/branch", from_run="runs/fig3")
        >>> [r["status"] for r in rows]
        ['converged', 'converged']
    """
    import contextlib
    import time

    sc = load_scene(scene, overrides)
    for value in values:  # the key and every value, before any work
        sc.with_overrides(f"{key}={float(value)!r}")
    opts = _travel_options(sc, k, from_run, damping, celerity, plot=plot, **options)
    quieted = contextlib.redirect_stdout(io.StringIO()) if quiet else contextlib.nullcontext()
    with _keyword_errors("out_dir"), _claimed(out_dir, force) as work, quieted:
        run_continuation(sc, opts, key, [float(v) for v in values], work, time.perf_counter())
    return json.loads((Path(out_dir) / "branch.json").read_text())


@contextlib.contextmanager
def _claimed(out_dir: str | Path, force: bool) -> Iterator[Path]:
    """The travel directory ``out_dir`` claimed (``studies.travel.output.prepare_dir``): yields
    the folder to write; swapped in when the block ends, discarded (an earlier result kept)
    when it raises."""
    claim = prepare_dir(Path(out_dir), force)
    try:
        yield claim.work
    except BaseException:
        claim.discard()
        claim.release()
        raise
    claim.commit()
    claim.release()


def reduced_waves(*, nu: float = 0.3, xi: float = 1.25, f: float = 0.7, k: int = 4,
                  delta: float = 1e-3, omega: float = 50.0, wave_speed: float = 1000.0,
                  radius: float = 1.0) -> list[dict]:
    """The reduced model's travelling waves (paper eqs. 1-7) at one point: no FE, no mesh.

    Args:
        nu: Poisson ratio; xi: outer/inner radius ratio; f: friction coefficient.
        k: wavenumber; delta: mismatch d/R; omega: the cylinder's speed [rad/s].
        wave_speed: sqrt(E/rho) [m/s]; radius: R [m] (with omega they set gamma).

    Returns:
        One dict per wave (admissible ones first), the entries of ``stickslip wave --json``:
        ``regime``, ``admissible``, ``celerity_m_s``, ``frequency_hz``, ``psi1``, ``psi2``, ...

    Example:
        >>> waves = stickslip.reduced_waves(f=0.7, k=4, delta=1e-3, omega=40.0)
        >>> waves[0]["regime"]
        'stick-slip'
    """
    co = coefficients(nu, xi, gamma_from_physical(wave_speed, radius, omega))
    return [w.summary(radius, omega) for w in find_waves(co, f, k, delta)] if f > 0 else []


def rpo_along(run_dir: str | Path, key: str, values: Sequence[float], *, leg: float = 1.0,
              wave: int | None = None, sideband: int | None = None,
              seed: float | None = None, quiet: bool = False) -> dict:
    """Follow a start along a scene key and measure its sideband (``stickslip rpo
    --along``): where a two-wave state is born (docs/theory/rpo.md).

    Each value runs ``leg`` s from the end state of the one before; per value the second
    wave's growth rate σ over the leg's second half (the real part of the rigid wave's
    complex pair where the sideband is small) and its frequency in the first wave's frame.

    Args:
        run_dir: a run or census start with a checkpoint.
        key: the dotted scene key (``loading.omega``, ...); values: its values, in order.
        leg: seconds run at each value.
        wave, sideband: the two wavenumbers (default: the census member's generators).
        seed: add seed × d cos(sideband θ) at each start and fit where the sideband is below
            1 % of the wave (a state with no sideband above round-off).
        quiet: do not print a line per value.

    Returns:
        {"key", "k_wave", "k_side", "rows"}; each row ``value``, ``sigma`` (1/s),
        ``frequency_hz``, ``wave_hz``, ``frame_hz``, ``share_start``, ``share_end``,
        ``misfit``, ``dt_s``.

    Example:
        >>> out = stickslip.rpo_along("census/P/starts/runs/n_inner-264_perturbation-"
        ...                           "random_seed-1", "loading.omega", [60.0, 66.0])
        >>> [round(r["frame_hz"]) for r in out["rows"]]
        [-78, -78]
    """
    values = [float(v) for v in values]
    report = None if quiet else (lambda row: print(_scan_line(row, key), flush=True))
    return _along(run_dir, key, values, leg=leg, wave=wave, sideband=sideband, seed=seed,
                  report=report)
