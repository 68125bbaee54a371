"""Fault injection for run directories: a failing write (disk full) or a signal,
at each phase of ``studies.rundir.run_scene``, and the invariant that must hold afterwards.

Phases, in the order a run meets them::

    setup       meshing/assembly (build_problem, one scene's or a batch's)
    loop        the time loop (the 3rd health check, i.e. the 3rd sample)
    scene.toml, summary.json (running), samples.npz, final_field.npz, summary.json (final),
    summary.json (analysis)        the writes, in this order (solver.atomic.atomic_write)
    swap        commit_run_dir (replacing an earlier run)

``inject(monkeypatch, kind, phase)`` arms one fault: ``kind`` is "disk-full" (the write fails
with ENOSPC after a few bytes, as a full disk does) or a signal name ("SIGINT", "SIGTERM")
sent to this process at that moment. ``check_after(run_dir, before)`` asserts the invariant:
no temporary file or directory is left; the earlier run (``before`` = its ``digest``) is
intact, or the directory holds a new run that is complete (final status, loadable samples)
or marked ``failed`` with a message; never ``running``.
"""

from __future__ import annotations

import errno
import hashlib
import json
import os
import signal
from pathlib import Path

import numpy as np

WRITES = ("scene.toml", "summary.json#1", "samples.npz", "final_field.npz", "summary.json#2",
          "summary.json#3")
PHASES = ("setup", "loop", *WRITES, "swap")
FINAL = ("completed", "interrupted", "diverged", "stopped")


def digest(run_dir: Path) -> str | None:
    """Hash of every file of a run directory (None if it does not exist)."""
    if not run_dir.is_dir():
        return None
    h = hashlib.sha256()
    for f in sorted(run_dir.rglob("*")):
        if f.is_file() and f.name != ".stickslip.lock":  # names the live holder, not data
            h.update(f.name.encode())
            h.update(f.read_bytes())
    return h.hexdigest()


def inject(monkeypatch, kind: str, phase: str) -> dict:  # noqa: ANN001
    """Arm one fault; returns a dict whose "fired" says whether it happened."""
    import stickslip.solver.atomic  # noqa: F401 (loaded: used as an attribute)
    import stickslip.solver.ensemble_run  # noqa: F401 (loaded: used as an attribute)
    import stickslip.solver.problem  # noqa: F401 (loaded: used as an attribute)
    import stickslip.solver.scene_column  # noqa: F401 (loaded: used as an attribute)
    import stickslip.studies.rundir  # noqa: F401 (loaded: used as an attribute)
    import stickslip.studies.rundir.directory  # noqa: F401 (loaded: used as an attribute)
    import stickslip.studies.rundir.scene_run  # noqa: F401 (loaded: used as an attribute)
    import stickslip.studies.rundir.writer  # noqa: F401 (loaded: used as an attribute)
    from stickslip import solver, studies

    state = {"fired": False, "count": {}}

    def fire() -> None:
        state["fired"] = True
        if kind == "disk-full":
            raise OSError(errno.ENOSPC, "No space left on device (injected)")
        os.kill(os.getpid(), getattr(signal, kind))

    if phase == "setup":
        real_build = solver.scene_column.build_problem

        def build(*a, **k):  # noqa: ANN002, ANN003
            if not state["fired"]:
                fire()
            return real_build(*a, **k)

        # where a run looks it up: the one scene's column imports it, a batch's columns
        # (solver.ensemble_run) read it from its module when they build
        monkeypatch.setattr(solver.scene_column, "build_problem", build)
        monkeypatch.setattr(solver.problem, "build_problem", build)
    elif phase == "loop":
        # the third sample of the run: a scene's column or a batch's columns
        for columns in (solver.scene_column.SceneColumn, solver.ensemble_run.BatchColumns):
            def sample(self, stepper, real_sample=columns.sample):  # noqa: ANN001
                state["count"]["loop"] = state["count"].get("loop", 0) + 1
                if state["count"]["loop"] == 3 and not state["fired"]:
                    fire()
                return real_sample(self, stepper)

            monkeypatch.setattr(columns, "sample", sample)
    elif phase == "swap":
        real_commit = studies.rundir.directory.commit_run_dir

        def commit(rd):  # noqa: ANN001
            if rd.replacing and not state["fired"]:
                fire()
            return real_commit(rd)

        # every swap, the writer's and the abnormal ends', is ``RunDirectory``'s (the writer)
        monkeypatch.setattr(studies.rundir.directory, "commit_run_dir", commit)
    else:
        name, _, nth = phase.partition("#")
        real_write = solver.atomic.atomic_write

        def write(path, fill):  # noqa: ANN001
            p = Path(path)
            n = state["count"][p.name] = state["count"].get(p.name, 0) + 1
            if p.name == name and n == int(nth or 1) and not state["fired"]:
                if kind == "disk-full":
                    def failing(fh):  # noqa: ANN001
                        fh.write(b"partial")
                        fire()
                    return real_write(path, failing)
                fire()  # a signal just before this write
            return real_write(path, fill)

        monkeypatch.setattr(solver.atomic, "atomic_write", write)
    return state


def leftovers(run_dir: Path) -> list[Path]:
    """Temporary files or directories a run must never leave behind."""
    out = list(run_dir.parent.glob(f".{run_dir.name}.new.*"))
    out += list(run_dir.parent.glob(f".{run_dir.name}.old.*"))
    if run_dir.is_dir():
        out += [p for p in run_dir.rglob(".*") if p.name.endswith(".tmp")]
    return out


def check_after(run_dir: Path, before: str | None) -> str:
    """Assert the invariant; returns "intact", "complete", "failed" or "absent"."""
    assert not leftovers(run_dir), leftovers(run_dir)
    if before is not None and digest(run_dir) == before:
        return "intact"
    if not run_dir.exists():
        assert before is None, "the earlier run disappeared"
        return "absent"
    summary = json.loads((run_dir / "summary.json").read_text())
    status = summary["status"]
    assert status != "running", summary
    if status == "failed":
        assert summary.get("message"), summary
        return "failed"
    assert status in FINAL, summary
    if "steps" in summary:  # the time loop ran: its samples must load
        with np.load(run_dir / "samples.npz") as data:
            assert data["t"].size == summary["samples"] > 0
    return "complete"


def wait_released(folder: Path, timeout: float = 120.0) -> None:
    """Block until no process holds ``folder``'s ``.stickslip.lock``.

    Every stickslip process that may still write a directory holds its lock: the command,
    and the helpers it forks (the watchdog, mpirun's rescue writer), which inherit it and
    outlive a rank that mpirun SIGKILLs. So once the lock is free, the directory's files are
    final. ``timeout`` only guards against a hang; it is not part of the handshake.
    """
    import fcntl
    import threading

    fd = os.open(Path(folder) / ".stickslip.lock", os.O_RDONLY)
    taken = threading.Event()

    def take() -> None:
        fcntl.flock(fd, fcntl.LOCK_SH)
        taken.set()

    threading.Thread(target=take, daemon=True).start()
    try:
        assert taken.wait(timeout), f"{folder} is still locked after {timeout} s (a hang)"
    finally:
        os.close(fd)


def wait_for_file(path: Path, timeout: float = 120.0) -> str:
    """The text of ``path`` once a program has written it (atomically), e.g. a readiness
    marker; ``timeout`` only guards against a hang."""
    import time

    t0 = time.monotonic()
    while not Path(path).exists():
        assert time.monotonic() - t0 < timeout, f"{path} never appeared (a hang)"
        time.sleep(0.02)
    return Path(path).read_text()
