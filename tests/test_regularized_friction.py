"""Prakash-Clifton friction: exact integration, constraints kept, Coulomb limit.

Law (``solver.contact.EffectivePressure``): bound f sigma_eff,
d sigma_eff/dt = -(|V| + V*)/L (sigma_eff - p), or -(sigma_eff - p)/t* ("constant-time").
"""

import numpy as np
import pytest
from conftest import step_checking_contact

from stickslip.solver.contact import (
    SEPARATION,
    SLIP,
    STICK,
    ConstantTime,
    ContactArrays,
    EffectivePressure,
    PrakashClifton,
    project_contact,
    project_contact_regularized,
    relax_effective_pressure,
)
from stickslip.solver.scene import SceneError, load_scene


def test_relaxation_is_exact_for_a_frozen_rate_at_any_step():
    """n steps of dt = one step of n dt = the closed form p + (s0 - p) exp(-rate t), to
    round-off (1e-13 relative), for steps far beyond 1/rate (no stability limit)."""
    rng = np.random.default_rng(0)
    s0, p, rate = rng.uniform(0, 2, 50), rng.uniform(0, 2, 50), rng.uniform(0.1, 50, 50)
    exact = p + (s0 - p) * np.exp(-rate * 0.7)
    for n in (1, 7, 700):
        s = s0.copy()
        for _ in range(n):
            relax_effective_pressure(s, p, rate, 0.7 / n, np.empty(50))
        assert np.allclose(s, exact, rtol=1e-13, atol=1e-15)


def test_prakash_clifton_rate_uses_the_slip_rate_of_the_last_step():
    """rate = (|V| + V*)/L with V = (du_theta - R Omega dt)/dt; constant-time: 1/t*."""
    n, dt, L, v_ref, slide = 4, 1e-5, 1e-4, 0.5, 5e-4
    eff = EffectivePressure(n, PrakashClifton(slip_length=L, reference_velocity=v_ref), dt)
    out = ContactArrays(n)
    out.in_contact[:] = True
    p = np.ones(n)
    eff.update(p, np.zeros(n), slide, 0.7, out)  # start: sigma = p, at rest
    assert np.allclose(eff.rate, (slide / dt + v_ref) / L)  # steady sliding: V = R Omega
    u_t = np.array([0.0, slide, 2 * slide, -slide])  # V = -R Omega, 0, +R Omega, -2 R Omega
    p2 = 2.0 * np.ones(n)
    eff.update(p2, u_t, slide, 0.7, out)
    V = np.abs(u_t - slide) / dt
    rate = (V + v_ref) / L
    assert np.allclose(eff.rate, rate, rtol=1e-12)
    assert np.allclose(eff.sigma, 2.0 - np.exp(-rate * dt), rtol=1e-12)
    assert np.allclose(out.cone, 0.7 * eff.sigma)
    out.in_contact[1] = False  # no friction bound without contact, whatever sigma is
    eff.update(p2, u_t, slide, 0.7, out)
    assert out.cone[1] == 0.0 and eff.sigma[1] > 0.0
    ct = EffectivePressure(n, ConstantTime(relaxation_time=3e-5), dt)
    assert np.allclose(ct.rate, 1 / 3e-5)


def test_short_slip_length_is_exactly_coulomb():
    """L -> 0: exp(-rate dt) = 0, sigma_eff = p, so the projection equals Coulomb's bit for
    bit (same forces, same statuses), on random trial states with all three statuses."""
    rng = np.random.default_rng(5)
    n, kappa, d, slide, f = 400, 1e-9, 1e-3, 1e-4, 0.7
    mass = rng.uniform(1, 2, n)
    a, b = ContactArrays(n), ContactArrays(n)
    eff = EffectivePressure(n, PrakashClifton(slip_length=1e-300, reference_velocity=1.0),
                            1e-6)
    for _ in range(5):
        ur = d + rng.normal(scale=1e-4, size=n)
        ut_prev = rng.normal(scale=1e-4, size=n)
        ut = ut_prev + slide + rng.normal(scale=1e-4, size=n)
        project_contact(ur, ut, ut_prev, mass, kappa, d, slide, f, a)
        project_contact_regularized(ur, ut, ut_prev, mass, kappa, d, slide, f, eff, b)
        assert np.array_equal(a.r_r, b.r_r) and np.array_equal(a.r_t, b.r_t)
        assert np.array_equal(a.status, b.status)
    assert set(np.unique(a.status)) == {SEPARATION, STICK, SLIP}


def test_bad_regularization_input_is_refused_with_key_and_range():
    base = ['friction.regularization="prakash-clifton"']
    cases = (
        ([*base, "friction.slip_length=-1e-5", "friction.reference_velocity=1"],
         r"friction.slip_length = -1e-05 is out of range: must satisfy slip_length >= 0"),
        ([*base, "friction.slip_length=nan", "friction.reference_velocity=1"],
         r"friction.slip_length = nan .*finite"),
        ([*base, "friction.slip_length=1e-5", "friction.reference_velocity=-1"],
         r"friction.reference_velocity = -1.0 .*>= 0"),
        ([*base, "friction.slip_length=1e-5"], r"reference_velocity > 0"),
        (['friction.regularization="constant-time"', "friction.relaxation_time=-1"],
         r"friction.relaxation_time = -1.0 .*>= 0"),
        (['friction.regularization="constant-time"'], r"relaxation_time > 0"),
        (['friction.regularization="prakash"'], r"did you mean 'prakash-clifton'"),
        ([*base, "friction.slip_length=1e-5", "friction.reference_velocity=1",
          "time.beta1=0.25", "time.dt_fraction=2"], r"needs the explicit scheme"),
    )
    for ov, match in cases:
        with pytest.raises(SceneError, match=match):
            load_scene("scenes/smoke.toml", ov)


pytest.importorskip("dolfinx")

from mpi4py import MPI  # noqa: E402

from stickslip.solver.run import Simulation  # noqa: E402


def test_non_penetration_and_exact_stick_with_prakash_clifton():
    """FE run (N = 72) with a slip length comparable to the slip per period: the law changes
    the wave, and still u_r >= d to round-off after every step, contact nodes sit on the
    cylinder, stick nodes advance exactly R Omega dt; all three statuses occur."""
    sc = load_scene("scenes/smoke.toml", [
        "output.progress=false", "time.end_time=0.25", "mesh.n_inner=72", "mesh.n_radial=0",
        'friction.regularization="prakash-clifton"', "friction.slip_length=2e-5",
        "friction.reference_velocity=1.0"])
    sim = Simulation(sc, MPI.COMM_SELF)
    proj = sim.columns.projection
    below_p = [0]

    def slip_on_the_effective_bound(status):
        slip, contact = status == SLIP, status != SEPARATION
        # slip force on the bound f sigma_eff (not f p): the law is really in use
        assert np.allclose(np.abs(proj.out.r_t[slip]), 0.7 * proj.effective.sigma[slip],
                           rtol=1e-12)
        below_p[0] += int(np.sum(proj.effective.sigma[contact] < 0.99 * proj.out.r_r[contact]))

    seen, n_stick = step_checking_contact(sim, 2500, slip_on_the_effective_bound)
    assert seen == {SEPARATION, STICK, SLIP}
    assert n_stick > 10 and below_p[0] > 100
