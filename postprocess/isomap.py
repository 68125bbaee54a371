"""Iso-value maps of u_r − d on the deformed tube (pyvista, off-screen): ``isomap.png``.

The map shows the wave, not the steady sliding state it grows on: from the final displacement
(``final_field.npz``) it removes the axisymmetric steady field of a tube clamped at r = ξR,

    u_steady = (d e_r + ū_θ e_θ) w(r),   w(r) = (r − ξ²R²/r) / (R − ξ²R²/R),

(the plane-strain Lamé field, u_r = A r + B/r, and the torsion field of the same form, both
zero at ξR and one at R; ū_θ is the mean u_θ on the contact circle). The colour is
u_r − d w(r), which is u_r − d on the contact circle, the same quantity as the other figures;
the mesh is drawn displaced by u − u_steady, magnified, so contact nodes sit on the circle
r = R (the cylinder's surface, drawn black) and separated ones inside it. The contact status
of each node at the last sample is a dot on the deformed contact circle
(``postprocess.style`` colours). pyvista is imported only inside the functions; without a
DISPLAY an Xvfb server is started (and stopped at exit) for off-screen rendering.
"""

from __future__ import annotations

import atexit
import os
import subprocess
from pathlib import Path

import numpy as np

from stickslip.postprocess.analysis import load_run
from stickslip.postprocess.style import FIELD_CMAP, MM, MS, STATUS_COLORS, STATUS_LABELS, wave_title

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


def steady_profile(r: np.ndarray, radius: float, xi: float) -> np.ndarray:
    """w(r) = (r − b²/r) / (R − b²/R), b = ξR: one at the contact circle, zero where clamped."""
    b2 = (xi * radius) ** 2
    return (r - b2 / r) / (radius - b2 / radius)


def wave_displacement(points: np.ndarray, u: np.ndarray, radius: float, xi: float, d: float
                      ) -> tuple[np.ndarray, np.ndarray]:
    """(u − u_steady (n, 2), u_r − d w(r) (n,)) at ``points`` (module docstring)."""
    x, y = points[:, 0], points[:, 1]
    r = np.hypot(x, y)
    er = np.column_stack([x / r, y / r])
    et = np.column_stack([-er[:, 1], er[:, 0]])
    ur = np.einsum("ij,ij->i", u, er)
    ut = np.einsum("ij,ij->i", u, et)
    on_circle = np.abs(r - radius) < 1e-6 * radius
    ut_mean = float(ut[on_circle].mean()) if on_circle.any() else 0.0
    w = steady_profile(r, radius, xi)
    ur_wave = ur - d * w
    ut_wave = ut - ut_mean * w
    return ur_wave[:, None] * er + ut_wave[:, None] * et, ur_wave


def isomap_pair(run_dirs: list[Path], out_png: Path, magnify: float | None = None,
                title: str | None = None) -> Path:
    """Iso-values of u_r − d on the deformed tube for 1 or 2 runs side by side.

    One colour range for both panels; the displacement of the wave (module docstring) is
    magnified so that its largest value (at least d/1000) is 8 % of R (or by ``magnify``).
    """
    ensure_display()
    import pyvista as pv

    pv.OFF_SCREEN = True
    panels = [_panel(Path(rd), load_run) for rd in run_dirs]
    # below d/1000 there is no wave to see (steady sliding): do not magnify round-off
    umax = max(max(float(np.abs(p["disp"]).max()), 1e-3 * p["d"]) for p in panels)
    mag = magnify if magnify is not None else 0.08 * panels[0]["radius"] / umax
    clim = [min(float(p["ur"].min()) for p in panels), max(float(p["ur"].max()) for p in panels)]
    n = len(panels)
    pl = pv.Plotter(shape=(1, n), off_screen=True, window_size=(760 * n, 860), border=False)
    for i, p in enumerate(panels):
        pl.subplot(0, i)
        _draw_panel(pl, pv, p, mag, clim)
    if title:
        pl.subplot(0, n - 1)
        pl.add_text(title, position="lower_right", font_size=11, color="black")
    return save_screenshot(pl, out_png)


def isomap_tube(run_dir: Path, out_png: Path) -> Path:
    """Iso-values of u_r − d w(r) on a 3D run's tube (``final_field.npz``, points and u in 3D),
    its half y < 0 cut away so that the contact surface r = R shows, drawn displaced by the
    wave (u − u_steady with u_z, magnified as ``isomap_pair``) and seen obliquely."""
    ensure_display()
    import pyvista as pv

    pv.OFF_SCREEN = True
    with np.load(Path(run_dir) / "final_field.npz") as ff:
        pts, cells, types, u = ff["points"], ff["cells"], ff["cell_types"], ff["u"]
        t_end = float(ff["time"])
    run = load_run(Path(run_dir))
    disp_xy, ur = wave_displacement(pts, u[:, :2], run.radius,
                                    float(run.scene["geometry"]["xi"]), run.d)
    grid = pv.UnstructuredGrid(cells.astype(np.int64), types.astype(np.uint8), pts.copy())
    grid.point_data["u_r − d (mm)"] = MM * ur
    grid.point_data["disp"] = np.column_stack([disp_xy, u[:, 2]])
    umax = max(float(np.abs(grid.point_data["disp"]).max()), 1e-3 * run.d)
    warped = grid.warp_by_vector("disp", factor=0.08 * run.radius / umax)
    half = warped.clip(normal=(0.0, -1.0, 0.0), origin=(0.0, 0.0, 0.0))
    pl = pv.Plotter(off_screen=True, window_size=(1100, 860), border=False)
    pl.add_mesh(half, scalars="u_r − d (mm)", cmap=FIELD_CMAP, show_edges=False, ambient=0.4,
                scalar_bar_args={"title": "u_r − d (mm)", "vertical": False,
                                 "position_x": 0.2, "position_y": 0.04, "width": 0.6})
    pl.add_text(f"{run.scene['name']}, L = {run.scene['geometry']['length']} m, "
                f"t = {MS * t_end:.1f} ms\n{wave_title(run.summary)}\n"
                "half the tube (y > 0), wave displacement magnified",
                position="upper_left", font_size=10, color="black")
    middle = 0.5 * float(pts[:, 2].max())
    pl.camera_position = [(0.0, -4.0 * run.radius, middle + 2.0 * run.radius),
                          (0.0, 0.4 * run.radius, middle), (0.0, 0.0, 1.0)]
    return save_screenshot(pl, out_png)


def save_screenshot(pl, out_png: Path) -> Path:  # noqa: ANN001 - a pyvista Plotter
    """Write the plotter's picture to ``out_png`` on a white background, atomically (a
    hidden temporary renamed into place), and close the plotter."""
    pl.set_background("white")
    out_png = Path(out_png)
    tmp = out_png.with_name(f".{out_png.stem}.tmp.png")
    pl.screenshot(str(tmp))
    pl.close()
    tmp.replace(out_png)
    return out_png


def _panel(run_dir: Path, load_run) -> dict:  # noqa: ANN001
    """The arrays of one run's panel: mesh, wave displacement, contact nodes and status."""
    with np.load(run_dir / "final_field.npz") as ff:
        pts, cells, types, u = ff["points"], ff["cells"], ff["cell_types"], ff["u"]
        t_end = float(ff["time"])
    run = load_run(run_dir)
    geo = run.scene["geometry"]
    disp, ur = wave_displacement(pts, u, run.radius, float(geo["xi"]), run.d)
    r = np.hypot(pts[:, 0], pts[:, 1])
    ring = np.flatnonzero(np.abs(r - run.radius) < 1e-6 * run.radius)
    s = run.samples
    theta_nodes = np.arctan2(pts[ring, 1], pts[ring, 0]) % (2 * np.pi)
    theta_samples = np.asarray(s["theta"]) % (2 * np.pi)
    gap = np.abs(((theta_nodes[:, None] - theta_samples[None, :] + np.pi) % (2 * np.pi)) - np.pi)
    status = np.asarray(s["status"][-1])[np.argmin(gap, axis=1)]
    return {"points": pts, "cells": cells, "types": types, "disp": disp, "ur": MM * ur,
            "ring": ring, "status": status, "radius": run.radius, "d": run.d, "t_end": t_end,
            "t_status": float(s["t"][-1]), "scene": run.scene,
            "wave": wave_title(run.summary)}


def _draw_panel(pl, pv, p: dict, mag: float, clim: list[float]) -> None:  # noqa: ANN001
    """Deformed mesh coloured by u_r − d, the cylinder circle, the status dots, the caption."""
    pts = p["points"]
    grid = pv.UnstructuredGrid(p["cells"].astype(np.int64), p["types"].astype(np.uint8),
                               pts.copy())
    grid.point_data["u_r − d (mm)"] = p["ur"]
    disp = np.zeros_like(pts)
    disp[:, :2] = p["disp"]
    grid.point_data["disp"] = disp
    warped = grid.warp_by_vector("disp", factor=mag)
    pl.add_mesh(warped, scalars="u_r − d (mm)", cmap=FIELD_CMAP, clim=clim, show_edges=False,
                scalar_bar_args={"title": "u_r − d (mm)", "vertical": False,
                                 "position_x": 0.2, "position_y": 0.04, "width": 0.6,
                                 "height": 0.07, "title_font_size": 18,
                                 "label_font_size": 15, "fmt": "%.2f"})
    R = p["radius"]
    phi = np.linspace(0.0, 2 * np.pi, 721)
    circle = np.column_stack([R * np.cos(phi), R * np.sin(phi), np.full(phi.size, 1e-3 * R)])
    pl.add_mesh(pv.lines_from_points(circle), color="black", line_width=1.5)
    dots = warped.points[p["ring"]].copy()
    dots[:, 2] = 2e-3 * R  # in front of the mesh (view from +z)
    for code, color in enumerate(STATUS_COLORS):
        m = p["status"] == code
        if m.any():
            pl.add_points(dots[m], color=color, point_size=8, render_points_as_spheres=True)
    pl.add_legend([[lab, col] for lab, col in zip(STATUS_LABELS, STATUS_COLORS, strict=True)],
                  bcolor="white", size=(0.22, 0.13), loc="center", face="circle")
    sc = p["scene"]
    pl.add_text(
        f"{sc['name']}: N = {sc['mesh']['n_inner']} contact nodes, t = {MS * p['t_end']:.1f} ms\n"
        f"{p['wave']}\n"
        f"colour: u_r − d w(r) (= u_r − d on the contact circle)\n"
        f"mesh: wave displacement u − u_steady x{mag:.0f}; black: cylinder (r = R + d)\n"
        f"dots: contact status at t = {MS * p['t_status']:.1f} ms",
        position="upper_left", font_size=10, color="black")
    pl.view_xy()
    pl.camera.zoom(1.15)
