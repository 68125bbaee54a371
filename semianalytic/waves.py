"""Stick-slip and stick-slip-separation travelling waves of the reduced model (eqs. [3]-[7]).

Conventions. Waves are ``U(φ), V(φ)`` with ``φ = θ − ct`` (eq. [3]), period ``T = 2π/k``;
``c > 0`` is the sense of rotation. Everything is solved in the *time-ordered* coordinate
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

Junction (matching) conditions. A bounded reaction cannot change momentum, so across a zone
boundary ``U, V, U', V'`` are continuous unless a Dirac reaction acts: ``(c²−b)[U_s] = I``,
``(c²−a)[V_s] = J`` with the time impulses ``I/|c| ≥ 0`` and ``|J| ≤ fI`` (Coulomb for impulses).
Unknowns: ``c, ψ1, ψ2`` plus 7 constants (4 separation, 1 stick, 2 slip) = 10. Two closures are
implemented:

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

import numpy as np
from numpy.typing import NDArray

from stickslip.semianalytic.coefficients import Coefficients, coefficients, gamma_from_physical
from stickslip.semianalytic.separation import (
    _solve_sss,
    _sss_res,
    _sss_wave,
    stick_slip_separation_waves,
)
from stickslip.semianalytic.stick_slip import _ss_residual, _ss_wave, stick_slip_waves
from stickslip.semianalytic.zones import (  # noqa: F401  (the public names of the reduced model's waves)
    TravellingWave,
    _scaled_coeffs,
    angular_frequency_rad_s,
    celerity_m_s,
    check_admissible,
    frequency_hz,
    separation_matrix,
    slip_matrix,
)

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


def refine_wave(
    wave: TravellingWave,
    coeffs: Coefficients,
    f: float | None = None,
    delta: float | None = None,
) -> TravellingWave | None:
    """One Newton solve (continuation step) of ``wave``'s branch at new coefficients/f/δ."""
    from scipy.optimize import root  # scipy on first use: the CLI starts without it

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
