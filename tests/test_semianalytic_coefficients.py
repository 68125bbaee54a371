"""Coefficients of eq. [2], steady sliding (sections 2-3) and flutter (items 1-3)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from stickslip.semianalytic.coefficients import coefficients, gamma_from_physical, reaction_scale
from stickslip.semianalytic.flutter import dispersion_roots, flutter_modes, mode_physical
from stickslip.semianalytic.steady import closed_form_steady, radial_mode, reduced_steady


def test_hand_computed_values_nu03_xi125() -> None:
    # Hand computation (ln 1.25 = 0.2231435513, ξ² = 1.5625, 2ξ²lnξ/(ξ²−1) = 1.2396864):
    # A = 1.28125 − 1.2396864 = 0.0415636, B = 0.9684974 − 0.921875 = 0.0466300,
    # C1 = 0.2396864, C2 = 0.8853136, ã = 0.7/(1.3·0.4) = 1.3461538, b̃ = 1/2.6.
    # Tolerance 1e-6 relative: the hand values carry 7 significant digits.
    c = coefficients(0.3, 1.25, 1.0)
    hand = {
        "A": 0.0415636,
        "B": 0.0466300,
        "C1": 0.2396864,
        "C2": 0.8853136,
        "a_tilde": 1.3461538,
        "b_tilde": 0.3846154,
    }
    for key, val in hand.items():
        assert getattr(c, key) == pytest.approx(val, rel=2e-6), key
    # a = ãA/B, b = b̃A/B, g = (2ã + 2(ξ²−1)b̃)/B, h = 2ξ²b̃/B, D = (aC1 − bC2)/A at γ = 1
    assert c.a == pytest.approx(1.3461538 * 0.0415636 / 0.0466300, rel=1e-5)
    assert c.b == pytest.approx(0.3846154 * 0.0415636 / 0.0466300, rel=1e-5)
    assert c.g == pytest.approx((2 * 1.3461538 + 2 * 0.5625 * 0.3846154) / 0.0466300, rel=1e-5)
    assert c.h == pytest.approx(2 * 1.5625 * 0.3846154 / 0.0466300, rel=1e-5)
    assert c.D == pytest.approx(-0.382811, rel=1e-4)


def test_coefficients_scale_as_one_over_gamma() -> None:
    # every coefficient of [2] carries 1/(γB): exact up to rounding
    c1, c2 = coefficients(0.3, 1.25, 1.0), coefficients(0.3, 1.25, 0.0016)
    for key in ("a", "b", "g", "h", "D"):
        assert getattr(c2, key) * 0.0016 == pytest.approx(getattr(c1, key), rel=1e-12)


@pytest.mark.parametrize(
    ("nu", "xi", "sign"),
    [
        (0.3, 1.05, 1),
        (0.3, 1.25, -1),
        (0.3, 2.0, -1),
        (0.45, 1.25, 1),
        (0.0, 1.05, -1),
        (0.4, 2.0, -1),
        (0.4, 1.5, 1),
    ],
)
def test_sign_change_of_D(nu: float, xi: float, sign: int) -> None:
    # D changes sign with ν and ξ (paper section 3); values computed from the closed form,
    # the smallest |D| in this table is 0.023 (ν=0.4, ξ=2), far from rounding.
    assert np.sign(coefficients(nu, xi, 1.0).D) == sign


def test_mode_integrals_and_positivity() -> None:
    # ∫X² r dr = B/(ξ²−1) (mass) and ∫X²/r dr = A/(ξ²−1) (hoop/shear stiffness): quad to 1e-10
    for xi in (1.1, 1.25, 2.0):
        c = coefficients(0.25, xi, 1.0)
        m, _ = quad(lambda r, xi=xi: radial_mode(r, xi) ** 2 * r, 1.0, xi)
        s, _ = quad(lambda r, xi=xi: radial_mode(r, xi) ** 2 / r, 1.0, xi)
        assert m == pytest.approx(c.B / (xi**2 - 1), rel=1e-9)
        assert s == pytest.approx(c.A / (xi**2 - 1), rel=1e-9)
        assert min(c.A, c.B, c.C1, c.C2) > 0


def test_gamma_from_physical() -> None:
    assert gamma_from_physical(1000.0, 1.0, 40.0) == pytest.approx(0.0016, rel=1e-14)
    with pytest.raises(ValueError, match="wave_speed"):
        gamma_from_physical(0.0, 1.0, 40.0)
    with pytest.raises(ValueError, match="nu"):
        coefficients(0.5, 1.25, 1.0)
    with pytest.raises(ValueError, match="xi"):
        coefficients(0.3, 1.0, 1.0)


def test_closed_form_steady_solves_lame_and_torsion() -> None:
    # u_e, v_e must satisfy plane-strain equilibrium and the tractions p_e, q_e at r = 1;
    # checked with 4th-order finite differences (h = 1e-3: error ~1e-11 relative)
    nu, xi, delta, f = 0.3, 1.25, 1e-3, 0.7
    lam = nu / ((1 + nu) * (1 - 2 * nu))
    mu = 1 / (2 * (1 + nu))
    hh = 1e-3

    def d(fun, r):  # noqa: ANN001, ANN202
        return (fun(r - 2 * hh) - 8 * fun(r - hh) + 8 * fun(r + hh) - fun(r + 2 * hh)) / (12 * hh)

    def u(r):  # noqa: ANN001, ANN202
        return closed_form_steady(r, delta=delta, f=f, nu=nu, xi=xi)[0]

    def v(r):  # noqa: ANN001, ANN202
        return closed_form_steady(r, delta=delta, f=f, nu=nu, xi=xi)[1]

    _, _, p_e, q_e = closed_form_steady(1.0, delta=delta, f=f, nu=nu, xi=xi)
    srr = lambda r: (lam + 2 * mu) * d(u, r) + lam * u(r) / r  # noqa: E731
    stt = lambda r: lam * d(u, r) + (lam + 2 * mu) * u(r) / r  # noqa: E731
    srt = lambda r: mu * (d(v, r) - v(r) / r)  # noqa: E731
    assert -srr(1.0) == pytest.approx(p_e, rel=1e-8)
    assert -srt(1.0) == pytest.approx(q_e, rel=1e-8)
    for r in (1.05, 1.1, 1.2):
        assert d(srr, r) + (srr(r) - stt(r)) / r == pytest.approx(0.0, abs=1e-8 * p_e)
        assert d(lambda s: s * s * srt(s), r) == pytest.approx(0.0, abs=1e-8 * q_e)
    assert float(u(xi)) == pytest.approx(0.0, abs=1e-15)
    assert float(v(xi)) == pytest.approx(0.0, abs=1e-15)
    # the lead's form v = q(1+ν)/ξ² (ξ²/r − r) is the same function: printed v_e has no typo
    r = np.linspace(1, xi, 7)
    np.testing.assert_allclose(v(r), q_e * (1 + nu) / xi**2 * (xi**2 / r - r), rtol=1e-13)


def test_reduced_steady_matches_fe_steady() -> None:
    # U_e = u_e(1), V_e = v_e(1) and P = p·(ξ²−1)/(γB) (reaction scaling): exact identities
    nu, xi, delta, f = 0.3, 1.25, 1e-3, 0.7
    co = coefficients(nu, xi, 0.0016)
    U_e, V_e, P_e, Q_e = reduced_steady(co, delta, f)
    u_e, v_e, p_e, q_e = closed_form_steady(1.0, delta=delta, f=f, nu=nu, xi=xi)
    assert U_e == pytest.approx(float(u_e), rel=1e-13)
    assert V_e == pytest.approx(float(v_e), rel=1e-13)
    assert P_e == pytest.approx(p_e * reaction_scale(co), rel=1e-13)
    assert Q_e / P_e == pytest.approx(f, rel=1e-14)


@pytest.mark.parametrize(("xi", "expected"), [(1.25, "opposite"), (1.05, "rotation")])
def test_flutter_direction_follows_sign_of_D(xi: float, expected: str) -> None:
    # Paper: D < 0 → exploding wave opposite to the rotation, D > 0 → in its sense.
    co = coefficients(0.3, xi, gamma_from_physical(1000.0, 1.0, 40.0))
    assert (co.D > 0) == (expected == "rotation")
    modes = flutter_modes(co, 0.7, kmax=8)
    for m in modes:
        assert m.growth_rate > 0
        assert m.direction == expected
        assert np.sign(m.phase_speed) == np.sign(co.D)
        assert np.sign(m.damped_phase_speed) == -np.sign(co.D)
        w = complex(m.omega_r, m.growth_rate)
        # dispersion relation ω² = ak² + h + ifDk to round-off (1e-12 relative)
        rhs = complex(co.a * m.k**2 + co.h, 0.7 * co.D * m.k)
        assert abs(w * w - rhs) < 1e-12 * abs(rhs)


def test_flutter_growth_vanishes_without_friction_and_units() -> None:
    co = coefficients(0.3, 1.25, gamma_from_physical(1000.0, 1.0, 40.0))
    grow, _ = dispersion_roots(co, 0.0, 3)
    assert abs(grow.imag) < 1e-12 * abs(grow)
    m = flutter_modes(co, 0.7, kmax=4)[3]
    phys = mode_physical(m, 1.0, 40.0)
    assert phys["growth_rate_per_s"] == pytest.approx(m.growth_rate * 40.0)
    assert phys["frequency_hz"] == pytest.approx(abs(m.omega_r) * 40.0 / (2 * math.pi))
    assert phys["phase_speed_m_s"] == pytest.approx(m.omega_r / 4 * 40.0)
    # weak friction: ω_r ≈ √(ak²+h) = physical speed ~ √a RΩ for large k (1% at k = 4)
    assert abs(phys["phase_speed_m_s"]) == pytest.approx(
        math.sqrt(co.a * 16 + co.h) / 4 * 40.0, rel=0.01
    )
