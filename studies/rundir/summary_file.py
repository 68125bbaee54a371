"""A run's ``summary.json``: its name and its one writer.

Every ``summary.json`` stickslip writes (a run, a batch member, a census start, a sweep's
failed or interrupted scene, a travelling wave) goes through ``write_summary``: one atomic
write of indented JSON, numpy scalars and arrays as plain numbers and lists. It is read,
checked, by ``studies.rundir.readers.read_summary``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from stickslip.solver.atomic import atomic_write_text

#: The file name of a run's summary, in every kind of run directory.
SUMMARY = "summary.json"


def _plain(value: object) -> object:
    """A numpy scalar or array as JSON writes it (``json.dumps``' ``default``)."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")


def json_text(value: object) -> str:
    """``value`` as stickslip writes its JSON files: indented, numpy values plain."""
    return json.dumps(value, indent=2, default=_plain)


def write_summary(folder: str | Path, summary: dict) -> None:
    """Write ``summary`` as ``folder/summary.json``, atomically (a reader sees the old file
    or the new one, never half of one)."""
    atomic_write_text(Path(folder) / SUMMARY, json_text(summary))
