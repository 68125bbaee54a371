"""Hang-ups and stop signals through the CLI and mpirun, as a user's shell or batch system
sends them: to a fresh ``stickslip`` process, which loads the FE stack only after its signal
handlers are in.

* SIGHUP to ``stickslip run`` / ``stickslip continue`` in the time loop ended in PETSc's
  "Caught signal number 1" and MPI_ABORT (exit 59), the run `crashed` and blamed on an
  out-of-memory SIGKILL, no samples. PETSc's ``PetscInitialize`` (and UCX, loaded with Open
  MPI) installs its own SIGHUP handler over Python's when dolfinx is first imported, during
  setup; the in-process test (tests/test_hostile_inputs.py) imports dolfinx first and so
  never saw it. Now SIGHUP does what SIGTERM does: `interrupted`, samples kept, exit 130.
* SIGTERM to ``mpirun -n 2 stickslip run`` exited 1 with nothing printed (Open MPI's own
  SIGKILL 0.25 s after SIGTERM); without HOME Open MPI printed a 14-line box. Now mpirun
  (docker/bin/mpirun, as ./dev and the image run it) hands the signal to the ranks, returns
  once they have saved, exit 130, the job's own line; without HOME one line, exit 2.

Every signal is sent after the program's own readiness line: the first progress line
(``t = ...``, printed from inside the time loop 5 s of wall time into it), or a job's
``ready`` line. The runs are the smoke scene (216 dofs), long enough in simulated time that
the loop is far from its end when the line comes (see ``LONG``).
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from faults import digest, wait_released

REPO = Path(__file__).resolve().parents[1]
MPIRUN = REPO / "docker" / "bin" / "mpirun"
# 3000 s of simulated time, ~39 million steps: minutes of loop on any machine (~140 000 steps/s
# on one fast core), so the first progress line (5 s into the loop) always comes with most of
# it left. Samples every 0.1 s and no probe histories keep memory and files small whatever
# the machine's speed (the sampling is coarse for the wave, hence --yes-i-know).
LONG = ["--set", "time.end_time=3000", "--set", "output.sample_interval=0.1",
        "--set", "output.probes_deg=[]", "--yes-i-know"]
END = 3000.0
STICKSLIP = [sys.executable, "-m", "stickslip.cli.main"]


def signal_in_loop(cmd: list[str], signum: int) -> tuple[int, str]:
    """Start ``cmd``, wait for its first progress line (the time loop runs), send ``signum``;
    its exit status and everything it printed (stdout and stderr together)."""
    proc = subprocess.Popen(cmd, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True)
    seen = []
    try:
        for line in proc.stdout:
            seen.append(line)
            if line.lstrip().startswith("t = "):
                break
        assert proc.poll() is None, "".join(seen)  # still running: the signal lands in the loop
        proc.send_signal(signum)
        rest, _ = proc.communicate(timeout=300)
    finally:
        if proc.poll() is None:
            proc.kill()
    return proc.returncode, "".join(seen) + rest


def assert_interrupted_by(run_dir: Path, out: str, name: str) -> dict:
    """The run directory holds a final `interrupted` run with loadable samples; the output
    says so in one line, with no dump, traceback or Open MPI box."""
    from stickslip.studies.rundir.readers import check_run_dir

    s = json.loads((run_dir / "summary.json").read_text())
    assert s["status"] == "interrupted" and s["message"] == f"interrupted by {name}", s
    with np.load(run_dir / "samples.npz") as data:
        assert data["t"].size >= 2 and np.all(np.isfinite(data["t"]))
    check_run_dir(run_dir)
    said = [ln for ln in out.splitlines() if "interrupted" in ln]
    assert said == [f"status: interrupted (interrupted by {name})"], out
    for noise in ("PETSC ERROR", "MPI_ABORT", "Traceback", "prterun", "-" * 20, "crashed"):
        assert noise not in out, out
    return s


@pytest.fixture(scope="module")
def hung_up_run(tmp_path_factory) -> tuple[Path, int, str]:
    """`stickslip run smoke` given SIGHUP in its time loop: (run dir, exit status, output)."""
    pytest.importorskip("dolfinx")
    run_dir = tmp_path_factory.mktemp("hup") / "r"
    rc, out = signal_in_loop([*STICKSLIP, "run", "smoke", *LONG, "-o", str(run_dir)],
                             signal.SIGHUP)
    return run_dir, rc, out


def test_sighup_to_run_in_the_time_loop_saves_interrupted(hung_up_run):
    """Exit 130 and `interrupted by SIGHUP`, as SIGTERM gives (not PETSc's exit 59)."""
    run_dir, rc, out = hung_up_run
    assert rc == 130, out
    s = assert_interrupted_by(run_dir, out, "SIGHUP")
    assert 0 < s["sim_time_s"] < END


def test_sighup_to_continue_in_the_time_loop_saves_interrupted(hung_up_run, tmp_path):
    """`continue` from the interrupted run, SIGHUP in its loop: the continuation is saved
    `interrupted` (exit 130), and the source run is untouched."""
    source, _, _ = hung_up_run
    wait_released(source)
    before = digest(source)
    t0 = json.loads((source / "summary.json").read_text())["sim_time_s"]
    out_dir = tmp_path / "c"
    rc, out = signal_in_loop([*STICKSLIP, "continue", str(source), "--until", str(END),
                              "--yes-i-know", "-o", str(out_dir)], signal.SIGHUP)
    assert rc == 130, out
    s = assert_interrupted_by(out_dir, out, "SIGHUP")
    assert t0 < s["sim_time_s"] < END  # it went on from the source's end
    assert digest(source) == before


def test_the_stack_leaves_sighup_to_python():
    """The cause, in one process: a SIGHUP handler installed before dolfinx (hence mpi4py and
    PETSc) is imported still runs afterwards; before, PETSc's handler had replaced it."""
    pytest.importorskip("dolfinx")
    code = ("import os, signal, sys\n"
            "import stickslip.solver\n"
            "signal.signal(signal.SIGHUP, lambda *a: sys.exit(42))\n"
            "import dolfinx\n"
            "from petsc4py import PETSc\n"
            "os.kill(os.getpid(), signal.SIGHUP)\n"
            "sys.exit(1)\n")
    res = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True,
                         text=True, timeout=120)
    assert res.returncode == 42, res.stderr


def test_keep_signals_for_python_keeps_the_users_settings():
    """-no_signal_handler is added once to the user's PETSC_OPTIONS; a UCX_DEBUG_SIGNO the
    user chose stays."""
    from stickslip.solver import keep_signals_for_python

    env = {"PETSC_OPTIONS": "-log_view", "UCX_DEBUG_SIGNO": "SIGUSR2"}
    keep_signals_for_python(env)
    keep_signals_for_python(env)
    assert env == {"PETSC_OPTIONS": "-log_view -no_signal_handler", "UCX_DEBUG_SIGNO": "SIGUSR2"}
    env = {}
    keep_signals_for_python(env)
    assert env == {"PETSC_OPTIONS": "-no_signal_handler", "UCX_DEBUG_SIGNO": "0"}


def open_mpi_mpirun() -> str | None:
    """Open MPI's own mpirun: the first on PATH that is not docker/bin/mpirun (for a test of
    what happens when the launcher itself is signalled, as a batch system signalling every
    process of a job does), or None."""
    for folder in os.environ.get("PATH", "").split(os.pathsep):
        path = Path(folder or ".", "mpirun")
        if path.is_file() and os.access(path, os.X_OK) and path.resolve() != MPIRUN:
            return str(path)
    return None


def needs_mpirun() -> None:
    if "OMPI_COMM_WORLD_SIZE" in os.environ:
        pytest.skip("outside mpirun")
    if open_mpi_mpirun() is None:
        pytest.skip("needs Open MPI's mpirun")


def test_mpirun_is_the_wrapper_in_dev_and_the_image():
    """./dev puts docker/bin first on PATH; the image installs the wrapper before /usr/bin."""
    if os.environ.get("STICKSLIP_DEV_ROOTFS") or "docker/bin" in os.environ.get("PATH", ""):
        assert Path(shutil.which("mpirun")).resolve() == MPIRUN
    dockerfile = (REPO / "Dockerfile").read_text()
    assert "COPY --chmod=0755 docker/bin/mpirun /usr/local/bin/mpirun" in dockerfile
    assert os.access(MPIRUN, os.X_OK)


def test_sigterm_to_mpirun_run_is_130_once_saved(tmp_path):
    """SIGTERM to `mpirun -n 2 stickslip run` in the loop: the ranks stop at the same sample
    and save; when mpirun returns the run is final (interrupted, samples loadable), the exit
    is 130 and the only word is rank 0's status line (no Open MPI box)."""
    pytest.importorskip("dolfinx")
    needs_mpirun()
    run_dir = tmp_path / "r"
    rc, out = signal_in_loop([str(MPIRUN), "-n", "2", *STICKSLIP, "run", "smoke", *LONG, "-o",
                              str(run_dir)], signal.SIGTERM)
    assert rc == 130, out
    s = assert_interrupted_by(run_dir, out, "SIGTERM")  # read at once: final on return
    assert s["ranks"] == 2


def test_sigterm_to_mpirun_of_a_silent_job_is_one_line():
    """A job without handlers dies of the SIGTERM handed to it: prterun's box about it is
    replaced by one line, exit 130."""
    needs_mpirun()
    job = "import time; print('ready', flush=True); time.sleep(120)"
    proc = subprocess.Popen([str(MPIRUN), "-n", "2", sys.executable, "-c", job], cwd=REPO,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline() == "ready\n" and proc.stdout.readline() == "ready\n"
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, err
    assert err.splitlines() == [
        "mpirun: the job was stopped by SIGTERM (mpirun's status 143); exit 130"], err


def test_mpirun_without_home_is_one_line():
    """HOME unset: one line naming it and the fix, exit 2 (not Open MPI's 14-line box)."""
    needs_mpirun()
    env = {k: v for k, v in os.environ.items() if k != "HOME"}
    res = subprocess.run([str(MPIRUN), "-n", "2", *STICKSLIP, "info"], cwd=REPO, env=env,
                         capture_output=True, text=True, timeout=60)
    assert res.returncode == 2 and res.stdout == "", res.stdout + res.stderr
    assert res.stderr.count("\n") == 1 and "HOME is not set" in res.stderr \
        and "export HOME=" in res.stderr, res.stderr


def test_a_refusal_under_mpirun_is_one_line():
    """A scene refused at load under `mpirun -n 2`: rank 0's one `error:` line and exit 2;
    prterun's box about a process that exited non-zero is dropped (the line said why)."""
    pytest.importorskip("dolfinx")
    needs_mpirun()
    res = subprocess.run([str(MPIRUN), "-n", "2", *STICKSLIP, "run", "smoke", "--set",
                          "geometry.delta=10"], cwd=REPO, capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 2, res.stderr
    assert res.stderr.count("\n") == 1 and res.stderr.startswith("error: "), res.stderr
    assert "geometry.delta = 10" in res.stderr


def test_a_reader_that_goes_away_does_not_stop_the_run(tmp_path):
    """`stickslip run smoke | head -1`: the reader closes the pipe after the first line and
    the next progress line meets a broken pipe. The run went `failed` (exit 120: "cannot
    use: Broken pipe"); now the printed lines go to /dev/null from there and the run ends
    as it would have: `completed`, exit 0, its samples whole."""
    pytest.importorskip("dolfinx")
    run_dir = tmp_path / "r"
    proc = subprocess.Popen([*STICKSLIP, "run", "smoke", "--set", "time.end_time=0.02",
                             "-o", str(run_dir)], cwd=REPO, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    first = proc.stdout.readline()  # the reader takes one line, as `head -1` does, and goes
    proc.stdout.close()
    _, err = proc.communicate(timeout=300)
    assert first.startswith("stickslip "), first
    assert proc.returncode == 0, err
    assert "Broken pipe" not in err and "Traceback" not in err, err
    from stickslip.studies.rundir.readers import check_run_dir

    assert json.loads((run_dir / "summary.json").read_text())["status"] == "completed"
    check_run_dir(run_dir)


BUG_ON_RANK_0 = """
import argparse, sys
from mpi4py import MPI
import stickslip.cli.main as cli

def handler(args):
    if MPI.COMM_WORLD.rank == 0:
        raise RuntimeError("a bug on rank 0")
    MPI.COMM_WORLD.barrier()  # rank 1 waits for rank 0, as a census's ranks do
    return 0

class Parser:
    def parse_args(self, argv):
        return argparse.Namespace(func=handler)

cli.build_parser = lambda *names: Parser()
sys.exit(cli.main([]))
"""


@pytest.mark.skipif(shutil.which("prterun") is None and shutil.which("orterun") is None,
                    reason="Open MPI's launcher is not installed")
def test_an_unexpected_error_on_one_rank_ends_the_whole_job(tmp_path):
    """A bug (an exception no handler expects) on rank 0 while rank 1 waits for it: rank 0
    used to end in MPI's finalisation, waiting for rank 1, which waited for rank 0: a job
    that never ended (met when a census's rank 0 raised in its answer). Now the traceback
    is printed and the job aborts, exit non-zero; the timeout only guards the test."""
    script = tmp_path / "bug.py"
    script.write_text(BUG_ON_RANK_0)
    proc = subprocess.run([str(MPIRUN), "-n", "2", sys.executable, str(script)], cwd=REPO,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode != 0
    assert "RuntimeError: a bug on rank 0" in proc.stderr, proc.stderr


def _wrapper_stderr(text: bytes) -> bytes:
    """What docker/bin/mpirun's ``copy_stderr`` passes on of the real mpirun's ``text``
    (no stop forwarded), read from a pipe as it runs."""
    import importlib.machinery
    import importlib.util
    import io

    loader = importlib.machinery.SourceFileLoader("mpirun_wrapper", str(MPIRUN))
    wrapper = importlib.util.module_from_spec(importlib.util.spec_from_loader(loader.name,
                                                                              loader))
    loader.exec_module(wrapper)
    read, write = os.pipe()
    os.write(write, text)
    os.close(write)
    out = io.BytesIO()
    real, sys.stderr = sys.stderr, io.TextIOWrapper(out, write_through=True)
    try:
        wrapper.copy_stderr(wrapper.Launch(), read)
        return out.getvalue()
    finally:
        sys.stderr.detach()  # leave ``out`` open; the wrapper's text layer goes
        sys.stderr = real
        os.close(read)


def test_the_pmix_teardown_line_after_the_jobs_own_error_is_dropped():
    """A rank's refusal ends the job; the PMIx server may then note that it could not reach
    the rank that had exited (``PMIX_ERR_UNREACH``, a teardown race): after the job's own
    ``error:`` line that note is dropped, so the refusal stays one line; where the job said
    nothing it is kept (nothing is hidden that nothing explains)."""
    note = b"[vm:1] PMIX ERROR: PMIX_ERR_UNREACH in file pmix_server.c at line 3184\n"
    refusal = b"error: scene.toml: geometry.delta = 10 is out of range\n"
    assert _wrapper_stderr(refusal + note) == refusal
    assert _wrapper_stderr(note) == note
