"""Reference spectra for the CEA: the exact f = 0 annulus frequencies and the reduced model."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from solver.scene import Scene

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


