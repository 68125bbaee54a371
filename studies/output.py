"""Where run and sweep directories go by default (no heavy imports: the CLI reads it)."""

from __future__ import annotations

import os
from pathlib import Path

DEFAULT_OUTPUT_ROOT = "runs"


def output_root() -> Path:
    """``$STICKSLIP_OUTPUT`` or ``./runs``."""
    return Path(os.environ.get("STICKSLIP_OUTPUT", DEFAULT_OUTPUT_ROOT))
