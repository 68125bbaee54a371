"""Discrete steady sliding state: the exact fixed point of the explicit scheme.

Steady sliding (paper section 2): the tube is at rest, every contact node is in contact
(u_r = d) and slips forward (the cylinder surface is faster), so the nodal contact force is
r = (p_i, f p_i) in the node's (e_r, e_theta) frame. At a fixed point of ``solver.newmark`` with
v = a = 0 the equations are

    K u = r,  u = 0 on the outer circle,  u_r = d and r_theta = f r_r at every contact node.

In rotated nodal coordinates w = Q^T u (Q rotates each contact node's (x, y) into (r, theta)),
K^ = Q^T K Q, the contact rows become
    w_r = d                                   (radial row replaced by the constraint)
    (K^ w)_theta - f (K^ w)_r = 0             (tangential row: eliminates p_i = (K^ w)_r)
which is one linear, non-symmetric system A w = b, solved once with a direct LU (MUMPS where
PETSc has it, so it also runs in parallel).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from petsc4py import PETSc

from solver.problem import TubeProblem


@dataclass
class SteadyState:
    """Discrete steady sliding: owned dofs of u_e and the contact pressure at owned nodes."""

    u: np.ndarray
    pressure: np.ndarray  # p_i = r_r,i / (int phi_i ds), Pa
    normal_force: np.ndarray  # r_r,i, N/m
    tangential_force: np.ndarray  # r_theta,i = f r_r,i


def _global_dofs(problem: TubeProblem, local: np.ndarray) -> np.ndarray:
    start = problem.K.getOwnershipRange()[0]
    return (start + local).astype(PETSc.IntType)


def solve_steady_sliding(problem: TubeProblem) -> SteadyState:
    """Solve the discrete steady sliding problem (see module docstring)."""
    K = problem.K
    nd = problem.nodes
    f = problem.scene.loading.f
    d = problem.scene.geometry.d
    comm = problem.comm
    gx, gy = _global_dofs(problem, nd.dofs_x), _global_dofs(problem, nd.dofs_y)
    start, end = K.getOwnershipRange()

    def identity_like(nnz: int) -> PETSc.Mat:
        M = PETSc.Mat().createAIJ(K.getSizes(), nnz=nnz, comm=comm)
        M.setUp()
        M.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
        is_contact = np.zeros(end - start, dtype=bool)
        is_contact[nd.dofs_x] = True
        is_contact[nd.dofs_y] = True
        for row in np.flatnonzero(~is_contact) + start:  # setup only, once per run
            M.setValue(row, row, 1.0)
        return M

    # Q: (x, y) <- (r, theta) at contact nodes, identity elsewhere.
    Q = identity_like(2)
    L = identity_like(2)
    for i in range(gx.size):  # setup only: one 2x2 block per owned contact node
        c, s = nd.cos_t[i], nd.sin_t[i]
        Q.setValues([gx[i], gy[i]], [gx[i], gy[i]], [[c, -s], [s, c]])
        # L: row theta <- row theta - f row r ; row r untouched (replaced below)
        L.setValues([gx[i], gy[i]], [gx[i], gy[i]], [[1.0, 0.0], [-f, 1.0]])
    Q.assemble()
    L.assemble()
    Khat = K.PtAP(Q)
    A = L.matMult(Khat)
    clamped_global = _global_dofs(problem, problem.clamped)
    rows = np.concatenate([gx, clamped_global]).astype(PETSc.IntType)
    A.zeroRows(rows, diag=1.0)
    b = A.createVecLeft()
    b.set(0.0)
    b.setValues(gx, np.full(gx.size, d))
    b.assemble()
    w = A.createVecRight()
    ksp = PETSc.KSP().create(comm)
    ksp.setOperators(A)
    ksp.setType("preonly")
    pc = ksp.getPC()
    pc.setType("lu")
    if "mumps" in _solver_packages():
        pc.setFactorSolverType("mumps")
    ksp.solve(b, w)
    u = Q.createVecLeft()
    Q.mult(w, u)
    # Contact forces r = K u at the contact nodes, in polar components.
    ku = K.createVecLeft()
    K.mult(u, ku)
    u_arr = u.array.copy()
    r_r, r_t = problem.polar(ku.array)
    for obj in (Q, L, Khat, A, b, w, u, ku, ksp):
        obj.destroy()
    pressure = r_r / nd.ds_weight
    if np.any(r_r <= 0.0):
        raise RuntimeError(
            "discrete steady sliding state has non-positive contact pressure at "
            f"{int(np.sum(r_r <= 0.0))} nodes; the mesh is too coarse or the data inconsistent"
        )
    return SteadyState(u=u_arr, pressure=pressure, normal_force=r_r, tangential_force=r_t)


def _solver_packages() -> set[str]:
    """Direct-solver packages that this PETSc build has (best effort)."""
    try:
        from petsc4py import PETSc as P

        cfg = P.Sys.getConfigInfo() if hasattr(P.Sys, "getConfigInfo") else None
    except Exception:  # pragma: no cover
        cfg = None
    if cfg is None:
        import petsc4py

        cfg = petsc4py.get_config()
    text = str(cfg).lower()
    return {name for name in ("mumps", "superlu_dist", "superlu") if name in text}
