"""Floquet multipliers of a relative periodic orbit: the leading eigenvalues μ of the
linearised map rotated back, M δξ = R₋ₛ DF_T(ξ) δξ (``orbit.OrbitProblem.monodromy``), by
Arnoldi: ``krylov`` products (each one central difference of the map in lockstep) from a
random vector, M V_m = V_{m+1} H_m, the Ritz values of the square H_m as the multipliers and
|h_{m+1,m} e_mᵀ y| (y the Ritz vector of H_m) as each one's residual ‖M x − μ x‖. A
contracting map's leading multipliers converge first; a fixed basis keeps the cost at
``krylov`` maps (an implicitly restarted Arnoldi, ARPACK, did not finish in 8 minutes on
the N = 132 orbit: its cluster of strongly damped multipliers).

Two multipliers are neutral where the orbit has the two continuous symmetries: time (the
orbit's own direction, e_t) and rotation (e_θ = ∂_θ ξ), each with μ = 1. They are
identified as the two eigenvectors with the largest share in span{e_t, e_θ} (their
projection over their norm), not by |μ − 1| alone, so that an unstable real multiplier near
1 is not taken for one. The orbit is **stable** when every other multiplier has |μ| < 1;
the verdict is None while a non-neutral Ritz residual exceeds ``RITZ_TOL``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stickslip.studies.rpo.newton import arnoldi

__all__ = ["Floquet", "floquet_multipliers"]

RITZ_TOL = 1e-3  #: a Ritz pair whose residual ‖M x − μ x‖ (unit x) is above this is unconverged


@dataclass
class Floquet:
    """The leading multipliers (by modulus), which of them are neutral, their shares in
    the neutral plane, and the verdict."""

    multipliers: np.ndarray
    neutral: np.ndarray  # bool per multiplier
    neutral_share: np.ndarray
    ritz_residual: np.ndarray  # ‖M x − μ x‖ of each (unit) Ritz vector

    @property
    def moduli(self) -> np.ndarray:
        return np.abs(self.multipliers)

    @property
    def leading_other(self) -> float:
        """The largest |μ| of the non-neutral multipliers."""
        other = self.moduli[~self.neutral]
        return float(other.max()) if other.size else 0.0

    @property
    def converged(self) -> bool:
        """Every non-neutral Ritz pair has a residual ≤ ``RITZ_TOL``."""
        return bool(np.all(self.ritz_residual[~self.neutral] <= RITZ_TOL))

    @property
    def stable(self) -> bool | None:
        """|μ| < 1 for every non-neutral multiplier; None while the Ritz pairs have not
        converged (a verdict on unconverged Ritz values would be a guess)."""
        return self.leading_other < 1.0 if self.converged else None

    def to_dict(self) -> dict:
        return {"moduli": [float(m) for m in self.moduli],
                "multipliers": [[float(m.real), float(m.imag)] for m in self.multipliers],
                "neutral": [bool(b) for b in self.neutral],
                "neutral_share": [float(x) for x in self.neutral_share],
                "ritz_residual": [float(x) for x in self.ritz_residual],
                "leading_non_neutral": self.leading_other, "converged": self.converged,
                "stable": self.stable}


def floquet_multipliers(problem, guess, count: int = 12, krylov: int = 60,
                        seed: int = 1) -> Floquet:
    """The ``count`` leading multipliers of ``guess`` (an ``orbit.Guess`` of ``problem``, an
    ``orbit.OrbitProblem``) from ``krylov`` Arnoldi steps, with the neutral pair marked
    (module docstring)."""
    apply = problem.monodromy(guess)
    v0 = np.random.default_rng(seed).standard_normal(guess.xi.size)
    V, H = arnoldi(apply, v0, krylov, 0.0)
    m = H.shape[1]
    vals, y = np.linalg.eig(H[:m, :m])
    order = np.argsort(-np.abs(vals))[:count]
    vals, y = vals[order], y[:, order]
    y = y / np.linalg.norm(y, axis=0)
    ritz_res = np.abs(H[m, m - 1] * y[-1, :]) if H.shape[0] > m else np.zeros(vals.size)
    vecs = V[:, :m] @ y
    e_t = problem.flow(guess.xi, guess.period, steps=1) - guess.xi
    e_th = problem.d_theta(guess.xi)
    basis, _ = np.linalg.qr(np.c_[e_t, e_th])
    share = np.linalg.norm(basis.T @ vecs, axis=0) / np.linalg.norm(vecs, axis=0)
    neutral = np.zeros(vals.size, dtype=bool)
    neutral[np.argsort(-share)[:2]] = True
    return Floquet(vals, neutral, share, ritz_res)
