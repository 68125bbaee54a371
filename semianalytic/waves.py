"""Stick-slip and stick-slip-separation travelling waves of the reduced model (eqs. [3]-[7]).

Conventions
-----------
Waves are ``U(φ), V(φ)`` with ``φ = θ − ct`` (eq. [3]), period ``T = 2π/k``; ``c > 0`` is the
sense of rotation. Everything is solved in the *time-ordered* coordinate
``s = σφ``, ``σ = −sign(c)``, so that ``ds/dt = |c| > 0`` at a material point. In ``s`` the
equations [4] keep their form with ``D`` replaced by ``D_s = σD``, the stick condition
``V_φ = −1/c`` becomes ``V_s = 1/|c|`` and the slip velocity ``1 + cV_φ`` is ``1 − |c|V_s``.

The zones follow each other in time as separation ``[0, ψ1T]`` → stick ``[ψ1T, ψ2T]`` →
slip ``[ψ2T, T]`` (for ``c < 0``, ``s = φ`` and this is exactly the paper's layout; for
``c > 0`` the φ-layout is mirrored). A stick-slip wave is the case ``ψ1 = 0``.

Zone solutions (closed form, matrix exponentials, no numerical ODE integration):

* separation [7], ``y = (U, U_s, V, V_s)``: ``y(s) = expm(M s) y0``;
* stick [6]: ``U = δ``, ``V = V1 + (s − ψ1T)/|c|``, ``P = gδ + D/c``, ``Q = hV``;
* slip [5], ``z = (V, V_s)``: ``z(s) = expm(N s)(z0 − z_p) + z_p`` with ``z_p = (fgδ/h, 0)``,
  ``P = gδ − D_s V_s``, ``Q = fP``.

Junction (matching) conditions
------------------------------
A bounded reaction cannot change momentum, so across a zone boundary ``U, V, U', V'`` are
continuous unless a Dirac reaction acts: ``(c²−b)[U_s] = I``, ``(c²−a)[V_s] = J`` with the
time impulses ``I/|c| ≥ 0`` and ``|J| ≤ fI`` (Coulomb for impulses). Unknowns: ``c, ψ1, ψ2``
plus 7 constants (4 separation, 1 stick, 2 slip) = 10. Two closures are implemented:

``junction='impact'`` (default, physical; 10 equations)
    * lift-off (slip → separation, ``s = T ≡ 0``): ``U, V, U', V'`` continuous **and**
      ``P → 0`` (the contact opens when the normal reaction vanishes);
    * landing (separation → stick, ``s = ψ1T``): ``U, V`` continuous; ``U', V'`` jump by an
      impact with ``I ≥ 0`` (needs ``c² > b``) and ``|J| ≤ fI``, checked a posteriori;
    * stick → slip (``s = ψ2T``): ``V, V'`` continuous **and** ``Q = fP`` (stick ends when the
      friction bound is reached; this is the condition that closes the stick-slip problem).

``junction='smooth'`` (the paper's count: 3 nonlinear unknowns; 10 equations)
    ``U, V, U', V'`` continuous at all three boundaries; ``P`` may jump at lift-off and ``Q``
    at stick → slip. (The paper's sentence "U', V' continuous at ψ1T, T only, may be
    discontinuous at the separation → stick transition" contradicts its own zone order:
    separation → stick happens at ``ψ1T``. Read literally it gives 9 equations and a velocity
    jump at stick → slip with no impulse, which Coulomb's law forbids.)

Stick-slip wave (``ψ1 = 0``): 5 unknowns (``c, ψ, V1`` and 2 slip constants); continuity of
``V, V'`` at both ends gives 4 equations, a one-parameter family. The missing physical
condition is ``|Q| = fP`` at the stick → slip transition (equivalently ``V''`` continuous).
With ``W = V − V_e`` all forcing is ``∝ 1/|c|``: ``c√γ`` and ``ψ`` depend only on
``(ν, ξ, f, k)``, not on ``δ`` or ``Ω``, and ``W ∝ 1/|c| ∝ Ω``.

Every inequality of [5]-[7] (and of the impacts) is checked on a fine grid; the first one that
fails is reported in ``TravellingWave.violated``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import expm
from scipy.ndimage import minimum_filter
from scipy.optimize import root

from semianalytic.coefficients import Coefficients

__all__ = [
    "TravellingWave",
    "check_admissible",
    "celerity_m_s",
    "frequency_hz",
    "angular_frequency_rad_s",
    "stick_slip_waves",
    "stick_slip_separation_waves",
    "find_waves",
    "refine_wave",
    "continuation_omega",
]

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
def _sep_matrix(co: Coefficients, c2: float, Ds: float) -> NDArray[np.float64]:
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


def _slip_matrix(co: Coefficients, c2: float, Ds: float, f: float) -> NDArray[np.float64]:
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
        Y = _propagate(_sep_matrix(co, c2, Ds), w.y0, ss, 0.0, np.zeros(4))
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
        Z = _propagate(_slip_matrix(co, c2, Ds, f), w.z2, s[slp], s2, zp)
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


# ----------------------------------------------------------------------------- stick-slip
def _ss_residual(
    x: NDArray[np.float64], co0: Coefficients, f: float, k: int, sigma: float
) -> NDArray[np.float64]:
    """Stick-slip residual in ``(c̃ = |c|√γ, ψ)`` with ``w = |c|(V − V_e)``.

    Stick ``[0, ψT]``: ``w_s = 1``; stick → slip at ``ψT``: ``w = −fD_s/h`` (``Q = fP``),
    ``w_s = 1``; slip ``[ψT, T]``: ``(c²−a)w'' + fD_s w' + hw = 0``; periodic closure at
    ``T``: ``w(T) = w(ψT) − ψT``, ``w_s(T) = 1``.
    """
    ct, psi = x
    T = 2.0 * math.pi / k
    Ds = sigma * co0.D
    wb = -f * Ds / co0.h
    E = expm(_slip_matrix(co0, ct * ct, Ds, f) * ((1.0 - psi) * T))
    zT = E @ np.array([wb, 1.0])
    return np.array([(zT[0] - (wb - psi * T)) / T, zT[1] - 1.0])


def _ss_wave(
    co: Coefficients,
    f: float,
    k: int,
    delta: float,
    ct: float,
    psi: float,
    sigma: float,
    res: float,
) -> TravellingWave:
    cabs = ct / math.sqrt(co.gamma)
    c = -sigma * cabs
    Ds = sigma * co.D
    Vb = f * (co.g * delta - Ds / cabs) / co.h
    T = 2.0 * math.pi / k
    w = TravellingWave(
        regime="stick-slip",
        k=k,
        c=c,
        psi1=0.0,
        psi2=psi,
        admissible=False,
        violated=None,
        amplitude=0.0,
        v_amplitude=0.0,
        junction="friction-bound",
        f=f,
        delta=delta,
        coeffs=co,
        y0=np.zeros(4),
        V1=Vb - psi * T / cabs,
        z2=np.array([Vb, 1.0 / cabs]),
        residual=res,
    )
    return _finish(w)


def _finish(w: TravellingWave, n: int = 2000) -> TravellingWave:
    ev = _evaluate(w, n)
    ok, viol, margins = check_admissible(w, n, ev)
    w.admissible, w.violated = ok, viol
    w.amplitude = float(np.max(ev["U"]) - w.delta)
    w.v_amplitude = float(0.5 * (np.max(ev["V"]) - np.min(ev["V"])))
    w.info.update({"margin " + key: val for key, val in margins.items()})
    return w


def _dedupe(sols: list[tuple[float, ...]], tol: float = 1e-6) -> list[tuple[float, ...]]:
    out: list[tuple[float, ...]] = []
    for s in sols:
        if all(max(abs(a - b) for a, b in zip(s, o, strict=True)) > tol for o in out):
            out.append(s)
    return out


def _local_minima(F: NDArray[np.float64], nmax: int) -> list[tuple[int, ...]]:
    """Indices of the ``nmax`` smallest finite local minima of ``F``."""
    G = np.where(np.isfinite(F), F, np.inf)
    mins = (G == minimum_filter(G, size=3, mode="nearest")) & np.isfinite(G)
    idx = np.argwhere(mins)
    vals = G[mins]
    order = np.argsort(vals)[:nmax]
    return [tuple(int(i) for i in idx[j]) for j in order]


def _ct_range(co0: Coefficients, cmax: float, n: int) -> NDArray[np.float64]:
    ct = np.linspace(0.02, cmax, n)
    bad = (np.abs(ct**2 - co0.a) < 2e-3) | (np.abs(ct**2 - co0.b) < 2e-3)
    return ct[~bad]


def stick_slip_waves(
    coeffs: Coefficients,
    f: float,
    k: int,
    delta: float,
    *,
    cmax: float = 3.0,
    n_c: int = 300,
    n_psi: int = 120,
    nmax: int = 40,
) -> list[TravellingWave]:
    """All stick-slip waves (stick + slip zones, eqs. [5]-[6]) found by multistart.

    ``cmax`` bounds ``|c|√γ`` (physical celerity / √(E/ρ)). Both propagation senses are
    searched. Returns admissible and rejected candidates (see ``violated``).
    """
    _check_wave_inputs(f, k, delta)
    co0 = _scaled_coeffs(coeffs)
    T = 2.0 * math.pi / k
    ct = _ct_range(co0, cmax, n_c)
    psi = np.linspace(0.005, 0.995, n_psi)
    found: list[tuple[float, ...]] = []
    for sigma in (1.0, -1.0):
        Ds = sigma * co0.D
        ea = ct**2 - co0.a
        N = np.zeros((ct.size, 2, 2), dtype=complex)
        N[:, 0, 1] = 1.0
        N[:, 1, 0] = -co0.h / ea
        N[:, 1, 1] = -f * Ds / ea
        E = _expm_batch(N, (1.0 - psi) * T)  # (nc, npsi, 2, 2)
        wb = -f * Ds / co0.h
        zT0 = E[..., 0, 0] * wb + E[..., 0, 1]
        zT1 = E[..., 1, 0] * wb + E[..., 1, 1]
        F = np.hypot((zT0 - (wb - psi[None, :] * T)) / T, zT1 - 1.0)
        for i, j in _local_minima(F, nmax):
            sol = root(
                _ss_residual, [ct[i], psi[j]], args=(co0, f, k, sigma), method="hybr", tol=1e-13
            )
            c_s, p_s = sol.x
            r = float(np.max(np.abs(_ss_residual(sol.x, co0, f, k, sigma))))
            if r < 1e-9 and _PSI_MIN < p_s < 1.0 - _PSI_MIN and _nonsingular(co0, c_s):
                found.append((sigma, float(c_s), float(p_s), r))
    waves = []
    for sigma, c_s, p_s, r in _dedupe(found):
        waves.append(_ss_wave(coeffs, f, k, delta, c_s, p_s, sigma, r))
    return sorted(waves, key=lambda w: (not w.admissible, abs(w.c)))


def _nonsingular(co0: Coefficients, ct: float) -> bool:
    return ct > 1e-3 and abs(ct * ct - co0.a) > _SING and abs(ct * ct - co0.b) > _SING


def _check_wave_inputs(f: float, k: int, delta: float) -> None:
    if not f > 0:
        raise ValueError(f"f={f!r} out of range: need f > 0")
    if int(k) != k or k < 1:
        raise ValueError(f"k={k!r} out of range: need an integer k >= 1")
    if not delta >= 0:
        raise ValueError(f"delta={delta!r} out of range: need delta >= 0")


# ----------------------------------------------------------------------------- separation
def _sss_parts(
    x: NDArray[np.float64],
    co0: Coefficients,
    f: float,
    k: int,
    dt: float,
    sigma: float,
    junction: str,
) -> tuple[NDArray[np.float64], dict[str, Any]]:
    """Residual of the stick-slip-separation problem in scaled variables (γ = 1, δ̃ = δ/√γ).

    ``impact``: ``x = (c̃, ψ1, ψ2)``; ``smooth``: ``x = (c̃, ψ1, ψ2, V1/(δ̃ + 1/c̃))``.
    """
    ct, p1, p2 = x[0], x[1], x[2]
    T = 2.0 * math.pi / k
    Ds = sigma * co0.D
    c2 = ct * ct
    sc = dt + 1.0 / ct
    zp = np.array([f * co0.g * dt / co0.h, 0.0])
    Lst = (p2 - p1) * T / ct
    if junction == "impact":
        Vb = f * (co0.g * dt - Ds / ct) / co0.h  # Q = fP at stick -> slip
        V1 = Vb - Lst
    else:
        V1 = x[3] * sc
        Vb = V1 + Lst
    z2 = np.array([Vb, 1.0 / ct])
    zT = expm(_slip_matrix(co0, c2, Ds, f) * ((1.0 - p2) * T)) @ (z2 - zp) + zp
    y0 = np.array([dt, 0.0, zT[0], zT[1]])
    y1 = expm(_sep_matrix(co0, c2, Ds) * (p1 * T)) @ y0
    if junction == "impact":
        r = np.array(
            [
                (co0.g * dt - Ds * zT[1]) / (co0.g * dt + abs(Ds) / ct),  # P(T-) = 0 at lift-off
                (y1[0] - dt) / sc,  # U = δ at landing
                (y1[2] - V1) / sc,  # V continuous at landing
            ]
        )
    else:
        r = np.array([(y1[0] - dt) / sc, y1[1] / sc, (y1[2] - V1) / sc, (y1[3] - 1.0 / ct) / sc])
    return r, {"y0": y0, "y1": y1, "V1": V1, "z2": z2, "zT": zT}


def _sss_res(x: NDArray[np.float64], *args: Any) -> NDArray[np.float64]:
    return _sss_parts(x, *args)[0]


def _sss_grid(
    co0: Coefficients,
    f: float,
    k: int,
    dt: float,
    sigma: float,
    junction: str,
    ct: NDArray[np.float64],
    psi: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Vectorised residual norm on the grid ``ct × psi1 × psi2`` (for seeding).

    Returns the norm (``inf`` where ``ψ1 ≥ ψ2``) and, for ``smooth``, the least-squares V1.
    """
    T = 2.0 * math.pi / k
    Ds = sigma * co0.D
    nc = ct.size
    ea, eb = ct**2 - co0.a, ct**2 - co0.b
    N = np.zeros((nc, 2, 2), dtype=complex)
    N[:, 0, 1] = 1.0
    N[:, 1, 0] = -co0.h / ea
    N[:, 1, 1] = -f * Ds / ea
    M = np.zeros((nc, 4, 4), dtype=complex)
    M[:, 0, 1] = 1.0
    M[:, 1, 0] = -co0.g / eb
    M[:, 1, 3] = Ds / eb
    M[:, 2, 3] = 1.0
    M[:, 3, 1] = -Ds / ea
    M[:, 3, 2] = -co0.h / ea
    Es = _expm_batch(N, (1.0 - psi) * T)  # (nc, n2, 2, 2) indexed by psi2
    Ep = _expm_batch(M, psi * T)  # (nc, n1, 4, 4) indexed by psi1
    sc = (dt + 1.0 / ct)[:, None, None]
    c_ = ct[:, None, None]
    vp = f * co0.g * dt / co0.h
    lst = (psi[None, None, :] - psi[None, :, None]) * T / c_  # (nc, n1, n2)
    Es_b = Es[:, None, :, :, :]  # (nc, 1, n2, 2, 2)
    Ep_b = Ep[:, :, None, :, :]  # (nc, n1, 1, 4, 4)

    def sep_end(vb: NDArray[Any]) -> tuple[NDArray[Any], NDArray[Any]]:
        zt0 = Es_b[..., 0, 0] * (vb - vp) + Es_b[..., 0, 1] / c_ + vp
        zt1 = Es_b[..., 1, 0] * (vb - vp) + Es_b[..., 1, 1] / c_
        y1 = (
            Ep_b[..., :, 0] * dt
            + Ep_b[..., :, 2] * zt0[..., None]
            + Ep_b[..., :, 3] * zt1[..., None]
        )
        return y1, zt1

    if junction == "impact":
        vb = f * (co0.g * dt - Ds / c_) / co0.h + 0.0 * lst
        y1, zt1 = sep_end(vb)
        r1 = (co0.g * dt - Ds * zt1) / (co0.g * dt + abs(Ds) / c_)
        r2 = (y1[..., 0] - dt) / sc
        r3 = (y1[..., 2] - (vb - lst)) / sc
        F = np.sqrt(r1**2 + r2**2 + r3**2)
        V1 = vb - lst
    else:
        # residual affine in V1: r = r0 + V1 r1 (evaluate at V1 = 0 and V1 = 1)
        def res(v1: NDArray[Any] | float) -> NDArray[Any]:
            y1, _ = sep_end(v1 + lst)
            return np.stack(
                [y1[..., 0] - dt, y1[..., 1], y1[..., 2] - v1, y1[..., 3] - 1.0 / c_], axis=-1
            )

        r0 = res(0.0 * lst)
        r1v = res(1.0 + 0.0 * lst) - r0
        V1 = -np.sum(r0 * r1v, axis=-1) / np.sum(r1v * r1v, axis=-1)
        F = np.linalg.norm(r0 + V1[..., None] * r1v, axis=-1) / sc
    valid = psi[None, :, None] < psi[None, None, :]
    F = np.where(valid & np.isfinite(F), F, np.inf)
    return F, np.asarray(V1)


def _sss_wave(
    co: Coefficients,
    f: float,
    k: int,
    delta: float,
    x: NDArray[np.float64],
    sigma: float,
    junction: str,
    res: float,
) -> TravellingWave:
    co0 = _scaled_coeffs(co)
    sg = math.sqrt(co.gamma)
    dt = delta / sg
    _, parts = _sss_parts(x, co0, f, k, dt, sigma, junction)
    ct = float(x[0])
    cabs = ct / sg
    # scaled -> unscaled amplitudes: U = √γ Ũ, V = √γ Ṽ
    w = TravellingWave(
        regime="stick-slip-separation",
        k=k,
        c=-sigma * cabs,
        psi1=float(x[1]),
        psi2=float(x[2]),
        admissible=False,
        violated=None,
        amplitude=0.0,
        v_amplitude=0.0,
        junction=junction,
        f=f,
        delta=delta,
        coeffs=co,
        y0=parts["y0"] * sg,
        V1=float(parts["V1"] * sg),
        z2=parts["z2"] * sg,
        residual=res,
    )
    y1 = parts["y1"]  # scaled, derivatives in s
    jump_u = 0.0 - y1[1]  # [U_s] at landing
    jump_v = 1.0 / ct - y1[3]  # [V_s] at landing
    # impulses in the scaled variables -> unscaled: (c²−b)[U_s] carries 1/γ · √γ
    w.info["impulse_normal"] = float((ct * ct - co0.b) * jump_u / sg)
    w.info["impulse_tangential"] = float((ct * ct - co0.a) * jump_v / sg)
    Ds = sigma * co0.D
    w.info["P_liftoff"] = float((co0.g * dt - Ds * parts["zT"][1]) / sg)
    w.info["Q_minus_fP_stick_end"] = float(
        (co0.h * parts["z2"][0] - f * (co0.g * dt - Ds / ct)) / sg
    )
    return _finish(w)


def stick_slip_separation_waves(
    coeffs: Coefficients,
    f: float,
    k: int,
    delta: float,
    *,
    junction: str = "impact",
    cmax: float = 3.0,
    n_c: int = 160,
    n_psi: int = 40,
    nmax: int = 30,
    senses: tuple[float, ...] = (1.0, -1.0),
) -> list[TravellingWave]:
    """All stick-slip-separation waves (zones [7] → [6] → [5]) found by multistart.

    ``junction`` selects the matching conditions (module docstring): ``'impact'`` (physical)
    or ``'smooth'`` (full continuity, the paper's count). Seeds are the local minima of the
    residual norm on a ``(c√γ, ψ1, ψ2)`` grid, each refined by a hybrid Newton solve.
    """
    _check_wave_inputs(f, k, delta)
    if junction not in ("impact", "smooth"):
        raise ValueError(f"junction={junction!r} out of range: 'impact' or 'smooth'")
    co0 = _scaled_coeffs(coeffs)
    dt = delta / math.sqrt(coeffs.gamma)
    ct = _ct_range(co0, cmax, n_c)
    psi = np.linspace(0.01, 0.99, n_psi)
    found: list[tuple[float, ...]] = []
    for sigma in senses:
        F, V1 = _sss_grid(co0, f, k, dt, sigma, junction, ct, psi)
        for i, j, l in _local_minima(F, nmax):
            x0 = [ct[i], psi[j], psi[l]]
            if junction == "smooth":
                x0.append(V1[i, j, l] / (dt + 1.0 / ct[i]))
            x = _solve_sss(np.array(x0), co0, f, k, dt, sigma, junction)
            if x is not None:
                found.append((sigma, *map(float, x)))
    waves = []
    for sol in _dedupe(found):
        sigma, x = sol[0], np.array(sol[1:])
        r = float(np.max(np.abs(_sss_res(x, co0, f, k, dt, sigma, junction))))
        waves.append(_sss_wave(coeffs, f, k, delta, x, sigma, junction, r))
    return sorted(waves, key=lambda w: (not w.admissible, abs(w.c)))


def _solve_sss(
    x0: NDArray[np.float64],
    co0: Coefficients,
    f: float,
    k: int,
    dt: float,
    sigma: float,
    junction: str,
) -> NDArray[np.float64] | None:
    sol = root(_sss_res, x0, args=(co0, f, k, dt, sigma, junction), method="hybr")
    x = sol.x
    r = np.max(np.abs(_sss_res(x, co0, f, k, dt, sigma, junction)))
    if (
        r < 1e-9
        and _PSI_MIN < x[1] < x[2] - _PSI_MIN < 1.0 - 2 * _PSI_MIN
        and _nonsingular(co0, x[0])
    ):
        return x
    return None


def refine_wave(
    wave: TravellingWave,
    coeffs: Coefficients,
    f: float | None = None,
    delta: float | None = None,
) -> TravellingWave | None:
    """One Newton solve (continuation step) of ``wave``'s branch at new coefficients/f/δ."""
    f = wave.f if f is None else f
    delta = wave.delta if delta is None else delta
    sigma = -1.0 if wave.c > 0 else 1.0
    co0 = _scaled_coeffs(coeffs)
    ct = abs(wave.c_scaled)
    if wave.regime == "stick-slip":
        sol = root(
            _ss_residual, [ct, wave.psi2], args=(co0, f, wave.k, sigma), method="hybr", tol=1e-13
        )
        r = float(np.max(np.abs(_ss_residual(sol.x, co0, f, wave.k, sigma))))
        if r > 1e-9 or not 0 < sol.x[1] < 1:
            return None
        return _ss_wave(coeffs, f, wave.k, delta, sol.x[0], sol.x[1], sigma, r)
    dt = delta / math.sqrt(coeffs.gamma)
    x0 = [ct, wave.psi1, wave.psi2]
    if wave.junction == "smooth":
        x0.append(
            wave.V1
            / math.sqrt(wave.coeffs.gamma)
            / (wave.delta / math.sqrt(wave.coeffs.gamma) + 1.0 / ct)
        )
    x = _solve_sss(np.array(x0), co0, f, wave.k, dt, sigma, wave.junction)
    if x is None:
        return None
    r = float(np.max(np.abs(_sss_res(x, co0, f, wave.k, dt, sigma, wave.junction))))
    return _sss_wave(coeffs, f, wave.k, delta, x, sigma, wave.junction, r)


def continuation_omega(
    wave: TravellingWave,
    omegas: NDArray[np.float64],
    *,
    wave_speed: float = 1000.0,
    radius: float = 1.0,
) -> list[TravellingWave | None]:
    """Follow ``wave``'s branch over rotation speeds ``omegas`` (rad/s), one Newton step each."""
    from semianalytic.coefficients import coefficients, gamma_from_physical

    out: list[TravellingWave | None] = []
    cur: TravellingWave | None = wave
    for om in omegas:
        co = coefficients(
            wave.coeffs.nu, wave.coeffs.xi, gamma_from_physical(wave_speed, radius, om)
        )
        nxt = refine_wave(cur, co) if cur is not None else None
        out.append(nxt)
        if nxt is not None:
            cur = nxt
    return out


def find_waves(
    coeffs: Coefficients,
    f: float,
    k: int,
    delta: float,
    *,
    regime: str = "auto",
    junctions: tuple[str, ...] = ("impact", "smooth"),
) -> list[TravellingWave]:
    """Every stick-slip and stick-slip-separation wave found (admissible first).

    ``regime``: ``'auto'`` (both kinds), ``'stick-slip'`` or ``'stick-slip-separation'``.
    """
    waves: list[TravellingWave] = []
    if regime in ("auto", "stick-slip"):
        waves += stick_slip_waves(coeffs, f, k, delta)
    if regime in ("auto", "stick-slip-separation"):
        for j in junctions:
            waves += stick_slip_separation_waves(coeffs, f, k, delta, junction=j)
    if regime not in ("auto", "stick-slip", "stick-slip-separation"):
        raise ValueError(f"regime={regime!r} out of range: auto|stick-slip|stick-slip-separation")
    return sorted(waves, key=lambda w: (not w.admissible, w.regime != "stick-slip", abs(w.c)))
