"""What a researcher meets on the first day with the Python API: ``quiet=True`` means no line
on stdout, the progress lines included."""

from __future__ import annotations

import inspect
import subprocess
import sys
from pathlib import Path

import pytest

import stickslip
from stickslip.solver.observers import Progress

REPO = Path(__file__).resolve().parents[1]


def test_quiet_run_prints_no_progress_line(tmp_path, capsys, monkeypatch):
    """A progress line is due every ``Progress.interval`` seconds of wall time, so a short run
    rarely meets one; here every sampled level is due (no clock involved), and a quiet run
    must still print nothing while a loud one prints the lines."""
    monkeypatch.setattr(Progress, "due", lambda self: self.enabled)
    stickslip.run("smoke", tmp_path / "quiet", quiet=True)
    assert capsys.readouterr().out == ""
    stickslip.run("smoke", tmp_path / "loud", quiet=False)
    assert "ETA" in capsys.readouterr().out


def test_the_eta_counts_from_where_the_loop_starts(monkeypatch):
    """A continued run's loop starts at its checkpoint: the ETA took t = 0 as its start and
    the set-up's seconds as the loop's, so continuing 0.3 s to 0.6 s at a steady rate said
    half the time it had left. Now the span from ``begin`` to the end, at the loop's rate
    (a clock of our own: no test waits on wall time)."""
    import io

    import stickslip.solver.observers as observers

    clock = [100.0]
    monkeypatch.setattr(observers.time, "perf_counter", lambda: clock[0])
    out = io.StringIO()
    progress = Progress(end_time=0.6, enabled=True, stream=out)
    clock[0] += 50.0  # the set-up: not the loop's
    progress.begin(0.3)
    clock[0] += 10.0  # 0.1 s of the 0.3 s to go, in 10 s: 20 s left
    progress.update(0.4, 100, None)
    assert "t = 0.4 s (66.7%)" in out.getvalue() and "wall 10.0 s  ETA 20 s" in out.getvalue()


def test_a_census_settle_log_carries_the_batch_progress(tmp_path, monkeypatch):
    """A census's settle legs (its starts continued as batches) said nothing between one
    leg's start and its end, however long; their progress line now goes into the settle
    log (every sample due here: ``Progress.due`` without the clock)."""
    pytest.importorskip("dolfinx")
    from stickslip.cli.main import main

    monkeypatch.setattr(Progress, "due", lambda self: self.enabled)
    out = tmp_path / "census"
    # the tutorial scene at N = 132: 2 of its first 4 starts are unsettled at 0.3 s (seeds
    # 2 and 3, k = 3 and 13), so one settle leg runs to 0.45 s (a few seconds)
    assert main(["attractors", "figure1_n132_damped", "--starts", "4", "--meshes", "132",
                 "--end-time", "0.3", "--max-time", "0.45", "--no-certify", "--yes-i-know",
                 "-o", str(out)]) == 0
    log = (out / "settle-rank0.log").read_text().splitlines()
    progress = [line for line in log if line.startswith("  t = ")]
    assert progress and "(100.0%)" in progress[-1], log


def _pattern(standing: bool, k: int = 4, f_hz: float = 198.0):
    """Synthetic stick-slip samples of mode k at f_hz: travelling against the rotation
    cos(k θ + ω t), or standing cos(k θ) cos(ω t), sampled at 20 points a period."""
    import numpy as np

    from stickslip.solver.contact import SLIP, STICK

    theta = np.linspace(0.0, 2.0 * np.pi, 72, endpoint=False)
    t = np.arange(400) / (20.0 * f_hz)
    w = 2.0 * np.pi * f_hz
    if standing:
        u_theta = np.cos(k * theta)[None, :] * np.cos(w * t)[:, None]
    else:
        u_theta = np.cos(k * theta[None, :] + w * t[:, None])
    u_theta = 1e-4 * u_theta
    status = np.where(u_theta > 0.5e-4, STICK, SLIP).astype(np.int8)  # a stick-slip wave
    return t, theta, np.zeros_like(u_theta), u_theta, status


def test_a_pinned_pattern_is_summarised_as_standing_with_its_frequency():
    """A standing mode-4 pattern has purity 0 (half of |U_4|'s spectral energy at each sign of
    frequency) and is reported as standing, with the 198 Hz a fixed point sees and no
    celerity; the same pattern travelling keeps purity 1 and its celerity
    c = -ω R / k. Tolerances: the sampled spectrum's leakage (Hann window over 20 whole
    periods) puts < 1e-6 of the energy on the wrong side; the frequency comes from the FFT
    bin, 1 / (record length) = 9.9 Hz wide, hence 5 Hz."""
    import numpy as np

    from stickslip.postprocess.analysis import analyse

    standing = analyse(*_pattern(True), d=0.0, radius=1.0, window=1.0)
    assert standing.direction == "standing"
    assert standing.travel_purity < 1e-6
    assert standing.celerity_m_s == 0.0
    assert abs(standing.frequency_hz - 198.0) < 5.0
    travelling = analyse(*_pattern(False), d=0.0, radius=1.0, window=1.0)
    assert travelling.direction == "opposite"
    assert travelling.travel_purity > 1.0 - 1e-6
    assert np.isclose(travelling.celerity_m_s, -2.0 * np.pi * 198.0 / 4, rtol=1e-6)
    assert np.isclose(travelling.frequency_hz, 198.0, rtol=1e-6)


def test_census_api_takes_the_command_options(tmp_path, capsys):
    """``stickslip.attractors`` has the command's options: ``max_time`` equal to ``end_time``
    stops every start at the first leg (without it the default cap of 4 s continued an
    unsettled start 100 times longer), ``along`` returns the census along a key (an integer
    key included), ``quiet`` prints nothing, and the default folder is the command's."""
    pytest.importorskip("dolfinx")
    from stickslip.studies.attractors.census import default_dir

    answer = stickslip.attractors("smoke", tmp_path / "c", starts=2, end_time=0.02,
                                  max_time=0.02, certify=False, quiet=True)
    assert capsys.readouterr().out == ""
    ends = [row["sim_time_s"] for row in answer["starts"]]
    assert len(ends) == 2 and max(ends) < 0.02 + 1e-3  # within a sample of the first leg's end
    along = stickslip.attractors("smoke", tmp_path / "a", starts=1, end_time=0.02,
                                 max_time=0.02, along="mesh.n_radial=2,3", certify=False,
                                 quiet=True)
    assert [p["value"] for p in along["points"]] == [2, 3]
    root = default_dir(stickslip.load_scene("smoke")).parent
    assert root.name == "attractors"
    assert "$STICKSLIP_OUTPUT/attractors/<scene name>" in inspect.getdoc(stickslip.attractors)


@pytest.fixture(scope="module")
def smoke_run(tmp_path_factory):
    pytest.importorskip("dolfinx")
    path = tmp_path_factory.mktemp("smoke") / "run"
    stickslip.run("smoke", path, quiet=True)
    return path


def _cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "stickslip.cli.main", *args], capture_output=True,
                          text=True, cwd=REPO)


def test_export_writes_the_probe_histories_and_draws_their_spectrum(smoke_run, tmp_path):
    """``stickslip export RUN -o FILE.csv --plot FILE.png``: the CSV holds every step of every
    probe exactly as samples.npz has it (10 significant digits: relative 1e-9), and the
    figure is drawn with the CEA's modes marked."""
    import numpy as np

    csv, png = tmp_path / "probe.csv", tmp_path / "signal.png"
    res = _cli("export", str(smoke_run), "-o", str(csv), "--plot", str(png), "--cea",
               "--cea-fmax-hz", "3000")
    assert res.returncode == 0, res.stderr
    with np.load(smoke_run / "samples.npz") as s:
        t, data, deg = s["probe_t"], s["probe_data"], s["probe_deg"]
    table = np.loadtxt(csv, delimiter=",", skiprows=1)
    header = csv.read_text().splitlines()[0].split(",")
    assert header[:3] == ["t_s", f"u_r@{deg[0]:g}deg_m", f"u_theta@{deg[0]:g}deg_m"]
    assert table.shape == (t.size, 1 + 4 * deg.size)
    np.testing.assert_allclose(table[:, 0], t, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(table[:, 1:5], data[0], rtol=1e-9, atol=1e-15)
    assert png.stat().st_size > 10_000 and f"figure: {png}" in res.stdout


def test_export_refuses_in_one_line(smoke_run, tmp_path):
    """A missing run, and an output in a folder that does not exist: one line, exit 2."""
    for args in (("export", str(tmp_path / "nope"), "-o", str(tmp_path / "a.csv")),
                 ("export", str(smoke_run), "-o", str(tmp_path / "no" / "a.csv")),
                 ("export", str(smoke_run), "-o", str(tmp_path / "a.csv"), "--census",
                  str(tmp_path))):
        res = _cli(*args)
        assert res.returncode == 2 and res.stderr.count("\n") == 1, res.stderr
        assert res.stderr.startswith("error: ")


def test_the_spectrum_reads_a_sine_at_its_amplitude():
    """``postprocess.probes.spectrum``: A cos(2π f t) at a bin's frequency reads A at f (the
    Hann window's coherent gain is divided out; exact at a bin, to round-off)."""
    import numpy as np

    from stickslip.postprocess.probes import spectrum

    t = np.arange(4096) * 1e-4
    freqs, amp = spectrum(t, 3e-4 * np.cos(2 * np.pi * 100 / (4096 * 1e-4) * t))
    i = int(np.argmax(amp))
    assert abs(freqs[i] - 100 / 0.4096) < 1e-9
    assert abs(amp[i] - 3e-4) < 1e-8 * 3e-4  # round-off of a 4096-point FFT


def test_cea_tables_list_every_mode_and_the_lock_in_points():
    """The complex-eigenvalue table has every computed mode, stable ones too, with
    Im λ = 2π f and ζ = −Re λ / |λ| (to round-off, 1e-12); along f = 0, 0.3, 0.7 every
    wavenumber that grows is stable at f = 0 (no friction, no flutter), so its lock-in lies
    between 0 and the first f where it grows."""
    pytest.importorskip("dolfinx")
    import math

    from stickslip.studies.flutter_fe.tables import csv_text, lock_in_points, mode_rows

    results = stickslip.cea_friction_sweep("smoke", [0.0, 0.3, 0.7], fmax_hz=3000.0)
    rows = mode_rows(results[-1])
    assert len(rows) == len(results[-1].modes)
    assert sum(r["unstable"] for r in rows) == len(results[-1].unstable()) > 0
    assert [r["frequency_hz"] for r in rows] == sorted(r["frequency_hz"] for r in rows)
    for r in rows:
        assert math.isclose(r["im_lambda_rad_s"], 2 * math.pi * r["frequency_hz"])
        size = math.hypot(r["re_lambda_per_s"], r["im_lambda_rad_s"])
        assert abs(r["damping_ratio"] + r["re_lambda_per_s"] / size) < 1e-12
    points = lock_in_points(results)
    assert points and all(p["f_stable"] == 0.0 and p["f_unstable"] in (0.3, 0.7)
                          for p in points)
    assert csv_text(rows).splitlines()[0].startswith("mode,frequency_hz,re_lambda_per_s")


def test_flutter_fe_writes_the_csv_tables(tmp_path):
    """``flutter-fe --csv FILE --f-sweep``: FILE has every computed mode (as many rows as the
    JSON's modes), the sweep table has each f's modes, the lock-in table one row per
    wavenumber that grows, each named on a ``table:`` line."""
    pytest.importorskip("dolfinx")
    import csv as csv_module
    import json

    base = tmp_path / "cea.csv"
    res = _cli("flutter-fe", "smoke", "--fmax-hz", "3000", "--f-sweep", "0,0.7", "--csv",
               str(base), "--json")
    assert res.returncode == 0, res.stderr
    out = json.loads(res.stdout)
    rows = list(csv_module.DictReader(base.open()))
    assert len(rows) == out["modes_in_band"]
    assert sum(int(r["unstable"]) for r in rows) == out["unstable_count"] > 0
    sweep = list(csv_module.DictReader((tmp_path / "cea_f_sweep.csv").open()))
    assert {float(r["f"]) for r in sweep} == {0.0, 0.7}
    lock_in = list(csv_module.DictReader((tmp_path / "cea_lock_in.csv").open()))
    assert lock_in and all(float(r["f_unstable"]) == 0.7 for r in lock_in)
    assert out["tables"] == [str(base), str(tmp_path / "cea_f_sweep.csv"),
                             str(tmp_path / "cea_lock_in.csv")]


def test_a_users_cross_section_has_no_reduced_column_and_pure_rows_only():
    """The four-clamp tube: the per-k table lists only modes of purity >= 0.5 (as the
    doublet table), so no k that the doublet table finds no pure mode for, and no column of
    the reduced model, which describes the axisymmetric tube only."""
    pytest.importorskip("dolfinx")
    res = _cli("flutter-fe", "tube_four_clamps", "--fmax-hz", "2000")
    assert res.returncode == 0, res.stderr
    text = res.stdout
    per_k = text[text.index("per k"):text.index("±k doublets")].splitlines()
    assert "reduced model eq. [2]" not in per_k[1]
    assert "no reduced-model column" in per_k[-1]
    pure = {int(line.split("|")[0]) for line in per_k[2:-1]}
    empty = {int(line.split()[0]) for line in text[text.index("±k doublets"):].splitlines()
             if "no mode of purity" in line}
    assert pure and not pure & empty


def test_fields_bp_reads_into_pyvista_and_renders_a_frame(tmp_path):
    """The documented Python route for ``fields.bp``/``stress.bp``: every frame's time, the
    mesh of the run (36 x 2 smoke mesh: 108 nodes, 144 triangles), the contact pressure only
    on the contact circle r = R (to round-off of the mesh's coordinates, 1e-9 R), finite von
    Mises stresses, and a rendered PNG."""
    pytest.importorskip("dolfinx")
    import numpy as np

    from stickslip.postprocess.vtx import read_vtx_frame, render_vtx_frame, vtx_times

    run = tmp_path / "fields"
    stickslip.run("smoke", run, quiet=True, overrides={
        "output.fields": True, "output.field_interval": 2e-3, "output.field_window": 0.01})
    times = vtx_times(run / "fields.bp")
    assert times.size == 5 and np.all(np.diff(times) > 0)
    grid, t = read_vtx_frame(run / "fields.bp")
    assert (grid.n_points, grid.n_cells) == (108, 144) and t == times[-1]
    r = np.hypot(grid.points[:, 0], grid.points[:, 1])
    pressed = grid.point_data["contact_pressure"] > 0
    assert pressed.any() and np.all(np.abs(r[pressed] - 1.0) < 1e-9)
    stress, _ = read_vtx_frame(run / "stress.bp", frame=0)
    assert np.all(np.isfinite(stress.cell_data["von_mises"]))
    png = render_vtx_frame(run / "fields.bp", tmp_path / "frame.png", "contact_pressure")
    assert png.stat().st_size > 10_000
    with pytest.raises(IndexError, match="holds 5 frames"):
        read_vtx_frame(run / "fields.bp", frame=5)
