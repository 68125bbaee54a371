"""Stick-slip-separation travelling waves of the reduced model: separation -> stick -> slip
zones under the impact or smooth junction closure (derivation: ``semianalytic.waves``)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from stickslip.semianalytic.coefficients import Coefficients
from stickslip.semianalytic.stick_slip import _ct_range, _dedupe, _finish, _local_minima
from stickslip.semianalytic.zones import (
    _PSI_MIN,
    TravellingWave,
    _check_wave_inputs,
    _expm_batch,
    _nonsingular,
    _scaled_coeffs,
    separation_matrix,
    slip_matrix,
)


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
    from scipy.linalg import expm  # scipy on first use: the CLI starts without it

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
    zT = expm(slip_matrix(co0, c2, Ds, f) * ((1.0 - p2) * T)) @ (z2 - zp) + zp
    y0 = np.array([dt, 0.0, zT[0], zT[1]])
    y1 = expm(separation_matrix(co0, c2, Ds) * (p1 * T)) @ y0
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
    from scipy.optimize import root  # scipy on first use: the CLI starts without it

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
