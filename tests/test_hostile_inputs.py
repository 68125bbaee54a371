"""Hostile but fair inputs: symbolic links where stickslip writes, full disks, hang-ups,
aliased waves, mismatched runs, and the papercuts a new user hit.

Each test is one case that failed before its fix: the command refuses in one line with exit
status 2, or records the true status, and never writes a file it did not make.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from faults import digest, leftovers
from test_ownership import SMOKE, cli, copy_run, one_line, run

REPO = Path(__file__).resolve().parents[1]
SHORT_SET = sum((["--set", s] for s in ("time.end_time=0.005", "output.progress=false")), [])


@pytest.fixture(scope="module")
def finished(tmp_path_factory) -> Path:
    """A finished smoke run (copied by each test that changes it)."""
    pytest.importorskip("dolfinx")
    d = tmp_path_factory.mktemp("done") / "r"
    assert run(d)["status"] == "completed"
    return d


# ------------------------------------------------------------------ symbolic links


def test_a_symlinked_lock_is_never_written_through(finished, tmp_path, capsys):
    """`R/.stickslip.lock` -> a user's file: `run -o R --force` wrote {"pid": ...} into it."""
    d = copy_run(finished, tmp_path / "r")
    victim = tmp_path / "thesis.tex"
    victim.write_text("keep")
    (d / ".stickslip.lock").unlink()
    (d / ".stickslip.lock").symlink_to(victim)
    rc, err = cli(capsys, "run", SMOKE, "-o", d, "--force", *SHORT_SET)
    one_line(rc, err, ".stickslip.lock as a symbolic link", "give the real directory")
    assert victim.read_text() == "keep" and (d / ".stickslip.lock").is_symlink()
    assert not leftovers(d)


def test_a_symlinked_output_directory_is_refused_never_replaced(finished, tmp_path, capsys):
    """A symlinked `-o` with --force was replaced by a real directory (its target stale, a
    `.NAME.old.PID` link left beside it). Now refused in one line; link and target kept."""
    target = copy_run(finished, tmp_path / "real")
    before = digest(target)
    link = tmp_path / "link"
    link.symlink_to(target)
    for extra in ([], ["--force"]):
        rc, err = cli(capsys, "run", SMOKE, "-o", link, *extra, *SHORT_SET)
        one_line(rc, err, f"-o {link} is a symbolic link (to {target})")
    assert link.is_symlink() and digest(target) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link", "real"]


def test_a_symlinked_marker_does_not_make_a_folder_stickslips(tmp_path, capsys):
    """A folder whose `.stickslip` is a link to a real marker is not stickslip's."""
    from studies.rundir.ownership import owned

    pytest.importorskip("dolfinx")
    real = tmp_path / "real"
    run(real)
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep")
    (mine / ".stickslip").symlink_to(real / ".stickslip")
    assert owned(real, "run") and not owned(mine)
    rc, err = cli(capsys, "run", SMOKE, "-o", mine, "--force", *SHORT_SET)
    one_line(rc, err, ".stickslip as a symbolic link")
    assert (mine / "notes.txt").read_text() == "keep"


@pytest.mark.parametrize("name", ["summary.json", "samples.npz", "scene.toml"])
def test_a_symlinked_run_file_is_not_read(finished, tmp_path, capsys, name):
    """compare/plot read a run's files through a link someone put in their place."""
    d = copy_run(finished, tmp_path / "r")
    moved = tmp_path / name
    os.replace(d / name, moved)
    (d / name).symlink_to(moved)
    rc, err = cli(capsys, "compare", d)
    one_line(rc, err, f"{d / name}: is a symbolic link")


def test_a_sweep_never_appends_to_a_symlinked_log(tmp_path, capsys):
    """A sweep's `logs/ID.log` -> a user's file: the resume appended to the user's file."""
    pytest.importorskip("dolfinx")
    spec = tmp_path / "s.toml"
    spec.write_text(f'base = "{SMOKE}"\nset = ["time.end_time=0.005", "output.progress=false"]'
                    '\n[grid]\n"loading.omega" = [2.0]\n')
    out = tmp_path / "out"
    assert cli(capsys, "sweep", spec, "-o", out)[0] == 0
    (run_dir,) = (out / "runs").iterdir()
    (run_dir / "summary.json").unlink()  # the scene runs again on resume
    log = out / "logs" / f"{run_dir.name}.log"
    victim = tmp_path / "diary.txt"
    victim.write_text("keep")
    log.unlink()
    log.symlink_to(victim)
    assert cli(capsys, "sweep", spec, "-o", out)[0] == 0
    assert victim.read_text() == "keep"
    assert not log.is_symlink() and "== start" in log.read_text()
    assert (out / "logs" / f"{log.name}.link").is_symlink()  # set aside, not followed


@pytest.mark.parametrize("name", ["runs", "logs"])
def test_a_sweep_refuses_a_symlinked_folder(tmp_path, capsys, name):
    """`runs/` or `logs/` a link to elsewhere: the resume wrote into the link's target."""
    pytest.importorskip("dolfinx")
    spec = tmp_path / "s.toml"
    spec.write_text(f'base = "{SMOKE}"\nset = ["time.end_time=0.005"]\n'
                    '[grid]\n"loading.omega" = [2.0]\n')
    out = tmp_path / "out"
    assert cli(capsys, "sweep", spec, "-o", out)[0] == 0
    elsewhere = tmp_path / "elsewhere"
    os.replace(out / name, elsewhere)
    (out / name).symlink_to(elsewhere)
    for p in (elsewhere.rglob("summary.json") if name == "runs" else ()):
        p.unlink()  # the scene would run again, into the link's target
    before = digest(elsewhere)
    rc, err = cli(capsys, "sweep", spec, "-o", out)
    one_line(rc, err, f"{out / name} is a symbolic link")
    assert digest(elsewhere) == before and (out / name).is_symlink()
