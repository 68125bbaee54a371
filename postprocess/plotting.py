"""Figures of a run directory (matplotlib, Agg): the pictures of ``stickslip run --plot``.

* ``spacetime.png``: iso-values of u_r - d over (theta, t) on the inner circle, and the contact
  status map (separation / stick / slip) — the wave's travel direction is the slope;
* ``profile.png``: u_r - d and u_theta along the circle at the last sample, zones shaded;
* ``phase.png``: phase diagrams (u_r, du_r/dt) and (u_theta, du_theta/dt) at the first probe;
* ``energy.png``: kinetic + strain energy and the contact work over time;
* ``uvpq.png``: the paper's Figure-1 layout from the FE wave: u_r, u_theta over one period of
  the co-moving coordinate (zones shaded, time order), phase diagrams, and the contact
  pressures p, q when the run recorded nodal forces; reduced-model waves dashed;
* ``isomap.png``: pyvista off-screen iso-values of u_r on the deformed tube at the end of the
  run, contact status on the inner circle (needs ``final_field.npz``).

``isomap_pair`` draws two runs (two mesh sizes) side by side like the paper's Figures 2-3;
``phase_family`` overlays several runs' phase diagrams like Figures 4-6;
``verification_figures`` makes the committed ``docs/figures/fe_*.png``. pyvista is imported
only inside the pyvista functions; without a DISPLAY an Xvfb server is started (and stopped at
exit) for off-screen rendering.
"""

from __future__ import annotations

import atexit
import json
import os
import subprocess
import tomllib
import warnings
from pathlib import Path

import numpy as np

STATUS_COLORS = ("#d9d9d9", "#1f77b4", "#ff7f0e")  # separation, stick, slip
STATUS_LABELS = ("separation", "stick", "slip")
PHASE_BINS = 90  # co-moving bins a period for the limit-cycle phase diagrams (~1 node each)
DOT_COLORS = ("#8c8c8c", "#1f77b4", "#ff7f0e")  # status dots on white (pyvista)


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
    for j, (label, cur) in enumerate(reduced_curves(scene, summary.get("mode") or 4)):
        axes[0].plot(1e3 * cur["u_r"], cur["v_r"], "--", color=f"C{j + 2}", lw=1.2,
                     label=label)
        axes[1].plot(1e3 * (cur["u_theta"] + pth.mean()), cur["v_theta"], "--",
                     color=f"C{j + 2}", lw=1.2, label=label)
    if axes[0].get_legend_handles_labels()[0]:
        axes[0].legend(fontsize=8)
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

    out.append(plot_uvpq(run_dir, run_dir / "uvpq.png"))
    if (run_dir / "final_field.npz").exists():
        out.append(isomap_pair([run_dir], run_dir / "isomap.png"))
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


# ---------------------------------------------------------------------------------------------
# Reduced-model overlays


def reduced_curves(scene: dict, k: int, admissible_only: bool = True,
                   n: int = 1000) -> list[tuple[str, dict[str, np.ndarray]]]:
    """Admissible reduced-model waves (``semianalytic.waves.find_waves``) at a scene's
    parameters and wavenumber k, over one period in the time-ordered coordinate, in physical
    units: ``s`` (rad), ``u_r`` = (U − δ)R, ``u_theta`` = (V − mean V)R (m), ``v_r``,
    ``v_theta`` = −c U' RΩ, −c V' RΩ (m/s), ``p``, ``q`` (Pa), ``zone``.
    """
    from semianalytic.coefficients import coefficients, gamma_from_physical, reaction_scale
    from semianalytic.waves import find_waves

    mat, geo, load = scene["material"], scene["geometry"], scene["loading"]
    c0 = float(mat.get("wave_speed") or np.sqrt(mat["E"] / mat["rho"]))
    R, om = float(geo["R"]), float(load["omega"])
    co = coefficients(float(mat["nu"]), float(geo["xi"]), gamma_from_physical(c0, R, om))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        waves = find_waves(co, float(load["f"]), int(k), float(geo["delta"]))
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


# ---------------------------------------------------------------------------------------------
# Figure-1 layout from the FE


def plot_uvpq(run_dir: Path, out_png: Path, overlay: bool = True) -> Path:
    """The paper's Figure-1 panels from an FE run: one period of the co-moving wave.

    u_r − d and u_θ (mean removed) against the time-ordered co-moving coordinate s/T (a
    material point meets s = 0 → 1 in this order; zones shaded), the phase diagrams
    (u_r − d, du_r/dt), (u_θ, du_θ/dt), and p, q (MPa) when ``samples.npz`` has nodal forces.
    Bin means over the analysis window (``postprocess.analysis.run_profile``).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from postprocess.analysis import analyse_run, load_run, run_profile

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
    a.plot(x, 1e3 * prof["u_r"], color="k", label="FE")
    a.set(xlabel="s / T (co-moving, time order)", ylabel="u_r − d (mm)", title="U: radial")
    a = axes[1, 0]
    a.plot(x, 1e3 * prof["u_theta"], color="k", label="FE")
    a.set(xlabel="s / T (co-moving, time order)", ylabel="u_θ − mean (mm)",
          title="V: tangential")
    a = axes[0, 1]
    a.plot(1e3 * prof["u_r"], prof["v_r"], color="k", label="FE")
    a.set(xlabel="u_r − d (mm)", ylabel="du_r/dt (m/s)", title="radial phase diagram")
    a = axes[1, 1]
    a.plot(1e3 * prof["u_theta"], prof["v_theta"], color="k", label="FE")
    rw = run.radius * float(run.scene["loading"]["omega"])
    a.axhline(rw, color="C0", ls=":", lw=0.8, label="RΩ (stick)")
    a.set(xlabel="u_θ − mean (mm)", ylabel="du_θ/dt (m/s)", title="tangential phase diagram")
    if has_pq:
        axes[0, 2].plot(x, 1e-6 * prof["p"], color="k", label="FE")
        axes[0, 2].set(xlabel="s / T (co-moving, time order)", ylabel="p (MPa)",
                       title="P: normal pressure")
        axes[1, 2].plot(x, 1e-6 * prof["q"], color="k", label="FE")
        axes[1, 2].set(xlabel="s / T (co-moving, time order)", ylabel="q (MPa)",
                       title="Q: tangential traction")
    for j, (label, cur) in enumerate(curves):
        xs = cur["s"] / T
        col = f"C{j + 1}"
        axes[0, 0].plot(xs, 1e3 * cur["u_r"], "--", color=col, label=label)
        axes[1, 0].plot(xs, 1e3 * cur["u_theta"], "--", color=col, label=label)
        axes[0, 1].plot(1e3 * cur["u_r"], cur["v_r"], "--", color=col, label=label)
        axes[1, 1].plot(1e3 * cur["u_theta"], cur["v_theta"], "--", color=col, label=label)
        if has_pq:
            axes[0, 2].plot(xs, 1e-6 * cur["p"], "--", color=col, label=label)
            axes[1, 2].plot(xs, 1e-6 * cur["q"], "--", color=col, label=label)
    for a in (axes[0, 0], axes[1, 0], *(axes[:, 2] if has_pq else ())):
        _shade_zones(a, x, zone)
        a.set_xlim(0, 1)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    uniq = dict(zip(labels, handles, strict=True))
    axes[0, 0].legend(uniq.values(), uniq.keys(), fontsize=7, loc="upper right")
    axes[1, 1].legend(fontsize=7, loc="lower right")
    sc = run.scene
    fig.suptitle(
        f"FE wave, Figure-1 layout: Ω = {sc['loading']['omega']:g} rad/s, "
        f"δ = {sc['geometry']['delta']:g}, f = {sc['loading']['f']:g}, "
        f"N = {sc['mesh']['n_inner']}, β2 = {sc['time']['beta2']:g} — {wave.regime}, "
        f"k = {wave.mode}, {wave.celerity_m_s:+.0f} m/s, ψ1 = {wave.psi1:.3f}, "
        f"ψ2 = {wave.psi2:.3f} ({wave.zone_order.replace('->', ' → ')})", fontsize=10)
    return _save(fig, Path(out_png))


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

    from postprocess.analysis import analyse_run, load_run, run_profile

    fig, axes = plt.subplots(1, 2, figsize=(12, 5.6), layout="constrained")
    notes = []
    for i, (rd, col, lab) in enumerate(zip(run_dirs, colors, labels, strict=True)):
        run = load_run(rd)
        wave = analyse_run(run)
        fe_lab = (f"{lab}: FE {wave.regime}, k = {wave.mode}, "
                  f"{wave.celerity_m_s:+.0f} m/s")
        if wave.angular_speed_rad_s != 0.0:
            # limit cycle: bin means over the analysis window in the co-moving frame (closed)
            prof = run_profile(run, wave, nbins=PHASE_BINS)
            loop = [np.append(prof[key], prof[key][:1])
                    for key in ("u_r", "v_r", "u_theta", "v_theta")]
            axes[0].plot(1e3 * loop[0], loop[1], color=col, lw=1.2, label=fe_lab)
            axes[1].plot(1e3 * loop[2], loop[3], color=col, lw=1.2, label=fe_lab)
        else:
            notes.append(f"{lab}: FE {wave.regime} (no wave)")
        k = (k_reduced[i] if k_reduced else wave.mode)
        curves = reduced_curves(run.scene, k)
        if not curves:
            notes.append(f"{lab}: no admissible reduced wave (k = {k})")
        for label, cur in curves:
            axes[0].plot(1e3 * cur["u_r"], cur["v_r"], "--", color=col, lw=1.6,
                         label=f"{lab}: {label}")
            axes[1].plot(1e3 * cur["u_theta"], cur["v_theta"], "--", color=col, lw=1.6,
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
    fig.suptitle(title + "   (solid: FE, N = 132; dashed: reduced model, admissible only)",
                 fontsize=10)
    return _save(fig, Path(out_png))


# ---------------------------------------------------------------------------------------------
# pyvista iso-value maps (paper Figures 2-3)

_XVFB: list[subprocess.Popen] = []


def ensure_display() -> None:
    """Give VTK an X display: keep $DISPLAY, else start a private Xvfb (stopped at exit).

    ``Xvfb -displayfd`` picks a free display number, so parallel users do not collide.
    """
    if os.environ.get("DISPLAY") or _XVFB:
        return
    r, w = os.pipe()
    proc = subprocess.Popen(
        ["Xvfb", "-displayfd", str(w), "-screen", "0", "1920x1200x24", "-nolisten", "tcp"],
        pass_fds=(w,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(w)
    with os.fdopen(r) as fh:
        num = fh.readline().strip()
    if not num:
        proc.terminate()
        raise RuntimeError("could not start Xvfb for off-screen rendering (is xvfb installed?)")
    _XVFB.append(proc)
    os.environ["DISPLAY"] = f":{num}"
    atexit.register(_stop_xvfb)


def _stop_xvfb() -> None:
    while _XVFB:
        proc = _XVFB.pop()
        proc.terminate()
        try:
            proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            proc.kill()


def isomap_pair(run_dirs: list[Path], out_png: Path, magnify: float | None = None,
                title: str | None = None) -> Path:
    """Iso-values of u_r on the deformed tube (final_field.npz) for 1 or 2 runs side by side.

    The displacement is magnified (default: 8 % of R over the largest |u|) and shown with one
    colour range for both panels; the contact status of the last sample is drawn as coloured
    dots just inside the inner circle (grey separation, blue stick, orange slip).
    """
    ensure_display()
    import pyvista as pv

    from postprocess.analysis import analyse_run, load_run

    pv.OFF_SCREEN = True
    grids, infos = [], []
    for rd in run_dirs:
        rd = Path(rd)
        with np.load(rd / "final_field.npz") as ff:
            pts, cells, types, u = ff["points"], ff["cells"], ff["cell_types"], ff["u"]
            t_end = float(ff["time"])
        run = load_run(rd)
        r = np.hypot(pts[:, 0], pts[:, 1])
        ur = (pts[:, 0] * u[:, 0] + pts[:, 1] * u[:, 1]) / r
        grid = pv.UnstructuredGrid(cells.astype(np.int64), types.astype(np.uint8), pts.copy())
        grid.point_data["u_r (mm)"] = 1e3 * ur
        disp = np.zeros_like(pts)
        disp[:, :2] = u
        grid.point_data["disp"] = disp
        grids.append(grid)
        infos.append((run, analyse_run(run), t_end, np.abs(u).max()))
    umax = max(i[3] for i in infos)
    mag = magnify if magnify is not None else 0.08 * infos[0][0].radius / max(umax, 1e-300)
    clim = [min(g.point_data["u_r (mm)"].min() for g in grids),
            max(g.point_data["u_r (mm)"].max() for g in grids)]
    n = len(grids)
    pl = pv.Plotter(shape=(1, n), off_screen=True, window_size=(760 * n, 860), border=False)
    for i, (grid, (run, wave, t_end, _)) in enumerate(zip(grids, infos, strict=True)):
        pl.subplot(0, i)
        warped = grid.warp_by_vector("disp", factor=mag)
        pl.add_mesh(warped, scalars="u_r (mm)", cmap="viridis", clim=clim, show_edges=False,
                    scalar_bar_args={"title": "u_r (mm)", "vertical": False,
                                     "position_x": 0.2, "position_y": 0.04, "width": 0.6,
                                     "height": 0.07, "title_font_size": 18,
                                     "label_font_size": 15, "fmt": "%.1f"})
        s = run.samples
        theta, status = s["theta"], s["status"][-1]
        R = run.radius
        rr = 0.955 * R
        for code, color in enumerate(DOT_COLORS):
            m = status == code
            if m.any():
                dots = np.column_stack([rr * np.cos(theta[m]), rr * np.sin(theta[m]),
                                        np.zeros(m.sum())])
                pl.add_points(dots, color=color, point_size=9, render_points_as_spheres=True)
        pl.add_legend([[lab, col] for lab, col in zip(STATUS_LABELS, DOT_COLORS, strict=True)],
                      bcolor="white", size=(0.22, 0.13), loc="center", face="circle")
        sc = run.scene
        pl.add_text(
            f"N = {sc['mesh']['n_inner']} contact nodes, t = {1e3 * t_end:.0f} ms\n"
            f"{wave.regime}, k = {wave.mode}, {wave.celerity_m_s:+.0f} m/s\n"
            f"displacement x{mag:.0f}", position="upper_left", font_size=11, color="black")
        pl.view_xy()
        pl.camera.zoom(1.15)
    if title:
        pl.subplot(0, n - 1)
        pl.add_text(title, position="lower_right", font_size=11, color="black")
    pl.set_background("white")
    out_png = Path(out_png)
    tmp = out_png.with_name(f".{out_png.stem}.tmp.png")
    pl.screenshot(str(tmp))
    pl.close()
    tmp.replace(out_png)
    return out_png


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
