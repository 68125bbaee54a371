"""Hostile but fair spellings of a directory: ``R/../R``, ``R/.``, ``R//``, ``./R`` and ``.``
inside ``R`` all name the run directory ``R`` (``studies.rundir.ownership.normal_path``).

A path that passes through the directory it names lost the run: ``continue R/../R``,
``continue R -o R/../R/`` and ``run -o R/../R --force`` moved ``R`` aside, then could not
find ``R/..`` to move the new copy in, and left both copies hidden. Each command now names
every ``-o`` and run argument by the one rule; refusals name the same directory as for the
plain spelling. Runs are the smoke scene for 0.005 s (~1 s each) in this process.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
from faults import digest, leftovers
from test_ownership import SMOKE, cli, copy_run, one_line

from stickslip.cli.main import main

REPO = Path(__file__).resolve().parents[1]
QUIET = ["--set", "output.progress=false"]
#: The continued end time: 0.0025 s (~32 steps) beyond the finished run's 0.005 s.
UNTIL = "0.0075"



def _summary(run_dir: Path) -> dict:
    return json.loads((run_dir / "summary.json").read_text())


def _same_arrays(a: Path, b: Path) -> None:
    """samples.npz and final_field.npz of ``a`` and ``b``: every array bitwise (a
    continuation is deterministic: tests/test_continue.py)."""
    for name in ("samples.npz", "final_field.npz"):
        with np.load(a / name) as x, np.load(b / name) as y:
            assert sorted(x.files) == sorted(y.files), name
            for key in x.files:
                assert np.array_equal(x[key], y[key]), (name, key)


def _hidden(parent: Path) -> list[str]:
    """The hidden siblings a claim or a swap makes (none may be left)."""
    return sorted(p.name for p in parent.iterdir() if p.name.startswith("."))


# ------------------------------------------------------------------ the rule itself


def test_normal_path_resolves_dots_and_keeps_links(tmp_path, monkeypatch):
    """`.`, `..` and `//` resolved against the current directory; a `..` after a link goes
    where the kernel goes (the parent of the link's target); a final link is kept."""
    from stickslip.studies.rundir.ownership import normal_path

    (tmp_path / "a" / "b").mkdir(parents=True)
    (tmp_path / "link").symlink_to(tmp_path / "a" / "b")
    monkeypatch.chdir(tmp_path)
    r = tmp_path / "R"
    for spelling in ("R", "R/../R", "R/.", "R//", "./R", "a/b/../../R", f"{r}/../R", f"{r}/"):
        assert normal_path(spelling) == r, spelling
    assert normal_path(".") == tmp_path and normal_path("..") == tmp_path.parent
    assert normal_path("link/../x") == tmp_path / "a" / "x"  # as `open("link/../x")`
    assert normal_path("link/.") == normal_path("link//") == tmp_path / "link"
    assert normal_path(normal_path("link/../../R")) == r  # idempotent


def test_a_link_spelled_with_a_dot_is_still_refused_as_a_link(finished, tmp_path, capsys):
    """`-o link/.` names the link (never its target): refused as a symlinked -o."""
    target = copy_run(finished, tmp_path / "real")
    before = digest(target)
    link = tmp_path / "link"
    link.symlink_to(target)
    rc, err = cli(capsys, "run", SMOKE, "-o", f"{link}/.", "--force", *QUIET)
    one_line(rc, err, f"-o {link} is a symbolic link (to {target})")
    assert link.is_symlink() and digest(target) == before


def test_a_claim_through_the_directory_itself_swaps_beside_it(finished, tmp_path):
    """The library route (no CLI): `claim("R/../R", force=True)` builds the replacement
    beside R and swaps it in; R is a run directory afterwards, nothing hidden is left."""
    from stickslip.studies.rundir.ownership import claim, owned

    d = copy_run(finished, tmp_path / "R")
    c = claim(f"{d}/../R", "run", force=True)
    try:
        assert c.final == d and c.work.parent == tmp_path
        (c.work / "summary.json").write_text("{}")
        c.commit()
    finally:
        c.release()
    assert owned(d, "run") and (d / "summary.json").read_text() == "{}"
    assert _hidden(tmp_path) == []


# ------------------------------------------------------------------ the three reported cases


def test_continue_in_place_through_dotdot_continues_the_run(finished, tmp_path, capsys):
    """`continue R/../R --until T` ended with R gone. Now R is continued to T: the same
    arrays as `continue R --until T` of a copy, exit 0, nothing hidden left."""
    plain = copy_run(finished, tmp_path / "plain")
    assert main(["continue", str(plain), "--until", UNTIL]) == 0
    d = copy_run(finished, tmp_path / "R")
    assert main(["continue", f"{d}/../R", "--until", UNTIL]) == 0, capsys.readouterr().err
    assert _summary(d)["status"] == "completed"
    assert _summary(d)["sim_time_s"] == pytest.approx(float(UNTIL), abs=_summary(d)["dt_s"])
    _same_arrays(d, plain)
    assert _hidden(tmp_path) == [] and not leftovers(d)


def test_continue_into_its_own_dir_spelled_otherwise_is_in_place(finished, tmp_path, capsys):
    """`continue R --until T -o R/../R/` is the continuation in place."""
    plain = copy_run(finished, tmp_path / "plain")
    assert main(["continue", str(plain), "--until", UNTIL]) == 0
    d = copy_run(finished, tmp_path / "R")
    rc = main(["continue", str(d), "--until", UNTIL, "-o", f"{d}/../R/"])
    assert rc == 0, capsys.readouterr().err
    _same_arrays(d, plain)
    assert _hidden(tmp_path) == [] and not leftovers(d)


@pytest.mark.parametrize("spelling", ["R/../R", "."])
def test_run_force_through_the_directory_replaces_it(finished, tmp_path, monkeypatch, capsys,
                                                     spelling):
    """`run -o R/../R --force` ended with R gone; `-o .` inside R made its hidden copy inside
    R. Now R is replaced by the new run (its own marker, the end time asked), exit 0."""
    d = copy_run(finished, tmp_path / "R")
    old_id = json.loads((d / ".stickslip").read_text())["id"]
    monkeypatch.chdir(tmp_path if spelling != "." else d)
    rc = main(["run", str(SMOKE), "-o", spelling, "--force", *QUIET,
               "--set", "time.end_time=0.003"])
    monkeypatch.chdir(tmp_path)  # `.` was the old R, swapped out and deleted
    assert rc == 0, capsys.readouterr().err
    assert json.loads((d / ".stickslip").read_text())["id"] != old_id
    assert _summary(d)["status"] == "completed"
    assert _summary(d)["sim_time_s"] == pytest.approx(0.003, abs=_summary(d)["dt_s"])
    assert _hidden(tmp_path) == [] and not leftovers(d)


# ------------------------------------------------------------------ every command, every spelling

#: Each command's argv with {p}: the spelling of X under test, {run}: a finished run that is
#: not X, {new}: a folder that does not exist; and what X is (a finished run, or a user's
#: folder). Each case is a refusal (exit 2, one line naming X), so it costs the checks only.
COMMANDS = {
    "run -o": (["run", str(SMOKE), "-o", "{p}", *QUIET], "run"),
    "continue RUN": (["continue", "{p}", "--until", "0.001"], "run"),
    "continue -o": (["continue", "{run}", "--until", UNTIL, "-o", "{p}"], "user"),
    "travel -o": (["travel", str(SMOKE), "--k", "4", "-o", "{p}"], "run"),
    "travel --from": (["travel", str(SMOKE), "--k", "4", "--from", "{p}", "-o", "{new}"],
                      "user"),
    "sweep -o": (["sweep", str(REPO / "sweeps" / "smoke4.toml"), "-o", "{p}"], "run"),
    "attractors -o": (["attractors", str(SMOKE), "--starts", "1", "-o", "{p}"], "run"),
    "plot RUN": (["plot", "{p}"], "user"),
    "compare RUN": (["compare", "{p}"], "user"),
}
#: The spellings of X (its folder's name is "X"), and the directory each is given from.
SPELLINGS = {"X/../X": ("{x}/../X", "parent"), "X/.": ("{x}/.", "parent"),
             "X//": ("{x}//", "parent"), "./X": ("./X", "parent"), ".": (".", "x")}


@pytest.mark.parametrize("command", list(COMMANDS))
def test_every_spelling_of_a_directory_is_the_directory(command, finished, tmp_path,
                                                        monkeypatch, capsys):
    """`X/../X`, `X/.`, `X//`, `./X` and `.` (inside X) are X: the same exit status and the
    same one line as X itself; X and its folder unchanged."""
    argv, what = COMMANDS[command]
    other = copy_run(finished, tmp_path / "other")
    x = tmp_path / "X"
    if what == "run":
        copy_run(finished, x)
    else:
        x.mkdir()
        (x / "notes.txt").write_text("keep")
    before, names = digest(x), sorted(os.listdir(tmp_path))

    def refused(spelling: str, where: Path) -> tuple[int, str]:
        monkeypatch.chdir(where)
        new = tmp_path / "new"
        rc, err = cli(capsys, *(a.format(p=spelling, run=other, new=new) for a in argv))
        assert digest(x) == before and sorted(os.listdir(tmp_path)) == names, spelling
        return rc, err

    expected = refused(str(x), tmp_path)
    one_line(*expected, str(x))
    for spelling, where in SPELLINGS.values():
        got = refused(spelling.format(x=x), x if where == "x" else tmp_path)
        assert got == expected, (spelling, got, expected)
