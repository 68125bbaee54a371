"""What a scene will cost, estimated before anything is meshed.

Dofs, steps, memory, output size and run time follow from the scene alone (no dolfinx):

* nodes = n_inner x (layers x degree + 1), layers = mesh.n_radial or the mesher's automatic
  choice round((xi - 1) n_edges / 2 pi) (>= 2); dofs = 2 nodes; a user's ``mesh.file``
  gives its own node and cell counts and shortest edge (read with gmsh, no dolfinx);
* the explicit step: dt_crit = sqrt(2/beta2) / omega_max, or with Kelvin-Voigt damping tau the
  damped limit (``solver.newmark.critical_time_step``: the undamped one counts 10 % too few
  steps at N = 264 of the damped paper scenes), omega_max ~ C c_p / h_min with
  c_p = wave_speed sqrt((1 - nu) / ((1 + nu)(1 - 2 nu))) and h_min the smallest node spacing;
  C = 2.8 measured (P1 triangles: 2.29 at N = 36, 2.67 at N = 132, 2.80 at N = 1056);
* memory = 250 MB (Python, dolfinx, PETSc per rank) + 3 kB per dof (measured 2.4 kB: peak RSS
  222 MB at 1584 dofs, 439 MB at 90816 dofs) + the preallocated recorders (49 B per contact
  node per sample; 180 B per probe per step at the peak: the history, its gather on rank 0
  and the archive's copy, measured 583 MB for 500 probes over 6470 steps); the samples on
  disk: 49 B per contact node per sample and 40 B per probe per step;
* field output (``output.fields``, ``solver.writers``): per written frame
  1.05 (105 B per node + (32 + 8 (v + 1)) B per cell) + 5 kB: per node the displacement and
  velocity padded to 3 components, pressure, shear, status and the stress file's mesh
  (points, original ids, ghost flags); per cell 4 stress values and the connectivity of its
  v vertices; 5 % and 5 kB of ADIOS2 metadata. Frames = ``solver.field_output.frame_count``.
  Measured 26 / 180 / 2758 kB per frame at N = 36 / 132 / 528 (P1), estimated 27 / 181 /
  2776 kB (``benchmarks/field_output_cost.py``); 1 us per dof and frame of run time;
* time (the run's own wall time, ``wall_time_s`` of its summary) = 1.2 s (the run's fixed
  costs: kernels, recorders, analysis) + 1.5 us per contact-node sample (writing and
  analysing the samples) + setup 11 s x (dofs / 90816)^1.5 (the SLEPc stability estimate
  dominates) + steps x (10 us + 8 ns x dofs x (dofs / 6336)^0.15: a step's cost per dof grows
  past the caches, 11 ns at N = 528 and 13 ns at 1056) on one rank. Fitted to the lower of
  two runs of the Figure-3 scene and its damped twin at N = 132, 264 and 528 and one damped
  run at 1056 on a 2-core machine (``benchmarks/doc_facts.py timings``,
  ``docs/facts/timings.json``): within 20 % of each (-17 % to +13 %); a step of the undamped scene
  (beta2 = 0.6) costs 45 % more than one of the damped scene at N = 264, which no model of
  dofs and steps alone tells apart.

A 3D tube (``mesh.dim = 3``: the cross-section's nodes on N_z + 1 levels, 3 dofs a node) has
its own costs (``tube_costs``): the steady state's LU sets its memory and setup, and its numpy
step costs about 200 ns per dof.

The numbers are order-of-magnitude guards, not promises: a run is refused when the memory
exceeds what the machine has available, the samples exceed the free disk, or the run time on
the ranks given (perfect scaling assumed) exceeds ``MAX_SECONDS`` without a
``time.max_wall_time`` that bounds it, unless the user says ``--yes-i-know``.
"""

from __future__ import annotations

import math
import os
import shutil
from dataclasses import dataclass
from pathlib import Path

from stickslip.solver.field_output import frame_count
from stickslip.solver.newmark import critical_time_step
from stickslip.solver.scene import STEADY_DIRECT_DOFS, Scene, tube_axial_layers
from stickslip.solver.surface_samples import SURFACE_BYTES_PER_NODE_SAMPLE

__all__ = ["Estimate", "ResourceError", "available_memory", "check_resources", "estimate"]

OMEGA_MAX_C = 2.8
OMEGA_MAX_C_3D = 1.95  # hexahedra: measured at N = 132, L/R = 0.5 (dt_crit 3.74e-5 s)
BASE_MEMORY = 250e6
BYTES_PER_DOF = 3e3
BYTES_PER_PROBE_STEP = 180.0  # peak memory of the probe histories (module docstring)
FIELD_BYTES_PER_NODE = 105.0  # one field frame on disk (module docstring)
FIELD_SECONDS_PER_DOF = 1e-6  # one frame's stress assembly and write (measured 0.5-0.7 us)
#: The run-time model (module docstring), seconds on one core: fixed, per contact-node
#: sample, setup at 90816 dofs, per step, and per step and dof at STEP_DOFS dofs, growing
#: as (dofs / STEP_DOFS)^STEP_DOF_GROWTH.
RUN_SECONDS = 1.2
SAMPLE_SECONDS = 1.5e-6
SETUP_SECONDS = 11.0
STEP_SECONDS = 1e-5
STEP_SECONDS_PER_DOF = 8e-9
STEP_DOFS = 6336.0
STEP_DOF_GROWTH = 0.15
#: Longest estimated run accepted without --yes-i-know or time.max_wall_time (two days).
MAX_SECONDS = 2 * 86400.0


#: Most time steps a scene may ask for: the steppers count steps in 64-bit integers.
MAX_STEPS = 1e18


class ResourceError(ValueError):
    """The scene needs more than the machine has (message: the numbers and the fix)."""


@dataclass(frozen=True)
class Estimate:
    """Cost of one scene (see the module docstring for the model)."""

    dofs: int
    steps: int
    samples: int
    memory_bytes: float
    output_bytes: float  # samples, probes and fields
    seconds: float
    field_frames: int = 0
    field_bytes: float = 0.0

    def line(self) -> str:
        """One line for the console."""
        fields = (f" (fields: {self.field_frames} frames, {_bytes(self.field_bytes)})"
                  if self.field_frames else "")
        return (f"estimate (before meshing; dt from the shortest edge, the mesh's own dt "
                f"below): {self.dofs} dofs, ~{self.steps} steps, {_bytes(self.memory_bytes)} "
                f"memory, {_bytes(self.output_bytes)} of output{fields}, "
                f"~{_duration(self.seconds)} on one rank")


def tube_layers(scene: Scene) -> int:
    """Element layers through the tube's wall: ``mesh.n_radial``, or the mesher's own
    choice (``meshes.annulus.auto_n_radial``) round((xi - 1) n_edges / 2 pi), at least 2."""
    m = scene.mesh
    return m.n_radial or max(2, round((scene.geometry.xi - 1.0) * (m.n_inner // m.degree)
                                      / (2.0 * math.pi)))


def tube_nodes(scene: Scene) -> int:
    """Nodes of the tube's cross-section: n_inner x (layers x degree + 1)."""
    return scene.mesh.n_inner * (tube_layers(scene) * scene.mesh.degree + 1)


#: The 3D tube's costs (``tube_costs``), fitted to Figure 3 damped with free ends at N = 132,
#: L/R = 0.25 to 2 (14 256 to 102 168 dofs; docs/tube3d.md) on one core: its numpy step
#: 170-215 ns per dof (with its observers and the surface record); the steady state's LU
#: 1.3, 2.2, 7.7 and 33 s, and the peak memory above the base 202, 374, 810 and 1879 MB.
STEP_SECONDS_PER_DOF_3D = 2.1e-7
TUBE_DOFS = 102168.0
TUBE_SETUP_SECONDS = 34.0
TUBE_LU_BYTES = 1.88e9
#: Above ``STEADY_DIRECT_DOFS`` GMRES with GAMG and the rigid-body modes: N_θ = 264, N_z =
#: 64 (617 760 dofs) peaked at 3128 MB with its base, and set up (mesh, stiffness, omega_max,
#: steady state: 13.8 + 29.5 + 55.6 s) in 99 s, both taken as linear in the dofs.
TUBE_ITERATIVE_BYTES_PER_DOF = 4.7e3
TUBE_ITERATIVE_SECONDS_PER_DOF = 1.6e-4


def tube_costs(dofs: float) -> tuple[float, float, float]:
    """(bytes, setup seconds, seconds per step) of a 3D tube of ``dofs`` dofs on one rank:
    the LU's memory as dofs^1.25 and time as dofs^2 up to ``STEADY_DIRECT_DOFS``, the
    iterative solve's memory and time linear beyond, and the step's
    ``STEP_SECONDS_PER_DOF_3D`` per dof."""
    scale = dofs / TUBE_DOFS
    if dofs <= STEADY_DIRECT_DOFS:
        memory, setup = TUBE_LU_BYTES * scale**1.25, TUBE_SETUP_SECONDS * scale**2
    else:
        memory = TUBE_ITERATIVE_BYTES_PER_DOF * dofs
        setup = TUBE_ITERATIVE_SECONDS_PER_DOF * dofs
    return memory, setup, STEP_SECONDS_PER_DOF_3D * dofs


def estimate(scene: Scene, ranks: int = 1) -> Estimate:
    """Dofs, steps, memory (all ranks), output size and one-rank run time of ``scene``."""
    g, m, ts = scene.geometry, scene.mesh, scene.time
    n_edges = m.n_inner // m.degree
    if m.tube:
        layers = tube_layers(scene)
        nodes = tube_nodes(scene)
        cells = n_edges * layers * (2 if m.cell == "triangle" else 1)
        h_min = min(2 * math.pi * g.R / m.n_inner, (g.xi - 1.0) * g.R / (layers * m.degree))
    else:  # a user's mesh file: its own counts and shortest edge (meshes.user_mesh, _tube)
        facts = m.file_facts(g.R)
        nodes, cells = facts.n_nodes, facts.n_cells
        h_min = facts.h_min / m.degree
    dofs, surface_nodes, vertices = 2 * nodes, 0, 8
    if m.dim == 3 and not m.tube:  # a user's tube: the file's counts (meshes.user_tube)
        surface_nodes, dofs, vertices = m.n_inner * (facts.n_axial + 1), 3 * nodes, \
            facts.nodes_per_cell
    elif m.dim == 3:  # the cross-section extruded in hexahedra (meshes.tube3d)
        levels = tube_axial_layers(scene)
        h_min = min(h_min, g.length / levels)
        cells = n_edges * tube_layers(scene) * levels  # a float: inf for a huge length
        nodes, surface_nodes = nodes * (levels + 1), m.n_inner * (levels + 1)
        dofs = int(3 * nodes) if math.isfinite(nodes) else 3 * nodes
    nu = scene.material.nu
    c_p = scene.material.wave_speed * math.sqrt((1 - nu) / ((1 + nu) * (1 - 2 * nu)))
    omega_max = (OMEGA_MAX_C_3D if m.dim == 3 else OMEGA_MAX_C) * c_p / h_min
    # the explicit limit with the Kelvin-Voigt damping's (lower) one: the unit of dt_fraction
    # of the explicit scheme; an upper bound of the steps of the implicit one, whose unit is
    # the undamped limit
    dt_crit = critical_time_step(omega_max, 0.0, ts.beta2, scene.damping.tau)
    dt = ts.dt if ts.dt > 0 else ts.dt_fraction * dt_crit
    if not dt > 0:  # a damping so large that the explicit stability limit underflows to 0
        raise ResourceError(
            f"the explicit time step is 0 s: the Kelvin-Voigt damping (tau = "
            f"{scene.damping.tau:.3g} s) leaves no stable step; lower damping.loss_factor or "
            "damping.retardation_time, or raise damping.reference_frequency_hz")
    if not ts.end_time / dt <= MAX_STEPS:  # end_time = 1e308: no count, no estimate
        raise ResourceError(
            f"time.end_time = {ts.end_time:g} s is more than {MAX_STEPS:.0e} time steps of "
            f"dt = {dt:.3g} s (the step counters are 64-bit): reduce time.end_time")
    steps = math.ceil(ts.end_time / dt)
    if ts.max_steps:
        steps = min(steps, ts.max_steps)
    every = max(1, round(scene.output.sample_interval / dt))
    samples = steps // every + 2
    sample_bytes = samples * (m.n_inner * 49.0
                              + surface_nodes * SURFACE_BYTES_PER_NODE_SAMPLE)
    n_probes = len(scene.output.probes_deg)
    probe_bytes = (steps + 1) * (40.0 * n_probes + 8.0)
    probe_peak = (steps + 1) * (BYTES_PER_PROBE_STEP * n_probes + 8.0)
    dof_bytes, setup, step_cost = (tube_costs(dofs) if m.dim == 3 else (
        BYTES_PER_DOF * dofs, SETUP_SECONDS * (dofs / 90816.0) ** 1.5,
        STEP_SECONDS_PER_DOF * dofs * (dofs / STEP_DOFS) ** STEP_DOF_GROWTH))
    memory = ranks * BASE_MEMORY + dof_bytes + sample_bytes + probe_peak
    seconds = (RUN_SECONDS + SAMPLE_SECONDS * samples * m.n_inner + setup
               + steps * (STEP_SECONDS + step_cost))
    frames, field_bytes = 0, 0.0
    if scene.output.fields:
        vertices = vertices if m.dim == 3 else {("triangle", 1): 3, ("triangle", 2): 6,
                                                ("quadrilateral", 1): 4,
                                                ("quadrilateral", 2): 9}[(m.cell, m.degree)]
        frames = frame_count(scene, dt, steps)
        field_bytes = frames * (1.05 * (FIELD_BYTES_PER_NODE * nodes
                                        + (32.0 + 8.0 * (vertices + 1)) * cells) + 5e3)
        seconds += frames * FIELD_SECONDS_PER_DOF * dofs
    return Estimate(dofs=dofs, steps=steps, samples=samples, memory_bytes=memory,
                    output_bytes=sample_bytes + probe_bytes + field_bytes, seconds=seconds,
                    field_frames=frames, field_bytes=field_bytes)


def available_memory() -> float:
    """MemAvailable of /proc/meminfo (bytes); +inf where it cannot be read."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024.0
    except OSError:
        pass
    return math.inf


def check_resources(scene: Scene, run_dir: Path, ranks: int = 1) -> Estimate:
    """The estimate, or :class:`ResourceError` if it exceeds the memory, the disk or the
    time (``MAX_SECONDS``, where ``time.max_wall_time`` does not bound the run)."""
    est = estimate(scene, ranks)
    mem = available_memory()
    fix = ("reduce mesh.n_inner, time.end_time or raise output.sample_interval (with "
           "output.fields: raise output.field_interval or shorten output.field_window), or "
           "pass --yes-i-know to run anyway")
    if est.memory_bytes > mem:
        raise ResourceError(
            f"scene '{scene.name}' needs about {_bytes(est.memory_bytes)} of memory "
            f"({est.dofs} dofs, {est.samples} samples, {est.steps} steps) but "
            f"{_bytes(mem)} is available: {fix}")
    wall = est.seconds / max(1, ranks)
    if wall > MAX_SECONDS and not scene.time.max_wall_time:
        raise ResourceError(
            f"scene '{scene.name}' would take about {_duration(wall)} on {ranks} rank(s) "
            f"({est.dofs} dofs, {est.steps} steps): reduce mesh.n_inner or time.end_time, "
            "bound it with time.max_wall_time, or pass --yes-i-know to run anyway")
    free = _free_disk(run_dir)
    if est.output_bytes > free:
        raise ResourceError(
            f"scene '{scene.name}' would write about {_bytes(est.output_bytes)} of output "
            f"but {_bytes(free)} is free under {run_dir}: {fix}")
    return est


def _free_disk(path: Path) -> float:
    p = Path(os.path.abspath(path))
    while not p.exists() and p != p.parent:
        p = p.parent
    try:
        return float(shutil.disk_usage(p).free)
    except OSError:
        return math.inf


def _bytes(n: float) -> str:
    if not math.isfinite(n):
        return "unlimited"
    for unit in ("B", "kB", "MB", "GB", "TB", "PB"):
        if n < 1000 or unit == "PB":
            return f"{n:.3g} {unit}"
        n /= 1000.0
    return f"{n:.3g} PB"  # pragma: no cover


def _duration(s: float) -> str:
    if s < 120:
        return f"{s:.0f} s"
    if s < 7200:
        return f"{s / 60:.0f} min"
    if s < 172800:
        return f"{s / 3600:.1f} h"
    return f"{s / 86400:.3g} days"
