"""Commands that can be made arbitrarily large refuse in one line (exit 2) before any work:
``flutter-fe --f-sweep`` with a huge count, ``travel --continue`` with a huge count or a
branch that leaves the scene's ranges, ``flutter-exact`` near incompressibility, and
``flutter-fe --plot`` at a directory."""

from __future__ import annotations

import pytest

from stickslip.cli.main import main


def one_line(capsys, *argv: str) -> str:
    rc = main([*argv])
    err = capsys.readouterr().err.strip()
    assert rc == 2, err
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    return err


@pytest.mark.parametrize("argv, words", [
    (("flutter-fe", "smoke", "--f-sweep", "0:1:100000"), "at most 200"),
    (("flutter-fe", "smoke", "--plot", "/tmp"), "is a directory"),
    (("travel", "smoke", "--k", "4", "--continue", "loading.omega=50:60:100000"),
     "at most 2000"),
    (("travel", "smoke", "--k", "4", "--continue", "loading.omega=50:inf:3"), "finite"),
    (("travel", "smoke", "--k", "4", "--continue", "loading.omega=50:1e300:3"),
     "out of range"),
    (("travel", "smoke", "--k", "4", "--continue", "geometry.xi=1.25:0.5:3"), "xi > 1"),
    (("flutter-exact", "--nu", "0.4999999"), "--yes-i-know"),
])
def test_a_costly_or_impossible_request_is_refused_in_one_line(capsys, argv, words):
    pytest.importorskip("dolfinx")
    assert words in one_line(capsys, *argv)


def test_a_million_point_sweep_is_refused_before_it_is_expanded(tmp_path, capsys):
    """A 10^6-point sweep was accepted (--list took 96 s and 650 MB)."""
    import time

    spec = tmp_path / "big.toml"
    values = ", ".join(str(10.0 + i) for i in range(1000))
    spec.write_text(f'base = "scenes/smoke.toml"\n[grid]\n"loading.omega" = [{values}]\n'
                    f'"loading.f" = [{", ".join(str(i / 1000) for i in range(1000))}]\n')
    t0 = time.perf_counter()
    err = one_line(capsys, "sweep", str(spec), "--list")
    assert "1000000 scenes" in err and "--yes-i-know" in err
    assert time.perf_counter() - t0 < 10.0  # refused before the grid is expanded
