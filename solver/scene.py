"""Scene files: TOML descriptions of one stick-slip-separation simulation.

A scene is a TOML file mapped onto frozen, validated dataclasses (SI units)::

    name = "figure3_n132"
    [material]   E, wave_speed | rho, nu
    [geometry]   R, xi, delta | d
    [loading]    omega, f
    [mesh]       n_inner, n_radial, cell, degree
    [time]       beta1, beta2, dt, dt_fraction, end_time, max_steps, max_wall_time, kernel
    [initial]    perturbation, mode, amplitude, seed, n_modes
    [damping]    loss_factor + reference_frequency_hz | retardation_time   (default: none)
    [friction]   regularization, slip_length, reference_velocity, relaxation_time
    [output]     sample_interval, probes_deg, fields, field_interval, progress

Every table and key is optional (defaults below).  Unknown keys, wrong types and
out-of-range values raise :class:`SceneError`, whose message names the dotted key,
the offending value and the allowed range or keys.  Pure standard library: this
module must not import dolfinx.
"""

from __future__ import annotations

import difflib
import math
import os
import re
import tomllib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any, ClassVar

__all__ = [
    "SCENES_DIR",
    "Damping",
    "Friction",
    "Geometry",
    "Initial",
    "Loading",
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
    "check_range",
    "check_speed_ratio",
    "dumps_toml",
    "list_scenes",
    "load_scene",
    "parse_override",
    "scene_from_dict",
    "scene_to_dict",
    "write_scene",
]

#: Directory of the scenes shipped with the project: ``<repo>/scenes``, or ``$STICKSLIP_SCENES``
#: where the project is installed away from its source tree (the Docker image).
SCENES_DIR = Path(os.environ.get("STICKSLIP_SCENES")
                  or Path(__file__).resolve().parent.parent / "scenes")


class SceneError(ValueError):
    """Invalid scene: the message names the dotted key, the bad value and the fix."""


# ----------------------------------------------------------------------------- type coercion


def _fmt(value: Any) -> str:
    """Render a value for an error message (TOML-ish: strings quoted, bools lower-case)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(value)


def _to_float(key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise SceneError(
            f"{key} = {_fmt(value)} has the wrong type: must be a number "
            f"(got {type(value).__name__})"
        )
    x = float(value)
    if not math.isfinite(x):
        raise SceneError(f"{key} = {_fmt(value)} is out of range: must be a finite number")
    return x


def _to_int(key: str, value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise SceneError(
            f"{key} = {_fmt(value)} has the wrong type: must be an integer "
            f"(got {type(value).__name__})"
        )
    return int(value)


def _to_str(key: str, value: Any) -> str:
    if not isinstance(value, str):
        raise SceneError(
            f"{key} = {_fmt(value)} has the wrong type: must be a string "
            f"(got {type(value).__name__}; quote it in TOML)"
        )
    return value


def _to_bool(key: str, value: Any) -> bool:
    if not isinstance(value, bool):
        raise SceneError(
            f"{key} = {_fmt(value)} has the wrong type: must be a boolean true/false "
            f"(got {type(value).__name__})"
        )
    return value


def _to_floats(key: str, value: Any) -> tuple[float, ...]:
    if not isinstance(value, list | tuple):
        raise SceneError(
            f"{key} = {_fmt(value)} has the wrong type: must be a list of numbers "
            f"such as [0.0, 90.0] (got {type(value).__name__})"
        )
    return tuple(_to_float(f"{key}[{i}]", v) for i, v in enumerate(value))


_COERCE: dict[str, Callable[[str, Any], Any]] = {
    "float": _to_float,
    "int": _to_int,
    "str": _to_str,
    "bool": _to_bool,
    "floats": _to_floats,
}


def _opt(default: Any, kind: str) -> Any:
    """Dataclass field with a coercion kind (key of ``_COERCE``) in its metadata."""
    return field(default=default, metadata={"kind": kind})


def _require(key: str, value: Any, ok: bool, rule: str) -> None:
    """Raise a range error for ``key`` unless ``ok``."""
    if not ok:
        raise SceneError(f"{key} = {_fmt(value)} is out of range: must satisfy {rule}")


def _choice(key: str, value: str, allowed: Sequence[Any]) -> None:
    if value not in allowed:
        opts = ", ".join(_fmt(a) for a in allowed)
        hint = _suggest(value, [str(a) for a in allowed]) if isinstance(value, str) else ""
        raise SceneError(f"{key} = {_fmt(value)} is not allowed: must be one of {opts}{hint}")


def _suggest(word: str, candidates: Sequence[str]) -> str:
    """ "; did you mean 'x'?" for the closest candidate (case-insensitive), else ""."""
    lower = {c.lower(): c for c in candidates}
    close = difflib.get_close_matches(word.lower(), list(lower), n=1, cutoff=0.6)
    return f"; did you mean {lower[close[0]]!r}?" if close else ""


@dataclass(frozen=True)
class Range:
    """An allowed range: ``ok(value)`` and the rule as the user reads it."""

    ok: Callable[[float], bool]
    rule: str


#: The physical ranges, in one place for the scenes and the reduced-model CLI (``wave``,
#: ``flutter``): key -> range. Keys are dotted scene keys.
RANGES: dict[str, Range] = {
    "material.E": Range(lambda x: x > 0, "E > 0 (Pa)"),
    "material.wave_speed": Range(lambda x: x > 0, "wave_speed > 0 (m/s)"),
    "material.rho": Range(lambda x: x > 0, "rho > 0 (kg/m^3)"),
    "material.nu": Range(
        lambda x: 0 <= x < 0.5,
        "0 <= nu < 0.5 (incompressible nu = 0.5 is not supported by the displacement "
        "formulation)",
    ),
    "geometry.R": Range(lambda x: x > 0, "R > 0 (m)"),
    "geometry.xi": Range(lambda x: x > 1, "xi > 1 (outer/inner radius ratio)"),
    "geometry.delta": Range(
        lambda x: x > 0,
        "delta > 0 (mismatch d/R; with delta = 0 the tube is not pressed on the cylinder: "
        "no contact pressure, no friction, nothing to simulate)",
    ),
    "geometry.d": Range(lambda x: x > 0, "d > 0 (m; the cylinder must press the tube)"),
    "loading.omega": Range(lambda x: x > 0, "omega > 0 (rad/s)"),
    "loading.f": Range(lambda x: x >= 0, "f >= 0 (Coulomb friction coefficient)"),
    "initial.mode": Range(lambda x: x >= 1, "mode >= 1"),
}

#: Allowed rim-speed ratio R*omega/wave_speed: outside it the numbers of the model
#: (gamma**2 in eqs. [2]-[3], steps per turn) leave double precision or make no sense.
SPEED_RATIO = (1e-12, 1e6)


def check_range(key: str, value: Any, label: str | None = None) -> None:
    """Raise :class:`SceneError` unless ``value`` is in ``RANGES[key]``; names ``label``."""
    r = RANGES[key]
    _require(label or key, value, r.ok(value), r.rule)


def check_speed_ratio(R: float, omega: float, wave_speed: float, label: str) -> None:
    """Raise :class:`SceneError` unless R*omega/wave_speed is within :data:`SPEED_RATIO`."""
    lo, hi = SPEED_RATIO
    with_ratio = R * omega / wave_speed if wave_speed > 0 else math.inf
    if not (lo <= with_ratio <= hi):
        raise SceneError(
            f"{label}: the rim-speed ratio R*omega/wave_speed = {with_ratio:.3g} is out of "
            f"range: must satisfy {lo:g} <= R*omega/wave_speed <= {hi:g} (check "
            "loading.omega and material.wave_speed)"
        )


class _Section:
    """Mixin: coerce field types from metadata, then run the section's range checks."""

    SECTION: ClassVar[str] = ""

    def __post_init__(self) -> None:
        for f in fields(self):  # type: ignore[arg-type]
            kind = f.metadata.get("kind")
            if kind is None:
                continue
            key = f"{self.SECTION}.{f.name}" if self.SECTION else f.name
            object.__setattr__(self, f.name, _COERCE[kind](key, getattr(self, f.name)))
        self._check()

    def _key(self, name: str) -> str:
        return f"{self.SECTION}.{name}"

    def _check(self) -> None:  # pragma: no cover - overridden
        pass


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
        c2 = self.wave_speed**2
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

    @property
    def d(self) -> float:
        """Radial mismatch delta*R [m]."""
        return self.delta * self.R

    @property
    def R_outer(self) -> float:
        """Outer radius xi*R [m]."""
        return self.xi * self.R

    def _check(self) -> None:
        for name in ("R", "xi", "delta"):
            check_range(self._key(name), getattr(self, name))


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
PERTURBATIONS = ("none", "mode", "random")
KERNELS = ("auto", "numpy", "numba")


@dataclass(frozen=True)
class Mesh(_Section):
    """Annulus mesh resolution and finite-element space."""

    SECTION: ClassVar[str] = "mesh"

    n_inner: int = _opt(132, "int")
    """Number of nodes on the inner (contact) circle."""
    n_radial: int = _opt(0, "int")
    """Element layers through the thickness; 0 = automatic."""
    cell: str = _opt("triangle", "str")
    """Cell type: "triangle" or "quadrilateral"."""
    degree: int = _opt(1, "int")
    """Lagrange degree: 1 (P1/Q1) or 2 (P2/Q2)."""

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
    imports). Same results to round-off; see solver.fused.resolve_kernel."""

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
        _choice(self._key("kernel"), self.kernel, KERNELS)


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


REGULARIZATIONS = ("none", "prakash-clifton", "constant-time")
FRICTION_FILTERS = ("nodal", "1-2-1")


@dataclass(frozen=True)
class Friction(_Section):
    """Regularisation of the Coulomb friction bound (the coefficient is ``loading.f``).

    "prakash-clifton": the bound is f sigma_eff with
    d sigma_eff/dt = -(|V| + V*) / L (sigma_eff - p)  (V: slip rate, L: ``slip_length``,
    V*: ``reference_velocity``); "constant-time": d sigma_eff/dt = -(sigma_eff - p) / t*
    (t*: ``relaxation_time``); "none": the classical bound f p.

    ``filter``: "nodal" (default) bounds the friction force of node i by f p_i, its own normal
    reaction; "1-2-1" by f p~_i with p~_i = in_contact_i (p_{i-1} + 2 p_i + p_{i+1}) / 4, the
    normal reactions filtered along the contact circle, which removes the FE's spurious
    mesh-scale flutter branch (docs/friction_filter.md). With a regularisation, sigma_eff
    relaxes towards p~.
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
    """"nodal" (bound f p_i) or "1-2-1" (bound f (p_{i-1} + 2 p_i + p_{i+1}) / 4)."""

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
        if self.regularization == "prakash-clifton":
            _require(self._key("slip_length"), self.slip_length, self.slip_length > 0,
                     'slip_length > 0 (m) with regularization = "prakash-clifton"')
            _require(self._key("reference_velocity"), self.reference_velocity,
                     self.reference_velocity > 0,
                     'reference_velocity > 0 (m/s) with regularization = "prakash-clifton" '
                     "(it keeps the relaxation finite at zero slip rate)")
        if self.regularization == "constant-time":
            _require(self._key("relaxation_time"), self.relaxation_time,
                     self.relaxation_time > 0,
                     'relaxation_time > 0 (s) with regularization = "constant-time"')


@dataclass(frozen=True)
class Output(_Section):
    """What is recorded and how often."""

    SECTION: ClassVar[str] = "output"

    sample_interval: float = _opt(1.0e-4, "float")
    """Seconds between samples of u_r(theta), u_theta(theta) on the inner circle."""
    probes_deg: tuple[float, ...] = _opt((0.0,), "floats")
    """Probe angles [degrees] for time histories."""
    fields: bool = _opt(False, "bool")
    """Write XDMF/VTX displacement and contact-status fields."""
    field_interval: float = _opt(1.0e-3, "float")
    """Seconds between field outputs."""
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


_SECTIONS: dict[str, type[_Section]] = {
    "material": Material,
    "geometry": Geometry,
    "loading": Loading,
    "mesh": Mesh,
    "time": Time,
    "initial": Initial,
    "output": Output,
    "damping": Damping,
    "friction": Friction,
}
_TOP_SCALARS = ("name", "description")
#: Input-only alternatives: (section, canonical key, alternative key).
_EXCLUSIVE = (("material", "wave_speed", "rho"), ("geometry", "delta", "d"))
#: A safe file name: it starts with a letter, digit or '_' (never '.', '..', '-x' or hidden).
_NAME_RE = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.\-]{0,127}")


@dataclass(frozen=True)
class Scene(_Section):
    """A complete, validated simulation description."""

    name: str = _opt("scene", "str")
    """Short identifier (letters, digits, '_', '-', '.'); used for output names."""
    description: str = _opt("", "str")
    material: Material = field(default_factory=Material)
    geometry: Geometry = field(default_factory=Geometry)
    loading: Loading = field(default_factory=Loading)
    mesh: Mesh = field(default_factory=Mesh)
    time: Time = field(default_factory=Time)
    initial: Initial = field(default_factory=Initial)
    output: Output = field(default_factory=Output)
    damping: Damping = field(default_factory=Damping)
    friction: Friction = field(default_factory=Friction)

    def _check(self) -> None:
        if not _NAME_RE.fullmatch(self.name):
            raise SceneError(
                f"name = {_fmt(self.name)} is not allowed: it names the run directory, so it "
                "must be 1 to 128 letters, digits, '_', '-' or '.', starting with a letter, "
                "digit or '_' (not '.' or '..')"
            )
        g, lo = self.geometry, self.loading
        check_speed_ratio(g.R, lo.omega, self.material.wave_speed,
                          f"loading.omega = {_fmt(lo.omega)}, material.wave_speed = "
                          f"{_fmt(self.material.wave_speed)}, geometry.R = {_fmt(g.R)}")
        for sec, cls in _SECTIONS.items():
            if not isinstance(getattr(self, sec), cls):
                raise SceneError(f"{sec} must be a {cls.__name__} (got {getattr(self, sec)!r})")
        if self.friction.enabled and self.time.beta1 != 0.0:
            raise SceneError(
                f"friction.regularization = {self.friction.regularization!r} needs the explicit "
                f"scheme (time.beta1 = 0; got {self.time.beta1}): the law is built into its "
                "forward-increment contact projection")
        if self.friction.filtered and self.time.beta1 != 0.0:
            raise SceneError(
                f"friction.filter = {self.friction.filter!r} needs the explicit scheme "
                f"(time.beta1 = 0; got {self.time.beta1}): the filtered bound couples "
                "neighbouring nodes, which the implicit active set does not model; use "
                'time.beta1 = 0 or friction.filter = "nodal"')
        half = self.mesh.n_inner // 2
        why = f"mesh.n_inner // 2 = {half} (at least 2 contact nodes per wavelength)"
        if self.initial.perturbation == "mode":
            _require(
                "initial.mode", self.initial.mode, self.initial.mode <= half, f"1 <= mode <= {why}"
            )
        if self.initial.perturbation == "random":
            _require(
                "initial.n_modes",
                self.initial.n_modes,
                self.initial.n_modes <= half,
                f"1 <= n_modes <= {why}",
            )

    def with_overrides(self, *overrides: str) -> Scene:
        """Return a copy with ``"section.key=value"`` overrides applied (and re-validated)."""
        return scene_from_dict(apply_overrides(scene_to_dict(self), overrides))

    def replace(self, **changes: Any) -> Scene:
        """``dataclasses.replace`` shortcut (validated)."""
        return replace(self, **changes)


# ----------------------------------------------------------------------------- dict <-> Scene


def _unknown(key: str, allowed: Sequence[str], word: str | None = None) -> SceneError:
    """Error for an unknown ``key``; suggests the closest of ``allowed`` to ``word``."""
    leaf = key.rsplit(".", 1)[-1] if word is None else word
    return SceneError(
        f"unknown key {key!r} (allowed: {', '.join(allowed)}){_suggest(leaf, allowed)}"
    )


def _allowed_keys(section: str) -> list[str]:
    keys = [f.name for f in fields(_SECTIONS[section])]
    for sec, canon, alt in _EXCLUSIVE:
        if sec == section:
            keys.insert(keys.index(canon) + 1, alt)
    return keys


def scene_from_dict(data: Mapping[str, Any]) -> Scene:
    """Validate a nested dict (as parsed from TOML) and build a :class:`Scene`."""
    if not isinstance(data, Mapping):
        raise SceneError(f"a scene must be a table/dict (got {type(data).__name__})")
    top_allowed = [*_TOP_SCALARS, *_SECTIONS]
    kwargs: dict[str, Any] = {}
    for key, value in data.items():
        if key not in top_allowed:
            raise _unknown(str(key), top_allowed)
        if key in _TOP_SCALARS:
            kwargs[key] = value
            continue
        if not isinstance(value, Mapping):
            raise SceneError(
                f"{key} = {_fmt(value)} has the wrong type: must be a table "
                f"([{key}] in TOML, keys: {', '.join(_allowed_keys(key))})"
            )
        allowed = _allowed_keys(key)
        sub = dict(value)
        for k in sub:
            if k not in allowed:
                raise _unknown(f"{key}.{k}", allowed)
        kwargs[key] = _build_section(key, sub)
    return Scene(**kwargs)


def _build_section(section: str, sub: dict[str, Any]) -> _Section:
    if section == "material" and "rho" in sub:
        _exactly_one(section, sub, "wave_speed", "rho", "wave_speed = sqrt(E/rho)")
        rho = _to_float("material.rho", sub.pop("rho"))
        check_range("material.rho", rho)
        E = _to_float("material.E", sub.get("E", Material.E))
        check_range("material.E", E)
        sub["wave_speed"] = math.sqrt(E / rho)
    if section == "geometry" and "d" in sub:
        _exactly_one(section, sub, "delta", "d", "delta = d/R")
        d = _to_float("geometry.d", sub.pop("d"))
        check_range("geometry.d", d)
        R = _to_float("geometry.R", sub.get("R", Geometry.R))
        check_range("geometry.R", R)
        sub["delta"] = d / R
    return _SECTIONS[section](**sub)


def _exactly_one(section: str, sub: Mapping[str, Any], a: str, b: str, rel: str) -> None:
    if a in sub and b in sub:
        raise SceneError(
            f"{section}: give exactly one of '{section}.{a}' or '{section}.{b}' "
            f"(got both: {a} = {_fmt(sub[a])}, {b} = {_fmt(sub[b])}; {rel})"
        )


def scene_to_dict(scene: Scene) -> dict[str, Any]:
    """Resolved nested dict of ``scene`` (all defaults filled in; lists for tuples)."""
    out: dict[str, Any] = {"name": scene.name, "description": scene.description}
    for sec in _SECTIONS:
        obj = getattr(scene, sec)
        out[sec] = {
            f.name: list(v) if isinstance(v := getattr(obj, f.name), tuple) else v
            for f in fields(obj)
        }
    return out


# ----------------------------------------------------------------------------- overrides


def parse_override(text: str) -> tuple[tuple[str, ...], Any]:
    """Split ``"section.key=value"`` into a key path and a TOML-parsed value.

    The value is parsed as a TOML value (``132``, ``0.7``, ``"quadrilateral"``,
    ``[0.0, 90.0]``, ``true``); anything that is not valid TOML is taken as a bare string.
    """
    if "=" not in text:
        raise SceneError(
            f"override {text!r} must look like 'section.key=value' (e.g. mesh.n_inner=132)"
        )
    raw_key, raw_value = (s.strip() for s in text.split("=", 1))
    path = tuple(p.strip() for p in raw_key.split("."))
    if len(path) == 1 and path[0] in _TOP_SCALARS:
        pass
    elif len(path) == 2 and path[0] in _SECTIONS:
        allowed = _allowed_keys(path[0])
        if path[1] not in allowed:
            raise _unknown(raw_key, allowed)
    elif path[0] in _SECTIONS:
        raise SceneError(
            f"override key {raw_key!r} must name one key of [{path[0]}] "
            f"(allowed: {', '.join(f'{path[0]}.{k}' for k in _allowed_keys(path[0]))})"
        )
    elif path[0] in _TOP_SCALARS:
        raise SceneError(f"override key {raw_key!r}: {path[0]!r} is a string, not a table")
    else:
        raise _unknown(raw_key, [*_TOP_SCALARS, *_SECTIONS], word=path[0])
    try:
        value = tomllib.loads(f"v = {raw_value}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw_value
    return path, value


def apply_overrides(data: Mapping[str, Any], overrides: Sequence[str]) -> dict[str, Any]:
    """Return a copy of the nested ``data`` with ``"section.key=value"`` overrides applied.

    Setting one of a mutually exclusive pair (``wave_speed``/``rho``, ``delta``/``d``)
    removes the other from the copy.
    """
    if isinstance(overrides, str):
        overrides = (overrides,)
    out: dict[str, Any] = {k: dict(v) if isinstance(v, Mapping) else v for k, v in data.items()}
    for text in overrides:
        path, value = parse_override(text)
        if len(path) == 1:
            out[path[0]] = value
            continue
        sec, key = path
        table = out.setdefault(sec, {})
        if not isinstance(table, dict):
            raise SceneError(f"{sec} must be a table (got {_fmt(table)})")
        for s, a, b in _EXCLUSIVE:
            if s == sec and key in (a, b):
                table.pop(b if key == a else a, None)
        table[key] = value
    return out


# ----------------------------------------------------------------------------- files


def list_scenes() -> list[Path]:
    """The ``*.toml`` scenes shipped in :data:`SCENES_DIR`, sorted."""
    return sorted(SCENES_DIR.glob("*.toml"))


def _resolve(path: str | Path) -> Path:
    p = Path(path)
    if p.is_dir():
        raise SceneError(f"scene file {str(path)!r} is a directory: give a scene .toml file "
                         "(e.g. scenes/smoke.toml)")
    if p.exists():
        return p
    if p.parent == Path(".") and (SCENES_DIR / f"{p.stem}.toml").is_file():
        return SCENES_DIR / f"{p.stem}.toml"
    shipped = ", ".join(s.stem for s in list_scenes())
    raise SceneError(f"scene file {str(path)!r} not found (shipped scenes: {shipped})")


def load_scene(path: str | Path, overrides: Sequence[str] = ()) -> Scene:
    """Load and validate a scene file, applying ``"section.key=value"`` overrides.

    ``path`` may also be the bare name of a shipped scene (``"figure3_n36"``).
    A missing ``name`` defaults to the file stem.
    """
    p = _resolve(path)
    try:
        with p.open("rb") as fh:
            data = tomllib.load(fh)
    except UnicodeDecodeError as exc:
        raise SceneError(f"{p}: not a text TOML file (byte {exc.start} is not UTF-8); "
                         "give a scene .toml file") from exc
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{p}: invalid TOML: {exc}") from exc
    except OSError as exc:
        raise SceneError(f"{p}: cannot read the scene file ({exc.strerror}); check the "
                         "path and its permissions") from exc
    data.setdefault("name", p.stem)
    data = apply_overrides(data, overrides)
    try:
        return scene_from_dict(data)
    except SceneError as exc:
        where = f"{p} with --set {' '.join(overrides)}" if overrides else str(p)
        raise SceneError(f"{where}: {exc}") from exc


def _toml_str(s: str) -> str:
    out = ['"']
    for ch in s:
        if ch == '"':
            out.append('\\"')
        elif ch == "\\":
            out.append("\\\\")
        elif ch == "\n":
            out.append("\\n")
        elif ch == "\t":
            out.append("\\t")
        elif ch == "\r":
            out.append("\\r")
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04X}")
        else:
            out.append(ch)
    out.append('"')
    return "".join(out)


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise SceneError(f"cannot write non-finite float {v!r}")
        return repr(v)
    if isinstance(v, str):
        return _toml_str(v)
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise SceneError(f"cannot write value {v!r} of type {type(v).__name__} to TOML")


def dumps_toml(scene: Scene) -> str:
    """Serialise ``scene`` (fully resolved) as TOML text."""
    d = scene_to_dict(scene)
    lines = ["# stickslip scene (resolved: all defaults written out)"]
    lines += [f"{k} = {_toml_value(d[k])}" for k in _TOP_SCALARS]
    for sec in _SECTIONS:
        lines += ["", f"[{sec}]"]
        lines += [f"{k} = {_toml_value(v)}" for k, v in d[sec].items()]
    return "\n".join(lines) + "\n"


def write_scene(scene: Scene, path: str | Path) -> Path:
    """Atomically write ``scene`` as TOML to ``path`` (temp file + os.replace)."""
    from solver.atomic import atomic_write_text

    return atomic_write_text(path, dumps_toml(scene))
