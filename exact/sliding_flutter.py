"""Exact flutter of steady sliding of the clamped annulus: every branch per order n.

Linearised sliding (every point of ``r = R`` stays in contact and slips forward): the
perturbation keeps ``u_r = 0`` and ``σ_rθ = f_eff(ω) σ_rr`` at ``r = R``; clamped at ``ξR``.
This is the N → ∞ limit of ``stickslip flutter-fe`` (docs/flutter.md) and of the seeded
transient in its linear phase. One scalar equation per order n in complex ω
(the determinant of :func:`exact.annulus.sliding_matrix`); its roots are found in two steps:

1. **all** eigenvalues in the band from a Chebyshev collocation of the same boundary-value
   problem (a dense matrix problem: nothing is missed by a root search);
2. each one polished by the secant method on the Bessel determinant (the exact answer);
   the collocation-to-Bessel shift is recorded (``shift``), and a root that does not
   converge near its seed is flagged ``polished = False``.

Dissipation (default off, :class:`Dissipation`):

* Kelvin-Voigt bulk viscosity ``σ = C:(ε + τ ε̇)``: moduli × ``(1 − iωτ)``;
  ``τ = η / (2π f_ref)`` for a loss factor ``η`` at ``f_ref``;
* linearised Prakash-Clifton friction: the friction bound is ``f σ_eff`` with
  ``dσ_eff/dt = −(|V| + V*)/L (σ_eff − p)``. In steady sliding ``σ_eff = p`` and the
  perturbation of ``|V|`` multiplies ``σ_eff − p = 0``, so to first order
  ``σ_eff' = p' / (1 − iω t*)`` (time factor ``e^{−iωt}``) with ``t* = L/(R|Ω| + V*)``,
  or ``t*`` = ``relaxation_time`` for the constant-time variant:
  ``f_eff(ω) = f / (1 − iω t*)``.

Sign conventions: a wave ``e^{i(nθ − ωt)}``, ``n ≥ 0``; ``Re ω > 0`` travels in the
rotation sense (``direction = "rotation"``), ``Re ω < 0`` against it (``"opposite"``).
Growth rate ``Im ω`` (1/s), frequency ``|Re ω|/2π`` (Hz), phase speed ``R Re ω / n``
(m/s, + = rotation sense, the ``celerity_m_s`` convention of ``stickslip run``).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from stickslip.exact.annulus import Elastic, collocation_operators, sliding_matrix

__all__ = [
    "ELASTIC",
    "Branch",
    "Dissipation",
    "OrderSpectrum",
    "band_limit",
    "collocation_roots",
    "polish",
    "sliding_branches",
]


@dataclass(frozen=True)
class Dissipation:
    """Kelvin-Voigt retardation time ``tau`` (s) and friction relaxation time ``t_star`` (s);
    0 = off (elastic, Coulomb)."""

    tau: float = 0.0
    t_star: float = 0.0

    def f_eff(self, f: float, omega: complex) -> complex:
        """Linearised friction coefficient ``f / (1 − iω t*)``."""
        return f / (1.0 - 1j * omega * self.t_star) if self.t_star > 0 else complex(f)

    @staticmethod
    def from_loss_factor(eta: float, f_ref_hz: float) -> float:
        """Retardation time ``τ = η / (2π f_ref)`` (loss factor η at frequency f_ref)."""
        return eta / (2.0 * math.pi * f_ref_hz)

    @staticmethod
    def prakash_clifton_time(slip_length: float, sliding_speed: float,
                             reference_velocity: float) -> float:
        """``t* = L / (|V| + V*)`` with ``|V| = R|Ω|`` the steady slip rate."""
        return slip_length / (abs(sliding_speed) + reference_velocity)


ELASTIC = Dissipation()  #: no dissipation (elastic bulk, Coulomb friction)


@dataclass(frozen=True)
class Branch:
    """One real motion ``Re(… e^{i(nθ − ωt)})`` of the linearised sliding annulus."""

    n: int
    frequency_hz: float
    growth_rate: float  # Im ω (1/s), > 0: flutter
    direction: str  # "rotation" | "opposite" | "standing"
    phase_speed_m_s: float  # R Re ω / n (+ = rotation sense); 0 for n = 0
    omega_re: float
    omega_im: float
    shift: float  # |ω_Bessel − ω_collocation| / |ω|
    polished: bool

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass
class OrderSpectrum:
    """All branches of order n in the band (sorted by frequency)."""

    n: int
    f: float
    band_hz: float
    branches: list[Branch]
    collocation_points: int

    def most_unstable(self) -> Branch | None:
        return max(self.branches, key=lambda b: b.growth_rate, default=None)


def band_limit(n: int, mat: Elastic, fmax_hz: float, speed_factor: float) -> float:
    """Band of order n (Hz): ``max(fmax_hz, speed_factor · c_p · n / (2πR))``."""
    return max(fmax_hz, speed_factor * mat.cp * abs(n) / (2 * math.pi * mat.R))


def _points(n: int, mat: Elastic, omega_max: float) -> int:
    """Collocation points: ~π per shear wavelength through the thickness, plus the
    ``e^{−n(r−R)/R}`` boundary layer of high orders (checked by the Bessel polish)."""
    h = (mat.xi - 1.0) * mat.R
    return int(28 + 0.8 * h * omega_max / mat.cs + 0.3 * abs(n))


def collocation_roots(
    n: int, f: float, mat: Elastic, omega_max: float, diss: Dissipation = ELASTIC,
    N: int | None = None,
) -> tuple[np.ndarray, int]:
    """Every ω (both signs of Re ω) with ``|Re ω| ≤ omega_max`` and ``Im ω ≥ −omega_max``
    of the collocated problem. Undamped and Kelvin-Voigt: the boundary rows are eliminated
    and ``−L/ρ`` gives ``μ = ω²/(1 − iωτ)`` (friction row independent of ω); with a
    friction relaxation time the quadratic problem ``(A₀ + ωA₁ + ω²A₂)x = 0`` is solved
    by companion linearisation."""
    import scipy.linalg as sla

    N = N or _points(n, mat, omega_max)
    col = collocation_operators(n, mat, N)
    M = 2 * (N + 1)
    iu0, iuN, iw0, iwN = 0, N, N + 1, 2 * N + 1
    interior = np.array([j for j in range(M) if j not in (iu0, iuN, iw0, iwN)])
    fr_S, fr_s = col.S[0].astype(complex), col.srr[0].astype(complex)
    if diss.t_star <= 0:
        row = fr_S + 1j * f * fr_s  # S + i f σ_rr = 0 at r = R
        # x_B: U_0 = U_N = W_N = 0, W_0 = −row_I x_I / row_W0
        T = -row[interior] / row[iw0]
        L = col.L.astype(complex)
        A = L[np.ix_(interior, interior)] + np.outer(L[interior, iw0], T)
        mu = sla.eigvals(-A / mat.rho)
        if diss.tau > 0:  # ω² + iτμω − μ = 0
            disc = np.sqrt(-(diss.tau * mu) ** 2 + 4 * mu)
            w = np.concatenate([(-1j * diss.tau * mu + disc) / 2, (-1j * diss.tau * mu - disc) / 2])
        else:
            s = np.sqrt(mu)
            w = np.concatenate([s, -s])
    else:
        # unknowns: all but U_0, U_N, W_N (zero); rows: the interior equations and the
        # friction row (1 − iωt*) S + i f σ_rr = 0; ω = ω₀ ŵ, rows scaled to O(1)
        cols = np.array([j for j in range(M) if j not in (iu0, iuN, iwN)])
        w0 = mat.cs / ((mat.xi - 1.0) * mat.R)
        Lr = col.L[np.ix_(interior, cols)] / (mat.rho * w0**2)
        fr0 = (fr_S + 1j * f * fr_s)[cols]
        fr1 = -1j * diss.t_star * w0 * fr_S[cols]
        nrm = max(np.max(np.abs(fr0)), np.max(np.abs(fr1)))
        m = cols.size
        A0 = np.vstack([Lr, fr0 / nrm]).astype(complex)
        A1 = np.vstack([-1j * diss.tau * w0 * Lr, fr1 / nrm])
        A2 = np.zeros((m, m), dtype=complex)
        A2[np.arange(m - 1), np.searchsorted(cols, interior)] = 1.0
        Id, Zm = np.eye(m), np.zeros((m, m))
        big_a = np.block([[Zm, Id], [A0, A1]])
        big_b = np.block([[Id, Zm], [Zm, -A2]])
        w = sla.eigvals(big_a, big_b)
        w = w[np.isfinite(w)] * w0  # the Dirichlet-free B is singular: infinite ones
    keep = (np.abs(w.real) <= omega_max) & (w.imag >= -omega_max) & (np.abs(w) > 1e-6)
    if n == 0:
        keep &= w.real >= 0  # ±ω are the same axisymmetric motion
    return w[keep], N


def polish(
    omega0: np.ndarray, n: int, f: float, mat: Elastic, diss: Dissipation = ELASTIC,
    rtol: float = 1e-12, maxiter: int = 60,
) -> tuple[np.ndarray, np.ndarray]:
    """Secant iteration on the Bessel determinant from each seed of ``omega0`` (vectorised
    over the seeds; constant column scaling taken at each seed, so each function iterated is
    analytic). Returns (roots, converged)."""
    x0 = np.array(omega0, dtype=complex).ravel()  # a copy: iterated in place
    # basis J, H⁽¹⁾ where Im α ≥ 0 (α = ω / c_p sqrt(1 − iωτ)), else J, H⁽²⁾; fixed per seed
    upper = (x0 / np.sqrt(1.0 - 1j * x0 * diss.tau)).imag >= 0
    scale = 1.0 / np.maximum(np.max(np.abs(sliding_matrix(x0, n, 0.0, mat, diss.tau, upper)),
                                    axis=-2), 1e-300)  # (m, 4)

    def g(w: np.ndarray, idx: np.ndarray) -> np.ndarray:
        M = sliding_matrix(w, n, diss.f_eff(f, w), mat, diss.tau, upper[idx])
        return np.linalg.det(M * scale[idx, None, :])

    allidx = np.arange(x0.size)
    x1 = x0 * (1 + 1e-7) + 1e-7 * np.abs(x0) * 1j
    g0, g1 = g(x0, allidx), g(x1, allidx)
    active = allidx
    for _ in range(maxiter):
        a = active
        den = g1[a] - g0[a]
        safe = (den != 0) & np.isfinite(den)
        x2 = x1[a].copy()
        x2[safe] = x1[a][safe] - g1[a][safe] * (x1[a][safe] - x0[a][safe]) / den[safe]
        bad = ~np.isfinite(x2)
        x2[bad] = x1[a][bad]
        x0[a], g0[a] = x1[a], g1[a]
        x1[a] = x2
        g1[a] = g(x2, a)
        finished = (np.abs(x1[a] - x0[a]) <= rtol * np.abs(x1[a])) | ~safe | bad
        active = a[~finished]
        if active.size == 0:
            break
    ok = np.abs(x1 - x0) <= 1e-9 * np.abs(x1)
    return x1, ok


def sliding_branches(
    n: int, f: float, mat: Elastic, *, fmax_hz: float = 3000.0, speed_factor: float = 0.0,
    diss: Dissipation = ELASTIC, N: int | None = None,
) -> OrderSpectrum:
    """Every branch of order ``n ≥ 0`` with frequency ≤ :func:`band_limit`, exact
    (collocation seeds, Bessel polish); see the module docstring for conventions."""
    if n < 0:
        raise ValueError(f"n={n}: use n >= 0 (direction comes from the sign of Re ω)")
    band = band_limit(n, mat, fmax_hz, speed_factor)
    wmax = 2 * math.pi * band
    seeds, npts = collocation_roots(n, f, mat, wmax * 1.02, diss, N)
    out: list[Branch] = []
    seen: list[complex] = []
    roots, conv = polish(seeds, n, f, mat, diss) if seeds.size else (seeds, seeds.real > 0)
    for w0, w, ok in zip(seeds, roots, conv, strict=True):
        w0, w = complex(w0), complex(w)
        shift = abs(w - w0) / abs(w0)
        if not ok or shift > 1e-3:
            w, ok = complex(w0), False
        if abs(w.real) > wmax:
            continue
        if any(abs(w - s) <= 1e-8 * abs(w) for s in seen):
            continue
        seen.append(w)
        standing = abs(w.real) <= 1e-9 * abs(w) or n == 0
        direction = "standing" if standing else ("rotation" if w.real > 0 else "opposite")
        out.append(Branch(
            n=n, frequency_hz=abs(w.real) / (2 * math.pi), growth_rate=w.imag,
            direction=direction,
            phase_speed_m_s=(mat.R * w.real / n) if n else 0.0,
            omega_re=w.real, omega_im=w.imag, shift=float(shift), polished=bool(ok),
        ))
    out.sort(key=lambda b: (b.frequency_hz, -b.growth_rate))
    return OrderSpectrum(n=n, f=f, band_hz=band, branches=out, collocation_points=npts)

