"""Scene files: TOML descriptions of one stick-slip-separation simulation.

A scene is a TOML file mapped onto frozen, validated dataclasses (SI units)::

    name = "figure3_n132"
    [material]   E, wave_speed | rho, nu
    [geometry]   R, xi, delta | d, length
    [loading]    omega, f
    [mesh]       dim, n_inner, n_radial, n_axial, cell, degree, file, contact_group,
                 clamped_group
    [boundary]   ends                                                      (mesh.dim = 3)
    [time]       beta1, beta2, dt, dt_fraction, end_time, max_steps, max_wall_time, kernel
    [initial]    perturbation, mode, amplitude, seed, n_modes
    [damping]    loss_factor + reference_frequency_hz | retardation_time   (default: none)
    [friction]   regularization, slip_length, reference_velocity, relaxation_time
    [output]     sample_interval, probes_deg, fields, field_interval, field_window,
                 field_periods, field_format, progress

Every table and key is optional (defaults below). The 3D keys (mesh.dim, mesh.n_axial,
geometry.length, boundary.ends) are written and hashed only where mesh.dim = 3, so a
plane-strain scene's resolved text and hashes do not depend on them
(``model.scene_to_dict``).  Unknown keys, wrong types and out-of-range values raise
:class:`SceneError`, whose message names the dotted key, the offending value and the
allowed range or keys.  Pure standard library: this module must not import dolfinx.
"""


from stickslip.solver.scene.files import (
    SCENES_DIR,
    dumps_toml,
    list_scenes,
    load_scene,
    write_scene,
)
from stickslip.solver.scene.model import (
    PLANE_STRAIN_ONLY,
    STEADY_DIRECT_DOFS,
    Scene,
    apply_overrides,
    axial_layers,
    parse_override,
    require_plane_strain,
    scene_from_dict,
    scene_to_dict,
    scene_warnings,
    tube_axial_layers,
)
from stickslip.solver.scene.sections import (
    Boundary,
    Damping,
    Friction,
    Geometry,
    Initial,
    Loading,
    Material,
    Mesh,
    Output,
    Time,
)
from stickslip.solver.scene.values import (
    MAX_STRAIN,
    RANGES,
    SPEED_RATIO,
    Range,
    SceneError,
    check_range,
    check_speed_ratio,
)

__all__ = [
    "PLANE_STRAIN_ONLY",
    "STEADY_DIRECT_DOFS",
    "SCENES_DIR",
    "Boundary",
    "Damping",
    "Friction",
    "Geometry",
    "Initial",
    "Loading",
    "MAX_STRAIN",
    "Material",
    "Mesh",
    "Output",
    "RANGES",
    "SPEED_RATIO",
    "Range",
    "Scene",
    "SceneError",
    "Time",
    "apply_overrides",
    "axial_layers",
    "check_range",
    "check_speed_ratio",
    "dumps_toml",
    "list_scenes",
    "load_scene",
    "parse_override",
    "require_plane_strain",
    "scene_from_dict",
    "scene_to_dict",
    "scene_warnings",
    "tube_axial_layers",
    "write_scene",
]
