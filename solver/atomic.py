"""Atomic file writes: a reader sees the old file or the new one, never half of one.

Every output goes through a temporary file in the same folder (``.NAME.PID.*.tmp``), is flushed to
disk, given the mode the umask allows (``mkstemp`` alone would leave it 0600, unreadable by
the host user of a Docker run) and renamed over ``NAME``. On any failure (disk full, a signal)
the temporary file is removed: nothing is ever left behind.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

__all__ = ["atomic_save_npz", "atomic_write", "atomic_write_text", "remove_temporaries",
           "umask_mode"]


def umask_mode(full: int = 0o666) -> int:
    """``full`` with the process umask applied (what ``open(..., 'w')`` would give)."""
    mask = os.umask(0)
    os.umask(mask)
    return full & ~mask


def atomic_write(path: str | Path, fill: Callable[[IO[bytes]], Any]) -> Path:
    """Write ``path`` with ``fill(binary file)`` through a temporary file, fsync, rename."""
    p = Path(path)
    # the writer's pid in the name: a process killed outright (SIGKILL) leaves a temporary
    # file that its survivors can tell from the live writers' (studies.rundir's watchdog)
    fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.{os.getpid()}.", suffix=".tmp",
                               dir=p.parent or ".")
    try:
        os.fchmod(fd, umask_mode())
        with os.fdopen(fd, "wb") as fh:
            fill(fh)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, p)
    except BaseException as err:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        if isinstance(err, OSError) and err.filename is None and err.errno is not None:
            # a failed write names no file ("No space left on device"): name the one written
            raise OSError(err.errno, err.strerror, str(p)) from err
        raise
    return p


def atomic_write_text(path: str | Path, text: str) -> Path:
    """Write ``text`` (UTF-8, ``\\n`` line ends) to ``path`` atomically."""
    data = text.encode("utf-8")
    return atomic_write(path, lambda fh: fh.write(data))


#: zlib level of the compressed .npz files. Level 1 instead of numpy's default 6 makes
#: them 1.02x larger and 1.45x faster to write: a run's samples are float64
#: fields that deflate to ~0.57 of their size at either level (docs/performance.md).
NPZ_LEVEL = 1


def _save_npz(fh: IO[bytes], arrays: dict[str, Any], compress: bool) -> None:
    """``numpy.savez_compressed`` / ``savez`` of ``arrays`` into ``fh`` (the same .npz
    layout, one NAME.npy member per array), deflated at ``NPZ_LEVEL`` when ``compress``."""
    import zipfile

    import numpy as np

    method = zipfile.ZIP_DEFLATED if compress else zipfile.ZIP_STORED
    with zipfile.ZipFile(fh, "w", compression=method, compresslevel=NPZ_LEVEL) as zf:
        for name, value in arrays.items():
            with zf.open(f"{name}.npy", "w", force_zip64=True) as member:
                np.lib.format.write_array(member, np.asanyarray(value), allow_pickle=True)


def atomic_save_npz(path: str | Path, arrays: dict[str, Any], compress: bool = True) -> Path:
    """``numpy.savez_compressed`` (or ``savez``) of ``arrays`` to ``path`` atomically."""
    return atomic_write(path, lambda fh: _save_npz(fh, arrays, compress))


def remove_temporaries(folder: str | Path, pid: int) -> None:
    """Remove the temporary files that process ``pid`` (now dead) left in ``folder``."""
    for tmp in Path(folder).glob(f".*.{pid}.*.tmp"):
        try:
            tmp.unlink()
        except OSError:
            pass
