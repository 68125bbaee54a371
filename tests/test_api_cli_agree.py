"""The Python API and the command line resolve their options in one place: the same arguments
give the same run or wave, bit for bit, and the API's errors name its keyword arguments."""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import numpy as np
import pytest

import stickslip

pytestmark = pytest.mark.dolfinx

#: Summary keys that time the command (wall clock) or measure the process (its peak memory,
#: which the second run in one process may raise), not the wave.
WALL_CLOCK = {"setup_time_s", "wall_time_s", "profile_s", "timings", "started", "finished",
              "message", "peak_rss_mb"}


def _cli(*argv) -> int:
    from stickslip.cli.main import main

    with contextlib.redirect_stdout(io.StringIO()):
        return main([str(a) for a in argv])


def _same_summary(a: dict, b: dict) -> None:
    a = {k: v for k, v in a.items() if k not in WALL_CLOCK}
    b = {k: v for k, v in b.items() if k not in WALL_CLOCK}
    assert json.loads(json.dumps(a, default=float)) == json.loads(json.dumps(b, default=float))


@pytest.mark.parametrize("flags, kwargs", [
    (["--celerity", "-2300", "--fixed-omega"], {"celerity": -2300.0, "fixed_omega": True}),
    (["--inertia", "rotation"], {"inertia": "rotation"}),
], ids=["fixed-celerity", "rotation"])
def test_travel_gives_the_command_lines_wave_bit_for_bit(tmp_path, flags, kwargs):
    """Figure 1's damped scene on N = 36, k = 4: the command's summary and profiles are the
    API's exactly (both call ``studies.travel.command``; no tolerance: same operations)."""
    pytest.importorskip("dolfinx")
    out = tmp_path / "wave"
    assert _cli("travel", "figure1_n132_damped", "--set", "mesh.n_inner=36", "--k", "4",
                *flags, "-o", out) == 0
    summary, profiles = stickslip.travel("figure1_n132_damped", 4,
                                         overrides={"mesh.n_inner": 36}, **kwargs)
    _same_summary(json.loads((out / "summary.json").read_text()), summary)
    with np.load(out / "profiles.npz") as written:
        assert sorted(written.files) == sorted(profiles)
        for name in written.files:
            assert np.array_equal(written[name], profiles[name]), name


def test_travel_defaults_are_the_command_lines(tmp_path):
    """With no option, both take the transient's discrete wave (shift, central, bdf1, the
    matched S). On N = 36 that solve from the reduced start ends on steady sliding: the
    command's recorded failure is the API's exception, to the last residual's bit."""
    pytest.importorskip("dolfinx")
    from stickslip.studies.travel.newton import NotConverged

    out = tmp_path / "wave"
    assert _cli("travel", "figure1_n132_damped", "--set", "mesh.n_inner=36", "--k", "4",
                "-o", out) == 1
    failed = json.loads((out / "summary.json").read_text())
    assert (failed["inertia"], failed["time_scheme"], failed["rate"]) == \
        ("shift", "central", "bdf1")
    with pytest.raises(NotConverged) as err:
        stickslip.travel("figure1_n132_damped", 4, overrides={"mesh.n_inner": 36})
    assert str(err.value) == failed["reason"]
    assert err.value.info["residual"] == failed["last_residual"]


def test_run_gives_the_command_lines_samples_bit_for_bit(tmp_path):
    """The smoke scene (N = 36, 0.02 s) run by ``stickslip run`` and by ``stickslip.run``:
    the same samples.npz arrays and summary (explicit scheme, deterministic on one rank)."""
    pytest.importorskip("dolfinx")
    assert _cli("run", "smoke", "--set", "time.end_time=0.005", "-o", tmp_path / "cli") == 0
    summary = stickslip.run("smoke", tmp_path / "api", overrides={"time.end_time": 0.005},
                            quiet=True)
    _same_summary(json.loads((tmp_path / "cli" / "summary.json").read_text()), summary)
    with np.load(tmp_path / "cli" / "samples.npz") as a, \
            np.load(tmp_path / "api" / "samples.npz") as b:
        assert sorted(a.files) == sorted(b.files)
        for name in a.files:
            assert np.array_equal(a[name], b[name]), name


def test_cea_defaults_are_the_commands(capsys):
    """``stickslip.cea`` uses the scene's friction filter by default, as ``flutter-fe``."""
    pytest.importorskip("dolfinx")
    from stickslip.cli.main import main

    assert main(["flutter-fe", "smoke", "--set", 'friction.filter="1-2-1"', "--fmax-hz",
                 "3000", "--json"]) == 0
    cli = json.loads(capsys.readouterr().out)
    res = stickslip.cea("smoke", overrides={"friction.filter": "1-2-1"}, fmax_hz=3000.0)
    api = json.loads(json.dumps(res.to_dict()))
    assert api["friction"] == cli["friction"] == "1-2-1"
    skip = {"timings_s", "solver"}  # the eigensolver's wall clock
    assert {k: v for k, v in api.items() if k not in skip} == \
        {k: cli[k] for k in api if k not in skip}


def test_api_errors_name_keyword_arguments_not_flags(tmp_path):
    pytest.importorskip("dolfinx")
    run_dir = tmp_path / "r"
    stickslip.run("smoke", run_dir, overrides={"time.end_time": 0.001}, quiet=True)
    with pytest.raises(FileExistsError) as err:
        stickslip.run("smoke", run_dir, overrides={"time.end_time": 0.001}, quiet=True)
    text = str(err.value)
    assert "force=True" in text and "--force" not in text and " -o" not in text
    with pytest.raises(ValueError, match=r"^k= 0: the wavenumber"):
        stickslip.travel("smoke", 0)
    with pytest.raises(ValueError, match=r"rate= bdf2: .*drop rate="):
        stickslip.travel("smoke", 4, rate="bdf2")


def test_travel_branch_quiet_prints_nothing(tmp_path, capsys):
    pytest.importorskip("dolfinx")
    rows = stickslip.travel_branch("figure1_n132_damped", 4, "loading.omega", [50.0, 52.0],
                                   tmp_path / "b", overrides={"mesh.n_inner": 36}, quiet=True)
    assert [r["value"] for r in rows] == [50.0, 52.0]
    assert capsys.readouterr().out == ""
    assert (Path(tmp_path) / "b" / "branch.json").is_file()


def test_samples_that_cannot_resolve_the_expected_wave_are_refused_at_load(tmp_path, capsys):
    """Samples every 10 ms (Nyquist 50 Hz) on the smoke scene, whose wave is ~1.6 kHz (its
    reduced model's flutter mode k = 4: 1.07 kHz): refused before anything is written, in one
    line naming the estimate, the fix and the override, by the command and by the API."""
    pytest.importorskip("dolfinx")
    from stickslip.cli.main import main

    coarse = ["--set", "time.end_time=60", "--set", "output.sample_interval=0.01"]
    assert main(["run", "smoke", *coarse, "-o", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "reduced model's flutter mode k = initial.mode = 4" in err
    assert "output.sample_interval < 0.000468 s" in err and "--yes-i-know" in err
    assert not (tmp_path / "r").exists()
    with pytest.raises(ValueError, match="check_resources=False"):
        stickslip.run("smoke", tmp_path / "r", overrides={"time.end_time": 60,
                                                          "output.sample_interval": 0.01})


def test_sweep_and_census_refusals_are_errors_naming_keyword_arguments(tmp_path):
    """A folder of the user's as the output: the command's one-line refusal, raised as
    ValueError in the API's words (out_dir, not -o), nothing written."""
    pytest.importorskip("dolfinx")
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("mine")
    sweep_file = Path(__file__).resolve().parents[1] / "sweeps" / "smoke4.toml"
    for call in (lambda: stickslip.sweep(sweep_file, mine, quiet=True),
                 lambda: stickslip.attractors("smoke", mine, starts=1, quiet=True)):
        with pytest.raises(ValueError, match="could not start") as err:
            call()
        assert "out_dir" in str(err.value) and " -o" not in str(err.value)
        assert sorted(p.name for p in mine.iterdir()) == ["notes.txt"]
