"""``checkpoint.npz`` is read and written without following a symbolic link that stickslip did
not make (the rule of every run file, ``studies.rundir.readers``): a link in its place is
refused in one line when read, and replaced, never written through, when written."""

from __future__ import annotations

import contextlib
import io
from pathlib import Path

import numpy as np
import pytest

SMOKE = Path(__file__).resolve().parents[1] / "scenes" / "smoke.toml"


def test_a_linked_checkpoint_is_refused_and_its_target_untouched(tmp_path, capsys):
    pytest.importorskip("dolfinx")
    from stickslip.cli.main import main

    run = tmp_path / "run"
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["run", str(SMOKE), "--set", "time.end_time=0.002", "-o", str(run)]) == 0
    users = tmp_path / "users.npz"
    (run / "checkpoint.npz").rename(users)  # a valid checkpoint, the user's file now
    (run / "checkpoint.npz").symlink_to(users)
    before = users.read_bytes()
    capsys.readouterr()
    rc = main(["continue", str(run), "--until", "0.004"])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and "symbolic link" in err, err
    assert users.read_bytes() == before and (run / "checkpoint.npz").is_symlink()


def test_writing_a_checkpoint_replaces_a_link_and_leaves_its_target(tmp_path):
    from stickslip.solver.scene import load_scene
    from stickslip.studies.rundir.checkpoint import read_checkpoint, write_checkpoint

    users = tmp_path / "users.txt"
    users.write_text("a user's file")
    (tmp_path / "checkpoint.npz").symlink_to(users)
    state = {"stepper/step_count": np.array(3), "stepper/time": np.array(0.5),
             "run/samples": np.array(1), "run/probe_steps": np.array(0)}
    write_checkpoint(tmp_path, [state], kind="run", scene=load_scene(SMOKE),
                     status="completed", kernel="numba")
    assert users.read_text() == "a user's file"
    assert not (tmp_path / "checkpoint.npz").is_symlink()
    assert read_checkpoint(tmp_path).time == 0.5
