"""Read a run's ADIOS2 VTX folders (``fields.bp``, ``stress.bp``: dolfinx's ``VTXWriter``) into
pyvista, and render one frame off-screen.

A VTX folder holds, per writing rank (an ADIOS2 *block*), the mesh once (``geometry``: the
points, ``connectivity``: each cell as [node count, nodes...], ``types``: the VTK cell type)
and, per written time level (an ADIOS2 *step*), the fields (``step`` is the time). A field
with one value per point of a block is point data, one per cell is cell data. The blocks are
joined into one grid (their points in block order; a point a rank shares with another appears
once per rank, which changes no picture).

Debian's ``python3-adios2`` has only the MPI bindings: ``import adios2`` needs
``ADIOS2_ALWAYS_USE_MPI=1`` (set by ``./dev`` and the Docker image; set here if missing).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from stickslip.postprocess.isomap import ensure_display, save_screenshot

#: VTX variables that describe the mesh or the writer, not a field
MESH_VARIABLES = ("NumberOfCells", "NumberOfEntities", "NumberOfNodes", "connectivity",
                  "geometry", "types", "step", "vtkGhostType", "vtkOriginalPointIds")


def _adios2() -> Any:
    os.environ.setdefault("ADIOS2_ALWAYS_USE_MPI", "1")
    import adios2

    return adios2


def vtx_times(path: str | Path) -> np.ndarray:
    """The times (s) of the frames a VTX folder holds."""
    with _adios2().FileReader(str(path)) as reader:
        return np.atleast_1d(reader.read("step", step_selection=[0, reader.num_steps()]))


def read_vtx_frame(path: str | Path, frame: int = -1) -> tuple[Any, float]:
    """Frame ``frame`` (an index into ``vtx_times``; -1: the last) of a VTX folder as a
    ``pyvista.UnstructuredGrid`` with every field as point or cell data, and its time (s)."""
    import pyvista as pv

    with _adios2().FileReader(str(path)) as reader:
        steps = reader.num_steps()
        if not -steps <= frame < steps:
            raise IndexError(f"{path}: frame {frame} is out of range (it holds {steps} frames)")
        frame %= steps
        blocks = len(reader.all_blocks_info("geometry")[0])
        points, cells, types, offset = [], [], [], 0
        for b in range(blocks):
            xyz = reader.read("geometry", block_id=b)
            conn = np.asarray(reader.read("connectivity", block_id=b), dtype=np.int64)
            conn[:, 1:] += offset
            points.append(xyz)
            cells.append(conn.ravel())
            cell_type = int(np.ravel(reader.read("types"))[0])
            types.append(np.full(conn.shape[0], cell_type, dtype=np.uint8))
            offset += xyz.shape[0]
        grid = pv.UnstructuredGrid(np.concatenate(cells), np.concatenate(types),
                                   np.vstack(points))
        fields = [name for name, info in reader.available_variables().items()
                  if name not in MESH_VARIABLES and int(info["AvailableStepsCount"]) == steps]
        for name in fields:
            value = np.concatenate([reader.read(name, block_id=b, step_selection=[frame, 1])
                                    for b in range(blocks)])
            if value.shape[0] == grid.n_points:
                grid.point_data[name] = value
            else:
                grid.cell_data[name] = value
        time = float(np.atleast_1d(reader.read("step", step_selection=[frame, 1]))[0])
    return grid, time


def render_vtx_frame(path: str | Path, out_png: str | Path, scalars: str,
                     frame: int = -1, warp: float = 10.0) -> Path:
    """Draw frame ``frame`` of a VTX folder coloured by ``scalars`` (for a vector, its
    magnitude), displaced by ``warp`` times ``displacement`` where the folder has it (10: the
    damped Figure-3 run's 5.6 mm becomes a fifth of its 0.25 m wall), into ``out_png``."""
    import pyvista as pv

    grid, time = read_vtx_frame(path, frame)
    if scalars not in grid.point_data and scalars not in grid.cell_data:
        raise KeyError(f"{path} has no field {scalars!r}: it has "
                       f"{sorted([*grid.point_data, *grid.cell_data])}")
    if "displacement" in grid.point_data and warp:
        grid = grid.warp_by_vector("displacement", factor=warp)
    ensure_display()
    pv.OFF_SCREEN = True
    plotter = pv.Plotter(off_screen=True, window_size=(900, 800))
    plotter.add_mesh(grid, scalars=scalars, cmap="viridis",
                     scalar_bar_args={"title": f"{scalars} at t = {time:.5g} s"})
    plotter.view_xy()
    return save_screenshot(plotter, Path(out_png))
