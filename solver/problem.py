"""The discrete problem: tube mesh -> P1/P2 vector space -> stiffness, lumped mass, contact nodes.

Everything here is built once per run. The time loop (``solver.newmark``) then only needs
``stiffness_mult`` (one PETSc MatMult), the inverse lumped mass and the contact projection.
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

from forms.elasticity import Material, lumped_mass, stiffness
from forms.polar import ContactNodes, contact_nodes
from meshes.annulus import INNER_TAG, OUTER_TAG, TubeMesh, annulus_mesh
from solver.contact import (
    ContactArrays,
    EffectivePressure,
    NeighbourFilter,
    NodalFrames,
    project_contact,
    project_contact_filtered,
    project_contact_regularized,
)
from solver.scene import Scene


@dataclass
class TubeProblem:
    """Spaces, matrices and contact data of one scene (SI units)."""

    scene: Scene
    tube: TubeMesh
    V: dolfinx.fem.FunctionSpace
    material: Material
    K: PETSc.Mat
    mass: np.ndarray  # lumped mass per owned dof
    inv_mass: np.ndarray  # 0 on clamped dofs
    clamped: np.ndarray  # owned local dof indices on the outer circle
    nodes: ContactNodes
    comm: MPI.Comm

    @property
    def n_owned(self) -> int:
        return self.mass.size

    @property
    def n_global_dofs(self) -> int:
        return self.K.getSize()[0]

    def vec(self, array: np.ndarray) -> PETSc.Vec:
        """A PETSc Vec sharing memory with an owned-dof numpy array (no copy)."""
        return PETSc.Vec().createWithArray(
            array, size=(array.size, self.n_global_dofs), comm=self.comm
        )

    def stiffness_mult(self):
        """``mult(u, out)``: out = K u on owned numpy arrays, via one PETSc MatMult.

        The PETSc vectors wrapping the arrays are created once per array pair and cached.
        """
        cache: dict[tuple[int, int], tuple[PETSc.Vec, PETSc.Vec]] = {}
        K = self.K

        def mult(u: np.ndarray, out: np.ndarray) -> None:
            key = (id(u), id(out))  # persistent integrator arrays; id() is the cheap key
            pair = cache.get(key)
            if pair is None:
                pair = cache[key] = (self.vec(u), self.vec(out))
            K.mult(pair[0], pair[1])

        return mult

    def owned_array(self, function: dolfinx.fem.Function) -> np.ndarray:
        """Owned dof values of a dolfinx Function (copy)."""
        n = self.n_owned
        return function.x.array[:n].copy()

    def to_function(self, array: np.ndarray, name: str = "u") -> dolfinx.fem.Function:
        """A dolfinx Function (ghosts updated) from owned dof values."""
        fn = dolfinx.fem.Function(self.V, name=name)
        fn.x.array[: self.n_owned] = array
        fn.x.scatter_forward()
        return fn

    def polar(self, array: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(radial, tangential) components of ``array`` at the owned contact nodes."""
        nd = self.nodes
        x, y = array[nd.dofs_x], array[nd.dofs_y]
        return nd.cos_t * x + nd.sin_t * y, -nd.sin_t * x + nd.cos_t * y

    def radial_field(self, amplitude_of_theta) -> np.ndarray:
        """Owned dofs of u = A(theta) X(r) e_r, X(r) = (xi^2 R/r - r/R) / (xi^2 - 1) (eq. [1]).

        X(R) = 1 and X(xi R) = 0, so the field is clamped on the outer circle. Defined from
        coordinates, hence independent of the mesh partition.
        """
        R, xi = self.scene.geometry.R, self.scene.geometry.xi

        def expr(x: np.ndarray) -> np.ndarray:
            r = np.hypot(x[0], x[1])
            theta = np.arctan2(x[1], x[0])
            radial = amplitude_of_theta(theta) * (xi**2 * R / r - r / R) / (xi**2 - 1.0)
            return np.vstack([radial * x[0] / r, radial * x[1] / r])

        fn = dolfinx.fem.Function(self.V)
        fn.interpolate(expr)
        arr = self.owned_array(fn)
        arr[self.clamped] = 0.0
        return arr


def build_problem(scene: Scene, comm: MPI.Comm = MPI.COMM_WORLD) -> TubeProblem:
    """Mesh, P1/P2 space, stiffness matrix, lumped mass and contact nodes for ``scene``."""
    g, m = scene.geometry, scene.mesh
    tube = annulus_mesh(
        comm, R=g.R, xi=g.xi, n_inner=m.n_inner, n_radial=m.n_radial, cell=m.cell, degree=m.degree
    )
    msh = tube.mesh
    V = dolfinx.fem.functionspace(msh, ("Lagrange", m.degree, (msh.geometry.dim,)))
    mat = scene.material
    material = Material(E=mat.E, nu=mat.nu, rho=mat.rho)
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    K = dolfinx.fem.petsc.assemble_matrix(dolfinx.fem.form(stiffness(u, v, material)))
    K.assemble()
    mass_vec = lumped_mass(V, material.rho)
    mass = mass_vec.array.copy()
    bs = V.dofmap.index_map_bs
    n_owned = V.dofmap.index_map.size_local * bs
    outer = tube.facet_tags.find(OUTER_TAG)
    blocks = dolfinx.fem.locate_dofs_topological(V, msh.topology.dim - 1, outer)
    clamped = (blocks[:, None] * bs + np.arange(bs)[None, :]).ravel()
    clamped = np.sort(clamped[clamped < n_owned])
    inv_mass = 1.0 / mass
    inv_mass[clamped] = 0.0
    nodes = contact_nodes(V, tube.facet_tags, INNER_TAG)
    return TubeProblem(scene, tube, V, material, K, mass, inv_mass, clamped, nodes, comm)


class ContactProjection(NodalFrames):
    """The forward-increment contact step of ``Newmark`` for the tube's inner circle.

    Rotating to and from the nodes' polar frames is done with complex numbers: an owned
    blocked array (x0, y0, x1, y1, ...) viewed as complex128 holds z_i = x_i + i y_i per node,
    and z_i e^{-i theta_i} = u_r + i u_theta. So each conversion is one ``take`` and one
    multiply over the contact nodes. Calls ``solver.contact.project_contact`` (the nodal law)
    and writes the nodal forces back at the contact dofs. Each node is owned by exactly one
    rank, so nothing is double counted in parallel. All arrays are preallocated.
    """

    def __init__(self, problem: TubeProblem, kappa: float, dt: float) -> None:
        sc = problem.scene
        nd = problem.nodes
        self.nodes = nd
        self.node_index = np.asarray(nd.nodes, dtype=np.intp)
        self.kappa = kappa
        self.dt = dt
        self.d = sc.geometry.d
        self.f = sc.loading.f
        self.slide = sc.geometry.R * sc.loading.omega * dt  # cylinder surface travel per step
        self.mass = problem.mass[nd.dofs_x].copy()
        self.inv_mass = 1.0 / self.mass
        self.phase = np.exp(1j * nd.theta)  # e^{i theta}: polar -> (x, y)
        self.phase_conj = np.conj(self.phase)  # (x, y) -> polar
        n = nd.dofs_x.size
        self.z_now = np.zeros(n, dtype=complex)  # u_n at the nodes, polar
        self.z_trial = np.zeros(n, dtype=complex)  # trial u_{n+1}, (x, y) then polar
        self.z_work = np.zeros(n, dtype=complex)
        self.r_polar = np.zeros(n, dtype=complex)  # r_r + i r_theta
        self.r_xy = np.zeros(n, dtype=complex)  # r_x + i r_y
        self.out = ContactArrays(n, r_r=self.r_polar.real, r_t=self.r_polar.imag)
        self._views: dict[int, np.ndarray] = {}

    def _project(self, u_r_trial: np.ndarray, u_t_trial: np.ndarray,
                 u_t_now: np.ndarray) -> None:
        """The nodal law (Coulomb): ``solver.contact.project_contact``."""
        project_contact(u_r_trial, u_t_trial, u_t_now, self.mass, self.kappa, self.d,
                        self.slide, self.f, self.out)

    def __call__(self, u_now: np.ndarray, v_pred: np.ndarray, accel: np.ndarray) -> None:
        """The ``Newmark`` contact step (see ``solver.newmark.ContactStep``)."""
        idx, trial, work = self.node_index, self.z_trial, self.z_work
        now = self.polar_at_nodes(u_now, self.z_now)
        # trial u_{n+1} = u_n + dt v~_n + kappa a*_n at the nodes only, (x, y) then polar
        a_c = self.complex_view(accel)
        self.complex_view(v_pred).take(idx, out=trial)
        trial *= self.dt
        a_c.take(idx, out=work)
        work *= self.kappa
        trial += work
        trial *= self.phase_conj
        trial += now
        self._project(trial.real, trial.imag, now.imag)
        # back to (x, y): r_x + i r_y = (r_r + i r_t) e^{i theta}; a_n = a*_n + r / m
        np.multiply(self.r_polar, self.phase, out=self.r_xy)
        a_c.take(idx, out=work)
        np.multiply(self.r_xy, self.inv_mass, out=trial)
        work += trial
        np.put(a_c, idx, work)


class RegularizedContactProjection(ContactProjection):
    """``ContactProjection`` with the Prakash-Clifton friction bound (scene ``[friction]``):
    ``solver.contact.project_contact_regularized`` and the per-node state
    ``solver.contact.EffectivePressure`` (allocated once)."""

    def __init__(self, problem: TubeProblem, kappa: float, dt: float) -> None:
        super().__init__(problem, kappa, dt)
        fr = problem.scene.friction
        self.effective = EffectivePressure(
            self.mass.size, fr.regularization, dt, slip_length=fr.slip_length,
            reference_velocity=fr.reference_velocity, relaxation_time=fr.relaxation_time)

    def _project(self, u_r_trial: np.ndarray, u_t_trial: np.ndarray,
                 u_t_now: np.ndarray) -> None:
        project_contact_regularized(u_r_trial, u_t_trial, u_t_now, self.mass, self.kappa,
                                    self.d, self.slide, self.f, self.effective, self.out)


class FilteredContactProjection(ContactProjection):
    """``ContactProjection`` with the 1-2-1 filtered friction bound (``[friction] filter =
    "1-2-1"``): ``solver.contact.project_contact_filtered`` with a ``NeighbourFilter`` over
    the angle-ordered contact nodes (Allgather of the N nodal p's under MPI), composed with
    the Prakash-Clifton state when the scene also regularises."""

    def __init__(self, problem: TubeProblem, kappa: float, dt: float) -> None:
        super().__init__(problem, kappa, dt)
        nd, fr = problem.nodes, problem.scene.friction
        self.filter = NeighbourFilter(nd.global_node_index, nd.n_global, problem.comm)
        self.effective = None
        if fr.enabled:
            self.effective = EffectivePressure(
                self.mass.size, fr.regularization, dt, slip_length=fr.slip_length,
                reference_velocity=fr.reference_velocity, relaxation_time=fr.relaxation_time)

    def _project(self, u_r_trial: np.ndarray, u_t_trial: np.ndarray,
                 u_t_now: np.ndarray) -> None:
        project_contact_filtered(u_r_trial, u_t_trial, u_t_now, self.mass, self.kappa, self.d,
                                 self.slide, self.f, self.filter, self.out, self.effective)


def make_projection(problem: TubeProblem, kappa: float, dt: float) -> ContactProjection:
    """The explicit contact step for the scene's friction law (Coulomb, filtered and/or
    regularised)."""
    if problem.scene.friction.filtered:
        return FilteredContactProjection(problem, kappa, dt)
    if problem.scene.friction.enabled:
        return RegularizedContactProjection(problem, kappa, dt)
    return ContactProjection(problem, kappa, dt)


def omega_max(problem: TubeProblem) -> float:
    """Largest eigenfrequency (rad/s) of K phi = w^2 M phi with the outer circle clamped.

    SLEPc Krylov-Schur on the symmetric scaled operator M^{-1/2} K M^{-1/2} (clamped rows and
    columns zeroed), largest magnitude. The top of the spectrum clusters on fine meshes
    (N >= 1000; N = 1024 takes ~13 s on one core), where Krylov-Schur may not converge to a
    relative 1e-6 in its budget: then the safe
    Gershgorin upper bound is used instead (a smaller, still stable dt; ~10 % smaller).
    """
    from slepc4py import SLEPc

    scale = np.sqrt(problem.inv_mass)
    d = problem.vec(scale)
    A = problem.K.copy()
    A.diagonalScale(d, d)
    eps = SLEPc.EPS().create(problem.comm)
    eps.setOperators(A)
    eps.setProblemType(SLEPc.EPS.ProblemType.HEP)
    eps.setWhichEigenpairs(SLEPc.EPS.Which.LARGEST_MAGNITUDE)
    eps.setDimensions(1, 32)
    eps.setTolerances(1e-6, 1000)
    eps.solve()
    converged = eps.getConverged() >= 1
    lam = eps.getEigenvalue(0).real if converged else math.nan
    eps.destroy()
    A.destroy()
    if converged:
        return math.sqrt(lam)
    return gershgorin_omega_max(problem)


def gershgorin_omega_max(problem: TubeProblem) -> float:
    """Upper bound of the largest eigenfrequency: w_max^2 <= max_i sum_j |K_ij| / m_i."""
    indptr, _, values = problem.K.getValuesCSR()
    row_abs = np.add.reduceat(np.abs(values), indptr[:-1]) if values.size else np.zeros(0)
    row_abs[np.diff(indptr) == 0] = 0.0
    lam = float(np.max(row_abs[: problem.n_owned] * problem.inv_mass, initial=0.0))
    return math.sqrt(problem.comm.allreduce(lam, op=MPI.MAX))
