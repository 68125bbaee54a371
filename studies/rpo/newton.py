"""Newton–Krylov with a hookstep (Viswanath 2007, J. Fluid Mech. 580; channelflow's
``findorbit``): the root of a square system F(X) = 0 whose Jacobian is known only through
products J v.

Each Newton iteration builds a Krylov basis V_k of J by Arnoldi (GMRES): J V_k = V_{k+1} H_k,
H_k the (k + 1) × k Hessenberg matrix, until the least-squares residual
min ‖H_k y − β e₁‖ (β = ‖F‖) is at most ``gmres_tol`` β or k = ``max_krylov``. The step is
δX = V_k y with y the **hookstep**: the minimiser of ‖H_k y − β e₁‖ subject to ‖y‖ ≤ Δ,
from the SVD H_k = U Σ Wᵀ: y = W z, z_i = σ_i p_i / (σ_i² + μ), p = Uᵀ β e₁, μ ≥ 0 the
Lagrange multiplier found so that ‖z‖ = Δ (μ = 0, the GMRES step, when it lies inside).
The trust radius Δ follows the ratio ρ of the actual to the predicted decrease of ‖F‖²:
ρ < 0.01 rejects the step and halves Δ (a new hookstep in the same basis, no new Krylov
products); ρ > 0.75 with the step on the boundary doubles Δ.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Iterate", "NewtonResult", "arnoldi", "hookstep", "newton_krylov_hookstep"]


@dataclass
class Iterate:
    """One Newton iteration: the residual before it, its Krylov dimension, the trust radius
    and step size taken, the number of trial steps, the residual after it."""

    iteration: int
    residual: float
    krylov: int
    radius: float
    step: float
    trials: int
    residual_after: float

    def to_dict(self) -> dict:
        return dict(self.__dict__)


@dataclass
class NewtonResult:
    """The last point, its residual ‖F‖, whether ‖F‖ ≤ tol, and the iterates."""

    X: np.ndarray
    residual: float
    converged: bool
    history: list[Iterate] = field(default_factory=list)
    message: str = ""

    @property
    def iterations(self) -> int:
        return len(self.history)


def arnoldi(jvp: Callable[[np.ndarray], np.ndarray], b: np.ndarray, max_krylov: int,
            tol: float) -> tuple[np.ndarray, np.ndarray]:
    """(V (M, k + 1), H (k + 1, k)) of the Krylov space of J from b: J V_k = V_{k+1} H_k,
    classical Gram–Schmidt applied twice (CGS2: orthogonal to round-off, each pass one
    matrix–vector product with the basis), stopped when the GMRES residual
    min ‖H_k y − β e₁‖ is ≤ tol ‖b‖ (module docstring) or at ``max_krylov``. That residual
    is kept by Givens rotations, O(k) a step: the QR factors of H_k are updated by one
    rotation per column, and |g_{k+1}| of the rotated β e₁ is the residual (Saad, Iterative
    Methods for Sparse Linear Systems, §6.5.3). tol ≤ 0 builds all ``max_krylov`` vectors
    (the Floquet multipliers). The basis is stored by rows, each vector contiguous."""
    beta = float(np.linalg.norm(b))
    V = np.zeros((max_krylov + 1, b.size))
    H = np.zeros((max_krylov + 1, max_krylov))
    cs, sn = np.zeros(max_krylov), np.zeros(max_krylov)
    g = np.zeros(max_krylov + 1)
    g[0] = beta
    V[0] = b / beta
    k = 0
    for j in range(max_krylov):
        w = jvp(V[j])
        for _ in range(2):
            c = V[: j + 1] @ w
            w -= c @ V[: j + 1]
            H[: j + 1, j] += c
        H[j + 1, j] = float(np.linalg.norm(w))
        k = j + 1
        col = H[: j + 2, j].copy()
        for i in range(j):  # the earlier rotations on the new column
            col[i], col[i + 1] = cs[i] * col[i] + sn[i] * col[i + 1], \
                -sn[i] * col[i] + cs[i] * col[i + 1]
        rho = math.hypot(col[j], col[j + 1])
        cs[j], sn[j] = (1.0, 0.0) if rho == 0.0 else (col[j] / rho, col[j + 1] / rho)
        g[j], g[j + 1] = cs[j] * g[j], -sn[j] * g[j]
        if H[j + 1, j] == 0.0 or (tol > 0.0 and abs(g[j + 1]) <= tol * beta):
            break
        V[j + 1] = w / H[j + 1, j]
    return V[: k + 1].T, H[: k + 1, :k]


def hookstep(H: np.ndarray, beta: float, radius: float) -> tuple[np.ndarray, float]:
    """(y, predicted ‖H y − β e₁‖) with ‖y‖ ≤ radius (module docstring)."""
    U, sig, Wt = np.linalg.svd(H, full_matrices=False)
    p = beta * U[0, :]
    keep = sig > 1e-14 * sig[0]
    sig, p, Wt = sig[keep], p[keep], Wt[keep]

    def z_of(mu: float) -> np.ndarray:
        return sig * p / (sig**2 + mu)

    z = z_of(0.0)
    if np.linalg.norm(z) > radius:
        # ‖z(μ)‖ decreases in μ and ‖z(μ)‖ ≤ ‖σ p‖/μ: bisection on [0, ‖σ p‖/radius]
        lo, hi = 0.0, float(np.linalg.norm(sig * p)) / radius
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            if np.linalg.norm(z_of(mid)) > radius:
                lo = mid
            else:
                hi = mid
            if hi - lo <= 1e-13 * hi:
                break
        z = z_of(hi)
    y = Wt.T @ z
    rhs = np.zeros(H.shape[0])
    rhs[0] = beta
    return y, float(np.linalg.norm(H @ y - rhs))


def newton_krylov_hookstep(residual: Callable[[np.ndarray], np.ndarray],
                           linearise: Callable[[np.ndarray], Callable],
                           X0: np.ndarray, *, tol: float = 1e-10, max_iter: int = 20,
                           max_krylov: int = 60, gmres_tol: float = 1e-3,
                           radius: float = 0.1, log: Callable[[str], None] | None = None
                           ) -> NewtonResult:
    """The root of ``residual`` from X0 (module docstring). ``linearise(X)`` returns the
    product v ↦ J(X) v. Stops when ‖F‖ ≤ ``tol``, after ``max_iter`` iterations, or when
    the trust radius collapses below 1e-12 (message says which)."""
    X = np.array(X0, dtype=float)
    F = residual(X)
    r = float(np.linalg.norm(F))
    out = NewtonResult(X, r, r <= tol)
    for it in range(max_iter):
        if r <= tol:
            break
        jvp = linearise(X)
        V, H = arnoldi(jvp, -F, max_krylov, gmres_tol)
        trials = 0
        while True:
            trials += 1
            y, pred = hookstep(H, r, radius)
            dX = V[:, : H.shape[1]] @ y
            X_new = X + dX
            F_new = residual(X_new)
            r_new = float(np.linalg.norm(F_new))
            denom = r**2 - pred**2
            rho = (r**2 - r_new**2) / denom if denom > 0 else -1.0
            on_edge = float(np.linalg.norm(y)) >= 0.99 * radius
            if rho >= 0.01 or r_new < r:
                if rho > 0.75 and on_edge:
                    radius *= 2.0
                break
            radius *= 0.5
            if radius < 1e-12:
                out.message = "trust radius collapsed: no descent along the Krylov space"
                return out
        step = float(np.linalg.norm(y))
        out.history.append(Iterate(it, r, H.shape[1], radius, step, trials, r_new))
        if log is not None:
            log(f"  newton {it}: |G| {r:.3e} -> {r_new:.3e}  krylov {H.shape[1]}  "
                f"step {step:.2e}  radius {radius:.2e}  trials {trials}")
        X, F, r = X_new, F_new, r_new
        out.X, out.residual = X, r
        out.converged = r <= tol
    if not out.converged and not out.message:
        out.message = f"not converged in {max_iter} iterations (|G| = {r:.3e})"
    return out
