"""The run directory on disk, through :mod:`studies.rundir.ownership` (kind ``run``): refuse
what is not stickslip's or is live, build a replacement beside the old run and swap it in at
the end, so ``--force`` never loses a finished run."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING

from stickslip.studies.output import output_root, process_alive  # noqa: F401  (re-exported)
from stickslip.studies.rundir.ownership import (
    Claim,
    OwnershipError,
    claim,
    normal_path,
    owned,
    refusal,
)

if TYPE_CHECKING:  # MPI starts where a run uses it, not when this module is imported
    from mpi4py import MPI

#: Where a run ends up (``final``) and where it is written meanwhile (``work``).
RunDir = Claim

#: The run directory is refused (exists, not stickslip's, live, not writable): one line.
RunDirError = OwnershipError

KIND = "run"


def is_run_dir(path: Path) -> bool:
    """True if ``path`` carries stickslip's run marker (a summary alone is not enough)."""
    return owned(path, KIND)


def _refusal(path: Path, force: bool) -> str | None:
    """Why ``path`` cannot take a run, or None (rank 0; no side effects)."""
    return refusal(path, KIND, force=force)


def prepare_run_dir(path: Path, force: bool, comm: MPI.Comm, in_place: bool = False) -> RunDir:
    """Claim ``path`` for a run (collective; rank 0 claims and holds the lock).

    Refused (:class:`RunDirError`, every rank): a non-empty ``path`` without ``force``, one
    that is not a run directory even with ``force``, a live one, a file, an unwritable place.
    ``in_place``: a replaced run's files are deleted first and the new run is written into
    ``path`` itself (for writers that do not swap). Every rank names ``path`` as
    :func:`~studies.rundir.ownership.normal_path` does (``RunDir.final``).
    """
    path = normal_path(path)
    result: tuple = (None, None, False)
    rd = None
    if comm.rank == 0:
        try:
            rd = claim(path, KIND, force=force, in_place=in_place)
            result = (None, str(rd.work), rd.created)
        except OwnershipError as err:
            result = (str(err), None, False)
    error, work, created = comm.bcast(result, root=0)
    if error:
        raise RunDirError(error)
    return rd if rd is not None else RunDir(path, Path(work), KIND, created=bool(created))


def commit_run_dir(rd: RunDir) -> None:
    """Swap the finished replacement in (rank 0)."""
    rd.commit()


def discard_run_dir(rd: RunDir) -> None:
    """Drop an unfinished replacement; the earlier run is left as it was."""
    rd.discard()


def _disk_status(folder: Path) -> str | None:
    """The status in ``folder/summary.json``, None if there is none (or it is unreadable)."""
    try:
        return str(json.loads((Path(folder) / "summary.json").read_text())["status"])
    except (OSError, ValueError, KeyError, TypeError):
        return None
