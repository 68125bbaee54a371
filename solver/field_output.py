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

from stickslip.solver.scene import Scene

__all__ = ["FieldOutput", "WindowCadence", "expected_period", "field_cadence", "frame_count",
           "last_level_fields", "window_seconds"]


def expected_period(scene: Scene) -> float:
    """T = 2π / ω_k [s] of the reduced model's flutter mode k = ``initial.mode`` (module
    docstring)."""
    from stickslip.semianalytic.coefficients import coefficients, gamma_from_physical
    from stickslip.semianalytic.flutter import flutter_modes

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
                              self.sim.projection.out)
        self.frames += 1
        return ""


def last_level_fields(sim) -> tuple[dict, dict]:
    """(point data, cell data) of the last completed level n of ``sim``, rank-local, for
    ``solver.run.gather_final_field``: the contact pressure and shear traction [Pa] at the
    points of the tube's Lagrange space, the polar stress and von Mises [Pa] per owned cell
    (``solver.writers.FieldValues``). Computed once, at the end."""
    from stickslip.solver.writers import FieldValues

    stepper = sim.integrator
    values = FieldValues(sim.problem)
    values.update(stepper.u_prev, stepper.v, sim.projection.out)
    points = {"contact_pressure": values.pressure.x.array,
              "contact_shear": values.shear.x.array}
    dofs = values.stress[0].function_space.dofmap.list[: values.n_cells, 0]
    return points, {fn.name: fn.x.array[dofs] for fn in values.stress}
