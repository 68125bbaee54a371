"""The finite tube's contact surface unrolled in (theta, z): ``surface.png`` of a 3D run.

From ``surface.npz`` (``solver.surface_samples``): u_r - d over the unrolled surface r = R,
theta in [0, 360) degrees along, z in [0, L] across, at the last sample, beside the contact
status there (separation / stick / slip) and the axial profile of the wave, the RMS over the
last fifth of the samples of u_r - d on each ring. A plane-strain wave is a pattern of
stripes along z; end effects and axial orders show as their bending and as the profile.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from stickslip.postprocess.style import FIELD_CMAP, MM, status_cmap, status_colorbar

__all__ = ["AXIAL_ORDERS", "axial_modes", "axial_structure", "surface_figure"]

#: The axial orders m that ``axial_modes`` resolves: cos(m pi zeta), m = 0 .. 4 (at most the
#: surface's layers)
AXIAL_ORDERS = 5


def _ring_coefficients(surface: dict) -> tuple[np.ndarray, float]:
    """u_r's Fourier coefficients around each ring over the last fifth of the samples,
    a_k(z, t) as (t, z, N), and the mean square of u_r there."""
    u_r = np.asarray(surface["u_r"], dtype=float)
    window = u_r[-max(1, u_r.shape[0] // 5):]
    return np.fft.fft(window, axis=2) / window.shape[2], float(np.mean(window**2))


def axial_structure(surface: dict, k: int) -> dict:
    """The axial shape of the wave of wavenumber ``k`` on a 3D tube's contact surface
    (``surface.npz``'s arrays) over the last fifth of the samples: ``profile``, the RMS over
    time of |a_k(z, t)| on each ring, a_k the ring's k-th Fourier coefficient of u_r,
    relative to its largest; ``end_phase_deg``, the phase of the wave at z = 0 against the
    middle ring, arg of the time mean of a_k(0, t) conj(a_k(L/2, t)) (0: straight fronts
    along z; fronts that bend towards the ends lead or lag there). Clamped ends hold their
    rings (status -1: no contact node, u = 0): the end is then the first ring in contact."""
    a, _ = _ring_coefficients(surface)
    n, middle = a.shape[2], a.shape[1] // 2
    end = int(np.flatnonzero((np.asarray(surface["status"]) >= 0).any(axis=(0, 2)))[0])
    a_k = a[..., k % n]  # (t, z)
    amplitude = np.sqrt(np.mean(np.abs(a_k) ** 2, axis=0))
    lag = np.degrees(np.angle(np.mean(a_k[:, end] * np.conj(a_k[:, middle]))))
    peak = amplitude.max() if amplitude.max() > 0 else 1.0
    return {"k": int(k), "z_m": [float(z) for z in surface["z"]],
            "profile": [round(float(a), 4) for a in amplitude / peak],
            "end_phase_deg": round(float(lag), 2)}


def axial_modes(surface: dict, floor: float = 0.01, top: int = 8) -> list[dict]:
    """The wave's content on a 3D tube's contact surface by wavenumber k (around) and axial
    order m (along), over the last fifth of the samples: u_r's k-th Fourier coefficient on
    each ring a_k(z, t) (k and −k, both directions, together), projected on the axial
    shapes cos(m pi zeta), zeta = (z − z_0) / L, orthonormalised for the trapezoid rule on
    the rings' levels (m = 0: uniform along z, m nodal rings otherwise; ``AXIAL_ORDERS``
    of them at most). ``share``: the time mean of |c_km|² over the whole of Σ_k ∫ |a_k|² dz,
    so what the orders left out carry is what the shares miss. The ``top`` (k, m) of share
    ≥ ``floor``, largest first; none where the surface carries no wave."""
    a, mean_square = _ring_coefficients(surface)
    n = a.shape[2]
    z = np.asarray(surface["z"], dtype=float)
    zeta = (z - z[0]) / (z[-1] - z[0])
    weight = np.zeros_like(zeta)  # the trapezoid rule on the levels
    weight[1:] += 0.5 * np.diff(zeta)
    weight[:-1] += 0.5 * np.diff(zeta)
    orders = min(AXIAL_ORDERS, z.size - 1)
    shapes = np.cos(np.pi * np.outer(zeta, np.arange(orders)))  # (z, m)
    basis, _ = np.linalg.qr(np.sqrt(weight)[:, None] * shapes)  # orthonormal columns
    ks = np.arange(1, n // 2 + 1)
    sides = [a[..., ks], a[..., (n - ks) % n] * (ks != n - ks)]  # k, then −k (once)
    total = sum(float(np.mean(np.sum(weight[None, :, None] * np.abs(x) ** 2, axis=1).sum(
        axis=1))) for x in sides)
    if not total > 1e-20 * mean_square:  # no wave on the surface
        return []
    power = sum(np.mean(np.abs(np.einsum("zm,tzk->tmk", basis,
                                         np.sqrt(weight)[None, :, None] * x)) ** 2, axis=0)
                for x in sides)  # (m, k)
    share = power / total
    found = [{"k": int(ks[j]), "m": int(m), "share": round(float(share[m, j]), 4)}
             for m, j in zip(*np.nonzero(share >= floor), strict=True)]
    return sorted(found, key=lambda e: -e["share"])[:top]


def surface_figure(run_dir: Path, d: float) -> Any:
    """The three panels of ``surface.png`` (module docstring) for the run in ``run_dir``
    with mismatch ``d`` [m]."""
    import matplotlib.pyplot as plt

    with np.load(Path(run_dir) / "surface.npz") as data:
        t, z, theta = data["t"], data["z"], data["theta"]
        status = data["status"]
        # (samples, rings, angles), mm; a clamped end's held rings (status -1) left blank
        wave = np.ma.masked_where(status < 0, (data["u_r"].astype(float) - d) * MM)
    degrees = np.degrees(theta)
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.2), width_ratios=[1.0, 1.0, 0.45],
                             constrained_layout=True)
    image = axes[0].pcolormesh(degrees, z, wave[-1], shading="nearest", cmap=FIELD_CMAP)
    fig.colorbar(image, ax=axes[0], label="u_r − d (mm)")
    cmap, norm = status_cmap()
    shown = axes[1].pcolormesh(degrees, z, np.ma.masked_less(status[-1], 0),
                               shading="nearest", cmap=cmap, norm=norm)
    status_colorbar(fig, shown, axes[1])
    for ax, what in zip(axes[:2], ("u_r − d", "contact status"), strict=True):
        ax.set(xlabel="θ (deg)", ylabel="z (m)", title=f"{what} at t = {t[-1] * 1e3:.2f} ms")
    window = wave[-max(1, wave.shape[0] // 5):]
    rms = np.sqrt(np.mean((window - window.mean(axis=(0, 2), keepdims=True)) ** 2,
                          axis=(0, 2)))
    axes[2].plot(rms, z, "o-")
    axes[2].set(xlabel="RMS of u_r − d (mm)", ylabel="z (m)", title="axial profile")
    return fig
