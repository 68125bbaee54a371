"""The terms of a run's energy balance, from the ``energies`` columns of ``samples.npz``.

Columns (``solver.observers.ENERGY_FIELDS``, cumulative works since the start):
kinetic K = ½ vᵀMv, strain U = ½ uᵀKu, work_contact W_c = Σ rₙ·Δuₙ (all contact forces on the
tube), work_cylinder W_cyl = Σ r_θ RΩ Δt (fed by the rotating cylinder), friction_dissipation
D_f = W_cyl − Σ r_θ Δu_θ, and damping_dissipation D_v (Kelvin–Voigt; absent from the batched
ensemble's five columns, zero there). The work of the normal contact forces is
W_c − (W_cyl − D_f); it is ≤ 0 (the impacts of the explicit contact step are inelastic), so
D_n = −(W_c − W_cyl + D_f) is the impact dissipation. The balance

    E(t) = K + U = E(0) + W_cyl − D_f − D_n − D_v + r(t)

defines the residual r(t) = E(t) − E(0) − W_c + D_v, the number ``summary.json`` reports as
``balance_residual_J_per_m``. With β₂ > ½ it is the algorithmic dissipation of the Newmark
scheme (negative), with β₂ = ½ the O(Δt²) error of the discrete energy identity.
"""

from __future__ import annotations

import numpy as np


def energy_terms(energies: np.ndarray) -> dict[str, np.ndarray]:
    """Time series (J/m) of every term of the balance from ``samples.npz``'s ``energies``.

    Returns ``kinetic``, ``strain``, ``total`` = K + U, and the terms accumulated since the
    first sample: ``work_cylinder``, ``friction_dissipation``, ``impact_dissipation``,
    ``viscous_dissipation``, and the ``residual`` r(t) with
    total = total[0] + work_cylinder − friction − impact − viscous + residual (exactly).
    """
    e = np.asarray(energies, dtype=float)
    if e.ndim != 2 or e.shape[1] < 5:
        raise ValueError(f"energies of shape {e.shape}: expected (samples, 5 or 6) columns")
    kinetic, strain = e[:, 0], e[:, 1]
    total = kinetic + strain
    work_contact = e[:, 2] - e[0, 2]
    work_cylinder = e[:, 3] - e[0, 3]
    friction = e[:, 4] - e[0, 4]
    viscous = e[:, 5] - e[0, 5] if e.shape[1] > 5 else np.zeros_like(total)
    impact = -(work_contact - (work_cylinder - friction))
    residual = total - total[0] - work_contact + viscous
    return {"kinetic": kinetic, "strain": strain, "total": total,
            "work_cylinder": work_cylinder, "friction_dissipation": friction,
            "impact_dissipation": impact, "viscous_dissipation": viscous,
            "residual": residual}

