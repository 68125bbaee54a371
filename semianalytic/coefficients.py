"""Coefficients of the reduced (one-mode radial) equations [2] of the paper, section 3.

The displacement is sought as ``u = U(θ,t) X(r)``, ``v = V(θ,t) X(r)`` with
``X(r) = (ξ²/r − r)/(ξ² − 1)`` (eq. [1]). Galerkin projection of the plane-strain
elastodynamics onto this mode gives eq. [2]::

    Ü − b U'' − D V' + g U = P
    V̈ − a V'' + D U' + h V = Q

Checks done by hand (docs/semianalytic.md): ``∫₁^ξ X² r dr = B/(ξ²−1)``,
``∫₁^ξ X²/r dr = A/(ξ²−1)``, the torsional stiffness ``2μξ²/(ξ²−1)`` gives ``h`` and the
exact Lamé radial stiffness gives ``g``. Hence the reduced reactions are the physical
non-dimensional pressures rescaled: ``P = p (ξ²−1)/(γB)``, ``Q = q (ξ²−1)/(γB)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["Coefficients", "coefficients", "gamma_from_physical", "reaction_scale"]


@dataclass(frozen=True)
class Coefficients:
    """Coefficients of eq. [2] (all non-dimensional) and the inputs they came from."""

    a: float
    b: float
    g: float
    h: float
    D: float
    A: float
    B: float
    C1: float
    C2: float
    a_tilde: float
    b_tilde: float
    nu: float
    xi: float
    gamma: float


def _check_inputs(nu: float, xi: float, gamma: float) -> None:
    if not (-1.0 < nu < 0.5):
        raise ValueError(f"nu={nu!r} out of range: need -1 < nu < 0.5")
    if not xi > 1.0:
        raise ValueError(f"xi={xi!r} out of range: need xi > 1")
    if not gamma > 0.0:
        raise ValueError(f"gamma={gamma!r} out of range: need gamma > 0")


def coefficients(nu: float, xi: float, gamma: float) -> Coefficients:
    """Coefficients ``a, b, g, h, D`` (and ``A, B, C1, C2``) of eq. [2] (paper section 3).

    ``γ = ρR²Ω²/E``; ``a, b, g, h, D`` all scale as ``1/γ``.
    """
    _check_inputs(nu, xi, gamma)
    x2 = xi * xi
    lnx = math.log(xi)
    a_t = (1.0 - nu) / ((1.0 + nu) * (1.0 - 2.0 * nu))
    b_t = 1.0 / (2.0 * (1.0 + nu))
    A = -2.0 * x2 * lnx / (x2 - 1.0) + (1.0 + x2) / 2.0
    B = x2 * x2 * lnx / (x2 - 1.0) + (1.0 - 3.0 * x2) / 4.0
    C1 = 2.0 * x2 * lnx / (x2 - 1.0) - 1.0
    C2 = -2.0 * x2 * lnx / (x2 - 1.0) - 1.0 + 2.0 * x2
    gB = gamma * B
    a = a_t * A / gB
    b = b_t * A / gB
    g = (2.0 * a_t + 2.0 * (x2 - 1.0) * b_t) / gB
    h = 2.0 * x2 * b_t / gB
    D = (a * C1 - b * C2) / A
    return Coefficients(
        a=a,
        b=b,
        g=g,
        h=h,
        D=D,
        A=A,
        B=B,
        C1=C1,
        C2=C2,
        a_tilde=a_t,
        b_tilde=b_t,
        nu=nu,
        xi=xi,
        gamma=gamma,
    )


def gamma_from_physical(wave_speed: float, radius: float, omega: float) -> float:
    """``γ = ρR²Ω²/E = (RΩ/c₀)²`` with ``c₀ = √(E/ρ)`` the bar wave speed (m/s)."""
    if not wave_speed > 0.0:
        raise ValueError(f"wave_speed={wave_speed!r} out of range: need > 0")
    if not radius > 0.0:
        raise ValueError(f"radius={radius!r} out of range: need > 0")
    if not omega > 0.0:
        raise ValueError(f"omega={omega!r} out of range: need > 0")
    return (radius * omega / wave_speed) ** 2


def reaction_scale(coeffs: Coefficients) -> float:
    """Factor ``s`` with ``P = s·p`` between reduced reaction P of [2] and pressure p/E."""
    return (coeffs.xi**2 - 1.0) / (coeffs.gamma * coeffs.B)
