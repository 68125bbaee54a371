"""One look for every figure of the project: the contact-status colours and the units.

Import these instead of writing colours or scale factors into a plotting function, so that a
zone has the same colour and a quantity the same unit in every picture:

* contact status (the codes of ``samples.npz``'s ``status``): 0 separation, 1 stick, 2 slip;
* displacements in mm, pressures and tractions in MPa, velocities in m/s, frequencies in Hz,
  times in ms, energies in J/m (per unit length of the tube, plane strain);
* the colour map of u_r − d (space-time maps and iso-value maps);
* the colours of the regimes of a sweep's map;
* the title lines that name a run's scene and what its analysis found.

matplotlib is imported only inside the functions that need it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

#: Labels and colours of the contact status codes 0, 1, 2 (samples.npz ``status``).
STATUS_LABELS = ("separation", "stick", "slip")
STATUS_COLORS = ("#a6a6a6", "#1f77b4", "#ff7f0e")  # grey, blue, orange
#: Colour map of the displacement fields (u_r − d) in space-time and iso-value maps.
FIELD_CMAP = "viridis"
#: Colours of the regimes a run can end in (sweep maps), plus a failed run.
REGIME_COLORS = {
    "steady-sliding": "#d9d9d9",
    "stick-slip": "#4c9be8",
    "slip-separation": "#f5b041",
    "stick-slip-separation": "#d64541",
    "diverged": "#222222",
    "failed": "#ffffff",
}

#: Scale factors from SI to the units of the figures.
MM = 1e3  # m -> mm
MPA = 1e-6  # Pa -> MPa
MS = 1e3  # s -> ms


def status_cmap() -> tuple[Any, Any]:
    """(ListedColormap, BoundaryNorm) that map the status codes 0, 1, 2 to their colours."""
    from matplotlib.colors import BoundaryNorm, ListedColormap

    cmap = ListedColormap(STATUS_COLORS, name="contact_status")
    return cmap, BoundaryNorm([-0.5, 0.5, 1.5, 2.5], cmap.N)


def status_colorbar(fig: Any, mappable: Any, ax: Any) -> Any:
    """A colour bar of a status map, ticks labelled separation / stick / slip."""
    cb = fig.colorbar(mappable, ax=ax, ticks=[0, 1, 2])
    cb.ax.set_yticklabels(STATUS_LABELS)
    return cb


def shade_zones(ax: Any, x: np.ndarray, status: np.ndarray, alpha: float = 0.35) -> None:
    """Shade the contact zones of ``status`` (codes at the sorted abscissae ``x``) behind a
    curve: each node owns the interval between the midpoints to its neighbours."""
    x = np.asarray(x, dtype=float)
    status = np.asarray(status)
    if x.size == 0:
        return
    mid = 0.5 * (x[1:] + x[:-1])
    half = 0.5 * (x[1] - x[0]) if x.size > 1 else 0.5
    edges = np.concatenate([[x[0] - half], mid, [x[-1] + half]])
    change = np.flatnonzero(np.diff(status)) + 1
    starts = np.concatenate([[0], change])
    ends = np.concatenate([change, [status.size]])
    labelled: set[int] = set()
    for a, b in zip(starts, ends, strict=True):
        code = int(status[a])
        ax.axvspan(edges[a], edges[b], color=STATUS_COLORS[code], alpha=alpha, lw=0,
                   label=None if code in labelled else STATUS_LABELS[code])
        labelled.add(code)


def status_handles(alpha: float = 1.0) -> list[Any]:
    """Legend entries of the three contact states."""
    from matplotlib.patches import Patch

    return [Patch(facecolor=c, alpha=alpha, label=lab)
            for c, lab in zip(STATUS_COLORS, STATUS_LABELS, strict=True)]


def scene_title(scene: dict, n_nodes: int | None = None) -> str:
    """One line that names a run's scene and its parameters (true for any scene)."""
    g, ld, tm = scene["geometry"], scene["loading"], scene["time"]
    damp = scene.get("damping", {})
    tau = float(damp.get("retardation_time") or 0.0)
    if not tau and float(damp.get("loss_factor") or 0.0) > 0.0:
        tau = float(damp["loss_factor"]) / (2 * np.pi * float(damp["reference_frequency_hz"]))
    n = n_nodes if n_nodes is not None else scene["mesh"]["n_inner"]
    return (f"{scene['name']}: Ω = {ld['omega']:g} rad/s, δ = {g['delta']:g}, f = {ld['f']:g}, "
            f"N = {n}, β₂ = {tm['beta2']:g}, "
            + (f"Kelvin–Voigt τ = {1e6 * tau:.3g} µs" if tau > 0 else "no damping"))


def wave_title(summary: dict) -> str:
    """What the run's wave analysis found, in one line (steady sliding reads as such)."""
    regime = summary.get("regime")
    if regime is None:
        return f"status {summary.get('status', '?')}, no wave analysis"
    if regime == "steady-sliding":
        return "steady sliding (no wave)"
    if summary.get("direction") == "standing":
        return (f"{regime}, k = {summary['mode']} standing (does not travel), "
                f"{summary['frequency_hz']:.0f} Hz")
    return (f"{regime}, k = {summary['mode']}, c = {summary['celerity_m_s']:+.0f} m/s "
            f"(+ = rotation sense), {summary['frequency_hz']:.0f} Hz")
