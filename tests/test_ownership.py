"""Every output directory under one ownership rule, and every file read back validated.

The data-loss cases of an adversarial audit, each a test: ``--force`` on a user's folder
(travel and run), on a live run, two commands on one new ``-o``, a sweep into a user's
folder, user files inside a run folder, a forged summary, Ctrl-C during a ``--force``
rerun; and corrupt, truncated, foreign or edited files read back by plot, compare and a
sweep resume. Runs are the smoke scene for 0.005 s (~1 s each) in this process.
"""

from __future__ import annotations

import io
import json
import multiprocessing
import os
from pathlib import Path

import numpy as np
import pytest
from faults import digest, leftovers

REPO = Path(__file__).resolve().parents[1]
SMOKE = REPO / "scenes" / "smoke.toml"


def _smoke_sweep(tmp_path: Path, omegas: list[float], end_time: float | None = None):
    """The sweep of the smoke scene over ``loading.omega`` (``tmp_path / "s.toml"``)."""
    from stickslip.studies.sweep import load_sweep

    extra = f'set = ["time.end_time={end_time}"]\n' if end_time is not None else ""
    spec_path = tmp_path / "s.toml"
    spec_path.write_text(f'base = "{SMOKE}"\n{extra}[grid]\n"loading.omega" = {omegas}\n')
    return load_sweep(spec_path)
SHORT = ["time.end_time=0.005", "output.progress=false"]


def run(run_dir: Path, *extra: str, force: bool = False) -> dict:
    from mpi4py import MPI

    from stickslip.solver.scene import load_scene
    from stickslip.studies.rundir import run_scene

    return run_scene(load_scene(SMOKE, [*SHORT, *extra]), run_dir, force=force,
                     comm=MPI.COMM_SELF, stream=io.StringIO())


def cli(capsys, *argv: str) -> tuple[int, str]:
    from stickslip.cli.main import main

    rc = main([str(a) for a in argv])
    return rc, capsys.readouterr().err


def one_line(rc: int, err: str, *words: str) -> None:
    assert rc == 2 and err.count("\n") == 1 and err.startswith("error: "), (rc, err)
    for w in words:
        assert w in err, err


def tree(path: Path) -> dict[str, bytes]:
    return {str(p.relative_to(path)): p.read_bytes() for p in sorted(path.rglob("*"))
            if p.is_file()}



def copy_run(src: Path, dst: Path) -> Path:
    import shutil

    shutil.copytree(src, dst)
    return dst


# ------------------------------------------------------------------ the ownership rule


def test_travel_force_keeps_a_users_folder(tmp_path, capsys):
    """travel --force -o DIR deleted any non-empty folder before solving."""
    d = tmp_path / "x"
    (d / "sub").mkdir(parents=True)
    (d / "thesis.tex").write_text("keep")
    rc, err = cli(capsys, "travel", SMOKE, "--k", "4", "-o", d, "--force")
    one_line(rc, err, "not a stickslip travel directory")
    assert (d / "thesis.tex").read_text() == "keep" and (d / "sub").is_dir()


def test_force_never_replaces_a_live_run(finished, tmp_path, capsys):
    """run --force on a run in progress deleted it under the running command."""
    from stickslip.studies.rundir.ownership import claim

    d = copy_run(finished, tmp_path / "r")
    before = digest(d)
    live = claim(d, "run", reuse=True)  # what a running command holds
    try:
        rc, err = cli(capsys, "run", SMOKE, "-o", d, "--force", *sum((["--set", s]
                                                                     for s in SHORT), []))
    finally:
        live.release()
    one_line(rc, err, "in use by a running stickslip command", f"pid {os.getpid()}")
    assert digest(d) == before and not leftovers(d)


def _claim_in_child(path: str, queue, answered) -> None:  # noqa: ANN001
    from stickslip.studies.rundir.ownership import OwnershipError, claim

    try:
        c = claim(path, "run")
        queue.put("ok")
        answered.wait(60)  # still running until every other command has tried
        c.release()
    except OwnershipError as err:
        queue.put(str(err))


@pytest.mark.filterwarnings("ignore::DeprecationWarning")  # fork: the child uses no thread
def test_two_commands_never_share_a_new_directory(tmp_path):
    """Two runs started together on the same new -o both ran into it (3 in 10)."""
    ctx = multiprocessing.get_context("fork")
    for trial in range(3):
        target = str(tmp_path / f"new{trial}" / "r")
        queue, answered = ctx.Queue(), ctx.Event()
        procs = [ctx.Process(target=_claim_in_child, args=(target, queue, answered))
                 for _ in range(4)]
        for p in procs:
            p.start()
        answers = [queue.get(timeout=60) for _ in procs]
        answered.set()  # the winner lets go only now: a late starter met a live claim
        for p in procs:
            p.join(60)
        assert answers.count("ok") == 1, answers
        assert all("in use" in a or "exists" in a for a in answers if a != "ok"), answers


def test_sweep_refuses_a_users_folder(tmp_path, capsys):
    """sweep -o an existing folder overwrote the user's sweep.csv, sweep.json, sweep.toml."""
    d = tmp_path / "mine"
    d.mkdir()
    for name in ("sweep.csv", "sweep.json", "sweep.toml"):
        (d / name).write_text("user data")
    spec = tmp_path / "s.toml"
    spec.write_text(f'base = "{SMOKE}"\nset = ["time.end_time=0.005"]\n'
                    '[grid]\n"loading.omega" = [2.0]\n')
    before = tree(d)
    rc, err = cli(capsys, "sweep", spec, "-o", d)
    one_line(rc, err, "not a stickslip sweep directory")
    assert tree(d) == before


def test_sweep_never_writes_a_users_folder_under_runs(tmp_path):
    """A user folder under runs/ got a `failed` summary, and --retry-failed deleted it."""
    pytest.importorskip("dolfinx")
    from mpi4py import MPI

    from stickslip.studies.sweep import run_sweep

    spec = _smoke_sweep(tmp_path, [2.0], end_time=0.005)
    out = tmp_path / "out"
    assert run_sweep(spec, out, comm=MPI.COMM_SELF, stream=io.StringIO()) == 0
    mine = out / "runs" / spec.tasks[0].id
    import shutil

    shutil.rmtree(mine)
    mine.mkdir()
    (mine / "notes.txt").write_text("mine")
    (mine / "summary.json").write_text('{"scene": "x", "status": "failed"}')
    before = tree(mine)
    for retry in (False, True):
        rc = run_sweep(spec, out, comm=MPI.COMM_SELF, stream=io.StringIO(),
                       retry_failed=retry)
        assert rc == 1 and tree(mine) == before
    row = json.loads((out / "sweep.json").read_text())["rows"][0]
    assert row["status"] == "foreign" and "did not write" in row["message"]


def test_force_keeps_user_files_and_refuses_a_forged_summary(finished, tmp_path, capsys):
    """--force deleted notes and an analysis/ folder inside a run folder, and took a forged
    two-key summary.json for a run."""
    d = copy_run(finished, tmp_path / "r")
    (d / "notes.md").write_text("mine")
    (d / "analysis").mkdir()
    (d / "analysis" / "fit.py").write_text("mine")
    before = tree(d)
    rc, err = cli(capsys, "run", SMOKE, "-o", d, "--force", "--set", SHORT[0])
    one_line(rc, err, "analysis/", "notes.md", "did not write")
    assert tree(d) == before
    forged = tmp_path / "forged"
    forged.mkdir()
    (forged / "summary.json").write_text('{"scene": "smoke", "status": "completed"}')
    (forged / "data.csv").write_text("1,2")
    before = tree(forged)
    rc, err = cli(capsys, "run", SMOKE, "-o", forged, "--force", "--set", SHORT[0])
    one_line(rc, err, "not a stickslip run directory")
    assert tree(forged) == before


def test_a_marker_of_another_kind_is_not_a_run(tmp_path):
    from stickslip.studies.rundir.ownership import OwnershipError, claim

    c = claim(tmp_path / "t", "travel")
    (tmp_path / "t" / "summary.json").write_text("{}")
    c.release()
    with pytest.raises(OwnershipError, match="is a stickslip travel directory, not a run"):
        claim(tmp_path / "t", "run", force=True)


def test_ctrl_c_during_a_force_rerun_keeps_the_old_run(finished, tmp_path, monkeypatch):
    """A SIGINT in the time loop of a --force rerun replaced a completed run."""
    from faults import inject

    d = copy_run(finished, tmp_path / "r")
    before = digest(d)
    state = inject(monkeypatch, "SIGINT", "loop")
    s = run(d, "initial.amplitude=0.2", force=True)
    assert state["fired"] and s["status"] == "interrupted"
    assert "kept unchanged" in s["message"]
    assert digest(d) == before and not leftovers(d)


def test_a_killed_replacement_is_tidied_and_the_old_run_restored(finished, tmp_path):
    """A command killed between the two renames of the swap: the old run goes back."""
    from stickslip.studies.rundir.ownership import claim, recover

    d = copy_run(finished, tmp_path / "r")
    before = digest(d)
    old = d.parent / ".r.old.999999"
    os.rename(d, old)
    stale = claim(d.parent / ".r.new.999998", "run")  # an unfinished replacement, dead
    stale.release()
    recover(d, "run")
    assert digest(d) == before and not leftovers(d)


# ------------------------------------------------------------------ validated readers


@pytest.mark.parametrize(("damage", "words"), [
    ("summary-list", "summary.json: holds a JSON list"),
    ("summary-garbage", "summary.json: not valid JSON"),
    ("summary-forged-status", "status 'great' is not one"),
    ("scene-garbage", "scene.toml: not a valid scene"),
    ("scene-deep", "scene.toml: nested too deeply"),
    ("field-truncated", "final_field.npz: not a readable numpy archive"),
    ("samples-edited", "samples.npz: u_r has shape"),
    ("samples-foreign", "samples.npz: has no t, theta"),
    ("samples-empty", "ended before its first sample period"),
])
@pytest.mark.parametrize("command", ["plot", "compare", "travel"])
def test_damaged_run_files_give_one_line(finished, tmp_path, capsys, damage, words, command):
    """plot, compare and travel --from on a damaged run directory: one line naming the file,
    exit 2 (tracebacks before)."""
    d = copy_run(finished, tmp_path / "r")
    what, _, how = damage.partition("-")
    if what == "summary":
        text = {"list": "[1, 2]", "garbage": "{not json",
                "forged": '{"scene": "smoke", "status": "great"}'}[how.split("-")[0]]
        (d / "summary.json").write_text(text)
    elif what == "scene":
        text = "x = " + "[" * 100_000 + "]" * 100_000 if how == "deep" else "[[[ nope"
        (d / "scene.toml").write_text(text)
    elif what == "field":
        data = (d / "final_field.npz").read_bytes()
        (d / "final_field.npz").write_bytes(data[: len(data) // 2])
    else:
        with np.load(d / "samples.npz") as z:
            arrays = {k: z[k] for k in z.files}
        if how == "edited":
            arrays["u_r"] = arrays["u_r"][:, :3]
        elif how == "foreign":
            arrays = {"x": np.arange(3)}
        else:
            arrays = {k: (v[:0] if k in ("t", "u_r", "u_theta", "status") else v)
                      for k, v in arrays.items()}
        np.savez(d / "samples.npz", **arrays)
    if command == "travel":
        rc, err = cli(capsys, "travel", SMOKE, "--k", "4", "--from", d, "-o", tmp_path / "t")
        assert not (tmp_path / "t").exists()
    else:
        rc, err = cli(capsys, command, d)
    one_line(rc, err, words)


def test_edited_sweep_table_gives_one_line(tmp_path, capsys):
    d = tmp_path / "sw"
    d.mkdir()
    (d / "sweep.json").write_text(json.dumps({"kind": "stickslip-sweep", "rows": "edited",
                                              "parameters": []}))
    from stickslip.studies.sweep.spec import SWEEP_KIND

    (d / "sweep.json").write_text(json.dumps({"kind": SWEEP_KIND, "rows": "edited",
                                              "parameters": []}))
    rc, err = cli(capsys, "plot", d)
    one_line(rc, err, "sweep.json: 'rows' is not a list")


@pytest.mark.parametrize("damage", ["garbage", "list", "deleted"])
def test_sweep_resume_reruns_a_scene_with_a_damaged_summary(tmp_path, damage):
    """A resume recorded `failed` for a garbage or deleted summary.json instead of rerunning."""
    from stickslip.studies.rundir.ownership import claim
    from stickslip.studies.sweep.table import task_state

    spec = _smoke_sweep(tmp_path, [2.0])
    run_dir = tmp_path / "out" / "runs" / spec.tasks[0].id
    claim(run_dir, "run").release()
    text = {"garbage": "\x00\x01", "list": "[]", "deleted": None}[damage]
    if text is not None:
        (run_dir / "summary.json").write_text(text)
    assert task_state(tmp_path / "out", spec, spec.tasks[0]) == "pending"
    claim(run_dir, "run", force=True, in_place=True).release()  # and it may be rerun


def test_a_sweep_of_months_is_refused_before_anything_is_written(tmp_path, capsys):
    """A sweep was accepted whatever its size; now its estimated time is checked first."""
    spec = tmp_path / "s.toml"
    spec.write_text(f'base = "{SMOKE}"\nset = ["time.end_time=1e7"]\n'
                    '[grid]\n"loading.omega" = [2.0, 3.0]\n')
    rc, err = cli(capsys, "sweep", spec, "-o", tmp_path / "out")
    one_line(rc, err, "2 pending scenes would take about", "--yes-i-know")
    assert not (tmp_path / "out").exists()


def test_force_replaces_a_run_with_what_stickslip_added_later(finished, tmp_path):
    """plot's figures and compare's table are stickslip's too: --force replaces them."""
    from stickslip.studies.rundir.ownership import KINDS

    d = copy_run(finished, tmp_path / "r")
    for name in ("spacetime.png", "phase.png", "isomap.png", "compare.json"):
        assert name in KINDS["run"]
        (d / name).write_text("old")
    s = run(d, "initial.amplitude=0.2", force=True)
    assert s["status"] == "completed" and not (d / "compare.json").exists()
    assert not leftovers(d)


@pytest.mark.parametrize("status", ["crashed", "interrupted", "running"])
def test_a_killed_scene_is_run_again_on_resume(tmp_path, status):
    """A sweep whose process was SIGKILLed left the scene `failed`, and a resume skipped it:
    the watchdog now writes `crashed` (or `interrupted` after a signal), neither final."""
    from stickslip.studies.rundir.ownership import claim
    from stickslip.studies.sweep.schedule import _classify

    spec = _smoke_sweep(tmp_path, [2.0])
    run_dir = tmp_path / "out" / "runs" / spec.tasks[0].id
    claim(run_dir, "run").release()
    (run_dir / "summary.json").write_text(json.dumps({
        "scene": "s", "status": status, "pid": 2**22 + 12345, "host": "elsewhere"}))
    pending, n_done, _ = _classify(tmp_path / "out", spec, retry_failed=False)
    assert [t.id for t in pending] == [spec.tasks[0].id] and n_done == 0


def test_a_large_sweep_table_is_not_rewritten_at_every_scene(tmp_path, monkeypatch):
    """A 10^6-point sweep rewrote its 474 MB sweep.json after every scene: a table of more
    than TABLE_SMALL scenes is rewritten at most every TABLE_PERIOD s (and at the end)."""
    from stickslip.studies.sweep import schedule

    spec = _smoke_sweep(tmp_path, [2.0, 3.0, 4.0])
    writes = []
    monkeypatch.setattr(schedule, "write_table", lambda *a, **k: writes.append(1))
    monkeypatch.setattr(schedule, "TABLE_SMALL", 2)
    out = tmp_path / "out"
    mon = schedule._Monitor(out, spec, spec.tasks, 0, io.StringIO(), live=False)
    for i, task in enumerate(spec.tasks):
        from stickslip.studies.rundir.ownership import claim

        run_dir = out / "runs" / task.id
        claim(run_dir, "run").release()
        (run_dir / "summary.json").write_text(json.dumps({"scene": "s", "status": "completed"}))
        mon.poll()
        assert len(writes) == 1, i  # the first at once, then not within TABLE_PERIOD
    mon.stop_event.set()
    mon.poll()
    assert len(writes) == 2  # the last scenes reach the table at the end


def test_a_batched_sweep_never_writes_a_users_folder_under_runs(tmp_path):
    """The batch path too: a user's folder under runs/ is left alone (named on the stream),
    and the other scenes of its batch run."""
    pytest.importorskip("dolfinx")
    pytest.importorskip("numba")
    from mpi4py import MPI

    from stickslip.studies.rundir.ownership import claim
    from stickslip.studies.sweep import run_sweep

    spec = _smoke_sweep(tmp_path, [2.0, 3.0, 4.0], end_time=0.005)
    out = tmp_path / "out"
    claim(out, "sweep").release()  # a sweep directory of stickslip's, not yet run
    mine = out / "runs" / spec.tasks[0].id
    mine.mkdir(parents=True)
    (mine / "notes.txt").write_text("mine")
    before = tree(mine)
    stream = io.StringIO()
    rc = run_sweep(spec, out, comm=MPI.COMM_SELF, stream=stream, batch="3")
    assert rc == 1 and tree(mine) == before
    rows = {r["id"]: r for r in json.loads((out / "sweep.json").read_text())["rows"]}
    assert rows[spec.tasks[0].id]["status"] == "foreign"
    assert all(rows[t.id]["status"] == "completed" for t in spec.tasks[1:])


def test_an_interrupted_travel_force_rerun_keeps_the_earlier_result(tmp_path, capsys,
                                                                     monkeypatch):
    """travel --force built its new result in place: Ctrl-C during the solve lost the old."""
    pytest.importorskip("dolfinx")
    import stickslip.cli.travel as travel_command
    from stickslip.studies.rundir.ownership import claim

    out = tmp_path / "wave"
    c = claim(out, "travel")
    (out / "summary.json").write_text('{"status": "converged", "celerity_m_s": -892.6}')
    c.release()
    before = tree(out)

    def solve_then_interrupt(scene, args, work, t0):  # noqa: ANN001
        (work / "summary.json").write_text('{"status": "half"}')
        raise KeyboardInterrupt

    monkeypatch.setattr(travel_command, "_one_wave", solve_then_interrupt)
    rc, _ = cli(capsys, "travel", SMOKE, "--k", "4", "-o", out, "--force")
    assert rc == 130

    def results(files: dict) -> dict:  # the lock names its last holder: not a result
        return {k: v for k, v in files.items() if k != ".stickslip.lock"}

    assert results(tree(out)) == results(before)
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".wave.")]


def test_a_claim_that_fails_on_a_full_disk_holds_no_lock(tmp_path, monkeypatch):
    """The marker cannot be written (ENOSPC) after the lock was taken: the claim fails, and
    its lock goes with it, so a retry in the same process (a census's next leg) is not told
    that the directory is "in use by a running stickslip command" (its own pid)."""
    import errno

    from stickslip.studies.rundir import ownership

    path = tmp_path / "run"
    ownership.claim(path, "run").release()  # a finished directory of the kind
    real = ownership._write_marker

    def full(*args, **kwargs):  # noqa: ANN002, ANN003, ANN202
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(ownership, "_write_marker", full)
    for _ in range(2):
        with pytest.raises(ownership.OwnershipError, match="No space left"):
            ownership.claim(path, "run", force=True)
    assert ownership.holder(path) is None
    monkeypatch.setattr(ownership, "_write_marker", real)
    again = ownership.claim(path, "run", force=True)
    again.discard()
    again.release()
