"""Travelling waves of the reduced model: eqs. [3]-[7] (items 4-5)."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from stickslip.semianalytic.coefficients import coefficients, gamma_from_physical
from stickslip.semianalytic.junctions import CLOSURES, junction_residual
from stickslip.semianalytic.waves import (
    TravellingWave,
    angular_frequency_rad_s,
    celerity_m_s,
    check_admissible,
    frequency_hz,
    refine_wave,
    stick_slip_separation_waves,
    stick_slip_waves,
)

warnings.simplefilter("ignore", RuntimeWarning)  # expm overflow on rejected Newton trials


def _co(omega: float, nu: float = 0.3, xi: float = 1.25) -> object:
    return coefficients(nu, xi, gamma_from_physical(1000.0, 1.0, omega))


@pytest.fixture(scope="module")
def paper_stick_slip() -> TravellingWave:
    """The paper's stick-slip example: c0 = 1000 m/s, ξ = 1.25, f = 1, R = 1 m, Ω = 100."""
    waves = stick_slip_waves(_co(100.0), 1.0, 8, 0.005)
    # two branches for k = 8 with |c|√γ < 3: 1255.6 m/s (admissible) and 1118.5 m/s
    # (rejected: slip velocity changes sign, [5] 1 + cV' >= 0)
    assert len(waves) == 2 and waves[0].admissible and not waves[1].admissible
    assert waves[1].violated == "[5] 1 + cV' >= 0 in slip"
    return waves[0]


def test_stick_slip_example_k8_nu03(paper_stick_slip: TravellingWave) -> None:
    # Finding: k = 8, ν = 0.3 gives celerity 1255.6 m/s and |c|kΩ = 10045.0 rad/s, i.e.
    # the paper's "10045 Hz" is an angular frequency (1598.7 Hz). Tolerances: the paper
    # prints 4-5 significant digits (±0.5 m/s, ±0.5 rad/s).
    w = paper_stick_slip
    assert w.c < 0  # D < 0: against the rotation, like the exploding flutter mode
    assert abs(celerity_m_s(w.c, 1.0, 100.0)) == pytest.approx(1255.6, abs=0.5)
    assert angular_frequency_rad_s(w.c, 8, 100.0) == pytest.approx(10045.0, abs=0.5)
    assert frequency_hz(w.c, 8, 100.0) == pytest.approx(10045.0 / (2 * math.pi), rel=1e-4)
    assert w.admissible, w.violated


@pytest.mark.parametrize("k", [1, 2, 4, 6])
def test_other_k_do_not_give_10045(k: int) -> None:
    # No other mode reproduces both numbers: with 1255 m/s, "10045 Hz" would need
    # k = 10045·2π/1255 = 50.3 (not an integer); rad/s needs k = 8.00.
    for w in stick_slip_waves(_co(100.0), 1.0, k, 0.005):
        assert abs(angular_frequency_rad_s(w.c, k, 100.0) - 10045.0) > 100.0


def test_stick_slip_junctions_and_ode(paper_stick_slip: TravellingWave) -> None:
    # The 5 conditions that fix the wave: V, V' continuous at both ends of stick (periodic),
    # and |Q| = fP where stick ends. Checked on the evaluated fields (grid 20000 points,
    # one-sided differences O(h) → tolerances 1e-3 relative).
    w = paper_stick_slip
    ev = w.evaluate_s(20000)
    s, V, Vs, P, Q, z = ev["s"], ev["V"], ev["Vs"], ev["P"], ev["Q"], ev["zone"]
    co, f, cabs = w.coeffs, w.f, abs(w.c)
    j = np.flatnonzero(np.diff(z))[0] + 1  # stick -> slip in time
    vsc = np.ptp(V)
    assert abs(V[j] - V[j - 1]) < 1e-3 * vsc
    assert abs(Vs[j] - 1 / cabs) < 1e-3 / cabs and np.allclose(Vs[z == 1], 1 / cabs)
    assert Q[j - 1] == pytest.approx(f * P[j - 1], rel=1e-3)  # friction bound reached
    # periodic closure
    h = s[1] - s[0]
    assert abs(V[-1] + Vs[-1] * h - V[0]) < 1e-3 * vsc
    # slip ODE (c²−a)V'' + fD_s V' + hV = fgδ by central differences (O(h²) ~ 1e-6 relative)
    Ds = (-1.0 if w.c > 0 else 1.0) * co.D
    i = np.flatnonzero(z == 2)[5:-5]
    Vss = (V[i + 1] - 2 * V[i] + V[i - 1]) / h**2
    lhs = (w.c**2 - co.a) * Vss + f * Ds * Vs[i] + co.h * V[i]
    assert np.max(np.abs(lhs - f * co.g * w.delta)) < 1e-4 * f * co.g * w.delta + 1e-6 * np.max(
        np.abs(co.h * V)
    )


def test_stick_slip_celerity_and_frequency_independent_of_omega_amplitude_linear() -> None:
    # Claims of section 3: c̄ and frequency independent of Ω, amplitude ∝ Ω. In the model
    # c√γ and ψ depend only on (ν, ξ, f, k) and V − V_e ∝ 1/|c| ∝ Ω exactly, so the
    # tolerances are round-off level (1e-8).
    res = {}
    for om in (25.0, 50.0, 100.0):
        waves = stick_slip_waves(_co(om), 1.0, 8, 0.02)
        assert waves[0].admissible
        res[om] = waves[0]
    for om, w in res.items():
        assert celerity_m_s(w.c, 1, om) == pytest.approx(
            celerity_m_s(res[100.0].c, 1, 100.0), rel=1e-8
        )
        assert frequency_hz(w.c, 8, om) == pytest.approx(
            frequency_hz(res[100.0].c, 8, 100.0), rel=1e-8
        )
        assert w.v_amplitude == pytest.approx(res[100.0].v_amplitude * om / 100.0, rel=1e-8)
        assert w.amplitude == 0.0  # U ≡ δ in a stick-slip wave: max U − δ is 0


def test_stick_slip_amplitude_vs_f_and_delta(paper_stick_slip: TravellingWave) -> None:
    # Amplitude grows with f (follow the branch by continuation in f); it does NOT fall with δ:
    # V − V_e is exactly independent of δ (only admissibility depends on δ). Numbers recorded
    # in docs/semianalytic.md; tolerances: monotonic by > 1 % per step, δ-independence 1e-9.
    co = paper_stick_slip.coeffs
    amps = []
    w = paper_stick_slip
    for f in (1.0, 1.2, 1.5):
        w = refine_wave(w, co, f=f)
        assert w is not None
        amps.append(w.v_amplitude)
    assert amps[0] * 1.01 < amps[1] and amps[1] * 1.01 < amps[2]
    w_low = paper_stick_slip
    for f in (0.8, 0.5, 0.3):
        w_low = refine_wave(w_low, co, f=f)
        assert w_low is not None
    assert w_low.v_amplitude < 0.99 * amps[0]
    for d in (0.005, 0.01, 0.05):
        wd = refine_wave(paper_stick_slip, co, delta=d)
        assert wd is not None
        assert wd.v_amplitude == pytest.approx(paper_stick_slip.v_amplitude, rel=1e-9)
        assert wd.c == pytest.approx(paper_stick_slip.c, rel=1e-12)


def test_stick_slip_not_admissible_when_rotation_too_strong(
    paper_stick_slip: TravellingWave,
) -> None:
    # Same branch at δ = 0.001: the stick reaction leaves the Coulomb cone (Q < −fP at the
    # start of stick). Reported by name.
    w = refine_wave(paper_stick_slip, paper_stick_slip.coeffs, delta=0.001)
    assert w is not None and not w.admissible
    assert w.violated == "[6] |Q| < fP in stick"
    ok, viol, margins = check_admissible(w, 4000)
    assert not ok and viol == w.violated and margins[viol] < -0.1


@pytest.fixture(scope="module")
def figure1_candidates() -> dict[str, list[TravellingWave]]:
    co = _co(40.0)
    return {
        j: stick_slip_separation_waves(co, 0.7, 4, 0.001, junction=j) for j in ("impact", "smooth")
    }


def test_figure1_case_admits_stick_slip_only() -> None:
    # Finding: at the Figure-1 parameters the model admits a stick-slip wave, 1670.1 m/s
    # against the rotation (±0.5 m/s: printed digits); it is lost between Ω = 50 and 60 rad/s.
    co = _co(40.0)
    waves = [w for w in stick_slip_waves(co, 0.7, 4, 0.001) if w.admissible]
    assert len(waves) == 1
    assert celerity_m_s(waves[0].c, 1, 40.0) == pytest.approx(-1670.1, abs=0.5)
    assert refine_wave(waves[0], _co(50.0)).admissible
    w60 = refine_wave(waves[0], _co(60.0))
    assert not w60.admissible and w60.violated == "[6] |Q| < fP in stick"


def test_figure1_case_has_no_admissible_separation_wave(
    figure1_candidates: dict[str, list[TravellingWave]],
) -> None:
    # Finding (docs/semianalytic.md): at ν=0.3, ξ=1.25, f=0.7, k=4, δ=0.001, Ω=40 no
    # candidate of either closure satisfies all inequalities of [5]-[7]; each names the
    # inequality it violates. None is near the published ψ1=0.716, ψ2=0.784, 1084 m/s.
    total = 0
    for cands in figure1_candidates.values():
        for w in cands:
            total += 1
            assert not w.admissible
            assert w.violated is not None and w.violated[:3] in ("[5]", "[6]", "[7]", "imp")
            near = (
                abs(w.psi1 - 0.716) < 0.05
                and abs(w.psi2 - 0.784) < 0.05
                and abs(abs(celerity_m_s(w.c, 1, 40)) - 1084) < 30
            )
            assert not near
    assert total >= 1


@pytest.mark.parametrize("closure", list(CLOSURES))
@pytest.mark.parametrize("xi", [1.25, 1.30])
def test_published_point_is_not_a_root(closure: str, xi: float) -> None:
    # The published (c, ψ1, ψ2) does not satisfy any closure: normalised least-squares
    # residual ≥ 0.05 (a root gives < 1e-9). At ξ = 1.30, c = −√a (1084.03 m/s) makes the
    # tangential equation singular and the residual explodes.
    co = _co(40.0, xi=xi)
    r, _ = junction_residual(co, 0.7, 4, 0.001, -1084.0 / 40.0, 0.716, 0.784, closure)
    assert r > 0.05
    assert math.sqrt(_co(40.0, xi=1.30).a) * 40.0 == pytest.approx(1084.0, abs=0.1)


def test_separation_candidate_satisfies_its_junctions(
    figure1_candidates: dict[str, list[TravellingWave]],
) -> None:
    # A root of the 'impact' closure: P → 0 at lift-off, Q = fP where stick ends, U = δ at
    # landing, and the separation ODE holds (central differences, tolerance 1e-4 relative).
    w = figure1_candidates["impact"][0]
    co = w.coeffs
    assert abs(w.info["P_liftoff"]) < 1e-7 * co.g * w.delta
    assert abs(w.info["Q_minus_fP_stick_end"]) < 1e-7 * co.g * w.delta
    ev = w.evaluate_s(40000)
    z, U, V, s = ev["zone"], ev["U"], ev["V"], ev["s"]
    h = s[1] - s[0]
    j = np.flatnonzero(z == 0)[-1]  # last separation point before landing
    assert abs(U[j] - w.delta) < 1e-3 * (np.ptp(U) + w.delta)
    Ds = (-1.0 if w.c > 0 else 1.0) * co.D
    i = np.flatnonzero(z == 0)[5:-5]
    Uss = (U[i + 1] - 2 * U[i] + U[i - 1]) / h**2
    Vs = (V[i + 1] - V[i - 1]) / (2 * h)
    lhs = (w.c**2 - co.b) * Uss - Ds * Vs + co.g * U[i]
    assert np.max(np.abs(lhs)) < 1e-4 * co.g * (np.max(np.abs(U)))


def test_mirror_symmetry_flips_direction() -> None:
    # (D, c) → (−D, −c) with mirrored zone order is a symmetry: at ξ = 1.05 (D > 0) the
    # stick-slip waves travel in the rotation sense, at ξ = 1.25 (D < 0) against it.
    for xi, sign in ((1.05, 1.0), (1.25, -1.0)):
        waves = stick_slip_waves(_co(100.0, xi=xi), 1.0, 8, 0.05)
        assert any(w.admissible for w in waves)
        assert all(np.sign(w.c) == sign for w in waves)
