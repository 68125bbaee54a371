"""Batch sweeps: sweep files, dynamic scheduling, faults, kill + resume, regime map.

Every FE scene here is scenes/smoke.toml (36 contact nodes, 2 layers, 216 dofs) run for a few
hundredths of a second: ~0.2 s per scene after the first one of a process.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from faults import wait_released

from stickslip.studies.sweep import SweepError, is_sweep_dir, load_sweep, scene_for
from stickslip.studies.sweep.schedule import _Monitor, _want_live
from stickslip.studies.sweep.spec import _cost

REPO = Path(__file__).resolve().parents[1]
SMOKE = REPO / "scenes" / "smoke.toml"

# The kill/resume sweep: 3 x 2 scenes, 0.1 s each (~0.35 s of wall time: long enough to be
# killed mid-way). Stick-slip at small Omega / large delta, separation at strong rotation /
# small mismatch (paper section 4).
KILL_SWEEP = f"""
name = "killme"
base = "{SMOKE}"
set = ["time.end_time=0.1"]
[grid]
"loading.omega" = [2.0, 20.0, 100.0]
"geometry.delta" = [4e-4, 5e-3]
[map]
k = [4]
"""


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def _starts(out: Path) -> dict[str, int]:
    """Number of attempts of each scene (one '== start' line per run_scene call)."""
    return {p.stem: p.read_text().count("== start") for p in (out / "logs").glob("*.log")}


def _rows(out: Path) -> dict[str, dict]:
    return {r["id"]: r for r in json.loads((out / "sweep.json").read_text())["rows"]}


def _env() -> dict[str, str]:
    env = dict(os.environ)
    for key in list(env):  # a parent under mpirun must not leak its job into the child
        if key.startswith(("PMIX_", "OMPI_COMM_WORLD", "PMI_")):
            del env[key]
    return env


# ------------------------------------------------------------------------ sweep files (no FE)


def test_grid_points_ids_and_overrides(tmp_path):
    path = _write(tmp_path / "s.toml", f"""
base = "{SMOKE}"
set = ["time.end_time=0.01"]
[grid]
loading.omega = [2.0, 50.0]
"geometry.delta" = [2e-4, 1e-3, 5e-3]
[[points]]
"initial.seed" = 1
"initial.perturbation" = "random"
[[points]]
"initial.seed" = 2
"initial.perturbation" = "random"
""")
    spec = load_sweep(path)
    assert spec.name == "s" and spec.group_size == 1
    assert spec.keys == ("initial.seed", "initial.perturbation", "loading.omega",
                         "geometry.delta")
    assert len(spec.tasks) == 2 * 2 * 3  # points x grid, grid in file order (last key fastest)
    first = spec.tasks[0]
    assert first.id == "seed-1_perturbation-random_omega-2.0_delta-0.0002"
    assert [t.params["geometry.delta"] for t in spec.tasks[:3]] == [2e-4, 1e-3, 5e-3]
    sc = scene_for(spec, spec.tasks[-1])
    assert (sc.loading.omega, sc.geometry.delta, sc.initial.seed) == (50.0, 5e-3, 2)
    assert sc.time.end_time == 0.01 and sc.output.progress is False
    assert sc.name == f"s.{spec.tasks[-1].id}"
    # Largest first (LPT): cost ~ N^3 t_end, so a 4x longer run of the same mesh costs 4x.
    big = sc.with_overrides("time.end_time=0.04")
    assert _cost(big) == pytest.approx(4 * _cost(sc), rel=1e-12)


def test_shipped_omega_delta_sweep_is_valid():
    spec = load_sweep(REPO / "sweeps" / "omega_delta.toml")
    assert len(spec.tasks) == 7 * 5 and spec.base == REPO / "scenes" / "figure3_n36.toml"
    assert (spec.map.x, spec.map.y) == ("loading.omega", "geometry.delta")
    sc = scene_for(spec, spec.tasks[0])
    assert (sc.mesh.n_inner, sc.time.end_time, sc.loading.f) == (36, 0.3, 0.7)


def test_shipped_damped_omega_delta_sweep_is_the_same_grid_on_the_damped_setting():
    """same Omega x delta grid as omega_delta.toml, converged setting."""
    spec = load_sweep(REPO / "sweeps" / "omega_delta_damped.toml")
    undamped = load_sweep(REPO / "sweeps" / "omega_delta.toml")
    assert [t.overrides for t in spec.tasks] == [t.overrides for t in undamped.tasks]
    assert spec.base == REPO / "scenes" / "figure3_n132_damped.toml"
    sc = scene_for(spec, spec.tasks[0])
    assert (sc.mesh.n_inner, sc.time.beta2, sc.time.end_time, sc.loading.f) == (132, 0.5, 0.3, 0.7)
    assert (sc.damping.loss_factor, sc.damping.reference_frequency_hz) == (0.02, 1600.0)


def test_compress_key_chooses_deflated_or_stored_samples(tmp_path):
    """``compress`` (default true) reaches the batches (``RunDirectory.save_member``)."""
    assert load_sweep(_write(tmp_path / "a.toml", f'base = "{SMOKE}"\n')).compress is True
    spec = load_sweep(_write(tmp_path / "b.toml", f'base = "{SMOKE}"\ncompress = false\n'))
    assert spec.compress is False


@pytest.mark.parametrize("body, words", [
    ('[grid]\n"loading.omegga" = [1.0]', ["loading.omegga", "omega"]),
    ('[grid]\n"loading.omega" = 5.0', ["non-empty list"]),
    ('[grid]\n"geometry.delta" = [1e-3, -1.0]', ["delta-", "geometry.delta", "> 0"]),
    ('[grid]\n"loading.omega" = [1.0, 1.0]', ["appears twice"]),
    ('group_size = 0', ["group_size"]),
    ('[map]\nx = "loading.f"', ["map.x", "not a swept key"]),
    ('colour = 1', ["unknown key 'colour'"]),
    ('compress = "no"', ["compress", "true or false"]),
])
def test_invalid_sweep_files_name_the_key(tmp_path, body, words):
    path = _write(tmp_path / "bad.toml", f'base = "{SMOKE}"\n{body}\n')
    with pytest.raises(SweepError) as err:
        load_sweep(path)
    for w in words:
        assert w in str(err.value)


def test_progress_modes_and_status_line(tmp_path, monkeypatch):
    class Tty(io.StringIO):
        def isatty(self) -> bool:
            return True

    for var in ("OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK", "CI"):
        monkeypatch.delenv(var, raising=False)
    monkeypatch.setenv("TERM", "xterm")
    assert _want_live("auto", Tty()) and not _want_live("auto", io.StringIO())
    monkeypatch.setenv("PMIX_RANK", "0")  # mpirun gives ranks a pseudo-TTY: no live line
    assert not _want_live("auto", Tty()) and _want_live("live", io.StringIO())
    spec = load_sweep(_write(tmp_path / "s.toml", KILL_SWEEP))
    mon = _Monitor(tmp_path, spec, spec.tasks[2:], 2, Tty(), live=True)
    line = mon.status_line()
    assert line.startswith("sweep killme: 2/6 done, 0 running, 0 failed") and "ETA ?" in line


def test_the_batch_plan_is_one_line_however_many_batches(tmp_path):
    """The plan listed every batch's size ("251 batch(es) of 4, 4, 4, ... scenes"): a line
    of a thousand characters for a large sweep. Now one entry per size."""
    from stickslip.studies.sweep.schedule import _announce

    spec = load_sweep(_write(tmp_path / "s.toml", KILL_SWEEP))
    out = io.StringIO()
    units = [["a"] * 4] * 250 + [["b"] * 2] + [["c"]]
    _announce(spec, tmp_path, units, 0, 2, 1, "cpu", out)
    assert out.getvalue().splitlines()[1] == (
        "  batched (cpu): 251 batch(es) (250 × 4, 1 × 2 scenes), 1 single scene(s)")


def test_a_batch_writes_its_progress_into_its_members_logs(tmp_path, monkeypatch):
    """A batch's scenes finish together, so a long batched sweep (or a census's starts)
    said nothing for hours, where scenes run alone finish one by one. Its progress line now
    goes into every member's log; every sample is "due" here (``Progress.due`` made
    wall-clock free, as no test waits on the clock)."""
    pytest.importorskip("dolfinx")
    from stickslip.cli.main import main
    from stickslip.solver.observers import Progress

    monkeypatch.setattr(Progress, "due", lambda self: self.enabled)
    spec = _write(tmp_path / "s.toml", f'base = "{SMOKE}"\nbatch = 2\nset = '
                  '["time.end_time=0.002"]\n[grid]\n"loading.omega" = [2.0, 3.0]\n')
    assert main(["sweep", str(spec), "-o", str(tmp_path / "out")]) == 0
    for log in (tmp_path / "out" / "logs").iterdir():
        lines = log.read_text().splitlines()
        progress = [line for line in lines if line.startswith("  t = ")]
        # a line at every sample: 0.002 s at smoke's 1e-4 s sample interval is about 20
        # (10 leaves room for the step's rounding of the interval)
        assert "batch of 2" in lines[0] and len(progress) >= 10, lines
        assert "(100.0%)  step 26" in progress[-1], progress[-1]  # 26 steps to 0.002 s


# ------------------------------------------------------------------------ FE sweeps


def test_failures_divergence_resume_and_retry(tmp_path, monkeypatch):
    """A raising and a diverging scene are recorded and the sweep goes on; resume skips."""
    pytest.importorskip("dolfinx")
    from mpi4py import MPI

    import stickslip.solver.scene_column  # noqa: F401 (loaded: used as an attribute)
    from stickslip import solver
    from stickslip.studies.sweep import run_sweep, write_table

    original = solver.scene_column.SceneColumn.sample

    def sample(self, stepper):  # Omega = 5: pretend the scheme blows up after one sample
        found = original(self, stepper)
        if self.scene.loading.omega == 5.0 and self.records.samples.n > 1:
            return {0: "forced divergence for the test"}
        return found

    monkeypatch.setattr(solver.scene_column.SceneColumn, "sample", sample)
    body = f"""
base = "{SMOKE}"
set = ["time.end_time=0.02"]
[[points]]
"loading.omega" = 2.0
[[points]]
"loading.omega" = 5.0
[[points]]
"time.dt" = 1.0
"""
    spec = load_sweep(_write(tmp_path / "f.toml", body))
    out = tmp_path / "out"
    log = io.StringIO()
    rc = run_sweep(spec, out, comm=MPI.COMM_SELF, stream=log, progress="lines")
    assert rc == 1  # the table holds a scene that raised
    rows = _rows(out)
    assert {k: r["status"] for k, r in rows.items()} == {
        "omega-2.0": "completed", "omega-5.0": "diverged", "dt-1.0": "failed"}
    assert rows["omega-5.0"]["regime"] == "diverged"
    assert "forced divergence" in rows["omega-5.0"]["message"]
    assert rows["dt-1.0"]["message"].startswith("StepTooLarge: time.dt = 1 s is above")
    # Table = summaries, exactly (CSV floats are repr()s, so they round-trip bit for bit).
    ok = rows["omega-2.0"]
    summary = json.loads((out / "runs" / "omega-2.0" / "summary.json").read_text())
    assert ok["celerity_m_s"] == summary["celerity_m_s"] and ok["mode"] == summary["mode"]
    with open(out / "sweep.csv") as fh:
        csv_rows = {r["id"]: r for r in csv.DictReader(fh)}
    assert float(csv_rows["omega-2.0"]["celerity_m_s"]) == ok["celerity_m_s"]
    assert csv_rows["dt-1.0"]["status"] == "failed"
    # Physics: at Omega = 2 rad/s the limit regime is a stick-slip wave (paper figure 2):
    # stick present, no separation (0.5 % = the classification threshold).
    assert ok["regime"] == "stick-slip" and ok["fraction_separation"] < 0.005
    assert "[3/3]" in log.getvalue()  # one line per finished scene, not a TTY
    assert _starts(out) == {"omega-2.0": 1, "omega-5.0": 1, "dt-1.0": 1}

    # Resume: everything is final, nothing runs again.
    assert run_sweep(spec, out, comm=MPI.COMM_SELF, stream=io.StringIO()) == 1
    assert _starts(out) == {"omega-2.0": 1, "omega-5.0": 1, "dt-1.0": 1}
    # --retry-failed runs the failed and the diverged scene again, only those.
    run_sweep(spec, out, comm=MPI.COMM_SELF, stream=io.StringIO(), retry_failed=True)
    assert _starts(out) == {"omega-2.0": 1, "omega-5.0": 2, "dt-1.0": 2}
    # A changed sweep file (another end time) reruns the finished scene it changes.
    spec2 = load_sweep(_write(tmp_path / "f.toml", body.replace("0.02", "0.021")))
    run_sweep(spec2, out, comm=MPI.COMM_SELF, stream=io.StringIO())
    assert _starts(out)["omega-2.0"] == 2 and _rows(out)["omega-2.0"]["steps"] > ok["steps"]
    # A run SIGKILLed between its first summary and the wave analysis (mpirun's SIGKILL
    # ~0.3 s after SIGTERM) is saved but unanalysed: the table says so, resume runs it again.
    path = out / "runs" / "omega-2.0" / "summary.json"
    first = {k: v for k, v in json.loads(path.read_text()).items()
             if k not in ("regime", "mode", "celerity_m_s")}
    path.write_text(json.dumps({**first, "analysis": "pending"}))
    write_table(out, spec2)
    assert _rows(out)["omega-2.0"]["status"] == "unanalysed"
    run_sweep(spec2, out, comm=MPI.COMM_SELF, stream=io.StringIO())
    assert _starts(out)["omega-2.0"] == 3
    again = _rows(out)["omega-2.0"]
    assert again["status"] == "completed" and again["regime"] == "stick-slip"


def _checked_on_rank0(comm, check) -> None:  # noqa: ANN001
    """Run ``check()`` (assertions on rank 0's files) on rank 0 and fail on every rank if it
    fails: a failure on one rank alone would leave the others waiting in the next
    collective (the whole parallel session hung)."""
    problem = None
    if comm.rank == 0:
        try:
            check()
        except AssertionError as err:
            problem = f"rank 0: {err!r}"
    problem = comm.bcast(problem, root=0)
    assert problem is None, problem


@pytest.mark.parallel
def test_slow_scene_does_not_stall_the_others(tmp_path):
    """Dynamic scheduling under mpirun -n 2: the slow scene is handed out first (largest cost
    first) and every scene runs exactly once. Which rank runs how many depends on their
    speeds on a loaded machine (wall-clock), so it is not asserted."""
    pytest.importorskip("dolfinx")
    from mpi4py import MPI

    from stickslip.studies.sweep import run_sweep
    from stickslip.studies.sweep.schedule import _classify

    comm = MPI.COMM_WORLD
    root = Path(comm.bcast(str(tmp_path) if comm.rank == 0 else None, root=0))
    points = ['"loading.omega" = 1.0\n"time.end_time" = 0.5']  # ~6500 steps: the slow one
    points += [f'"loading.omega" = {om}\n"time.end_time" = 0.005' for om in (2.0, 5.0, 10.0,
                                                                               20.0)]
    body = f'base = "{SMOKE}"\n' + "".join(f"[[points]]\n{p}\n" for p in points)
    if comm.rank == 0:
        _write(root / "p.toml", body)
        _write(root / "p2.toml", f'base = "{SMOKE}"\n'
               + "".join(f"[[points]]\n{p}\n" for p in points[1:]))
    comm.Barrier()
    spec = load_sweep(root / "p.toml")
    slow = "omega-1.0_end_time-0.5"
    order = [t.id for t in _classify(root / "out", spec, retry_failed=False)[0]]
    assert order[0] == slow and len(order) == 5  # the order the counter hands them out
    rc = run_sweep(spec, root / "out", comm=comm, stream=io.StringIO())
    assert rc == 0

    def ran_once() -> None:
        rows = _rows(root / "out")
        assert all(r["status"] == "completed" for r in rows.values())
        ran_by: dict[str, list[str]] = {}
        for log in (root / "out" / "logs").glob("*.log"):
            text = log.read_text()
            assert text.count("== start") == 1  # every scene exactly once
            rank = text.split("world rank ")[1].split()[0]
            ran_by.setdefault(rank, []).append(log.stem)
        assert sum(len(v) for v in ran_by.values()) == 5

    _checked_on_rank0(comm, ran_once)
    # group_size = all ranks: the short scenes again, each on one group of comm.size ranks.
    spec2 = load_sweep(root / "p2.toml")
    rc = run_sweep(spec2, root / "grouped", comm=comm, group_size=comm.size,
                   stream=io.StringIO())
    assert rc == 0

    def same_numbers() -> None:
        one, grouped = _rows(root / "out"), _rows(root / "grouped")
        for sid, row in grouped.items():
            assert row["ranks"] == comm.size
            # Partitioned sums change only the rounding (measured 1e-15 relative).
            assert row["celerity_m_s"] == pytest.approx(one[sid]["celerity_m_s"], rel=1e-9)

    _checked_on_rank0(comm, same_numbers)


def _run_until_then_kill(cmd: list[str], out: Path, n_done: int, log: Path,
                         timeout: float = 300.0) -> int:
    """Start ``cmd``, wait until ``n_done`` scenes saved a completed summary (the program's
    own marker), SIGTERM it, return its code. ``timeout`` only guards against a hang."""
    with open(log, "w") as fh:
        proc = subprocess.Popen(cmd, cwd=REPO, env=_env(), stdout=fh, stderr=subprocess.STDOUT)
        t0 = time.monotonic()
        try:
            done = 0
            while proc.poll() is None:
                done = sum('"completed"' in p.read_text()
                           for p in out.glob("runs/*/summary.json"))
                if done >= n_done:
                    break
                assert time.monotonic() - t0 < timeout, "the sweep hangs"
                time.sleep(0.05)
            assert proc.poll() is None and done >= n_done, log.read_text()
            proc.send_signal(signal.SIGTERM)
            return proc.wait(timeout=timeout)
        finally:
            if proc.poll() is None:
                proc.kill()


def _disk_states(out: Path) -> dict[str, str]:
    """Each scene's state read from its own run directory (what a resume goes by)."""
    from stickslip.studies.sweep.table import live_status

    return {p.parent.name: live_status(json.loads(p.read_text()))
            for p in out.glob("runs/*/summary.json")}


@pytest.fixture(scope="module")
def killed_and_resumed(tmp_path_factory):
    """The 6-scene sweep run serially, killed after 2 scenes, then resumed."""
    pytest.importorskip("dolfinx")
    tmp = tmp_path_factory.mktemp("kill")
    sweep = _write(tmp / "killme.toml", KILL_SWEEP)
    out = tmp / "out"
    cmd = [sys.executable, "-m", "stickslip.cli.main", "sweep", str(sweep), "-o", str(out)]
    rc = _run_until_then_kill(cmd, out, 2, tmp / "first.log")
    wait_released(out)  # every helper of the killed sweep has ended: the files are final
    after_kill = _rows(out)
    disk_kill = _disk_states(out)
    starts_kill = _starts(out)
    second = subprocess.run(cmd, cwd=REPO, env=_env(), capture_output=True, text=True,
                            timeout=300)
    return {"rc_kill": rc, "after_kill": after_kill, "disk_kill": disk_kill,
            "starts_kill": starts_kill, "rc_resume": second.returncode,
            "stdout": (tmp / "first.log").read_text() + second.stdout + second.stderr,
            "resume_stdout": second.stdout, "out": out}


def test_kill_then_resume_completes_and_runs_no_scene_twice(killed_and_resumed):
    k = killed_and_resumed
    assert k["rc_kill"] == 130, k["stdout"]
    # The table written at the interruption is the run directories' own word, scene by
    # scene (a scene that finished while the signal was handled reads completed).
    for sid, row in k["after_kill"].items():
        assert row["status"] == k["disk_kill"].get(sid, "pending"), (sid, row, k["disk_kill"])
    done_before = {i for i, r in k["after_kill"].items() if r["status"] == "completed"}
    # In flight = started but not finished (the signal may land before run_scene made the
    # run directory: then the scene is simply still pending).
    in_flight = set(k["starts_kill"]) - done_before
    assert len(done_before) >= 2 and len(in_flight) <= 1  # serial: one scene in flight
    for sid in in_flight:
        assert k["after_kill"][sid]["status"] in ("interrupted", "pending")
    assert set(k["after_kill"][sid]["status"] for sid in k["after_kill"]) \
        <= {"completed", "interrupted", "pending"}
    assert k["rc_resume"] == 0, k["stdout"]
    rows = _rows(k["out"])
    assert len(rows) == 6 and all(r["status"] == "completed" for r in rows.values())
    starts = _starts(k["out"])
    for sid in rows:  # finished scenes never ran again; the one in flight ran once more
        assert starts[sid] == (2 if sid in in_flight else 1), (sid, starts)
    for sid in in_flight:
        assert "== end interrupted" in (k["out"] / "logs" / f"{sid}.log").read_text()
    # The resumed sweep says nothing stale about the scene it reran and completed.
    assert "interrupted" not in k["resume_stdout"], k["resume_stdout"]
    # Non-TTY output: one line per finished scene, no carriage-return redraws.
    assert "\r" not in k["stdout"], k["stdout"]
    finished = [ln for ln in k["stdout"].splitlines()
                if "] omega-" in ln and "interrupted" not in ln]
    assert len(finished) == 6, k["stdout"]


def test_stick_slip_wave_celerity_and_amplitude_scaling(killed_and_resumed):
    """Paper section 3: stick-slip celerity independent of Omega, amplitude proportional."""
    rows = _rows(killed_and_resumed["out"])
    slow, fast = rows["omega-2.0_delta-0.0004"], rows["omega-20.0_delta-0.005"]
    assert slow["regime"] == fast["regime"] == "stick-slip" and slow["mode"] == fast["mode"]
    # Both stick-slip waves solve the same linear problem for u - u_e forced by the sliding
    # speed R Omega; the 1 % tolerance covers the analysis window (measured: 1e-5, 1e-4).
    assert fast["celerity_m_s"] == pytest.approx(slow["celerity_m_s"], rel=1e-2)
    assert fast["amplitude_m"] / slow["amplitude_m"] == pytest.approx(10.0, rel=1e-2)
    # Strong rotation on a small mismatch: the contact opens (separation above the 0.5 %
    # classification threshold) and the wave travels against the rotation (D < 0).
    sep = rows["omega-100.0_delta-0.0004"]
    assert sep["fraction_separation"] > 0.005 and sep["celerity_m_s"] < 0


@pytest.mark.skipif(shutil.which("mpirun") is None, reason="needs mpirun")
def test_mpirun_kill_resume_gives_the_serial_results(killed_and_resumed, tmp_path):
    """mpirun -n 2: SIGTERM mid-way, resume; results equal the serial sweep's bit for bit."""
    sweep = _write(tmp_path / "killme.toml", KILL_SWEEP)
    out = tmp_path / "out"
    cmd = ["mpirun", "-n", "2", sys.executable, "-m", "stickslip.cli.main", "sweep", str(sweep),
           "-o", str(out)]
    rc = _run_until_then_kill(cmd, out, 2, tmp_path / "first.log")
    assert rc != 0  # mpirun reports the killed job
    wait_released(out)  # the ranks' rescue writers and watchdogs have ended
    # What finished is read from the run directories, not from sweep.json: under mpirun the
    # table is rewritten by rank 0's monitor and may lag a scene that finished just before
    # Open MPI's SIGKILL (0.25 s after SIGTERM).
    # A scene SIGKILLed between saving its run and adding the wave analysis ("analysis":
    # "pending") is not done: the resumed sweep runs it again.
    summaries = {p.parent.name: json.loads(p.read_text())
                 for p in out.glob("runs/*/summary.json")}
    done_before = {sid for sid, s in summaries.items()
                   if s.get("status") == "completed" and "analysis" not in s}
    in_flight = set(_starts(out)) - done_before
    assert len(in_flight) <= 2 and len(done_before) >= 2
    res = subprocess.run(cmd, cwd=REPO, env=_env(), capture_output=True, text=True,
                         timeout=300)
    assert res.returncode == 0, res.stdout + res.stderr
    rows, serial = _rows(out), _rows(killed_and_resumed["out"])
    starts = _starts(out)
    for sid in done_before:
        assert starts[sid] == 1
    assert sum(starts.values()) <= 6 + len(in_flight)
    # One rank per scene: the same arithmetic whichever rank ran it, so identical numbers.
    for sid, row in rows.items():
        for key in ("regime", "mode", "celerity_m_s", "fraction_stick", "amplitude_m"):
            assert row[key] == serial[sid][key], (sid, key)
    assert {r["ranks"] for r in rows.values()} == {1}


def test_regime_map_and_semianalytic_boundary(killed_and_resumed):
    pytest.importorskip("matplotlib")
    from stickslip.solver.scene import load_scene
    from stickslip.studies.sweep import existence_grid, plot_sweep

    out = killed_and_resumed["out"]
    assert is_sweep_dir(out) and not is_sweep_dir(out / "runs" / "omega-2.0_delta-0.0004")
    paths = plot_sweep(out)
    assert [p.name for p in paths] == ["regime_map.png"]
    assert paths[0].stat().st_size > 20_000  # a drawn map, not an empty canvas
    cache = json.loads((out / "semianalytic.json").read_text())
    (entry,) = cache.values()
    grid = entry["stick-slip"]["admissible"]
    # delta rows x Omega columns: the stick-slip wave exists at small Omega / large delta
    # and not at strong rotation on the small mismatch (docs/semianalytic.md).
    assert grid[-1][0] == 1 and grid[0][-1] == 0
    # docs/semianalytic.md, Figure-1 parameters (f = 0.7, k = 4, delta = 1e-3): the
    # stick-slip branch is admissible at Omega = 50 rad/s and not at 60 rad/s.
    base = load_scene(SMOKE)
    assert existence_grid(base, "loading.omega", [50.0, 60.0], "geometry.delta", [1e-3], [4],
                          regime="stick-slip") == [[1, 0]]


def test_xdmf_field_output_for_paraview(tmp_path):
    """output.field_format = "xdmf" writes fields.xdmf (+ .h5) every interval."""
    pytest.importorskip("dolfinx")
    from mpi4py import MPI

    from stickslip.solver.scene import load_scene
    from stickslip.studies.rundir import run_scene

    scene = load_scene(SMOKE, ["time.end_time=0.002", "output.fields=true",
                               "output.field_interval=5e-4", "output.progress=false",
                               "output.field_format=xdmf", "output.field_window=1"])
    summary = run_scene(scene, tmp_path / "run", comm=MPI.COMM_SELF, stream=io.StringIO())
    xdmf = tmp_path / "run" / "fields.xdmf"
    assert xdmf.is_file() and (tmp_path / "run" / "fields.h5").is_file()
    dt, steps = summary["dt_s"], summary["steps"]
    every = round(5e-4 / dt)
    times = sorted({float(t.get("Value")) for t in ET.parse(xdmf).getroot().iter("Time")})
    # Levels 0, every, 2 every, ... written at t_n = n dt, to rounding (1e-9 rel).
    expected = [j * every * dt for j in range(math.ceil(steps / every))]
    assert times == pytest.approx(expected, rel=1e-9)
    names = {a.get("Name") for a in ET.parse(xdmf).getroot().iter("Attribute")}
    assert {"displacement", "velocity", "contact_status", "von_mises"} <= names
