"""What a new user meets first: where a relative ``--plot`` goes, and what ``run`` prints
before it starts."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

SMOKE = Path(__file__).resolve().parents[1] / "scenes" / "smoke.toml"


def test_flutter_fe_plot_goes_to_the_current_directory_and_says_where(tmp_path, capsys):
    """A relative --plot is the user's current directory (under ./dev too: it keeps the
    caller's directory); the figure line names the file in full."""
    pytest.importorskip("dolfinx")
    from stickslip.cli.main import main

    (tmp_path / "out").mkdir()
    old = os.getcwd()
    os.chdir(tmp_path)
    try:
        rc = main(["flutter-fe", str(SMOKE), "--fmax-hz", "3000", "--plot", "out/cea.png"])
    finally:
        os.chdir(old)
    assert rc == 0 and (tmp_path / "out" / "cea.png").is_file()
    assert f"figure: {tmp_path / 'out' / 'cea.png'}" in capsys.readouterr().out


def test_the_step_estimate_says_it_is_made_before_meshing(tmp_path, capsys):
    """The estimate bounds dt from the shortest edge (a few per cent off the mesh's own dt):
    its line says so, and the next line gives the steps the run takes."""
    pytest.importorskip("dolfinx")
    from stickslip.cli.main import main

    assert main(["run", str(SMOKE), "--set", "time.end_time=0.002", "-o",
                 str(tmp_path / "r")]) == 0
    out = capsys.readouterr().out
    assert "estimate (before meshing; dt from the shortest edge, the mesh's own dt below)" in out
    assert " steps to t = 0.002 s" in out
