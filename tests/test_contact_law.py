"""The nodal contact/friction projection on its own (solver.contact), no dolfinx needed."""

import numpy as np
import pytest

from solver.contact import SEPARATION, SLIP, STICK, ContactArrays, project_contact

D = 1e-3  # mismatch, m
KAPPA = 2e-10  # (beta2 + 1/2) dt^2, s^2
SLIDE = 1e-4  # R Omega dt, m


def project(u_r, u_t, u_t_prev, f, mass=2.0):
    n = len(u_r)
    out = ContactArrays(n)
    project_contact(np.asarray(u_r, float), np.asarray(u_t, float), np.asarray(u_t_prev, float),
                    np.full(n, mass), KAPPA, D, SLIDE, f, out)
    return out


def test_separated_node_gets_no_force():
    out = project([D + 1e-6], [0.0], [0.0], f=0.7)
    assert out.status[0] == SEPARATION
    assert out.r_r[0] == 0.0 and out.r_t[0] == 0.0


def test_penetrating_node_is_pushed_exactly_back_to_the_cylinder():
    m = 2.0
    u_r_trial = D - 3e-7
    out = project([u_r_trial], [0.0], [0.0], f=0.0, mass=m)
    # corrected position u_r_trial + kappa/m r_r must sit on the cylinder to round-off
    assert u_r_trial + KAPPA / m * out.r_r[0] == pytest.approx(D, abs=1e-18)
    assert out.r_r[0] > 0 and out.status[0] == SLIP  # f = 0: contact without friction slips


def test_stick_inside_the_cone_moves_with_the_cylinder():
    m, u_prev = 2.0, 5e-6
    # trial tangential position close to the cylinder's: small stick force, deep contact
    u_t_trial = u_prev + SLIDE - 1e-12
    out = project([D - 1e-6], [u_t_trial], [u_prev], f=0.7, mass=m)
    assert out.status[0] == STICK
    assert abs(out.r_t[0]) <= 0.7 * out.r_r[0]
    # the node advances exactly R Omega dt in the step
    assert u_t_trial + KAPPA / m * out.r_t[0] - u_prev == pytest.approx(SLIDE, rel=1e-12)


def test_slip_force_sits_on_the_cone_and_opposes_relative_sliding():
    # tube trial motion slower than the cylinder: friction drags it forward (+)
    out = project([D - 1e-9], [0.0], [0.0], f=0.3)
    assert out.status[0] == SLIP
    assert out.r_t[0] == pytest.approx(0.3 * out.r_r[0], rel=1e-14)
    # tube trial motion faster than the cylinder: friction brakes it (-)
    out = project([D - 1e-9], [10 * SLIDE], [0.0], f=0.3)
    assert out.status[0] == SLIP
    assert out.r_t[0] == pytest.approx(-0.3 * out.r_r[0], rel=1e-14)


def test_vectorised_mixed_statuses_and_coulomb_inequality():
    rng = np.random.default_rng(1)
    n = 500
    u_r = D + rng.normal(0, 1e-6, n)
    u_prev = rng.normal(0, 1e-6, n)
    u_t = u_prev + SLIDE + rng.normal(0, 1e-6, n)
    out = project(u_r, u_t, u_prev, f=0.5)
    assert set(np.unique(out.status)) == {SEPARATION, STICK, SLIP}
    assert np.all(out.r_r >= 0)
    assert np.all(np.abs(out.r_t) <= 0.5 * out.r_r * (1 + 1e-14))
    assert np.all(out.r_r[out.status == SEPARATION] == 0)
    # complementarity after correction: p * g = 0 (to round-off)
    g = u_r + KAPPA / 2.0 * out.r_r - D
    assert np.all(g >= -1e-18)
    assert np.max(np.abs(out.r_r * g)) < 1e-12 * out.r_r.max() * D
