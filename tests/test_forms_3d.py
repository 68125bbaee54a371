"""The elasticity forms (forms/elasticity.py) and the stress output (forms/stress.py) on the
3D tube of trilinear hexahedra (meshes/tube3d.py).

* A manufactured static solution u_m of −div σ(u) = f (f = −div σ(u_m) in UFL), u = u_m on
  the whole boundary, converges at the trilinear element's orders: 2 in L², 1 in the H¹
  seminorm, over three meshes refined by 2 in every direction.
* The strain energy ½ uᵀKu of the assembled stiffness equals ∫ ½ σ(u):ε(u) dx for a random
  u, and the lumped mass carries ρ |Ω_h| in each component.
* The cylindrical stress (σ_rr, σ_θθ, σ_zz, σ_rθ, σ_rz, σ_θz, σ_vm) as cell averages: exact
  for a uniform axial strain and zero for a rigid rotation (both in the trilinear space), and
  on a plane-strain field the 2D tube's polar stress of the cross-section above each cell.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("dolfinx")

import dolfinx  # noqa: E402
import dolfinx.fem.petsc  # noqa: E402
import ufl  # noqa: E402
from mpi4py import MPI  # noqa: E402

from stickslip.forms.elasticity import (  # noqa: E402
    Material,
    lumped_mass,
    stiffness,
    strain,
    stress,
)
from stickslip.forms.stress import (  # noqa: E402
    STRESS_COMPONENTS,
    STRESS_COMPONENTS_3D,
    cell_area,
    cell_average_stress,
)
from stickslip.meshes.annulus import annulus_mesh  # noqa: E402
from stickslip.meshes.compat import solve_linear  # noqa: E402
from stickslip.meshes.tube3d import tube_mesh_3d  # noqa: E402

STEEL = Material(E=2.1e11, nu=0.3, rho=7800.0)


def _tube(n_inner: int = 16, n_radial: int = 2, n_axial: int = 3, R: float = 0.1,
          xi: float = 1.25, length: float = 0.05):
    return tube_mesh_3d(MPI.COMM_SELF, R=R, xi=xi, length=length, n_inner=n_inner,
                        n_axial=n_axial, n_radial=n_radial)


def _integral(expr: ufl.core.expr.Expr, msh: dolfinx.mesh.Mesh, degree: int = 6) -> float:
    dx = ufl.dx(domain=msh, metadata={"quadrature_degree": degree})
    return float(dolfinx.fem.assemble_scalar(dolfinx.fem.form(expr * dx)))


def _mms_errors(n_inner: int) -> tuple[float, float, float]:
    """(h, ‖u_h − u_m‖_L², |u_h − u_m|_H¹) on the tube R = 1, ξ = 1.25, L = 0.5 with
    ``n_inner`` nodes around and ``n_inner``/8 layers through the wall and along z: every cell
    edge (2π/N around, 2/N through, 4/N along) scales with h = 2π/N."""
    t = _tube(n_inner, n_inner // 8, n_inner // 8, R=1.0, length=0.5)
    msh = t.mesh
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    x = ufl.SpatialCoordinate(msh)
    exact = 1e-3 * ufl.as_vector((ufl.sin(2 * x[2]) * x[1], ufl.cos(x[0]) * x[2],
                                  x[0] * x[1] * ufl.exp(x[2])))
    f = -ufl.div(stress(exact, STEEL))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    boundary = dolfinx.fem.Function(V)
    boundary.interpolate(dolfinx.fem.Expression(exact, V.element.interpolation_points()))
    dofs = dolfinx.fem.locate_dofs_topological(V, 2, t.facet_tags.indices)
    uh = solve_linear(stiffness(u, v, STEEL), ufl.inner(f, v) * ufl.dx,
                      [dolfinx.fem.dirichletbc(boundary, dofs)],
                      {"ksp_type": "preonly", "pc_type": "lu"})
    e = uh - exact
    return (2 * math.pi / n_inner, math.sqrt(_integral(ufl.inner(e, e), msh)),
            math.sqrt(_integral(ufl.inner(ufl.grad(e), ufl.grad(e)), msh)))


def test_a_manufactured_solution_converges_at_orders_two_and_one():
    """N = 16, 32, 64 (96, 768, 6144 cells). u_m and f are smooth on all of R³, so the
    discrete problem on the polygonal tube Ω_h is the manufactured problem on Ω_h itself: no
    geometry error, and the errors are the trilinear element's, O(h²) in L² and O(h) in H¹
    (the cells, sectors of an annulus, tend to parallelepipeds, which keeps both orders).
    Measured: L² errors 1.53e-5, 3.91e-6, 9.82e-7 m (orders 1.97, 1.99), H¹ 1.68e-4,
    8.42e-5, 4.21e-5 (orders 0.999, 1.000). Asserted within 0.15 of 2 and 1: an order
    observed on two meshes carries the error expansion's next term, 0.03 at most here."""
    errors = [_mms_errors(n) for n in (16, 32, 64)]
    orders = [[math.log(a[i] / b[i]) / math.log(a[0] / b[0]) for i in (1, 2)]
              for a, b in zip(errors, errors[1:], strict=False)]
    for l2, h1 in orders:
        assert abs(l2 - 2.0) < 0.15 and abs(h1 - 1.0) < 0.15, (errors, orders)


def test_the_strain_energy_and_the_lumped_mass_in_3d():
    """Tube R = 0.1 m, ξ = 1.25, L = 50 mm, N = 16, 2 × 3 layers. For a random u (uniform in
    ±1 µm) ½ uᵀKu equals ∫ ½ σ(u):ε(u) dx to 1e-12 relative: the same integrand and the same
    quadrature, summed in another order (measured 0). Each component's lumped mass sums to
    ρ |Ω_h| to 1e-12 (round-off of 192 positive terms and one rescaling; measured 5e-15),
    with |Ω_h| = L (N/2) sin(2π/N) ((ξR)² − R²): the cross-section's straight edges make it
    the region between two regular N-gons, smaller than the circular annulus π((ξR)² − R²)
    by the factor sin(2π/N)/(2π/N) = 1 − (2π/N)²/6 + O(N⁻⁴), 0.9745 at N = 16."""
    R, xi, length, n = 0.1, 1.25, 0.05, 16
    msh = _tube(n, 2, 3, R=R, xi=xi, length=length).mesh
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    K = dolfinx.fem.petsc.assemble_matrix(
        dolfinx.fem.form(stiffness(ufl.TrialFunction(V), ufl.TestFunction(V), STEEL)))
    K.assemble()
    uh = dolfinx.fem.Function(V)
    uh.x.array[:] = np.random.default_rng(7).uniform(-1e-6, 1e-6, uh.x.array.size)
    Ku = K.createVecLeft()
    K.mult(uh.x.petsc_vec, Ku)
    discrete = 0.5 * Ku.dot(uh.x.petsc_vec)
    energy = dolfinx.fem.form(0.5 * ufl.inner(stress(uh, STEEL), strain(uh)) * ufl.dx)
    assert discrete == pytest.approx(dolfinx.fem.assemble_scalar(energy), rel=1e-12)

    per_component = lumped_mass(V, STEEL.rho).array.reshape(-1, 3).sum(axis=0)
    polygons = length * 0.5 * n * math.sin(2 * math.pi / n) * ((xi * R) ** 2 - R**2)
    assert np.allclose(per_component, STEEL.rho * polygons, rtol=1e-12, atol=0.0)
    circles = math.pi * ((xi * R) ** 2 - R**2) * length
    ratio = math.sin(2 * math.pi / n) / (2 * math.pi / n)
    assert polygons / circles == pytest.approx(ratio, rel=1e-14)
    assert abs(ratio - (1 - (2 * math.pi / n) ** 2 / 6)) < (2 * math.pi / n) ** 4 / 100


def _cell_stress(msh: dolfinx.mesh.Mesh, u: ufl.core.expr.Expr, names: tuple[str, ...]
                 ) -> dict[str, np.ndarray]:
    """The cell averages of ``cell_average_stress(u)``, by component name."""
    cells = dolfinx.fem.functionspace(msh, ("DG", 0))
    vector = dolfinx.fem.functionspace(msh, ("DG", 0, (len(names),)))
    size = dolfinx.fem.assemble_vector(dolfinx.fem.form(cell_area(ufl.TestFunction(cells))))
    s = dolfinx.fem.assemble_vector(dolfinx.fem.form(
        cell_average_stress(u, STEEL, ufl.TestFunction(vector))))
    s = s.array.reshape(-1, len(names)) / size.array[:, None]
    return {name: s[:, i] for i, name in enumerate(names)}


def _interpolated(msh: dolfinx.mesh.Mesh, field) -> dolfinx.fem.Function:  # noqa: ANN001
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (msh.geometry.dim,)))
    u = dolfinx.fem.Function(V)
    u.interpolate(field)
    return u


def test_the_cylindrical_stress_of_a_uniform_axial_strain_and_a_rotation():
    """u = (0, 0, ε z) has σ = diag(λε, λε, (λ + 2μ)ε) in any frame: σ_rr = σ_θθ = λε,
    σ_zz = (λ + 2μ)ε, no shear, σ_vm = 2μ|ε|. A small rigid rotation u = ω × x has ε = 0 and
    no stress. Both fields are trilinear, so the cell averages are exact but for round-off:
    1e-12 of the stress scale (E ε, E |ω|) allowed, 3.4e-15 measured."""
    msh = _tube().mesh
    eps, lam, mu = 1e-4, STEEL.lame_lambda, STEEL.lame_mu
    s = _cell_stress(msh, _interpolated(msh, lambda x: np.stack([0 * x[0], 0 * x[0],
                                                                 eps * x[2]])),
                     STRESS_COMPONENTS_3D)
    expected = {"sigma_rr": lam * eps, "sigma_tt": lam * eps, "sigma_zz": (lam + 2 * mu) * eps,
                "sigma_rt": 0.0, "sigma_rz": 0.0, "sigma_tz": 0.0, "von_mises": 2 * mu * eps}
    for name, value in expected.items():
        assert np.max(np.abs(s[name] - value)) < 1e-12 * STEEL.E * eps, name
    omega = np.array([2e-4, -3e-4, 5e-4])
    s = _cell_stress(msh, _interpolated(msh, lambda x: np.cross(omega, x.T).T),
                     STRESS_COMPONENTS_3D)
    for name in STRESS_COMPONENTS_3D:
        assert np.max(np.abs(s[name])) < 1e-12 * STEEL.E * np.linalg.norm(omega), name


def test_the_cylindrical_stress_of_a_plane_strain_field_is_the_polar_stress():
    """The 2D tube in quadrilaterals (N = 16, 2 layers) and the 3D tube extruded from it
    (3 layers); the same in-plane field u(x, y), u_z = 0, interpolated in both. On each
    hexahedron the trilinear u is the bilinear u of the quadrilateral below it, constant in
    z, so its cell averages are the quadrilateral's: σ_rr, σ_θθ, σ_rθ, σ_vm equal the 2D
    ones, σ_zz equals plane strain's ν (σ_rr + σ_θθ), σ_rz = σ_θz = 0. Allowed 1e-12 of the
    largest stress, 3.2e-15 measured: the degree-4 rules on the hexahedron and the
    quadrilateral share their in-plane points, and only the order of the arithmetic
    differs."""
    two = annulus_mesh(MPI.COMM_SELF, R=0.1, xi=1.25, n_inner=16, n_radial=2,
                       cell="quadrilateral").mesh
    three = _tube().mesh

    def field(x: np.ndarray) -> np.ndarray:  # u(x, y): x's rows 0 and 1 only
        return 1e-5 * np.stack([np.cos(20 * x[0]) * x[1] / 0.1, np.sin(30 * x[1]) + x[0] / 0.1])

    s2 = _cell_stress(two, _interpolated(two, field), STRESS_COMPONENTS)
    s3 = _cell_stress(three, _interpolated(three, lambda x: np.vstack([field(x),
                                                                       0 * x[0]])),
                      STRESS_COMPONENTS_3D)
    mid2 = dolfinx.mesh.compute_midpoints(two, 2, np.arange(s2["sigma_rr"].size,
                                                            dtype=np.int32))
    mid3 = dolfinx.mesh.compute_midpoints(three, 3, np.arange(s3["sigma_rr"].size,
                                                              dtype=np.int32))
    gap = np.linalg.norm(mid3[:, None, :2] - mid2[None, :, :2], axis=2)
    below = np.argmin(gap, axis=1)
    assert np.max(gap[np.arange(below.size), below]) < 1e-12
    s2["sigma_zz"] = STEEL.nu * (s2["sigma_rr"] + s2["sigma_tt"])
    scale = max(np.max(np.abs(v)) for v in s2.values())
    for name in ("sigma_rr", "sigma_tt", "sigma_rt", "von_mises", "sigma_zz"):
        assert np.max(np.abs(s3[name] - s2[name][below])) < 1e-12 * scale, name
    for name in ("sigma_rz", "sigma_tz"):
        assert np.max(np.abs(s3[name])) < 1e-12 * scale, name
