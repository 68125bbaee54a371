"""Inertia of a wave that is stationary in a frame turning at ω (``stickslip travel``).

A wave turning rigidly at angular speed ω is u(x, t) = Q(ωt) w(Q(ωt)ᵀx), Q(α) = exp(αJ),
J = [[0, −1], [1, 0]] the quarter turn. With y = Qᵀx, dy/dα = −Jy and ∇w·(−Jy) = −∂_θ w
(∂_θ = x ∂_y − y ∂_x), so

    ∂u/∂α = Q (J − ∂_θ) w,    ü = ω² Q (∂_θ − J)² w.

On the annulus (rotation invariant) ∂_θ is skew-adjoint in L² (its field (−y, x) is
divergence free and tangent to both circles) and J is a skew matrix, so L = ∂_θ − J is
skew-adjoint and ∫ρ ü·v (pulled back to the wave frame) = −ω² ∫ρ Lw·Lv. The wave-frame
equation K w − ω² G w = r (r: contact forces) therefore has the symmetric, positive
semi-definite "travelling inertia" G below. An axisymmetric field has Lw = 0 (∂_θ e_r = e_θ =
J e_r), so steady sliding feels no inertia, as it must.
"""

from __future__ import annotations

import ufl

__all__ = ["frame_derivative", "travelling_inertia", "travelling_transport"]


def frame_derivative(w: ufl.core.expr.Expr, x: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """``(∂_θ − J) w`` with ``∂_θ w = ∇w · (−x₂, x₁)`` and ``J w = (−w₂, w₁)``."""
    t = ufl.as_vector((-x[1], x[0]))
    return ufl.dot(ufl.grad(w), t) - ufl.as_vector((-w[1], w[0]))


def travelling_inertia(u: ufl.Argument, v: ufl.Argument, rho: float,
                       lumped: bool = False) -> ufl.Form:
    """``G(u, v) = ∫ ρ (∂_θ − J)u · (∂_θ − J)v dx``; wave-frame operator ``K − ω² G``.

    ``lumped``: the integral by the vertex rule (∫g ≈ |cell| mean of g at the vertices), the
    rule that makes the P1 mass the transient's lumped mass (``forms.elasticity.lumped_mass``):
    the wave-frame counterpart of mass lumping, exact for (∂_θ − J)x = 0 (rigid rotation)."""
    x = ufl.SpatialCoordinate(u.ufl_function_space().mesh)
    dx = (ufl.dx(metadata={"quadrature_rule": "vertex", "quadrature_degree": 1}) if lumped
          else ufl.dx)
    return rho * ufl.inner(frame_derivative(u, x), frame_derivative(v, x)) * dx


def travelling_transport(u: ufl.Argument, v: ufl.Argument, rho: float) -> ufl.Form:
    """``B(w, v) = ∫ ρ (∂_θ − J)w · v dx``: the frame velocity −ω(∂_θ − J)w tested in L².

    With the lumped mass M, ``M⁻¹B w`` is the P1 field of (∂_θ − J)w (its lumped L²
    projection), so the wave-frame Kelvin–Voigt damping is ``D = τ K M⁻¹ B`` (the transient's
    C = τK applied to the frame velocity; ``studies.travel.frame.frame_operators``). Only first
    derivatives of w appear. The direct form τ∫σ((∂_θ − J)w):ε(v) would differentiate ∇w once
    more inside each cell, which P1 cannot: it loses the leading term τ∂_θ ε(w) and gives
    ~−0.03 of the damping on a travelling harmonic (archive/travel/travelling_waves_history.md
    2d)."""
    x = ufl.SpatialCoordinate(u.ufl_function_space().mesh)
    return rho * ufl.inner(frame_derivative(u, x), v) * ufl.dx
