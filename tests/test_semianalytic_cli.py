"""CLI subcommands ``wave`` and ``flutter`` (item 6), via a throwaway parser."""

from __future__ import annotations

import argparse
import json

import pytest

from stickslip.cli.semianalytic import register


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    parser = argparse.ArgumentParser(prog="stickslip")
    sub = parser.add_subparsers(dest="command", required=True)
    register(sub)
    args = parser.parse_args(argv)
    rc = args.func(args)
    out = capsys.readouterr()
    return rc, out.out, out.err


def test_wave_json_stick_slip_example(capsys: pytest.CaptureFixture[str]) -> None:
    # paper's stick-slip example (k = 8, ν = 0.3): 1255.6 m/s against the rotation and
    # 10045 rad/s = 1598.7 Hz (±0.5 on the printed digits)
    rc, out, _ = _run(
        [
            "wave",
            "--nu",
            "0.3",
            "--xi",
            "1.25",
            "--f",
            "1",
            "--k",
            "8",
            "--delta",
            "0.005",
            "--omega",
            "100",
            "--regime",
            "stick-slip",
            "--json",
        ],
        capsys,
    )
    assert rc == 0
    d = json.loads(out)
    assert d["regime"] == "stick-slip"
    assert d["celerity_m_s"] == pytest.approx(-1255.6, abs=0.5)
    assert d["frequency_hz"] == pytest.approx(1598.7, abs=0.5)
    assert d["c"] == pytest.approx(-12.556, abs=1e-3)
    assert d["amplitude"] == 0.0
    for s in d["solutions"]:
        assert {
            "regime",
            "c",
            "celerity_m_s",
            "frequency_hz",
            "psi1",
            "psi2",
            "amplitude",
            "admissible",
            "violated",
        } <= set(s)
        assert s["admissible"] == (s["violated"] is None)


def test_wave_json_figure1_parameters(capsys: pytest.CaptureFixture[str]) -> None:
    # Figure 1 parameters (our finding, docs/semianalytic.md): the only admissible wave is a
    # stick-slip wave at −1670.1 m/s (k = 4: 1063.2 Hz); no stick-slip-separation candidate
    # is admissible. ±0.5 on the printed digits.
    rc, out, _ = _run(
        [
            "wave",
            "--nu",
            "0.3",
            "--xi",
            "1.25",
            "--f",
            "0.7",
            "--k",
            "4",
            "--delta",
            "0.001",
            "--omega",
            "40",
            "--json",
        ],
        capsys,
    )
    assert rc == 0
    d = json.loads(out)
    assert d["regime"] == "stick-slip"
    assert d["celerity_m_s"] == pytest.approx(-1670.1, abs=0.5)
    assert d["frequency_hz"] == pytest.approx(1063.2, abs=0.5)
    sss = [s for s in d["solutions"] if s["regime"] == "stick-slip-separation"]
    assert sss and not any(s["admissible"] for s in sss)
    assert all(isinstance(s["violated"], str) for s in sss)
    assert sum(s["admissible"] for s in d["solutions"]) == 1


def test_wave_none_when_nothing_admissible(capsys: pytest.CaptureFixture[str]) -> None:
    # Ω = 100 at the same δ: the stick-slip branch leaves the Coulomb cone; nothing admissible
    rc, out, _ = _run(
        [
            "wave",
            "--f",
            "0.7",
            "--k",
            "4",
            "--delta",
            "0.001",
            "--omega",
            "100",
            "--regime",
            "stick-slip",
            "--json",
        ],
        capsys,
    )
    d = json.loads(out)
    assert rc == 0 and d["regime"] == "none" and d["c"] is None and d["solutions"]


def test_wave_table_output(capsys: pytest.CaptureFixture[str]) -> None:
    rc, out, _ = _run(
        [
            "wave",
            "--f",
            "1",
            "--k",
            "8",
            "--delta",
            "0.005",
            "--omega",
            "100",
            "--regime",
            "stick-slip",
        ],
        capsys,
    )
    assert rc == 0 and "selected regime: stick-slip" in out and "-1255.6" in out


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["wave", "--nu", "0.5"], "--nu 0.5"),
        (["wave", "--xi", "1.0"], "--xi 1.0"),
        (["wave", "--k", "0"], "--k 0"),
        (["wave", "--delta", "-0.001"], "--delta -0.001"),
        (["flutter", "--nu", "0.7"], "--nu 0.7"),
        (["flutter", "--kmax", "0"], "--kmax 0"),
        (["wave", "--omega", "-1"], "--omega -1.0"),
    ],
)
def test_bad_input_exit_2_one_line(
    argv: list[str], needle: str, capsys: pytest.CaptureFixture[str]
) -> None:
    rc, out, err = _run(argv, capsys)
    assert rc == 2 and out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and needle in lines[0]
    assert "need" in lines[0]  # names the allowed range


def test_flutter_json(capsys: pytest.CaptureFixture[str]) -> None:
    rc, out, _ = _run(
        [
            "flutter",
            "--nu",
            "0.3",
            "--xi",
            "1.25",
            "--f",
            "0.7",
            "--omega",
            "40",
            "--kmax",
            "5",
            "--json",
        ],
        capsys,
    )
    assert rc == 0
    d = json.loads(out)
    assert [m["k"] for m in d["modes"]] == [1, 2, 3, 4, 5]
    for m in d["modes"]:
        assert {"k", "growth_rate_per_s", "phase_speed_m_s", "frequency_hz", "direction"} <= set(m)
        # D < 0 at ν = 0.3, ξ = 1.25: exploding modes travel against the rotation
        assert m["direction"] == "opposite" and m["phase_speed_m_s"] < 0
        assert m["growth_rate_per_s"] > 0


def test_wave_plot_writes_png(tmp_path: object, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("matplotlib")
    png = tmp_path / "w.png"  # type: ignore[operator]
    rc, _, _ = _run(
        [
            "wave",
            "--f",
            "1",
            "--k",
            "8",
            "--delta",
            "0.005",
            "--omega",
            "100",
            "--regime",
            "stick-slip",
            "--plot",
            str(png),
        ],
        capsys,
    )
    assert rc == 0 and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
