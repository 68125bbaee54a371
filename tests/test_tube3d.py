"""The finite-length tube in 3D (meshes/tube3d.py) and the elasticity forms in 3D.

* The mesh: hexahedra, exactly N × (N_z + 1) nodes on the contact surface r = R at the
  angles 2πj/N and the levels Lk/N_z, the tags of the contact surface, the clamped surface
  and both ends; bad parameters refused in one line.
* The plane-strain limit, on the discrete operators: with roller ends (u_z = 0 at z = 0 and
  z = L) and the outer surface clamped, every eigenvalue ω² of the 2D tube (K u = ω² M u, the
  lumped mass) is an eigenvalue of the 3D tube extruded from the same cross-section. The
  trilinear space holds the z-constant in-plane fields, and on them the 3D stiffness and the
  HRZ-lumped mass are the 2D ones times the lumped P1 weights along z (dz/2 at the ends, dz
  inside), so the match is exact but for round-off: 1e-10 relative allowed (dense
  eigensolvers on matrices of condition ~1e3), 5e-15 measured.
* The forms in 3D: a manufactured static solution of −div σ(u) = f on the tube, clamped on
  its whole boundary, converges in L² at the trilinear element's order 2 (observed order from
  three meshes within 0.25 of 2: the polygonal surfaces add an O(h²) geometry error of
  their own; measured 1.97 and 1.99 at N = 16, 32, 64).
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

from stickslip.forms.elasticity import Material, lumped_mass, stiffness, stress  # noqa: E402
from stickslip.meshes.annulus import INNER_TAG, OUTER_TAG, annulus_mesh  # noqa: E402
from stickslip.meshes.compat import solve_linear  # noqa: E402
from stickslip.meshes.tube3d import END0_TAG, END1_TAG, tube_mesh_3d  # noqa: E402

STEEL = Material(E=2.1e11, nu=0.3, rho=7800.0)


def test_the_mesh_has_n_times_nz_plus_one_contact_nodes_and_its_tags():
    t = tube_mesh_3d(MPI.COMM_SELF, R=0.1, xi=1.25, length=0.05, n_inner=16, n_axial=3,
                     n_radial=2)
    msh = t.mesh
    assert msh.topology.cell_type == dolfinx.mesh.CellType.hexahedron
    assert msh.topology.index_map(3).size_local == 16 * 2 * 3
    x = msh.geometry.x
    r = np.hypot(x[:, 0], x[:, 1])
    inner = x[np.abs(r - 0.1) < 1e-14]
    assert inner.shape[0] == 16 * 4
    angles = np.sort(np.round(np.mod(np.arctan2(inner[:, 1], inner[:, 0]), 2 * math.pi)
                              / (2 * math.pi / 16)).astype(int) % 16)
    assert np.array_equal(np.bincount(angles), np.full(16, 4))
    levels = inner[:, 2] / (0.05 / 3)
    assert np.array_equal(levels, np.rint(levels))
    counts = {tag: int(np.sum(t.facet_tags.values == tag))
              for tag in (INNER_TAG, OUTER_TAG, END0_TAG, END1_TAG)}
    assert counts == {INNER_TAG: 48, OUTER_TAG: 48, END0_TAG: 32, END1_TAG: 32}


@pytest.mark.parametrize("bad, words", [
    ({"length": 0.0}, "length=0.0"), ({"length": math.inf}, "length=inf"),
    ({"n_axial": 0}, "n_axial=0"), ({"n_inner": 6}, "n_inner=6"), ({"xi": 1.0}, "xi=1.0"),
    ({"n_radial": -1}, "n_radial=-1")])
def test_bad_parameters_are_one_line_errors(bad, words):
    args = dict(R=0.1, xi=1.25, length=0.05, n_inner=16, n_axial=2) | bad
    with pytest.raises(ValueError, match=words) as err:
        tube_mesh_3d(MPI.COMM_SELF, **args)
    assert "\n" not in str(err.value)


def _free_spectrum(msh, clamped: list[tuple[np.ndarray, int | None]]) -> np.ndarray:
    """The eigenvalues ω² of K u = ω² M u (lumped M) on the dofs not in ``clamped`` (each:
    facets of the mesh's boundary, and the component fixed there, None for all)."""
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (msh.geometry.dim,)))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    K = dolfinx.fem.petsc.assemble_matrix(dolfinx.fem.form(stiffness(u, v, STEEL)))
    K.assemble()
    n = V.dofmap.index_map.size_local * V.dofmap.index_map_bs
    dense = K.convert("dense").getDenseArray()[:n, :n]
    mass = lumped_mass(V, STEEL.rho).array[:n]
    fixed = np.zeros(n, dtype=bool)
    tdim = msh.topology.dim
    for facets, comp in clamped:
        if comp is None:  # the nodes (blocks) of the facets: every component
            nodes = dolfinx.fem.locate_dofs_topological(V, tdim - 1, facets)
            for c in range(msh.geometry.dim):
                fixed[nodes * msh.geometry.dim + c] = True
        else:  # a component: the sub-space's dofs, numbered in V's (unrolled) dofs
            fixed[dolfinx.fem.locate_dofs_topological(V.sub(comp), tdim - 1, facets)] = True
    free = ~fixed
    scale = 1.0 / np.sqrt(mass[free])
    A = dense[np.ix_(free, free)] * scale[:, None] * scale[None, :]
    return np.linalg.eigvalsh(0.5 * (A + A.T))


def test_roller_ends_hold_every_plane_strain_eigenvalue():
    """The 2D quadrilateral tube (N = 16, 2 layers, outer circle clamped) and the 3D tube
    extruded from it (3 axial layers, outer surface clamped, u_z = 0 on both ends): each 2D
    eigenvalue is in the 3D spectrum to 1e-10 relative; the 3D spectrum has more (the modes
    that vary along z)."""
    two = annulus_mesh(MPI.COMM_SELF, R=0.1, xi=1.25, n_inner=16, n_radial=2,
                       cell="quadrilateral")
    lam2 = _free_spectrum(two.mesh, [(two.facet_tags.find(OUTER_TAG), None)])
    three = tube_mesh_3d(MPI.COMM_SELF, R=0.1, xi=1.25, length=0.03, n_inner=16, n_axial=3,
                         n_radial=2)
    ft = three.facet_tags
    ends = np.concatenate([ft.find(END0_TAG), ft.find(END1_TAG)])
    lam3 = _free_spectrum(three.mesh, [(ft.find(OUTER_TAG), None), (ends, 2)])
    assert lam3.size > 3 * lam2.size
    gap = np.array([np.min(np.abs(lam3 - lam)) / lam for lam in lam2])
    assert gap.max() < 1e-10, gap.max()


def _mms_error(n_inner: int, n_radial: int, n_axial: int) -> tuple[float, float]:
    """(h, L² error) of the manufactured static solution on one mesh (module docstring)."""
    t = tube_mesh_3d(MPI.COMM_SELF, R=1.0, xi=1.25, length=0.5, n_inner=n_inner,
                     n_axial=n_axial, n_radial=n_radial)
    msh = t.mesh
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    x = ufl.SpatialCoordinate(msh)
    scale = 1e-3
    exact = scale * ufl.as_vector((ufl.sin(2 * x[2]) * x[1], ufl.cos(x[0]) * x[2],
                                   x[0] * x[1] * ufl.exp(x[2])))
    f = -ufl.div(stress(exact, STEEL))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    boundary = dolfinx.fem.Function(V)
    boundary.interpolate(dolfinx.fem.Expression(exact, V.element.interpolation_points()))
    dofs = dolfinx.fem.locate_dofs_topological(V, 2, t.facet_tags.indices)
    uh = solve_linear(stiffness(u, v, STEEL), ufl.inner(f, v) * ufl.dx,
                      [dolfinx.fem.dirichletbc(boundary, dofs)],
                      {"ksp_type": "preonly", "pc_type": "lu"})
    err = dolfinx.fem.assemble_scalar(dolfinx.fem.form(ufl.inner(uh - exact, uh - exact)
                                                       * ufl.dx))
    return 2 * math.pi / n_inner, math.sqrt(err)


def test_the_forms_converge_at_order_two_in_3d():
    errors = [_mms_error(n, n // 8, n // 8) for n in (16, 32, 64)]
    orders = [math.log(e0 / e1) / math.log(h0 / h1)
              for (h0, e0), (h1, e1) in zip(errors, errors[1:], strict=False)]
    assert all(abs(p - 2.0) < 0.25 for p in orders), (errors, orders)


@pytest.mark.parallel
def test_the_distributed_mesh_has_the_same_tags():
    """On any number of ranks the owned facets of each tag add up to the serial counts."""
    comm = MPI.COMM_WORLD
    t = tube_mesh_3d(comm, R=0.1, xi=1.25, length=0.05, n_inner=16, n_axial=3, n_radial=2)
    msh = t.mesh
    owned = msh.topology.index_map(2).size_local
    counts = {tag: comm.allreduce(int(np.sum(t.facet_tags.find(tag) < owned)))
              for tag in (INNER_TAG, OUTER_TAG, END0_TAG, END1_TAG)}
    assert counts == {INNER_TAG: 48, OUTER_TAG: 48, END0_TAG: 32, END1_TAG: 32}
    assert comm.allreduce(msh.topology.index_map(3).size_local) == 96
