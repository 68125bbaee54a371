"""Pseudo-arclength continuation of a travelling wave in a loading or mismatch key.

Natural-parameter continuation (``continuation``) solves F(W, ω; λ) = 0 at each requested λ
from the last wave; at a fold (dλ/ds = 0) the branch turns back and no wave exists beyond
it, so that Newton fails. Here λ is an unknown too, x = (W, ω, λ), and the extra equation

    tᵀ D (x − x̂) = 0,     x̂ = x₀ + Δs t,

(t the unit tangent of the branch in the scaled variables D x = (W/d, ω/ω₀, λ/λ₀), x₀ the
last wave, Δs the step) fixes the position along the branch instead of λ: the augmented
Jacobian [[F_W, F_ω, F_λ], [tᵀD]] stays regular through a fold, so the branch is followed
around it. F is the wave-frame residual of ``newton`` (the contact law and the phase
condition), F_W and F_ω its generalised Jacobian (``newton._jacobian``); λ enters only the
contact law (RΩ, f or d), and F_λ is a difference quotient. The tangent is the secant of the
last two waves. A fold is where λ changes its sense along the branch.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from stickslip.studies.travel.newton import (
    INEQUALITY_NAMES,
    CircleProblem,
    NotConverged,
    TravelSolution,
    _jacobian,
    _Law,
    fourier_k,
    inequality_margins,
    nodal_stiffness,
)

__all__ = ["ARCLENGTH_KEYS", "problem_at", "arclength_step", "phase_row_of"]

#: keys that enter only the contact law: (CircleProblem field, factor from the scene value)
ARCLENGTH_KEYS = ("loading.omega", "loading.f", "geometry.delta")


def problem_at(prob: CircleProblem, key: str, value: float, radius: float) -> CircleProblem:
    """``prob`` with the scene key ``key`` set to ``value`` (RΩ, f or d = δR)."""
    if key == "loading.omega":
        return replace(prob, surface_speed=radius * value)
    if key == "loading.f":
        return replace(prob, f=value)
    if key == "geometry.delta":
        return replace(prob, d=radius * value)
    raise ValueError(f"{key}: pseudo-arclength follows only {', '.join(ARCLENGTH_KEYS)}")


def arclength_step(
    prob_of: Callable[[float], CircleProblem], k: int, x0: np.ndarray, tangent: np.ndarray,
    ds: float, scale: np.ndarray, phase_row: np.ndarray, *, tol: float = 1e-10,
    max_iter: int = 30,
) -> tuple[np.ndarray, TravelSolution]:
    """One predictor–corrector step (module doc) from x0 = (W, ω, λ) along ``tangent`` (unit,
    in the scaled variables x/scale) by ``ds``. Returns the new x and its wave; raises
    ``NotConverged`` (with the violated inequality, if any) when the corrector fails or the
    wave is not admissible."""
    base = prob_of(float(x0[-1]))
    n = base.n
    c = nodal_stiffness(base)
    fscale = c * base.d
    target = x0 / scale + ds * tangent

    def augmented(x: np.ndarray) -> tuple[np.ndarray, CircleProblem, _Law, np.ndarray]:
        prob = prob_of(float(x[-1]))
        law = _Law(prob, c)
        S, _ = prob.stiffness(float(x[n * 2]), False)
        C, proj = law(x[: 2 * n], S @ x[: 2 * n], float(x[2 * n]))
        G = np.concatenate([C, [fscale * float(phase_row @ x[n: 2 * n]) / base.d,
                                fscale * float(tangent @ (x / scale - target))]])
        return G, prob, law, proj

    x = x0 + ds * tangent * scale
    G, prob, law, proj = augmented(x)
    for _ in range(max_iter):
        if np.max(np.abs(G)) <= tol * fscale:
            break
        W, om, lam = x[: 2 * n], float(x[2 * n]), float(x[-1])
        S, dS = prob.stiffness(om, True)
        J = np.zeros((2 * n + 2, 2 * n + 2))
        J[: 2 * n + 1, : 2 * n + 1] = _jacobian(prob, law, W, om, S, dS, phase_row, fscale)
        h = 1e-7 * max(abs(lam), 1e-12)
        x_h = x.copy()
        x_h[-1] += h
        J[: 2 * n, -1] = (augmented(x_h)[0][: 2 * n] - G[: 2 * n]) / h
        J[-1] = fscale * tangent / scale
        dx = np.linalg.lstsq(J, -G, rcond=None)[0]
        merit, step = float(G @ G), 1.0
        for _ in range(10):  # backtracking on ‖G‖²
            G_t, prob_t, law_t, proj_t = augmented(x + step * dx)
            if np.isfinite(G_t).all() and float(G_t @ G_t) < (1.0 - 1e-4 * step) * merit:
                break
            step *= 0.5
        x, G, prob, law, proj = x + step * dx, G_t, prob_t, law_t, proj_t
    res = float(np.max(np.abs(G))) / fscale
    sol = TravelSolution(omega=float(x[2 * n]), W_r=x[:n].copy(), W_t=x[n: 2 * n].copy(),
                         p=proj[:n].copy(), q=proj[n:].copy(), status=law.out.status.copy(),
                         iterations=max_iter, residual=res)
    sol.margins = inequality_margins(prob, sol, fscale)
    bad = [key for key, m in sol.margins.items() if m < -1e-8]
    sol.violated = INEQUALITY_NAMES[bad[0]] if bad else None
    info = {"residual": res, "violated": sol.violated}
    if not res <= tol or not math.isfinite(res):
        raise NotConverged(f"arclength corrector: residual {res:.2e}; violated inequality: "
                           f"{sol.violated or 'none'}", info)
    if sol.violated:
        raise NotConverged(f"the branch leaves the admissible set: {sol.violated}", info)
    if abs(fourier_k(sol.W_t, base.theta, k)) < 1e-3 * abs(fourier_k(x0[n: 2 * n], base.theta, k)):
        raise NotConverged("the branch collapsed to steady sliding", info)
    return x, sol


def phase_row_of(W_t: np.ndarray, theta: np.ndarray, k: int) -> np.ndarray:
    """The phase condition's row (``newton.solve_wave``) that holds W_θ's mode k at its phase."""
    a0 = fourier_k(W_t, theta, k)
    return np.exp(-1j * (np.angle(a0) + k * theta)).imag / abs(a0)
