"""Flutter of the steady sliding state of the reduced system (paper section 3).

In the sliding regime (``U = δ``, ``Q = fP``, ``1 − V̇ > 0``) eq. [2] reduces to::

    V̈ − a V'' + f D V' + h V = f g δ,      P = g δ − D V'.

A perturbation ``v = exp(i(kθ − ωt))`` of ``V_e`` satisfies the dispersion relation
``ω² = a k² + h + i f D k``. With ``ω = ω_r + i ω_i``: ``2 ω_r ω_i = f D k``, so the
growing root (``ω_i > 0``) has ``sign(ω_r) = sign(D)`` (for ``f, k > 0``): it travels in
the sense of rotation (phase speed ``ω_r/k > 0``) when ``D > 0`` and against it when
``D < 0``; the other root decays and travels the other way.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from stickslip.semianalytic.coefficients import Coefficients

__all__ = ["FlutterMode", "flutter_modes", "mode_physical", "dispersion_roots"]


@dataclass(frozen=True)
class FlutterMode:
    """One unstable mode ``exp(i(kθ − ωt))`` (non-dimensional: time unit ``1/Ω``)."""

    k: int
    growth_rate: float  # ω_i, > 0 for the exploding mode
    omega_r: float  # real angular frequency (signed, same sign as the phase speed)
    phase_speed: float  # ω_r/k, > 0 = sense of rotation
    direction: str  # 'rotation' | 'opposite' | 'none'
    frequency: float  # |ω_r| (angular, non-dimensional)
    damped_phase_speed: float  # phase speed of the companion decaying root

    def to_dict(self) -> dict[str, float | int | str]:
        """Plain dict (JSON friendly)."""
        return asdict(self)


def dispersion_roots(coeffs: Coefficients, f: float, k: int) -> tuple[complex, complex]:
    """The two roots ω of ``ω² = a k² + h + i f D k``; the first has the larger imaginary part."""
    w = complex(np.sqrt(complex(coeffs.a * k * k + coeffs.h, f * coeffs.D * k)))
    r1, r2 = w, -w
    return (r1, r2) if r1.imag >= r2.imag else (r2, r1)


def flutter_modes(
    coeffs: Coefficients, f: float, kmax: int = 8, kmin: int = 1
) -> list[FlutterMode]:
    """Growth rate, phase speed and direction of the flutter modes ``k = kmin..kmax``."""
    if kmax < kmin or kmin < 1:
        raise ValueError(f"kmax={kmax!r} out of range: need kmax >= {max(kmin, 1)}")
    modes = []
    for k in range(kmin, kmax + 1):
        grow, decay = dispersion_roots(coeffs, f, k)
        if grow.imag > 1e-14 * abs(grow):
            direction = "rotation" if grow.real > 0 else "opposite"
        else:
            direction = "none"
        modes.append(
            FlutterMode(
                k=k,
                growth_rate=grow.imag,
                omega_r=grow.real,
                phase_speed=grow.real / k,
                direction=direction,
                frequency=abs(grow.real),
                damped_phase_speed=decay.real / k,
            )
        )
    return modes


def mode_physical(mode: FlutterMode, radius: float, omega: float) -> dict[str, float | int | str]:
    """Physical units: growth rate 1/s, signed phase speed m/s, frequency in Hz (= |ω_r|Ω/2π)."""
    return {
        "k": mode.k,
        "growth_rate_per_s": mode.growth_rate * omega,
        "phase_speed_m_s": mode.phase_speed * radius * omega,
        "frequency_hz": mode.frequency * omega / (2.0 * math.pi),
        "angular_frequency_rad_s": mode.frequency * omega,
        "direction": mode.direction,
    }
