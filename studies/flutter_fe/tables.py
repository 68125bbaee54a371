"""The CEA as tables a brake-NVH engineer reads: every mode of one friction coefficient (the
layout of a complex-eigenvalue step's output), the modes against friction, and the lock-in
points where a wavenumber's pair of modes couples and starts to grow.

Each mode is one real motion ``u = Re(ψ e^{λt})``, λ = Re λ + i Im λ with Im λ = 2π f ≥ 0
(``cea.CEAMode``); the damping ratio is ζ = −Re λ / |λ| (negative: unstable).
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Sequence

from stickslip.studies.flutter_fe.cea import CEAMode, CEAResult

#: The columns of one mode, in order.
MODE_COLUMNS = ("mode", "frequency_hz", "re_lambda_per_s", "im_lambda_rad_s", "damping_ratio",
                "k", "direction", "purity", "phase_speed_m_s", "unstable", "mesh_scale",
                "axial_order")


def mode_row(index: int, mode: CEAMode, unstable: bool) -> dict:
    """One mode as a row of ``MODE_COLUMNS`` (1-based ``mode`` in frequency order)."""
    return {"mode": index, "frequency_hz": mode.frequency_hz,
            "re_lambda_per_s": mode.growth_rate,
            "im_lambda_rad_s": 2.0 * math.pi * mode.frequency_hz,
            "damping_ratio": mode.zeta, "k": mode.k, "direction": mode.direction,
            "purity": mode.purity, "phase_speed_m_s": mode.phase_speed_m_s,
            "unstable": int(unstable), "mesh_scale": int(mode.mesh_scale),
            "axial_order": mode.axial_order}


def mode_rows(result: CEAResult) -> list[dict]:
    """Every computed mode of ``result``, stable ones too, in frequency order."""
    growing = {id(m) for m in result.unstable()}
    return [mode_row(i, m, id(m) in growing)
            for i, m in enumerate(sorted(result.modes, key=lambda m: m.frequency_hz), 1)]


def sweep_rows(results: Sequence[CEAResult]) -> list[dict]:
    """The modes against friction, one row per (f, mode): ``f`` then ``MODE_COLUMNS``."""
    return [{"f": r.f, **row} for r in results for row in mode_rows(r)]


def lock_in_points(results: Sequence[CEAResult]) -> list[dict]:
    """For each wavenumber |k| with a resolved mode, where along the friction sweep its modes
    first grow (mode coupling, "lock-in"): the last f at which none of its resolved modes is
    unstable and the first at which one is, with that mode's frequency and growth. A
    wavenumber unstable at the first f is reported with ``f_stable = None`` (a degenerate
    ±k doublet couples at any f > 0); one that never grows is left out."""
    ordered = sorted(results, key=lambda r: r.f)
    wavenumbers = sorted({m.wavenumber for r in ordered for m in r.modes
                          if m.wavenumber > 0 and not m.mesh_scale})
    points = []
    for k in wavenumbers:
        previous = None
        for r in ordered:
            growing = [m for m in r.unstable() if m.wavenumber == k and not m.mesh_scale]
            if growing:
                points.append({"k": k, "f_stable": previous, "f_unstable": r.f,
                               "frequency_hz": growing[0].frequency_hz,
                               "growth_rate_per_s": growing[0].growth_rate})
                break
            previous = r.f
    return points


def csv_text(rows: Sequence[dict]) -> str:
    """Rows of one set of keys as CSV text, floats to 10 significant digits."""
    if not rows:
        return ""
    out = io.StringIO()
    writer = csv.DictWriter(out, fieldnames=list(rows[0]), lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({key: f"{v + 0.0:.10g}" if isinstance(v, float) else v  # no "-0"
                         for key, v in row.items()})
    return out.getvalue()
