"""Discrete steady sliding state of the tube (paper section 2), with the NODAL contact law.

Problem: ``Div σ = 0`` in the tube, ``u = 0`` on r = ξR, and on the contact circle r = R the
nodal law used by the explicit solver, at every contact node ``i`` (angle θ_i):

* normal constraint ``u_i·e_r(θ_i) = d`` (``d = δR``, mismatch, persistent contact),
* nodal force exerted by the cylinder ``F_i = λ_i (e_r(θ_i) + f e_θ(θ_i))``: Coulomb sliding
  with ``t_θ = f p`` (``q = fp``), ``λ_i > 0`` the unknown normal nodal force [N/m].

``λ_i`` are Lagrange multipliers eliminated node by node: rotate each contact node to its
(r, θ) basis (``ũ = Tᵀu``), replace the θ-row by ``row_θ − f·row_r`` (``F_θ = f F_r``) and the
r-row by the constraint ``ũ_r = d``; one nonsymmetric sparse LU solve. The result is the
exact discrete equilibrium of the solver's contact law (a clean initial condition), and the
pressure is ``p_i = λ_i / ∫_Γ φ_i ds``. It converges to the closed form ``u_e, v_e, p_e``.
"""

from __future__ import annotations

from dataclasses import dataclass

import dolfinx
import dolfinx.fem.petsc
import numpy as np
import ufl
from numpy.typing import NDArray
from petsc4py import PETSc

from stickslip.forms.elasticity import Material, stiffness
from stickslip.forms.polar import ContactNodes, contact_nodes, without_held
from stickslip.meshes.annulus import INNER_TAG, OUTER_TAG, TubeMesh

__all__ = ["StaticSliding", "node_matrix", "rigid_body_modes", "set_near_nullspace",
           "static_sliding"]


@dataclass
class StaticSliding:
    """Discrete steady sliding state: displacement, contact nodes, nodal forces, pressures."""

    u: dolfinx.fem.Function
    contact: ContactNodes
    normal_force: NDArray[np.float64]  # λ_i [N/m] on the owned contact nodes
    pressure: NDArray[np.float64]  # p_i = λ_i / ds_weight_i [Pa]
    iterations: int = 0  # the solver's iterations in the first solve (1: the LU)


def node_matrix(
    template: PETSc.Mat,
    rows_x: NDArray[np.int64],
    local_x: NDArray[np.int32],
    vals: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]],
) -> PETSc.Mat:
    """Identity, except 2×2 blocks ``[[a, b], [c, d]]`` on the contact node dof pairs."""
    (n_loc, _), _ = template.getSizes()
    rstart = template.getOwnershipRange()[0]
    counts = np.ones(n_loc, dtype=PETSc.IntType)
    counts[local_x] = 2
    counts[local_x + 1] = 2
    indptr = np.zeros(n_loc + 1, dtype=PETSc.IntType)
    np.cumsum(counts, out=indptr[1:])
    cols = (rstart + np.arange(n_loc, dtype=PETSc.IntType))[np.repeat(np.arange(n_loc), counts)]
    data = np.ones(indptr[-1], dtype=PETSc.ScalarType)
    a, b, c, d = vals
    px, py = indptr[local_x], indptr[local_x + 1]
    cols[px], cols[px + 1], cols[py], cols[py + 1] = rows_x, rows_x + 1, rows_x, rows_x + 1
    data[px], data[px + 1], data[py], data[py + 1] = a, b, c, d
    mat = PETSc.Mat().createAIJ(
        size=template.getSizes(), csr=(indptr, cols, data), comm=template.getComm()
    )
    mat.assemble()
    return mat


def _steady_solver(A: PETSc.Mat, iterative: bool) -> PETSc.KSP:
    """The solver of the steady system ``A`` (``static_sliding``), own options prefix."""
    ksp = PETSc.KSP().create(A.getComm())
    ksp.setOperators(A)
    ksp.setOptionsPrefix("stickslip_steady_")
    pc = ksp.getPC()
    if iterative:
        ksp.setType("gmres")
        ksp.setGMRESRestart(200)
        ksp.setTolerances(rtol=1e-13, max_it=4000)
        pc.setType("gamg")
    else:
        ksp.setType("preonly")
        pc.setType("lu")
        pc.setFactorSolverType("mumps")
        # A is non-symmetric and indefinite: MUMPS' default relative pivot threshold (0.01)
        # can lose digits silently; 0.5 pivots for accuracy (nothing global is set).
        PETSc.Options().setValue("stickslip_steady_mat_mumps_cntl_1", 0.5)
    ksp.setFromOptions()
    return ksp


def rigid_body_modes(V: dolfinx.fem.FunctionSpace) -> list[NDArray[np.float64]]:
    """The rigid-body motions of the solid on V's owned dofs, (n_owned * bs,) each: the
    translations e_i and the rotations u_i = -x_j, u_j = x_i (3 in 2D, 6 in 3D)."""
    gdim, bs = V.mesh.geometry.dim, V.dofmap.index_map_bs
    x = V.tabulate_dof_coordinates()[: V.dofmap.index_map.size_local]
    modes = []
    for i in range(gdim):
        mode = np.zeros((x.shape[0], bs))
        mode[:, i] = 1.0
        modes.append(mode)
    for i, j in [(0, 1)] if gdim == 2 else [(0, 1), (1, 2), (2, 0)]:
        mode = np.zeros((x.shape[0], bs))
        mode[:, i], mode[:, j] = -x[:, j], x[:, i]
        modes.append(mode)
    return [mode.reshape(-1) for mode in modes]


def set_near_nullspace(A: PETSc.Mat, V: dolfinx.fem.FunctionSpace, T: PETSc.Mat) -> None:
    """Give ``A`` (the steady system in the rotated unknowns ũ = Tᵀ u) the rigid-body modes
    of V, rotated (Tᵀ r) and orthonormalised, as its near null space, and V's block size:
    what smoothed aggregation needs to build an elasticity coarse space. Without them GAMG
    takes 208 GMRES iterations at 102 168 dofs (35 s), with them 18 (6.4 s, and 660 MB
    against the LU's 1.7 GB); the three solutions agree to 1e-15 of max|u|."""
    basis: list[PETSc.Vec] = []
    u = T.createVecLeft()
    for mode in rigid_body_modes(V):
        ut = T.createVecRight()
        u.setArray(mode)
        T.multTranspose(u, ut)
        for w in basis:  # Gram-Schmidt
            ut.axpy(-ut.dot(w), w)
        ut.scale(1.0 / ut.norm())
        basis.append(ut)
    u.destroy()
    A.setNearNullSpace(PETSc.NullSpace().create(vectors=basis, comm=A.getComm()))
    A.setBlockSize(V.dofmap.index_map_bs)
    for vec in basis:
        vec.destroy()


def _refine(A: PETSc.Mat, ksp: PETSc.KSP, b: PETSc.Vec, x: PETSc.Vec) -> None:
    """Two steps of iterative refinement of A x = b, in place: the LU error (~cond(A) eps)
    would otherwise make the initial state depend on the factorisation (serial vs parallel
    MUMPS) at ~1e-12, and the flutter-unstable steady state amplifies it; refined, it is
    round-off (~eps) in u."""
    res, corr = A.createVecLeft(), A.createVecRight()
    for _ in range(2):
        A.mult(x, res)
        res.aypx(-1.0, b)  # res = b - A x
        ksp.solve(res, corr)
        x.axpy(1.0, corr)
    res.destroy()
    corr.destroy()


def static_sliding(
    V: dolfinx.fem.FunctionSpace,
    tube: TubeMesh,
    material: Material,
    delta_m: float,
    f: float,
    held: NDArray[np.int32] | None = None,
    iterative: bool = False,
) -> StaticSliding:
    """Solve the discrete steady sliding problem (mismatch ``delta_m`` = d [m], friction
    ``f``), u = 0 on the outer boundary and at the owned local dofs ``held`` (a 3D tube's
    ends, ``solver.problem.TubeProblem.end_held``; a contact node whose radial dof is held,
    a clamped end's, is no contact node). One LU (MUMPS), or with ``iterative``
    GMRES preconditioned by smoothed aggregation (GAMG, with the rigid-body modes as its
    near null space: ``set_near_nullspace``) to 1e-13: memory linear in the dofs where a
    3D LU's fill-in is not (2.1 GB at 102 168 dofs); with the refinement below both give u
    to round-off (8e-16 apart at 28 512 dofs, 9e-16 of max|u| at 102 168)."""
    msh = V.mesh
    comm = msh.comm
    fdim = msh.topology.dim - 1
    msh.topology.create_connectivity(fdim, msh.topology.dim)
    outer = dolfinx.fem.locate_dofs_topological(V, fdim, tube.facet_tags.find(OUTER_TAG))
    bs = V.dofmap.index_map_bs
    bc = dolfinx.fem.dirichletbc(np.zeros(bs, dtype=dolfinx.default_scalar_type), outer, V)
    u_, v_ = ufl.TrialFunction(V), ufl.TestFunction(V)
    K = dolfinx.fem.petsc.assemble_matrix(dolfinx.fem.form(stiffness(u_, v_, material)), bcs=[bc])
    K.assemble()
    rstart = V.dofmap.index_map.local_range[0] * bs
    if held is not None and comm.allreduce(int(np.size(held))):
        K.zeroRowsColumns((rstart + np.asarray(held)).astype(PETSc.IntType), diag=1.0)

    cn = contact_nodes(V, tube.facet_tags, INNER_TAG)
    if held is not None:  # a node the ends hold is the support's, no contact node
        cn = without_held(cn, held, comm)
    rows_x = (rstart + cn.dofs_x).astype(PETSc.IntType)
    c, s = cn.cos_t, cn.sin_t
    T = node_matrix(K, rows_x, cn.dofs_x, (c, -s, s, c))  # u = T ũ, ũ = (ũ_r, ũ_θ)
    one, zero = np.ones_like(c), np.zeros_like(c)
    L = node_matrix(K, rows_x, cn.dofs_x, (one, zero, -f * one, one))  # row_θ − f row_r

    Kt = K.ptap(T)  # Tᵀ K T
    A = L.matMult(Kt)
    A.zeroRows(rows_x, diag=1.0)  # ũ_r = d
    b = A.createVecLeft()
    b.set(0.0)
    b.setValues(rows_x, np.full(rows_x.size, delta_m))
    b.assemble()

    if iterative:
        set_near_nullspace(A, V, T)
    ksp = _steady_solver(A, iterative)
    ut = A.createVecRight()
    ksp.solve(b, ut)
    if ksp.getConvergedReason() < 0:
        raise RuntimeError(f"static sliding solve failed: reason {ksp.getConvergedReason()}")
    iterations = max(1, ksp.getIterationNumber())
    _refine(A, ksp, b, ut)

    r = Kt.createVecLeft()
    Kt.mult(ut, r)  # = Tᵀ F_ext: (λ_i, f λ_i) on the contact nodes, 0 elsewhere
    lam = r.getArray(readonly=True)[cn.dofs_x].copy()
    u = dolfinx.fem.Function(V, name="u_static")
    uv = T.createVecLeft()
    T.mult(ut, uv)
    n = uv.getLocalSize()
    u.x.array[:n] = uv.getArray(readonly=True)
    u.x.scatter_forward()
    for obj in (ksp, A, Kt, K, T, L, b, ut, r, uv):
        obj.destroy()
    return StaticSliding(u=u, contact=cn, normal_force=lam, pressure=lam / cn.ds_weight,
                         iterations=iterations)

