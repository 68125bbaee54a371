"""Property-based fuzzing (Hypothesis) of what users and files hand to stickslip.

Scene files, ``--set`` values, sweep files, CLI option strings and damaged run directories:
each case gives a one-line error (the class the layer promises: ``SceneError``,
``SweepError``, ``ReadError``; exit 2 through the CLI) or a valid result; never another
exception, never a traceback, never a change to a file the command does not own.

Derandomised (the same examples on every CI run) with a fixed number of examples per test:
about 40 s in all on 2 cores.
"""

from __future__ import annotations

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
    from solver.scene import SceneError, load_scene

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
    from solver.scene import SceneError, load_scene

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
    from studies.sweep import load_sweep
    from studies.sweep.spec import SweepError

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
    from cli.main import main

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


@pytest.fixture(scope="module")
def finished(tmp_path_factory) -> Path:
    pytest.importorskip("dolfinx")
    from mpi4py import MPI

    from solver.scene import load_scene
    from studies.rundir import run_scene

    d = tmp_path_factory.mktemp("fuzzrun") / "r"
    scene = load_scene(SMOKE, ["time.end_time=0.005", "output.progress=false"])
    run_scene(scene, d, comm=MPI.COMM_SELF, stream=io.StringIO())
    return d


FILES = ["summary.json", "scene.toml", "samples.npz", "final_field.npz", ".stickslip"]


@settings(FUZZ, max_examples=40)
@given(st.sampled_from(FILES), st.sampled_from(["truncate", "flip", "delete", "replace"]),
       st.floats(0, 1), st.binary(max_size=40))
def test_damaged_run_directories(finished, tmp_path_factory, capsys, name, how, where, junk):
    """A run directory with one file truncated, flipped, deleted or replaced: the reader
    check passes (then compare reads it) or fails in one ReadError line; `run --force` on it
    replaces it or refuses in one line, and never touches what is not stickslip's."""
    from cli.main import main
    from studies.rundir.readers import ReadError, check_run_dir

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

    from cli.main import main

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
