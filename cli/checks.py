"""Checks the command handlers make before any work: one line naming the problem and the fix.

Light (standard library only at import): every command module may use it.
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["output_file_problem", "samples_problem"]


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


def samples_problem(run_dir: str | Path, need: int = 0) -> str | None:
    """Why ``RUN_DIR/samples.npz`` cannot be used (missing, corrupt, too short), or None."""
    import zipfile

    import numpy as np

    f = Path(run_dir) / "samples.npz"
    if not f.exists():
        return f"{run_dir} has no samples.npz (not a finished run directory)"
    try:
        with np.load(f) as data:
            n = int(data["t"].size)
            data["u_r"]  # noqa: B018 - read it: a truncated member fails here
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as err:
        return (f"{f} is not a readable samples file ({type(err).__name__}: "
                f"{str(err)[:80]}); run the scene again")
    if n < need:
        return (f"{run_dir} is too short: {n} samples, the wave analysis needs at least "
                f"{need}; run longer (time.end_time) or sample more often "
                "(output.sample_interval)")
    return None
