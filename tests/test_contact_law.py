"""The nodal contact/friction projection on its own (solver.contact), no dolfinx needed."""

import numpy as np
import pytest

from stickslip.solver.contact import SEPARATION, SLIP, STICK, ContactArrays, project_contact

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


def test_the_bound_is_two_typed_parts_and_the_kernels_read_their_constants():
    """The friction bound of ``ContactLaw`` is a ``SpatialFilter`` and a ``Regularisation``;
    ``variant`` composes the same names as the scene keys, and ``kernel_bound`` gives the
    kernels' constants of each regularisation (exact: the same float operations as the
    numpy ``EffectivePressure``), refusing the filtered bound."""
    from stickslip.solver.contact import ContactLaw, SpatialFilter
    from stickslip.solver.contact.law import ConstantTime, PrakashClifton, regularisation_of

    dt = 1e-6
    pc = regularisation_of("prakash-clifton", slip_length=2e-5, reference_velocity=0.5,
                           relaxation_time=9.0)
    ct = regularisation_of("constant-time", slip_length=9.0, relaxation_time=4e-4)
    assert pc == PrakashClifton(slip_length=2e-5, reference_velocity=0.5)
    assert ct == ConstantTime(relaxation_time=4e-4)
    law = ContactLaw(d=1e-5, f=0.3, surface_speed=1.0, dt=dt, beta2=0.5)
    assert law.variant == "nodal" and law.kernel_bound() == (0, 0.0, 0.0)
    assert ContactLaw(1e-5, 0.3, 1.0, dt, 0.5, regularisation=pc).kernel_bound() == (
        1, 1.0 / (dt * 2e-5), 0.5 / 2e-5)
    assert ContactLaw(1e-5, 0.3, 1.0, dt, 0.5, regularisation=ct).kernel_bound() == (
        2, 0.0, 1.0 / 4e-4)
    filtered = ContactLaw(1e-5, 0.3, 1.0, dt, 0.5, SpatialFilter.ONE_TWO_ONE, pc)
    assert filtered.variant == "1-2-1+prakash-clifton"
    assert ContactLaw(1e-5, 0.3, 1.0, dt, 0.5, SpatialFilter.ONE_TWO_ONE).variant == "1-2-1"
    with pytest.raises(ValueError, match="1-2-1"):
        filtered.kernel_bound()
    with pytest.raises(ValueError, match="regularization"):
        regularisation_of("rate-and-state")


def test_a_registered_scheme_is_found_by_for_scene():
    """``add_scheme`` puts a scheme object in ``SCHEMES``; ``for_scene`` asks each in turn
    and returns the first that applies; no scheme for a scene is a ValueError."""
    from types import SimpleNamespace

    from stickslip.solver.schemes.select import SCHEMES, add_scheme, for_scene

    def scene(beta1):
        return SimpleNamespace(time=SimpleNamespace(beta1=beta1))

    assert for_scene(scene(0.0)).name == "explicit"
    assert for_scene(scene(0.25)).name == "implicit"
    with pytest.raises(ValueError, match="beta1"):
        for_scene(scene(-1.0))

    @add_scheme("test-negative")
    class Negative:
        def applies_to(self, sc) -> bool:
            return sc.time.beta1 < 0.0

    try:
        assert isinstance(for_scene(scene(-1.0)), Negative)
    finally:
        SCHEMES.pop("test-negative")
