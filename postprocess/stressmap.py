"""Stress iso-maps of a run's last level (pyvista, off-screen): ``stress.png``.

Two panels on the tube's cross-section, drawn from ``final_field.npz`` (the fields that
``output.fields`` writes, at the last completed level: ``solver.field_output``):

* von Mises σ_vm [MPa] per cell (plane strain: σ_zz = ν (σ_rr + σ_θθ) is included);
* the contact pressure p [MPa] on the contact circle r = R, a thick ring coloured by p over
  the tube in grey: p = 0 where the tube has separated.

The mesh is drawn undeformed (the displacements are ~10⁻³ R); ``postprocess.isomap`` shows
the wave's displacement. Units are on the colour bars.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from stickslip.postprocess.analysis import load_run
from stickslip.postprocess.isomap import ensure_display, save_screenshot
from stickslip.postprocess.style import FIELD_CMAP, MPA, MS

__all__ = ["has_stress", "stress_maps"]

#: The panels' titles: fixed-size text (a vtkTextActor) at the top left of each panel, in
#: the panel's viewport coordinates. A named corner ("upper_left") is a vtkCornerAnnotation,
#: which shrinks a long line to fit, so the two panels' titles came out in different sizes.
_TITLE = {"position": (0.02, 0.89), "viewport": True, "font_size": 12, "color": "black"}

_BAR = {"vertical": False, "position_x": 0.2, "position_y": 0.03, "width": 0.6,
        "height": 0.06, "title_font_size": 17, "label_font_size": 14, "fmt": "%.1f",
        "n_labels": 4}


def has_stress(run_dir: Path) -> bool:
    """True when the run's ``final_field.npz`` carries the stress (single runs)."""
    path = Path(run_dir) / "final_field.npz"
    if not path.exists():
        return False
    with np.load(path) as ff:
        return "von_mises" in ff.files and "contact_pressure" in ff.files


def stress_maps(run_dir: Path, out_png: Path) -> Path:
    """Von Mises and contact-pressure maps of ``run_dir`` side by side, saved to ``out_png``."""
    ensure_display()
    import pyvista as pv

    pv.OFF_SCREEN = True
    run = load_run(run_dir)
    with np.load(Path(run_dir) / "final_field.npz") as ff:
        pts, cells, types = ff["points"], ff["cells"], ff["cell_types"]
        von_mises, pressure = MPA * ff["von_mises"], MPA * ff["contact_pressure"]
        t = float(ff["fields_time"]) if "fields_time" in ff.files else float(ff["time"])
    grid = pv.UnstructuredGrid(cells.astype(np.int64), types.astype(np.uint8), pts.copy())
    R = run.radius
    r = np.hypot(pts[:, 0], pts[:, 1])
    ring = np.flatnonzero(np.abs(r - R) < 1e-6 * R)
    angle = np.arctan2(pts[ring, 1], pts[ring, 0])
    _, first = np.unique(np.round(angle, 9), return_index=True)  # ghost copies under MPI
    ring = ring[first]  # sorted by angle
    loop = np.append(ring, ring[0])
    ring_line = pv.lines_from_points(pts[loop] + [0.0, 0.0, 1e-3 * R])
    ring_line.point_data["p (MPa)"] = pressure[loop]
    sc = run.scene
    when = f"{sc['name']}: N = {ring.size} contact nodes, t = {MS * t:.2f} ms"
    pl = pv.Plotter(shape=(1, 2), off_screen=True, window_size=(1520, 860), border=False)
    pl.subplot(0, 0)
    grid.cell_data["von Mises (MPa)"] = von_mises
    pl.add_mesh(grid, scalars="von Mises (MPa)", cmap=FIELD_CMAP,
                scalar_bar_args={"title": "von Mises stress (MPa)", **_BAR})
    pl.add_text(f"von Mises stress, plane strain\n(sigma_zz = nu (sigma_rr + sigma_tt))\n{when}",
                **_TITLE)
    pl.view_xy()
    pl.camera.zoom(1.1)
    pl.subplot(0, 1)
    pl.add_mesh(grid.copy(), color="#d9d9d9", show_edges=False)
    pl.add_mesh(ring_line, scalars="p (MPa)", cmap="inferno", line_width=9,
                clim=[0.0, max(float(pressure[ring].max()), 1e-12)],
                scalar_bar_args={"title": "contact pressure p (MPa)", **_BAR})
    pl.add_text(f"contact pressure on r = R\n(0: separated)\n{when}", **_TITLE)
    pl.view_xy()
    pl.camera.zoom(1.1)
    return save_screenshot(pl, out_png)
