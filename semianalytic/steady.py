"""Steady sliding solutions (paper section 2, FE closed form, and section 3, reduced model).

Non-dimensional: lengths / R, stresses / E. Traction on the inner face ``r = 1`` is
``t = -σ·e_r`` with ``t_r = p`` and ``t_θ = q`` (eq. of section 2: ``σ_rr(1) = −p``,
``σ_rθ(1) = −q``); the shear modulus is ``μ = 1/(2(1+ν))``.

Derivation of ``v_e`` (checked, see docs/semianalytic.md): ``v = v(r)`` gives
``σ_rθ = μ(v_r − v/r)`` and equilibrium ``(r²σ_rθ)_r = 0``. With ``v = αr + β/r`` and
``v(ξ) = 0``: ``v = (β/ξ²)(ξ²/r − r)``, ``σ_rθ(1) = −2μβ = −q`` so
``v = q(1+ν)/ξ² (ξ²/r − r)``. With ``q_e = f p_e`` this is exactly the printed
``v_e = δf X(r)(1 + 1/(ξ²(1−2ν)))``: the printed formula has no typo.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from stickslip.semianalytic.coefficients import Coefficients

__all__ = ["closed_form_steady", "radial_mode", "reduced_steady"]


def radial_mode(r: ArrayLike, xi: float) -> NDArray[np.float64]:
    """Radial shape ``X(r) = (ξ²/r − r)/(ξ² − 1)`` of eq. [1]; ``X(1) = 1``, ``X(ξ) = 0``."""
    r = np.asarray(r, dtype=float)
    return (xi * xi / r - r) / (xi * xi - 1.0)


def closed_form_steady(
    r: ArrayLike, *, delta: float, f: float, nu: float, xi: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], float, float]:
    """FE steady sliding solution of section 2: ``(u_e(r), v_e(r), p_e, q_e)``.

    ``u_e = δX(r)``, ``v_e = δfX(r)(1 + 1/(ξ²(1−2ν)))``,
    ``p_e = δ/(ξ²−1)·(ξ² + 1/(1−2ν))/(1+ν)``, ``q_e = f p_e``.
    """
    if not (-1.0 < nu < 0.5):
        raise ValueError(f"nu={nu!r} out of range: need -1 < nu < 0.5")
    if not xi > 1.0:
        raise ValueError(f"xi={xi!r} out of range: need xi > 1")
    X = radial_mode(r, xi)
    x2 = xi * xi
    u_e = delta * X
    v_e = delta * f * X * (1.0 + 1.0 / (x2 * (1.0 - 2.0 * nu)))
    p_e = delta / (x2 - 1.0) / (1.0 + nu) * (x2 + 1.0 / (1.0 - 2.0 * nu))
    return u_e, v_e, float(p_e), float(f * p_e)


def reduced_steady(
    coeffs: Coefficients, delta: float, f: float
) -> tuple[float, float, float, float]:
    """Steady sliding of the reduced system [2]: ``U_e = δ, V_e = δfg/h, P_e = gδ, Q_e = fP_e``."""
    P_e = coeffs.g * delta
    return delta, delta * f * coeffs.g / coeffs.h, P_e, f * P_e
