"""Linear elasticity (paper section 2, eq. of the governing system), SI units: plane strain on
the 2D cross-section, and the same law in 3D on the finite-length tube (``meshes.tube3d``;
every form here follows the mesh's dimension).

``σ = λ tr(ε) I + 2μ ε`` with ``λ = Eν/((1+ν)(1−2ν))``, ``μ = E/(2(1+ν))``; divided by ``E`` this is
the paper's non-dimensional law ``σ = ν/((1+ν)(1−2ν)) tr(ε) I + ε/(1+ν)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import dolfinx
import dolfinx.fem.petsc
import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc

from stickslip.meshes.compat import create_petsc_vector

__all__ = ["Material", "lumped_mass", "mass", "stiffness", "strain", "stress"]


@dataclass(frozen=True)
class Material:
    """Isotropic elastic material: ``E`` [Pa], Poisson ratio ``nu``, density ``rho`` [kg/m³]."""

    E: float
    nu: float
    rho: float

    def __post_init__(self) -> None:
        if not self.E > 0.0 or not self.rho > 0.0:
            raise ValueError(f"need E > 0 and rho > 0, got E={self.E!r}, rho={self.rho!r}")
        if not -1.0 < self.nu < 0.5:
            raise ValueError(f"nu={self.nu!r}: need -1 < nu < 0.5")

    @property
    def lame_lambda(self) -> float:
        """``λ = Eν/((1+ν)(1−2ν))`` [Pa]."""
        return self.E * self.nu / ((1.0 + self.nu) * (1.0 - 2.0 * self.nu))

    @property
    def lame_mu(self) -> float:
        """Shear modulus ``μ = E/(2(1+ν))`` [Pa]."""
        return self.E / (2.0 * (1.0 + self.nu))

    @property
    def pressure_wave_speed(self) -> float:
        """Plane-strain P-wave speed ``c_p = sqrt((λ+2μ)/ρ)`` [m/s]."""
        return math.sqrt((self.lame_lambda + 2.0 * self.lame_mu) / self.rho)

    @property
    def shear_wave_speed(self) -> float:
        """S-wave speed ``c_s = sqrt(μ/ρ)`` [m/s]."""
        return math.sqrt(self.lame_mu / self.rho)


def strain(u: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """Small strain ``ε = (∇u)_s``."""
    return ufl.sym(ufl.grad(u))


def stress(u: ufl.core.expr.Expr, material: Material) -> ufl.core.expr.Expr:
    """Cauchy stress ``σ = λ tr(ε) I + 2μ ε``: in 2D the plane-strain in-plane part (2×2),
    in 3D the whole tensor."""
    eps = strain(u)
    dim = ufl.shape(eps)[0]
    return material.lame_lambda * ufl.tr(eps) * ufl.Identity(dim) + 2.0 * material.lame_mu * eps


def stiffness(u: ufl.Argument, v: ufl.Argument, material: Material) -> ufl.Form:
    """Stiffness bilinear form ``∫ σ(u):ε(v) dx``."""
    return ufl.inner(stress(u, material), strain(v)) * ufl.dx


def mass(u: ufl.Argument, v: ufl.Argument, rho: float) -> ufl.Form:
    """Consistent mass bilinear form ``∫ ρ u·v dx`` (inertia term ``γü`` of section 2)."""
    return rho * ufl.inner(u, v) * ufl.dx


def lumped_mass(V: dolfinx.fem.FunctionSpace, rho: float) -> PETSc.Vec:
    """Diagonal (lumped) mass of the blocked space ``V``, ghosted and strictly positive.

    HRZ-type lumping: the diagonal of the consistent mass ``M_ii`` rescaled by one factor so
    that every displacement component carries exactly the total mass ``ρ·|Ω_h|``. For affine
    cells ``M^e_ii = ρ|e|c_i`` with reference constants ``c_i``, so this global factor equals
    the element-wise HRZ factor; it only differs on curved (P2-geometry) boundary cells.

    Row-sum lumping is NOT used: for P2 triangles ``∫ φ_vertex dx = 0`` (vertex shape
    functions integrate to zero), so row-sum gives zero vertex masses (and negative ones on
    curved cells), which breaks an explicit scheme. Diagonals ``M_ii = ∫ρφ_i² dx`` are always
    > 0.
    """
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    M = dolfinx.fem.petsc.assemble_matrix(dolfinx.fem.form(mass(u, v, rho)))
    M.assemble()
    diag = M.getDiagonal()
    M.destroy()
    msh = V.mesh
    one = dolfinx.fem.Constant(msh, dolfinx.default_scalar_type(rho))
    total = msh.comm.allreduce(
        dolfinx.fem.assemble_scalar(dolfinx.fem.form(one * ufl.dx(domain=msh))), op=MPI.SUM
    )
    bs = V.dofmap.index_map_bs
    owned = diag.getArray(readonly=True)
    per_component = msh.comm.allreduce(float(np.sum(owned)), op=MPI.SUM) / bs
    m = create_petsc_vector(V.dofmap.index_map, bs)
    m.array_w[: owned.size] = owned * (total / per_component)
    diag.destroy()
    m.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
    return m
