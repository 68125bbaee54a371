"""Continuation (``stickslip continue``, ``studies.rundir.continuation``): a run continued from
its checkpoint gives bitwise the samples, final field and summary of one run straight to the
end time, for every scheme and kernel, under MPI and for the members of a batch; the run
directory is replaced atomically, and what cannot be continued is refused in one line.

Tiny scenes: the smoke mesh (36 contact nodes), 0.0031 s then 0.0063 s (~40 + 40 steps),
sampled every ~5th step (3.5e-4 s), so that both ends fall between two samples, with two
probes (one per rank under mpirun)."""

from __future__ import annotations

import io
import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("dolfinx")

from mpi4py import MPI  # noqa: E402

SMOKE = Path(__file__).resolve().parents[1] / "scenes" / "smoke.toml"
COMMON = ["output.progress=false", "output.sample_interval=3.5e-4",
          "output.probes_deg=[0.0, 100.0]"]
T_PART, T_MID, T_FULL = 0.0031, 0.0047, 0.0063
DAMPED = ["damping.loss_factor=0.02", "damping.reference_frequency_hz=1600"]
IMPLICIT = ["time.beta1=0.25", "time.beta2=0.5", "time.dt_fraction=2"]
CASES = {
    "numba": [],
    "numpy": ['time.kernel="numpy"'],
    "implicit": IMPLICIT,
    "damped-numba": DAMPED,
    "damped-numpy": ['time.kernel="numpy"', *DAMPED],
    "implicit-damped": [*IMPLICIT, *DAMPED],
    "prakash-clifton-numba": ['friction.regularization="prakash-clifton"',
                              "friction.slip_length=2e-5", "friction.reference_velocity=0.1"],
}


def _run(root: Path, name: str, extra: list[str], end: float, comm) -> dict:
    from stickslip.solver.scene import load_scene
    from stickslip.studies.rundir import run_scene

    scene = load_scene(SMOKE, [*COMMON, *extra, f"time.end_time={end}"])
    return run_scene(scene, root / name, force=True, comm=comm, stream=io.StringIO())


def _same_files(a: Path, b: Path, rtol: float = 0.0) -> None:
    """samples.npz and final_field.npz: every array bitwise (``rtol`` > 0: floats to rtol of
    the array's largest value, the rest exactly); scene.toml the same text."""
    for name in ("samples.npz", "final_field.npz"):
        with np.load(a / name) as x, np.load(b / name) as y:
            assert sorted(x.files) == sorted(y.files), name
            for key in x.files:
                u, v = x[key], y[key]
                assert u.dtype == v.dtype and u.shape == v.shape, key
                if rtol and u.dtype.kind == "f":
                    scale = float(np.max(np.abs(u), initial=0.0))
                    assert np.allclose(u, v, rtol=0.0, atol=rtol * scale), f"{name}: {key}"
                else:
                    assert u.tobytes() == v.tobytes(), f"{name}: {key}"
    assert (a / "scene.toml").read_text() == (b / "scene.toml").read_text()


def _same_summary(a: dict, b: dict, rtol: float = 0.0) -> None:
    """Equal (floats bitwise: == on the JSON numbers; ``rtol`` > 0: to rtol) but for the
    wall-clock keys."""
    from stickslip.studies.rundir.continuation import WALL_CLOCK_KEYS

    def strip(s: dict) -> dict:
        s = json.loads(json.dumps(s))
        for key in WALL_CLOCK_KEYS:
            head, _, tail = key.partition(".")
            (s.get(head, {}) if tail else s).pop(tail or head, None)
        return s

    def close(x, y, scale: float = 0.0) -> bool:
        # to rtol of the larger value, or of the largest number beside it in its table: a
        # value that is a difference of large terms (an energy balance, a celerity of 0)
        # carries their round-off, not its own
        if isinstance(x, dict):
            beside = max((abs(v) for v in x.values() if isinstance(v, float)), default=0.0)
            return isinstance(y, dict) and x.keys() == y.keys() and all(
                close(x[k], y[k], beside) for k in x)
        if isinstance(x, list):
            return isinstance(y, list) and len(x) == len(y) and all(
                close(u, v, scale) for u, v in zip(x, y, strict=True))
        if isinstance(x, float) and isinstance(y, float) and rtol:
            return abs(x - y) <= rtol * max(abs(x), abs(y), scale) or x == y
        return x == y

    a, b = strip(a), strip(b)
    if rtol:
        # The implicit scheme's active set decides from gaps and slips that are 0 up to
        # round-off at the contact nodes: where the two runs' round-off differs (MPI), a
        # step may take one active-set iteration more or less; the states still agree to
        # rtol (checked in the samples). So the counts agree to one iteration.
        sa, sb = a.get("scheme", {}), b.get("scheme", {})
        if "active_set_iterations_mean" in sa:
            total = [x.pop("active_set_iterations_mean") * a["steps"] for x in (sa, sb)]
            assert abs(total[0] - total[1]) <= 1.0 + 1e-9, (sa, sb)
            top = [x.pop("active_set_iterations_max") for x in (sa, sb)]
            assert abs(top[0] - top[1]) <= 1, (sa, sb)
    assert close(a, b), (a, b)


@pytest.mark.parallel
@pytest.mark.parametrize("case", sorted(CASES))
def test_continued_run_is_bitwise_the_run_straight_through(case, tmp_path):
    """Run to 0.0031 s, continue in place to 0.0047 s and on to 0.0063 s: the same bits as
    one run to 0.0063 s. Under mpirun the straight runs themselves are not reproducible bit
    for bit: about one in ten differs from the next at 1e-14 relative from its first sample
    on, on the same partition and dof numbering (the steady state's parallel MUMPS solve),
    so there the numbers are compared to 1e-9 of each array's scale (round-off grown over
    ~80 steps, far below any physical change) and the statuses exactly; the restore itself
    is checked bitwise on two ranks by ``test_restore_reproduces_every_rank_state_bitwise``.
    """
    from stickslip.studies.rundir import continue_run

    comm = MPI.COMM_WORLD
    root = Path(comm.bcast(str(tmp_path), root=0))
    full = _run(root, "full", CASES[case], T_FULL, comm)
    part = _run(root, "part", CASES[case], T_PART, comm)
    continue_run(root / "part", T_MID, comm=comm, stream=io.StringIO())
    cont = continue_run(root / "part", T_FULL, comm=comm, stream=io.StringIO())
    rtol = 1e-9 if comm.size > 1 else 0.0
    if comm.rank == 0:
        assert part["sim_time_s"] < T_FULL and part["status"] == "completed"
        assert cont["status"] == "completed" and cont["steps"] > part["steps"]
        _same_summary(full, cont, rtol)
        _same_summary(full, json.loads((root / "part" / "summary.json").read_text()), rtol)
        _same_files(root / "full", root / "part", rtol)
        assert not list(root.glob(".part.*"))  # the replacement was swapped in


@pytest.mark.parallel
@pytest.mark.parametrize("case", ["numba", "implicit-damped"])
def test_restore_reproduces_every_rank_state_bitwise(case):
    """A Simulation restored from another's checkpoint (same scene, same ranks) holds the
    same state, bit for bit, on every rank: its own checkpoint equals the one it came from
    (stepper, contact, work sums, energy guard, counts)."""
    from stickslip.solver.run import Simulation
    from stickslip.solver.scene import load_scene

    scene = load_scene(SMOKE, [*COMMON, *CASES[case], f"time.end_time={T_PART}"])
    first = Simulation(scene, MPI.COMM_WORLD)
    first.proceed()
    state = first.checkpoint()
    second = Simulation(scene, MPI.COMM_WORLD)
    second.restore([state], [None])
    again = second.checkpoint()
    assert again.keys() == state.keys()
    for key, value in state.items():
        assert np.asarray(again[key]).tobytes() == np.asarray(value).tobytes(), key


def test_run_stopped_by_max_steps_continues_bitwise(tmp_path):
    """A run stopped by time.max_steps (between two samples) continues to the end time,
    with the step limit dropped: the run straight through, bitwise."""
    from stickslip.studies.rundir import continue_run

    full = _run(tmp_path, "full", [], T_FULL, MPI.COMM_SELF)
    part = _run(tmp_path, "part", ["time.max_steps=23"], T_FULL, MPI.COMM_SELF)
    assert part["steps"] == 23 and part["stop_reason"] == "max_steps"
    cont = continue_run(tmp_path / "part", T_FULL, tmp_path / "cont", comm=MPI.COMM_SELF,
                        stream=io.StringIO())
    _same_summary(full, cont)
    _same_files(tmp_path / "full", tmp_path / "cont")


def test_run_interrupted_by_a_signal_writes_its_checkpoint_and_continues(tmp_path,
                                                                      monkeypatch):
    """A signal's stop (``Simulation.stop_requested``, seen at a sample) ends the run
    ``interrupted`` at a whole level with its checkpoint; continued, it is the run straight
    through, bitwise. The flag is set by the loop itself at step 23 (no clock, no signal)."""
    from stickslip.solver import run as run_module
    from stickslip.studies.rundir import continue_run

    full = _run(tmp_path, "full", [], T_FULL, MPI.COMM_SELF)
    observe = run_module.StopCheck.observe

    def signal_at_step_23(self, stepper):  # noqa: ANN001
        self.sim.stop_requested = stepper.step_count >= 23
        return observe(self, stepper)

    monkeypatch.setattr(run_module.StopCheck, "observe", signal_at_step_23)
    part = _run(tmp_path, "part", [], T_FULL, MPI.COMM_SELF)
    monkeypatch.undo()
    assert part["status"] == "interrupted" and part["sim_time_s"] < T_FULL
    assert (tmp_path / "part" / "checkpoint.npz").is_file()
    cont = continue_run(tmp_path / "part", T_FULL, comm=MPI.COMM_SELF, stream=io.StringIO())
    _same_summary(full, cont)
    _same_files(tmp_path / "full", tmp_path / "part")


BATCH = """
name = "b"
base = "{base}"
set = ["time.end_time = {end}", "output.sample_interval = 3.5e-4",
       "output.probes_deg = [0.0, 100.0]", "output.progress = false"{extra}]
[[points]]
"loading.f" = 0.7
"initial.amplitude" = 0.1
[[points]]
"loading.f" = 0.5
"initial.amplitude" = 0.3
[[points]]
"loading.f" = 0.6
"initial.amplitude" = 0.2
"""


@pytest.mark.parametrize("damped", [False, True], ids=["undamped", "damped"])
def test_batch_members_continue_bitwise_as_one_batch(damped, tmp_path):
    """Three scenes run as one batch to 0.0031 s and continued together to 0.0047 s, then
    to 0.0063 s (one batch again each time) equal the same batch run to 0.0063 s,
    bitwise (summaries but for the wall-clock keys); with Kelvin-Voigt damping too (the
    kernel's damping sums and w_{n+1} are part of the state). No leg solves a steady state
    (restore overwrites the start), and the second takes the first's mesh and K."""
    from stickslip.studies.rundir import continue_batch
    from stickslip.studies.sweep.schedule import run_sweep
    from stickslip.studies.sweep.spec import load_sweep

    dirs = {}
    for end in (T_FULL, T_PART):
        spec = tmp_path / f"{end}.toml"
        extra = "".join(f', "{kv.replace("=", " = ")}"' for kv in DAMPED) if damped else ""
        spec.write_text(BATCH.format(base=SMOKE, end=end, extra=extra))
        with open(os.devnull, "w") as quiet:
            assert run_sweep(load_sweep(spec), tmp_path / str(end), comm=MPI.COMM_SELF,
                             batch="3", stream=quiet, progress="lines") == 0
        dirs[end] = sorted((tmp_path / str(end) / "runs").iterdir())
    continue_batch(dirs[T_PART], T_MID, stream=io.StringIO())  # twice: a census extends
    summaries = continue_batch(dirs[T_PART], T_FULL, stream=io.StringIO())  # step by step
    assert [s["batch"]["size"] for s in summaries] == [3, 3, 3]
    assert not {"steady-state", "mesh+assembly", "stability"} & set(summaries[0]["profile_s"])
    assert (summaries[0]["scheme"]["damping_tau_s"] > 0.0) == damped
    for full, cont, summary in zip(dirs[T_FULL], dirs[T_PART], summaries, strict=True):
        _same_files(full, cont)
        _same_summary(json.loads((full / "summary.json").read_text()), summary)


def test_a_member_continued_alone_is_bitwise_the_batch_run_and_read_once(tmp_path,
                                                                          monkeypatch):
    """`stickslip continue` of one batch member (``continue_run``): the member goes on as a
    batch of one, which steps with the single-scene kernel, and equals its column of the
    same batch run straight through, bitwise (damped: w_{n+1} is part of the state). Its
    samples are read once (the command's plan is the batch's)."""
    from stickslip.studies.rundir import continuation
    from stickslip.studies.sweep.schedule import run_sweep
    from stickslip.studies.sweep.spec import load_sweep

    dirs = {}
    for end in (T_FULL, T_PART):
        spec = tmp_path / f"{end}.toml"
        extra = "".join(f', "{kv.replace("=", " = ")}"' for kv in DAMPED)
        spec.write_text(BATCH.format(base=SMOKE, end=end, extra=extra))
        with open(os.devnull, "w") as quiet:
            assert run_sweep(load_sweep(spec), tmp_path / str(end), comm=MPI.COMM_SELF,
                             batch="3", stream=quiet, progress="lines") == 0
        dirs[end] = sorted((tmp_path / str(end) / "runs").iterdir())
    plans = []
    plan = continuation.plan_continuation
    monkeypatch.setattr(continuation, "plan_continuation",
                        lambda *a, **k: plans.append(a) or plan(*a, **k))
    summary = continuation.continue_run(dirs[T_PART][1], T_FULL, comm=MPI.COMM_SELF,
                                        stream=io.StringIO())
    assert len(plans) == 1 and summary.pop("batch")["size"] == 1
    _same_files(dirs[T_FULL][1], dirs[T_PART][1])
    full = json.loads((dirs[T_FULL][1] / "summary.json").read_text())
    assert full.pop("batch")["size"] == 3  # the one key that says how it ran
    _same_summary(full, summary)


def test_interrupted_continuation_keeps_the_run_as_it_was(tmp_path, monkeypatch):
    """A continuation interrupted in its time loop (KeyboardInterrupt from the loop, as a
    signal's handler raises it) drops its replacement: every file of the run is unchanged
    and no temporary sibling is left."""
    from stickslip.solver import run as run_module
    from stickslip.studies.rundir import continue_run

    _run(tmp_path, "part", [], T_PART, MPI.COMM_SELF)
    before = {p.name: p.read_bytes() for p in (tmp_path / "part").iterdir() if p.is_file()}

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(run_module, "run_loop", interrupted)
    summary = continue_run(tmp_path / "part", T_FULL, comm=MPI.COMM_SELF,
                           stream=io.StringIO())
    assert summary["status"] == "interrupted" and "kept unchanged" in summary["message"]
    after = {p.name: p.read_bytes() for p in (tmp_path / "part").iterdir() if p.is_file()}
    assert after.keys() == before.keys()
    assert all(after[k] == before[k] for k in before if k != ".stickslip.lock")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["part"]


def _cli(*args: str) -> tuple[int, str]:
    import contextlib

    from stickslip.cli.main import main

    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        rc = main(["continue", *args])
    return rc, err.getvalue()


def test_what_cannot_be_continued_is_refused_in_one_line(tmp_path):
    """Exit status 2 and one line naming the fix: --until not beyond the run's time, an -o
    that is another run, a scene.toml edited since the checkpoint, a checkpoint of another
    number of ranks, a run without a checkpoint; the run is untouched each time, and -o
    leaves the original as it was."""
    from stickslip.solver.atomic import atomic_save_npz

    _run(tmp_path, "part", [], T_PART, MPI.COMM_SELF)
    run = tmp_path / "part"
    rc, err = _cli(str(run), "--until", str(T_PART))
    assert rc == 2 and "already at t = " in err and err.count("\n") == 1
    shutil.copytree(run, tmp_path / "other")
    rc, err = _cli(str(run), "--until", str(T_FULL), "-o", str(tmp_path / "other"))
    assert rc == 2 and "--force" in err and err.count("\n") == 1
    scene_text = (run / "scene.toml").read_text()
    (run / "scene.toml").write_text(scene_text.replace("f = 0.7", "f = 0.6"))
    rc, err = _cli(str(run), "--until", str(T_FULL))
    assert rc == 2 and "not the scene its checkpoint was written with" in err
    (run / "scene.toml").write_text(scene_text)
    with np.load(run / "checkpoint.npz") as data:
        arrays = {k: data[k] for k in data.files}
    meta = json.loads(str(arrays["meta"]))
    atomic_save_npz(run / "checkpoint.npz", dict(arrays, meta=np.array(json.dumps(
        dict(meta, ranks=2)))))
    rc, err = _cli(str(run), "--until", str(T_FULL))
    assert rc == 2 and "written on 2 rank(s)" in err and "mpirun -n 2" in err
    (run / "checkpoint.npz").unlink()
    rc, err = _cli(str(run), "--until", str(T_FULL))
    assert rc == 2 and "checkpoint.npz: missing" in err and "stickslip run" in err
    assert json.loads((run / "summary.json").read_text())["sim_time_s"] < T_FULL
    shutil.rmtree(run)
    _run(tmp_path, "part", [], T_PART, MPI.COMM_SELF)
    original = {p.name: p.read_bytes() for p in run.iterdir() if p.is_file()}
    rc, _ = _cli(str(run), "--until", str(T_FULL), "-o", str(tmp_path / "longer"))
    assert rc == 0
    assert {p.name: p.read_bytes() for p in run.iterdir() if p.is_file()} == original
    assert json.loads((tmp_path / "longer" / "summary.json").read_text())["sim_time_s"] \
        >= T_FULL * (1 - 1e-12)


@pytest.mark.parametrize("batch", ["off", 2])
def test_continue_shows_its_progress_for_a_sweeps_scene(tmp_path, capsys, monkeypatch, batch):
    """A sweep's scenes have ``output.progress`` off (the sweep's console has its own), so
    `stickslip continue SWEEP/runs/ID` ran for hours without a line, alone or as a batch
    member. The command now prints its progress (every sample due here: ``Progress.due``
    without the clock)."""
    from stickslip.cli.main import main
    from stickslip.solver.observers import Progress

    spec = tmp_path / "s.toml"
    spec.write_text(f'base = "{SMOKE}"\nbatch = {batch!r}\nset = ["time.end_time=0.002"]\n'
                    '[grid]\n"loading.omega" = [2.0, 3.0]\n'.replace("'", '"'))
    assert main(["sweep", str(spec), "-o", str(tmp_path / "out")]) == 0
    capsys.readouterr()
    monkeypatch.setattr(Progress, "due", lambda self: self.enabled)
    run = tmp_path / "out" / "runs" / "omega-2.0"
    assert main(["continue", str(run), "--until", "0.004"]) == 0
    progress = [line for line in capsys.readouterr().out.splitlines()
                if line.startswith("  t = ")]
    assert progress and "(100.0%)" in progress[-1], progress
    kind = json.loads((run / "summary.json").read_text()).get("batch")
    assert (kind is not None) == (batch != "off")  # both ways a scene continues
