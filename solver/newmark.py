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

The implicit scheme (beta_1 > 0) lives in ``solver.implicit.ImplicitNewmark`` (it needs the
stiffness matrix and a factorisation, not only a stiffness product); ``solver.schemes`` picks
the class from the scene's ``time.beta1``.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from stickslip.solver.contact.law import forward_increment_factor
from stickslip.solver.stepper import HookedStepper, copy_state, put_state

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

    With Kelvin-Voigt damping C = tau K, explicit (``DampedNewmark``: damping force on the
    predictor v~_n), a mode w obeys a_n = -w^2 u_n - c v~_n with c = tau w^2 = 2 zeta w. In
    x = (u_n, dt v~_n) one step is x_{n+1} = A x_n with (W = w dt, C = c dt, k = beta_2 + 1/2)

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


class Newmark(HookedStepper):
    """Explicit Newmark (beta_1 = 0) on owned-dof numpy arrays.

    The only global operation per step is ``stiffness_mult(u, ku)`` (one PETSc MatMult);
    everything else is in-place numpy on preallocated arrays.

    Args:
        stiffness_mult: ``stiffness_mult(u, out)`` computes out = K u on owned arrays.
        inv_mass: Inverse lumped mass per owned dof; 0 on clamped dofs (they never move).
        dt, beta1, beta2: Time step and Newmark parameters (paper's notation).
        contact: Optional forward-increment constraint, see ``ContactStep``.
    """

    #: Kelvin-Voigt retardation time (``DampedNewmark``; 0: undamped)
    tau: float = 0.0
    #: What the next step reads: u_{n+1}, u_n (a damped step's u_{n-1}) and v~_{n+1}.
    STATE: tuple[str, ...] = ("u", "u_prev", "v_pred")

    def __init__(
        self,
        stiffness_mult: Callable[[np.ndarray, np.ndarray], None],
        inv_mass: np.ndarray,
        dt: float,
        beta1: float = 0.0,
        beta2: float = 0.5,
        contact: ContactStep | None = None,
    ) -> None:
        if beta1 != 0.0:
            raise NotImplementedError(
                f"time.beta1 = {beta1}: Newmark is the explicit scheme (beta1 = 0) driven by a "
                "stiffness product; beta1 > 0 needs the factorised K_eff: use "
                "solver.implicit.ImplicitNewmark (solver.schemes.select.for_scene picks it)"
            )
        if not 0.5 <= beta2 <= 1.0:
            raise ValueError(f"time.beta2 = {beta2} must be in [0.5, 1]")
        self.beta1, self.beta2, self.dt = beta1, beta2, dt
        self.kappa = forward_increment_factor(beta2, dt)
        self._mult = stiffness_mult
        self.inv_mass = inv_mass
        self.contact = contact
        n = inv_mass.size
        self.u = np.zeros(n)  # u_n
        self.v = np.zeros(n)  # v_n (after the step that produced it)
        self.a = np.zeros(n)  # a_n
        self.v_pred = np.zeros(n)  # v~_{n}: v_{n-1} + (1 - beta2) dt a_{n-1}
        self.ku = np.zeros(n)  # K u_n
        self.u_prev = np.zeros(n)  # u_{n} once the step is done (u holds u_{n+1})
        self.scratch = np.zeros(n)
        self._neg_inv_mass = -inv_mass
        self.time = 0.0
        self.step_count = 0
        self._init_hooks()

    def facts(self) -> dict:
        """Scheme facts for the run summary (``solver.stepper.Stepper``)."""
        return {"scheme": "explicit", "beta1": self.beta1, "beta2": self.beta2,
                "damping_tau_s": self.tau,
                "contact_s": float(getattr(self.contact, "seconds", 0.0)),
                "kernel": "numpy"}

    def state(self) -> dict[str, np.ndarray]:
        """The checkpoint of the stepper (``solver.stepper.Stepper.state``)."""
        return copy_state(self, self.STATE, clock=True)

    def restore(self, state: dict[str, np.ndarray]) -> None:
        """Continue from ``state()`` (``solver.stepper.Stepper.restore``)."""
        put_state(self, state, self.STATE)

    def kick(self, b: int, du: np.ndarray, dv: np.ndarray) -> None:
        """Perturb the scene where it stands (``b`` = 0: one scene), as
        ``solver.ensemble.BatchedExplicit.kick``: u_{n+1} and u_n move by ``du`` (the
        displacement kick leaves the velocity alone), v~_{n+1} by ``dv``; a damped step forms
        w = u + tau v~ from them."""
        self.u += du
        self.u_prev += du
        self.v_pred += dv

    def set_state(self, u: np.ndarray, v: np.ndarray, a0: np.ndarray | None = None) -> None:
        """Initial displacement, velocity and (optionally) acceleration.

        The first step computes v_0 = v~_0 + beta_2 dt a_0, so the predictor is set to
        v~_0 = v_0 - beta_2 dt a_0 when a_0 is known; without it v~_0 = v_0, exact when a_0 = 0
        (e.g. a start from the steady state) and an O(dt) start-up error otherwise, which
        makes the whole run first order.
        """
        self.u[:] = u
        self.v[:] = v
        self.v_pred[:] = v
        if a0 is not None:
            self.v_pred -= self.beta2 * self.dt * np.asarray(a0)
        self.a.fill(0.0)

    def _elastic_acceleration(self, u: np.ndarray, v_pred: np.ndarray, a: np.ndarray) -> None:
        """a*_n = -M^{-1} K u_n (K u_n kept in ``ku`` for the energies)."""
        self._mult(u, self.ku)
        np.multiply(self.ku, self._neg_inv_mass, out=a)

    def step(self) -> None:
        """Advance one step: u_n -> u_{n+1}.

        Afterwards ``u`` is u_{n+1}, while ``u_prev``, ``v``, ``a`` and ``ku`` hold u_n, v_n,
        a_n and K u_n (one consistent time level, used for energies); the contact forces r_n
        are in the contact step's own arrays.

        Operation count: one MatMult and 7 (beta_2 = 1/2) or 9 vector operations, using
        w = v_n + dt/2 a_n:  u_{n+1} = u_n + dt w,  v~_{n+1} = w + (1/2 - beta_2) dt a_n.
        ``u`` and ``u_prev`` swap arrays instead of copying.
        """
        dt, b2 = self.dt, self.beta2
        u, a, v, vp = self.u, self.a, self.v, self.v_pred
        self._elastic_acceleration(u, vp, a)  # a*_n
        if self.contact is not None:
            self.contact(u, vp, a)  # a_n = a*_n + M^{-1} r_n at the contact dofs
        # v_n = v~_n + beta2 dt a_n
        np.multiply(a, b2 * dt, out=v)
        v += vp
        # w = v_n + dt/2 a_n (kept in v_pred), u_{n+1} = u_n + dt w (into the spare array)
        np.multiply(a, 0.5 * dt, out=vp)
        vp += v
        nxt = self.u_prev
        np.multiply(vp, dt, out=nxt)
        nxt += u
        self.u, self.u_prev = nxt, u
        # v~_{n+1} = v_n + (1 - beta2) dt a_n = w + (1/2 - beta2) dt a_n
        if b2 != 0.5:
            np.multiply(a, (0.5 - b2) * dt, out=self.scratch)
            vp += self.scratch
        self.time += dt
        self.step_count += 1


class DampedNewmark(Newmark):
    """Explicit Newmark with Kelvin-Voigt damping C = tau K (scene ``[damping]``).

    M a_n + tau K v~_n + K u_n = r_n: the damping force uses the velocity predictor
    v~_n = v_{n-1} + (1 - beta_2) dt a_{n-1} (known before a_n), so the internal force is ONE
    MatMult, K w_n with w_n = u_n + tau v~_n, and the contact force still moves u_{n+1} by
    kappa M^{-1} r (the forward-increment projection is unchanged). Stability limit:
    ``critical_time_step(w_max, 0, beta_2, tau)``. Only the elastic acceleration differs from
    ``Newmark`` (``_elastic_acceleration``): the undamped step does no damping work.

    After ``step()``, ``kw`` = K w_n (the internal force that was applied) and ``ku`` is only
    valid after ``refresh_ku()`` (one extra MatMult, done at sample times by the observers).
    """

    damped = True

    def __init__(self, stiffness_mult: Callable[[np.ndarray, np.ndarray], None],
                 inv_mass: np.ndarray, dt: float, beta1: float = 0.0, beta2: float = 0.5,
                 contact: ContactStep | None = None, tau: float = 0.0) -> None:
        super().__init__(stiffness_mult, inv_mass, dt, beta1, beta2, contact)
        if not (math.isfinite(tau) and tau > 0.0):
            raise ValueError(f"damping tau = {tau} must be a finite number > 0 (s)")
        self.tau = tau
        self.w = np.zeros(inv_mass.size)  # u_n + tau v~_n
        self.kw = np.zeros(inv_mass.size)  # K w_n

    def refresh_ku(self) -> None:
        """ku = K u_n (u_n is ``u_prev`` after a step): for the strain energy at samples."""
        self._mult(self.u_prev, self.ku)

    def _elastic_acceleration(self, u: np.ndarray, v_pred: np.ndarray, a: np.ndarray) -> None:
        """a*_n = -M^{-1} K (u_n + tau v~_n): elastic plus Kelvin-Voigt force, one MatMult."""
        np.multiply(v_pred, self.tau, out=self.w)
        self.w += u
        self._mult(self.w, self.kw)
        np.multiply(self.kw, self._neg_inv_mass, out=a)
