"""Stick-slip travelling waves of the reduced model (psi1 = 0): the closed-form zone solutions
with |Q| = fP at the stick -> slip transition (derivation: ``semianalytic.waves``)."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from stickslip.semianalytic.coefficients import Coefficients
from stickslip.semianalytic.zones import (
    _PSI_MIN,
    TravellingWave,
    _check_wave_inputs,
    _evaluate,
    _expm_batch,
    _nonsingular,
    _scaled_coeffs,
    check_admissible,
    slip_matrix,
)


# ----------------------------------------------------------------------------- stick-slip
def _ss_residual(
    x: NDArray[np.float64], co0: Coefficients, f: float, k: int, sigma: float
) -> NDArray[np.float64]:
    """Stick-slip residual in ``(c̃ = |c|√γ, ψ)`` with ``w = |c|(V − V_e)``.

    Stick ``[0, ψT]``: ``w_s = 1``; stick → slip at ``ψT``: ``w = −fD_s/h`` (``Q = fP``),
    ``w_s = 1``; slip ``[ψT, T]``: ``(c²−a)w'' + fD_s w' + hw = 0``; periodic closure at
    ``T``: ``w(T) = w(ψT) − ψT``, ``w_s(T) = 1``.
    """
    from scipy.linalg import expm  # scipy on first use: the CLI starts without it

    ct, psi = x
    T = 2.0 * math.pi / k
    Ds = sigma * co0.D
    wb = -f * Ds / co0.h
    E = expm(slip_matrix(co0, ct * ct, Ds, f) * ((1.0 - psi) * T))
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
    from scipy.ndimage import minimum_filter  # scipy on first use: the CLI starts without it

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
    from scipy.optimize import root  # scipy on first use: the CLI starts without it

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
