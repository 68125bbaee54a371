"""The stress in the cylinder's polar frame and von Mises, as cell averages (element stress).

With ``e_r = x/|x|`` and ``e_θ = (−y, x)/|x|`` (``forms.polar``), the in-plane stress of
``forms.elasticity.stress`` has the polar components

    σ_rr = e_r·σ·e_r,   σ_θθ = e_θ·σ·e_θ,   σ_rθ = e_r·σ·e_θ.

Plane strain (ε_zz = 0) carries the out-of-plane stress σ_zz = ν (σ_rr + σ_θθ), which von Mises
includes:

    σ_vm = sqrt(½ [(σ_rr − σ_θθ)² + (σ_θθ − σ_zz)² + (σ_zz − σ_rr)²] + 3 σ_rθ²).

The four are projected on piecewise constants (DG0): the L² projection on DG0 is the cell
average ``s_K = ∫_K s dx / |K|``, so the forms below are the right-hand side ``∫ s·q dx`` and
the cell areas ``∫ q dx`` (q: DG0 test functions) and no system is solved. For P1 triangles
σ is constant per cell, and the cell average is the exact FE stress; for P2 or quadrilaterals
it is the mean over the cell.

In 3D (the finite tube, ``meshes.tube3d``) the cylindrical frame ``e_r = (x, y, 0)/ρ``,
``e_θ = (−y, x, 0)/ρ``, ``e_z = (0, 0, 1)`` (ρ = sqrt(x² + y²)) gives the six components
``σ_ab = e_a·σ·e_b`` of the whole tensor, and

    σ_vm = sqrt(½ [(σ_rr − σ_θθ)² + (σ_θθ − σ_zz)² + (σ_zz − σ_rr)²]
                + 3 (σ_rθ² + σ_rz² + σ_θz²)).

For a plane-strain field (u_z = 0, u independent of z) the 3D σ_zz = λ tr ε equals the 2D
ν (σ_rr + σ_θθ) (2ν(λ + μ) = λ), so the 3D components restrict to the 2D ones.
"""

from __future__ import annotations

import ufl

from stickslip.forms.elasticity import Material, stress
from stickslip.forms.polar import radial_unit, tangential_unit

__all__ = ["STRESS_COMPONENTS", "STRESS_COMPONENTS_3D", "cell_area", "cell_average_stress",
           "cylindrical_frame", "cylindrical_stress", "polar_stress"]

#: The components of ``polar_stress``, in order (the names the field files give them).
STRESS_COMPONENTS = ("sigma_rr", "sigma_tt", "sigma_rt", "von_mises")
#: The components of ``cylindrical_stress`` (3D), in order.
STRESS_COMPONENTS_3D = ("sigma_rr", "sigma_tt", "sigma_zz", "sigma_rt", "sigma_rz", "sigma_tz",
                        "von_mises")


def polar_stress(u: ufl.core.expr.Expr, material: Material) -> ufl.core.expr.Expr:
    """The vector (σ_rr, σ_θθ, σ_rθ, σ_vm) of displacement ``u`` [Pa] (module docstring)."""
    x = ufl.SpatialCoordinate(u.ufl_function_space().mesh)
    sigma = stress(u, material)
    e_r, e_t = radial_unit(x), tangential_unit(x)
    s_rr = ufl.dot(e_r, ufl.dot(sigma, e_r))
    s_tt = ufl.dot(e_t, ufl.dot(sigma, e_t))
    s_rt = ufl.dot(e_r, ufl.dot(sigma, e_t))
    s_zz = material.nu * (s_rr + s_tt)  # plane strain: ε_zz = 0
    von_mises = ufl.sqrt(0.5 * ((s_rr - s_tt) ** 2 + (s_tt - s_zz) ** 2 + (s_zz - s_rr) ** 2)
                         + 3.0 * s_rt**2)
    return ufl.as_vector((s_rr, s_tt, s_rt, von_mises))


def cylindrical_frame(x: ufl.core.expr.Expr) -> tuple[ufl.core.expr.Expr, ...]:
    """The unit vectors ``(e_r, e_θ, e_z)`` at the 3D point ``x``: ``e_r = (x, y, 0)/ρ``,
    ``e_θ = (−y, x, 0)/ρ``, ``e_z = (0, 0, 1)``, ρ = sqrt(x² + y²)."""
    rho = ufl.sqrt(x[0] ** 2 + x[1] ** 2)
    return (ufl.as_vector((x[0] / rho, x[1] / rho, 0.0)),
            ufl.as_vector((-x[1] / rho, x[0] / rho, 0.0)), ufl.as_vector((0.0, 0.0, 1.0)))


def cylindrical_stress(u: ufl.core.expr.Expr, material: Material) -> ufl.core.expr.Expr:
    """The vector (σ_rr, σ_θθ, σ_zz, σ_rθ, σ_rz, σ_θz, σ_vm) of the 3D displacement ``u``
    [Pa], ``σ_ab = e_a·σ·e_b`` in ``cylindrical_frame`` (module docstring)."""
    x = ufl.SpatialCoordinate(u.ufl_function_space().mesh)
    sigma = stress(u, material)
    e_r, e_t, e_z = cylindrical_frame(x)

    def part(a: ufl.core.expr.Expr, b: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
        return ufl.dot(a, ufl.dot(sigma, b))

    s_rr, s_tt, s_zz = part(e_r, e_r), part(e_t, e_t), part(e_z, e_z)
    s_rt, s_rz, s_tz = part(e_r, e_t), part(e_r, e_z), part(e_t, e_z)
    von_mises = ufl.sqrt(0.5 * ((s_rr - s_tt) ** 2 + (s_tt - s_zz) ** 2 + (s_zz - s_rr) ** 2)
                         + 3.0 * (s_rt**2 + s_rz**2 + s_tz**2))
    return ufl.as_vector((s_rr, s_tt, s_zz, s_rt, s_rz, s_tz, von_mises))


def cell_average_stress(u: ufl.core.expr.Expr, material: Material, q: ufl.Argument,
                        quadrature_degree: int = 4) -> ufl.Form:
    """``∫ s(u)·q dx`` with s = ``polar_stress(u)`` and q a test function of (DG0)⁴ on a 2D
    mesh, s = ``cylindrical_stress(u)`` and q one of (DG0)⁷ on a 3D mesh.

    The polar frame x/|x| and von Mises' square root are not polynomials: UFL would pick
    degree 22 (1.3 ms per assembly at N = 132, ten times the cost). Degree 4 integrates
    the P1/P2 stress times the smooth frame to 1e-9 relative at N = 132.
    """
    dx = ufl.dx(metadata={"quadrature_degree": quadrature_degree})
    field = cylindrical_stress if ufl.shape(u) == (3,) else polar_stress
    return ufl.inner(field(u, material), q) * dx


def cell_area(q: ufl.Argument) -> ufl.Form:
    """``∫ q dx``: the cell areas |K| (volumes in 3D), q a scalar DG0 test function."""
    return q * ufl.dx
