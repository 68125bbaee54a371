"""Complex eigenvalue analysis (CEA) of the FE steady sliding state: ``stickslip flutter-fe``.

Linearisation (paper section 2, sliding regime of the nodal law used by ``solver.newmark``):
every contact node ``i`` stays in contact and slips forward, so in its rotated frame
``ũ = Tᵀu`` (the trick of ``forms.steady``)

* ``ũ_r,i = d``: the radial dof is eliminated (its perturbation is 0);
* the normal reaction is ``λ_i = (K̂ũ)_r,i + m_i ü_r,i = (K̂ũ)_r,i`` (``K̂ = TᵀKT``; with the
  lumped mass ``ü_r,i = 0`` drops out) and the tangential one is ``f λ_i``, so the θ-row
  becomes ``row_θ − f row_r``: ``K + K_f`` with the non-symmetric friction stiffness
  ``K_f = −f E K̂`` (``E`` copies r-rows onto θ-rows).

On the free dofs (outer circle clamped, contact radial dofs removed) this gives
``A = K + K_f`` and ``(K + K_f) φ = μ M φ`` (``M`` = the solver's lumped mass, or
``L TᵀM_cT`` with the consistent one). It does not depend on ``d`` or ``Ω``: only on the
mesh, material and ``f``.

Kelvin–Voigt damping ``C = τK`` (scene ``[damping]``, ``solver.ensemble.ArrayColumns``):
the transient's internal force is ``K(u + τu̇)`` on every dof, and the contact projection
takes the normal reaction from it, so the viscous force enters ``λ_i`` and the friction
force as well: the damping matrix of the linearised system is ``τA``, and

    ``λ² M φ + τλ A φ + A φ = 0``  ⇔  ``A φ = μ M φ`` with ``λ² + τμλ + μ = 0``.

The quadratic eigenproblem is therefore solved exactly through the undamped pencil: same
eigenvectors, and each ``μ`` gives the root ``λ`` of ``λ² + τμλ + μ = 0`` with the larger
real part (the growing or least damped motion); for small ``τ``,
``Re λ ≈ Re λ₀ − τ Re μ / 2``. Undamped (``τ = 0``), ``λ = ±i√μ``: a complex pair
``μ, conj(μ)`` is one growing travelling wave (growth ``Re λ > 0``) and one decaying wave
travelling the other way. ``tests/test_flutter_fe.py`` checks this reduction against the
dense quadratic eigenproblem.

Solver: SLEPc Krylov-Schur, GNHEP, shift-and-invert (MUMPS LU, pivot threshold 0.5) with
real targets ``σ = ω_t²`` marching through ``[0, (2π f_max)²]`` in slices; each slice is
accepted only where its disc of converged eigenvalues covers the strip of flutter
eigenvalues (see :func:`band_eigenvalues`). Verification and findings: docs/flutter.md.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable
from dataclasses import asdict, dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from stickslip.solver.contact import ContactLaw, SpatialFilter

if TYPE_CHECKING:
    from mpi4py import MPI
    from petsc4py import PETSc

    from stickslip.solver.problem import TubeProblem
    from stickslip.solver.scene import Scene


TARGET_STEP = 0.7  # next target: this many half-widths of the last slice above its end
_PREFIX = "stickslip_cea_"  # PETSc options prefix of the CEA eigensolver
STRIP_SAFETY = 1.3  # strip half-height H = this × the largest |Im ω²| found in a disc
REAL_TOL = 1e-9  # |Im ω²| <= REAL_TOL |ω²|: a real eigenvalue (stable, or f = 0)


# --------------------------------------------------------------------------------- operators


@dataclass
class CEAOperators:
    """Free-dof matrices of the linearised sliding problem: ``A(f) = Kt + f Kf``, mass ``B``."""

    Kt: PETSc.Mat  # K̂ on the free dofs (symmetric)
    Kf: PETSc.Mat  # −E K̂ on the free dofs (unit friction stiffness)
    B: PETSc.Mat  # lumped (diagonal) or L·M̂_c (consistent) mass on the free dofs
    free: np.ndarray  # owned local dof indices (rotated frame) kept in the eigenproblem
    pos_theta: np.ndarray  # positions of the owned contact θ-dofs in the free numbering
    theta: np.ndarray  # angles of the owned contact nodes
    n_contact: int  # contact nodes around the circle N (all ranks; per level in 3D)
    radius: float
    mass_kind: str
    friction: str = "nodal"  # friction law on the reactions: 'nodal' or '1-2-1'
    consistent_friction_mass: PETSc.Mat | None = None  # −E M̂_c (consistent mass only)
    comm: Any = None
    #: the z-level of each owned contact node (0 … levels − 1; all 0 in 2D) and the levels
    level: np.ndarray | None = None
    levels: int = 1

    @property
    def n_free(self) -> int:
        return int(self.Kt.getSize()[0])

    def operator(self, f: float) -> PETSc.Mat:
        """``K + K_f`` for friction coefficient ``f`` (a new matrix)."""
        A = self.Kt.copy()
        if f != 0.0:
            A.axpy(f, self.Kf)
        return A

    def mass(self, f: float) -> PETSc.Mat:
        """The mass matrix (with the friction row-combination for the consistent mass)."""
        if self.consistent_friction_mass is None or f == 0.0:
            return self.B
        Bf = self.B.copy()
        Bf.axpy(f, self.consistent_friction_mass)
        return Bf

    def destroy(self) -> None:
        for m in (self.Kt, self.Kf, self.B, self.consistent_friction_mass):
            if m is not None:
                m.destroy()


#: The friction filters by their scene name, and their weights (``SpatialFilter``).
FRICTION_FILTERS = {kind.value: kind.weights for kind in SpatialFilter}


def _friction_rows(K: PETSc.Mat, nd: Any, weights: tuple[float, float, float]) -> PETSc.Mat:
    """``E_s``: the θ-row of contact node i takes ``w₋ r-row(i−1) + w₀ r-row(i) + w₊ r-row(i+1)``
    (neighbours in angle along the contact circle, across ranks): the friction force on node
    i is f × the filtered nodal normal reactions (``friction.filter = "1-2-1"``,
    docs/friction_filter.md)."""
    from petsc4py import PETSc

    comm = K.getComm().tompi4py()
    rstart = K.getOwnershipRange()[0]
    theta = np.concatenate(comm.allgather(np.asarray(nd.theta, dtype=float)))
    gcol = np.concatenate(comm.allgather((rstart + nd.dofs_x).astype(np.int64)))
    order = np.argsort(theta, kind="stable")
    pos = np.empty_like(order)
    pos[order] = np.arange(order.size)
    sizes = comm.allgather(len(nd.theta))
    first = int(sum(sizes[: comm.rank]))  # this rank's nodes in the gathered arrays
    mine = pos[first: first + len(nd.theta)]
    m = order.size
    cols = np.stack([gcol[order[(mine + off) % m]] for off in (-1, 0, 1)], axis=1)
    vals = np.broadcast_to(np.asarray(weights, dtype=float), cols.shape).copy()
    srt = np.argsort(cols, axis=1)
    cols = np.take_along_axis(cols, srt, axis=1)
    vals = np.take_along_axis(vals, srt, axis=1)
    n_loc = K.getSizes()[0][0]
    counts = np.zeros(n_loc, dtype=PETSc.IntType)
    counts[nd.dofs_y] = 3
    indptr = np.zeros(n_loc + 1, dtype=PETSc.IntType)
    np.cumsum(counts, out=indptr[1:])
    J = np.zeros(indptr[-1], dtype=PETSc.IntType)
    A = np.zeros(indptr[-1], dtype=PETSc.ScalarType)
    rows = np.argsort(nd.dofs_y)  # CSR rows in increasing dof order
    for j in range(3):
        J[indptr[nd.dofs_y[rows]] + j] = cols[rows, j]
        A[indptr[nd.dofs_y[rows]] + j] = vals[rows, j]
    mat = PETSc.Mat().createAIJ(size=K.getSizes(), csr=(indptr, J, A), comm=K.getComm())
    mat.assemble()
    return mat


def build_operators(
    problem: TubeProblem, mass: str = "lumped", friction: str = "nodal"
) -> CEAOperators:
    """Rotate the contact nodes, split off the friction part, restrict to the free dofs.

    ``mass="lumped"`` (default) is ``problem.mass``, the explicit solver's mass, so CEA and
    the transient describe the same discrete system; ``"consistent"`` uses ``∫ρφ_i·φ_j``.
    ``friction="nodal"`` (default, the transient's law) applies ``f λ_i`` at node i;
    ``"1-2-1"`` applies ``f (λ_{i−1} + 2λ_i + λ_{i+1})/4``, the transient's law with
    ``friction.filter = "1-2-1"`` (removes the spurious mesh-scale flutter branch; an O(h²)
    change, docs/friction_filter.md).
    """
    from petsc4py import PETSc

    if mass not in ("lumped", "consistent"):
        raise ValueError(f"mass={mass!r}: use 'lumped' or 'consistent'")
    if friction not in FRICTION_FILTERS:
        raise ValueError(f"friction={friction!r}: use one of {sorted(FRICTION_FILTERS)}")
    comm = problem.comm
    K, nd = problem.K, problem.every_contact_node
    rstart = K.getOwnershipRange()[0]
    frame = _ContactFrame(problem, friction)
    Khat = K.ptap(frame.T)
    Kf = frame.friction_part(Khat)  # = −E K̂
    free = _free_dofs(problem)
    iset = PETSc.IS().createGeneral((rstart + free).astype(PETSc.IntType), comm=comm)
    Kt_f = Khat.createSubMatrix(iset, iset)
    Kf_f = Kf.createSubMatrix(iset, iset)
    if mass == "lumped":
        B, friction_mass = _lumped_mass(problem, Kt_f, free), None
    else:
        B, friction_mass = _consistent_mass(problem, frame, iset)
    for m in (Khat, Kf, iset):
        m.destroy()
    frame.destroy()
    level, levels = contact_levels(problem)
    return CEAOperators(
        Kt=Kt_f, Kf=Kf_f, B=B, free=free,
        pos_theta=np.searchsorted(free, nd.dofs_y), theta=nd.theta,
        n_contact=nd.n_global // levels, radius=problem.scene.geometry.R, mass_kind=mass,
        friction=friction,
        consistent_friction_mass=friction_mass, comm=comm, level=level, levels=levels,
    )


def contact_levels(problem: TubeProblem) -> tuple[np.ndarray, int]:
    """(level of each owned contact node, number of levels): the distinct z of the contact
    surface's nodes, in order (a 3D tube: N_z + 1 rings of N nodes); one level in 2D."""
    nd = problem.every_contact_node
    xyz = problem.V.tabulate_dof_coordinates()[nd.nodes]
    if problem.V.mesh.geometry.dim < 3:
        return np.zeros(nd.n_owned, dtype=np.int64), 1
    scale = max(*problem.comm.allgather(float(np.abs(xyz[:, 2]).max(initial=0.0))), 1e-300)
    keys = np.round(xyz[:, 2] / scale * 1e9).astype(np.int64)
    every = np.unique(np.concatenate(problem.comm.allgather(keys)))
    return np.searchsorted(every, keys).astype(np.int64), int(every.size)


@dataclass
class ContactGrid:
    """A field on the contact surface unrolled: ``values[level, j]`` at the angle ``theta[j]``
    (rad, ``2πj/N`` in ``[0, 2π)``) and the height ``z_rel[level]`` = z/L of its ring (the
    rings are equally spaced, ``tube_mesh_3d``; one ring at 0 in 2D)."""

    theta: np.ndarray  # (N,)
    z_rel: np.ndarray  # (levels,)
    values: np.ndarray  # (levels, N), complex


def contact_grid(ops: CEAOperators, free_vec: np.ndarray, normalise: bool = True
                 ) -> ContactGrid:
    """ψ_θ of a free-dof vector (owned entries) on the (θ, z) grid of every contact node (all
    ranks; collective), grouped in rings by ``contact_levels`` as ``axial_order`` groups them,
    ``normalise``d: ``max |ψ_θ| = 1`` and ``ψ_θ`` real > 0 at that node. ψ_θ, not ψ_r: the
    sliding linearisation holds each contact node on the cylinder (``ψ_r = 0`` there)."""
    comm = ops.comm
    level = np.zeros(ops.theta.size, dtype=np.int64) if ops.level is None else ops.level
    theta = np.concatenate(comm.allgather(np.mod(np.asarray(ops.theta, dtype=float),
                                                 2 * math.pi)))
    rings = np.concatenate(comm.allgather(level))
    psi = np.concatenate(comm.allgather(np.asarray(free_vec)[ops.pos_theta]))
    n = ops.n_contact
    column = np.rint(theta / (2 * math.pi / n)).astype(np.int64) % n
    hits = np.zeros((ops.levels, n), dtype=np.int64)
    np.add.at(hits, (rings, column), 1)
    if not np.all(hits == 1):
        raise ValueError("the contact nodes are not N equally spaced angles on each ring "
                         "(a structured tube's contact surface)")
    values = np.zeros((ops.levels, n), dtype=complex)
    values[rings, column] = psi
    peak = values.flat[int(np.argmax(np.abs(values)))]
    if normalise and peak != 0:
        values = values / peak
    z_rel = np.linspace(0.0, 1.0, ops.levels) if ops.levels > 1 else np.zeros(1)
    return ContactGrid(theta=2 * math.pi * np.arange(n) / n, z_rel=z_rel, values=values)


class _ContactFrame:
    """The contact nodes' polar frame, u = T ũ (ũ = (ũ_r, ũ_θ) at the contact nodes), and the
    friction row-combination E: the θ-row of node i takes f × the r-row (nodal law, through
    ``L1`` = row_θ − 1·row_r) or f × the filtered r-rows of i − 1, i, i + 1 (``E_s``)."""

    def __init__(self, problem: TubeProblem, friction: str) -> None:
        from petsc4py import PETSc

        # dolfinx on first use: the command line imports this package at start
        from stickslip.forms.steady import node_matrix

        K, nd = problem.K, problem.every_contact_node
        rows_x = (K.getOwnershipRange()[0] + nd.dofs_x).astype(PETSc.IntType)
        c, s = nd.cos_t, nd.sin_t
        one, zero = np.ones_like(c), np.zeros_like(c)
        self.T = node_matrix(K, rows_x, nd.dofs_x, (c, -s, s, c))  # u = T ũ
        self.L1 = node_matrix(K, rows_x, nd.dofs_x, (one, zero, -one, one))  # row_θ − row_r
        self.Es = None if FRICTION_FILTERS[friction] is None else \
            _friction_rows(K, nd, FRICTION_FILTERS[friction])

    def friction_part(self, Xhat: PETSc.Mat) -> PETSc.Mat:
        """−E X̂ (a new matrix) for a rotated operator X̂ = Tᵀ X T."""
        if self.Es is None:
            Xf = self.L1.matMult(Xhat)
            Xf.axpy(-1.0, Xhat)  # = −E X̂
        else:
            Xf = self.Es.matMult(Xhat)
            Xf.scale(-1.0)  # = −E_s X̂
        return Xf

    def destroy(self) -> None:
        for m in (self.T, self.L1, self.Es):
            if m is not None:
                m.destroy()


def _free_dofs(problem: TubeProblem) -> np.ndarray:
    """Owned local dofs of the eigenproblem: not clamped, not ũ_r at a contact node (= d,
    eliminated)."""
    keep = np.ones(problem.n_owned, dtype=bool)
    keep[problem.clamped] = False
    keep[problem.every_contact_node.dofs_x] = False  # ũ_r = d: eliminated
    return np.flatnonzero(keep)


def _lumped_mass(problem: TubeProblem, Kt_f: PETSc.Mat, free: np.ndarray) -> PETSc.Mat:
    """B = the explicit solver's lumped mass on the free dofs (diagonal; rotation-invariant)."""
    from petsc4py import PETSc

    B = PETSc.Mat().createAIJ(size=Kt_f.getSizes(), nnz=(1, 0), comm=problem.comm)
    B.setUp()
    diag = Kt_f.createVecLeft()
    diag.getArray()[:] = problem.mass[free]
    B.setDiagonal(diag)
    B.assemble()
    diag.destroy()
    return B


def _consistent_mass(problem: TubeProblem, frame: _ContactFrame,
                     iset: PETSc.IS) -> tuple[PETSc.Mat, PETSc.Mat]:
    """(M̂_c, −E M̂_c) on the free dofs: the consistent mass ∫ρφ_i·φ_j rotated, and its friction
    row-combination (the θ-rows of the contact nodes carry the friction's inertia)."""
    import dolfinx
    import dolfinx.fem.petsc
    import ufl

    # dolfinx on first use: the command line imports this package at start
    from stickslip.forms.elasticity import mass as mass_form

    u, v = ufl.TrialFunction(problem.V), ufl.TestFunction(problem.V)
    Mc = dolfinx.fem.petsc.assemble_matrix(
        dolfinx.fem.form(mass_form(u, v, problem.material.rho))
    )
    Mc.assemble()
    Mhat = Mc.ptap(frame.T)
    Mf = frame.friction_part(Mhat)
    B = Mhat.createSubMatrix(iset, iset)
    friction_mass = Mf.createSubMatrix(iset, iset)
    for m in (Mc, Mhat, Mf):
        m.destroy()
    return B, friction_mass


# --------------------------------------------------------------------------------- eigensolver


@dataclass
class BandStats:
    """How the band was covered: slices, solves, eigenpairs converged, strip, wall time."""

    slices: int = 0
    solves: int = 0
    converged: int = 0
    strip_half_height: float = 0.0  # largest H = safety × max |Im ω²| used
    max_residual: float = 0.0  # largest ||A x − μ B x|| / (|μ| ||x||) accepted
    seconds: float = 0.0


def _slice_solve(A: PETSc.Mat, B: PETSc.Mat, sigma: float, nev: int, tol: float):
    """Shift-and-invert Krylov-Schur (GNHEP, MUMPS LU): the ``nev`` eigenvalues nearest the
    real target ``sigma`` (``TARGET_MAGNITUDE``: the order in which Krylov resolves them)."""
    from petsc4py import PETSc
    from slepc4py import SLEPc

    eps = SLEPc.EPS().create(A.getComm())
    eps.setOptionsPrefix(_PREFIX)
    eps.setOperators(A, B)
    eps.setProblemType(SLEPc.EPS.ProblemType.GNHEP)
    eps.setType(SLEPc.EPS.Type.KRYLOVSCHUR)
    eps.setTarget(sigma)
    eps.setWhichEigenpairs(SLEPc.EPS.Which.TARGET_MAGNITUDE)
    st = eps.getST()
    st.setType(SLEPc.ST.Type.SINVERT)
    ksp = st.getKSP()
    ksp.setType("preonly")
    pc = ksp.getPC()
    pc.setType("lu")
    pc.setFactorSolverType("mumps")
    # A − σB is indefinite and non-symmetric: MUMPS' default pivot threshold (0.01) loses
    # up to 1e-5 of accuracy on it (measured, cond = 53), which SLEPc's Krylov residual
    # estimate does not see. Threshold 0.5 (near partial pivoting) solves it to round-off.
    opts = PETSc.Options()
    opts.setValue(f"{_PREFIX}st_mat_mumps_cntl_1", 0.5)
    eps.setFromOptions()
    n = A.getSize()[0]
    nev = min(nev, n)
    eps.setDimensions(nev, min(n, max(2 * nev, nev + 32)), PETSc.DECIDE)
    eps.setTolerances(tol, 2000)
    eps.solve()
    return eps, nev


def band_eigenvalues(
    A: PETSc.Mat,
    B: PETSc.Mat,
    mu_max: float,
    *,
    nev_slice: int = 64,
    tol: float = 1e-10,
    contact_pos: np.ndarray | None = None,
    strip_safety: float = STRIP_SAFETY,
    keep_vector: Callable[[complex], bool] | None = None,
    vectors: dict[int, np.ndarray] | None = None,
    keep_most: tuple[int, Callable[[complex], float]] | None = None,
) -> tuple[np.ndarray, np.ndarray, BandStats]:
    """All eigenvalues ``μ`` of ``A φ = μ B φ`` with ``Re μ ≤ mu_max`` (slices along Re μ).

    A shift-and-invert solve at the real target ``σ`` returning the ``nev`` eigenvalues
    nearest ``σ`` leaves none out (up to Krylov convergence) in the disc ``|μ − σ| < ρ``
    (``ρ`` = distance of the ``nev``-th). The eigenvalues lie in a strip ``|Im μ| ≤ H``
    around the real axis (flutter: ``Im μ = −2σ_g ω``); ``H`` = ``strip_safety`` × the largest
    ``|Im μ|`` found in the disc, and no lower than the lower slices' ``H``, and the disc must
    reach above it (``ρ > H``, else ``nev`` doubles). The disc then covers the strip on
    ``Re μ ∈ σ ± √(ρ² − H²)``: slices are accepted there only, march upwards from
    ``lo = −0.02 mu_max`` (first target ``lo``, next ``0.7`` half-width above the covered
    end), and a slice that does not reach back to ``lo`` is redone nearer. Each accepted
    pair's relative residual is checked (< 1e-6, recorded).
    Returns ``μ`` (complex), the eigenvectors at ``contact_pos`` (owned entries; rows =
    eigenvalues) and statistics. With ``keep_vector`` and ``vectors``, the whole owned
    eigenvector of each ``μ`` with ``keep_vector(μ)`` goes into ``vectors`` under its index
    in the returned array (mode shapes: the band may hold thousands), with ``keep_most =
    (count, score)`` only the ``count`` of the largest ``score(μ)`` (a 3D tube's are large).
    """
    t0 = time.perf_counter()
    stats, n = BandStats(), A.getSize()[0]
    found = _BandPairs(A, contact_pos, keep_vector, keep_most)
    lo = -0.02 * mu_max
    sigma, nev = lo, nev_slice
    while lo < mu_max:
        if stats.solves > 50 + 8 * n // max(nev_slice, 1):
            raise RuntimeError(f"band_eigenvalues: no progress after {stats.solves} solves")
        eps, nev = _slice_solve(A, B, sigma, nev, tol)
        stats.solves += 1
        nconv = eps.getConverged()
        mu = np.array([complex(eps.getEigenvalue(i)) for i in range(nconv)])
        dist = np.abs(mu - sigma)
        order = np.argsort(dist, kind="stable")
        everything = nconv >= n
        if nconv < nev and not everything:
            eps.destroy()
            nev = min(2 * nev, n)  # not converged: a bigger subspace
            continue
        inside = order if everything else order[:nev]
        # open disc, shrunk by 1e-9: the nev-th may have an unreturned twin at equal distance
        rho = math.inf if everything else float(dist[order[nev - 1]]) * (1.0 - 1e-9)
        # at least as tall as the lower slices found it: a disc smaller than the tallest
        # eigenvalues sees none of them (a 3D tube's crowded band: tests/test_tube3d.py)
        strip = max(_strip_half_height(mu[inside], sigma, rho, strip_safety),
                    stats.strip_half_height)
        if not everything and rho <= strip:
            eps.destroy()
            nev = min(2 * nev, n)
            continue
        stats.strip_half_height = max(stats.strip_half_height, strip)
        half = math.sqrt(rho * rho - strip * strip) if not everything else math.inf
        if sigma - half >= lo:  # the cover does not reach back to ``lo``: target lower
            eps.destroy()
            sigma = lo + 0.9 * half
            continue
        hi = sigma + half
        for i in inside:
            if lo <= mu[i].real < hi:
                found.take(eps, int(i), mu[i], stats)
        eps.destroy()
        stats.slices += 1
        stats.converged += nconv
        if everything:
            break
        lo = hi
        sigma, nev = hi + TARGET_STEP * half, nev_slice if nev <= nev_slice else nev
    stats.seconds = time.perf_counter() - t0
    return (*found.result(mu_max, vectors), stats)


def _strip_half_height(mu: np.ndarray, sigma: float, rho: float, strip_safety: float) -> float:
    """H of the strip |Im μ| ≤ H covered by a slice's disc |μ − σ| < ρ (``band_eigenvalues``;
    ρ = ∞: the solve returned the whole spectrum).

    safety × max |Im μ| over the disc, then lowered to the eigenvalues of the slice's own
    Re-interval while that stays consistent (a lower strip widens the interval, which must
    not take in a taller eigenvalue).
    """
    im, re = np.abs(mu.imag), np.abs(mu.real - sigma)
    strip = strip_safety * float(np.max(im, initial=0.0))
    for _ in range(4):
        if math.isinf(rho) or rho <= strip:  # the whole spectrum, or no strip to lower
            break
        half = math.sqrt(rho * rho - strip * strip)
        lower = strip_safety * float(np.max(im[re <= half], initial=0.0))
        if lower >= strip:
            break
        wider = math.sqrt(rho * rho - lower * lower)
        if strip_safety * float(np.max(im[re <= wider], initial=0.0)) > lower:
            break
        strip = lower
    return strip


class _BandPairs:
    """The accepted eigenpairs of ``band_eigenvalues``: μ, the eigenvector at the contact
    positions, and the whole eigenvector where ``keep_vector(μ)``."""

    def __init__(self, A: PETSc.Mat, contact_pos: np.ndarray | None,
                 keep_vector: Callable[[complex], bool] | None,
                 keep_most: tuple[int, Callable[[complex], float]] | None = None) -> None:
        self.contact_pos, self.keep_vector, self.keep_most = contact_pos, keep_vector, keep_most
        self.pos = np.zeros(0, dtype=np.int64) if contact_pos is None else contact_pos
        self.vr, self.vi = A.createVecRight(), A.createVecRight()
        self.mus: list[complex] = []
        self.vecs: list[np.ndarray] = []
        self.full: dict[int, np.ndarray] = {}

    def take(self, eps: Any, i: int, m: complex, stats: BandStats) -> None:
        """Accept pair i of the solve (its relative residual checked < 1e-6, recorded)."""
        from slepc4py import SLEPc

        err = eps.computeError(i, SLEPc.EPS.ErrorType.RELATIVE)
        stats.max_residual = max(stats.max_residual, err)
        if err > 1e-6:
            raise RuntimeError(f"eigenpair {m} has relative residual {err:.2g}")
        self.mus.append(m)
        if self.contact_pos is not None or self.keep_vector is not None:  # collective
            vr, vi, pos = self.vr, self.vi, self.pos
            eps.getEigenpair(i, vr, vi)
            self.vecs.append(vr.getArray()[pos] + 1j * vi.getArray()[pos])
            if self.keep_vector is not None and self.keep_vector(m):
                self.full[len(self.mus) - 1] = vr.getArray() + 1j * vi.getArray()
                self._evict()

    def _evict(self) -> None:
        """Drop the kept vector of the smallest score while more than ``keep_most``'s count
        are held."""
        if self.keep_most is None:
            return
        count, score = self.keep_most
        while len(self.full) > count:
            del self.full[min(self.full, key=lambda i: score(self.mus[i]))]

    def result(self, mu_max: float,
               vectors: dict[int, np.ndarray] | None) -> tuple[np.ndarray, np.ndarray]:
        """(μ, contact eigenvectors) with Re μ ≤ mu_max; the kept whole eigenvectors into
        ``vectors`` under their new indices. Frees the work vectors."""
        self.vr.destroy()
        self.vi.destroy()
        mu_arr = np.array(self.mus, dtype=complex)
        keep = mu_arr.real <= mu_max
        vecs = self.vecs
        width = self.pos.size if self.contact_pos is not None else 0
        V = np.array(vecs, dtype=complex).reshape(len(vecs), width) if vecs else \
            np.zeros((mu_arr.size, width), dtype=complex)
        if vectors is not None:
            new_index = np.cumsum(keep) - 1
            vectors.update({int(new_index[i]): v for i, v in self.full.items() if keep[i]})
        return mu_arr[keep], V[keep]


# --------------------------------------------------------------------------------- regularised


def _scipy(mat: PETSc.Mat) -> Any:
    from scipy.sparse import csr_matrix

    indptr, indices, data = mat.getValuesCSR()
    return csr_matrix((data, indices, indptr), shape=mat.getSize())


def _regularised_matrices(ops: CEAOperators, f: float, tau: float, t_star: float,
                          w0: float) -> list[PETSc.Mat]:
    """``[A₀, A₁, A₂]`` of the (u, ŝ) quadratic problem in ``λ̂ = λ/w0`` (see
    :func:`regularised_band`), ``s = κ ŝ`` with ``κ`` the mean diagonal of ``K``."""
    import scipy.sparse as sp
    from petsc4py import PETSc

    K, Kf = _scipy(ops.Kt), _scipy(ops.Kf)
    M = sp.diags(ops.B.getDiagonal().getArray().copy())
    n, pos = K.shape[0], ops.pos_theta
    n_c = pos.size
    kappa = float(np.mean(np.abs(K.diagonal())))
    H = -Kf[pos, :] / kappa  # p̃ / κ
    G = sp.csr_matrix((np.full(n_c, kappa), (pos, np.arange(n_c))), shape=(n, n_c))
    eye, zero = sp.identity(n_c), sp.csr_matrix((n_c, n_c))
    blocks = (
        sp.bmat([[K, -f * G], [-H, eye]]),
        sp.bmat([[tau * w0 * K, None], [-tau * w0 * H, t_star * w0 * eye]]),
        sp.bmat([[w0 * w0 * M, None], [None, zero]]),
    )
    mats = []
    for b in blocks:
        b = b.tocsr()
        b.sort_indices()
        mats.append(PETSc.Mat().createAIJ(size=b.shape, csr=(b.indptr, b.indices, b.data),
                                          comm=PETSc.COMM_SELF))
    return mats


def _pep_solve(mats: list[PETSc.Mat], nev: int, tol: float) -> Any:
    """SLEPc PEP (TOAR, shift-and-invert at 0 with MUMPS): the ``nev`` eigenvalues nearest 0."""
    from petsc4py import PETSc
    from slepc4py import SLEPc

    pep = SLEPc.PEP().create(PETSc.COMM_SELF)
    pep.setOptionsPrefix(_PREFIX)
    pep.setOperators(mats)
    pep.setProblemType(SLEPc.PEP.ProblemType.GENERAL)
    pep.setType(SLEPc.PEP.Type.TOAR)
    pep.setTarget(0.0)
    pep.setWhichEigenpairs(SLEPc.PEP.Which.TARGET_MAGNITUDE)
    st = pep.getST()
    st.setType(SLEPc.ST.Type.SINVERT)
    ksp = st.getKSP()
    ksp.setType("preonly")
    ksp.getPC().setType("lu")
    ksp.getPC().setFactorSolverType("mumps")
    PETSc.Options().setValue(f"{_PREFIX}st_mat_mumps_cntl_1", 0.5)  # as in _slice_solve
    pep.setFromOptions()
    size = mats[0].getSize()[0]
    pep.setDimensions(nev, min(2 * size, max(2 * nev, nev + 32)), PETSc.DECIDE)
    pep.setTolerances(tol, 1000)
    pep.solve()
    return pep


def regularised_band(
    ops: CEAOperators, f: float, tau: float, t_star: float, fmax_hz: float, *,
    tol: float = 1e-10, keep_vector: bool = False,
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, BandStats]:
    """Every exponent ``λ`` with ``|λ| < 1.05 ω_max`` of the sliding system with a regularised
    friction bound (SLEPc PEP, one rank).

    The friction force of contact node ``i`` is ``f s_i``, and its bound relaxes towards the
    (filtered) normal reaction: ``t* ṡ = p̃ − s`` (``solver.contact.EffectivePressure``
    linearised; ``p̃ = H(u + τu̇)``, ``H = −K_f`` on the contact θ-rows). With ``G`` the
    injection of ``s_i`` into the θ-row of node ``i``, ``(u, s)`` obeys the quadratic problem

        ``λ² [[M, 0], [0, 0]] + λ [[τK, 0], [−τH, t* I]] + [[K, −f G], [−H, I]]``

    (``t* → 0`` gives back ``λ²M + (1 + τλ)(K + f K_f)``), scaled to ``λ = ω_max λ̂`` and
    ``s = κ ŝ`` so that the blocks are O(1). Krylov with shift-and-invert at 0 returns the
    eigenvalues nearest 0 first, so ``nev`` doubles until the last one returned lies beyond
    the band (or the whole finite spectrum, ``2n + n_c``, is in); each accepted pair's
    backward error must be < 1e-8. The band is the disc: a mode of frequency ≤ f_max outside
    it would grow faster than 0.3 ω. Outside lie the relaxation modes near ``−1/t*`` (when
    ``1/t* > 1.05 ω_max``) and the infinite eigenvalues of the massless ``s`` block
    (returned as huge finite numbers). Returns ``λ`` (``Im λ ≥ 0``), ψ_θ at the contact
    nodes (rows), the free-dof ``u`` parts (if ``keep_vector``) and statistics.
    """
    from slepc4py import SLEPc

    t0 = time.perf_counter()
    stats = BandStats(slices=1)
    w0 = 2.0 * math.pi * fmax_hz
    mats = _regularised_matrices(ops, f, tau, t_star, w0)
    n, pos = ops.n_free, ops.pos_theta
    finite_count = 2 * n + pos.size
    radius, nev = 1.05, min(64, finite_count)
    while True:
        pep = _pep_solve(mats, nev, tol)
        stats.solves += 1
        nconv = pep.getConverged()
        lam = np.array([complex(pep.getEigenpair(i)) for i in range(nconv)])
        size = np.sort(np.abs(lam[np.isfinite(lam)]))
        if (size.size >= nev and size[nev - 1] > radius) or nev >= finite_count:
            break
        pep.destroy()
        nev = min(2 * nev, finite_count)
    keep = [i for i in range(nconv) if abs(lam[i]) < radius
            and lam[i].imag >= -REAL_TOL * abs(lam[i])]
    xr, xi = mats[0].createVecRight(), mats[0].createVecRight()
    psi, full = [], []
    for i in keep:
        err = pep.computeError(i, SLEPc.PEP.ErrorType.BACKWARD)
        stats.max_residual = max(stats.max_residual, err)
        if err > 1e-8:
            raise RuntimeError(f"regularised eigenpair {lam[i] * w0} has backward error "
                               f"{err:.2g}")
        pep.getEigenpair(i, xr, xi)
        x = xr.getArray()[:n] + 1j * xi.getArray()[:n]
        psi.append(x[pos])
        if keep_vector:
            full.append(x)
    stats.converged, stats.seconds = nconv, time.perf_counter() - t0
    pep.destroy()
    for m in (*mats, xr, xi):
        m.destroy()
    psi_arr = np.array(psi, dtype=complex).reshape(len(keep), pos.size)
    return lam[keep] * w0, psi_arr, (np.array(full) if keep_vector else None), stats


# --------------------------------------------------------------------------------- modes

#: A mode whose wavelength on the contact circle spans fewer element edges than this
#: (``|k| > N / MESH_SCALE_ELEMENTS``) is not resolved by the mesh. At N = 132, f = 0.7 the
#: FE per-k growth approaches the exact continuum from below up to k = 20 (6.6 elements a
#: wavelength) and exceeds the continuum's largest growth from k = 22 (6.0) on
#: (docs/continuum.md, section 4); 8 elements leaves a margin (P1 frequency error ~3 %).
MESH_SCALE_ELEMENTS = 8.0


def damped_exponents(mu: np.ndarray, tau: float) -> np.ndarray:
    """``λ`` of each eigenvalue ``μ`` of ``A φ = μ M φ`` with Kelvin–Voigt damping ``τA``.

    ``λ² + τμλ + μ = 0``; of its two roots the one with the larger real part (the growing,
    or least damped, motion of the eigenvector). ``τ = 0``: ``λ = ±i√μ``, the root with
    ``Re λ = |Im √μ| ≥ 0``.
    """
    mu = np.asarray(mu, dtype=complex)
    disc = np.sqrt((tau * mu) ** 2 - 4.0 * mu)
    first, second = 0.5 * (-tau * mu + disc), 0.5 * (-tau * mu - disc)
    return np.where(first.real >= second.real, first, second)


@dataclass(frozen=True)
class CEAMode:
    """One real motion ``u = Re(ψ e^{λt})`` of the linearised sliding system.

    ``k`` is the signed dominant wavenumber of ``ψ_θ`` on the contact circle
    (``ψ_θ ≈ A e^{ikθ}``); the wave travels at ``−ω/k`` rad/s, so ``k < 0`` is the sense of
    rotation. Stable real eigenvalues (double, ``±k``) have ``direction = "standing"``.
    ``zeta = −Re λ / |λ|`` is the damping ratio (negative: unstable).
    """

    omega2_real: float  # Re μ [rad²/s²] (eigenvalue of the undamped pencil A φ = μ M φ)
    omega2_imag: float  # Im μ (>= 0: one member of each conjugate pair)
    growth_rate: float  # Re λ [1/s], > 0 = unstable (flutter)
    frequency_hz: float  # |Im λ| / 2π >= 0
    k: int  # signed wavenumber of the growing motion's ψ_θ (contact circle DFT)
    wavenumber: int  # |k|
    purity: float  # share of the DFT power of ψ_θ in wavenumber ±|k|
    direction: str  # 'rotation' | 'opposite' | 'standing' | 'divergence'
    phase_speed_m_s: float  # −ω R / k (signed, + = rotation sense); 0 if standing
    zeta: float = 0.0  # damping ratio −Re λ / |λ| (< 0: unstable)
    elements_per_wavelength: float = math.inf  # N / |k| on the contact circle
    mesh_scale: bool = False  # elements_per_wavelength < MESH_SCALE_ELEMENTS
    axial_order: int = 0  # m: nodal rings of the mode along a 3D tube (``axial_order``)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def distinct_modes(modes: Iterable[CEAMode]) -> list[CEAMode]:
    """Modes sorted by frequency, one per degenerate (±k, f = 0) pair."""
    out: list[CEAMode] = []
    for m in sorted(modes, key=lambda m: m.frequency_hz):
        if out and abs(m.frequency_hz - out[-1].frequency_hz) <= 1e-7 * m.frequency_hz \
                and abs(m.growth_rate - out[-1].growth_rate) <= 1e-7 * m.frequency_hz:
            continue
        out.append(m)
    return out


@dataclass
class CEAResult:
    """Spectrum of one friction coefficient (modes sorted by frequency)."""

    f: float
    fmax_hz: float
    mass: str
    n_free: int
    modes: list[CEAMode]
    stats: BandStats
    scene: str = ""
    timings: dict[str, float] = field(default_factory=dict)
    tau: float = 0.0  # Kelvin–Voigt retardation time of the damping τA [s]
    friction: str = "nodal"  # friction law on the reactions: 'nodal' or '1-2-1'
    n_contact: int = 0  # contact nodes N
    t_star: float = 0.0  # relaxation time of a regularised friction bound [s] (0: Coulomb)
    levels: int = 1  # rings of contact nodes along z (a 3D tube: N_z + 1; 1 in plane strain)
    #: owned free-dof shapes ψ of the unstable modes (index in ``modes``), on request
    shapes: dict[int, np.ndarray] = field(default_factory=dict, repr=False)

    def unstable(self, rel_tol: float = 1e-7) -> list[CEAMode]:
        """Modes with growth rate > rel_tol·ω (flutter), most unstable first."""
        out = [m for m in self.modes if _is_unstable(m.growth_rate, m.frequency_hz, rel_tol)]
        return sorted(out, key=lambda m: -m.growth_rate)

    def by_wavenumber(self) -> dict[int, CEAMode]:
        """The most unstable mode of each wavenumber |k| (k ≥ 0)."""
        best: dict[int, CEAMode] = {}
        for m in self.modes:
            if m.wavenumber not in best or m.growth_rate > best[m.wavenumber].growth_rate:
                best[m.wavenumber] = m
        return dict(sorted(best.items()))

    def mesh_scale_reason(self) -> str:
        """One line: why the flagged modes are not resolved by the mesh."""
        kmax = int(self.n_contact / MESH_SCALE_ELEMENTS)
        return (f"mesh-scale modes: wavelength < {MESH_SCALE_ELEMENTS:g} elements on the contact "
                f"circle (|k| > {kmax} at N = {self.n_contact}); the FE growth of such modes "
                "departs from the exact continuum (docs/continuum.md)")

    def to_dict(self) -> dict[str, Any]:
        uns = self.unstable()
        resolved = [m for m in uns if not m.mesh_scale]
        return {
            "scene": self.scene, "f": self.f, "fmax_hz": self.fmax_hz, "mass": self.mass,
            "damping_tau_s": self.tau, "friction": self.friction,
            "friction_relaxation_time_s": self.t_star,
            "n_contact": self.n_contact, "free_dofs": self.n_free,
            "modes_in_band": len(self.modes), "unstable_count": len(uns),
            "unstable_resolved_count": len(resolved),
            "max_growth_rate_per_s": uns[0].growth_rate if uns else 0.0,
            "max_resolved_growth_rate_per_s": resolved[0].growth_rate if resolved else 0.0,
            "mesh_scale_rule": self.mesh_scale_reason(),
            "unstable": [m.to_dict() for m in uns],
            "most_unstable_per_k": {str(k): m.to_dict() for k, m in self.by_wavenumber().items()},
            "solver": asdict(self.stats), "timings_s": self.timings,
        }


def _is_unstable(growth: float, frequency_hz: float, rel_tol: float = 1e-7) -> bool:
    return growth > rel_tol * max(2 * math.pi * frequency_hz, 1.0)


def _modes(
    mu: np.ndarray, psi: np.ndarray, ops: CEAOperators, tau: float = 0.0
) -> tuple[list[CEAMode], list[int]]:
    """Growth, frequency, damping ratio, wavenumber and direction from the eigenvalues ``μ``
    and contact ψ_θ; also each mode's index in ``mu``. Modes sorted by frequency."""
    real = np.abs(mu.imag) <= REAL_TOL * np.abs(mu)
    index = np.flatnonzero(real | (mu.imag > 0))  # one eigenvalue of each conjugate pair
    mu, psi, real = mu[index], psi[index], real[index]
    lam = damped_exponents(np.where(real, mu.real + 0j, mu), tau)
    # growing motion with positive frequency has shape conj(φ) (Im μ > 0), see module doc
    shape = np.where(real[:, None], psi, np.conj(psi))
    modes = _classify(lam, shape, real, mu, ops)
    order = sorted(range(len(modes)), key=lambda i: (modes[i].frequency_hz,
                                                     -modes[i].growth_rate))
    return [modes[i] for i in order], [int(index[i]) for i in order]


def _classify(lam: np.ndarray, shape: np.ndarray, real: np.ndarray, mu: np.ndarray,
              ops: CEAOperators) -> list[CEAMode]:
    """One ``CEAMode`` per motion ``Re(ψ e^{λt})``: ``lam`` its exponent, ``shape`` its ψ_θ at
    the owned contact nodes (the positive-frequency motion), ``real`` a non-oscillating
    eigenvalue (standing or divergence), ``mu`` the ``ω²`` recorded with it."""
    n_c = ops.n_contact
    kk = np.arange(-(n_c // 2), n_c // 2 + 1)
    growth, omega = lam.real, np.abs(lam.imag)
    basis = np.exp(-1j * np.outer(ops.theta, kk))  # owned nodes × k
    level = np.zeros(ops.theta.size, dtype=np.int64) if ops.level is None else ops.level
    local = np.zeros((lam.size, ops.levels, kk.size), dtype=complex)
    for z in range(ops.levels):  # the DFT along θ on each ring of the contact surface
        on = level == z
        if shape.size and on.any():
            local[:, z] = shape[:, on] @ basis[on]
    coeff = np.zeros_like(local)
    ops.comm.Allreduce(local, coeff)
    power = (np.abs(coeff) ** 2).sum(axis=1)
    modes = []
    for i in range(lam.size):
        p = power[i]
        j = int(np.argmax(p))
        k = int(kk[j])
        m = axial_order(coeff[i, :, j])
        total = float(p.sum())
        pair = p[j] + (p[kk == -k][0] if k != 0 else 0.0)
        purity = float(pair / total) if total > 0 else 0.0
        if real[i]:
            direction = "divergence" if growth[i] > 0 and omega[i] == 0 else "standing"
            k, speed = abs(k), 0.0
        else:
            speed = -omega[i] * ops.radius / k if k != 0 else 0.0
            direction = "rotation" if speed > 0 else ("opposite" if speed < 0 else "standing")
        per_wave = n_c / abs(k) if k != 0 else math.inf
        modes.append(CEAMode(
            omega2_real=float(mu[i].real), omega2_imag=float(abs(mu[i].imag)),
            growth_rate=float(growth[i]), frequency_hz=float(omega[i] / (2 * math.pi)),
            k=k, wavenumber=abs(k), purity=purity, direction=direction,
            phase_speed_m_s=float(speed),
            zeta=float(-growth[i] / abs(lam[i])) if lam[i] != 0 else 0.0,
            elements_per_wavelength=float(per_wave),
            mesh_scale=bool(per_wave < MESH_SCALE_ELEMENTS), axial_order=m,
        ))
    return modes


#: a ring whose |a_k| is below this share of the largest does not count in ``axial_order``
AXIAL_FLOOR = 0.05


def axial_order(profile: np.ndarray) -> int:
    """The axial order m of a mode along the tube: the sign changes of its dominant
    wavenumber's coefficient a_k(z) from ring to ring, after the common phase is removed
    (a_k e^{−iφ} with φ = arg(Σ a_k²)/2, real for a standing axial shape); rings below
    ``AXIAL_FLOOR`` of the largest |a_k| are skipped. 0: uniform or of one sign along z
    (the plane-strain modes), 1: one nodal ring, and so on; 0 in 2D (one ring)."""
    if profile.size < 2:
        return 0
    real = (profile * np.exp(-0.5j * np.angle(np.sum(profile**2)))).real
    kept = real[np.abs(profile) >= AXIAL_FLOOR * np.abs(profile).max()]
    return int(np.count_nonzero(np.diff(np.sign(kept)) != 0))


def _exponent(mu: complex, tau: float) -> complex:
    """``λ`` of one eigenvalue ``μ`` (a real one when ``|Im μ| ≤ REAL_TOL |μ|``)."""
    if abs(mu.imag) <= REAL_TOL * abs(mu):
        mu = complex(mu.real)
    return complex(damped_exponents(np.array([mu]), tau)[0])


def _unstable_mu(tau: float, fmax_hz: float = math.inf) -> Callable[[complex], bool]:
    """Predicate on an eigenvalue ``μ``: is its motion (with damping ``τ``) growing, at a
    frequency ≤ ``fmax_hz``?"""
    def unstable(mu: complex) -> bool:
        if mu.imag < 0:  # one member of each conjugate pair
            return False
        lam = _exponent(mu, tau)
        hz = abs(lam.imag) / (2 * math.pi)
        return hz <= fmax_hz and _is_unstable(lam.real, hz)
    return unstable


def _fastest(shapes: bool | int, tau: float) -> tuple[int, Callable[[complex], float]] | None:
    """``band_eigenvalues``' ``keep_most`` for ``shapes``: a count K keeps the K vectors of
    the largest growth rate ``Re λ(μ)``; True (or nothing) no limit."""
    if shapes is True or not shapes:
        return None
    return int(shapes), lambda mu: _exponent(mu, tau).real


def friction_relaxation_time(scene: Any) -> float:
    """``t*`` of the scene's regularised friction bound, linearised about steady sliding
    (0: Coulomb). Prakash–Clifton ``dσ/dt = −(|V| + V*)/L (σ − p)`` with the steady slip rate
    ``|V| = R|Ω|`` (the perturbation of ``|V|`` multiplies ``σ − p = 0``): ``t* = L/(R|Ω| +
    V*)``; constant-time: ``t* = relaxation_time``."""
    law = ContactLaw.from_scene(scene, 1.0)  # the bound's law; the step does not enter t*
    return law.regularisation.linearised_time(abs(law.surface_speed))


def unrepresented_terms(t_star: float, mass: str = "lumped", ranks: int = 1) -> str | None:
    """Why CEA cannot linearise a scene whose friction bound relaxes in ``t_star`` seconds
    (0: Coulomb) with this mass on this many ranks (one line), or None.

    Represented: elasticity, the lumped or consistent mass, Coulomb friction on the nodal
    or 1-2-1 filtered reactions, Kelvin–Voigt damping, and a regularised friction bound
    (its relaxation state per node, :func:`regularised_band`) with the lumped mass on one
    rank.
    """
    if t_star > 0 and mass != "lumped":
        return (f"a regularised friction bound (t* = {t_star:.3g} s) with --mass {mass}: the "
                "regularised CEA uses the solver's lumped mass; drop --mass")
    if t_star > 0 and ranks > 1:
        return (f"a regularised friction bound (t* = {t_star:.3g} s): the regularised CEA "
                f"runs on one rank (got {ranks}); run it without mpirun")
    return None


def cea_problem(scene: Scene, comm: MPI.Comm | None = None) -> TubeProblem:
    """The problem whose steady sliding the CEA linearises (``build_problem``): the scene's
    plane-strain cross-section, or with ``mesh.dim`` = 3 the finite tube its 3D keys
    describe, on the ranks of ``comm`` (default: all)."""
    from mpi4py import MPI

    # dolfinx on first use: the command line and the scene are checked before it loads
    from stickslip.solver.problem import build_problem

    return build_problem(scene, MPI.COMM_WORLD if comm is None else comm)


def complex_eigenvalue_analysis(
    problem: TubeProblem,
    f: float | None = None,
    fmax_hz: float = 10_000.0,
    *,
    mass: str = "lumped",
    ops: CEAOperators | None = None,
    nev_slice: int = 64,
    tol: float = 1e-10,
    tau: float | None = None,
    t_star: float | None = None,
    shapes: bool | int = False,
) -> CEAResult:
    """CEA of ``problem``'s steady sliding at friction ``f`` (default: the scene's) up to
    ``fmax_hz``: every eigenvalue with frequency ≤ fmax, growth rates, damping ratios,
    wavenumbers. ``tau``: Kelvin–Voigt retardation time (default: the scene's
    ``damping.tau``; the damping matrix is ``τA``, see the module docstring). ``t_star``:
    relaxation time of a regularised friction bound (default: the scene's,
    :func:`friction_relaxation_time`; > 0 solves :func:`regularised_band`). ``shapes``:
    keep the shapes of the unstable modes (``CEAResult.shapes``): True every one, a count
    K > 0 only those of the K fastest-growing (``unstable()[:K]``).
    """
    t0 = time.perf_counter()
    f = problem.scene.loading.f if f is None else float(f)
    tau = problem.scene.damping.tau if tau is None else float(tau)
    t_star = friction_relaxation_time(problem.scene) if t_star is None else float(t_star)
    for name, value in (("tau", tau), ("t_star", t_star)):
        if not (math.isfinite(value) and value >= 0.0):
            raise ValueError(f"{name} = {value!r}: need a time >= 0 (s)")
    own = ops is None
    if ops is None:
        ops = build_operators(problem, mass, problem.scene.friction.filter)
    refused = unrepresented_terms(t_star, ops.mass_kind, problem.comm.size)
    if refused:
        if own:
            ops.destroy()
        raise ValueError(refused)
    t1 = time.perf_counter()
    if t_star > 0:
        modes, kept, stats = _regularised_modes(ops, f, tau, t_star, fmax_hz, tol, shapes)
    else:
        modes, kept, stats = _coulomb_modes(ops, f, tau, fmax_hz, nev_slice, tol, shapes)
    t2 = time.perf_counter()
    res = CEAResult(
        f=f, fmax_hz=fmax_hz, mass=ops.mass_kind, n_free=ops.n_free, modes=modes,
        stats=stats, scene=problem.scene.name,
        timings={"operators": t1 - t0, "eigensolve": stats.seconds,
                 "modes": t2 - t1 - stats.seconds},
        tau=tau, friction=ops.friction, n_contact=ops.n_contact, shapes=kept, t_star=t_star,
        levels=ops.levels,
    )
    if own:
        ops.destroy()
    return res


def _coulomb_modes(ops: CEAOperators, f: float, tau: float, fmax_hz: float, nev_slice: int,
                   tol: float, shapes: bool | int
                   ) -> tuple[list[CEAMode], dict[int, np.ndarray], BandStats]:
    """Coulomb friction: the pencil ``A φ = μ M φ`` by slices, then ``λ`` per ``μ``."""
    A, B = ops.operator(f), ops.mass(f)
    w_max = 2.0 * math.pi * fmax_hz
    # damping lowers the frequency: |Im λ| = √(μ − (τμ/2)²) for real μ; widen the band so
    # every μ whose damped frequency is ≤ fmax is in it
    zeta_max = min(0.5 * tau * w_max, 0.99)
    mu_max = w_max * w_max / (1.0 - zeta_max * zeta_max)
    vectors: dict[int, np.ndarray] = {}
    mu, psi, stats = band_eigenvalues(
        A, B, mu_max * 1.0001, nev_slice=nev_slice, tol=tol, contact_pos=ops.pos_theta,
        keep_vector=_unstable_mu(tau, fmax_hz) if shapes else None, vectors=vectors,
        keep_most=_fastest(shapes, tau),
    )
    A.destroy()
    if B is not ops.B:
        B.destroy()
    modes, index = _modes(mu, psi, ops, tau)
    in_band = [i for i, m in enumerate(modes) if m.frequency_hz <= fmax_hz]
    kept = {}  # the shape ψ of the positive-frequency motion: conj(φ) for complex μ
    for new, i in enumerate(in_band):
        if index[i] in vectors:
            vec = vectors[index[i]]
            kept[new] = np.conj(vec) if modes[i].omega2_imag > 0 else vec
    return [modes[i] for i in in_band], kept, stats


def _regularised_modes(ops: CEAOperators, f: float, tau: float, t_star: float,
                       fmax_hz: float, tol: float, shapes: bool | int
                       ) -> tuple[list[CEAMode], dict[int, np.ndarray], BandStats]:
    """Regularised friction: ``λ`` directly (:func:`regularised_band`). Every motion of
    positive frequency is listed (the growing wave and the decaying one of each pair);
    ``omega2_*`` record ``−λ²``."""
    lam, psi, full, stats = regularised_band(ops, f, tau, t_star, fmax_hz, tol=tol,
                                             keep_vector=shapes)
    real = np.abs(lam.imag) <= REAL_TOL * np.abs(lam)
    lam = np.where(real, lam.real + 0j, lam)
    modes = _classify(lam, psi, real, -lam * lam, ops)
    order = sorted((i for i, m in enumerate(modes) if m.frequency_hz <= fmax_hz),
                   key=lambda i: (modes[i].frequency_hz, -modes[i].growth_rate))
    kept = {}
    if full is not None:
        kept = {new: full[i] for new, i in enumerate(order)
                if _is_unstable(modes[i].growth_rate, modes[i].frequency_hz)}
        if shapes is not True:  # a count: the fastest-growing ones
            fastest = sorted(kept, key=lambda new: -modes[order[new]].growth_rate)
            kept = {new: kept[new] for new in fastest[:int(shapes)]}
    return [modes[i] for i in order], kept, stats


def sweep_friction(
    problem: TubeProblem, fs: np.ndarray, fmax_hz: float, *, mass: str = "lumped",
    tau: float | None = None,
) -> list[CEAResult]:
    """CEA for each friction coefficient of ``fs`` (operators built once)."""
    ops = build_operators(problem, mass, problem.scene.friction.filter)
    try:
        return [complex_eigenvalue_analysis(problem, float(f), fmax_hz, ops=ops, tau=tau)
                for f in fs]
    finally:
        ops.destroy()
