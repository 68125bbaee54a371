"""Growth rates measured in a transient, to check the CEA: matrix pencil, Newmark exponents."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from stickslip.postprocess.analysis import mode_coefficients
from stickslip.solver.contact import SLIP
from stickslip.solver.errors import Diverged
from stickslip.solver.run import Simulation

if TYPE_CHECKING:
    from mpi4py import MPI

    from stickslip.solver.scene import Scene



# --------------------------------------------------------------------------------- transient


def matrix_pencil(
    dt: float, signal: np.ndarray, rel_tol: float = 1e-7, max_order: int = 40
) -> tuple[np.ndarray, np.ndarray]:
    """Complex exponents ``s_j`` and amplitudes ``c_j`` of ``signal[n] ≈ Σ c_j e^{s_j n dt}``.

    Matrix-pencil method (Hua & Sarkar 1990): Hankel matrix of the samples, SVD truncated at
    ``rel_tol`` × the largest singular value (model order), eigenvalues ``z_j`` of the pencil,
    ``s_j = log(z_j)/dt``; amplitudes by least squares. Exact for noise-free sums of
    exponentials, which is what a linear system's response is.
    """
    y = np.asarray(signal, dtype=complex)
    n = y.size
    L = n // 2
    H = np.lib.stride_tricks.sliding_window_view(y, L + 1)  # (n − L) × (L + 1)
    _, sv, vh = np.linalg.svd(H, full_matrices=False)
    order = int(min(max_order, np.count_nonzero(sv > rel_tol * sv[0])))
    W = vh[:order].T  # (L + 1) × order: its columns span the vectors (1, z_j, z_j², ...)
    z = np.linalg.eigvals(np.linalg.pinv(W[:-1]) @ W[1:])
    Z = z[None, :] ** np.arange(n)[:, None]
    c = np.linalg.lstsq(Z, y, rcond=None)[0]
    return np.log(z) / dt, c


def newmark_exponents(
    omega2: np.ndarray, dt: float, beta2: float, tau: float = 0.0
) -> np.ndarray:
    """Discrete exponents ``s = log(z)/dt`` of the explicit solver for eigenvalues ``ω²``.

    In the sliding regime the solver's forward-increment constraint keeps ``ũ_r = d`` exactly
    (the radial acceleration of a contact node then vanishes: ``a_{n+1} = a_n (β₂−½)/(β₂+½)``
    from ``a_0 = 0``), so the free dofs follow explicit Newmark (``β₁ = 0``, ``γ = β₂``) on
    ``M ü + τA u̇ + A u = 0``, ``A = K + K_f``, with the damping force on the velocity
    predictor (``solver.ensemble.ArrayColumns``). Per eigenvalue (``W = ω² dt²``,
    ``C = τω² dt``) the amplification matrix of ``(u_n, dt ṽ_n)`` has
    ``z² − (2 − (β₂ + ½)W − C) z + 1 − C − (β₂ − ½)W = 0``. Returns the root of larger
    ``|z|`` (the growing / less damped one) as ``s`` with ``Im s ≥ 0``; it tends to the CEA's
    ``λ`` as ``dt → 0``. For ``β₂ = ½``, ``τ = 0`` (central differences)
    ``cosh(s dt) = 1 − ω²dt²/2``.
    """
    mu = np.asarray(omega2, dtype=complex)
    w2 = mu * dt * dt
    damp = tau * mu * dt
    b = 2.0 - (beta2 + 0.5) * w2 - damp
    c = 1.0 - damp - (beta2 - 0.5) * w2
    disc = np.sqrt(b * b - 4.0 * c)
    z1, z2 = 0.5 * (b + disc), 0.5 * (b - disc)
    z = np.where(np.abs(z1) >= np.abs(z2), z1, z2)
    s = np.log(z) / dt
    return np.where(s.imag < 0, np.conj(s), s)


@dataclass
class TransientGrowth:
    """Growth of mode k of u_θ on the contact circle in a seeded transient run.

    ``growth_rate``/``frequency_hz``: slope of log|U_k(t)| and of its phase over the window
    (the dominant component if one dominates). ``exponents``: matrix-pencil decomposition
    ``U_k(t) = Σ c_j e^{s_j t}`` (growth Re s, signed frequency Im s/2π: > 0 = travelling
    against the rotation, as ψ ∝ e^{ikθ}), sorted by |c_j e^{s_j t_end}| (dominance at the
    end of the window).
    """

    k: int
    growth_rate: float
    frequency_hz: float
    exponents: list[tuple[float, float, float]]  # (growth 1/s, signed Hz, |c e^{s t_end}|)
    window_s: tuple[float, float]
    amplitude_range_m: tuple[float, float]
    all_slip: bool  # every node slipped in contact during the window (linear regime)
    dt_s: float


def measure_transient_growth(
    scene: Scene, k: int, comm: MPI.Comm, *, window: tuple[float, float],
    amplitude: float = 1e-6, beta2: float = 0.5, sample_interval: float = 2e-5,
) -> TransientGrowth:
    """Seed steady sliding with a small mode-k bump and measure how U_k(t) of u_θ grows.

    ``solver.run.Simulation`` with ``initial.perturbation = "mode"`` (``amplitude`` × d),
    ``β₂ = 1/2`` by default (no numerical damping), run to ``window[1]``; ``U_k`` from
    ``postprocess.analysis.mode_coefficients`` of the recorder's u_θ samples in ``window``
    (which must lie in the linear phase: checked, every node slipping).
    """
    sc = scene.with_overrides(
        'initial.perturbation="mode"', f"initial.mode={k}", f"initial.amplitude={amplitude}",
        f"time.beta2={beta2}", f"time.end_time={window[1] + 2 * sample_interval}",
        f"output.sample_interval={sample_interval}", "output.progress=false",
    )
    sim = Simulation(sc, comm)
    if sim.proceed() == "diverged":  # a blow-up has no growth rate to measure
        raise Diverged(sim.message)
    result = None
    if comm.rank == 0:
        data = sim.recorder.arrays()
        t = data["t"]
        coeff = mode_coefficients(data["u_theta"], data["theta"], k)[:, k]
        sel = (t >= window[0] - 1e-12) & (t <= window[1] + 1e-12)
        ts, amp = t[sel], np.abs(coeff[sel])
        slope = float(np.polyfit(ts, np.log(amp), 1)[0])
        freq = float(np.polyfit(ts, np.unwrap(np.angle(coeff[sel])), 1)[0]) / (2 * math.pi)
        dts = float(np.mean(np.diff(ts)))
        s, c = matrix_pencil(dts, coeff[sel])
        size = np.abs(c * np.exp(s * (ts[-1] - ts[0])))
        order = np.argsort(-size)
        result = TransientGrowth(
            k=k, growth_rate=slope, frequency_hz=freq,
            exponents=[(float(s[i].real), float(s[i].imag / (2 * math.pi)), float(size[i]))
                       for i in order],
            window_s=(float(ts[0]), float(ts[-1])),
            amplitude_range_m=(float(amp.min()), float(amp.max())),
            all_slip=bool(np.all(data["status"][sel] == SLIP)), dt_s=sim.dt,
        )
    return comm.bcast(result, root=0)


