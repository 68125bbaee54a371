"""Plane-strain annulus ``R ≤ r ≤ ξR``, clamped at ``r = ξR``: exact modal building blocks.

Fields per circumferential order ``n`` (signed integer) and time factor ``e^{-iωt}``::

    u_r = U(r) e^{i(nθ-ωt)},   u_θ = i W(r) e^{i(nθ-ωt)}

(the factor ``i`` on ``u_θ`` makes every operator below real for real ω and real moduli).
The friction row at ``r = R`` is ``S + i f_eff σ_rr = 0`` with ``σ_rθ = i S``, i.e.
``σ_rθ = f_eff σ_rr``: the rigid cylinder (inside the tube) slides in ``+θ``, so the tube
feels the traction ``λ(e_r + f e_θ)`` with ``λ = −σ_rr > 0``. A root ``ω`` with
``Re ω > 0`` and ``n > 0`` is a wave travelling in ``+θ`` (the rotation sense); its growth
rate is ``Im ω``.

Two independent discretisations of the same boundary-value problem:

* **Bessel potentials** (exact): ``φ = F(r) e^{inθ}``, ``ψ = i H(r) e^{inθ}`` with
  ``F = A J_|n|(αr) + B Y_|n|(αr)``, ``H = C J_|n|(βr) + D Y_|n|(βr)``, ``α = ω/c_p``,
  ``β = ω/c_s`` (complex for complex ω or complex moduli)::

      U = F' − nH/r,   W = nF/r − H',
      σ_rr/μ = −(λ/μ) α² F + 2 (F'' − nH'/r + nH/r²),
      S/μ   = 2nF'/r − 2nF/r² − 2n²H/r² + 2H'/r + β² H

  The 4×4 determinant with rows ``U(R)``, ``S/μ + i f σ_rr/μ`` at ``R``, ``U(ξR)``, ``W(ξR)``
  vanishes at the eigenfrequencies (the determinant of :func:`sliding_matrix`).
* **Chebyshev collocation** in r of the Navier equations in stress form
  (:func:`collocation_operators`): a dense matrix problem giving every eigenvalue in a band at
  once; its roots seed the Newton polish on the Bessel determinant, and the agreement of the
  two is a check of both.

Kelvin-Voigt damping ``σ = C:(ε + τ ε̇)`` multiplies both moduli by ``(1 − iωτ)``:
``c² → c²(1 − iωτ)``. The f = 0 real frequencies (:func:`annulus_sliding_frequencies`) are
the verification reference of docs/flutter.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = [
    "Elastic",
    "annulus_sliding_frequencies",
    "bessel_columns",
    "chebyshev",
    "collocation_operators",
]


@dataclass(frozen=True)
class Elastic:
    """Isotropic plane-strain material and annulus geometry (SI units)."""

    E: float
    rho: float
    nu: float
    R: float = 1.0
    xi: float = 1.25

    @property
    def lam(self) -> float:
        """Lamé λ = Eν/((1+ν)(1−2ν))."""
        return self.E * self.nu / ((1 + self.nu) * (1 - 2 * self.nu))

    @property
    def mu(self) -> float:
        """Shear modulus μ = E/(2(1+ν))."""
        return self.E / (2 * (1 + self.nu))

    @property
    def cp(self) -> float:
        """Pressure wave speed sqrt((λ+2μ)/ρ)."""
        return math.sqrt((self.lam + 2 * self.mu) / self.rho)

    @property
    def cs(self) -> float:
        """Shear wave speed sqrt(μ/ρ)."""
        return math.sqrt(self.mu / self.rho)


def _second(m: int, z: np.ndarray, upper: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """The second radial solution and its derivative: ``Y_m`` (``upper is None``), else
    ``H⁽¹⁾_m`` where ``upper`` (decays for Im z > 0) and ``H⁽²⁾_m`` elsewhere. With ``J_m``
    this basis stays well conditioned for strongly growing or decaying waves
    (|Im z| ≫ 1), where ``J`` and ``Y`` both grow like ``e^{|Im z|}`` and cancel."""
    from scipy.special import h1vp, h2vp, hankel1, hankel2, yv, yvp

    if upper is None:
        return yv(m, z), yvp(m, z)
    up = np.broadcast_to(upper, z.shape)
    return (np.where(up, hankel1(m, z), hankel2(m, z)),
            np.where(up, h1vp(m, z), h2vp(m, z)))


def bessel_columns(
    omega: complex | np.ndarray, n: int, r: float, mat: Elastic, tau: float = 0.0,
    upper: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(U, W, σ_rr/μ̃, S/μ̃) at radius ``r`` of the 4 potentials ``J_|n|(αr)``, second(αr)
    (for F) and ``J_|n|(βr)``, second(βr) (for H), second = ``Y`` or a Hankel function
    (:func:`_second`); ``μ̃ = μ(1 − iωτ)`` (Kelvin-Voigt).
    ``omega`` may be an array: the results have shape ``omega.shape + (4,)``."""
    from scipy.special import jv, jvp

    m = abs(int(n))
    w = np.asarray(omega, dtype=complex)[..., None]
    up = None if upper is None else np.asarray(upper)[..., None]
    visc = 1.0 - 1j * w * tau
    al = w / (mat.cp * np.sqrt(visc))
    be = w / (mat.cs * np.sqrt(visc))
    za, zb = al * r, be * r
    zero = np.zeros_like(w)
    ya, ypa = _second(m, za, up)
    yb, ypb = _second(m, zb, up)
    F = np.concatenate([jv(m, za), ya, zero, zero], axis=-1)
    Fp = np.concatenate([al * jvp(m, za), al * ypa, zero, zero], axis=-1)
    H = np.concatenate([zero, zero, jv(m, zb), yb], axis=-1)
    Hp = np.concatenate([zero, zero, be * jvp(m, zb), be * ypb], axis=-1)
    Fpp = -Fp / r - (al**2 - m * m / r**2) * F  # Bessel's equation
    U = Fp - n * H / r
    W = n * F / r - Hp
    srr = -(mat.lam / mat.mu) * al**2 * F + 2 * (Fpp - n * Hp / r + n * H / r**2)
    S = 2 * n * Fp / r - 2 * n * F / r**2 - 2 * n * n * H / r**2 + 2 * Hp / r + be**2 * H
    return U, W, srr, S


def sliding_matrix(
    omega: complex | np.ndarray, n: int, f_eff: complex | np.ndarray, mat: Elastic,
    tau: float = 0.0, upper: np.ndarray | None = None,
) -> np.ndarray:
    """The 4×4 matrix (rows ``U(R)``, ``S + i f σ_rr`` at ``R``, ``U(ξR)``, ``W(ξR)``;
    shape ``omega.shape + (4, 4)``); ``upper``: Hankel basis choice (:func:`_second`)."""
    Ua, _, sa, Sa = bessel_columns(omega, n, mat.R, mat, tau, upper)
    Ub, Wb, _, _ = bessel_columns(omega, n, mat.xi * mat.R, mat, tau, upper)
    fe = np.asarray(f_eff)[..., None]
    return np.stack([Ua * mat.R, (Sa + 1j * fe * sa) * mat.R**2, Ub * mat.R, Wb * mat.R],
                    axis=-2)


def annulus_sliding_frequencies(
    k: int, R: float, xi: float, E: float, nu: float, rho: float, fmax_hz: float,
    df_hz: float = 0.5,
) -> np.ndarray:
    """Natural frequencies (Hz) of order ``k`` of the annulus in frictionless sliding contact
    (``u_r = 0``, ``σ_rθ = 0`` at ``r = R``, clamped at ``ξR``): the f = 0 limit.

    The real determinant of :func:`sliding_matrix` (f = 0, real ω, positive column scaling)
    is bracketed on a ``df_hz`` grid and refined with ``brentq``.
    """
    from scipy.optimize import brentq

    mat = Elastic(E=E, rho=rho, nu=nu, R=R, xi=xi)

    def det(w: np.ndarray) -> np.ndarray:
        M = sliding_matrix(np.atleast_1d(w), k, 0.0, mat).real
        M = M / np.max(np.abs(M), axis=-2, keepdims=True)  # positive: keeps the sign
        return np.linalg.det(M)

    w = 2 * math.pi * np.arange(max(df_hz, 1.0), fmax_hz + df_hz, df_hz)
    d = det(w)
    roots = [brentq(lambda x: float(det(x)[0]), w[i], w[i + 1], xtol=1e-10)
             for i in np.flatnonzero(np.sign(d[:-1]) * np.sign(d[1:]) < 0)]
    return np.array(roots) / (2 * math.pi)


# ------------------------------------------------------------------------- collocation


def chebyshev(N: int) -> tuple[np.ndarray, np.ndarray]:
    """Chebyshev-Gauss-Lobatto points ``x_j = cos(πj/N)`` and differentiation matrix."""
    x = np.cos(np.pi * np.arange(N + 1) / N)
    c = np.ones(N + 1)
    c[0] = c[-1] = 2.0
    c *= (-1.0) ** np.arange(N + 1)
    X = x[:, None] - x[None, :]
    D = np.outer(c, 1.0 / c) / (X + np.eye(N + 1))
    D -= np.diag(D.sum(axis=1))
    return x, D


@dataclass
class Collocation:
    """Operators on ``x = [U_0..U_N, W_0..W_N]`` at ``r_j`` (``r_0 = R``, ``r_N = ξR``)."""

    r: np.ndarray
    L: np.ndarray  # Navier operator (both equations, all nodes): L x + ρω² x = 0 inside
    srr: np.ndarray  # σ_rr rows (2(N+1) columns)
    S: np.ndarray  # σ_rθ / i rows


def collocation_operators(n: int, mat: Elastic, N: int) -> Collocation:
    """Chebyshev collocation (N+1 points in r) of the Navier equations in stress form::

        σ_rr' − nS/r + (σ_rr − σ_θθ)/r + ρω²U = 0,   S' + nσ_θθ/r + 2S/r + ρω²W = 0

    with ``σ_rr = (λ+2μ)U' + λ(U − nW)/r``, ``σ_θθ = λU' + (λ+2μ)(U − nW)/r``,
    ``S = μ(nU/r + W' − W/r)`` (elastic moduli; Kelvin-Voigt scales all of them).
    """
    x, Dx = chebyshev(N)
    h = (mat.xi - 1.0) * mat.R
    r = mat.R + h * (1.0 - x) / 2.0
    D = Dx * (-2.0 / h)
    Z = np.zeros((N + 1, N + 1))
    Id = np.eye(N + 1)
    ri = np.diag(1.0 / r)
    lam, mu = mat.lam, mat.mu
    dU = np.hstack([D, Z])
    dW = np.hstack([Z, D])
    U = np.hstack([Id, Z])
    W = np.hstack([Z, Id])
    hoop = ri @ (U - n * W)
    srr = (lam + 2 * mu) * dU + lam * hoop
    stt = lam * dU + (lam + 2 * mu) * hoop
    S = mu * (n * ri @ U + dW - ri @ W)
    eq1 = D @ srr - n * ri @ S + ri @ (srr - stt)
    eq2 = D @ S + n * ri @ stt + 2 * ri @ S
    return Collocation(r=r, L=np.vstack([eq1, eq2]), srr=srr, S=S)
