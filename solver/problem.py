"""The discrete problem: mesh (tube or a user's file) -> P1/P2 space -> K, lumped mass, nodes.

Everything here is built once per run. The time loop (``solver.newmark``) then only needs
``stiffness_mult`` (one PETSc MatMult), the inverse lumped mass and the contact projection
(``solver.contact.projection``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import dolfinx
import dolfinx.fem.petsc
import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc

from stickslip.forms.elasticity import Material, lumped_mass, stiffness
from stickslip.forms.polar import ContactNodes, contact_nodes, ring_first, without_held
from stickslip.meshes.annulus import INNER_TAG, OUTER_TAG, TubeMesh, annulus_mesh
from stickslip.meshes.tube3d import END0_TAG, END1_TAG, tube_mesh_3d
from stickslip.meshes.user_mesh import resolve, user_mesh
from stickslip.meshes.user_tube import user_tube_mesh
from stickslip.solver.scene import SCENES_DIR, Scene, tube_axial_layers
from stickslip.solver.scene.sections import ENDS


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
    nodes: ContactNodes  # the contact circle; of a 3D tube, the ring at mid-length
    comm: MPI.Comm
    #: A 3D tube's contact surface, every node (``solver.contact.surface``); None in 2D.
    surface: ContactNodes | None = None
    #: Owned dofs that the ends hold at 0 (``boundary.ends``; empty in 2D), besides the
    #: outer surface's: the steady state holds them too.
    end_held: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int32))

    @property
    def every_contact_node(self) -> ContactNodes:
        """Every owned contact node: a 3D tube's ``surface``, else the circle ``nodes``."""
        return self.nodes if self.surface is None else self.surface

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

        X(R) = 1 and X(xi R) = 0, so the field is clamped on the outer circle; beyond xi R
        (a user's cross-section) X is taken as 0, and the clamped dofs are set to 0. Defined
        from coordinates, hence independent of the mesh partition.
        """
        R, xi = self.scene.geometry.R, self.scene.geometry.xi

        def expr(x: np.ndarray) -> np.ndarray:
            r = np.hypot(x[0], x[1])
            theta = np.arctan2(x[1], x[0])
            # the product in eq. [1]'s order (the tube's starts keep their bits); 0 beyond xi R
            radial = np.where(r < xi * R, amplitude_of_theta(theta) * (xi**2 * R / r - r / R)
                              / (xi**2 - 1.0), 0.0)
            xy = [radial * x[0] / r, radial * x[1] / r]
            return np.vstack(xy if self.surface is None else [*xy, np.zeros_like(r)])

        fn = dolfinx.fem.Function(self.V)
        fn.interpolate(expr)
        arr = self.owned_array(fn)
        arr[self.clamped] = 0.0
        return arr


def cross_section(scene: Scene, comm: MPI.Comm = MPI.COMM_WORLD) -> TubeMesh:
    """The scene's mesh: the tube (``meshes.annulus``) or the user's ``mesh.file``
    (``meshes.user_mesh``: contact group -> ``INNER_TAG``, clamped group -> ``OUTER_TAG``)."""
    g, m = scene.geometry, scene.mesh
    if m.tube:
        return annulus_mesh(comm, R=g.R, xi=g.xi, n_inner=m.n_inner, n_radial=m.n_radial,
                            cell=m.cell, degree=m.degree)

    return user_mesh(comm, resolve(m.file, (SCENES_DIR,)), R=g.R, xi=g.xi,
                     n_contact=m.n_inner, cell=m.cell, degree=m.degree,
                     contact_group=m.contact_group, clamped_group=m.clamped_group)


def build_problem(scene: Scene, comm: MPI.Comm = MPI.COMM_WORLD) -> TubeProblem:
    """Mesh, P1/P2 space, stiffness matrix, lumped mass and contact nodes for ``scene``: the
    plane-strain cross-section, or with ``mesh.dim`` = 3 the finite tube its keys describe
    (``tube_problem_3d``: ``geometry.length``, ``tube_axial_layers``, ``boundary.ends``)."""
    m, g = scene.mesh, scene.geometry
    if m.dim == 3 and m.tube:
        return tube_problem_3d(scene, length=g.length, n_axial=int(tube_axial_layers(scene)),
                               ends=scene.boundary.ends, comm=comm)
    if m.dim == 3:  # a user's tube (``meshes.user_tube``)
        tube = user_tube_mesh(comm, resolve(m.file, (SCENES_DIR,)), R=g.R, xi=g.xi,
                              n_contact=m.n_inner, contact_group=m.contact_group,
                              clamped_group=m.clamped_group, ends_group=m.ends_group)
        return finite_tube_problem(scene, tube, scene.boundary.ends, comm)
    return problem_on(scene, cross_section(scene, comm), comm)


def tube_problem_3d(scene: Scene, *, length: float, n_axial: int, ends: str = "roller",
                    comm: MPI.Comm = MPI.COMM_WORLD) -> TubeProblem:
    """The finite tube of length ``length`` (m) in hexahedra (``meshes.tube3d``: the scene's
    annulus, N = ``mesh.n_inner`` around, ``mesh.n_radial`` through the wall, ``n_axial``
    layers along z), degree 1, outer surface clamped and ``ends`` (``ENDS``) on z = 0, L.
    With roller ends the plane-strain fields (u_z = 0, no z dependence) are a subspace that
    K, the lumped mass and the sliding CEA's friction rows keep, so every eigenvalue of the
    2D scene in quadrilaterals (the cross-section extruded) is one of the 3D tube
    (tests/test_tube3d.py). The CEA (``studies.flutter_fe.build_operators``) couples the
    friction to the θ-rows only: about sliding along θ, the disc-shaped Coulomb cone adds
    a damping f λ₀/(ΩR) on the contact's z-dofs that it leaves out, so of a 3D tube it is
    exact for the plane-strain modes alone. ``nodes`` is the ring of contact nodes at
    z = L floor(n_axial / 2) / n_axial, ``surface`` every contact node, the ring's first
    (``forms.polar.ring_first``); clamped ends hold their rings, which are then no
    contact nodes (``forms.polar.without_held``)."""
    if ends not in ENDS:
        raise ValueError(f"ends = {ends!r}: use one of {', '.join(ENDS)}")
    if ends == "clamped" and n_axial < 2:
        raise ValueError(f"n_axial = {n_axial} with clamped ends: no ring of contact nodes "
                         "between them; use mesh.n_axial >= 2")
    if scene.mesh.degree != 1 or not scene.mesh.tube:
        raise ValueError("the 3D tube is the structured annulus of degree 1 extruded "
                         "(mesh.degree = 1, no mesh.file)")
    g = scene.geometry
    tube = tube_mesh_3d(comm, R=g.R, xi=g.xi, length=length, n_inner=scene.mesh.n_inner,
                        n_axial=n_axial, n_radial=scene.mesh.n_radial)
    return finite_tube_problem(scene, tube, ends, comm)


def finite_tube_problem(scene: Scene, tube, ends: str,  # noqa: ANN001 - a Tube3DMesh
                        comm: MPI.Comm) -> TubeProblem:
    """The problem on the 3D tube mesh ``tube`` (the built-in one or a user's) with ``ends``
    held on the facets ``END0_TAG`` and ``END1_TAG``: ``nodes`` the ring of contact nodes at
    its middle level, ``surface`` every contact node that the ends do not hold, the ring's
    first, with its ring-major index (``tube_problem_3d``)."""
    fixed = [(tag, ENDS[ends]) for tag in (END0_TAG, END1_TAG)]
    problem = problem_on(scene, tube, comm, fixed=fixed)
    z_mid = float(tube.levels[tube.n_axial // 2])  # a ring's exact z (snapped)
    ring = contact_nodes(problem.V, tube.facet_tags, INNER_TAG, z_level=z_mid)
    surface = without_held(problem.nodes, problem.end_held, comm)  # clamped: less the ends
    problem.surface = ring_first(_ring_major(problem, surface, tube), ring)
    problem.nodes = ring
    return problem


def _ring_major(problem: TubeProblem, surface: ContactNodes,
                tube) -> ContactNodes:  # noqa: ANN001 - Tube3DMesh
    """The contact surface's nodes with their partition-free global index ring-major:
    level x N + the angle's rank (the nearest of the tube's ``levels`` and ``angles``), so
    that a ring's nodes are consecutive (the 1-2-1 filter's neighbours).
    The index runs over every level, 0 .. (n_axial + 1) N - 1, the held end rings of
    clamped ends included (they are no contact nodes: ``forms.polar.without_held``)."""
    n, levels, angles = tube.n_inner, tube.levels, tube.angles
    z = problem.V.tabulate_dof_coordinates()[surface.nodes, 2]
    level = np.searchsorted((levels[1:] + levels[:-1]) / 2.0, z)  # the nearest ring
    around = np.append(angles, angles[0] + 2.0 * math.pi)
    angle = np.searchsorted((around[1:] + around[:-1]) / 2.0, surface.theta) % n
    return replace(surface, global_node_index=(level * n + angle).astype(np.int64))


def problem_on(scene: Scene, tube, comm: MPI.Comm,  # noqa: ANN001 - TubeMesh or Tube3DMesh
               fixed: list[tuple[int, tuple[int, ...]]] = ()) -> TubeProblem:
    """The problem on the mesh ``tube`` (tags ``INNER_TAG``: contact, ``OUTER_TAG``:
    clamped): the Lagrange space of the scene's degree with the mesh's dimension, K, the
    lumped mass, the clamped dofs (every component on ``OUTER_TAG``, and each (tag,
    components) of ``fixed``, which are also ``end_held``) and the contact nodes."""
    m = scene.mesh
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
    ends = [_tag_dofs(V, tube.facet_tags, tag, parts) for tag, parts in fixed if parts]
    held = [_tag_dofs(V, tube.facet_tags, OUTER_TAG, range(bs)), *ends]
    clamped = np.unique(np.concatenate(held))
    clamped = np.sort(clamped[clamped < n_owned])
    inv_mass = 1.0 / mass
    inv_mass[clamped] = 0.0
    nodes = contact_nodes(V, tube.facet_tags, INNER_TAG)
    end_held = np.unique(np.concatenate(ends)) if ends else np.zeros(0, dtype=np.int32)
    return TubeProblem(scene, tube, V, material, K, mass, inv_mass, clamped, nodes, comm,
                       end_held=end_held[end_held < n_owned].astype(np.int32))


def _tag_dofs(V: dolfinx.fem.FunctionSpace, facet_tags: dolfinx.mesh.MeshTags, tag: int,
              parts) -> np.ndarray:  # noqa: ANN001 - an iterable of components
    """The local dofs of the components ``parts`` at the nodes of the facets ``tag``."""
    msh = V.mesh
    bs = V.dofmap.index_map_bs
    blocks = dolfinx.fem.locate_dofs_topological(V, msh.topology.dim - 1,
                                                 facet_tags.find(tag))
    return (blocks[:, None] * bs + np.asarray(list(parts))[None, :]).ravel()


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
