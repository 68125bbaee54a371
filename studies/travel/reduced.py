"""The travelling-wave solver on the reduced equations [2] (first rung of the verification ladder).

Non-dimensional (lengths / R, time Ωt: the cylinder surface speed is 1). With U(θ, t) =
U(φ), φ = θ − ct, the accelerations are Ü = c²U'', V̈ = c²V'', so eq. [2] in the wave frame is

    −(c² − b)U'' − DV' + gU = P,     −(c² − a)V'' + DU' + hV = Q.

On N periodic nodes with the P1/lumped discretisation of ``studies.reduced_transient``
(M = Δθ I, K = Δθ[[−bL + gI, −DG], [DG, −aL + hI]]) the wave-frame operator is

    S(c) = K − c² Γ,   Γ = −Δθ blockdiag(L, L),   dS/dc = −2cΓ,

and the nodal forces are S(c)W = Δθ(P, Q). Γ is K built with a = b = 1, g = h = D = 0, so
both come from the same ``stiffness_matrix``. The contact law and the Newton solver are
``studies.travel.newton`` (shared with the FE problem): d = δ, RΩ = 1, ω = c.
The closed-form waves of ``semianalytic.waves`` are the reference (tests/test_travel_reduced.py).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from stickslip.semianalytic.coefficients import Coefficients
from stickslip.semianalytic.waves import TravellingWave
from stickslip.studies.reduced_transient import stiffness_matrix, wave_fields
from stickslip.studies.travel.newton import CircleProblem, TravelSolution, solve_wave

__all__ = ["reduced_problem", "wave_start", "solve_reduced"]

Array = NDArray[np.float64]


def reduced_problem(co: Coefficients, f: float, delta: float, n: int,
                    rate: str = "bdf2") -> CircleProblem:
    """The reduced model [2] on ``n`` nodes as a ``CircleProblem`` (module doc; ``rate``: the
    material-derivative scheme, ``newton.RATES``)."""
    K = stiffness_matrix(co, n).toarray()
    unit = replace(co, a=1.0, b=1.0, g=0.0, h=0.0, D=0.0)
    G = stiffness_matrix(unit, n).toarray()  # Γ = −Δθ blockdiag(L, L)

    def stiffness(c: float, derivative: bool = True) -> tuple[Array, Array | None]:
        return K - (c * c) * G, ((-2.0 * c) * G if derivative else None)

    return CircleProblem(n=n, d=delta, surface_speed=1.0, f=f, stiffness=stiffness, rate=rate)


def wave_start(w: TravellingWave, n: int) -> tuple[Array, float]:
    """(W, c) of a closed-form wave sampled at the nodes θ_j = 2πj/N (t = 0, φ = θ)."""
    theta = np.arange(n) * (2.0 * math.pi / n)
    ev = wave_fields(w, theta)
    return np.concatenate([ev["U"], ev["V"]]), float(w.c)


def solve_reduced(
    co: Coefficients, f: float, delta: float, n: int, W0: Array, c0: float, k: int,
    rate: str = "bdf2", **kw,
) -> TravelSolution:
    """Solve the discrete reduced travelling-wave problem from (W0, c0)."""
    return solve_wave(reduced_problem(co, f, delta, n, rate), W0, c0, k, **kw)

