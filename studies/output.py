"""Where run and sweep directories go by default (no heavy imports: the CLI reads it)."""

from __future__ import annotations

import os
import socket
from pathlib import Path

DEFAULT_OUTPUT_ROOT = "runs"


def output_root() -> Path:
    """``$STICKSLIP_OUTPUT`` or ``./runs``."""
    return Path(os.environ.get("STICKSLIP_OUTPUT", DEFAULT_OUTPUT_ROOT))


def process_alive(summary: dict) -> bool | None:
    """Is the process that wrote a ``running`` summary alive? None: cannot tell (other host)."""
    pid, host = summary.get("pid"), summary.get("host")
    if not isinstance(pid, int) or host != socket.gethostname():
        return None
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # alive, owned by another user
        return True
    return True
