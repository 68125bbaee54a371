"""Property-based fuzzing (Hypothesis) of what users and files hand to stickslip.

Scene files, ``--set`` values, sweep files, CLI option strings and damaged run directories:
each case gives a one-line error (the class the layer promises: ``SceneError``,
``SweepError``, ``ReadError``; exit 2 through the CLI) or a valid result; never another
exception, never a traceback, never a change to a file the command does not own.

Derandomised (the same examples on every CI run) with a fixed number of examples per test,
and a fixed grid of hostile numbers for every numeric option and scene key: about 65 s in
all on 2 cores.
"""

from __future__ import annotations

import contextlib
import io
import shutil
import tomllib
from pathlib import Path

import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
SMOKE = REPO / "scenes" / "smoke.toml"
FUZZ = settings(derandomize=True, deadline=None, database=None,
                suppress_health_check=list(HealthCheck))


def _keys() -> list[str]:
    data = tomllib.loads(SMOKE.read_text())
    return sorted(f"{s}.{k}" for s, v in data.items() if isinstance(v, dict) for k in v)


KEYS = _keys()
NUMBERS = st.one_of(st.floats(allow_nan=True, allow_infinity=True).map(repr),
                    st.integers(-10**30, 10**30).map(str),
                    st.sampled_from(["1e308", "-0.0", "1e-320", "0x10", "1_0", "nan", "inf"]))
VALUES = st.one_of(NUMBERS, st.text(max_size=12).map(repr), st.text(max_size=12),
                   st.sampled_from(["true", "[1, 2]", "{a = 1}", '"', "[[[", "'x'"]))


def one_line(err: BaseException) -> None:
    text = str(err)
    assert text and "\n" not in text and "Traceback" not in text, repr(text)


@settings(FUZZ, max_examples=150)
@given(st.lists(st.tuples(st.one_of(st.sampled_from(KEYS), st.text(max_size=10)), VALUES),
                max_size=3))
def test_set_values(pairs):
    """``--set KEY=VALUE``: a valid scene or one SceneError line."""
    from stickslip.solver.scene import SceneError, load_scene

    try:
        load_scene(SMOKE, [f"{k}={v}" for k, v in pairs])
    except SceneError as err:
        one_line(err)


TOML_SCALARS = st.one_of(st.floats(allow_nan=False, allow_infinity=False),
                         st.integers(-10**6, 10**6), st.booleans(), st.text(max_size=8))
TOML_VALUES = st.recursive(TOML_SCALARS, lambda inner: st.lists(inner, max_size=3), max_leaves=6)


def _toml(value) -> str:  # noqa: ANN001
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return '"' + value.encode("unicode_escape").decode().replace('"', '\\"') + '"'
    if isinstance(value, list):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    return repr(value)


@settings(FUZZ, max_examples=120)
@given(st.dictionaries(st.sampled_from(KEYS), TOML_VALUES, max_size=5),
       st.sampled_from(["", "junk = 1\n", "[[geometry]]\n", "\x00", "name = 3\n"]))
def test_scene_files(tmp_path_factory, entries, extra):
    """Scene files: the smoke scene with fields replaced by anything TOML can hold."""
    from stickslip.solver.scene import SceneError, load_scene

    data = tomllib.loads(SMOKE.read_text())
    for key, value in entries.items():
        section, _, name = key.partition(".")
        data[section][name] = value
    lines = [extra]
    for section, body in data.items():
        if isinstance(body, dict):
            lines.append(f"[{section}]")
            lines += [f"{k} = {_toml(v)}" for k, v in body.items()]
        else:
            lines.insert(0, f"{section} = {_toml(body)}")
    path = tmp_path_factory.mktemp("scene") / "s.toml"
    path.write_text("\n".join(lines) + "\n")
    try:
        load_scene(path)
    except SceneError as err:
        one_line(err)


@settings(FUZZ, max_examples=120)
@given(st.dictionaries(st.sampled_from(["name", "base", "group_size", "set", "grid", "points",
                                        "map", "batch", "backend", "output", "bogus"]),
                       st.one_of(TOML_VALUES, st.dictionaries(
                           st.sampled_from([*KEYS[:6], "x", "y", "k", "nope"]),
                           st.one_of(TOML_VALUES, st.lists(st.floats(allow_nan=False,
                                                                     allow_infinity=False),
                                                           max_size=4)),
                           max_size=3)), max_size=5))
def test_sweep_files(tmp_path_factory, body):
    """Sweep files: a SweepSpec or one SweepError line (never a traceback)."""
    from stickslip.studies.sweep import load_sweep
    from stickslip.studies.sweep.spec import SweepError

    lines, tables = [f'base = "{SMOKE}"'] if "base" not in body else [], []
    for key, value in body.items():
        if isinstance(value, dict):
            tables.append(f"[{key}]")
            tables += [f'"{k}" = {_toml(v)}' for k, v in value.items()]
        else:
            lines.append(f"{key} = {_toml(value)}")
    path = tmp_path_factory.mktemp("sweep") / "s.toml"
    path.write_text("\n".join(lines + tables) + "\n")
    try:
        load_sweep(path)
    except SweepError as err:
        one_line(err)


OPTION = st.one_of(st.sampled_from(["--omega", "--nu", "--kmax", "--k", "--f", "--delta",
                                    "--xi", "--plot", "--json", "--set", "-o", "--force",
                                    "--yes-i-know", "--", "-", "--omega=", "--kmax=-1"]),
                   NUMBERS, st.text(min_size=1, max_size=8).filter(lambda s: "\x00" not in s))


@settings(FUZZ, max_examples=60)
@given(st.sampled_from(["wave", "flutter"]), st.lists(OPTION, max_size=5))
def test_cli_option_strings(tmp_path_factory, capsys, command, options):
    """The light commands with any option strings: exit 0, or exit 2 with one line (argparse
    usage errors print their usage line too, and exit 2)."""
    from stickslip.cli.main import main

    cwd = tmp_path_factory.mktemp("cli")
    before = sorted(p.name for p in cwd.iterdir())
    import os

    old = os.getcwd()
    os.chdir(cwd)
    try:
        rc = main([command, *options])
    except SystemExit as stop:  # argparse
        rc = stop.code
    finally:
        os.chdir(old)
    err = capsys.readouterr().err
    assert rc in (0, 2), (rc, err)
    assert "Traceback" not in err
    if rc == 2 and not err.startswith("usage:"):
        assert err.count("\n") == 1, err
    written = sorted(p.name for p in cwd.iterdir())
    assert set(written) - set(before) <= {o for o in options if o.endswith((".png", ".json"))}



FILES = ["summary.json", "scene.toml", "samples.npz", "final_field.npz", ".stickslip"]


@settings(FUZZ, max_examples=40)
@given(st.sampled_from(FILES), st.sampled_from(["truncate", "flip", "delete", "replace"]),
       st.floats(0, 1), st.binary(max_size=40))
def test_damaged_run_directories(finished, tmp_path_factory, capsys, name, how, where, junk):
    """A run directory with one file truncated, flipped, deleted or replaced: the reader
    check passes (then compare reads it) or fails in one ReadError line; `run --force` on it
    replaces it or refuses in one line, and never touches what is not stickslip's."""
    from stickslip.cli.main import main
    from stickslip.studies.rundir.readers import ReadError, check_run_dir

    d = tmp_path_factory.mktemp("damaged") / "r"
    shutil.copytree(finished, d)
    (d / "mine.txt").write_text("the user's")
    f = d / name
    data = f.read_bytes()
    cut = int(where * len(data))
    if how == "truncate":
        f.write_bytes(data[:cut])
    elif how == "flip":
        f.write_bytes(data[:cut] + bytes([data[cut] ^ 0xFF]) + data[cut + 1:]
                      if cut < len(data) else data)
    elif how == "delete":
        f.unlink()
    else:
        f.write_bytes(junk)
    try:
        check_run_dir(d, need=4)
        ok = True
    except ReadError as err:
        one_line(err)
        ok = False
    rc = main(["compare", str(d), "--json", str(d.parent / "c.json")])
    err = capsys.readouterr().err
    assert rc in ((0,) if ok else (2,)), (rc, err)
    assert "Traceback" not in err and (rc == 0 or err.count("\n") == 1), err
    rc = main(["run", str(SMOKE), "-o", str(d), "--force", "--set", "time.end_time=1e-5"])
    err = capsys.readouterr().err
    assert rc in (2, 0, 1), err
    assert (d / "mine.txt").read_text() == "the user's"


RUN_OPTIONS = st.lists(st.one_of(
    st.tuples(st.just("--set"), st.tuples(st.sampled_from(KEYS), VALUES).map("=".join)),
    st.tuples(st.sampled_from(["--force", "--yes-i-know", "--profile"])),
    st.tuples(st.just("-o"), st.sampled_from(["mine", "mine/sub", "new", "file.txt",
                                              "new/deeper", ".", ""]))), max_size=3)


@settings(FUZZ, max_examples=15)
@given(RUN_OPTIONS)
def test_run_option_strings(tmp_path_factory, capsys, options):
    """`stickslip run` with any options (short runs): a run with its exit status, or exit 2
    with one line; the user's folder and file are never changed."""
    pytest.importorskip("dolfinx")
    import os

    from stickslip.cli.main import main

    cwd = tmp_path_factory.mktemp("runfuzz")
    (cwd / "mine").mkdir()
    (cwd / "mine" / "notes.txt").write_text("mine")
    (cwd / "file.txt").write_text("mine")
    argv = ["run", str(SMOKE), "--set", "time.end_time=0.002", "--set",
            "output.progress=false", "-o", "default"]
    for opt in options:
        argv += list(opt)
    old = os.getcwd()
    os.chdir(cwd)
    try:
        rc = main(argv)
    except SystemExit as stop:  # argparse
        rc = stop.code
    finally:
        os.chdir(old)
    err = capsys.readouterr().err
    assert rc in (0, 1, 2, 3), (rc, err)
    assert "Traceback" not in err
    if rc == 2 and not err.startswith("usage:"):
        assert err.count("\n") == 1, err
    assert (cwd / "mine" / "notes.txt").read_text() == "mine"
    assert (cwd / "file.txt").read_text() == "mine"


# ------------------------------------------------------- every numeric option of every command

class Reached(BaseException):
    """The command accepted its options and reached its work (replaced by this sentinel, so
    that a case costs the option handling only; a BaseException, so no handler mistakes it
    for an error of its own)."""


def _reached(*args, **kwargs):  # noqa: ANN002, ANN003, ANN202
    raise Reached


#: Each command: its argv before the fuzzed option ({tmp}: a fresh folder, {run}: a finished
#: run) and the calls that do its work, replaced by ``Reached`` (the light commands run).
COMMANDS = {
    "run": (["run", "smoke", "-o", "{tmp}/r"], ["stickslip.cli.run.run_scene"]),
    "plot": (["plot", "{run}"], ["stickslip.cli.run.plot_run"]),
    "continue": (["continue", "{run}"], ["stickslip.cli.continue_run.continue_run"]),
    "wave": (["wave", "--json"], []),
    "flutter": (["flutter", "--json"], []),
    "compare": (["compare", "{run}", "--json", "{tmp}/c.json"], []),
    "sweep": (["sweep", str(REPO / "sweeps" / "smoke4.toml"), "-o", "{tmp}/s"],
              ["stickslip.cli.sweep.run_sweep"]),
    "flutter-fe": (["flutter-fe", "smoke", "--json"],
                   ["stickslip.cli.flutter_fe.complex_eigenvalue_analysis"]),
    "flutter-exact": (["flutter-exact", "smoke", "--json"],
                      ["stickslip.cli.continuum.sliding_branches"]),
    "travel": (["travel", "smoke", "--k", "4", "-o", "{tmp}/t"],
               ["stickslip.studies.travel.command.solve",
                "stickslip.cli.travel.run_continuation"]),
    "export": (["export", "{run}", "-o", "{tmp}/p.csv", "--cea", "--plot", "{tmp}/p.png"],
               ["stickslip.cli.export._marks"]),
    "attractors": (["attractors", "smoke", "-o", "{tmp}/a"],
                   ["stickslip.cli.attractors.run_census", "stickslip.cli.attractors.run_along"]),
    "rpo": (["rpo", "{run}", "--period", "1e-3", "--shift", "10", "-o", "{tmp}/o"],
            ["stickslip.cli.rpo.rpo_certificate", "stickslip.cli.rpo.along"]),
}
#: Options that take numbers inside a string: the string built from drawn numbers.
TEMPLATES = {"--batch": "{i}", "--f-sweep": "{x}:{y}:{i}",
             "--continue": "loading.omega={x}:{y}:{i}", "--meshes": "{i},{j}",
             "--degrees": "{i},{j}",
             "--structured": "{i}:{j}", "--n": "{i},{j}", "--along": "loading.omega={x}:{y}:{i}"}
EXTREME_FLOATS = st.one_of(
    st.sampled_from(["nan", "inf", "-inf", "-1", "0", "-0.0", "5e-324", "1e-300", "1e300",
                     "1.7976931348623157e308", "1e12", "0.5", "3"]),
    st.floats(allow_nan=True, allow_infinity=True).map(repr))
EXTREME_INTS = st.one_of(
    st.sampled_from(["-1", "0", "1", "2", "4", "2147483648", "9223372036854775808",
                     str(10**30), str(-10**30), "1.5"]),
    st.integers(-10**20, 10**20).map(str))


def _numeric_options() -> list[tuple[str, str, str]]:
    """(command, option, kind) of every option whose value is a number (argparse type int,
    float or a parsing function) or holds numbers (``TEMPLATES``), read from the parser."""
    from stickslip.cli.main import build_parser

    sub = next(a for a in build_parser()._actions if a.dest == "command")
    out = []
    for command, parser in sub.choices.items():
        for action in parser._actions:
            if not action.option_strings or action.nargs == 0:
                continue
            flag = action.option_strings[-1]
            if action.type is int:
                out.append((command, flag, "int"))
            elif action.type is float or (action.type is not None and action.type is not str):
                out.append((command, flag, "float"))
            elif flag in TEMPLATES:
                out.append((command, flag, "template"))
    return out


NUMERIC_OPTIONS = _numeric_options()


def test_every_numeric_option_is_fuzzed():
    """Every command with a numeric option has its work replaced (or is light): the list
    below covers the parser as it is."""
    assert {c for c, _, _ in NUMERIC_OPTIONS} <= set(COMMANDS)
    assert len(NUMERIC_OPTIONS) >= 40


@settings(FUZZ, max_examples=200)
@given(st.sampled_from(NUMERIC_OPTIONS), st.data())
def test_numeric_options(finished, tmp_path_factory, capsys, monkeypatch, option, data):
    """Any number (NaN, ±inf, 0, negative, tiny, huge, not an int) for any numeric option:
    exit 0 (or the command's work reached), or exit 2 with one line; never a traceback."""
    command, flag, kind = option
    if kind == "int":
        value = data.draw(EXTREME_INTS)
    elif kind == "float":
        value = data.draw(EXTREME_FLOATS)
        value = value + data.draw(st.sampled_from(["", "ms", "T"])) if flag == "--window" \
            else value
    else:
        value = TEMPLATES[flag].format(x=data.draw(EXTREME_FLOATS), y=data.draw(EXTREME_FLOATS),
                                       i=data.draw(EXTREME_INTS), j=data.draw(EXTREME_INTS))
    _one_line_or_reached(command, flag, value, tmp_path_factory.mktemp("num"), finished,
                         capsys, monkeypatch)


#: The values every numeric option meets, each one (a fixed grid beside the drawn ones above):
#: past 32 and 64 bits, negative, zero, not a number, infinite, the largest float.
HOSTILE = {"int": ["2147483648", str(10**30), "-1", "0"],
           "float": ["nan", "inf", "1e308", "-1", "0"]}
HOSTILE["template"] = sorted({TEMPLATES[flag].format(x=x, y=y, i=i, j=j)
                              for flag in TEMPLATES
                              for x, y in (("1", "2"), ("nan", "1"), ("-1e308", "1e308"))
                              for i, j in (("3", "4"), ("1", "100000"), ("2147483648", "1"),
                                           ("-1", str(10**20)))})


def _hostile_cases() -> list[tuple[str, str, str]]:
    cases = []
    for command, flag, kind in NUMERIC_OPTIONS:
        values = HOSTILE[kind] if kind != "template" else [
            v for v in HOSTILE["template"] if v.startswith(TEMPLATES[flag].split("{")[0])
            and v.count(":") == TEMPLATES[flag].count(":")
            and v.count(",") == TEMPLATES[flag].count(",")]
        cases += [(command, flag, v) for v in values]
    return cases


@pytest.mark.parametrize(("command", "flag", "value"), _hostile_cases())
def test_numeric_options_hostile_grid(finished, tmp_path, capsys, monkeypatch, command, flag,
                                      value):
    """Each numeric option with each hostile value: exit 0 (or the command's work reached),
    or exit 2 with one line at load; never a traceback, an overflow or a huge allocation."""
    _one_line_or_reached(command, flag, value, tmp_path, finished, capsys, monkeypatch)


def _one_line_or_reached(command: str, flag: str, value: str, tmp: Path, finished: Path,
                         capsys, monkeypatch) -> None:  # noqa: ANN001
    """``command`` with ``flag=value``: its work reached (exit 0), or exit 2 with one line
    (argparse's usage lines aside); never a traceback."""
    from stickslip.cli.main import main

    before, works = COMMANDS[command]
    for target in works:
        monkeypatch.setattr(target, _reached, raising=False)
    argv = [a.format(tmp=tmp, run=finished) for a in before] + [f"{flag}={value}"]
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            rc = main(argv)
    except Reached:
        rc = 0
    except SystemExit as stop:  # argparse: a value of the wrong type, with its usage line
        rc = stop.code
    err = capsys.readouterr().err
    assert rc in (0, 2), (argv, rc, err)
    assert "Traceback" not in err, err
    if rc == 2 and not err.startswith("usage:"):
        assert err.count("\n") == 1, (argv, err)


def _numeric_scene_keys() -> list[str]:
    """Every numeric key of a resolved scene (the defaults included), as ``section.key``."""
    from stickslip.solver.scene import load_scene
    from stickslip.solver.scene.model import scene_to_dict

    data = scene_to_dict(load_scene(SMOKE))
    return sorted(f"{s}.{k}" for s, v in data.items() if isinstance(v, dict)
                  for k, x in v.items() if isinstance(x, int | float)
                  and not isinstance(x, bool))


@pytest.mark.parametrize("value", HOSTILE["int"] + HOSTILE["float"])
def test_scene_numbers_hostile_grid(tmp_path, capsys, monkeypatch, value):
    """`run --set KEY=VALUE` for every numeric key of a scene and each hostile value, up to
    the resource check (the run directory is not made): exit 2 in one line, or the run
    reached; never a traceback (time.end_time = 1e308 overflowed the step count)."""
    from stickslip.cli.main import main

    monkeypatch.setattr("stickslip.studies.rundir.directory.prepare_run_dir", _reached)
    keys = _numeric_scene_keys()
    assert len(keys) >= 30
    for key in keys:
        argv = ["run", str(SMOKE), "-o", str(tmp_path / "r"), "--set", f"{key}={value}"]
        try:
            with contextlib.redirect_stdout(io.StringIO()):
                rc = main(argv)
        except Reached:
            rc = 0
        err = capsys.readouterr().err
        assert rc in (0, 2), (argv, rc, err)
        assert "Traceback" not in err, err
        if rc == 2:
            assert err.count("\n") == 1, (argv, err)


# ------------------------------------------- signals at phases chosen by Hypothesis, symlinks

FINAL_STATUSES = {"completed", "interrupted", "diverged", "stopped", "failed", "crashed",
                  "converged"}


def _tiny_commands(tmp: Path) -> dict[str, list[str]]:
    """Each long-running command on a tiny problem (a second or two), writing under ``tmp``."""
    sweep = tmp / "tiny.toml"
    sweep.write_text(f'name = "tiny"\nbase = "{SMOKE}"\n[set]\n"time.end_time" = 0.002\n'
                     '"output.progress" = false\n[grid]\n"loading.omega" = [40.0, 50.0]\n')
    return {
        "run": ["run", str(SMOKE), "--set", "time.end_time=0.002", "-o", str(tmp / "out")],
        "sweep": ["sweep", str(sweep), "-o", str(tmp / "out")],
        "attractors": ["attractors", str(SMOKE), "--starts", "2", "--end-time", "0.002",
                       "--no-certify", "-o", str(tmp / "out")],
        "travel": ["travel", "figure1_n132_damped", "--set", "mesh.n_inner=36", "--k", "4",
                   "--celerity", "-2300", "--fixed-omega", "-o", str(tmp / "out")],
    }


def _run_quietly(argv: list[str]) -> int:
    from stickslip.cli.main import main

    with contextlib.redirect_stdout(io.StringIO()):
        return main(argv)


def _nothing_half_written(out: Path) -> None:
    """No temporary file or folder, and every summary in the tree final (never running)."""
    import json

    from faults import leftovers

    for d in [out, *(p for p in out.rglob("*") if p.is_dir())] if out.exists() else []:
        assert not leftovers(d), leftovers(d)
    for summary in out.rglob("summary.json") if out.exists() else []:
        assert json.loads(summary.read_text())["status"] in FINAL_STATUSES, summary


@settings(FUZZ, max_examples=10)
@given(st.sampled_from(["run", "sweep", "attractors", "travel"]),
       st.sampled_from(["SIGINT", "SIGTERM", "SIGHUP"]),
       st.sampled_from(["setup", "loop", "scene.toml", "summary.json#1", "samples.npz",
                        "final_field.npz", "summary.json#2"]))
def test_a_signal_at_any_phase(tmp_path_factory, monkeypatch, command, kind, phase):
    """A signal delivered in-process at a phase of the work (``faults.inject``, no timing):
    exit 130 once it fired (0 if the phase never came), nothing half-written, every summary
    final; the same command again then finishes (a sweep or census resumes)."""
    pytest.importorskip("dolfinx")
    import sys

    sys.path.insert(0, str(REPO / "tests"))
    from faults import inject

    tmp = tmp_path_factory.mktemp("sig")
    argv = _tiny_commands(tmp)[command]
    with monkeypatch.context() as patch:
        state = inject(patch, kind, phase)
        rc = _run_quietly(argv)
    assert rc == (130 if state["fired"] else 0), (argv, phase, rc)
    _nothing_half_written(tmp / "out")
    again = _run_quietly(argv + (["--force"] if command in ("run", "travel") else []))
    assert again == 0, (argv, again)
    _nothing_half_written(tmp / "out")


@pytest.mark.parametrize(("kind", "phase"), [
    ("SIGINT", "setup"), ("SIGTERM", "loop"), ("SIGHUP", "samples.npz"),
    ("SIGINT", "summary.json#3"), ("disk-full", "summary.json#1"),
    ("disk-full", "samples.npz"), ("disk-full", "checkpoint.npz")])
def test_a_batched_sweep_at_a_fault(tmp_path, monkeypatch, kind, phase):
    """A batch of two (each member's directory a ``RunDirectory``, its log a ``TaskLog``)
    under a signal or a full disk at a phase (``faults.inject``; the hypothesis tests above
    sample unbatched sweeps): a signal gives 130 and a resume completes both; a full disk
    fails the member that hit it, exit 1, its message naming the file, the other member
    completed. Nothing half-written, no summary left ``running``."""
    pytest.importorskip("dolfinx")
    import json
    import sys

    sys.path.insert(0, str(REPO / "tests"))
    from faults import inject

    spec = tmp_path / "tiny.toml"
    spec.write_text(f'name = "tiny"\nbase = "{SMOKE}"\nbatch = 2\n[set]\n'
                    '"time.end_time" = 0.002\n"output.progress" = false\n[grid]\n'
                    '"loading.omega" = [40.0, 50.0]\n')
    argv = ["sweep", str(spec), "-o", str(tmp_path / "out")]
    with monkeypatch.context() as patch:
        state = inject(patch, kind, phase)
        rc = _run_quietly(argv)
    assert state["fired"], phase
    _nothing_half_written(tmp_path / "out")
    rows = json.loads((tmp_path / "out" / "sweep.json").read_text())["rows"]
    if kind == "disk-full":
        assert rc == 1 and sorted(r["status"] for r in rows) == ["completed", "failed"], rows
        (failed,) = (r for r in rows if r["status"] == "failed")
        assert "No space left" in failed["message"] and phase.split("#")[0] in failed["message"]
        return
    assert rc == 130 and _run_quietly(argv) == 0
    rows = json.loads((tmp_path / "out" / "sweep.json").read_text())["rows"]
    assert [r["status"] for r in rows] == ["completed", "completed"], rows
    _nothing_half_written(tmp_path / "out")


@settings(FUZZ, max_examples=8)
@given(st.sampled_from(["run", "sweep", "attractors", "travel"]),
       st.sampled_from(["scene.toml", "summary.json#1", "samples.npz", "final_field.npz",
                        "summary.json#2", "summary.json#3"]))
def test_a_full_disk_at_any_write(tmp_path_factory, monkeypatch, command, phase):
    """A write that fails with ENOSPC (``faults.inject``, as a full 2 MB tmpfs does): a
    one-line failure or an exit status that says so, nothing half-written, every summary
    final, and no table row that hides the failure as ``unanalysed`` or ``running``."""
    pytest.importorskip("dolfinx")
    import json
    import sys

    sys.path.insert(0, str(REPO / "tests"))
    from faults import inject

    tmp = tmp_path_factory.mktemp("full")
    argv = _tiny_commands(tmp)[command]
    with monkeypatch.context() as patch:
        state = inject(patch, "disk-full", phase)
        rc = _run_quietly(argv)
    assert rc in (0, 1, 2), (argv, phase, rc)
    _nothing_half_written(tmp / "out")
    for table in (tmp / "out").rglob("sweep.json"):
        rows = json.loads(table.read_text())["rows"]
        assert not {r["status"] for r in rows} & {"unanalysed", "running"}, rows
        if state["fired"] and any(r["status"] == "failed" for r in rows):
            assert rc != 0, (argv, phase)


#: Entries a finished directory of each command holds, each of which may be a link.
WRITTEN = {
    "run": ["scene.toml", "summary.json", "samples.npz", "final_field.npz", "checkpoint.npz",
            ".stickslip", ".stickslip.lock"],
    "sweep": ["sweep.json", "sweep.csv", ".stickslip", ".stickslip.lock", "runs",
              "runs/omega-40.0/summary.json", "runs/omega-40.0/samples.npz", "sweep.toml",
              "logs"],
    "travel": ["scene.toml", "summary.json", "profiles.npz", ".stickslip", ".stickslip.lock"],
    "attractors": ["census.json", "census.toml", "base.toml", "attractors.json",
                   "attractors.csv", "members.csv", ".stickslip", ".stickslip.lock",
                   "starts/sweep.json", "starts/.stickslip.lock"],
}


@pytest.fixture(scope="module")
def finished_dirs(tmp_path_factory) -> dict[str, Path]:
    """A finished run, sweep, census and travel directory to copy (made once)."""
    pytest.importorskip("dolfinx")
    tmp = tmp_path_factory.mktemp("finished")
    dirs = {}
    for command, argv in _tiny_commands(tmp).items():
        if command in WRITTEN:
            out = tmp / command
            argv[argv.index(str(tmp / "out"))] = str(out)
            assert _run_quietly(argv) == 0, argv
            dirs[command] = out
    return dirs


@pytest.mark.parametrize("case", sorted((c, e) for c, es in WRITTEN.items() for e in es),
                         ids="/".join)
def test_a_symlink_at_any_written_path(finished_dirs, tmp_path_factory, capsys, case):
    """A finished directory with one of its entries replaced by a link to the user's file:
    the command again (run/travel --force, sweep and census resumed) refuses in one line (exit 2) or
    replaces the link; it never writes through it, and the user's file stays as it was."""
    command, entry = case
    tmp = tmp_path_factory.mktemp("link")
    out = tmp / "out"
    shutil.copytree(finished_dirs[command], out, symlinks=True)
    users = tmp / "users.txt"
    users.write_text("the user's")
    target = out / entry
    if target.is_dir():
        shutil.rmtree(target)
    else:
        target.unlink()
    target.symlink_to(users)
    argv = _tiny_commands(tmp)[command] + (["--force"] if command in ("run", "travel") else [])
    capsys.readouterr()
    rc = _run_quietly(argv)
    err = capsys.readouterr().err
    assert rc in (0, 2), (argv, entry, rc, err)
    assert "Traceback" not in err and (rc == 0 or err.count("\n") == 1), err
    assert users.read_text() == "the user's"


@pytest.mark.parametrize("command", ["sweep", "attractors", "travel"])
def test_a_read_only_folder_is_refused_in_one_line(tmp_path, command):
    """`-o` inside a folder the user cannot write (root writes anywhere, so the command runs
    as the unprivileged user `nobody`): exit 2, one line, nothing created."""
    import os
    import subprocess
    import sys
    import tempfile

    if os.geteuid() != 0:
        pytest.skip("needs root to run a command as another user")
    pytest.importorskip("dolfinx")
    ro = Path(tempfile.mkdtemp(dir="/tmp"))
    argv = _tiny_commands(ro)[command]  # the tiny sweep file is written before the lock-down
    argv[argv.index(str(ro / "out"))] = str(ro / "x")
    (ro / "tiny.toml").chmod(0o644)
    try:
        ro.chmod(0o555)
        res = subprocess.run([sys.executable, "-m", "stickslip.cli.main", *argv], cwd=REPO,
                             capture_output=True, text=True, timeout=120,
                             env={**os.environ, "HOME": "/tmp"},
                             preexec_fn=lambda: os.setuid(65534))
        assert res.returncode == 2, res.stderr
        assert res.stderr.count("\n") == 1 and "Traceback" not in res.stderr, res.stderr
        assert f"{ro / 'x'}" in res.stderr and "writ" in res.stderr, res.stderr
        assert not (ro / "x").exists()
    finally:
        ro.chmod(0o755)
        shutil.rmtree(ro)
