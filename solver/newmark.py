"""Newmark beta-method (the paper's beta_1, beta_2) with a forward-increment contact step.

Semi-discrete system (lumped mass M, stiffness K, nodal contact forces r on the inner circle):

    M a + K u = r.

Newmark, paper's notation (beta_1 = "beta", beta_2 = "gamma" elsewhere):

    u_{n+1} = u_n + dt v_n + dt^2/2 [(1 - 2 beta_1) a_n + 2 beta_1 a_{n+1}]
    v_{n+1} = v_n + dt [(1 - beta_2) a_n + beta_2 a_{n+1}]

Explicit case beta_1 = 0 with the Carpenter-Taylor-Katona forward increment [CAR 91]: the
contact force r_n at t_n is chosen so that the constraint holds at t_{n+1}. Write the velocity
as a predictor plus its beta_2 part, v_n = v~_n + beta_2 dt a_n with
v~_n = v_{n-1} + (1 - beta_2) dt a_{n-1}. With a_n = a*_n + M^{-1} r_n, a*_n = -M^{-1} K u_n:

    u_{n+1} = u_n + dt v~_n + kappa a*_n  +  kappa M^{-1} r_n,   kappa = (beta_2 + 1/2) dt^2.

So, because v_n carries beta_2 dt a_n, a contact force moves u_{n+1} by kappa M^{-1} r, not by
the textbook dt^2/2 M^{-1} r (which is kappa only for beta_2 = 0). The projection
(``solver.contact.project_contact``) uses this kappa, which makes non-penetration exact to
round-off and stick nodes move exactly R Omega dt per step.

Stability of the explicit scheme (no physical damping), from the amplification matrix of
u'' + w^2 u = 0: |eigenvalues| <= 1 iff w dt <= sqrt(2 / beta_2) (= 2, central differences,
for beta_2 = 1/2). With w_max the largest eigenfrequency of (K, M):
dt_crit = sqrt(2 / beta_2) / w_max. The algorithmic damping of beta_2 > 1/2 acts on w dt, so at a
fixed fraction of dt_crit it damps the same *relative* part of the spectrum on every mesh, but
a given physical frequency is damped less on a finer mesh (smaller dt).

The explicit step itself is ``solver.ensemble``'s (``internal_force``, ``newmark_update``:
B scenes at once, one scene a batch of one, ``solver.scene_explicit``); this module holds its
contact-step protocol and stability limit. The implicit scheme (beta_1 > 0) lives in
``solver.implicit.ImplicitNewmark`` (it needs the stiffness matrix and a factorisation, not
only a stiffness product); ``solver.schemes`` picks the scheme from the scene's
``time.beta1``.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

ContactStep = Callable[[np.ndarray, np.ndarray, np.ndarray], None]
"""contact(u_n, v~_n, a): the forward-increment constraint, in place on ``a``.

On entry ``a`` holds a*_n = -M^{-1} K u_n. The contact step forms the trial position
u_n + dt v~_n + kappa a*_n at its own dofs only, computes the nodal forces r_n and adds
M^{-1} r_n to ``a`` at those dofs. Nothing else is touched, so the cost scales with the
number of contact nodes, not with the mesh.
"""


def critical_time_step(omega_max: float, beta1: float, beta2: float, tau: float = 0.0) -> float:
    """Largest stable dt of the Newmark scheme for eigenfrequency ``omega_max``.

    beta_1 = 0: sqrt(2 / beta_2) / omega_max without damping. Unconditionally stable (inf) for
    2 beta_1 >= beta_2 >= 1/2; otherwise 1 / (omega_max sqrt(beta_2 / 2 - beta_1)).

    With Kelvin-Voigt damping C = tau K, explicit (the damping force on the predictor v~_n,
    ``solver.ensemble.internal_force``), a mode w obeys
    a_n = -w^2 u_n - c v~_n with c = tau w^2 = 2 zeta w. In x = (u_n, dt v~_n) one step is
    x_{n+1} = A x_n with (W = w dt, C = c dt, k = beta_2 + 1/2)

        A = [[1 - k W^2, 1 - k C], [-W^2, 1 - C]],  tr A = 2 - k W^2 - C,
        det A = 1 - C - (beta_2 - 1/2) W^2.

    Jury's conditions |det| <= 1, |tr| <= 1 + det reduce to beta_2 W^2 + C <= 2, i.e.
    w dt <= (sqrt(zeta^2 + 2 beta_2) - zeta) / beta_2 (central differences, beta_2 = 1/2:
    (2 / w)(sqrt(1 + zeta^2) - zeta)). As c grows with w^2 the largest w is critical:
    dt_crit = 4 / (w_max^2 (tau + sqrt(tau^2 + 8 beta_2 / w_max^2))) (rationalised root of
    beta_2 w^2 dt^2 + tau w^2 dt = 2). The implicit scheme treats the damping implicitly, so
    ``tau`` only enters the explicit limit.
    """
    if beta2 < 0.5:
        raise ValueError(f"beta2 = {beta2} < 0.5 is unstable for any dt (need beta2 >= 0.5)")
    if 2.0 * beta1 >= beta2:
        return math.inf
    if beta1 == 0.0 and tau > 0.0:
        w2 = omega_max * omega_max
        return 4.0 / (w2 * (tau + math.sqrt(tau * tau + 8.0 * beta2 / w2)))
    return 1.0 / (omega_max * math.sqrt(beta2 / 2.0 - beta1))
