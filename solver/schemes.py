"""Choice of the time scheme for a scene: time step and integrator + contact step.

The scene's ``time`` table picks the scheme: beta1 = 0 is the paper's explicit Newmark with
the forward-increment (Carpenter-Taylor-Katona) nodal contact projection.
"""

from __future__ import annotations

from solver.newmark import Newmark, critical_time_step
from solver.scene import Scene


class StepTooLarge(ValueError):
    """A fixed time step above the explicit stability limit."""


def time_step(scene: Scene, omega_max: float) -> tuple[float, float]:
    """(dt, dt_crit) for ``scene``: a fixed ``time.dt`` (checked) or ``dt_fraction * dt_crit``."""
    ts = scene.time
    dt_crit = critical_time_step(omega_max, ts.beta1, ts.beta2)
    if ts.dt > 0.0:
        if ts.dt > dt_crit:
            raise StepTooLarge(
                f"time.dt = {ts.dt:.4g} s is above the explicit stability limit "
                f"dt_crit = sqrt(2/beta2)/omega_max = {dt_crit:.4g} s "
                f"(omega_max = {omega_max:.4g} rad/s, beta2 = {ts.beta2}). Use "
                f"time.dt <= {dt_crit:.4g}, or time.dt = 0 with time.dt_fraction <= 1"
            )
        return ts.dt, dt_crit
    return ts.dt_fraction * dt_crit, dt_crit


def make_integrator(problem, scene: Scene, dt: float):
    """(integrator, projection) for the scene's scheme.

    The projection exposes ``out`` (ContactArrays: r_r, r_t, status), ``slide``, ``nodes`` and
    ``_polar`` as used by the observers; the integrator exposes ``step()``, ``set_state``,
    ``u``, ``u_prev``, ``v``, ``a``, ``ku``, ``time``, ``dt``, ``step_count``.
    """
    from solver.problem import ContactProjection

    ts = scene.time
    integrator = Newmark(problem.stiffness_mult(), problem.inv_mass, dt, ts.beta1, ts.beta2)
    projection = ContactProjection(problem, integrator.kappa, dt)
    integrator.contact = projection
    return integrator, projection
