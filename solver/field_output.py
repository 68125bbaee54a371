"""When fields are written: a sim-time cadence inside a window at the end of the run.

``output.field_interval`` Δt_f is the cadence: the written levels are the multiples of
``every = round(Δt_f / Δt)`` (at least 1). The window is the stretch of sim time written:

* ``output.field_window`` > 0: the last ``field_window`` seconds of the run;
* ``output.field_window`` = 0 (default): the last ``field_periods`` periods T of the scene's
  expected wave, T = 2π / ω_k with ω_k the flutter frequency of the wavenumber k =
  ``initial.mode`` in the reduced model (``semianalytic.flutter``, paper section 3, with the
  scene's ν, ξ, γ = (RΩ/c₀)², f). For the paper's Figure-3 scene (k = 4) T = 0.94 ms
  (1.07 kHz; the limit cycle's wave, at 1.6 kHz, is faster: ten periods hold 16 of it).
  For a user's cross-section (``mesh.file``) the rule uses the tube of the scene's R and ξ.

The run's end is ``time.end_time`` (or ``time.max_steps`` Δt where that comes first); the
window starts at ``max(0, end − window)``. A window longer than the run writes the whole run.
The number of frames is ``frame_count`` (the size estimate of ``studies.resources`` uses it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from stickslip.semianalytic.coefficients import coefficients, gamma_from_physical
from stickslip.semianalytic.flutter import flutter_modes
from stickslip.solver.scene import Scene

__all__ = ["FieldOutput", "WindowCadence", "expected_period", "field_cadence", "frame_count",
           "gather_final_field", "last_level_fields", "window_seconds"]


def expected_period(scene: Scene) -> float:
    """T = 2π / ω_k [s] of the reduced model's flutter mode k = ``initial.mode`` (module
    docstring)."""
    g, m, ld = scene.geometry, scene.material, scene.loading
    k = max(1, scene.initial.mode)
    co = coefficients(m.nu, g.xi, gamma_from_physical(m.wave_speed, g.R, ld.omega))
    mode = flutter_modes(co, ld.f, kmax=k, kmin=k)[0]
    return 2.0 * math.pi / (mode.frequency * ld.omega)


def window_seconds(scene: Scene) -> float:
    """The length of sim time written at the end of the run [s] (module docstring)."""
    out = scene.output
    if out.field_window > 0.0:
        return out.field_window
    return out.field_periods * expected_period(scene)


@dataclass(frozen=True)
class WindowCadence:
    """Every ``every`` levels from level ``first`` on (``first`` a multiple of ``every``); the
    ``solver.observers.Cadence`` interface that ``run_loop`` asks (``at``, ``next_level``)."""

    every: int
    first: int

    def at(self, level: int) -> bool:
        return level >= self.first and level % self.every == 0

    def next_level(self, level: int) -> int:
        """The first written level >= ``level``."""
        level = max(level, self.first)
        return level + (-level % self.every)


def field_cadence(scene: Scene, dt: float, steps: int) -> WindowCadence:
    """The written levels of a run of ``steps`` steps of ``dt``."""
    every = max(1, int(round(scene.output.field_interval / dt)))
    start = max(0.0, steps * dt - window_seconds(scene))
    first_level = int(math.floor(start / dt + 1e-9))
    return WindowCadence(every, first_level + (-first_level % every))


def frame_count(scene: Scene, dt: float, steps: int) -> int:
    """How many levels ``field_cadence`` writes among the levels 0 .. steps − 1."""
    c = field_cadence(scene, dt, steps)
    return 0 if c.first > steps - 1 else (steps - 1 - c.first) // c.every + 1


class FieldOutput:
    """Observer: the fields of ``solver.writers.FieldFrames`` at the levels of
    ``field_cadence``; level n is written at t_n = n Δt with u_n, v_n and the contact forces
    r_n of the step that produced u_{n+1}."""

    def __init__(self, sim, output_dir: Path) -> None:
        # dolfinx: batches and the resource estimate import this module without it
        from stickslip.solver.writers import FieldFrames

        self.sim = sim
        self.writer = FieldFrames(sim.problem, Path(output_dir), sim.scene.output.field_format)
        self.cadence = field_cadence(sim.scene, sim.dt, sim.planned_steps())
        self.frames = 0

    def due(self, level: int) -> bool:
        return self.cadence.at(level)

    def observe(self, stepper) -> str:
        with self.sim.profile.phase("output"):
            self.writer.write(stepper.time - stepper.dt, stepper.u_prev, stepper.v,
                              self.sim.projection.surface_out)
        self.frames += 1
        return ""


def last_level_fields(sim) -> tuple[dict, dict]:
    """(point data, cell data) of the last completed level n of ``sim``, rank-local, for
    ``gather_final_field``: the contact pressure and shear traction [Pa] at the
    points of the tube's Lagrange space, the polar stress and von Mises [Pa] per owned cell
    (``solver.writers.FieldValues``). Computed once, at the end."""
    # dolfinx: batches and the resource estimate import this module without it
    from stickslip.solver.writers import FieldValues

    stepper = sim.integrator
    values = FieldValues(sim.problem)
    values.update(stepper.u_prev, stepper.v, sim.projection.surface_out)
    points = {"contact_pressure": values.pressure.x.array,
              "contact_shear": values.shear.x.array}
    dofs = values.stress[0].function_space.dofmap.list[: values.n_cells, 0]
    return points, {fn.name: fn.x.array[dofs] for fn in values.stress}


def gather_final_field(problem, u: np.ndarray, comm, time_s: float,
                       point_data: dict[str, np.ndarray] | None = None,
                       cell_data: dict[str, np.ndarray] | None = None,
                       ) -> dict[str, np.ndarray] | None:
    """Displacement ``u`` (owned dofs) on the whole tube, gathered to rank 0 (None elsewhere).

    VTK-ready arrays for iso-value maps: ``points`` (n, 3), ``cells`` (flat VTK topology
    [nv, i0, ..., nv, ...]), ``cell_types``, ``u`` (n, 2), or (n, 3) in 3D, at the points.
    Each rank sends its local cells; ghost points are duplicated, which is harmless for plotting.
    ``point_data`` (values at the rank's local dofs of the scalar space, ghosts included)
    and ``cell_data`` (values at its owned cells) are gathered alongside, under their keys.
    """
    import dolfinx.plot

    point_data, cell_data = point_data or {}, cell_data or {}
    fn = problem.to_function(u)
    topology, cell_types, geometry = dolfinx.plot.vtk_mesh(problem.V)
    n_points = geometry.shape[0]
    values = fn.x.array.reshape(-1, problem.V.dofmap.index_map_bs)[:n_points]
    extra = {k: np.asarray(v)[:n_points] for k, v in point_data.items()}
    extra.update(cell_data)
    pieces = comm.gather((topology, cell_types, geometry, values, extra), root=0)
    if comm.rank != 0:
        return None
    cells, types, points, us = [], [], [], []
    offset = 0
    for top, ct, geo, val, _ in pieces:
        nv = int(top[0]) if top.size else 0
        blocks = top.reshape(-1, nv + 1).copy() if top.size else top.reshape(0, 1)
        blocks[:, 1:] += offset
        cells.append(blocks.ravel())
        types.append(ct)
        points.append(geo)
        us.append(val)
        offset += geo.shape[0]
    out = {
        "points": np.concatenate(points),
        "cells": np.concatenate(cells),
        "cell_types": np.concatenate(types),
        "u": np.concatenate(us),
        "time": np.array(time_s),
    }
    for key in (*point_data, *cell_data):
        out[key] = np.concatenate([piece[4][key] for piece in pieces])
    return out
