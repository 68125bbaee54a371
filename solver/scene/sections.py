"""The scene's sections as frozen, validated dataclasses (SI units), and ``Scene`` itself."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

from stickslip.solver.contact.law import REGULARISATIONS, SpatialFilter, regularisation_of
from stickslip.solver.scene.values import (
    MAX_AXIAL_LAYERS,
    MAX_STRAIN,
    SCENES_DIR,
    SceneError,
    _choice,
    _opt,
    _require,
    _Section,
    _to_float,
    check_range,
)

# ----------------------------------------------------------------------------- sections


@dataclass(frozen=True)
class Material(_Section):
    """Linear elastic, isotropic tube material (plane strain)."""

    SECTION: ClassVar[str] = "material"

    E: float = _opt(1.0e9, "float")
    """Young's modulus [Pa]."""
    wave_speed: float = _opt(1000.0, "float")
    """Reference wave speed sqrt(E/rho) [m/s] (the scene may give ``rho`` instead)."""
    nu: float = _opt(0.3, "float")
    """Poisson ratio [-]."""

    @property
    def rho(self) -> float:
        """Mass density E / wave_speed**2 [kg/m^3]."""
        return self.E / self.wave_speed**2

    @classmethod
    def from_rho(cls, E: float = 1.0e9, rho: float = 1000.0, nu: float = 0.3) -> Material:
        """Build from a density instead of a wave speed."""
        E = _to_float("material.E", E)
        rho = _to_float("material.rho", rho)
        check_range("material.rho", rho)
        check_range("material.E", E)
        return cls(E=E, wave_speed=math.sqrt(E / rho), nu=nu)

    def _check(self) -> None:
        for name in ("E", "wave_speed", "nu"):
            check_range(self._key(name), getattr(self, name))
        c2 = self.wave_speed * self.wave_speed  # inf, not OverflowError, at 1e308
        rho = self.E / c2 if c2 > 0 else math.inf
        _require(self._key("wave_speed"), self.wave_speed, 0 < rho < math.inf,
                 "a finite, non-zero density E / wave_speed**2 (kg/m^3)")


@dataclass(frozen=True)
class Geometry(_Section):
    """Elastic tube of inner radius R and outer radius xi*R on a rigid cylinder R + d."""

    SECTION: ClassVar[str] = "geometry"

    R: float = _opt(1.0, "float")
    """Inner radius of the tube [m]."""
    xi: float = _opt(1.25, "float")
    """Outer/inner radius ratio R*/R [-]."""
    delta: float = _opt(4.0e-4, "float")
    """Non-dimensional mismatch d/R [-] (the scene may give ``d`` in metres instead)."""
    length: float = _opt(0.0, "float", needs="3d")
    """Length of the finite tube along z [m] (``mesh.dim`` = 3 only, where it is required)."""

    @property
    def d(self) -> float:
        """Radial mismatch delta*R [m]."""
        return self.delta * self.R

    @property
    def R_outer(self) -> float:
        """Outer radius xi*R [m]."""
        return self.xi * self.R

    @property
    def strained_length(self) -> float:
        """The length that takes up a radial displacement of the contact circle [m]:
        min(R, (xi - 1) R). The outer circle is clamped, so a thin wall is squeezed across
        its thickness (xi - 1) R; a thick tube's contact circle is stretched round its
        length (hoop strain u_r / R)."""
        return min(self.R, (self.xi - 1.0) * self.R)

    def _check(self) -> None:
        for name in ("R", "xi", "delta"):
            check_range(self._key(name), getattr(self, name))
        _require(self._key("length"), self.length, self.length >= 0,
                 "length >= 0 (m; > 0 with mesh.dim = 3)")
        strain = self.d / self.strained_length
        if strain > MAX_STRAIN * (1.0 + 1e-9):  # the bound itself is allowed, to round-off
            raise SceneError(
                f"geometry.delta = {self.delta:.6g} with geometry.xi = {self.xi:.10g} is out of "
                f"range: the mismatch d = delta R squeezes the tube's wall ((xi - 1) R = "
                f"{(self.xi - 1.0) * self.R:.3g} m, clamped outside) by a strain of about "
                f"d / min(R, (xi - 1) R) = {strain:.3g}, above the {MAX_STRAIN:.0%} that the "
                f"small-strain model allows: lower geometry.delta to <= "
                f"{MAX_STRAIN * self.strained_length / self.R:.3g} or thicken the wall "
                f"(geometry.xi >= {1.0 + self.delta / MAX_STRAIN:.4g})")


@dataclass(frozen=True)
class Loading(_Section):
    """Rotation of the rigid cylinder and Coulomb friction."""

    SECTION: ClassVar[str] = "loading"

    omega: float = _opt(50.0, "float")
    """Angular velocity of the rigid cylinder [rad/s]."""
    f: float = _opt(0.7, "float")
    """Coulomb friction coefficient [-]."""

    def _check(self) -> None:
        for name in ("omega", "f"):
            check_range(self._key(name), getattr(self, name))


CELL_TYPES = ("triangle", "quadrilateral")
#: the ends of a finite tube (``solver.problem.tube_problem_3d``): the displacement
#: components held at 0 on z = 0 and z = L (0, 1, 2: x, y, z); a roller end holds u_z and
#: leaves the end free in its plane
ENDS = {"free": (), "roller": (2,), "clamped": (0, 1, 2)}
END_NAMES = tuple(ENDS)
PERTURBATIONS = ("none", "mode", "random")
TIME_KERNELS = ("auto", "numpy", "numba")


@dataclass(frozen=True)
class Mesh(_Section):
    """The cross-section's mesh and finite-element space: the tube (annulus, default) or a
    user's gmsh file (``file``, meshes.user_mesh)."""

    SECTION: ClassVar[str] = "mesh"

    dim: int = _opt(2, "int", needs="3d")
    """2: the cross-section in plane strain; 3: the finite tube of ``geometry.length``, the
    structured annulus of degree 1 extruded in hexahedra (``mesh.cell`` is not used) or a
    user's ``file`` (meshes.user_tube), for ``stickslip flutter-fe``, ``run``, ``sweep``,
    ``continue`` and ``attractors`` (``travel`` and ``rpo`` are plane strain only)."""
    n_inner: int = _opt(132, "int")
    """Number of nodes on the inner (contact) circle (with ``file``: the stated count)."""
    n_radial: int = _opt(0, "int")
    """Element layers through the thickness; 0 = automatic (the tube only)."""
    n_axial: int = _opt(0, "int", needs="3d")
    """Element layers along z (``dim`` = 3); 0 = cells as long as they are wide on the
    contact surface, round(L N / (2 pi R)), at least 1."""
    cell: str = _opt("triangle", "str")
    """Cell type: "triangle" or "quadrilateral"."""
    degree: int = _opt(1, "int")
    """Lagrange degree: 1 (P1/Q1) or 2 (P2/Q2)."""
    file: str = _opt("", "str")
    """A gmsh .geo or .msh cross-section instead of the tube ("" = the tube), or with
    ``dim`` = 3 a finite tube; a relative path is looked up in the working directory, then
    in the shipped scenes' folder."""
    contact_group: str = _opt("contact", "str")
    """Physical group of ``file`` on the contact circle r = R (N nodes; in 3D the surface
    r = R, rings of N nodes)."""
    clamped_group: str = _opt("clamped", "str")
    """Physical group of ``file`` that is clamped (u = 0; a curve, in 3D a surface)."""
    ends_group: str = _opt("ends", "str", needs="3d")
    """Physical surface group of a 3D ``file`` that ``boundary.ends`` holds (the tube's
    ends); optional where the ends are free."""

    @property
    def tube(self) -> bool:
        """True for the built-in tube (no ``file``)."""
        return not self.file

    def file_facts(self, R: float):
        """The checked facts of ``file`` (``meshes.user_mesh.inspect_mesh_file``, with
        ``dim`` = 3 ``meshes.user_tube.inspect_tube_file``) for the contact radius R;
        ``SceneError`` (one line) when a check fails."""
        # gmsh and dolfinx read a mesh file: scenes load without them
        from stickslip.meshes.user_mesh import MeshFileError, inspect_mesh_file, resolve

        # the same: gmsh reads a user's 3D tube (meshes.user_tube)
        from stickslip.meshes.user_tube import inspect_tube_file

        try:
            if self.dim == 3:
                return inspect_tube_file(resolve(self.file, (SCENES_DIR,)), R=R,
                                         n_contact=self.n_inner,
                                         contact_group=self.contact_group,
                                         clamped_group=self.clamped_group,
                                         ends_group=self.ends_group)
            return inspect_mesh_file(resolve(self.file, (SCENES_DIR,)), R=R,
                                     n_contact=self.n_inner, cell=self.cell,
                                     degree=self.degree, contact_group=self.contact_group,
                                     clamped_group=self.clamped_group)
        except MeshFileError as err:
            raise SceneError(str(err)) from None

    def _check(self) -> None:
        _require(self._key("n_inner"), self.n_inner, self.n_inner >= 8, "n_inner >= 8")
        _require(
            self._key("n_radial"),
            self.n_radial,
            self.n_radial >= 0,
            "n_radial >= 0 (0 = automatic)",
        )
        _choice(self._key("cell"), self.cell, CELL_TYPES)
        _choice(self._key("degree"), self.degree, (1, 2))
        _choice(self._key("dim"), self.dim, (2, 3))
        # the rule a literal (the scene reference reads it): 1e7 is MAX_AXIAL_LAYERS
        _require(self._key("n_axial"), self.n_axial, 0 <= self.n_axial <= MAX_AXIAL_LAYERS,
                 "0 <= n_axial <= 1e7 (0 = cells as long as they are wide on the contact "
                 "surface)")
        if self.dim == 3:  # what solver.problem.tube_problem_3d extrudes, or a user's
            _require(self._key("degree"), self.degree, self.degree == 1,
                     "degree = 1 with mesh.dim = 3 (the 3D tube, the structured annulus "
                     "extruded or a user's file, is of degree 1)")


@dataclass(frozen=True)
class Boundary(_Section):
    """The ends z = 0 and z = L of the finite tube (``mesh.dim`` = 3); its outer surface is
    clamped, as the outer circle in plane strain. Default "free": nothing holds a tube's
    ends unless something is built there, and ``stickslip flutter-fe --length L`` alone
    builds the same tube."""

    SECTION: ClassVar[str] = "boundary"

    ends: str = _opt("free", "str", needs="3d")
    """"free", "roller" (u_z = 0: the plane-strain modes are then modes of the 3D tube) or
    "clamped" (u = 0), on both ends."""

    def _check(self) -> None:
        _choice(self._key("ends"), self.ends, END_NAMES)


@dataclass(frozen=True)
class Time(_Section):
    """Newmark time integration (paper notation beta1, beta2) and run limits."""

    SECTION: ClassVar[str] = "time"

    beta1: float = _opt(0.0, "float")
    """Newmark beta_1 (0 = explicit; > 0 implicit, e.g. 0.25 with beta2 = 0.5)."""
    beta2: float = _opt(0.6, "float")
    """Newmark beta_2 (gamma in other texts)."""
    dt: float = _opt(0.0, "float")
    """Time step [s]; 0 = dt_fraction times the explicit stability limit."""
    dt_fraction: float = _opt(0.9, "float")
    """Multiple of the explicit stability limit used when dt = 0 (<= 1 if beta1 = 0)."""
    end_time: float = _opt(0.3, "float")
    """Simulated physical time [s]."""
    max_steps: int = _opt(0, "int")
    """Step limit; 0 = unlimited."""
    max_wall_time: float = _opt(0.0, "float")
    """Wall-clock limit [s]; 0 = unlimited."""
    kernel: str = _opt("auto", "str")
    """Explicit step: "numpy" (reference), "numba" (fused, solver.fused), "auto" (numba if it
    imports). Same results to round-off; see solver.schemes.select.resolve_kernel."""

    def _check(self) -> None:
        _require(
            self._key("beta1"),
            self.beta1,
            0 <= self.beta1 <= 0.5,
            "0 <= beta1 <= 0.5 (0 = explicit)",
        )
        _require(
            self._key("beta2"),
            self.beta2,
            0.5 <= self.beta2 <= 1.0,
            "0.5 <= beta2 <= 1.0 (beta2 < 0.5 is unstable)",
        )
        _require(
            self._key("dt"), self.dt, self.dt >= 0, "dt >= 0 (s; 0 = automatic from dt_fraction)"
        )
        if self.beta1 == 0:
            _require(
                self._key("dt_fraction"),
                self.dt_fraction,
                0 < self.dt_fraction <= 1,
                "0 < dt_fraction <= 1 (fraction of the explicit stability limit; the "
                "implicit scheme, beta1 > 0, allows dt_fraction > 1)",
            )
        else:
            _require(
                self._key("dt_fraction"),
                self.dt_fraction,
                0 < self.dt_fraction <= 1e6,
                "0 < dt_fraction <= 1e6 (multiple of the explicit stability limit "
                "sqrt(2/beta2)/omega_max; beta1 > 0 is implicit)",
            )
        _require(self._key("end_time"), self.end_time, self.end_time > 0, "end_time > 0 (s)")
        _require(
            self._key("max_steps"),
            self.max_steps,
            self.max_steps >= 0,
            "max_steps >= 0 (0 = unlimited)",
        )
        _require(
            self._key("max_wall_time"),
            self.max_wall_time,
            self.max_wall_time >= 0,
            "max_wall_time >= 0 (s; 0 = unlimited)",
        )
        _choice(self._key("kernel"), self.kernel, TIME_KERNELS)


@dataclass(frozen=True)
class Initial(_Section):
    """Perturbation of the steady sliding state that seeds the instability."""

    SECTION: ClassVar[str] = "initial"

    perturbation: str = _opt("mode", "str")
    """"none", "mode" (single cos(k*theta) bump) or "random" (modes 1..n_modes)."""
    mode: int = _opt(4, "int")
    """Circumferential wavenumber k of the "mode" bump."""
    amplitude: float = _opt(0.1, "float")
    """Perturbation amplitude as a fraction of the mismatch d."""
    seed: int = _opt(0, "int")
    """Random seed for "random"."""
    n_modes: int = _opt(16, "int")
    """Highest wavenumber for "random"."""

    def _check(self) -> None:
        _choice(self._key("perturbation"), self.perturbation, PERTURBATIONS)
        check_range(self._key("mode"), self.mode)
        _require(
            self._key("amplitude"),
            self.amplitude,
            self.amplitude >= 0,
            "amplitude >= 0 (fraction of d)",
        )
        _require(self._key("seed"), self.seed, self.seed >= 0, "seed >= 0")
        _require(self._key("n_modes"), self.n_modes, self.n_modes >= 1, "n_modes >= 1")


@dataclass(frozen=True)
class Damping(_Section):
    """Kelvin-Voigt bulk viscosity sigma = C : (eps + tau eps_dot), i.e. damping matrix tau K.

    Give either ``loss_factor`` eta at ``reference_frequency_hz`` f_ref (tau = eta / (2 pi
    f_ref): the loss factor of a Kelvin-Voigt solid is eta(omega) = tau omega), or
    ``retardation_time`` tau directly. All zero (the default): no damping, and the time step
    does no damping work at all.
    """

    SECTION: ClassVar[str] = "damping"

    loss_factor: float = _opt(0.0, "float")
    """Loss factor eta [-] at ``reference_frequency_hz`` (tau = eta / (2 pi f_ref))."""
    reference_frequency_hz: float = _opt(0.0, "float")
    """Frequency [Hz] at which ``loss_factor`` is given."""
    retardation_time: float = _opt(0.0, "float")
    """Retardation time tau [s] (instead of loss_factor + reference_frequency_hz)."""

    @property
    def tau(self) -> float:
        """Retardation time tau [s]; 0 = undamped."""
        if self.retardation_time > 0.0:
            return self.retardation_time
        if self.loss_factor > 0.0:
            return self.loss_factor / (2.0 * math.pi * self.reference_frequency_hz)
        return 0.0

    @property
    def enabled(self) -> bool:
        return self.tau > 0.0

    def _check(self) -> None:
        _require(self._key("loss_factor"), self.loss_factor, 0 <= self.loss_factor <= 10,
                 "0 <= loss_factor <= 10 (eta = tau omega; 0.01-0.02 is a lightly damped "
                 "polymer or a brake pad, 0 = undamped)")
        _require(self._key("reference_frequency_hz"), self.reference_frequency_hz,
                 self.reference_frequency_hz >= 0, "reference_frequency_hz >= 0 (Hz)")
        _require(self._key("retardation_time"), self.retardation_time,
                 self.retardation_time >= 0, "retardation_time >= 0 (s; 0 = undamped)")
        if self.loss_factor > 0 and self.retardation_time > 0:
            raise SceneError(
                f"damping: give either damping.loss_factor (+ reference_frequency_hz) or "
                f"damping.retardation_time, not both (got loss_factor = {self.loss_factor}, "
                f"retardation_time = {self.retardation_time}; tau = eta / (2 pi f_ref))")
        if self.loss_factor > 0:
            _require(self._key("reference_frequency_hz"), self.reference_frequency_hz,
                     self.reference_frequency_hz > 0,
                     "reference_frequency_hz > 0 (Hz) when loss_factor > 0 (e.g. 1600, the "
                     "frequency of the Figure-3 wave)")


FIELD_FORMATS = ("vtx", "xdmf")
#: The scene names of the friction bound's typed parts (``solver.contact.law``).
REGULARIZATIONS = ("none", *(name for name in REGULARISATIONS if name))
FRICTION_FILTERS = tuple(kind.value for kind in SpatialFilter)


@dataclass(frozen=True)
class Friction(_Section):
    """Regularisation of the Coulomb friction bound (the coefficient is ``loading.f``).

    "prakash-clifton": the bound is ``f sigma_eff`` with
    ``d sigma_eff/dt = -(|V| + V*) / L (sigma_eff - p)`` (``V``: slip rate, ``L``:
    ``slip_length``, ``V*``: ``reference_velocity``); "constant-time":
    ``d sigma_eff/dt = -(sigma_eff - p) / t*`` (``t*``: ``relaxation_time``); "none": the
    classical bound ``f p``.

    ``filter``: "nodal" (default) bounds the friction force of node i by ``f p_i``, its own
    normal reaction; "1-2-1" by ``f p~_i`` with
    ``p~_i = in_contact_i (p_{i-1} + 2 p_i + p_{i+1}) / 4``, the normal reactions filtered
    along the contact circle, which removes the FE's spurious mesh-scale flutter branch
    (docs/friction_filter.md). With a regularisation, ``sigma_eff`` relaxes towards ``p~``.
    """

    SECTION: ClassVar[str] = "friction"

    regularization: str = _opt("none", "str")
    """"none", "prakash-clifton" or "constant-time"."""
    slip_length: float = _opt(0.0, "float")
    """Prakash-Clifton slip length L [m]."""
    reference_velocity: float = _opt(0.0, "float")
    """Prakash-Clifton reference velocity V* [m/s]."""
    relaxation_time: float = _opt(0.0, "float")
    """Constant-time variant: relaxation time t* [s]."""
    filter: str = _opt("nodal", "str")
    """"nodal" (bound ``f p_i``) or "1-2-1" (bound ``f (p_{i-1} + 2 p_i + p_{i+1}) / 4``)."""

    @property
    def enabled(self) -> bool:
        """A regularised (Prakash-Clifton or constant-time) bound."""
        return self.regularization != "none"

    @property
    def filtered(self) -> bool:
        """The bound uses the 1-2-1 filtered normal reactions."""
        return self.filter != "nodal"

    def _check(self) -> None:
        _choice(self._key("regularization"), self.regularization, REGULARIZATIONS)
        _choice(self._key("filter"), self.filter, FRICTION_FILTERS)
        _require(self._key("slip_length"), self.slip_length, self.slip_length >= 0,
                 "slip_length >= 0 (m)")
        _require(self._key("reference_velocity"), self.reference_velocity,
                 self.reference_velocity >= 0, "reference_velocity >= 0 (m/s)")
        _require(self._key("relaxation_time"), self.relaxation_time,
                 self.relaxation_time >= 0, "relaxation_time >= 0 (s)")
        variant = regularisation_of(self.regularization)  # a known name: checked above
        for key, (unit, why) in variant.required.items():  # the variant's own parameters
            value = getattr(self, key)
            _require(self._key(key), value, value > 0, f"{key} > 0 ({unit}) with "
                     f'regularization = "{self.regularization}"{why}')


@dataclass(frozen=True)
class Output(_Section):
    """What is recorded and how often."""

    SECTION: ClassVar[str] = "output"

    sample_interval: float = _opt(1.0e-4, "float")
    """Seconds between samples of u_r(theta), u_theta(theta) on the inner circle."""
    probes_deg: tuple[float, ...] = _opt((0.0,), "floats")
    """Probe angles [degrees] for time histories."""
    fields: bool = _opt(False, "bool")
    """Write the fields for ParaView: displacement, velocity, polar stress and von Mises,
    contact pressure, shear traction and status (solver.writers)."""
    field_interval: float = _opt(1.0e-3, "float")
    """Seconds between field outputs (the cadence)."""
    field_window: float = _opt(0.0, "float")
    """Seconds at the end of the run that are written; 0 = the last ``field_periods``
    periods of the expected wave (solver.field_output)."""
    field_periods: float = _opt(10.0, "float")
    """Periods of the expected wave (the reduced model's flutter mode ``initial.mode``)
    written at the end of the run when ``field_window`` = 0."""
    field_format: str = _opt("vtx", "str")
    """"vtx" (ADIOS2 fields.bp + stress.bp) or "xdmf" (fields.xdmf + fields.h5)."""
    progress: bool = _opt(True, "bool")
    """Print progress on long runs."""

    def _check(self) -> None:
        _require(
            self._key("sample_interval"),
            self.sample_interval,
            self.sample_interval > 0,
            "sample_interval > 0 (s)",
        )
        _require(
            self._key("field_interval"),
            self.field_interval,
            self.field_interval > 0,
            "field_interval > 0 (s)",
        )
        _require(self._key("field_window"), self.field_window, self.field_window >= 0,
                 "field_window >= 0 (s; 0 = the last field_periods periods of the wave)")
        _require(self._key("field_periods"), self.field_periods, self.field_periods > 0,
                 "field_periods > 0 (periods of the expected wave written at the end)")
        _choice(self._key("field_format"), self.field_format, FIELD_FORMATS)


_SECTIONS: dict[str, type[_Section]] = {
    "material": Material,
    "geometry": Geometry,
    "loading": Loading,
    "mesh": Mesh,
    "boundary": Boundary,
    "time": Time,
    "initial": Initial,
    "output": Output,
    "damping": Damping,
    "friction": Friction,
}
