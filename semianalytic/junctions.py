"""Generic junction-condition residuals for the stick-slip-separation wave (evidence tool).

Used to compare closures of eqs. [5]-[7] (docs/semianalytic.md, "Figure 1 case"). The 7
integration constants ``x = (y0[4], V1, z2[2])`` enter linearly; for given ``(c, ψ1, ψ2)``
they are eliminated by least squares and the normalised residual norm measures how far the
point is from satisfying the chosen conditions. Time-ordered coordinate ``s`` as in
:mod:`semianalytic.waves` (separation [0, ψ1T] → stick → slip [ψ2T, T]).

Condition names: ``liftoff:U, liftoff:V, liftoff:dU, liftoff:dV, liftoff:P0`` (at s = T ≡ 0),
``landing:U, landing:V, landing:dU, landing:dV`` (s = ψ1T), ``stickslip:V, stickslip:dV,
stickslip:Qbound`` (s = ψ2T).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from stickslip.semianalytic.coefficients import Coefficients
from stickslip.semianalytic.waves import _scaled_coeffs, separation_matrix, slip_matrix

__all__ = ["CLOSURES", "junction_residual"]

#: continuity of U, V, U', V' at lift-off and landing, and of V at stick -> slip (9)
_CONTINUITY: tuple[str, ...] = (
    "liftoff:U",
    "liftoff:V",
    "liftoff:dU",
    "liftoff:dV",
    "landing:U",
    "landing:V",
    "landing:dU",
    "landing:dV",
    "stickslip:V",
)

#: closures compared in docs/semianalytic.md (number of equations in brackets)
CLOSURES: dict[str, tuple[str, ...]] = {
    # full continuity of U, V, U', V' (10): the paper's "3 nonlinear unknowns" count
    "smooth": (*_CONTINUITY, "stickslip:dV"),
    # impact at landing, P -> 0 at lift-off, Q = fP at stick -> slip (10): physical
    "impact": (
        "liftoff:U",
        "liftoff:V",
        "liftoff:dU",
        "liftoff:dV",
        "liftoff:P0",
        "landing:U",
        "landing:V",
        "stickslip:V",
        "stickslip:dV",
        "stickslip:Qbound",
    ),
    # paper read literally: U', V' continuous at ψ1T and T only (9; underdetermined)
    "paper-literal": _CONTINUITY,
    # paper literal + friction bound at stick -> slip (10)
    "paper-literal+Qbound": (*_CONTINUITY, "stickslip:Qbound"),
}


def _raw(
    x: NDArray[np.float64],
    co0: Coefficients,
    f: float,
    k: int,
    dt: float,
    ct: float,
    p1: float,
    p2: float,
    sigma: float,
    conds: tuple[str, ...],
) -> NDArray[np.float64]:
    from scipy.linalg import expm  # scipy on first use: the CLI starts without it

    T = 2.0 * math.pi / k
    Ds = sigma * co0.D
    c2 = ct * ct
    y0, V1, z2 = x[:4], x[4], x[5:7]
    zp = np.array([f * co0.g * dt / co0.h, 0.0])
    zT = expm(slip_matrix(co0, c2, Ds, f) * ((1.0 - p2) * T)) @ (z2 - zp) + zp
    y1 = expm(separation_matrix(co0, c2, Ds) * (p1 * T)) @ y0
    Lst = (p2 - p1) * T / ct
    su = dt + 1.0 / ct
    sp = co0.g * dt + abs(Ds) / ct
    vals = {
        "liftoff:U": (y0[0] - dt) / su,
        "liftoff:dU": y0[1] / su,
        "liftoff:V": (y0[2] - zT[0]) / su,
        "liftoff:dV": (y0[3] - zT[1]) / su,
        "liftoff:P0": (co0.g * dt - Ds * zT[1]) / sp,
        "landing:U": (y1[0] - dt) / su,
        "landing:dU": y1[1] / su,
        "landing:V": (y1[2] - V1) / su,
        "landing:dV": (y1[3] - 1.0 / ct) / su,
        "stickslip:V": (z2[0] - V1 - Lst) / su,
        "stickslip:dV": (z2[1] - 1.0 / ct) / su,
        "stickslip:Qbound": (co0.h * (V1 + Lst) - f * (co0.g * dt - Ds / ct)) / (f * sp),
    }
    return np.array([vals[c] for c in conds])


def junction_residual(
    coeffs: Coefficients,
    f: float,
    k: int,
    delta: float,
    c: float,
    psi1: float,
    psi2: float,
    conditions: tuple[str, ...] | str = "smooth",
) -> tuple[float, NDArray[np.float64]]:
    """Least-squares residual norm of the chosen junction conditions at ``(c, ψ1, ψ2)``.

    ``c`` is the signed non-dimensional celerity. Returns ``(norm, constants)`` (scaled
    variables, γ = 1). A root of the closure has norm 0.
    """
    conds = CLOSURES[conditions] if isinstance(conditions, str) else conditions
    co0 = _scaled_coeffs(coeffs)
    sg = math.sqrt(coeffs.gamma)
    dt, ct = delta / sg, abs(c) * sg
    sigma = -1.0 if c > 0 else 1.0
    args = (co0, f, k, dt, ct, psi1, psi2, sigma, conds)
    b = _raw(np.zeros(7), *args)
    A = np.column_stack([_raw(e, *args) - b for e in np.eye(7)])
    x, *_ = np.linalg.lstsq(A, -b, rcond=None)
    return float(np.linalg.norm(A @ x + b)), x

