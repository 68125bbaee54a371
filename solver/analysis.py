"""Wave analysis of sampled inner-circle fields: mode, celerity, frequency, zones, limit cycle.

Pure numpy on arrays (t, theta, u_r(t, theta), u_theta(t, theta), status(t, theta)), so it works
on a run directory's ``samples.npz`` as well as on synthetic travelling waves in tests.

Conventions (paper eq. [3]): a wave u(theta - c t) travels in the sense of rotation when its
angular speed c > 0. For mode k, the Fourier coefficient U_k(t) = sum_j u_j exp(-i k theta_j)
of u = A cos(k (theta - c t)) has phase -k c t, so c = -(d phase/dt) / k. Celerity in m/s is
c R (signed), the frequency a fixed point sees is k |c| / (2 pi) Hz.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from solver.contact import SEPARATION, SLIP, STICK

ZONE_THRESHOLD = 0.005  # a zone counts as present above 0.5 % of node-samples


@dataclass
class WaveSummary:
    regime: str
    mode: int
    angular_speed_rad_s: float
    celerity_m_s: float
    frequency_hz: float
    fractions: dict
    amplitude_m: float
    limit_cycle: bool
    window_s: float

    def to_dict(self) -> dict:
        return asdict(self)


def mode_coefficients(field: np.ndarray, theta: np.ndarray, kmax: int) -> np.ndarray:
    """Fourier coefficients U_k(t), k = 0..kmax, of ``field`` (samples x nodes) on angles theta.

    A direct sum over the node angles (works for non-uniform node spacing), normalised so that
    A cos(k theta + phi) has |U_k| = A.
    """
    k = np.arange(kmax + 1)
    basis = np.exp(-1j * np.outer(theta, k)) * (2.0 / theta.size)
    coeffs = np.atleast_2d(field) @ basis
    coeffs[:, 0] *= 0.5
    return coeffs


def dominant_mode(field: np.ndarray, theta: np.ndarray, kmax: int | None = None) -> int:
    """The wavenumber k >= 1 with the largest mean amplitude over the samples."""
    kmax = kmax or theta.size // 2
    amp = np.abs(mode_coefficients(field, theta, kmax)).mean(axis=0)
    return int(np.argmax(amp[1:]) + 1)


def angular_speed(t: np.ndarray, field: np.ndarray, theta: np.ndarray, k: int) -> float:
    """Signed angular phase speed c (rad/s) of mode k, from a line fit of the unwrapped phase."""
    coeff = mode_coefficients(field, theta, k)[:, k]
    phase = np.unwrap(np.angle(coeff))
    if t.size < 2:
        return 0.0
    slope = np.polyfit(t, phase, 1)[0]
    return float(-slope / k)


def zone_fractions(status: np.ndarray) -> dict[str, float]:
    """Fractions of node-samples in separation / stick / slip."""
    total = max(1, status.size)
    return {
        "separation": float(np.count_nonzero(status == SEPARATION)) / total,
        "stick": float(np.count_nonzero(status == STICK)) / total,
        "slip": float(np.count_nonzero(status == SLIP)) / total,
    }


def classify(fractions: dict[str, float], threshold: float = ZONE_THRESHOLD) -> str:
    """Regime name from zone fractions (slip is always present while the cylinder drives)."""
    sep = fractions["separation"] > threshold
    stick = fractions["stick"] > threshold
    if sep and stick:
        return "stick-slip-separation"
    if sep:
        return "slip-separation"
    if stick:
        return "stick-slip"
    return "steady-sliding"


def analyse(
    t: np.ndarray,
    theta: np.ndarray,
    u_r: np.ndarray,
    u_theta: np.ndarray,
    status: np.ndarray,
    *,
    d: float,
    radius: float,
    window: float | None = None,
) -> WaveSummary:
    """Analyse the last ``window`` seconds (default: last third of the record)."""
    if t.size == 0:
        raise ValueError("no samples to analyse")
    span = t[-1] - t[0]
    window = span / 3.0 if window is None else min(window, span)
    sel = t >= t[-1] - window
    tw, ur, ut, st = t[sel], u_r[sel], u_theta[sel], status[sel]
    fractions = zone_fractions(st)
    regime = classify(fractions)
    if fractions["separation"] > ZONE_THRESHOLD:
        signal = ur - d
        amplitude = float(np.max(signal))
    else:
        signal = ut - ut.mean()
        amplitude = float(0.5 * (ut.max(axis=0) - ut.min(axis=0)).mean())
    k = dominant_mode(signal, theta)
    c = angular_speed(tw, signal, theta, k) if regime != "steady-sliding" else 0.0
    limit = _limit_cycle(t, u_r - d if fractions["separation"] > ZONE_THRESHOLD
                         else u_theta - u_theta.mean(), theta, status, k, c)
    return WaveSummary(
        regime=regime,
        mode=k,
        angular_speed_rad_s=c,
        celerity_m_s=c * radius,
        frequency_hz=abs(c) * k / (2.0 * np.pi),
        fractions=fractions,
        amplitude_m=amplitude,
        limit_cycle=limit,
        window_s=float(window),
    )


def _limit_cycle(t, signal, theta, status, k, c, periods: int = 3, tol: float = 0.05) -> bool:
    """Stationary mode-k envelope and zone fractions over two consecutive blocks of periods."""
    if c == 0.0 or t.size < 8:
        return False
    period = 2.0 * np.pi / (k * abs(c))
    block = periods * period
    if t[-1] - t[0] < 2 * block:
        return False
    late = t >= t[-1] - block
    early = (t >= t[-1] - 2 * block) & ~late
    amp = np.abs(mode_coefficients(signal, theta, k)[:, k])
    a_late, a_early = amp[late].mean(), amp[early].mean()
    if a_late <= 0 or abs(a_late - a_early) > tol * a_late:
        return False
    f_late, f_early = zone_fractions(status[late]), zone_fractions(status[early])
    return all(abs(f_late[z] - f_early[z]) < 0.02 for z in f_late)
