"""Hostile but fair inputs: symbolic links where stickslip writes, full disks, hang-ups,
aliased waves, mismatched runs, and the papercuts a new user hit.

Each test is one case that failed before its fix: the command refuses in one line with exit
status 2, or records the true status, and never writes a file it did not make.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
from faults import digest, leftovers
from test_ownership import SMOKE, cli, copy_run, one_line, run

from stickslip.cli.main import main

REPO = Path(__file__).resolve().parents[1]
SHORT_SET = sum((["--set", s] for s in ("time.end_time=0.005", "output.progress=false")), [])



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
    from stickslip.studies.rundir.ownership import owned

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


def test_a_batch_members_directory_is_in_use_while_its_batch_runs(finished, tmp_path, capsys):
    """A batch lets each member's lock go once its directory is claimed (B open files
    otherwise), so `run -o SWEEP/runs/ID --force` replaced a member while its batch ran, and
    the batch then wrote its files over the user's run. The member's ``running`` summary
    names the batch's live process: now refused in one line; a dead one's is replaced."""
    import socket
    import subprocess

    d = copy_run(finished, tmp_path / "r")
    batch = subprocess.Popen(["sleep", "600"])  # the batch's process, alive
    try:
        running = {"scene": "s.omega-2.0", "status": "running", "pid": batch.pid,
                   "host": socket.gethostname()}
        (d / "summary.json").write_text(json.dumps(running))
        rc, err = cli(capsys, "run", SMOKE, "-o", d, "--force", *SHORT_SET)
        one_line(rc, err, f"is in use by a running stickslip command (pid {batch.pid}")
        assert json.loads((d / "summary.json").read_text()) == running
    finally:
        batch.kill()
        batch.wait()
    assert cli(capsys, "run", SMOKE, "-o", d, "--force", *SHORT_SET)[0] == 0  # it died
    assert json.loads((d / "summary.json").read_text())["status"] == "completed"


@pytest.mark.parametrize("batch", ["off", 2])
def test_a_sweep_never_appends_to_a_symlinked_log(tmp_path, capsys, batch):
    """A sweep's `logs/ID.log` -> a user's file: the resume appended to the user's file (a
    scene alone; a batch's members, whose logs were opened by a plain ``open``)."""
    pytest.importorskip("dolfinx")
    spec = tmp_path / "s.toml"
    batched = batch != "off"
    spec.write_text(f'base = "{SMOKE}"\nset = ["time.end_time=0.002", "output.progress=false"]'
                    f'\nbatch = {batch!r}\n[grid]\n"loading.omega" = '
                    f'{[2.0, 3.0] if batched else [2.0]}\n'.replace("'", '"'))
    out = tmp_path / "out"
    assert cli(capsys, "sweep", spec, "-o", out)[0] == 0
    logs = [out / "logs" / f"{run_dir.name}.log" for run_dir in (out / "runs").iterdir()]
    for log in logs:
        (out / "runs" / log.stem / "summary.json").unlink()  # the scene runs again on resume
        log.unlink()
        log.symlink_to(tmp_path / f"diary-{log.stem}.txt")
        (tmp_path / f"diary-{log.stem}.txt").write_text("keep")
    assert cli(capsys, "sweep", spec, "-o", out)[0] == 0
    for log in logs:
        assert (tmp_path / f"diary-{log.stem}.txt").read_text() == "keep"
        assert not log.is_symlink() and "== start" in log.read_text()
        assert ("batch of 2" in log.read_text()) == batched
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


# ------------------------------------------------------------------ statuses


def _one_point_sweep(tmp_path: Path, omegas: str = "[2.0, 3.0]") -> Path:
    spec = tmp_path / "s.toml"
    spec.write_text(f'base = "{SMOKE}"\nset = ["time.end_time=0.005", "output.progress=false"]'
                    f'\n[grid]\n"loading.omega" = {omegas}\n')
    return spec


def _full_disk_for(monkeypatch, run_id: str, fit: int) -> None:
    """Every write into ``runs/run_id`` after the first ``fit`` fails with ENOSPC, as on a
    full disk (so the scene's own summary cannot record its failure)."""
    import errno

    import stickslip.solver.atomic  # noqa: F401 (loaded: used as an attribute)
    import stickslip.solver.run  # noqa: F401 (loaded: used as an attribute)
    from stickslip import solver

    real = solver.atomic.atomic_write
    seen = []

    def write(path, fill):  # noqa: ANN001, ANN202
        if Path(path).parent.name.startswith((run_id, f".{run_id}.new")):
            seen.append(Path(path).name)
            if len(seen) > fit:
                raise OSError(errno.ENOSPC, "No space left on device (injected)")
        return real(path, fill)

    monkeypatch.setattr(solver.atomic, "atomic_write", write)


def test_a_write_that_fails_names_its_file(tmp_path):
    """A full disk fails ``fh.write`` with an OSError that names no file: the one-line errors
    and the summaries' messages said "No space left on device" without saying where. The
    atomic writer now names the file it wrote, and leaves no temporary file."""
    import errno

    from stickslip.solver.atomic import atomic_write

    def full(fh):  # noqa: ANN001 - as a full disk's write fails
        raise OSError(errno.ENOSPC, "No space left on device")

    target = tmp_path / "summary.json"
    with pytest.raises(OSError) as caught:
        atomic_write(target, full)
    assert caught.value.errno == errno.ENOSPC and caught.value.filename == str(target)
    assert str(target) in str(caught.value) and list(tmp_path.iterdir()) == []


def test_a_sweep_with_a_damaged_run_scene_still_plots(tmp_path, capsys):
    """`plot SWEEP` took its map's scene from the first run's scene.toml: a damaged one was
    a SceneError traceback. It is now passed over (the next run's, or the base scene's);
    where none loads, one line naming the fix."""
    pytest.importorskip("dolfinx")
    spec = tmp_path / "s.toml"
    base = tmp_path / "base.toml"
    base.write_text(SMOKE.read_text())
    spec.write_text(f'base = "{base}"\nset = ["time.end_time=0.002", "output.progress=false"]'
                    '\n[grid]\n"loading.omega" = [2.0, 3.0]\n')
    out = tmp_path / "out"
    assert cli(capsys, "sweep", spec, "-o", out)[0] == 0
    runs = sorted((out / "runs").iterdir())
    runs[0].joinpath("scene.toml").write_text("junk")
    assert cli(capsys, "plot", out)[0] == 0
    assert (out / "regime_map.png").is_file()
    runs[1].joinpath("scene.toml").write_text("junk")
    base.unlink()
    rc, err = cli(capsys, "plot", out)
    one_line(rc, err, "no run's scene.toml loads, nor its base scene", "run the sweep again")


@pytest.mark.parametrize("fit", [1, 3, 5], ids=["scene.toml", "samples", "analysis"])
def test_a_full_disk_fails_the_scene_in_the_table_and_the_exit_status(tmp_path, monkeypatch,
                                                                      capsys, fit):
    """A 2 MB tmpfs as -o: the scenes that hit ENOSPC read `unanalysed` in sweep.csv,
    sweep.json and --list, and the sweep exited 0. Now `failed`, with the error, exit 1; a
    resume keeps it failed and --retry-failed runs it again. ``fit``: the writes that fit
    (the marker, scene.toml, the running summary, samples.npz, the pending summary)."""
    pytest.importorskip("dolfinx")
    import csv

    spec, out = _one_point_sweep(tmp_path), tmp_path / "out"
    _full_disk_for(monkeypatch, "omega-2.0", fit)
    assert cli(capsys, "sweep", spec, "-o", out)[0] == 1
    rows = {r["id"]: r for r in json.loads((out / "sweep.json").read_text())["rows"]}
    assert rows["omega-2.0"]["status"] == "failed" and rows["omega-3.0"]["status"] == "completed"
    assert "No space left" in rows["omega-2.0"]["message"]
    with open(out / "sweep.csv") as fh:
        assert {r["id"]: r["status"] for r in csv.DictReader(fh)} == {
            "omega-2.0": "failed", "omega-3.0": "completed"}
    monkeypatch.undo()  # space again
    assert main(["sweep", str(spec), "-o", str(out), "--list"]) == 0
    listed = dict(line.split() for line in capsys.readouterr().out.splitlines())
    assert listed == {"omega-2.0": "failed", "omega-3.0": "completed"}
    assert cli(capsys, "sweep", spec, "-o", out)[0] == 1  # resumed: still failed, not rerun
    assert cli(capsys, "sweep", spec, "-o", out, "--retry-failed")[0] == 0
    meta = json.loads((out / "sweep.json").read_text())
    assert meta["counts"] == {"completed": 2} and meta["unrecorded_failures"] == {}


def test_sighup_saves_like_sigterm(tmp_path, monkeypatch):
    """SIGHUP (a closed terminal) ended a run in PETSc's MPI_ABORT, `crashed`, blamed on
    "SIGKILL: out of memory", no samples. Now `interrupted` by SIGHUP, samples saved."""
    pytest.importorskip("dolfinx")
    from faults import check_after, inject

    state = inject(monkeypatch, "SIGHUP", "loop")
    s = run(tmp_path / "r")
    assert state["fired"]
    assert s["status"] == "interrupted" and s["message"] == "interrupted by SIGHUP"
    assert check_after(tmp_path / "r", None) == "complete" and s["samples"] >= 2


def test_sighup_stops_a_sweep_like_sigterm(tmp_path, monkeypatch, capsys):
    """A sweep gets SIGHUP between scenes: interrupted (exit 130), resumable."""
    pytest.importorskip("dolfinx")
    import signal

    import stickslip.studies.sweep.schedule as schedule

    real, calls = schedule._run_unit, []

    def unit(*a, **k):  # noqa: ANN002, ANN003, ANN202
        calls.append(1)
        if len(calls) == 2:  # the first scene is done
            os.kill(os.getpid(), signal.SIGHUP)
        return real(*a, **k)

    monkeypatch.setattr(schedule, "_run_unit", unit)
    spec, out = _one_point_sweep(tmp_path), tmp_path / "out"
    assert cli(capsys, "sweep", spec, "-o", out)[0] == 130
    monkeypatch.undo()
    assert main(["sweep", str(spec), "-o", str(out)]) == 0
    assert "1 already done" in capsys.readouterr().out


def test_sigterm_during_travel_continue_saves_like_sigint(tmp_path, monkeypatch, capsys):
    """SIGTERM during `travel --continue` exited 143 and saved nothing (SIGINT saved)."""
    pytest.importorskip("dolfinx")
    import signal

    from stickslip.studies.travel import driver

    calls = []

    def hooked(real):  # noqa: ANN001, ANN202
        def call(*a, **k):  # noqa: ANN002, ANN003, ANN202
            calls.append(1)
            if len(calls) == 2:  # the first point is solved and in the rows
                os.kill(os.getpid(), signal.SIGTERM)
            return real(*a, **k)
        return call

    monkeypatch.setattr(driver, "setup", hooked(driver.setup))
    monkeypatch.setattr(driver, "retarget", hooked(driver.retarget))
    out = tmp_path / "branch"
    rc, err = cli(capsys, "travel", SMOKE, "--k", "4", "--continue", "loading.omega=20:22:3",
                  "-o", out)
    assert rc == 130 and "after 1 of 3 points" in err, err
    assert len(json.loads((out / "branch.json").read_text())) == 1


# ------------------------------------------------------------------ results that cannot be right


def test_samples_that_alias_the_wave_are_flagged(tmp_path, capsys):
    """`run smoke --set time.end_time=60 --set output.sample_interval=0.01` reported a 6.7 Hz
    limit cycle; the wave is 1601 Hz. Here 0.3 s: samples every 2 ms (Nyquist 250 Hz) show
    an 80 Hz wave; the per-step probe sees ~1570 Hz, and the run says so."""
    pytest.importorskip("dolfinx")
    aliased = run(tmp_path / "a", "time.end_time=0.3", "output.sample_interval=0.002")
    assert "aliased" in aliased["warning"] and aliased["probe_frequency_hz"] > 1000
    assert aliased["nyquist_hz"] == pytest.approx(250, rel=0.01)  # 2 ms rounded to steps
    saved = json.loads((tmp_path / "a" / "summary.json").read_text())
    assert saved["warning"] == aliased["warning"]
    rc = main(["run", str(SMOKE), "-o", str(tmp_path / "b"), "--set", "time.end_time=0.3",
               "--set", "output.sample_interval=0.002", "--yes-i-know"])
    assert rc == 0 and "warning: aliased" in capsys.readouterr().out
    fine = run(tmp_path / "c", "time.end_time=0.3")
    assert "warning" not in fine
    # Resolved, the probe and the samples see one wave: they agree within the probe's
    # frequency bin, 1 / (analysis window 0.1 s) = 10 Hz.
    assert fine["probe_frequency_hz"] == pytest.approx(fine["frequency_hz"], abs=10.0)


@pytest.mark.parametrize(("change", "words"), [
    ("loading.omega=60", "is not the scene the run used (edited after the run"),
    ("name=figure3_n36", "is scene 'figure3_n36', but summary.json is of 'smoke' (swapped)"),
    ("mesh.n_inner=48", "is not the scene the run used"),
])
@pytest.mark.parametrize("command", ["plot", "compare"])
def test_a_run_whose_scene_was_edited_or_swapped_is_refused(finished, tmp_path, capsys,
                                                             change, words, command):
    """compare and plot on a run whose scene.toml was edited or swapped used it, exit 0."""
    from stickslip.solver.scene import load_scene, write_scene

    d = copy_run(finished, tmp_path / "r")
    write_scene(load_scene(d / "scene.toml", [change]), d / "scene.toml")
    rc, err = cli(capsys, command, d)
    one_line(rc, err, f"{d / 'scene.toml'}: {words}")


@pytest.mark.parametrize(("change", "words"), [
    ("loading.omega=60", "its loading.omega = 50.0, not 60.0 here"),
    ("mesh.n_inner=48", "its mesh.n_inner = 36, not 48 here"),
])
def test_travel_from_a_run_of_another_scene_is_refused(finished, tmp_path, capsys, change,
                                                       words):
    """travel SCENE --from RUN solved SCENE's wave and reported it "against the run" of
    another scene (exit 0); another number of contact nodes gave a traceback and left an
    empty claimed directory."""
    out = tmp_path / "t"
    rc, err = cli(capsys, "travel", SMOKE, "--k", "4", "--set", change, "--from", finished,
                  "-o", out)
    one_line(rc, err, f"--from: {finished} is a run of another problem: {words}")
    assert not out.exists()


# ------------------------------------------------------------------ tracebacks, exit codes


@pytest.mark.parametrize(("damage", "words"), [
    ("not JSON", "summary.json: not valid JSON"),
    ("no sim_time_s", "sim_time_s is None"),
])
def test_rpo_from_a_damaged_summary_is_one_line(finished, tmp_path, capsys, damage, words):
    """`rpo RUN --period T --shift S` read summary.json raw for the checkpoint's time: a
    JSONDecodeError or KeyError traceback. Now its validated readers: one line, exit 2."""
    d = copy_run(finished, tmp_path / "r")
    summary = d / "summary.json"
    if damage == "not JSON":
        summary.write_text("{garbage")
    else:
        s = json.loads(summary.read_text())
        s.pop("sim_time_s")
        summary.write_text(json.dumps(s))
    rc, err = cli(capsys, "rpo", d, "--period", "0.001", "--shift", "0.1")
    one_line(rc, err, words)


@pytest.mark.parametrize(("argv", "words"), [
    (["flutter-fe", "smoke", "--fmax-hz", "1e12"], "--fmax-hz 1e+12 is far above the mesh's "
                                                   "highest frequency"),
    (["flutter-fe", "smoke", "--kmax", "-1"], "--kmax -1 is out of range: need 1 <= kmax"),
    (["flutter-exact", "--wave-speed", "1e-300"], "--wave-speed 1e-300 gives the density"),
    (["run", "smoke", "--set", "material.E=1e308", "-o", "OUT"], "material.E = 1e+308 is "
                                                                  "out of range"),
    (["run", "smoke", "-o", ""], "-o is empty: give a path"),
    (["travel", "smoke", "--k", "1000", "-o", "OUT"], "--k 1000 is above the highest "
                                                      "wavenumber of mesh.n_inner = 36"),
    (["plot", "ONE"], "holds 1 samples, fewer than the 2 needed"),
    (["wave", "--f", "1.7976931348623157e308"], "--f 1.7976931348623157e+308 is out of range"),
    (["run", "tube3d_figure3_damped", "--set", "geometry.length=1e308", "-o", "OUT"],
     "geometry.length = 1e+308 is out of range: must satisfy 0.001 R <= length <= 1000 R"),
    (["run", "tube3d_figure3_damped", "--set", "geometry.length=1e-300", "--set",
      "mesh.n_axial=2", "-o", "OUT"], "geometry.length = 1e-300 is out of range"),
    (["run", "tube3d_figure3_damped", "--set", "material.E=1e-300", "-o", "OUT"],
     "material.E = 1e-300 is out of range: must satisfy E >= 1"),
    (["run", "tube3d_figure3_damped", "--set", "mesh.n_axial=100000000", "-o", "OUT"],
     "mesh.n_axial = 100000000 is out of range: must satisfy 0 <= n_axial <= 1e7"),
])
def test_bad_input_is_one_line_with_exit_2(tmp_path, capsys, argv, words):
    """Tracebacks (flutter-fe, flutter-exact, a 3D tube's length of 1e308 m), a 10-line SLEPc
    stack (E = 1e308; a 3D tube's E = 1e-300, its mass's inverse overflowing), a gmsh abort
    (a length of 1e308 m in 2 layers), a silent write to runs/ (-o ""), exit 1 after a solve
    (travel --k 1000 at N = 36), numpy warnings and empty figures (plot of a one-sample run):
    now one line, exit 2, nothing written."""
    pytest.importorskip("dolfinx")
    if "ONE" in argv:
        run(tmp_path / "one", "time.end_time=0.003", "output.sample_interval=0.003")
    subs = {"OUT": str(tmp_path / "out"), "ONE": str(tmp_path / "one")}
    before = sorted(Path.cwd().iterdir())
    rc = main([subs.get(a, a) for a in argv])
    captured = capsys.readouterr()
    one_line(rc, captured.err, words)
    assert "Warning" not in captured.out + captured.err
    assert not (tmp_path / "out").exists() and sorted(Path.cwd().iterdir()) == before


def test_a_thread_count_numba_refuses_is_named(tmp_path):
    """NUMBA_NUM_THREADS=0 in the environment (a batch system's template): numba's import
    said "Number of threads specified must be > 0." without naming the variable. Now one
    line that names it and the fix (a fresh process: numba reads it once, at import)."""
    import os
    import subprocess
    import sys

    pytest.importorskip("dolfinx")
    done = subprocess.run([sys.executable, "-m", "stickslip.cli.main", "run", str(SMOKE),
                           "-o", str(tmp_path / "r"), *SHORT_SET], capture_output=True,
                          text=True, env={**os.environ, "NUMBA_NUM_THREADS": "0"}, timeout=300)
    one_line(done.returncode, done.stderr, "NUMBA_NUM_THREADS = 0",
             "unset it or set NUMBA_NUM_THREADS=1")
    assert not (tmp_path / "r").exists()  # refused before anything is written


@pytest.mark.parametrize(("entry", "command", "words"), [
    ("summary.json", ["run", "SMOKE", "--force", "-o", "D"], "holds D/summary.json as"),
    (".stickslip.lock", ["continue", "D", "--until", "0.01"], "holds D/.stickslip.lock as"),
    ("scene.toml", ["rpo", "D", "--period", "0.001", "--shift", "1"],
     "scene.toml: not a regular file"),
    ("summary.json", ["plot", "D"], "summary.json: cannot be read (not a regular file"),
    ("summary.json", ["compare", "D"], "summary.json: cannot be read (not a regular file"),
])
def test_a_fifo_in_a_run_directory_is_refused_not_waited_on(finished, tmp_path, entry,
                                                            command, words):
    """A FIFO where stickslip writes a file: every reader's open waited for a writer, for
    ever (`run --force`, `continue`, `rpo`, `plot`, `compare` hung). Now one line, exit 2.
    A child process with a time limit, so that a regression fails instead of hanging."""
    import os
    import subprocess
    import sys

    d = copy_run(finished, tmp_path / "r")
    (d / entry).unlink()
    os.mkfifo(d / entry)
    argv = [str(SMOKE) if a == "SMOKE" else str(d) if a == "D" else a for a in command]
    done = subprocess.run([sys.executable, "-m", "stickslip.cli.main", *argv,
                           *(SHORT_SET if command[0] == "run" else [])],
                          capture_output=True, text=True, timeout=120)
    one_line(done.returncode, done.stderr, words.replace("D/", f"{d}/"))


def test_a_fifo_deep_in_a_sweep_is_refused_on_resume(tmp_path, capsys):
    """A FIFO as a member's summary.json: the resumed sweep's table waited on it for ever.
    The claim now looks four levels down (a census's starts/runs/ID/summary.json)."""
    import os
    import subprocess
    import sys

    pytest.importorskip("dolfinx")
    spec, out = _one_point_sweep(tmp_path, "[2.0]"), tmp_path / "out"
    assert cli(capsys, "sweep", spec, "-o", out)[0] == 0
    fifo = out / "runs" / "omega-2.0" / "summary.json"
    fifo.unlink()
    os.mkfifo(fifo)
    done = subprocess.run([sys.executable, "-m", "stickslip.cli.main", "sweep", str(spec),
                           "-o", str(out)], capture_output=True, text=True, timeout=120)
    one_line(done.returncode, done.stderr, f"holds {fifo} as something other than a file")


def test_help_and_reference_print_percent_once_and_keep_table_rows():
    """`attractors --help` printed "95 %% Wilson"; the reference, "0.2 %%"; a `|` inside a
    metavar (`5T|4ms|0.01s|all`, `off|auto|B`, `A:B:N|F1,F2,...`) split the reference's table
    rows; the --window default was a Python tuple."""
    import re
    import sys

    from stickslip.cli.main import build_parser

    sub = next(a for a in build_parser()._actions if hasattr(a, "choices") and a.choices)
    assert "%%" not in sub.choices["attractors"].format_help()
    sys.path.insert(0, str(REPO / "docs" / "_ext"))
    from stickslip_reference import cli_markdown

    text = cli_markdown()
    assert "%%" not in text
    for line in text.splitlines():
        if line.startswith("| `"):  # argument | meaning | default | choices
            assert len(re.findall(r"(?<!\\)\|", line)) == 5, line
    window = next(ln for ln in text.splitlines() if ln.startswith("| `--window`"))
    assert window.endswith("| `5T` |  |"), window


def test_license_file_matches_pyproject():
    import tomllib

    meta = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    assert meta["license"] == {"text": "MIT"}
    text = (REPO / "LICENSE").read_text()
    assert text.startswith("MIT License") and "Copyright (c) stickslip maintainers" in text


def test_a_scene_may_name_a_base_scene(tmp_path):
    """Tutorial 2's custom "damped" scene silently got beta2 = 0.6: scenes had no `base =`."""
    from stickslip.solver.scene import SceneError, load_scene, scene_to_dict

    (tmp_path / "damped.toml").write_text(
        'base = "figure1_n132_damped"\n[mesh]\nn_inner = 36\n[material]\nrho = 2000.0\n')
    scene, base = load_scene(tmp_path / "damped.toml"), load_scene("figure1_n132_damped")
    assert scene.name == "damped" and scene.description == ""
    assert scene.mesh.n_inner == 36
    # rho is kept as wave_speed = sqrt(E / rho): one rounding each way
    assert scene.material.rho == pytest.approx(2000.0, rel=1e-14)
    mine, theirs = scene_to_dict(scene), scene_to_dict(base)
    for section in ("time", "damping", "loading", "geometry", "friction"):
        assert mine[section] == theirs[section], section  # beta2 = 0.5, the loss factor
    (tmp_path / "b.toml").write_text(f'base = "{tmp_path / "damped.toml"}"\n'
                                     '[loading]\nomega = 40.0\n')
    chained = load_scene(tmp_path / "b.toml", ["loading.f=0.5"])
    assert (chained.mesh.n_inner, chained.loading.omega, chained.loading.f) == (36, 40.0, 0.5)
    (tmp_path / "c.toml").write_text('base = "c.toml"\n')
    with pytest.raises(SceneError, match="a cycle of bases"):
        load_scene(tmp_path / "c.toml")
    (tmp_path / "d.toml").write_text('base = "nope"\n')
    with pytest.raises(SceneError, match="base = 'nope' not found"):
        load_scene(tmp_path / "d.toml")


def test_a_killed_watchdog_does_not_take_the_run_down(tmp_path):
    """SIGKILL of a run's watchdog: the run's next write to its pipe raised SIGPIPE, which
    PETSc's handler turned into MPI_ABORT near the end (the run lost, `running` forever).
    Now the run goes on and saves as ever."""
    pytest.importorskip("dolfinx")
    import subprocess
    import sys

    driver = tmp_path / "driver.py"
    driver.write_text(f"""
import io, os, signal, sys
from pathlib import Path
from mpi4py import MPI
import stickslip.solver.scene_column
from stickslip import solver
from stickslip.solver.scene import load_scene
from stickslip.studies.rundir import run_scene
real, calls = solver.scene_column.SceneColumn.sample, []
def sample(self, stepper):
    calls.append(1)
    if len(calls) == 3:  # in the time loop: the watchdog is this process's only child
        me = os.getpid()
        for pid in Path(f"/proc/{{me}}/task/{{me}}/children").read_text().split():
            os.kill(int(pid), signal.SIGKILL)
    return real(self, stepper)
solver.scene_column.SceneColumn.sample = sample
s = run_scene(load_scene("smoke", ["time.end_time=0.005", "output.progress=false"]),
              {str(tmp_path / 'r')!r}, comm=MPI.COMM_SELF, stream=io.StringIO())
print(s["status"], len(calls))
""")
    res = subprocess.run([sys.executable, str(driver)], cwd=REPO, capture_output=True,
                         text=True, timeout=300)
    assert res.returncode == 0, res.stdout + res.stderr
    status, checks = res.stdout.split()
    assert status == "completed" and int(checks) > 3
    assert json.loads((tmp_path / "r" / "summary.json").read_text())["status"] == "completed"


@pytest.mark.parametrize(("edit", "words"), [
    ({"parameters": ["no.such.key"]}, "'parameters' names 'no.such.key', which its rows"),
    ({"map": {"x": 5}}, "map.x = 5 is not one a sweep file allows"),
    ({"map": {"junctions": [[1]]}}, "map.junctions = [[1]] is not one"),
])
def test_plot_of_an_edited_sweep_table_is_one_line(tmp_path, capsys, edit, words):
    """plot on a sweep whose sweep.json was edited: a traceback (min() of nothing, KeyError)."""
    from stickslip.studies.sweep.spec import SWEEP_KIND

    d = tmp_path / "sw"
    d.mkdir()
    rows = [{"id": "omega-2.0", "status": "completed", "loading.omega": 2.0}]
    table = {"kind": SWEEP_KIND, "parameters": ["loading.omega"], "rows": rows, **edit}
    (d / "sweep.json").write_text(json.dumps(table))
    rc, err = cli(capsys, "plot", d)
    one_line(rc, err, f"{d / 'sweep.json'}: {words}")


def test_a_resumed_sweep_says_nothing_of_an_earlier_sessions_summary(tmp_path):
    """A resumed sweep printed the stale "interrupted by SIGINT" line of the scene it was
    rerunning (the summary was written less than a second before it started). Only a
    summary written in this session is reported."""
    import io

    from stickslip.studies.sweep import load_sweep
    from stickslip.studies.sweep.schedule import _Monitor

    spec = load_sweep(_one_point_sweep(tmp_path, "[2.0]"))
    run_dir = tmp_path / "out" / "runs" / "omega-2.0"
    run_dir.mkdir(parents=True)
    summary = {"scene": "s.omega-2.0", "status": "interrupted", "message":
               "interrupted by SIGINT", "wall_time_s": 1.0}
    (run_dir / "summary.json").write_text(json.dumps(summary))  # the killed session's
    stream = io.StringIO()
    monitor = _Monitor(tmp_path / "out", spec, spec.tasks, 0, stream, live=False)
    monitor.poll()
    assert stream.getvalue() == ""
    tmp = run_dir / ".summary.json.tmp"  # this session's rerun, written as the runs write
    tmp.write_text(json.dumps(dict(summary, status="failed", message="boom")))
    os.replace(tmp, run_dir / "summary.json")
    monitor.poll()
    assert "omega-2.0: failed: boom" in stream.getvalue()
    assert "interrupted" not in stream.getvalue()


def test_a_command_stops_on_sigint_whatever_handler_it_inherits(tmp_path, monkeypatch):
    """A SIGINT handler left by the caller that only records the signal (an embedding
    program's) made an in-process census ignore Ctrl-C and exit 0; each command now owns
    SIGINT while it runs (KeyboardInterrupt: exit 130) and gives the caller's back after."""
    pytest.importorskip("dolfinx")
    import contextlib
    import io
    import signal
    import sys

    from stickslip.cli.main import main

    sys.path.insert(0, str(Path(__file__).parent))
    from faults import inject

    came: list[int] = []
    previous = signal.signal(signal.SIGINT, lambda signum, frame: came.append(signum))
    try:
        state = inject(monkeypatch, "SIGINT", "setup")
        with contextlib.redirect_stdout(io.StringIO()):
            rc = main(["attractors", "smoke", "--starts", "2", "--end-time", "0.002",
                       "--no-certify", "-o", str(tmp_path / "a")])
        assert state["fired"] and rc == 130 and not came
        assert signal.getsignal(signal.SIGINT) is not signal.default_int_handler  # given back
    finally:
        signal.signal(signal.SIGINT, previous)
