"""Zones of the reduced model's travelling waves (eqs. [3]-[7]): units, zone matrices,
the wave object, its evaluation and the admissibility checks.

Conventions (``φ = θ − ct``, the time-ordered coordinate ``s``, the zone order) and the closed-form
zone solutions are derived in the docstring of ``semianalytic.waves``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from stickslip.semianalytic.coefficients import Coefficients

_PSI_MIN = 1e-4  # zones shorter than this fraction of T are degenerate (another regime)
_SING = 1e-4  # exclude |c̃² − a0|, |c̃² − b0| below this (zone matrices singular there)


# ----------------------------------------------------------------------------- units
def celerity_m_s(c: float, R: float, omega: float) -> float:
    """Physical signed wave speed ``c R Ω`` (m/s), > 0 in the sense of rotation (section 3)."""
    return c * R * omega


def angular_frequency_rad_s(c: float, k: int, omega: float) -> float:
    """The paper's "frequency" ``|c| k Ω``: an angular frequency in rad/s."""
    return abs(c) * k * omega


def frequency_hz(c: float, k: int, omega: float) -> float:
    """Frequency in hertz seen by a material point: ``|c| k Ω / 2π``.

    The paper's ``|c|kΩ`` is in rad/s: its "10045 Hz" is ``1255.6 m/s × 8 / 1 m`` (k = 8) in
    rad/s, i.e. 1599 Hz (docs/semianalytic.md).
    """
    return angular_frequency_rad_s(c, k, omega) / (2.0 * math.pi)


# ----------------------------------------------------------------------------- matrices
def separation_matrix(co: Coefficients, c2: float, Ds: float) -> NDArray[np.float64]:
    """First-order matrix of [7] in s for ``y = (U, U_s, V, V_s)``."""
    eb, ea = c2 - co.b, c2 - co.a
    return np.array(
        [
            [0.0, 1.0, 0.0, 0.0],
            [-co.g / eb, 0.0, 0.0, Ds / eb],
            [0.0, 0.0, 0.0, 1.0],
            [0.0, -Ds / ea, -co.h / ea, 0.0],
        ]
    )


def slip_matrix(co: Coefficients, c2: float, Ds: float, f: float) -> NDArray[np.float64]:
    """First-order matrix of the slip equation [5] in s for ``z = (V, V_s)``."""
    ea = c2 - co.a
    return np.array([[0.0, 1.0], [-co.h / ea, -f * Ds / ea]])


def _expm_batch(Mb: NDArray[np.complex128], L: NDArray[np.float64]) -> NDArray[np.float64]:
    """``expm(M_i L_j)`` for batches via eigen-decomposition; shape ``(nM, nL, m, m)``."""
    lam, W = np.linalg.eig(Mb)
    Winv = np.linalg.inv(W)
    with np.errstate(over="ignore", invalid="ignore"):
        ex = np.exp(lam[:, None, :] * L[None, :, None])
        E = np.einsum("aij,abj,ajk->abik", W, ex, Winv)
    return E.real


def _scaled_coeffs(co: Coefficients) -> Coefficients:
    """Coefficients at γ = 1 (``a0 = aγ`` ...): the zone matrices only depend on ``c√γ``."""
    return replace(
        co,
        a=co.a * co.gamma,
        b=co.b * co.gamma,
        g=co.g * co.gamma,
        h=co.h * co.gamma,
        D=co.D * co.gamma,
        gamma=1.0,
    )


# ----------------------------------------------------------------------------- result
@dataclass
class TravellingWave:
    """A travelling wave solution of eqs. [4]-[7] (non-dimensional unless stated).

    ``psi1, psi2``: zone fractions in time order (separation [0, ψ1T], stick [ψ1T, ψ2T],
    slip [ψ2T, T]); identical to the paper's φ-layout when ``c < 0``. ``amplitude`` is
    ``max U − δ``; ``v_amplitude`` is ``(max V − min V)/2``.
    """

    regime: str
    k: int
    c: float
    psi1: float
    psi2: float
    admissible: bool
    violated: str | None
    amplitude: float
    v_amplitude: float
    junction: str
    f: float
    delta: float
    coeffs: Coefficients = field(repr=False)
    y0: NDArray[np.float64] = field(repr=False)  # separation start (U, U_s, V, V_s) at s = 0
    V1: float = field(repr=False, default=0.0)  # V at the start of stick
    z2: NDArray[np.float64] = field(repr=False, default_factory=lambda: np.zeros(2))
    residual: float = 0.0
    info: dict[str, float] = field(default_factory=dict)

    @property
    def period(self) -> float:
        """``T = 2π/k``."""
        return 2.0 * math.pi / self.k

    @property
    def c_scaled(self) -> float:
        """``c√γ`` = physical celerity / √(E/ρ) (independent of Ω for stick-slip waves)."""
        return self.c * math.sqrt(self.coeffs.gamma)

    def evaluate_s(self, n: int = 2000) -> dict[str, NDArray[Any]]:
        """Fields on a uniform grid of the time-ordered coordinate ``s ∈ [0, T)``."""
        return _evaluate(self, n)

    def evaluate(self, n: int = 2000) -> dict[str, NDArray[Any]]:
        """``φ, U, V, U', V', P, Q, zone`` on ``n`` points of ``φ ∈ [0, T)`` (eq. [3]).

        Derivatives are with respect to φ; ``zone`` is 0 separation, 1 stick, 2 slip.
        Time derivatives follow from ``U̇ = −cU'``.
        """
        ev = _evaluate(self, n)
        T = self.period
        sig = -1.0 if self.c > 0 else 1.0
        phi = np.mod(sig * ev["s"], T)
        order = np.argsort(phi, kind="stable")
        out = {"phi": phi[order]}
        for key in ("U", "V", "P", "Q", "zone"):
            out[key] = ev[key][order]
        out["dU"] = sig * ev["Us"][order]
        out["dV"] = sig * ev["Vs"][order]
        return out

    def summary(self, R: float = 1.0, omega: float = 1.0) -> dict[str, Any]:
        """JSON-friendly summary in the CLI's field names (physical units from R, Ω)."""
        return {
            "regime": self.regime,
            "junction": self.junction,
            "k": self.k,
            "c": self.c,
            "celerity_m_s": celerity_m_s(self.c, R, omega),
            "frequency_hz": frequency_hz(self.c, self.k, omega),
            "angular_frequency_rad_s": angular_frequency_rad_s(self.c, self.k, omega),
            "psi1": self.psi1,
            "psi2": self.psi2,
            "amplitude": self.amplitude,
            "v_amplitude": self.v_amplitude,
            "admissible": self.admissible,
            "violated": self.violated,
            "residual": self.residual,
        }


def _evaluate(w: TravellingWave, n: int) -> dict[str, NDArray[Any]]:
    co, f, delta = w.coeffs, w.f, w.delta
    T = w.period
    cabs = abs(w.c)
    Ds = (-1.0 if w.c > 0 else 1.0) * co.D
    c2 = w.c * w.c
    s = np.arange(n) * (T / n)
    U = np.full(n, delta)
    Us = np.zeros(n)
    V = np.empty(n)
    Vs = np.empty(n)
    P = np.empty(n)
    Q = np.empty(n)
    zone = np.empty(n, dtype=int)
    s1, s2 = w.psi1 * T, w.psi2 * T
    sep = s < s1
    stk = (s >= s1) & (s < s2)
    slp = s >= s2
    if sep.any():
        ss = s[sep]
        Y = _propagate(separation_matrix(co, c2, Ds), w.y0, ss, 0.0, np.zeros(4))
        U[sep], Us[sep], V[sep], Vs[sep] = Y.T
        P[sep] = 0.0
        Q[sep] = 0.0
        zone[sep] = 0
    if stk.any():
        V[stk] = w.V1 + (s[stk] - s1) / cabs
        Vs[stk] = 1.0 / cabs
        P[stk] = co.g * delta - Ds / cabs
        Q[stk] = co.h * V[stk]
        zone[stk] = 1
    if slp.any():
        zp = np.array([f * co.g * delta / co.h, 0.0])
        Z = _propagate(slip_matrix(co, c2, Ds, f), w.z2, s[slp], s2, zp)
        V[slp], Vs[slp] = Z.T
        P[slp] = co.g * delta - Ds * Vs[slp]
        Q[slp] = f * P[slp]
        zone[slp] = 2
    return {"s": s, "U": U, "Us": Us, "V": V, "Vs": Vs, "P": P, "Q": Q, "zone": zone}


def _propagate(
    M: NDArray[np.float64],
    y0: NDArray[np.float64],
    s: NDArray[np.float64],
    s0: float,
    yp: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Exact ``y(s) = expm(M(s − s0))(y0 − yp) + yp`` on a uniform increasing grid."""
    from scipy.linalg import expm  # scipy on first use: the CLI starts without it

    out = np.empty((s.size, y0.size))
    y = expm(M * (s[0] - s0)) @ (y0 - yp)
    out[0] = y
    if s.size > 1:
        step = expm(M * (s[1] - s[0]))
        for i in range(1, s.size):
            y = step @ y
            out[i] = y
    return out + yp


# ----------------------------------------------------------------------------- checks
def check_admissible(
    w: TravellingWave, n: int = 2000, ev: dict[str, NDArray[Any]] | None = None
) -> tuple[bool, str | None, dict[str, float]]:
    """Check every inequality of [5]-[7] (and of the landing impact) on ``n`` points a period.

    Returns ``(admissible, first violated inequality or None, margins)``; margins are the
    worst normalised values (negative = violated).
    """
    co, f, delta = w.coeffs, w.f, w.delta
    ev = _evaluate(w, n) if ev is None else ev
    n = ev["s"].size
    cabs = abs(w.c)
    u_sc = delta + 1.0 / cabs
    p_sc = co.g * delta + abs(co.D) / cabs
    tol = 1e-7
    z = ev["zone"]
    m: dict[str, float] = {}
    # separation [7]: U > δ (strict inside the zone; the end points touch)
    sep = z == 0
    if sep.any():
        idx = np.flatnonzero(sep)
        if idx.size > 2:
            m["[7] U > delta in separation"] = float(np.min(ev["U"][idx[1:]] - delta) / u_sc)
    stk = z == 1
    if stk.any():
        m["[6] P >= 0 in stick"] = float(np.min(ev["P"][stk]) / p_sc)
        m["[6] |Q| < fP in stick"] = float(
            np.min(f * ev["P"][stk] - np.abs(ev["Q"][stk])) / (f * p_sc)
        )
    slp = z == 2
    if slp.any():
        m["[5] P >= 0 in slip"] = float(np.min(ev["P"][slp]) / p_sc)
        m["[5] 1 + cV' >= 0 in slip"] = float(np.min(1.0 - cabs * ev["Vs"][slp]))
    if w.psi1 > 0 and w.junction == "impact":
        I_, J_ = w.info.get("impulse_normal", 0.0), w.info.get("impulse_tangential", 0.0)
        m["impact: normal impulse >= 0"] = I_ / (p_sc * w.period)
        m["impact: |J| <= f I"] = (f * I_ - abs(J_)) / (f * p_sc * w.period)
    violated = None
    for key, val in m.items():
        if val < -tol:
            violated = key
            break
    return violated is None, violated, m


def _nonsingular(co0: Coefficients, ct: float) -> bool:
    return ct > 1e-3 and abs(ct * ct - co0.a) > _SING and abs(ct * ct - co0.b) > _SING


def _check_wave_inputs(f: float, k: int, delta: float) -> None:
    if not f > 0:
        raise ValueError(f"f={f!r} out of range: need f > 0")
    if int(k) != k or k < 1:
        raise ValueError(f"k={k!r} out of range: need an integer k >= 1")
    if not delta >= 0:
        raise ValueError(f"delta={delta!r} out of range: need delta >= 0")
