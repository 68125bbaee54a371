"""Floquet multipliers of a relative periodic orbit: the leading eigenvalues μ of the
linearised map rotated back, M δξ = R₋ₛ DF_T(ξ) δξ (``orbit.OrbitProblem.monodromy``), by
Arnoldi: products (each one forward difference of the map) from a random vector,
M V_m = V_{m+1} H_m, the Ritz values of the square H_m as the multipliers and
|h_{m+1,m} e_mᵀ y| (y the Ritz vector of H_m) as each one's residual ‖M x − μ x‖. A
contracting map's leading multipliers converge first; a fixed basis keeps the cost at
``krylov`` maps (an implicitly restarted Arnoldi, ARPACK, did not finish in 8 minutes on
the N = 132 orbit: its cluster of strongly damped multipliers). Where the verdict below is
still open, the basis is built again at twice the size, up to ``krylov_max``.

Each multiplier's **growth rate** is σ = ln|μ| / T (1/s).

**Neutral multipliers.** Where the orbit has the two continuous symmetries, time (the
orbit's own direction, e_t) and rotation (e_θ = ∂_θ ξ), each has μ = 1: the two eigenvectors
with the largest share in span{e_t, e_θ} (their projection over their norm) are set aside,
not those nearest 1, so that an unstable real multiplier near 1 is not taken for one. With
the shift held at whole node passages (``hold_shift``, a rigid wave on the mesh) the scheme
has no continuous symmetry, and e_t and e_θ nearly coincide (∂_t = −ω ∂_θ on a rigid wave):
at most one eigenvector is set aside, the one with the largest share, and only where its
share is ≥ ``NEUTRAL_SHARE`` and |σ| ≤ ``GROWTH_TOL``. (On the public point's N = 264
rigid wave locked to 90 steps per 40 node passages the real μ = 1.0241, σ = 23 1/s, has a
share 0.97 and is a growing mode, as the map iterated from the orbit shows: it is not set
aside.)

**The verdict.** A multiplier is converged when its Ritz residual is ≤ ``RITZ_TOL``.
* **unstable**: a converged non-neutral multiplier grows faster than ``GROWTH_TOL``;
* **stable**: no non-neutral multiplier among the leading ``count``, converged or not, grows
  faster than ``GROWTH_TOL``;
* otherwise **None**: an unconverged Ritz value above the threshold might be spurious or
  real.
"Stable" so means: no mode grows faster than ``GROWTH_TOL``. A slower one would need
ln(10³)/σ > 7 s to grow from a 10⁻³ kick to the state's size, longer than a census's cap.

**The clamped dofs.** They carry no mass, so the scheme keeps their u and ṽ: on them the
map is a Jordan block at μ = 1 that is no mode of the tube. The Arnoldi start vector is zero
there, so every product is too. (A start with them put a crowd of spurious Ritz values at
|μ| = 1.00000x, residuals ~10⁻¹¹, among the public point's rigid wave's multipliers; without
them its fifth multiplier is 0.944.)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from stickslip.studies.rpo.newton import arnoldi

__all__ = ["Floquet", "floquet_multipliers", "growth_from_the_orbit"]

#: a Ritz pair whose residual ‖M x − μ x‖ (unit x) is above this is unconverged; spurious
#: Ritz values at 200 vectors on the public point's rigid wave (start vector on the clamped
#: dofs too) had 1.5e-5 and 3.3e-4, the converged ones ≤ 1e-13
RITZ_TOL = 1e-6
#: growth rate (1/s) from which a mode counts as growing (module docstring)
GROWTH_TOL = 1.0
#: share in span{e_t, e_θ} from which an eigenvector is the neutral one of a held shift
NEUTRAL_SHARE = 0.5


@dataclass
class Floquet:
    """The leading multipliers (by modulus) over the period ``period`` (s), which of them
    are neutral, their shares in the neutral plane, their Ritz residuals, the Krylov
    dimension used, and the verdict (module docstring)."""

    multipliers: np.ndarray
    neutral: np.ndarray  # bool per multiplier
    neutral_share: np.ndarray
    ritz_residual: np.ndarray  # ‖M x − μ x‖ of each (unit) Ritz vector
    period: float
    krylov: int = 0

    @property
    def moduli(self) -> np.ndarray:
        return np.abs(self.multipliers)

    @property
    def growth(self) -> np.ndarray:
        """σ = ln|μ| / T (1/s) of each multiplier."""
        return growth_rates(self.multipliers, self.period)

    @property
    def leading_other(self) -> float:
        """The largest |μ| of the non-neutral multipliers."""
        other = self.moduli[~self.neutral]
        return float(other.max()) if other.size else 0.0

    @property
    def fastest_growth(self) -> float:
        """The largest growth rate σ (1/s) of the non-neutral multipliers."""
        other = self.growth[~self.neutral]
        return float(other.max()) if other.size else -math.inf

    @property
    def converged(self) -> bool:
        """Every non-neutral Ritz pair has a residual ≤ ``RITZ_TOL``."""
        return bool(np.all(self.ritz_residual[~self.neutral] <= RITZ_TOL))

    @property
    def stable(self) -> bool | None:
        """The verdict (module docstring): False, True or None."""
        growing = ~self.neutral & (self.growth > GROWTH_TOL)
        if np.any(growing & (self.ritz_residual <= RITZ_TOL)):
            return False
        return None if np.any(growing) else True

    def to_dict(self) -> dict:
        return {"moduli": [float(m) for m in self.moduli],
                "multipliers": [[float(m.real), float(m.imag)] for m in self.multipliers],
                "growth_per_s": [float(g) for g in self.growth],
                "neutral": [bool(b) for b in self.neutral],
                "neutral_share": [float(x) for x in self.neutral_share],
                "ritz_residual": [float(x) for x in self.ritz_residual],
                "leading_non_neutral": self.leading_other,
                "fastest_growth_per_s": self.fastest_growth, "converged": self.converged,
                "period_s": self.period, "krylov": self.krylov,
                "growth_tol_per_s": GROWTH_TOL, "ritz_tol": RITZ_TOL,
                "stable": self.stable}


def growth_rates(multipliers: np.ndarray, period: float) -> np.ndarray:
    """σ = ln|μ| / T (1/s) of each multiplier μ over the period T."""
    return np.log(np.maximum(np.abs(multipliers), 1e-300)) / period


def neutral_marks(share: np.ndarray, growth: np.ndarray, held: bool) -> np.ndarray:
    """Which multipliers are neutral (module docstring): the two of largest ``share``, or
    with ``held`` at most the one of largest share, if its share ≥ ``NEUTRAL_SHARE`` and
    |growth| ≤ ``GROWTH_TOL``."""
    neutral = np.zeros(share.size, dtype=bool)
    if not held:
        neutral[np.argsort(-share)[:2]] = True
        return neutral
    top = int(np.argmax(share)) if share.size else 0
    if share.size and share[top] >= NEUTRAL_SHARE and abs(growth[top]) <= GROWTH_TOL:
        neutral[top] = True
    return neutral


def _ritz(problem, guess, V: np.ndarray, H: np.ndarray, count: int, held: bool) -> Floquet:
    """The ``count`` leading Ritz pairs of the basis (V, H) as a ``Floquet``."""
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
    growth = growth_rates(vals, guess.period)
    return Floquet(vals, neutral_marks(share, growth, held), share, ritz_res,
                   float(guess.period), m)


def floquet_multipliers(problem, guess, count: int = 12, krylov: int = 60,
                        seed: int = 1, krylov_max: int | None = None) -> Floquet:
    """The ``count`` leading multipliers of ``guess`` (an ``orbit.Guess`` of ``problem``, an
    ``orbit.OrbitProblem``) from ``krylov`` Arnoldi steps, with the neutral ones marked;
    while the verdict is None the basis is rebuilt at twice the size, up to ``krylov_max``
    (default ``krylov``: one size) (module docstring)."""
    apply = problem.monodromy(guess)
    # the clamped dofs keep u and ṽ: a Jordan block at μ = 1 that is no mode of the tube; a
    # start without them keeps every product without them
    v0 = np.random.default_rng(seed).standard_normal(guess.xi.size) * problem.free
    held = bool(getattr(problem, "hold_shift", False))
    size, top = int(krylov), int(krylov_max or krylov)
    while True:
        V, H = arnoldi(apply, v0, size, 0.0)
        flo = _ritz(problem, guess, V, H, count, held)
        if flo.stable is not None or size >= top:
            return flo
        size = min(2 * size, top)


def growth_from_the_orbit(problem, guess, periods: int, size: float = 1e-6,
                          seed: int = 5) -> tuple[np.ndarray, float | None, tuple[int, int]]:
    """The nonlinear map's own check of the multipliers: G = R₋ₛ F_T iterated ``periods``
    times from the orbit plus a random perturbation of the free dofs (``size`` relative
    RMS). Returns |δξ| after each period, the growth rate (1/s) fitted to ln|δξ| where it
    grows linearly (above 100 times its start, where the leading modes dominate, and below a
    tenth of its largest, before it saturates; None where fewer than 3 periods lie there),
    and that range's first and last period (1-based)."""
    free = problem.free
    rng = np.random.default_rng(seed)
    xi = guess.xi + size * free * rng.standard_normal(guess.xi.size) / math.sqrt(free.sum())
    sizes = np.empty(periods)
    for j in range(periods):
        xi = problem.rotate(problem.flow(xi, guess.period), -guess.shift)
        sizes[j] = float(np.linalg.norm(xi - guess.xi))
    linear = np.flatnonzero((sizes > 100.0 * sizes[0]) & (sizes < 0.1 * sizes.max()))
    if linear.size < 3:
        return sizes, None, (0, 0)
    times = guess.period * (linear + 1)
    rate = float(np.polyfit(times, np.log(sizes[linear]), 1)[0])
    return sizes, rate, (int(linear[0]) + 1, int(linear[-1]) + 1)
