"""A sweep scene's log, ``SWEEP_DIR/logs/ID.log``: one for every way the scene runs.

Every run of the scene (alone on a group of ranks, or as a member of a batch) appends one
block: ``== start DATE WHERE``, what the run prints, a traceback if it raised, and
``== end STATUS``. The log is never opened through a symbolic link (a user's file): a link in
its place is set aside as ``ID.log.link``, kept and not followed, and a new log begun.
"""

from __future__ import annotations

import os
import time
from pathlib import Path


class TaskLog:
    """The log of one sweep scene, opened for one run of it (module docstring)."""

    def __init__(self, path: Path) -> None:
        if path.is_symlink():
            os.replace(path, path.with_name(path.name + ".link"))
        fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_NOFOLLOW, 0o666)
        self.file = os.fdopen(fd, "a")

    def start(self, where: str) -> None:
        """The run's first line: when, and where it runs (ranks, pid, batch)."""
        self.file.write(f"== start {time.strftime('%Y-%m-%dT%H:%M:%S')} {where}\n")
        self.file.flush()

    def write(self, text: str) -> None:
        """Append ``text`` (a traceback, a message); what a run prints goes to ``file``."""
        self.file.write(text)

    def end(self, status: str) -> None:
        """The run's last line, its final status; the log is closed (once)."""
        if not self.file.closed:
            self.file.write(f"== end {status}\n")
            self.file.close()


class LogTee:
    """The logs of a batch's members as one stream: each line (the batch's progress, every
    ``Progress.interval`` seconds) goes into every member's log, as a scene run alone writes
    its progress into its own."""

    def __init__(self, logs: list[TaskLog]) -> None:
        self.files = [log.file for log in logs]

    def write(self, text: str) -> None:
        for file in self.files:
            file.write(text)

    def flush(self) -> None:
        for file in self.files:
            file.flush()
