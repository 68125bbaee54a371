"""Figure 1 of the paper for a :class:`~semianalytic.waves.TravellingWave` (matplotlib, lazy)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from stickslip.semianalytic.waves import celerity_m_s, frequency_hz

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from stickslip.semianalytic.waves import TravellingWave

__all__ = ["plot_wave"]

_ZONE_NAMES = ("separation", "stick", "slip")


def _shade(ax: object, phi: np.ndarray, zone: np.ndarray, T: float,
           colours: Sequence[str]) -> None:
    edges = np.flatnonzero(np.diff(zone)) + 1
    starts = np.concatenate([[0], edges])
    ends = np.concatenate([edges, [zone.size]])
    for a, b in zip(starts, ends, strict=True):
        x0 = phi[a]
        x1 = phi[b] if b < zone.size else T
        colour = colours[int(zone[a])]
        ax.axvspan(x0, x1, color=colour, alpha=0.35, lw=0)  # type: ignore[attr-defined]


def plot_wave(
    wave: TravellingWave, path: str, *, zone_colours: Sequence[str], R: float = 1.0,
    omega: float = 1.0, n: int = 2000
) -> None:
    """Draw U, V, phase diagrams (U, U̇), (V, V̇) and P, Q over one period, zones shaded.

    Time derivatives are ``U̇ = dU/dt = −c U'`` (non-dimensional time ``Ωt``).
    ``zone_colours``: colours of separation, stick, slip (the project's code,
    ``postprocess.style.STATUS_COLORS``; this package imports nothing of the project).
    """
    zones = dict(enumerate(zip(zone_colours, _ZONE_NAMES, strict=True)))
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ev = wave.evaluate(n)
    fig, axs = plt.subplots(2, 3, figsize=(14, 8), constrained_layout=True)
    _plot_profiles(axs[0], wave, ev, zone_colours)
    _plot_phase_diagrams(axs[1, :2], wave, ev, zones)
    _write_facts(axs[1, 2], wave, R, omega, zones)
    fig.suptitle("Travelling wave of the reduced model (paper Figure 1 layout)")
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _plot_profiles(axs: Sequence[Axes], wave: TravellingWave, ev: dict[str, np.ndarray],
                   zone_colours: Sequence[str]) -> None:
    """Top row: U(φ) with the contact level δ, V(φ), and the reactions P, Q with fP."""
    phi, U, V, P, Q, zone = (ev[k] for k in ("phi", "U", "V", "P", "Q", "zone"))
    T = wave.period
    for ax, y, lab in ((axs[0], U, "U = u(1)/R"), (axs[1], V, "V = v(1)/R")):
        _shade(ax, phi, zone, T, zone_colours)
        ax.plot(phi, y, "k-", lw=1.5)
        ax.set_xlabel("φ = θ − ct (rad)")
        ax.set_ylabel(lab)
        ax.set_xlim(0, T)
        ax.grid(alpha=0.3)
    axs[0].axhline(wave.delta, color="r", ls="--", lw=1, label="δ (contact)")
    axs[0].legend(loc="best", fontsize=8)
    ax = axs[2]
    _shade(ax, phi, zone, T, zone_colours)
    ax.plot(phi, P, "b-", lw=1.5, label="P")
    ax.plot(phi, Q, "m-", lw=1.5, label="Q")
    ax.plot(phi, wave.f * P, "m:", lw=1, label="fP")
    ax.set_xlabel("φ = θ − ct (rad)")
    ax.set_ylabel("reduced reactions P, Q")
    ax.set_xlim(0, T)
    ax.legend(loc="best", fontsize=8)
    ax.grid(alpha=0.3)


def _plot_phase_diagrams(axs: Sequence[Axes], wave: TravellingWave, ev: dict[str, np.ndarray],
                         zones: dict[int, tuple[str, str]]) -> None:
    """Bottom row: the phase diagrams (U, U̇) and (V, V̇), U̇ = −c U', points coloured by
    zone; V̇ = 1 is stick."""
    U, V, zone = ev["U"], ev["V"], ev["zone"]
    Ud, Vd = -wave.c * ev["dU"], -wave.c * ev["dV"]
    for ax, x, y, xl, yl in (
        (axs[0], U, Ud, "U", "dU/dt (per unit Ωt)"),
        (axs[1], V, Vd, "V", "dV/dt (per unit Ωt)"),
    ):
        for zid, (colour, name) in zones.items():
            m = zone == zid
            if m.any():
                ax.plot(x[m], y[m], ".", ms=2, color=colour, label=name)
        ax.plot(x, y, "k-", lw=0.5, alpha=0.6)
        ax.set_xlabel(xl)
        ax.set_ylabel(yl)
        ax.set_title(f"phase diagram ({xl}, d{xl}/dt)")
        ax.grid(alpha=0.3)
    axs[1].axhline(1.0, color="r", ls="--", lw=1, label="V̇ = 1 (stick)")
    axs[0].legend(loc="best", fontsize=8, markerscale=4)
    axs[1].legend(loc="best", fontsize=8, markerscale=4)


def _write_facts(ax: Axes, wave: TravellingWave, R: float, omega: float,
                 zones: dict[int, tuple[str, str]]) -> None:
    """The wave's facts (regime, inputs, c, frequency, ψ1, ψ2, amplitude, admissibility) and
    the zones' legend, in an empty panel."""
    from matplotlib.patches import Patch

    ax.axis("off")
    co = wave.coeffs
    status = "admissible" if wave.admissible else f"NOT admissible: {wave.violated}"
    lines = [
        f"regime: {wave.regime} ({wave.junction})",
        f"ν = {co.nu}, ξ = {co.xi}, f = {wave.f}, k = {wave.k}, δ = {wave.delta}",
        f"Ω = {omega} rad/s, R = {R} m, γ = {co.gamma:.4g}",
        f"c = {wave.c:.5g}  ({celerity_m_s(wave.c, R, omega):.1f} m/s)",
        f"frequency = {frequency_hz(wave.c, wave.k, omega):.1f} Hz",
        f"ψ1 = {wave.psi1:.4f}, ψ2 = {wave.psi2:.4f}",
        f"max U − δ = {wave.amplitude:.3g}",
        status,
    ]
    ax.text(
        0.0,
        1.0,
        "\n".join(lines),
        va="top",
        family="monospace",
        fontsize=10,
        transform=ax.transAxes,
    )
    ax.legend(
        handles=[Patch(color=c, alpha=0.5, label=n) for c, n in zones.values()],
        loc="lower left",
        title="zones",
    )
