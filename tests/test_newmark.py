"""Explicit Newmark (solver.newmark) on a spring chain: stability limit and contact kappa.

No dolfinx needed: the stiffness is a scipy sparse matrix with exactly known spectrum.
"""

import numpy as np
import pytest
import scipy.sparse as sp

from stickslip.solver.newmark import Newmark, critical_time_step

N = 60


def chain():
    """Fixed-fixed chain of N unit masses and unit springs: w_max = 2 sin(N pi / (2(N+1)))."""
    K = sp.diags([-np.ones(N - 1), 2 * np.ones(N), -np.ones(N - 1)], [-1, 0, 1], format="csr")
    w_max = 2 * np.sin(N * np.pi / (2 * (N + 1)))
    return K, w_max


def run(dt, beta2, steps=3000):
    K, _ = chain()
    integ = Newmark(lambda u, out: np.copyto(out, K @ u), np.ones(N), dt, 0.0, beta2)
    rng = np.random.default_rng(0)
    integ.set_state(rng.normal(size=N), np.zeros(N))
    for _ in range(steps):
        integ.step()
    return np.max(np.abs(integ.u))


@pytest.mark.parametrize("beta2", [0.5, 0.6, 0.9])
def test_stability_limit_sqrt2_over_beta2(beta2):
    _, w_max = chain()
    dt_crit = critical_time_step(w_max, 0.0, beta2)
    assert dt_crit == pytest.approx(np.sqrt(2 / beta2) / w_max)
    # 2 % below the limit: bounded (initial amplitude ~3); 2 % above: the top mode grows by
    # |lambda|^3000 >> 1e6 (|lambda| - 1 = O(sqrt(0.02)) for beta2 = 1/2, O(0.02) otherwise).
    assert run(0.98 * dt_crit, beta2) < 10.0
    with np.errstate(all="ignore"):
        blown = run(1.02 * dt_crit, beta2)
    assert not np.isfinite(blown) or blown > 1e6


def test_implicit_is_refused_with_a_clear_message():
    with pytest.raises(NotImplementedError, match="beta1 = 0"):
        Newmark(lambda u, out: None, np.ones(3), 1e-3, 0.25, 0.5)


def test_contact_force_moves_next_displacement_by_kappa_over_m():
    """A force r at step n changes u_{n+1} by (beta2 + 1/2) dt^2 r / m, not dt^2/2 r / m."""
    dt, beta2, m = 1e-3, 0.7, 3.0
    r = 5.0

    def contact(u_now, v_pred, accel):
        accel += r / m  # a_n = a*_n + M^{-1} r_n

    base = Newmark(lambda u, out: out.fill(0.0), np.full(1, 1 / m), dt, 0.0, beta2)
    pushed = Newmark(lambda u, out: out.fill(0.0), np.full(1, 1 / m), dt, 0.0, beta2, contact)
    for integ in (base, pushed):
        integ.set_state(np.zeros(1), np.zeros(1))
        integ.step()
    assert pushed.u[0] - base.u[0] == pytest.approx((beta2 + 0.5) * dt**2 * r / m, rel=1e-12)
    assert pushed.kappa == pytest.approx((beta2 + 0.5) * dt**2)
