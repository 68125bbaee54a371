"""Figures of a run directory (matplotlib, Agg): the pictures of ``stickslip run --plot``.

* ``spacetime.png``: iso-values of u_r − d over (θ, t) on the inner circle and the contact
  status map (separation / stick / slip) over the last few periods (``--window``): the wave's
  travel direction is the slope of the stripes;
* ``profile.png``: u_r − d and u_θ along the circle at the last sample, zones shaded;
* ``phase.png``: phase diagrams (u_r − d, du_r/dt) and (u_θ, du_θ/dt) at the first probe;
* ``energy.png``: every term of the energy balance (``postprocess.energy_balance``): kinetic
  and strain energy, the work of the cylinder, the frictional, impact and viscous
  dissipation, and the residual (the algorithmic dissipation of β₂ > ½);
* ``uvpq.png`` (a run that found a wave): one period of the FE wave in its co-moving
  coordinate, u_r − d, u_θ (zones shaded, time order), phase diagrams, and the contact
  pressures p, q when the run recorded nodal forces; reduced-model waves dashed;
* ``isomap.png``: iso-values of u_r − d on the deformed tube (``postprocess.isomap``);
* ``stress.png``: von Mises and contact pressure at the end (``postprocess.stressmap``);
* ``surface.png`` (a 3D tube, instead of the stress map): its contact surface unrolled in
  (θ, z) (``postprocess.surface_map``); its ``isomap.png`` is half the tube, seen obliquely.

Colours and units come from ``postprocess.style`` (mm, MPa, m/s, Hz, ms, J/m).
``phase_family`` overlays several runs' phase diagrams like the paper's Figures 4-6;
``verification_figures`` makes the committed ``docs/figures/fe_*.png``.
"""

from __future__ import annotations

import argparse
import functools
import re
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from stickslip.postprocess.analysis import analyse_run, load_run, run_profile
from stickslip.postprocess.energy_balance import energy_terms
from stickslip.postprocess.isomap import isomap_pair, isomap_tube
from stickslip.postprocess.stressmap import has_stress, stress_maps
from stickslip.postprocess.style import (
    FIELD_CMAP,
    MM,
    MPA,
    MS,
    STATUS_LABELS,
    scene_title,
    shade_zones,
    status_cmap,
    status_colorbar,
    wave_title,
)
from stickslip.postprocess.surface_map import surface_figure
from stickslip.semianalytic.coefficients import coefficients, gamma_from_physical, reaction_scale
from stickslip.semianalytic.waves import find_waves

__all__ = ["plot_run", "parse_window", "spacetime_window", "spacetime_figure",
           "energy_figure", "plot_uvpq", "phase_family", "isomap_pair", "reduced_curves",
           "verification_figures", "DEFAULT_WINDOW"]

PHASE_BINS = 90  # co-moving bins a period for the limit-cycle phase diagrams (~1 node each)
#: Space-time maps show the last DEFAULT_WINDOW of the run: a few periods are enough to read
#: the slope (direction, celerity) and the zones; hundreds of periods alias into moiré.
DEFAULT_WINDOW = "5T"
_WINDOW = re.compile(r"^\s*([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*(T|periods?|ms|s)\s*$")


def parse_window(text: str) -> tuple[float, str] | None:
    """A space-time window: ``5T`` (5 periods at a fixed point), ``4ms``, ``0.01s``, ``all``.

    Returns (value, "T") for periods, (seconds, "s") for a duration, None for the whole run.
    Raises ``argparse.ArgumentTypeError`` with the accepted forms (a one-line CLI error).
    """
    if text.strip().lower() == "all":
        return None
    m = _WINDOW.match(text)
    if not m or float(m.group(1)) <= 0.0:
        raise argparse.ArgumentTypeError(
            f"window {text!r}: give a number of periods (5T), a duration (4ms, 0.01s) or all")
    value, unit = float(m.group(1)), m.group(2)
    if unit.startswith("T") or unit.startswith("period"):
        return value, "T"
    return (value * 1e-3 if unit == "ms" else value), "s"


def spacetime_window(t: np.ndarray, frequency_hz: float | None,
                     window: tuple[float, str] | None) -> tuple[float, str]:
    """(start time, caption) of the space-time window over the samples' times ``t``.

    A window in periods uses the frequency a fixed point sees; without a wave (no frequency)
    it falls back to the whole run. At least 8 sample rows are kept.
    """
    t0, t1 = float(t[0]), float(t[-1])
    dt = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    if window is None:
        return t0, "whole run"
    value, unit = window
    if unit == "T":
        if not frequency_hz or frequency_hz <= 0.0:
            return t0, "whole run (no wave frequency to count periods)"
        span = value / frequency_hz
        caption = f"last {value:g} periods (T = {MS / frequency_hz:.3g} ms at a fixed point)"
    else:
        span = value
        caption = f"last {MS * value:g} ms"
    start = max(t0, t1 - max(span, 8 * dt))
    if start <= t0:
        caption = "whole run"
    return start, caption


def plot_run(run_dir: Path, window: tuple[float, str] | None | str = DEFAULT_WINDOW
             ) -> list[Path]:
    """Draw and save every figure of a run directory; returns the PNG paths."""
    import matplotlib

    matplotlib.use("Agg")
    run_dir = Path(run_dir)
    run = load_run(run_dir)
    if isinstance(window, str):
        window = parse_window(window)
    out = [
        save_figure(spacetime_figure(run, window), run_dir / "spacetime.png"),
        save_figure(profile_figure(run), run_dir / "profile.png"),
        save_figure(phase_figure(run), run_dir / "phase.png"),
        save_figure(energy_figure(run), run_dir / "energy.png"),
    ]
    if run.summary.get("regime") not in (None, "steady-sliding") \
            and run.summary.get("direction") != "standing":  # one period of a travelling wave
        out.append(plot_uvpq(run_dir, run_dir / "uvpq.png"))
    if (run_dir / "surface.npz").exists():  # a 3D tube: its contact surface unrolled
        out.append(save_figure(surface_figure(run_dir, run.d), run_dir / "surface.png"))
        out.append(isomap_tube(run_dir, run_dir / "isomap.png"))
        return out
    if (run_dir / "final_field.npz").exists():
        out.append(isomap_pair([run_dir], run_dir / "isomap.png"))
    if has_stress(run_dir):
        out.append(stress_maps(run_dir, run_dir / "stress.png"))
    return out


def spacetime_figure(run: Any, window: tuple[float, str] | None = (5.0, "T")) -> Any:
    """u_r − d (mm) and the contact status over (θ, t) in the window (``spacetime_window``)."""
    import matplotlib.pyplot as plt

    s, summary = run.samples, run.summary
    t, deg = s["t"], np.degrees(s["theta"])
    start, caption = spacetime_window(t, summary.get("frequency_hz"), window)
    sel = t >= start
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.4), sharey=True, constrained_layout=True)
    # room between the left panel's colour bar label and the right panel
    fig.get_layout_engine().set(wspace=0.08)
    im = axes[0].pcolormesh(deg, MS * t[sel], MM * (s["u_r"][sel] - run.d), shading="nearest",
                            cmap=FIELD_CMAP)
    fig.colorbar(im, ax=axes[0], label="u_r − d (mm)")
    axes[0].set(xlabel="θ (deg)", ylabel="t (ms)", title="u_r − d on the contact circle")
    cmap, norm = status_cmap()
    im2 = axes[1].pcolormesh(deg, MS * t[sel], s["status"][sel], shading="nearest", cmap=cmap,
                             norm=norm)
    status_colorbar(fig, im2, axes[1])
    axes[1].set(xlabel="θ (deg)", title="contact status")
    rows = int(sel.sum())
    fig.suptitle(f"{scene_title(run.scene, deg.size)}\n{wave_title(summary)}\n"
                 f"{caption}: {rows} samples every {MS * float(np.median(np.diff(t))):.3g} ms",
                 fontsize=9)
    return fig


def profile_figure(run: Any) -> Any:
    """u_r − d and u_θ − mean (mm) along the contact circle at the last sample, zones shaded."""
    import matplotlib.pyplot as plt

    s = run.samples
    deg = np.degrees(s["theta"])
    ur, ut = s["u_r"][-1] - run.d, s["u_theta"][-1]
    fig, ax = plt.subplots(figsize=(8, 4.0), constrained_layout=True)
    shade_zones(ax, deg, s["status"][-1])
    ax.plot(deg, MM * ur, color="k", label="u_r − d")
    ax.plot(deg, MM * (ut - ut.mean()), color="C3", label="u_θ − mean")
    ax.set(xlabel="θ (deg)", ylabel="displacement (mm)", xlim=(deg.min(), deg.max()))
    ax.legend(loc="upper right", fontsize=8, ncol=2)
    ax.set_title(f"{scene_title(run.scene, deg.size)}\n{wave_title(run.summary)}; "
                 f"contact circle at t = {MS * s['t'][-1]:.1f} ms", fontsize=9)
    return fig


def phase_figure(run: Any) -> Any:
    """Phase diagrams at the first probe (every-step history) over the last periods."""
    import matplotlib.pyplot as plt

    s, summary, scene, d = run.samples, run.summary, run.scene, run.d
    t = s["t"]
    window = summary.get("analysis_window_s", (t[-1] - t[0]) / 3)
    if "probe_data" in s and s["probe_data"].shape[0] > 0:
        pt, pd = s["probe_t"], s["probe_data"][0]
        sel = pt >= pt[-1] - min(window, 5.0 * _period(summary, pt))
        pr, pth, pvr, pvt = pd[sel, 0] - d, pd[sel, 1], pd[sel, 2], pd[sel, 3]
        probe_deg = float(s["probe_deg"][0])
        shown = float(pt[-1] - pt[sel][0])
    else:
        deg = np.degrees(s["theta"])
        probe = scene["output"].get("probes_deg", [0.0])[0]
        j = int(np.argmin(np.abs(((deg - probe + 180.0) % 360.0) - 180.0)))
        sel = t >= t[-1] - window
        pr, pth = s["u_r"][sel, j] - d, s["u_theta"][sel, j]
        pvr, pvt = s["v_r"][sel, j], s["v_theta"][sel, j]
        probe_deg = float(deg[j])
        shown = float(window)
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.2), constrained_layout=True)
    axes[0].plot(MM * pr, pvr, lw=0.8, color="k", label="FE")
    axes[0].set(xlabel="u_r − d (mm)", ylabel="du_r/dt (m/s)", title="radial phase diagram")
    axes[1].plot(MM * pth, pvt, lw=0.8, color="k", label="FE")
    rw = float(scene["geometry"]["R"]) * float(scene["loading"]["omega"])
    axes[1].axhline(rw, color="0.4", ls=":", lw=0.8, label="RΩ (stick)")
    axes[1].set(xlabel="u_θ (mm)", ylabel="du_θ/dt (m/s)", title="tangential phase diagram")
    if summary.get("regime") not in (None, "steady-sliding"):
        for j, (label, cur) in enumerate(reduced_curves(scene, summary.get("mode") or 4)):
            axes[0].plot(MM * cur["u_r"], cur["v_r"], "--", color=f"C{j + 2}", lw=1.2,
                         label=label)
            axes[1].plot(MM * (cur["u_theta"] + pth.mean()), cur["v_theta"], "--",
                         color=f"C{j + 2}", lw=1.2, label=label)
    axes[0].legend(fontsize=8)
    axes[1].legend(fontsize=8)
    fig.suptitle(f"{scene_title(scene)}\n{wave_title(summary)}; probe θ = {probe_deg:.1f}°, "
                 f"last {MS * shown:.3g} ms", fontsize=9)
    return fig


def energy_figure(run: Any) -> Any:
    """Every term of the energy balance over time (``postprocess.energy_balance``).

    Top: the stored energies K, U and E = K + U. Bottom: the accumulated flows, the work fed
    by the cylinder and the frictional, impact and viscous dissipation, the residual r(t), and
    E(t) − E(0) = W_cyl − D_f − D_n − D_v + r, whose terms sum to it exactly.
    """
    import matplotlib.pyplot as plt

    terms = energy_terms(run.samples["energies"])
    ms = MS * run.samples["t"]
    beta2 = float(run.scene["time"]["beta2"])
    fig, axes = plt.subplots(2, 1, figsize=(8.5, 6.6), sharex=True, constrained_layout=True)
    ax = axes[0]
    ax.plot(ms, terms["total"], color="k", label="E = K + U")
    ax.plot(ms, terms["kinetic"], color="C9", lw=0.8, label="kinetic K")  # not the zone colours
    ax.plot(ms, terms["strain"], color="C8", lw=0.8, label="strain U")
    ax.set(ylabel="energy (J/m)", title="stored energy")
    ax.legend(fontsize=8, loc="upper left")
    residual_name = ("residual r = algorithmic dissipation of β₂ > ½ (+ O(Δt²))"
                     if beta2 > 0.5 else "residual r (O(Δt²) at β₂ = ½)")
    flows = (("work_cylinder", "work of the cylinder W_cyl", "C2", "-"),
             ("friction_dissipation", "− frictional dissipation D_f", "C3", "-"),
             ("impact_dissipation", "− impact dissipation D_n (normal contact)", "C4", "-"),
             ("viscous_dissipation", "− viscous dissipation D_v (Kelvin–Voigt)"
              + ("" if terms["viscous_dissipation"].any() else ": none, no damping"), "C5", "--"),
             ("residual", residual_name, "C7", "-"))
    ax = axes[1]
    for key, label, color, ls in flows:
        sign = 1.0 if key in ("work_cylinder", "residual") else -1.0
        ax.plot(ms, sign * terms[key], color=color, ls=ls, lw=1.0, label=label)
    ax.plot(ms, terms["total"] - terms["total"][0], color="k", lw=2.2, ls=":",
            label="E(t) − E(0) = sum of the terms above")
    ax.axhline(0.0, color="0.6", lw=0.6)
    e0, wc, r = terms["total"][0], terms["work_cylinder"][-1], terms["residual"][-1]
    share = f"{100 * r / wc:+.3g} % of W_cyl" if wc else "no work fed"
    ax.set(xlabel="t (ms)", ylabel="accumulated (J/m)",
           title=f"E(t) = E(0) + W_cyl − D_f − D_n − D_v + r;  E(0) = {e0:.4g} J/m, "
                 f"r(end) = {r:.3g} J/m ({share})")
    ax.title.set_fontsize(9)
    ax.legend(fontsize=7.5, loc="upper left")
    fig.suptitle(scene_title(run.scene), fontsize=9)
    return fig


def _period(summary: dict, t: np.ndarray) -> float:
    """Wave period seen at a fixed point (s), or the record length if there is no wave."""
    freq = summary.get("frequency_hz") or 0.0
    return 1.0 / freq if freq > 0 else float(t[-1] - t[0])


def save_figure(fig: Any, path: Path, dpi: int = 110) -> Path:
    """Write a figure atomically (a temporary file renamed into place) and close it."""
    import matplotlib.pyplot as plt

    tmp = path.with_name(f".{path.stem}.tmp.png")
    fig.savefig(tmp, dpi=dpi)
    plt.close(fig)
    tmp.replace(path)
    return path


# ---------------------------------------------------------------------------------------------
# Reduced-model overlays


def reduced_curves(scene: dict, k: int, admissible_only: bool = True,
                   n: int = 1000) -> list[tuple[str, dict[str, np.ndarray]]]:
    """Admissible reduced-model waves (``semianalytic.waves.find_waves``) at a scene's
    parameters and wavenumber k, over one period in the time-ordered coordinate, in physical
    units: ``s`` (rad), ``u_r`` = (U − δ)R, ``u_theta`` = (V − mean V)R (m), ``v_r``,
    ``v_theta`` = −c U' RΩ, −c V' RΩ (m/s), ``p``, ``q`` (Pa), ``zone``.
    """
    mat, geo, load = scene["material"], scene["geometry"], scene["loading"]
    c0 = float(mat.get("wave_speed") or np.sqrt(mat["E"] / mat["rho"]))
    R, om = float(geo["R"]), float(load["omega"])
    co = coefficients(float(mat["nu"]), float(geo["xi"]), gamma_from_physical(c0, R, om))
    waves = _reduced_waves(float(mat["nu"]), float(geo["xi"]), co.gamma, float(load["f"]),
                           int(k), float(geo["delta"]))
    E = float(mat.get("E", 1e9))
    out = []
    for w in waves:
        if admissible_only and not w.admissible:
            continue
        ev = w.evaluate_s(n)
        c = abs(w.c)
        scale = E / reaction_scale(co)  # P -> p in Pa
        cur = {"s": ev["s"], "u_r": (ev["U"] - w.delta) * R,
               "u_theta": (ev["V"] - ev["V"].mean()) * R,
               "v_r": c * ev["Us"] * R * om, "v_theta": c * ev["Vs"] * R * om,
               "p": ev["P"] * scale, "q": ev["Q"] * scale, "zone": ev["zone"]}
        label = (f"reduced {w.regime}, k = {w.k}, {w.c * R * om:+.0f} m/s"
                 + ("" if w.admissible else " (NOT admissible)"))
        out.append((label, cur))
    return out


@functools.lru_cache(maxsize=8)
def _reduced_waves(nu: float, xi: float, gamma: float, f: float, k: int, delta: float) -> tuple:
    """``find_waves`` once per parameter set (the phase and u-v-p-q figures share it)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return tuple(find_waves(coefficients(nu, xi, gamma), f, k, delta))


# ---------------------------------------------------------------------------------------------
# One period of the FE wave (the panels of the paper's Figure 1)


def plot_uvpq(run_dir: Path, out_png: Path, overlay: bool = True) -> Path:
    """One period of an FE run's wave in the panels of the paper's Figure 1.

    u_r − d and u_θ (mean removed) against the time-ordered co-moving coordinate s/T (a
    material point meets s = 0 → 1 in this order; zones shaded), the phase diagrams
    (u_r − d, du_r/dt), (u_θ, du_θ/dt), and p, q (MPa) when ``samples.npz`` has nodal forces.
    Bin means over the analysis window (``postprocess.analysis.run_profile``).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    run = load_run(run_dir)
    wave = analyse_run(run)
    prof = run_profile(run, wave)
    T = 2 * np.pi / wave.mode
    x = prof["s"] / T
    has_pq = "p" in prof
    curves = reduced_curves(run.scene, wave.mode) if overlay else []
    fig, axes = plt.subplots(2, 2 if not has_pq else 3, figsize=(13 if has_pq else 10, 6.4),
                             constrained_layout=True)
    axes = np.atleast_2d(axes)
    zone = np.argmax(np.vstack([prof[f"frac_{z}"] for z in STATUS_LABELS]), axis=0)
    a = axes[0, 0]
    a.plot(x, MM * prof["u_r"], color="k", label="FE")
    a.set(xlabel="s / T (co-moving, time order)", ylabel="u_r − d (mm)", title="U: radial")
    a = axes[1, 0]
    a.plot(x, MM * prof["u_theta"], color="k", label="FE")
    a.set(xlabel="s / T (co-moving, time order)", ylabel="u_θ − mean (mm)",
          title="V: tangential")
    a = axes[0, 1]
    a.plot(MM * prof["u_r"], prof["v_r"], color="k", label="FE")
    a.set(xlabel="u_r − d (mm)", ylabel="du_r/dt (m/s)", title="radial phase diagram")
    a = axes[1, 1]
    a.plot(MM * prof["u_theta"], prof["v_theta"], color="k", label="FE")
    rw = run.radius * float(run.scene["loading"]["omega"])
    a.axhline(rw, color="C0", ls=":", lw=0.8, label="RΩ (stick)")
    a.set(xlabel="u_θ − mean (mm)", ylabel="du_θ/dt (m/s)", title="tangential phase diagram")
    if has_pq:
        axes[0, 2].plot(x, MPA * prof["p"], color="k", label="FE")
        axes[0, 2].set(xlabel="s / T (co-moving, time order)", ylabel="p (MPa)",
                       title="P: normal pressure")
        axes[1, 2].plot(x, MPA * prof["q"], color="k", label="FE")
        axes[1, 2].set(xlabel="s / T (co-moving, time order)", ylabel="q (MPa)",
                       title="Q: tangential traction")
    for j, (label, cur) in enumerate(curves):
        xs = cur["s"] / T
        col = f"C{j + 2}"  # C0, C1 are the stick and slip colours
        axes[0, 0].plot(xs, MM * cur["u_r"], "--", color=col, label=label)
        axes[1, 0].plot(xs, MM * cur["u_theta"], "--", color=col, label=label)
        axes[0, 1].plot(MM * cur["u_r"], cur["v_r"], "--", color=col, label=label)
        axes[1, 1].plot(MM * cur["u_theta"], cur["v_theta"], "--", color=col, label=label)
        if has_pq:
            axes[0, 2].plot(xs, MPA * cur["p"], "--", color=col, label=label)
            axes[1, 2].plot(xs, MPA * cur["q"], "--", color=col, label=label)
    for a in (axes[0, 0], axes[1, 0], *(axes[:, 2] if has_pq else ())):
        shade_zones(a, x, zone)
        a.set_xlim(0, 1)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    uniq = dict(zip(labels, handles, strict=True))
    axes[0, 0].legend(uniq.values(), uniq.keys(), fontsize=7, loc="upper right")
    axes[1, 1].legend(fontsize=7, loc="lower right")
    what = (f"one period of the FE wave in its co-moving coordinate: {wave.regime}, "
            f"k = {wave.mode}, {wave.celerity_m_s:+.0f} m/s, ψ₁ = {wave.psi1:.3f}, "
            f"ψ₂ = {wave.psi2:.3f} ({wave.zone_order.replace('->', ' → ')})"
            if wave.regime != "steady-sliding" else
            "steady sliding: no travelling wave (bin means of the sliding state)")
    fig.suptitle(f"{scene_title(run.scene)}\n{what}", fontsize=10)
    return save_figure(fig, Path(out_png))


# ---------------------------------------------------------------------------------------------
# Phase diagram families (paper Figures 4-6)


def phase_family(run_dirs: list[Path], colors: list[str], labels: list[str], out_png: Path,
                 title: str, k_reduced: list[int] | None = None) -> Path:
    """Radial and tangential phase diagrams of several runs, the admissible reduced-model
    waves at each run's parameters dashed in the same colour (paper Figures 4-6).

    The FE curve is the limit cycle a material point describes: the co-moving bin means of
    (u_r − d, u̇_r), (u_θ, u̇_θ) over the analysis window (``postprocess.analysis.run_profile``),
    smoother than one probe's history and identical to it for a steady travelling wave.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 5.6), layout="constrained")
    notes, meshes = [], set()
    for i, (rd, col, lab) in enumerate(zip(run_dirs, colors, labels, strict=True)):
        run = load_run(rd)
        meshes.add(int(run.scene["mesh"]["n_inner"]))
        wave = analyse_run(run)
        fe_lab = (f"{lab}: FE {wave.regime}, k = {wave.mode}, "
                  f"{wave.celerity_m_s:+.0f} m/s")
        if wave.angular_speed_rad_s != 0.0:
            # limit cycle: bin means over the analysis window in the co-moving frame (closed)
            prof = run_profile(run, wave, nbins=PHASE_BINS)
            loop = [np.append(prof[key], prof[key][:1])
                    for key in ("u_r", "v_r", "u_theta", "v_theta")]
            axes[0].plot(MM * loop[0], loop[1], color=col, lw=1.2, label=fe_lab)
            axes[1].plot(MM * loop[2], loop[3], color=col, lw=1.2, label=fe_lab)
        else:
            notes.append(f"{lab}: FE {wave.regime} (no wave)")
        k = (k_reduced[i] if k_reduced else wave.mode)
        curves = reduced_curves(run.scene, k)
        if not curves:
            notes.append(f"{lab}: no admissible reduced wave (k = {k})")
        for label, cur in curves:
            axes[0].plot(MM * cur["u_r"], cur["v_r"], "--", color=col, lw=1.6,
                         label=f"{lab}: {label}")
            axes[1].plot(MM * cur["u_theta"], cur["v_theta"], "--", color=col, lw=1.6,
                         label=f"{lab}: {label}")
    axes[0].set(xlabel="u_r − d (mm)", ylabel="du_r/dt (m/s)",
                title="radial phase diagram (one period, limit cycle)")
    axes[1].set(xlabel="u_θ − mean (mm)", ylabel="du_θ/dt (m/s)",
                title="tangential phase diagram (one period, limit cycle)")
    handles, labs = axes[0].get_legend_handles_labels()
    fig.legend(handles, labs, loc="outside lower center", ncol=2, fontsize=8, frameon=False)
    if notes:
        axes[1].text(0.02, 0.02, "\n".join(notes), transform=axes[1].transAxes, fontsize=7,
                     va="bottom")
    n_txt = "/".join(str(n) for n in sorted(meshes))
    fig.suptitle(f"{title}   (solid: FE, N = {n_txt}; dashed: reduced model, admissible only)",
                 fontsize=10)
    return save_figure(fig, Path(out_png))


# ---------------------------------------------------------------------------------------------
# The committed figures


def verification_figures(runs: Path, figs: Path) -> list[Path]:
    """docs/figures/fe_*.png from the runs of ``benchmarks/verification_runs.py``."""
    runs, figs = Path(runs), Path(figs)
    figs.mkdir(parents=True, exist_ok=True)
    made: list[Path] = []

    def have(*names: str) -> bool:
        return all((runs / n / "samples.npz").exists() for n in names)

    for case, paper in (("figure2", "paper Figure 2"), ("figure3", "paper Figure 3")):
        pair = [f"{case}_mode4_n132_b6", f"{case}_mode4_n528_b6"]
        if have(*pair):
            made.append(isomap_pair([runs / p for p in pair], figs / f"fe_{case}_isomap.png",
                                    title=paper))
    for name in ("figure1_mode4_n528_b9", "figure1_mode4_n528_b6"):
        if have(name):
            made.append(plot_uvpq(runs / name, figs / f"fe_{name.split('_')[0]}_uvpq_"
                                  f"{name.split('_', 2)[2]}.png"))
    families = (
        ("figure4", ["figure4_d0005", "figure4_d001", "figure4_d005"], ["green", "black", "red"],
         ["δ = 0.0005", "δ = 0.001", "δ = 0.005"],
         "Figure 4: Ω = 100 rad/s, f = 0.3", None),
        ("figure5", ["figure5_w32", "figure5_w380", "figure5_w1000"], ["black", "blue", "red"],
         ["Ω = 32", "Ω = 380", "Ω = 1000"], "Figure 5: δ = 0.001, f = 0.9", None),
        ("figure6", ["figure6_k2", "figure6_k3", "figure6_k4"], ["black", "blue", "green"],
         ["seed k = 2", "seed k = 3", "seed k = 4"],
         "Figure 6: Ω = 100 rad/s, δ = 0.0004, f = 0.7", [2, 3, 4]),
    )
    for fig, names, cols, labs, title, ks in families:
        if have(*names):
            made.append(phase_family([runs / n for n in names], cols, labs,
                                     figs / f"fe_{fig}_phase.png", title, ks))
    return made
