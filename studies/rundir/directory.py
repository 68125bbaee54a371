"""The run directory on disk: refuse what is not ours, build a replacement beside the old
run and swap it in at the end (``--force`` never loses a finished run; issue 12)."""

from __future__ import annotations

import json
import os
import shutil
import socket
from dataclasses import dataclass
from pathlib import Path

from mpi4py import MPI

from studies.output import output_root, process_alive  # noqa: F401  (re-exported)


class RunDirError(FileExistsError):
    """The run directory is refused (exists, not ours, not writable): a one-line message."""


def is_run_dir(path: Path) -> bool:
    """True if ``path`` holds a ``summary.json`` written by ``stickslip run`` (its marker)."""
    try:
        s = json.loads((Path(path) / "summary.json").read_text())
    except (OSError, ValueError):
        return False
    return isinstance(s, dict) and "scene" in s and "status" in s


@dataclass
class RunDir:
    """Where a run ends up (``final``) and where it is written meanwhile (``work``).

    Replacing an earlier run (``--force``) writes into a hidden sibling ``.NAME.new.PID`` and
    swaps it in at the end (:func:`commit_run_dir`): the earlier run stays intact until the new
    one has a final status, and stays for good if the new one fails.
    """

    final: Path
    work: Path
    created: bool = False

    @property
    def replacing(self) -> bool:
        return self.work != self.final


def _siblings(path: Path, kind: str) -> list[Path]:
    return sorted(path.parent.glob(f".{path.name}.{kind}.*"))


def _recover(path: Path) -> None:
    """Clean up after a run killed while replacing ``path`` (rank 0, before anything else).

    ``.NAME.old.PID`` exists only during the swap: if NAME is missing it goes back in place.
    ``.NAME.new.PID`` of a dead process is an unfinished replacement: removed.
    """
    for old in _siblings(path, "old"):
        if not path.exists() and is_run_dir(old):
            os.rename(old, path)
        elif is_run_dir(old):
            shutil.rmtree(old, ignore_errors=True)
    for new in _siblings(path, "new"):
        pid = new.name.rsplit(".", 1)[-1]
        alive = process_alive({"pid": int(pid), "host": socket.gethostname()}) \
            if pid.isdigit() else True
        if not alive and (is_run_dir(new) or not any(new.iterdir())):
            shutil.rmtree(new, ignore_errors=True)


def _refusal(path: Path, force: bool) -> str | None:
    """Why ``path`` cannot take a run, or None (rank 0; no side effects)."""
    fix = "choose another -o"
    if path.exists() and not path.is_dir():
        return f"-o {path} is not a directory (a file or device); {fix}"
    if path.is_dir() and any(path.iterdir()):
        if not force:
            return (f"run directory {path} exists; use --force to replace it (only a run "
                    f"directory is replaced, atomically), or {fix}")
        if not is_run_dir(path):
            return (f"{path} is not a stickslip run directory (no run summary.json): --force "
                    f"replaces only run directories; {fix}, or empty it yourself")
    parent = path.parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not parent.is_dir() or not os.access(parent, os.W_OK | os.X_OK) \
            or str(parent.resolve()).startswith(("/proc", "/sys")):
        return f"cannot create {path}: {parent} is not a writable directory; {fix}"
    return None


def prepare_run_dir(path: Path, force: bool, comm: MPI.Comm) -> RunDir:
    """Check ``path`` and create the directory to write into (collective; rank 0 acts).

    Refused (:class:`RunDirError`, every rank): a non-empty ``path`` without ``force``, one
    that is not a run directory even with ``force``, a file, an unwritable place.
    """
    path = Path(path)
    result: tuple = (None, None, False)
    if comm.rank == 0:
        try:
            _recover(path)
            error = _refusal(path, force)
            if error is None:
                if path.is_dir() and any(path.iterdir()):
                    work = path.parent / f".{path.name}.new.{os.getpid()}"
                    work.mkdir()
                    created = True
                else:
                    work = path
                    created = not path.exists()
                    path.mkdir(parents=True, exist_ok=True)
                result = (None, str(work), created)
            else:
                result = (error, None, False)
        except OSError as err:
            result = (f"cannot create {path}: {err.strerror or err}; choose another -o", None,
                      False)
    error, work, created = comm.bcast(result, root=0)
    if error:
        raise RunDirError(error)
    return RunDir(final=path, work=Path(work), created=bool(created))


def commit_run_dir(rd: RunDir) -> None:
    """Swap the finished replacement in (rank 0): two renames, then the old run is deleted."""
    if not rd.replacing:
        return
    old = rd.final.parent / f".{rd.final.name}.old.{os.getpid()}"
    os.rename(rd.final, old)
    os.rename(rd.work, rd.final)
    shutil.rmtree(old, ignore_errors=True)


def discard_run_dir(rd: RunDir) -> None:
    """Drop an unfinished replacement; the earlier run is left as it was."""
    if rd.replacing:
        shutil.rmtree(rd.work, ignore_errors=True)


def _disk_status(folder: Path) -> str | None:
    """The status in ``folder/summary.json``, None if there is none (or it is unreadable)."""
    try:
        return str(json.loads((Path(folder) / "summary.json").read_text())["status"])
    except (OSError, ValueError, KeyError, TypeError):
        return None
