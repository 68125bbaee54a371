"""The explicit Newmark step (solver.ensemble, a batch of one with its own operators) on a
spring chain: stability limit and contact kappa.

No dolfinx needed: the stiffness is a scipy sparse matrix with exactly known spectrum.
"""

import numpy as np
import pytest
import scipy.sparse as sp
from conftest import explicit_stepper

from stickslip.solver.newmark import critical_time_step

N = 60


def chain():
    """Fixed-fixed chain of N unit masses and unit springs: w_max = 2 sin(N pi / (2(N+1)))."""
    K = sp.diags([-np.ones(N - 1), 2 * np.ones(N), -np.ones(N - 1)], [-1, 0, 1], format="csr")
    w_max = 2 * np.sin(N * np.pi / (2 * (N + 1)))
    return K, w_max


def run(dt, beta2, steps=3000):
    K, _ = chain()
    integ = explicit_stepper(lambda u, out: np.copyto(out, K @ u), np.ones(N), dt, beta2)
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


@pytest.mark.parametrize("beta2", [0.4, 1.5])
def test_a_beta2_outside_one_half_to_one_is_refused_with_its_value(beta2):
    with pytest.raises(ValueError, match=rf"time.beta2 = {beta2} must be in \[0.5, 1\]"):
        explicit_stepper(lambda u, out: None, np.ones(4), 1e-3, beta2)


def test_contact_force_moves_next_displacement_by_kappa_over_m():
    """A force r at step n changes u_{n+1} by (beta2 + 1/2) dt^2 r / m, not dt^2/2 r / m."""
    dt, beta2, m = 1e-3, 0.7, 3.0
    r = 5.0

    def contact(u_now, v_pred, accel):
        accel += r / m  # a_n = a*_n + M^{-1} r_n

    base = explicit_stepper(lambda u, out: out.fill(0.0), np.full(2, 1 / m), dt, beta2)
    pushed = explicit_stepper(lambda u, out: out.fill(0.0), np.full(2, 1 / m), dt, beta2,
                              contact)
    for integ in (base, pushed):
        integ.set_state(np.zeros(2), np.zeros(2))
        integ.step()
    assert pushed.u[0] - base.u[0] == pytest.approx((beta2 + 0.5) * dt**2 * r / m, rel=1e-12)
    assert pushed.kappa == pytest.approx((beta2 + 0.5) * dt**2)


@pytest.mark.parametrize(("beta2", "tau"), [(0.5, 0.0), (0.6, 0.02)])
def test_one_system_steps_as_the_batch_of_one_it_is(beta2, tau):
    """The numpy step of one system given by its operators (``SceneArrayColumns``: 1-D
    views, its own product) and the numpy reference batch (``ArrayColumns``, kernel "xp":
    (n, 1) arrays, scipy's K) run the same two functions, ``internal_force`` and
    ``newmark_update``: on the spring chain without contact, 400 steps, plain and damped,
    u, v and v~ are the same bits."""
    from stickslip.solver.ensemble import BatchedExplicit, BatchedProblem

    K, w_max = chain()
    dt = 0.5 * critical_time_step(w_max, 0.0, beta2, tau)
    one = explicit_stepper(lambda u, out: np.copyto(out, K @ u), np.ones(N), dt, beta2,
                           tau=tau)
    bp = BatchedProblem(indptr=K.indptr, indices=K.indices, data=K.data, mass=np.ones(N),
                        inv_mass=np.ones(N), cx=np.zeros(0, dtype=np.int64),
                        theta=np.zeros(0), cmass=np.zeros(0), dt=dt, beta2=beta2)
    batch = BatchedExplicit(bp, d=np.zeros(1), slide=np.zeros(1), f=np.zeros(1),
                            kernel="xp", tau=tau)
    u0 = np.random.default_rng(2).normal(size=N)
    one.set_state(u0, np.zeros(N))
    batch.set_state(u0[:, None], np.zeros((N, 1)))
    for _ in range(400):
        one.step()
        batch.step()
    for name in ("u", "u_prev", "v", "v_pred"):
        np.testing.assert_array_equal(getattr(one, name), getattr(batch, name)[:, 0], name)
    assert np.max(np.abs(one.u)) > 0.1 * np.max(np.abs(u0))  # still vibrating: not zeros compared


def test_the_numpy_kernel_and_its_operators_go_together():
    """The numpy kernel steps one system with its own operators; the batch kernels bring
    their own product and law: either mismatch is one line naming it."""
    from stickslip.solver.ensemble import BatchedExplicit, BatchedProblem

    bp = BatchedProblem.without_matrix(np.ones(4), np.ones(4), 1e-3, 0.5)
    args = dict(d=np.zeros(1), slide=np.zeros(1), f=np.zeros(1))
    with pytest.raises(ValueError, match=r"kernel = 'numpy' steps one scene with its own K "
                       r"product and contact step \(operators\)$"):
        BatchedExplicit(bp, kernel="numpy", **args)
    with pytest.raises(ValueError, match=r"kernel = 'xp' has its own K product and contact "
                       r"law \(no operators\)$"):
        BatchedExplicit(bp, kernel="xp", operators=(lambda u, out: None, None), **args)
    with pytest.raises(ValueError, match="steps one scene, not B = 2"):
        BatchedExplicit(bp, kernel="numpy", operators=(lambda u, out: None, None),
                        d=np.zeros(2), slide=np.zeros(2), f=np.zeros(2))
