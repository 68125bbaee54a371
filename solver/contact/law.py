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
the friction variant (nodal Coulomb, the 1-2-1 filtered bound, the Prakash-Clifton
regularisation) with its parameters, and the status codes. The numpy projections
(``solver.contact.projection``), the numba kernels (``solver._fused_kernels``) and the CUDA
source (``solver.ensemble_cuda``) all take their constants from here.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "SEPARATION", "STICK", "SLIP", "STATUS_NAMES", "ContactLaw", "forward_increment_factor",
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


@dataclass(frozen=True)
class ContactLaw:
    """The contact and friction data of one scene at one time step.

    Attributes
    ----------
    d
        Radial mismatch: the cylinder's radius exceeds the tube's inner radius by d [m].
    f
        Coulomb friction coefficient [-] (0: frictionless, every contact node slips).
    surface_speed
        R Omega, the cylinder's surface speed [m/s].
    dt, beta2
        The explicit step and its Newmark beta_2.
    variant
        "nodal" (Coulomb bound f p per node), "1-2-1" (bound f p~ with p~ the 1-2-1 filtered
        pressure along the circle), "prakash-clifton" or "constant-time" (bound f sigma_eff, a
        relaxed pressure; ``solver.contact.nodal.EffectivePressure``), or "1-2-1+..." for the
        filter composed with a regularisation.
    slip_length, reference_velocity, relaxation_time
        Parameters of the regularisation (``[friction]`` scene table); unused by "nodal".
    """

    d: float
    f: float
    surface_speed: float
    dt: float
    beta2: float
    variant: str = "nodal"
    slip_length: float = 0.0
    reference_velocity: float = 0.0
    relaxation_time: float = 0.0

    @classmethod
    def from_scene(cls, scene, dt: float, beta2: float | None = None) -> ContactLaw:
        """The law of ``scene`` (``[geometry]`` d and R, ``[loading]`` f and Omega,
        ``[friction]``) at time step ``dt`` (beta_2 from ``[time]`` unless given)."""
        g, fr = scene.geometry, scene.friction
        b2 = scene.time.beta2 if beta2 is None else beta2
        return cls(d=g.d, f=scene.loading.f, surface_speed=g.R * scene.loading.omega, dt=dt,
                   beta2=b2, variant=cls.variant_of(scene), slip_length=fr.slip_length,
                   reference_velocity=fr.reference_velocity,
                   relaxation_time=fr.relaxation_time)

    @staticmethod
    def variant_of(scene) -> str:
        """The friction variant of ``scene``'s ``[friction]`` table (see ``variant``)."""
        fr = scene.friction
        regularisation = fr.regularization if fr.enabled else ""
        if fr.filtered:
            return "1-2-1" + (f"+{regularisation}" if regularisation else "")
        return regularisation or "nodal"

    @property
    def kappa(self) -> float:
        """(beta_2 + 1/2) dt^2, see ``forward_increment_factor``."""
        return forward_increment_factor(self.beta2, self.dt)

    @property
    def slide(self) -> float:
        """R Omega dt, the distance the cylinder's surface travels in one step [m]."""
        return self.surface_speed * self.dt

    @property
    def filtered(self) -> bool:
        """The friction bound uses the 1-2-1 filtered pressure."""
        return self.variant.startswith("1-2-1")

    @property
    def regularisation(self) -> str:
        """"prakash-clifton", "constant-time" or "" (the bound follows p at once)."""
        rest = self.variant.removeprefix("1-2-1").removeprefix("+")
        return "" if rest in ("", "nodal") else rest

    @property
    def nodal_coulomb(self) -> bool:
        """The plain law that the fused and batched kernels implement."""
        return self.variant == "nodal"
