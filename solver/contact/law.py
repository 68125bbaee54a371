"""The contact law of a scene, defined once: the data every contact step reads.

The tube's inner circle touches a rigid cylinder of radius R + d turning at Omega (paper
section 2). At a contact node, with gap g = u_r - d and the cylinder's surface travel
R Omega dt per step:

* unilateral contact: g >= 0, p >= 0, p g = 0;
* Coulomb friction: |q| <= f p, stick (the node moves with the cylinder) or slip with
  q = f p sign(R Omega - u_theta_dot).

The explicit Newmark step enforces both at t_{n+1} with the forward increment of Carpenter,
Taylor & Katona [CAR 91]: a nodal force r applied at t_n moves the node at t_{n+1} by
kappa r / m with kappa = (beta_2 + 1/2) dt^2 (``forward_increment_factor``; the derivation is in
``solver.newmark``). The multiplier is then found node by node in closed form
(``solver.contact.nodal``).

``ContactLaw`` gathers what a contact step needs: d, f, the cylinder's travel per step, kappa,
and the friction bound as two typed parts, each variant defined in one place:

* the spatial filter of the pressure in the bound (``SpatialFilter``): nodal, or 1-2-1 along
  the circle;
* the regularisation of the bound (``Regularisation``: ``Instantaneous``, ``PrakashClifton``,
  ``ConstantTime``, by name in ``REGULARISATIONS``): how sigma_eff relaxes towards the
  pressure, with its parameters and the constants the kernels read (``kernel_bound``).

The numpy projections (``solver.contact.projection``), the numba kernels
(``solver._fused_kernels``) and the CUDA source (``solver.ensemble_cuda``) all take their
constants from here. A new friction law: a ``Regularisation`` class (or a filter) here, its
nodal projection in ``solver.contact.nodal``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum
from typing import ClassVar

__all__ = [
    "SEPARATION", "STICK", "SLIP", "STATUS_NAMES", "ContactLaw", "forward_increment_factor",
    "SpatialFilter", "Regularisation", "Instantaneous", "PrakashClifton", "ConstantTime",
    "REGULARISATIONS", "regularisation_of",
]

#: Status codes of a contact node, as stored in ``samples.npz`` (``status``).
SEPARATION, STICK, SLIP = 0, 1, 2
STATUS_NAMES = ("separation", "stick", "slip")


def forward_increment_factor(beta2: float, dt: float) -> float:
    """kappa = (beta_2 + 1/2) dt^2: a nodal force r at t_n moves u_{n+1} by kappa r / m.

    The explicit Newmark velocity v_n = v~_n + beta_2 dt a_n carries beta_2 dt a_n, so the
    displacement update u_{n+1} = u_n + dt v_n + dt^2/2 a_n sees a contact force through
    (beta_2 + 1/2) dt^2 (``solver.newmark`` module docstring)."""
    return (beta2 + 0.5) * dt * dt


class SpatialFilter(Enum):
    """The pressure in the friction bound of node i (scene ``friction.filter``)."""

    NODAL = "nodal"
    """p_i, the node's own normal reaction."""
    ONE_TWO_ONE = "1-2-1"
    """p~_i = in_contact_i (p_{i-1} + 2 p_i + p_{i+1}) / 4 along the circle
    (``solver.contact.nodal.NeighbourFilter``; docs/friction_filter.md)."""

    @property
    def weights(self) -> tuple[float, float, float] | None:
        """(w_{i-1}, w_i, w_{i+1}) of the neighbours' pressures in p~_i; None: p_i alone."""
        return None if self is SpatialFilter.NODAL else (0.25, 0.5, 0.25)


@dataclass(frozen=True)
class Regularisation:
    """How the bound's pressure sigma_eff relaxes towards p, as the kernels integrate it:

        sigma_eff <- p + (sigma_eff - p) exp(-rate dt),  rate = |V dt| rate_slip + rate_base

    with V dt = u_theta,n - u_theta,{n-1} - R Omega dt the step's slip
    (``solver.contact.nodal.EffectivePressure``). ``Instantaneous``: no relaxation, the
    bound is f p at once."""

    name: ClassVar[str] = ""
    """The scene's ``friction.regularization`` ("" for none)."""
    code: ClassVar[int] = 0
    """The kernels' code of the bound (0: f p)."""
    compiled: ClassVar[bool] = False
    """The fused and batched kernels implement it (``ContactLaw.kernel_bound``)."""
    required: ClassVar[dict[str, tuple[str, str]]] = {}
    """The parameters it needs > 0 (scene keys of ``[friction]``): (unit, why)."""

    def rates(self, dt: float) -> tuple[float, float]:
        """(rate_slip, rate_base) at step ``dt`` (see the class docstring)."""
        return 0.0, 0.0

    def linearised_time(self, slip_speed: float) -> float:
        """t*: the relaxation time linearised about steady sliding at ``slip_speed`` |V|
        [m/s] (the perturbation of |V| multiplies sigma_eff - p = 0 there); 0: none."""
        return 0.0


@dataclass(frozen=True)
class Instantaneous(Regularisation):
    """The classical bound f p (``friction.regularization = "none"``)."""

    compiled: ClassVar[bool] = True


@dataclass(frozen=True)
class PrakashClifton(Regularisation):
    """d sigma_eff / dt = -(|V| + V*) / L (sigma_eff - p) (Prakash & Clifton 1993)."""

    slip_length: float = 0.0
    """L [m]."""
    reference_velocity: float = 0.0
    """V* [m/s]."""
    name: ClassVar[str] = "prakash-clifton"
    code: ClassVar[int] = 1
    compiled: ClassVar[bool] = True
    required: ClassVar[dict[str, tuple[str, str]]] = {
        "slip_length": ("m", ""),
        "reference_velocity": ("m/s", " (it keeps the relaxation finite at zero slip rate)")}

    def rates(self, dt: float) -> tuple[float, float]:
        """(1 / (dt L), V* / L)."""
        return 1.0 / (dt * self.slip_length), self.reference_velocity / self.slip_length

    def linearised_time(self, slip_speed: float) -> float:
        """t* = L / (|V| + V*)."""
        return self.slip_length / (slip_speed + self.reference_velocity)


@dataclass(frozen=True)
class ConstantTime(Regularisation):
    """d sigma_eff / dt = -(sigma_eff - p) / t*."""

    relaxation_time: float = 0.0
    """t* [s]."""
    name: ClassVar[str] = "constant-time"
    code: ClassVar[int] = 2
    compiled: ClassVar[bool] = True
    required: ClassVar[dict[str, tuple[str, str]]] = {"relaxation_time": ("s", "")}

    def rates(self, dt: float) -> tuple[float, float]:
        """(0, 1 / t*)."""
        return 0.0, 1.0 / self.relaxation_time

    def linearised_time(self, slip_speed: float) -> float:
        """t*, whatever |V|."""
        return self.relaxation_time


#: The regularisations by their scene name (``friction.regularization``; "none" is "").
REGULARISATIONS: dict[str, type[Regularisation]] = {
    cls.name: cls for cls in (Instantaneous, PrakashClifton, ConstantTime)}


def regularisation_of(name: str, slip_length: float = 0.0, reference_velocity: float = 0.0,
                      relaxation_time: float = 0.0) -> Regularisation:
    """The regularisation named ``name`` ("none" or "" for ``Instantaneous``) with the
    parameters it takes (the others are ignored)."""
    key = "" if name == "none" else name
    if key not in REGULARISATIONS:
        raise ValueError(f"friction.regularization = {name!r}: use one of "
                         f"{('none', *list(REGULARISATIONS)[1:])}")
    given = {"slip_length": slip_length, "reference_velocity": reference_velocity,
             "relaxation_time": relaxation_time}
    cls = REGULARISATIONS[key]
    return cls(**{k: v for k, v in given.items() if k in cls.__dataclass_fields__})


@dataclass(frozen=True)
class ContactLaw:
    """The contact and friction data of one scene at one time step.

    Attributes:
        d: Radial mismatch: the cylinder's radius exceeds the tube's inner radius by d [m].
        f: Coulomb friction coefficient [-] (0: frictionless, every contact node slips).
        surface_speed: R Omega, the cylinder's surface speed [m/s].
        dt: The explicit step.
        beta2: Its Newmark beta_2.
        filter: The pressure in the bound (``SpatialFilter``).
        regularisation: How the bound follows it (``Regularisation``).
    """

    d: float
    f: float
    surface_speed: float
    dt: float
    beta2: float
    filter: SpatialFilter = SpatialFilter.NODAL
    regularisation: Regularisation = field(default_factory=Instantaneous)

    @classmethod
    def from_scene(cls, scene, dt: float, beta2: float | None = None) -> ContactLaw:
        """The law of ``scene`` (``[geometry]`` d and R, ``[loading]`` f and Omega,
        ``[friction]``) at time step ``dt`` (beta_2 from ``[time]`` unless given)."""
        g, fr = scene.geometry, scene.friction
        b2 = scene.time.beta2 if beta2 is None else beta2
        return cls(d=g.d, f=scene.loading.f, surface_speed=g.R * scene.loading.omega, dt=dt,
                   beta2=b2, filter=SpatialFilter(fr.filter),
                   regularisation=regularisation_of(
                       fr.regularization, slip_length=fr.slip_length,
                       reference_velocity=fr.reference_velocity,
                       relaxation_time=fr.relaxation_time))

    @property
    def variant(self) -> str:
        """The bound's name: "nodal", "1-2-1", "prakash-clifton", "constant-time" or
        "1-2-1+<regularisation>" (messages, the kernels' list of bounds)."""
        reg = self.regularisation.name
        if self.filter is SpatialFilter.NODAL:
            return reg or SpatialFilter.NODAL.value
        return self.filter.value + (f"+{reg}" if reg else "")

    @property
    def kappa(self) -> float:
        """(beta_2 + 1/2) dt^2, see ``forward_increment_factor``."""
        return forward_increment_factor(self.beta2, self.dt)

    @property
    def slide(self) -> float:
        """R Omega dt, the distance the cylinder's surface travels in one step [m]."""
        return self.surface_speed * self.dt

    def kernel_bound(self) -> tuple[int, float, float]:
        """(code, rate_slip, rate_base) of the bound for the compiled kernels
        (``Regularisation``); ValueError for a bound they do not have (a filtered one, a
        regularisation not ``compiled``)."""
        reg = self.regularisation
        if self.filter is not SpatialFilter.NODAL:
            raise ValueError(f"friction variant {self.variant!r}: the 1-2-1 filtered bound "
                             "runs with the numpy step (time.kernel = \"numpy\")")
        if not reg.compiled:
            raise ValueError(f"friction variant {self.variant!r} runs with the numpy step "
                             "(time.kernel = \"numpy\")")
        return (reg.code, *reg.rates(self.dt))
