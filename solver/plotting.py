"""Figures of a run directory (matplotlib, Agg): the pictures of ``stickslip run --plot``.

* ``spacetime.png``: iso-values of u_r - d over (theta, t) on the inner circle, and the contact
  status map (separation / stick / slip) — the wave's travel direction is the slope;
* ``profile.png``: u_r - d and u_theta along the circle at the last sample, zones shaded;
* ``phase.png``: phase diagrams (u_r, du_r/dt) and (u_theta, du_theta/dt) at the first probe;
* ``energy.png``: kinetic + strain energy and the contact work over time.
"""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import numpy as np

STATUS_COLORS = ("#d9d9d9", "#1f77b4", "#ff7f0e")  # separation, stick, slip


def plot_run(run_dir: Path) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap

    run_dir = Path(run_dir)
    data = np.load(run_dir / "samples.npz")
    scene = tomllib.loads((run_dir / "scene.toml").read_text())
    summary = json.loads((run_dir / "summary.json").read_text())
    d = scene["geometry"]["delta"] * scene["geometry"]["R"]
    t, theta = data["t"], data["theta"]
    ur, ut, st = data["u_r"] - d, data["u_theta"], data["status"]
    deg = np.degrees(theta)
    title = (f"{scene['name']}: Ω = {scene['loading']['omega']:g} rad/s, "
             f"δ = {scene['geometry']['delta']:g}, f = {scene['loading']['f']:g}, "
             f"N = {theta.size}")
    wave = ""
    if "regime" in summary:
        wave = (f"{summary['regime']}, k = {summary['mode']}, "
                f"c = {summary['celerity_m_s']:+.0f} m/s, {summary['frequency_hz']:.0f} Hz")
    out: list[Path] = []

    # Space-time iso-values and status map.
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), sharey=True, constrained_layout=True)
    ms = 1e3 * t
    im = axes[0].pcolormesh(deg, ms, 1e3 * ur, shading="nearest", cmap="viridis")
    fig.colorbar(im, ax=axes[0], label="u_r − d (mm)")
    axes[0].set(xlabel="θ (deg)", ylabel="t (ms)", title="radial displacement on r = R")
    cmap = ListedColormap(STATUS_COLORS)
    im2 = axes[1].pcolormesh(deg, ms, st, shading="nearest", cmap=cmap, vmin=-0.5, vmax=2.5)
    cb = fig.colorbar(im2, ax=axes[1], ticks=[0, 1, 2])
    cb.ax.set_yticklabels(["separation", "stick", "slip"])
    axes[1].set(xlabel="θ (deg)", title="contact status")
    fig.suptitle(f"{title}\n{wave}", fontsize=10)
    out.append(_save(fig, run_dir / "spacetime.png"))

    # Profile at the last sample.
    fig, ax = plt.subplots(figsize=(8, 3.8), constrained_layout=True)
    ax.plot(deg, 1e3 * ur[-1], label="u_r − d")
    ax.plot(deg, 1e3 * (ut[-1] - ut[-1].mean()), label="u_θ − mean")
    _shade_zones(ax, deg, st[-1])
    ax.set(xlabel="θ (deg)", ylabel="displacement (mm)",
           title=f"inner circle at t = {1e3 * t[-1]:.1f} ms   ({wave})")
    ax.legend(loc="upper right", fontsize=8)
    out.append(_save(fig, run_dir / "profile.png"))

    # Phase diagrams at the first probe (every-step history), over the analysis window.
    window = summary.get("analysis_window_s", (t[-1] - t[0]) / 3)
    if "probe_data" in data.files and data["probe_data"].shape[1] > 0:
        pt, pd = data["probe_t"], data["probe_data"][0]
        sel = pt >= pt[-1] - min(window, 5.0 * _period(summary, pt))
        pr, pth, pvr, pvt = pd[sel, 0] - d, pd[sel, 1], pd[sel, 2], pd[sel, 3]
        probe_deg = float(data["probe_deg"][0])
    else:
        probe = scene["output"].get("probes_deg", [0.0])[0]
        j = int(np.argmin(np.abs(((deg - probe + 180.0) % 360.0) - 180.0)))
        sel = t >= t[-1] - window
        pr, pth, pvr, pvt = ur[sel, j], ut[sel, j], data["v_r"][sel, j], data["v_theta"][sel, j]
        probe_deg = float(deg[j])
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    axes[0].plot(1e3 * pr, pvr, lw=0.8)
    axes[0].set(xlabel="u_r − d (mm)", ylabel="du_r/dt (m/s)", title="radial phase diagram")
    axes[1].plot(1e3 * pth, pvt, lw=0.8, color="C1")
    rw = scene["geometry"]["R"] * scene["loading"]["omega"]
    axes[1].axhline(rw, color="k", ls="--", lw=0.8, label="RΩ (stick)")
    axes[1].set(xlabel="u_θ (mm)", ylabel="du_θ/dt (m/s)", title="tangential phase diagram")
    axes[1].legend(fontsize=8)
    fig.suptitle(f"{title}, probe θ = {probe_deg:.1f}°", fontsize=10)
    out.append(_save(fig, run_dir / "phase.png"))

    # Energies.
    e = data["energies"]
    fig, ax = plt.subplots(figsize=(8, 3.8), constrained_layout=True)
    ax.plot(ms, e[:, 0] + e[:, 1], label="kinetic + strain")
    ax.plot(ms, e[:, 0], label="kinetic", lw=0.8)
    ax.plot(ms, e[0, 0] + e[0, 1] + e[:, 2] - e[0, 2], "--", label="E(0) + contact work")
    ax.set(xlabel="t (ms)", ylabel="energy (J/m)", title="energy balance")
    ax.legend(fontsize=8)
    out.append(_save(fig, run_dir / "energy.png"))
    return out


def _period(summary: dict, t: np.ndarray) -> float:
    """Wave period seen at a fixed point (s), or the record length if there is no wave."""
    freq = summary.get("frequency_hz") or 0.0
    return 1.0 / freq if freq > 0 else float(t[-1] - t[0])


def _shade_zones(ax, deg: np.ndarray, status: np.ndarray) -> None:
    for code, color in enumerate(STATUS_COLORS):
        mask = status == code
        if mask.any():
            ax.fill_between(deg, 0, 1, where=mask, color=color, alpha=0.35,
                            transform=ax.get_xaxis_transform(), step="mid", lw=0,
                            label=("separation", "stick", "slip")[code])


def _save(fig, path: Path) -> Path:
    import matplotlib.pyplot as plt

    tmp = path.with_name(f".{path.stem}.tmp.png")
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    tmp.replace(path)
    return path
