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
``(K + K_f) φ = ω² M φ`` (``M`` = the solver's lumped mass, or ``L TᵀM_cT`` with the
consistent one). It does not depend on ``d`` or ``Ω``: only on the mesh, material and ``f``.
With ``u = Re(ψ e^{λt})``, ``λ² = −ω²``: a complex pair ``ω², conj(ω²)`` is one growing
travelling wave (growth ``Re λ > 0``) and one decaying wave travelling the other way.

Solver: SLEPc Krylov-Schur, GNHEP, shift-and-invert (MUMPS LU, pivot threshold 0.5) with
real targets ``σ = ω_t²`` marching through ``[0, (2π f_max)²]`` in slices; each slice is
accepted only where its disc of converged eigenvalues covers the strip of flutter
eigenvalues (see :func:`band_eigenvalues`). Verification and findings: docs/flutter.md.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from dataclasses import asdict, dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from mpi4py import MPI
    from petsc4py import PETSc

    from solver.problem import TubeProblem
    from solver.scene import Scene

__all__ = [
    "CEAMode",
    "CEAOperators",
    "CEAResult",
    "TransientGrowth",
    "annulus_sliding_frequencies",
    "band_eigenvalues",
    "build_operators",
    "complex_eigenvalue_analysis",
    "matrix_pencil",
    "measure_transient_growth",
    "newmark_exponents",
    "parse_f_sweep",
    "plot_cea_diagram",
    "plot_spectrum",
    "reduced_model_flutter",
    "register",
    "sweep_friction",
]

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
    n_contact: int  # contact nodes in total (all ranks)
    radius: float
    mass_kind: str
    consistent_friction_mass: PETSc.Mat | None = None  # −E M̂_c (consistent mass only)
    comm: Any = None

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


def build_operators(problem: TubeProblem, mass: str = "lumped") -> CEAOperators:
    """Rotate the contact nodes, split off the friction part, restrict to the free dofs.

    ``mass="lumped"`` (default) is ``problem.mass``, the explicit solver's mass, so CEA and
    the transient describe the same discrete system; ``"consistent"`` uses ``∫ρφ_i·φ_j``.
    """
    import dolfinx
    import dolfinx.fem.petsc
    import ufl
    from petsc4py import PETSc

    from forms.elasticity import mass as mass_form
    from forms.steady import node_matrix

    if mass not in ("lumped", "consistent"):
        raise ValueError(f"mass={mass!r}: use 'lumped' or 'consistent'")
    comm = problem.comm
    K, nd = problem.K, problem.nodes
    rstart = K.getOwnershipRange()[0]
    rows_x = (rstart + nd.dofs_x).astype(PETSc.IntType)
    c, s = nd.cos_t, nd.sin_t
    one, zero = np.ones_like(c), np.zeros_like(c)
    T = node_matrix(K, rows_x, nd.dofs_x, (c, -s, s, c))  # u = T ũ
    L1 = node_matrix(K, rows_x, nd.dofs_x, (one, zero, -one, one))  # row_θ − 1·row_r
    Khat = K.ptap(T)
    Kf = L1.matMult(Khat)
    Kf.axpy(-1.0, Khat)  # = −E K̂

    keep = np.ones(problem.n_owned, dtype=bool)
    keep[problem.clamped] = False
    keep[nd.dofs_x] = False  # ũ_r = d: eliminated
    free = np.flatnonzero(keep)
    iset = PETSc.IS().createGeneral((rstart + free).astype(PETSc.IntType), comm=comm)
    Kt_f = Khat.createSubMatrix(iset, iset)
    Kf_f = Kf.createSubMatrix(iset, iset)
    friction_mass = None
    if mass == "lumped":
        B = PETSc.Mat().createAIJ(size=Kt_f.getSizes(), nnz=(1, 0), comm=comm)
        B.setUp()
        diag = Kt_f.createVecLeft()
        diag.getArray()[:] = problem.mass[free]
        B.setDiagonal(diag)
        B.assemble()
        diag.destroy()
    else:
        u, v = ufl.TrialFunction(problem.V), ufl.TestFunction(problem.V)
        Mc = dolfinx.fem.petsc.assemble_matrix(
            dolfinx.fem.form(mass_form(u, v, problem.material.rho))
        )
        Mc.assemble()
        Mhat = Mc.ptap(T)
        Mf = L1.matMult(Mhat)
        Mf.axpy(-1.0, Mhat)
        B = Mhat.createSubMatrix(iset, iset)
        friction_mass = Mf.createSubMatrix(iset, iset)
        for m in (Mc, Mhat, Mf):
            m.destroy()
    for m in (T, L1, Khat, Kf, iset):
        m.destroy()
    return CEAOperators(
        Kt=Kt_f, Kf=Kf_f, B=B, free=free,
        pos_theta=np.searchsorted(free, nd.dofs_y), theta=nd.theta,
        n_contact=nd.n_global, radius=problem.scene.geometry.R, mass_kind=mass,
        consistent_friction_mass=friction_mass, comm=comm,
    )


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
) -> tuple[np.ndarray, np.ndarray, BandStats]:
    """All eigenvalues ``μ`` of ``A φ = μ B φ`` with ``Re μ ≤ mu_max`` (slices along Re μ).

    A shift-and-invert solve at the real target ``σ`` returning the ``nev`` eigenvalues
    nearest ``σ`` leaves none out (up to Krylov convergence) in the disc ``|μ − σ| < ρ``
    (``ρ`` = distance of the ``nev``-th). The eigenvalues lie in a strip ``|Im μ| ≤ H``
    around the real axis (flutter: ``Im μ = −2σ_g ω``); ``H`` = ``strip_safety`` × the largest
    ``|Im μ|`` found in the disc, and the disc must reach above it (``ρ > H``, else ``nev``
    doubles). The disc then covers the strip on ``Re μ ∈ σ ± √(ρ² − H²)``: slices are
    accepted there only, march upwards from ``lo = −0.02 mu_max`` (first target ``lo``, next
    ``0.7`` half-width above the covered end), and a slice that does not reach back to ``lo``
    is redone nearer. Each accepted pair's relative residual is checked (< 1e-6, recorded).
    Returns ``μ`` (complex), the eigenvectors at ``contact_pos`` (owned entries; rows =
    eigenvalues) and statistics.
    """
    from slepc4py import SLEPc

    t0 = time.perf_counter()
    stats = BandStats()
    n = A.getSize()[0]
    mus: list[complex] = []
    vecs: list[np.ndarray] = []
    pos = np.zeros(0, dtype=np.int64) if contact_pos is None else contact_pos
    vr, vi = A.createVecRight(), A.createVecRight()
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
        # Strip height: safety × max |Im μ| over the disc, then lowered to the eigenvalues of
        # the slice's own Re-interval while that stays consistent (a lower strip widens the
        # interval, which must not take in a taller eigenvalue).
        im, re = np.abs(mu[inside].imag), np.abs(mu[inside].real - sigma)
        strip = strip_safety * float(np.max(im, initial=0.0))
        for _ in range(4):
            if everything or rho <= strip:
                break
            half = math.sqrt(rho * rho - strip * strip)
            lower = strip_safety * float(np.max(im[re <= half], initial=0.0))
            if lower >= strip:
                break
            wider = math.sqrt(rho * rho - lower * lower)
            if strip_safety * float(np.max(im[re <= wider], initial=0.0)) > lower:
                break
            strip = lower
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
            m = mu[i]
            if lo <= m.real < hi:
                err = eps.computeError(int(i), SLEPc.EPS.ErrorType.RELATIVE)
                stats.max_residual = max(stats.max_residual, err)
                if err > 1e-6:
                    raise RuntimeError(f"eigenpair {m} has relative residual {err:.2g}")
                mus.append(m)
                if contact_pos is not None:  # collective: every rank, even without nodes
                    eps.getEigenpair(int(i), vr, vi)
                    vecs.append(vr.getArray()[pos] + 1j * vi.getArray()[pos])
        eps.destroy()
        stats.slices += 1
        stats.converged += nconv
        if everything:
            break
        lo = hi
        sigma, nev = hi + TARGET_STEP * half, nev_slice if nev <= nev_slice else nev
    vr.destroy()
    vi.destroy()
    mu_arr = np.array(mus, dtype=complex)
    keep = mu_arr.real <= mu_max
    stats.seconds = time.perf_counter() - t0
    width = pos.size if contact_pos is not None else 0
    V = np.array(vecs, dtype=complex).reshape(len(vecs), width) if vecs else \
        np.zeros((mu_arr.size, width), dtype=complex)
    return mu_arr[keep], V[keep], stats


# --------------------------------------------------------------------------------- modes


@dataclass(frozen=True)
class CEAMode:
    """One real motion ``u = Re(ψ e^{λt})`` of the linearised sliding system.

    ``k`` is the signed dominant wavenumber of ``ψ_θ`` on the contact circle
    (``ψ_θ ≈ A e^{ikθ}``); the wave travels at ``−ω/k`` rad/s, so ``k < 0`` is the sense of
    rotation. Stable real eigenvalues (double, ``±k``) have ``direction = "standing"``.
    """

    omega2_real: float  # Re ω² [rad²/s²]
    omega2_imag: float  # Im ω² (>= 0: one member of each conjugate pair)
    growth_rate: float  # Re λ [1/s], > 0 = unstable (flutter)
    frequency_hz: float  # Im λ / 2π >= 0
    k: int  # signed wavenumber of the growing motion's ψ_θ (contact circle DFT)
    wavenumber: int  # |k|
    purity: float  # share of the DFT power of ψ_θ in wavenumber ±|k|
    direction: str  # 'rotation' | 'opposite' | 'standing' | 'divergence'
    phase_speed_m_s: float  # −ω R / k (signed, + = rotation sense); 0 if standing

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


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

    def unstable(self, rel_tol: float = 1e-7) -> list[CEAMode]:
        """Modes with growth rate > rel_tol·ω (flutter), most unstable first."""
        out = [
            m for m in self.modes
            if m.growth_rate > rel_tol * max(2 * math.pi * m.frequency_hz, 1.0)
        ]
        return sorted(out, key=lambda m: -m.growth_rate)

    def by_wavenumber(self) -> dict[int, CEAMode]:
        """The most unstable mode of each wavenumber |k| (k ≥ 0)."""
        best: dict[int, CEAMode] = {}
        for m in self.modes:
            if m.wavenumber not in best or m.growth_rate > best[m.wavenumber].growth_rate:
                best[m.wavenumber] = m
        return dict(sorted(best.items()))

    def to_dict(self) -> dict[str, Any]:
        uns = self.unstable()
        return {
            "scene": self.scene, "f": self.f, "fmax_hz": self.fmax_hz, "mass": self.mass,
            "free_dofs": self.n_free, "modes_in_band": len(self.modes),
            "unstable_count": len(uns),
            "max_growth_rate_per_s": uns[0].growth_rate if uns else 0.0,
            "unstable": [m.to_dict() for m in uns],
            "most_unstable_per_k": {str(k): m.to_dict() for k, m in self.by_wavenumber().items()},
            "solver": asdict(self.stats), "timings_s": self.timings,
        }


def _modes(mu: np.ndarray, psi: np.ndarray, ops: CEAOperators) -> list[CEAMode]:
    """Growth, frequency, wavenumber and direction from eigenvalues and contact ψ_θ."""
    comm = ops.comm
    n_c = ops.n_contact
    kk = np.arange(-(n_c // 2), n_c // 2 + 1)
    real = np.abs(mu.imag) <= REAL_TOL * np.abs(mu)
    keep = real | (mu.imag > 0)  # one eigenvalue of each conjugate pair
    mu, psi = mu[keep], psi[keep]
    real = real[keep]
    root = np.sqrt(mu.astype(complex))  # a + i b, a >= 0
    growth = np.where(real & (mu.real < 0), np.sqrt(np.abs(mu.real)), np.abs(root.imag))
    omega = np.where(real & (mu.real < 0), 0.0, root.real)
    # growing motion with positive frequency has shape conj(φ) (Im μ > 0), see module doc
    shape = np.where(real[:, None], psi, np.conj(psi))
    basis = np.exp(-1j * np.outer(ops.theta, kk))  # owned nodes × k
    local = shape @ basis if shape.size else np.zeros((mu.size, kk.size), dtype=complex)
    coeff = np.zeros_like(local)
    comm.Allreduce(local, coeff)
    power = np.abs(coeff) ** 2
    modes = []
    for i in range(mu.size):
        p = power[i]
        j = int(np.argmax(p))
        k = int(kk[j])
        total = float(p.sum())
        pair = p[j] + (p[kk == -k][0] if k != 0 else 0.0)
        purity = float(pair / total) if total > 0 else 0.0
        if real[i]:
            direction = "divergence" if mu[i].real < 0 else "standing"
            k, speed = abs(k), 0.0
        else:
            speed = -omega[i] * ops.radius / k if k != 0 else 0.0
            direction = "rotation" if speed > 0 else ("opposite" if speed < 0 else "standing")
        modes.append(CEAMode(
            omega2_real=float(mu[i].real), omega2_imag=float(abs(mu[i].imag)),
            growth_rate=float(growth[i]), frequency_hz=float(omega[i] / (2 * math.pi)),
            k=k, wavenumber=abs(k), purity=purity, direction=direction,
            phase_speed_m_s=float(speed),
        ))
    return sorted(modes, key=lambda m: (m.frequency_hz, -m.growth_rate))


def complex_eigenvalue_analysis(
    problem: TubeProblem,
    f: float | None = None,
    fmax_hz: float = 10_000.0,
    *,
    mass: str = "lumped",
    ops: CEAOperators | None = None,
    nev_slice: int = 64,
    tol: float = 1e-10,
) -> CEAResult:
    """CEA of ``problem``'s steady sliding at friction ``f`` (default: the scene's) up to
    ``fmax_hz``: every eigenvalue with frequency ≤ fmax, growth rates, wavenumbers.
    """
    t0 = time.perf_counter()
    f = problem.scene.loading.f if f is None else float(f)
    own = ops is None
    if ops is None:
        ops = build_operators(problem, mass)
    t1 = time.perf_counter()
    A, B = ops.operator(f), ops.mass(f)
    mu_max = (2.0 * math.pi * fmax_hz) ** 2
    mu, psi, stats = band_eigenvalues(
        A, B, mu_max * 1.0001, nev_slice=nev_slice, tol=tol, contact_pos=ops.pos_theta
    )
    t2 = time.perf_counter()
    modes = [m for m in _modes(mu, psi, ops) if m.frequency_hz <= fmax_hz]
    t3 = time.perf_counter()
    res = CEAResult(
        f=f, fmax_hz=fmax_hz, mass=ops.mass_kind, n_free=ops.n_free, modes=modes, stats=stats,
        scene=problem.scene.name,
        timings={"operators": t1 - t0, "eigensolve": t2 - t1, "modes": t3 - t2},
    )
    A.destroy()
    if B is not ops.B:
        B.destroy()
    if own:
        ops.destroy()
    return res


def sweep_friction(
    problem: TubeProblem, fs: np.ndarray, fmax_hz: float, *, mass: str = "lumped"
) -> list[CEAResult]:
    """CEA for each friction coefficient of ``fs`` (operators built once)."""
    ops = build_operators(problem, mass)
    try:
        return [complex_eigenvalue_analysis(problem, float(f), fmax_hz, ops=ops) for f in fs]
    finally:
        ops.destroy()


# --------------------------------------------------------------------------------- references


def annulus_sliding_frequencies(
    k: int, R: float, xi: float, E: float, nu: float, rho: float, fmax_hz: float,
    df_hz: float = 0.5,
) -> np.ndarray:
    """Natural frequencies (Hz) of mode ``k`` of the plane-strain annulus ``R ≤ r ≤ ξR``,
    clamped at ``r = ξR`` and in frictionless sliding contact at ``r = R``
    (``u_r = 0``, ``σ_rθ = 0``): the f = 0 limit of the linearised sliding problem.

    Potentials ``φ = F(r) cos kθ``, ``ψ = G(r) sin kθ`` with ``F = A J_k(αr) + B Y_k(αr)``,
    ``G = C J_k(βr) + D Y_k(βr)``, ``α = ω/c_p``, ``β = ω/c_s``:
    ``u_r = F' + kG/r``, ``u_θ = −kF/r − G'``,
    ``σ_rθ/μ = 2k(F/r² − F'/r) + 2G'/r + (β² − 2k²/r²) G``. The roots of the 4×4
    determinant (rows ``u_r(R)``, ``σ_rθ(R)``, ``u_r(ξR)``, ``u_θ(ξR)``; columns normalised)
    are bracketed on a ``df_hz`` grid and refined with ``brentq``.
    """
    from scipy.optimize import brentq
    from scipy.special import jv, jvp, yv, yvp

    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    mu_s = E / (2 * (1 + nu))
    cp, cs = math.sqrt((lam + 2 * mu_s) / rho), math.sqrt(mu_s / rho)
    a, b = R, xi * R

    def columns(w: np.ndarray, r: float) -> tuple[np.ndarray, ...]:
        """(u_r, u_θ, σ_rθ/μ) of each of the 4 basis solutions at radius r: arrays (n, 4)."""
        al, be = w / cp, w / cs
        F = np.stack([jv(k, al * r), yv(k, al * r), 0 * w, 0 * w], axis=-1)
        Fp = np.stack([al * jvp(k, al * r), al * yvp(k, al * r), 0 * w, 0 * w], axis=-1)
        G = np.stack([0 * w, 0 * w, jv(k, be * r), yv(k, be * r)], axis=-1)
        Gp = np.stack([0 * w, 0 * w, be * jvp(k, be * r), be * yvp(k, be * r)], axis=-1)
        ur = Fp + k * G / r
        ut = -k * F / r - Gp
        srt = 2 * k * (F / r**2 - Fp / r) + 2 * Gp / r + ((be**2)[..., None] - 2 * k * k / r**2) * G
        return ur, ut, srt

    def det(w: np.ndarray) -> np.ndarray:
        w = np.atleast_1d(np.asarray(w, dtype=float))
        ur_a, _, s_a = columns(w, a)
        ur_b, ut_b, _ = columns(w, b)
        M = np.stack([ur_a, s_a * a, ur_b, ut_b], axis=-2)  # (n, 4 rows, 4 cols)
        M = M / np.max(np.abs(M), axis=-2, keepdims=True)  # positive column scaling
        return np.linalg.det(M)

    w = 2 * math.pi * np.arange(max(df_hz, 1.0), fmax_hz + df_hz, df_hz)
    d = det(w)
    roots = []
    for i in np.flatnonzero(np.sign(d[:-1]) * np.sign(d[1:]) < 0):
        roots.append(brentq(lambda x: float(det(x)[0]), w[i], w[i + 1], xtol=1e-10))
    return np.array(roots) / (2 * math.pi)


def reduced_model_flutter(scene: Scene, kmax: int = 12) -> list[dict[str, Any]]:
    """The reduced model's flutter modes (eq. [2] in sliding, ``semianalytic.flutter``) in
    physical units for the scene's ν, ξ, f, c₀, R, Ω (growth 1/s, frequency Hz, m/s)."""
    from semianalytic.coefficients import coefficients, gamma_from_physical
    from semianalytic.flutter import flutter_modes, mode_physical

    g, m, lo = scene.geometry, scene.material, scene.loading
    gamma = gamma_from_physical(math.sqrt(m.E / m.rho), g.R, lo.omega)
    co = coefficients(m.nu, g.xi, gamma)
    return [mode_physical(md, g.R, lo.omega) for md in flutter_modes(co, lo.f, kmax)]


# --------------------------------------------------------------------------------- transient


def matrix_pencil(
    dt: float, signal: np.ndarray, rel_tol: float = 1e-7, max_order: int = 40
) -> tuple[np.ndarray, np.ndarray]:
    """Complex exponents ``s_j`` and amplitudes ``c_j`` of ``signal[n] ≈ Σ c_j e^{s_j n dt}``.

    Matrix-pencil method (Hua & Sarkar 1990): Hankel matrix of the samples, SVD truncated at
    ``rel_tol`` × the largest singular value (model order), eigenvalues ``z_j`` of the pencil,
    ``s_j = log(z_j)/dt``; amplitudes by least squares. Exact for noise-free sums of
    exponentials, which is what a linear system's response is.
    """
    y = np.asarray(signal, dtype=complex)
    n = y.size
    L = n // 2
    H = np.lib.stride_tricks.sliding_window_view(y, L + 1)  # (n − L) × (L + 1)
    _, sv, vh = np.linalg.svd(H, full_matrices=False)
    order = int(min(max_order, np.count_nonzero(sv > rel_tol * sv[0])))
    W = vh[:order].T  # (L + 1) × order: its columns span the vectors (1, z_j, z_j², ...)
    z = np.linalg.eigvals(np.linalg.pinv(W[:-1]) @ W[1:])
    Z = z[None, :] ** np.arange(n)[:, None]
    c = np.linalg.lstsq(Z, y, rcond=None)[0]
    return np.log(z) / dt, c


def newmark_exponents(omega2: np.ndarray, dt: float, beta2: float) -> np.ndarray:
    """Discrete exponents ``s = log(z)/dt`` of the explicit solver for eigenvalues ``ω²``.

    In the sliding regime the solver's forward-increment constraint keeps ``ũ_r = d`` exactly
    (the radial acceleration of a contact node then vanishes: ``a_{n+1} = a_n (β₂−½)/(β₂+½)``
    from ``a_0 = 0``), so the free dofs follow explicit Newmark (``β₁ = 0``, ``γ = β₂``) on
    ``M ü + (K + K_f) u = 0``. Per eigenvalue (``Ω² = ω² dt²``) the amplification matrix
    has ``z² − (2 − (β₂ + ½)Ω²) z + 1 − (β₂ − ½)Ω² = 0``. Returns the root of larger
    ``|z|`` (the growing / less damped one) as ``s`` with ``Im s ≥ 0``; it tends to
    ``λ`` as ``dt → 0``. For ``β₂ = ½`` (central differences) ``cosh(s dt) = 1 − ω²dt²/2``.
    """
    w2 = np.asarray(omega2, dtype=complex) * dt * dt
    b = 2.0 - (beta2 + 0.5) * w2
    c = 1.0 - (beta2 - 0.5) * w2
    disc = np.sqrt(b * b - 4.0 * c)
    z1, z2 = 0.5 * (b + disc), 0.5 * (b - disc)
    z = np.where(np.abs(z1) >= np.abs(z2), z1, z2)
    s = np.log(z) / dt
    return np.where(s.imag < 0, np.conj(s), s)


@dataclass
class TransientGrowth:
    """Growth of mode k of u_θ on the contact circle in a seeded transient run.

    ``growth_rate``/``frequency_hz``: slope of log|U_k(t)| and of its phase over the window
    (the dominant component if one dominates). ``exponents``: matrix-pencil decomposition
    ``U_k(t) = Σ c_j e^{s_j t}`` (growth Re s, signed frequency Im s/2π: > 0 = travelling
    against the rotation, as ψ ∝ e^{ikθ}), sorted by |c_j e^{s_j t_end}| (dominance at the
    end of the window).
    """

    k: int
    growth_rate: float
    frequency_hz: float
    exponents: list[tuple[float, float, float]]  # (growth 1/s, signed Hz, |c e^{s t_end}|)
    window_s: tuple[float, float]
    amplitude_range_m: tuple[float, float]
    all_slip: bool  # every node slipped in contact during the window (linear regime)
    dt_s: float


def measure_transient_growth(
    scene: Scene, k: int, comm: MPI.Comm, *, window: tuple[float, float],
    amplitude: float = 1e-6, beta2: float = 0.5, sample_interval: float = 2e-5,
) -> TransientGrowth:
    """Seed steady sliding with a small mode-k bump and measure how U_k(t) of u_θ grows.

    ``solver.run.Simulation`` with ``initial.perturbation = "mode"`` (``amplitude`` × d),
    ``β₂ = 1/2`` by default (no numerical damping), run to ``window[1]``; ``U_k`` from
    ``solver.analysis.mode_coefficients`` of the recorder's u_θ samples in ``window``
    (which must lie in the linear phase: checked, every node slipping).
    """
    from solver.analysis import mode_coefficients
    from solver.contact import SLIP
    from solver.run import Simulation

    sc = scene.with_overrides(
        'initial.perturbation="mode"', f"initial.mode={k}", f"initial.amplitude={amplitude}",
        f"time.beta2={beta2}", f"time.end_time={window[1] + 2 * sample_interval}",
        f"output.sample_interval={sample_interval}", "output.progress=false",
    )
    sim = Simulation(sc, comm)
    sim.proceed()
    result = None
    if comm.rank == 0:
        data = sim.recorder.arrays()
        t = data["t"]
        coeff = mode_coefficients(data["u_theta"], data["theta"], k)[:, k]
        sel = (t >= window[0] - 1e-12) & (t <= window[1] + 1e-12)
        ts, amp = t[sel], np.abs(coeff[sel])
        slope = float(np.polyfit(ts, np.log(amp), 1)[0])
        freq = float(np.polyfit(ts, np.unwrap(np.angle(coeff[sel])), 1)[0]) / (2 * math.pi)
        dts = float(np.mean(np.diff(ts)))
        s, c = matrix_pencil(dts, coeff[sel])
        size = np.abs(c * np.exp(s * (ts[-1] - ts[0])))
        order = np.argsort(-size)
        result = TransientGrowth(
            k=k, growth_rate=slope, frequency_hz=freq,
            exponents=[(float(s[i].real), float(s[i].imag / (2 * math.pi)), float(size[i]))
                       for i in order],
            window_s=(float(ts[0]), float(ts[-1])),
            amplitude_range_m=(float(amp.min()), float(amp.max())),
            all_slip=bool(np.all(data["status"][sel] == SLIP)), dt_s=sim.dt,
        )
    return comm.bcast(result, root=0)


# --------------------------------------------------------------------------------- plots


def _distinct(modes: Any) -> list[CEAMode]:
    """Modes sorted by frequency, one per degenerate (±k, f = 0) pair."""
    out: list[CEAMode] = []
    for m in sorted(modes, key=lambda m: m.frequency_hz):
        if out and abs(m.frequency_hz - out[-1].frequency_hz) <= 1e-7 * m.frequency_hz \
                and abs(m.growth_rate - out[-1].growth_rate) <= 1e-7 * m.frequency_hz:
            continue
        out.append(m)
    return out


def plot_cea_diagram(
    results: list[CEAResult], path: str, *, k_detail: int = 4, kmax: int = 12,
    reduced: dict[float, list[dict]] | None = None, title: str = "",
) -> str:
    """The classic CEA diagram against the friction coefficient f, three panels:

    (a) frequency of every mode of wavenumber ``k_detail`` (▲ travels with the rotation,
    ▼ against it, ● standing); (b) their real parts ``Re λ = ±σ``: each conjugate pair is a
    growing (+σ) and a decaying (−σ) wave, degenerate (±k, σ = 0) at f = 0; (c) growth rate
    of the most unstable mode of each k = 1..kmax (reduced model of eq. [2] dashed, if given).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fs = np.array([r.f for r in results])
    fig, axes = plt.subplots(1, 3, figsize=(16, 5.2), constrained_layout=True)
    ax1, ax2, ax3 = axes
    marks = {"rotation": ("^", "tab:red"), "opposite": ("v", "tab:blue"),
             "standing": ("o", "0.4"), "divergence": ("s", "k")}
    # (a), (b): branches of k_detail, connected in frequency order
    branches = [_distinct(m for m in r.modes if m.wavenumber == k_detail) for r in results]
    nb = min((len(b) for b in branches), default=0)
    for j in range(nb):
        fr = [b[j].frequency_hz for b in branches]
        gr = [b[j].growth_rate for b in branches]
        ax1.plot(fs, fr, "-", color="0.75", lw=0.8, zorder=1)
        ax2.plot(fs, gr, "-", color="0.75", lw=0.8, zorder=1)
        ax2.plot(fs, [-g for g in gr], "--", color="0.75", lw=0.8, zorder=1)
    for r, b in zip(results, branches, strict=True):
        for m in b:
            mk, col = marks[m.direction]
            ax1.scatter(r.f, m.frequency_hz, marker=mk, c=col, s=22, zorder=2)
            ax2.scatter(r.f, m.growth_rate, marker=mk, c=col, s=22, zorder=2)
            ax2.scatter(r.f, -m.growth_rate, marker=mk, facecolors="none", edgecolors=col,
                        s=22, zorder=2)
    for mk, col, lab in (("^", "tab:red", "travels with the rotation"),
                         ("v", "tab:blue", "travels against the rotation"),
                         ("o", "0.4", "standing (f = 0: ±k degenerate)")):
        ax1.scatter([], [], marker=mk, c=col, label=lab)
    ax1.legend(loc="lower right", fontsize=8)
    ax1.set_title(f"(a) frequencies of the |k| = {k_detail} modes")
    ax1.set_ylabel("frequency Im λ / 2π (Hz)")
    ax2.set_title(f"(b) Re λ of the |k| = {k_detail} modes (open: decaying partner)")
    ax2.set_ylabel("Re λ (1/s), > 0: flutter")
    ax2.axhline(0.0, color="k", lw=0.6)
    # (c) most unstable growth per k
    cmap = plt.get_cmap("turbo")
    for k in range(1, kmax + 1):
        g = [r.by_wavenumber().get(k) for r in results]
        ax3.plot(fs, [m.growth_rate if m else np.nan for m in g], "-", color=cmap(k / kmax),
                 lw=1.4, label=f"k = {k}" if k in (1, k_detail, kmax) else None)
    top = [r.unstable()[0].growth_rate if r.unstable() else 0.0 for r in results]
    ax3.plot(fs, top, "k-", lw=2.2, label="most unstable, all k in band")
    if reduced:
        rf = sorted(reduced)
        ax3.plot(rf, [next(x["growth_rate_per_s"] for x in reduced[f] if x["k"] == k_detail)
                      for f in rf], "k--", lw=1.2, label=f"reduced model eq. [2], k = {k_detail}")
    ax3.set_title("(c) growth rate of the most unstable mode of each k")
    ax3.set_ylabel("growth rate (1/s)")
    ax3.legend(fontsize=8, loc="upper left")
    for ax in axes:
        ax.set_xlabel("friction coefficient f")
        ax.grid(alpha=0.3)
    if title:
        fig.suptitle(title)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def plot_spectrum(result: CEAResult, path: str, *, reduced: list[dict] | None = None) -> str:
    """Growth rate against frequency at one f, coloured by |k| (reduced model overlaid)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fr = np.array([m.frequency_hz for m in result.modes])
    gr = np.array([m.growth_rate for m in result.modes])
    kk = np.array([m.wavenumber for m in result.modes])
    fig, ax = plt.subplots(figsize=(8, 5), constrained_layout=True)
    sc = ax.scatter(fr, gr, c=kk, cmap="turbo", s=12)
    fig.colorbar(sc, ax=ax, label="|k|")
    if reduced:
        ax.plot([r["frequency_hz"] for r in reduced], [r["growth_rate_per_s"] for r in reduced],
                "k+-", ms=8, lw=0.8, label="reduced model (eq. [2]), k = 1, 2, ...")
        ax.legend(loc="upper left")
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("growth rate (1/s)")
    ax.set_title(f"CEA of steady sliding: {result.scene}, f = {result.f:g}, "
                 f"{result.mass} mass, {result.n_free} free dofs")
    ax.grid(alpha=0.3)
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path


# --------------------------------------------------------------------------------- CLI


def parse_f_sweep(text: str) -> np.ndarray:
    """``"start:stop:num"`` (inclusive linspace) or a comma list ``"0,0.3,0.7"``."""
    try:
        if ":" in text:
            a, b, n = text.split(":")
            vals = np.linspace(float(a), float(b), int(n))
        else:
            vals = np.array([float(x) for x in text.split(",") if x.strip()])
    except ValueError as err:
        raise ValueError(f"--f-sweep {text!r}: use start:stop:num or a comma list") from err
    if vals.size == 0 or np.any(vals < 0) or not np.all(np.isfinite(vals)):
        raise ValueError(f"--f-sweep {text!r}: need finite friction coefficients >= 0")
    return vals


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``flutter-fe SCENE`` to the ``stickslip`` subcommands."""
    p = sub.add_parser(
        "flutter-fe",
        help="complex eigenvalue analysis (CEA) of FE steady sliding (SLEPc)",
        description=(
            "Linearise the FE system about discrete steady sliding (contact nodes stay in "
            "contact, tangential force = f x normal reaction), solve (K + K_f) phi = w^2 M phi "
            "with SLEPc shift-and-invert and list the unstable (flutter) modes: growth rate, "
            "frequency, wavenumber k, propagation direction. Works under mpirun."
        ),
    )
    p.add_argument("scene", help="scene TOML file, or the name of a scene in scenes/")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scene field, e.g. --set loading.f=0.5 (repeatable)")
    p.add_argument("--fmax-hz", type=float, default=10_000.0,
                   help="upper end of the frequency band (Hz, default 10000)")
    p.add_argument("--mass", choices=("lumped", "consistent"), default="lumped",
                   help="mass matrix: the explicit solver's lumped one (default) or consistent")
    p.add_argument("--f-sweep", default=None, metavar="A:B:N|F1,F2,...",
                   help="also sweep the friction coefficient (CEA diagram with --plot)")
    p.add_argument("--kmax", type=int, default=12, help="reduced-model modes to compare (k<=)")
    p.add_argument("--k-detail", type=int, default=4,
                   help="wavenumber whose branches the CEA diagram details (default 4)")
    p.add_argument("--top", type=int, default=20, help="unstable modes listed (table output)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--plot", metavar="PNG", default=None,
                   help="growth vs frequency (or the CEA diagram with --f-sweep) to this file")
    p.set_defaults(func=flutter_fe_command)


def flutter_fe_command(args: argparse.Namespace) -> int:
    """Handler of ``stickslip flutter-fe``."""
    from mpi4py import MPI

    from solver.scene import SceneError, load_scene

    comm = MPI.COMM_WORLD
    rank0 = comm.rank == 0

    def fail(msg: str) -> int:
        if rank0:
            print(f"error: {msg}", file=sys.stderr)
        return 2

    try:
        scene = load_scene(args.scene, args.overrides)
        fs = parse_f_sweep(args.f_sweep) if args.f_sweep else None
    except (SceneError, FileNotFoundError, ValueError) as err:
        return fail(str(err))
    if not (math.isfinite(args.fmax_hz) and args.fmax_hz > 0):
        return fail(f"--fmax-hz {args.fmax_hz!r} is out of range: need a frequency > 0 (Hz)")
    from solver.problem import build_problem

    t0 = time.perf_counter()
    problem = build_problem(scene, comm)
    t_build = time.perf_counter() - t0
    ops = build_operators(problem, args.mass)
    res = complex_eigenvalue_analysis(problem, None, args.fmax_hz, ops=ops)
    res.timings["mesh+assembly"] = t_build
    sweep = None
    if fs is not None:
        sweep = [complex_eigenvalue_analysis(problem, float(f), args.fmax_hz, ops=ops)
                 for f in fs]
    ops.destroy()
    reduced = reduced_model_flutter(scene, args.kmax)
    if not rank0:
        return 0
    out = res.to_dict()
    out["reduced_model"] = reduced
    if sweep is not None:
        out["f_sweep"] = [
            {"f": r.f, "max_growth_rate_per_s": (r.unstable()[0].growth_rate
                                                 if r.unstable() else 0.0),
             "modes": [[m.frequency_hz, m.growth_rate, m.k] for m in r.modes]}
            for r in sweep
        ]
    if args.plot:
        if sweep is not None:
            red = {float(f): reduced_model_flutter(scene.with_overrides(f"loading.f={f}"),
                                                   args.kmax) for f in fs if f > 0}
            plot_cea_diagram(sweep, args.plot, k_detail=args.k_detail, kmax=args.kmax,
                             reduced=red, title=f"CEA of steady sliding: {scene.name} "
                             f"({res.n_free} free dofs, {res.mass} mass, up to "
                             f"{args.fmax_hz:g} Hz)")
        else:
            plot_spectrum(res, args.plot, reduced=reduced)
    if args.json:
        print(json.dumps(out, indent=2))
    else:
        _print_table(res, reduced, args.top, args.plot)
    return 0


def _print_table(res: CEAResult, reduced: list[dict], top: int, plot: str | None) -> None:
    uns = res.unstable()
    lines = [
        f"CEA of steady sliding: scene '{res.scene}', f = {res.f:g}, {res.mass} mass, "
        f"{res.n_free} free dofs",
        f"{len(res.modes)} modes up to {res.fmax_hz:g} Hz, {len(uns)} unstable; "
        f"eigensolve {res.timings['eigensolve']:.2f} s ({res.stats.slices} slices)",
        f"{'freq (Hz)':>10} {'growth (1/s)':>12} {'k':>4} {'direction':>9} "
        f"{'speed (m/s)':>11} {'purity':>6}",
    ]
    for m in uns[:top]:
        lines.append(f"{m.frequency_hz:10.1f} {m.growth_rate:12.2f} {m.wavenumber:4d} "
                     f"{m.direction:>9} {m.phase_speed_m_s:11.1f} {m.purity:6.3f}")
    lines.append("per k (Hz, 1/s, m/s; speed + = rotation sense):")
    lines.append(f"{'k':>4} | {'FE lowest branch':^28} | {'FE most unstable':^28} | "
                 f"{'reduced model eq. [2]':^28}")
    red = {r["k"]: r for r in reduced}
    best = res.by_wavenumber()
    for k in sorted(best):
        if k == 0 or k not in red:
            continue
        low = _distinct(m for m in res.modes if m.wavenumber == k)[0]
        cells = [(m.frequency_hz, m.growth_rate, m.phase_speed_m_s) for m in (low, best[k])]
        cells.append((red[k]["frequency_hz"], red[k]["growth_rate_per_s"],
                      red[k]["phase_speed_m_s"]))
        lines.append(f"{k:4d} | " + " | ".join(f"{a:8.1f} {b:8.1f} {c:+9.1f}" for a, b, c in cells))
    if plot:
        lines.append(f"figure: {plot}")
    print("\n".join(lines))
