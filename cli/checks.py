"""Checks the command handlers make before any work: one line naming the problem and the fix.

Light (standard library only at import): the command line imports it at start-up.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from stickslip.solver.scene import SceneError, require_plane_strain
from stickslip.studies.rundir.readers import ReadError, read_scene_file

__all__ = ["environment_problem", "fail", "output_file_problem", "run_dir_dimension_problem"]


def _writable_dir(path: str) -> bool:
    return os.path.isdir(path) and os.access(path, os.W_OK | os.X_OK) \
        and not os.path.realpath(path).startswith(("/proc", "/sys"))


def environment_problem(env: dict | None = None) -> str | None:
    """Why this process environment cannot run stickslip (one line, the variable and the
    fix), or None. Open MPI's initialisation fails without a home directory (about 20 lines,
    under mpirun on every rank), PETSc and Open MPI write temporary files in ``TMPDIR``."""
    env = os.environ if env is None else env
    home = env.get("HOME", "")
    if not home:
        return ("HOME is not set: Open MPI, PETSc and matplotlib need a writable home "
                "directory; set it (export HOME=/tmp, or docker run -e HOME=/tmp)")
    if not _writable_dir(home):
        return (f"HOME={home} is not a writable directory: Open MPI, PETSc and matplotlib "
                "write there; point HOME at a writable one (export HOME=/tmp)")
    tmp = env.get("TMPDIR", "")
    if tmp and not _writable_dir(tmp):
        return (f"TMPDIR={tmp} is not a writable directory: Open MPI and PETSc write "
                "temporary files there; unset TMPDIR or point it at a writable one "
                "(export TMPDIR=/tmp)")
    return None


def output_file_problem(path: str | Path, flag: str) -> str | None:
    """Why a file cannot be written at ``path`` (given as ``flag``), or None."""
    p = Path(path)
    if p.is_dir():
        return f"{flag} {p} is a directory; give a file name such as {p / 'out'}"
    if p.exists() and not p.is_file():
        return f"{flag} {p} is not a regular file (a device?); give a file name"
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        return f"{flag} {p}: the folder {parent} does not exist; create it or choose another"
    if not os.access(parent, os.W_OK | os.X_OK) or str(parent.resolve()).startswith(
            ("/proc", "/sys")):
        return f"{flag} {p}: cannot write in {parent} (read-only or no permission); " \
               "choose another place"
    return None


def run_dir_dimension_problem(run_dir: str | Path) -> str | None:
    """Why the transient cannot go on from ``run_dir`` (its scene.toml a 3D scene:
    ``solver.scene.require_plane_strain``, one line), or None. A missing or invalid
    scene.toml is left to the command's own reader, which names what is wrong with it."""
    path = Path(run_dir) / "scene.toml"
    try:  # the validated reader: no link, no FIFO (whose read would wait for ever)
        scene = read_scene_file(path)
    except (ReadError, OSError):
        return None
    try:
        require_plane_strain(scene)
    except SceneError as err:
        return f"{path}: {err}"
    return None


def fail(message: str, rank: int = 0) -> int:
    """The one-line refusal ``error: message`` on stderr (by rank 0 only: ``rank`` is this
    process's); exit status 2."""
    if rank == 0:
        print(f"error: {message}", file=sys.stderr, flush=True)
    return 2
