"""Complex eigenvalue analysis of FE steady sliding (``studies/flutter_fe``).

Checks: the SLEPc band slicing finds every eigenvalue; f = 0 reproduces the clamped/sliding
annulus' Bessel frequencies; growth rates converge with the mesh; a seeded transient of the
explicit solver grows exactly as CEA predicts (through the Newmark map, and at small dt as
the continuous CEA); the unperturbed steady state's round-off growth (~700 /s on
scenes/smoke.toml) is CEA's most unstable mode damped by beta2 = 0.6; the reduced model is a
Ritz upper bound at f = 0; MPI gives the same eigenvalues; Kelvin-Voigt damping (against the
dense quadratic eigenproblem, the exact damped continuum and the damped transient); the CLI
(table, mode shapes, refusal of a regularised friction law).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import jv, yv

from stickslip.studies.flutter_fe import (
    annulus_sliding_frequencies,
    matrix_pencil,
    newmark_exponents,
)

E, NU, RHO, R, XI = 1.0e9, 0.3, 1000.0, 1.0, 1.25  # the paper's tube (scenes/figure3_*)


# ------------------------------------------------------------------------- pure numerics


def test_matrix_pencil_recovers_exponents_and_amplitudes():
    dt = 2e-5
    s_true = np.array([1200 + 2j * np.pi * 1800, 950 - 2j * np.pi * 2400, -40 + 2j * np.pi * 900])
    c_true = np.array([1e-9, 3e-9j, 5e-10])
    t = dt * np.arange(400)
    y = (c_true[None, :] * np.exp(np.outer(t, s_true))).sum(axis=1)
    s, c = matrix_pencil(dt, y)
    assert s.size == 3
    for st, ct in zip(s_true, c_true, strict=True):
        i = np.argmin(np.abs(s - st))
        # noise-free data: exact to round-off amplified by the Hankel conditioning
        assert abs(s[i] - st) < 1e-6 * abs(st)
        assert abs(c[i] - ct) < 1e-6 * abs(ct)


def test_newmark_exponents_limits():
    mu = np.array([(2 * np.pi * 1500) ** 2 * (1 + 0.1j)])
    lam = np.sqrt(-mu.astype(complex))
    lam = np.where(lam.real < 0, -lam, lam)
    lam = np.where(lam.imag < 0, np.conj(lam), lam)
    # dt -> 0: the continuous exponent, error O(dt^2)
    e1 = abs(newmark_exponents(mu, 1e-6, 0.5)[0] - lam[0])
    e2 = abs(newmark_exponents(mu, 5e-7, 0.5)[0] - lam[0])
    assert e1 < 1e-3 * abs(lam[0]) and 3.5 < e1 / e2 < 4.5
    # central differences conserve a real mode (|z| = 1), beta2 > 1/2 damps it
    w2 = np.array([(2 * np.pi * 2000) ** 2 + 0j])
    assert abs(newmark_exponents(w2, 2e-5, 0.5)[0].real) < 1e-9
    assert newmark_exponents(w2, 2e-5, 0.6)[0].real < -100.0


def test_bessel_reference_contains_the_k0_closed_forms():
    """k = 0 decouples: radial J1(aA)Y1(aB) = J1(aB)Y1(aA) (u_r = 0 on both circles) and
    torsional J2(bA)Y1(bB) = J1(bB)Y2(bA) (sigma_rt = 0 at R, u_t = 0 at xi R): both root
    sets are derived by hand, independently of the 4x4 determinant."""
    lam, mu = E * NU / ((1 + NU) * (1 - 2 * NU)), E / (2 * (1 + NU))
    cp, cs = math.sqrt((lam + 2 * mu) / RHO), math.sqrt(mu / RHO)
    a, b = R, XI * R

    def radial(w):
        x = w / cp
        return jv(1, x * a) * yv(1, x * b) - jv(1, x * b) * yv(1, x * a)

    def torsion(w):
        x = w / cs
        return jv(2, x * a) * yv(1, x * b) - jv(1, x * b) * yv(2, x * a)

    fmax = 6000.0
    grid = 2 * np.pi * np.arange(1.0, fmax, 1.0)
    roots = []
    for fn in (radial, torsion):
        v = fn(grid)
        for i in np.flatnonzero(np.sign(v[:-1]) != np.sign(v[1:])):
            roots.append(brentq(fn, grid[i], grid[i + 1], xtol=1e-12) / (2 * np.pi))
    expected = np.sort(roots)
    got = annulus_sliding_frequencies(0, R, XI, E, NU, RHO, fmax, df_hz=2.0)
    assert got.size == expected.size >= 3
    np.testing.assert_allclose(got, expected, rtol=1e-9)


# ------------------------------------------------------------------------- FE (dolfinx)


def _fe():
    pytest.importorskip("dolfinx")
    from mpi4py import MPI

    from stickslip.solver.problem import build_problem
    from stickslip.solver.scene import load_scene

    return MPI, build_problem, load_scene


def _problem(name: str, *overrides: str, comm=None):
    MPI, build_problem, load_scene = _fe()
    scene = load_scene(name, ["output.progress=false", *overrides])
    return build_problem(scene, comm or MPI.COMM_SELF)


def _branches(res, k: int):
    """Distinct modes of wavenumber |k| (one per ±k pair), by frequency."""
    from stickslip.studies.flutter_fe.cea import distinct_modes

    return distinct_modes(m for m in res.modes if m.wavenumber == k)


def test_band_slicing_finds_every_eigenvalue_of_the_dense_problem():
    """SLEPc slices (nev = 24 per slice, to force several slices) vs LAPACK on the dense pencil,
    the whole spectrum of scenes/smoke.toml (108 free dofs, all below 10 kHz)."""
    _fe()
    import scipy.linalg as sl
    from scipy.sparse import csr_matrix

    from stickslip.studies.flutter_fe import band_eigenvalues, build_operators

    pb = _problem("smoke")
    ops = build_operators(pb)
    A, B = ops.operator(0.7), ops.B

    def dense(M):
        ai, aj, av = M.getValuesCSR()
        return csr_matrix((av, aj, ai), shape=M.getSize()).toarray()

    mu_max = (2 * np.pi * 10_000.0) ** 2
    mu, _, stats = band_eigenvalues(A, B, mu_max, nev_slice=24)
    ref = sl.eigvals(dense(A), dense(B))
    ref = ref[ref.real <= mu_max]
    assert stats.slices >= 4 and mu.size == ref.size == ops.n_free == 108
    d = np.abs(np.sort_complex(mu)[:, None] - ref[None, :]).min(axis=1)
    assert np.max(d / np.abs(np.sort_complex(mu))) < 1e-9  # SLEPc tol 1e-10
    ops.destroy()


def test_f0_gives_real_double_frequencies_matching_the_bessel_reference():
    """At f = 0 the problem is symmetric: real frequencies, ±k doubly degenerate, and the
    lowest three per k = 0..8 converge to the annulus with u_r = 0, sigma_rt = 0 at R and
    clamped at xi R (Bessel determinant, 1e-9 accurate).

    Measured worst relative errors over k (lumped mass, N = 72 / 132): first branch 0.88 % /
    0.43 % (lumped-mass and stiffness errors of opposite signs: it changes sign with k),
    second 9.7 % / 3.6 %, third 6.6 % / 2.4 %. Tolerances at N = 132: 0.5 %, 4 %, 3 %; and
    for the second and third branches the error of EVERY k must fall with an observed order
    > 1.4 from N = 72 to 132 (P1: 2 expected)."""
    from stickslip.studies.flutter_fe import complex_eigenvalue_analysis

    errors = {}
    for n in (72, 132):
        res = complex_eigenvalue_analysis(_problem("figure3_n36", f"mesh.n_inner={n}"), 0.0,
                                          3000.0)
        assert all(m.growth_rate < 1e-6 * 2 * np.pi * m.frequency_hz for m in res.modes)
        assert all(m.omega2_imag <= 1e-9 * m.omega2_real for m in res.modes)
        err = np.zeros((9, 3))
        for k in range(9):
            fe = np.array(sorted(m.frequency_hz for m in res.modes if m.wavenumber == k))
            if k > 0:  # every frequency twice (cos/sin = the +k and -k travelling waves)
                np.testing.assert_allclose(fe[0::2], fe[1::2], rtol=1e-8)
                fe = fe[0::2]
            ref = annulus_sliding_frequencies(k, R, XI, E, NU, RHO, 3000.0, df_hz=5.0)
            assert fe.size >= 3 and ref.size >= 3
            err[k] = np.abs(fe[:3] - ref[:3]) / ref[:3]
        errors[n] = err
    assert np.all(errors[132].max(axis=0) < [0.005, 0.04, 0.03]), errors
    assert errors[72][:, 0].max() < 0.01
    order = np.log(errors[72][:, 1:] / errors[132][:, 1:]) / np.log(132 / 72)
    assert np.all(order > 1.4), order


def test_growth_rates_converge_with_the_mesh():
    """The flutter branches of k = 2, 4, 7 that travel against the rotation near 1.5-1.9
    kHz (second radial family): growth rate and frequency converge as N = 72, 132, 264.

    Measured growth (1/s), N = 36 / 72 / 132 / 264: k = 2: 411, 549, 658, 712; k = 4: 765,
    928, 1031, 1074; k = 7: 1042, 1136, 1150, 1149 (frequencies: k = 4: 1636, 1762, 1820,
    1845 Hz). The successive changes must shrink (|last| < 0.6 |previous|, observed 0.07-0.5
    while h halves, then shrinks by 1.83) and the last one stay below 10 % (growth) and 3 %
    (frequency) of the value: first-order-like convergence of the nodal contact."""
    from stickslip.studies.flutter_fe import complex_eigenvalue_analysis

    results = [complex_eigenvalue_analysis(_problem("figure3_n36", f"mesh.n_inner={n}"), 0.7,
                                           2000.0) for n in (72, 132, 264)]
    for k in (2, 4, 7):
        picks = [max((m for m in r.modes if m.wavenumber == k and m.direction == "opposite"
                      and m.frequency_hz > 1400.0), key=lambda m: m.growth_rate)
                 for r in results]
        g = np.array([m.growth_rate for m in picks])
        f = np.array([m.frequency_hz for m in picks])
        # (or already converged to 0.5 %: k = 7 moves 1898.3, 1898.7, 1893.3 Hz)
        assert abs(g[2] - g[1]) < max(0.6 * abs(g[1] - g[0]), 0.005 * g[2]), (k, g)
        assert abs(f[2] - f[1]) < max(0.6 * abs(f[1] - f[0]), 0.005 * f[2]), (k, f)
        assert abs(g[2] - g[1]) < 0.10 * g[2] and abs(f[2] - f[1]) < 0.03 * f[2], (k, g, f)


def test_seeded_transient_grows_as_cea_predicts():
    """figure3_n132 (the paper's mesh), beta2 = 1/2, mode k = 4 seeded at 1e-6 d, linear
    phase 1-8 ms (every node slipping; U_4 grows from ~4e-11 to ~1e-6 m).

    The explicit solver in sliding is Newmark on M u'' + (K + K_f) u = 0 (the radial
    constraint is exact), so the matrix-pencil exponents of U_4(t) ARE the CEA eigenvalues
    mapped by ``newmark_exponents`` (measured agreement < 1e-5; tolerance 1e-3 for the
    fit). At dt = 0.3 dt_crit the map moves the growth by < 0.3 %, so the transient then
    matches the continuous CEA growth rate of k = 4 (1192 /s, 2395 Hz, travelling with the
    rotation): tolerance 1 %. The raw slope of log|U_4| includes the second k = 4 branch
    (1031 /s, against the rotation, amplitude ratio ~0.3 at 8 ms): tolerance 5 %."""
    MPI, _, load_scene = _fe()
    from stickslip.studies.flutter_fe import complex_eigenvalue_analysis, measure_transient_growth

    scene = load_scene("figure3_n132")
    res = complex_eigenvalue_analysis(_problem("figure3_n132"), None, 3000.0)
    k4 = sorted(_branches(res, 4), key=lambda m: -m.growth_rate)
    top = k4[0]
    assert top.direction == "rotation" and top.growth_rate > 1000.0
    for fraction, tol_map in ((0.9, 1e-3), (0.3, 1e-3)):
        sc = scene.with_overrides(f"time.dt_fraction={fraction}")
        g = measure_transient_growth(sc, 4, MPI.COMM_SELF, window=(1e-3, 8e-3))
        assert g.all_slip and g.amplitude_range_m[1] < 1e-5
        for m, (growth, freq, _) in zip(k4[:2], g.exponents[:2], strict=True):
            s = newmark_exponents(np.array([m.omega2_real + 1j * m.omega2_imag]), g.dt_s, 0.5)[0]
            sign = -1.0 if m.direction == "rotation" else 1.0  # U_k of a +theta wave: e^{-iwt}
            assert growth == pytest.approx(s.real, rel=tol_map)
            assert freq == pytest.approx(sign * s.imag / (2 * np.pi), rel=tol_map)
        if fraction == 0.3:
            assert g.exponents[0][0] == pytest.approx(top.growth_rate, rel=0.01)
            assert -g.exponents[0][1] == pytest.approx(top.frequency_hz, rel=0.01)
            assert g.growth_rate == pytest.approx(top.growth_rate, rel=0.05)


def test_roundoff_growth_of_unperturbed_sliding_is_the_damped_cea_maximum():
    """scenes/smoke.toml, no perturbation, beta2 = 0.6: round-off grows at ~700 /s
    (steps 300-600, before saturation). CEA's most unstable mode (k = 7, 1819 Hz) grows at
    1042 /s; mapped through explicit Newmark with beta2 = 0.6 at the scene's dt
    (w dt ~ 0.9) the two largest discrete growth rates are 715.6 and 682.7 /s. Round-off
    seeds both with arbitrary weights (which one leads depends on the summation order of the
    vector updates: measured 707 /s with one arithmetic, 684 /s with another), and they
    separate only by e^{33 t}, so the measured rate must lie between them (1 % slack)."""
    MPI, _, load_scene = _fe()
    from stickslip.solver.run import Simulation
    from stickslip.studies.flutter_fe import complex_eigenvalue_analysis

    sim = Simulation(load_scene("smoke", ['initial.perturbation="none"',
                                          "output.progress=false"]), MPI.COMM_SELF)
    res = complex_eigenvalue_analysis(sim.problem, None, 20_000.0)
    mu = np.array([m.omega2_real + 1j * m.omega2_imag for m in res.modes])
    s = newmark_exponents(mu, sim.dt, 0.6)
    assert res.unstable()[0].growth_rate == pytest.approx(1041.7, rel=1e-3)
    rates = np.unique(np.round(s.real, 1))[::-1]
    first, second = rates[0], rates[1]
    assert first == pytest.approx(715.6, abs=0.2) and second == pytest.approx(682.7, abs=0.2)
    u0 = sim.integrator.u.copy()
    dev = np.zeros(600)
    for i in range(600):
        sim.integrator.step()
        dev[i] = np.max(np.abs(sim.integrator.u - u0))
    t = sim.dt * np.arange(1, 601)
    rate = np.polyfit(t[300:], np.log(dev[300:]), 1)[0]
    assert 0.99 * second <= rate <= 1.01 * first
    assert rate < 0.75 * res.unstable()[0].growth_rate  # the beta2 damping is what hides it


def test_reduced_model_is_a_ritz_upper_bound_and_underestimates_the_growth():
    """Eq. [2] restricts the sliding motion to v = V(theta) X(r), u = 0: a Rayleigh-Ritz
    subspace of the same continuum, so at f = 0 its frequency sqrt(a k^2 + h) is an upper
    bound of the exact lowest one (Bessel reference): measured 12.7-14.2 % above, k = 1..8.
    At f = 0.7 the reduced model's growth rates (26-106 /s for k = 1..8) are far below the FE
    ones of the same k (> 350 /s): the single radial shape X(r) with u = delta removes the
    radial motion of the tube interior, which is what friction couples to."""
    _fe()
    from stickslip.studies.flutter_fe import complex_eigenvalue_analysis, reduced_model_flutter

    scene0 = _problem("figure3_n132").scene
    red0 = reduced_model_flutter(scene0.with_overrides("loading.f=0.0"), 8)
    for r in red0:
        exact = annulus_sliding_frequencies(r["k"], R, XI, E, NU, RHO, 2000.0, df_hz=5.0)[0]
        assert 1.0 < r["frequency_hz"] / exact < 1.2, (r, exact)
    res = complex_eigenvalue_analysis(_problem("figure3_n132"), 0.7, 2600.0)
    best = res.by_wavenumber()
    for r in reduced_model_flutter(scene0, 8):
        assert r["direction"] == "opposite" and 0 < r["growth_rate_per_s"] < 120.0
        assert best[r["k"]].growth_rate > 3.0 * r["growth_rate_per_s"]


@pytest.mark.parallel
def test_eigenvalues_are_the_same_on_one_and_all_ranks():
    """N = 72, f = 0.7, up to 2.5 kHz: same modes, growth rates and wavenumbers on
    COMM_SELF and COMM_WORLD (MUMPS/Krylov in another order: agreement to 1e-8)."""
    MPI, _, _ = _fe()
    from stickslip.studies.flutter_fe import complex_eigenvalue_analysis

    out = {}
    for name, comm in (("self", MPI.COMM_SELF), ("world", MPI.COMM_WORLD)):
        pb = _problem("figure3_n36", "mesh.n_inner=72", comm=comm)
        out[name] = complex_eigenvalue_analysis(pb, None, 2500.0)
    a, b = out["self"].modes, out["world"].modes
    assert len(a) == len(b) > 50
    for ma, mb in zip(a, b, strict=True):
        assert mb.frequency_hz == pytest.approx(ma.frequency_hz, rel=1e-8)
        assert mb.growth_rate == pytest.approx(ma.growth_rate, rel=1e-6, abs=1e-6)
        assert (mb.k, mb.direction) == (ma.k, ma.direction)


def test_cli_json_table_and_bad_input(capsys, tmp_path):
    _fe()
    from stickslip.cli.main import main

    assert main(["flutter-fe", "smoke", "--json", "--fmax-hz", "5000"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["free_dofs"] == 108 and out["unstable_count"] > 40
    top = out["unstable"][0]
    assert top["wavenumber"] == 7 and top["direction"] == "opposite"
    assert top["growth_rate"] == pytest.approx(1041.7, rel=1e-3)
    assert len(out["reduced_model"]) == 12
    png = tmp_path / "cea.png"
    assert main(["flutter-fe", "smoke", "--set", "loading.f=0.5", "--fmax-hz", "2500",
                 "--f-sweep", "0,0.5", "--plot", str(png)]) == 0
    text = capsys.readouterr().out
    assert "f = 0.5" in text and png.stat().st_size > 10_000
    assert main(["flutter-fe", "smoke", "--fmax-hz", "-1"]) == 2
    assert "--fmax-hz" in capsys.readouterr().err
    assert main(["flutter-fe", "smoke", "--f-sweep", "0:x"]) == 2


# ------------------------------------------------------------------------- Kelvin–Voigt damping

TAU_FIG = 0.02 / (2 * math.pi * 1600.0)  # scenes/*_damped: loss factor 2 % at 1.6 kHz, 1.99 µs


def test_damped_exponents_solve_the_dense_quadratic_eigenproblem():
    """The reduction λ² + τμλ + μ = 0 (studies.flutter_fe.cea) against the quadratic
    eigenproblem λ²M + λτA + A = 0 itself, solved densely by companion linearisation
    (LAPACK), on scenes/smoke.toml (108 free dofs) with τ = 1e-5 s (ζ up to 0.9 in the
    band, far from the small-τ regime). Each CEA mode's λ must be an eigenvalue of the dense
    problem to 1e-8 relative (round-off of two dense 216² solves; measured < 1e-10)."""
    _fe()
    import scipy.linalg as sl
    from scipy.sparse import csr_matrix

    from stickslip.studies.flutter_fe import build_operators, complex_eigenvalue_analysis

    tau = 1e-5
    pb = _problem("smoke")
    ops = build_operators(pb)

    def dense(m):
        return csr_matrix(m.getValuesCSR()[::-1], shape=m.getSize()).toarray()

    A, M = dense(ops.operator(0.7)), dense(ops.mass(0.7))
    n = A.shape[0]
    w0 = math.sqrt(np.max(np.abs(A)) / np.max(M))  # λ = w0 s: an O(1) companion pencil
    a_s = A / (w0 * w0 * np.max(M))
    Z, eye = np.zeros((n, n)), np.eye(n)
    lam = w0 * sl.eigvals(np.block([[Z, eye], [-a_s, -tau * w0 * a_s]]),
                          np.block([[eye, Z], [Z, M / np.max(M)]]))
    res = complex_eigenvalue_analysis(pb, 0.7, 20_000.0, ops=ops, tau=tau)
    ops.destroy()
    assert len(res.modes) > 50
    for m in res.modes:
        got = m.growth_rate + 2j * math.pi * m.frequency_hz
        err = np.min(np.abs(np.concatenate([lam, np.conj(lam)]) - got)) / abs(got)
        assert err < 1e-8, (m, err)
        assert m.zeta == pytest.approx(-m.growth_rate / abs(got), rel=1e-12)


def test_damping_lowers_the_growth_by_tau_omega2_over_2_as_in_the_continuum():
    """scenes/figure1_n132_damped (τ = 1.99 µs), its lowest k = 8 branch (against the
    rotation): 1414.4 Hz, growth 324.4 /s undamped (the scene with τ = 0) and 245.9 /s damped.

    * The damped growth is the undamped one less τ Re μ / 2 (first order in τω = 0.018:
      second-order terms are < 0.02 %, tolerance 0.2 %): 78.5 /s.
    * The exact continuum with the same damping (``exact.sliding_flutter``, the N → ∞ limit
      of both the undamped and the damped CEA) lowers its growth by 79.8 /s. The shift is
      ∝ Re μ ≈ ω², so its mesh error is twice the frequency's (0.82 % at N = 132):
      measured 1.6 %, tolerance 3 × the frequency error.
    * The damped growth converges to the exact damped growth at O(h²), like the undamped
      one: error 28.0 /s at N = 132, 6.9 /s at N = 264 (observed order 2.02; band 1.7-2.3),
      < 3 % at N = 264.
    """
    _fe()
    from stickslip.exact.annulus import Elastic
    from stickslip.exact.sliding_flutter import Dissipation, sliding_branches
    from stickslip.studies.flutter_fe import complex_eigenvalue_analysis

    mat = Elastic(E=E, rho=RHO, nu=NU, R=R, xi=XI)

    def exact(tau):
        br = sliding_branches(8, 0.7, mat, fmax_hz=1600.0, diss=Dissipation(tau=tau)).branches
        return min((b for b in br if b.growth_rate > 0), key=lambda b: b.frequency_hz)

    ex0, ex1 = exact(0.0), exact(TAU_FIG)
    assert ex1.direction == ex0.direction == "opposite"
    errors = []
    for n in (132, 264):
        pb = _problem("figure1_n132_damped", f"mesh.n_inner={n}")
        assert pb.scene.damping.tau == pytest.approx(TAU_FIG, rel=1e-12)
        undamped = _branches(complex_eigenvalue_analysis(pb, None, 1600.0, tau=0.0), 8)[0]
        damped = _branches(complex_eigenvalue_analysis(pb, None, 1600.0), 8)[0]
        assert damped.direction == undamped.direction == "opposite"
        shift = damped.growth_rate - undamped.growth_rate
        assert shift == pytest.approx(-0.5 * TAU_FIG * undamped.omega2_real, rel=2e-3)
        f_err = abs(undamped.frequency_hz / ex0.frequency_hz - 1.0)
        exact_shift = ex1.growth_rate - ex0.growth_rate
        assert abs(shift / exact_shift - 1.0) < 3.0 * f_err, (n, shift, exact_shift, f_err)
        if n == 132:
            assert undamped.frequency_hz == pytest.approx(1414.4, abs=0.1)
            assert undamped.growth_rate == pytest.approx(324.4, abs=0.1)
            assert shift == pytest.approx(-78.5, abs=0.5)
        errors.append(abs(damped.growth_rate - ex1.growth_rate))
    order = math.log2(errors[0] / errors[1])
    assert 1.7 < order < 2.3, errors
    assert errors[1] < 0.03 * ex1.growth_rate


def test_damped_transient_grows_as_the_damped_cea_predicts():
    """scenes/figure3_n132_damped (β₂ = ½, τ = 1.99 µs), mode k = 4 seeded at 1e-6 d, linear
    phase 1-8 ms (every node slipping). The explicit solver with Kelvin–Voigt damping is
    Newmark on M ü + τA u̇ + A u = 0 with the damping on the velocity predictor, so the
    matrix-pencil exponents of U_4(t) are the damped CEA eigenvalues mapped by
    ``newmark_exponents(..., tau)``: measured agreement 1e-11 at the scene's dt (0.9 dt_crit),
    tolerance 1e-6 for the fit. At dt = 0.3 dt_crit the map moves the growth by 0.58 % (3.4 %
    at 0.9 dt_crit: the damping on the predictor is first order in dt), so the transient
    matches the continuous damped CEA of k = 4 (968 /s at 2401 Hz, with the rotation;
    1192 /s undamped): tolerance 1 %."""
    MPI, _, load_scene = _fe()
    from stickslip.studies.flutter_fe import complex_eigenvalue_analysis, measure_transient_growth

    scene = load_scene("figure3_n132_damped")
    tau = scene.damping.tau
    res = complex_eigenvalue_analysis(_problem("figure3_n132_damped"), None, 3000.0)
    k4 = sorted(_branches(res, 4), key=lambda m: -m.growth_rate)
    top = k4[0]
    assert top.direction == "rotation" and top.growth_rate == pytest.approx(968.1, abs=0.5)
    for fraction in (0.9, 0.3):
        sc = scene.with_overrides(f"time.dt_fraction={fraction}")
        g = measure_transient_growth(sc, 4, MPI.COMM_SELF, window=(1e-3, 8e-3))
        assert g.all_slip and g.amplitude_range_m[1] < 1e-5
        for m, (growth, freq, _) in zip(k4[:2], g.exponents[:2], strict=True):
            mu = np.array([m.omega2_real + 1j * m.omega2_imag])
            s = newmark_exponents(mu, g.dt_s, 0.5, tau)[0]
            sign = -1.0 if m.direction == "rotation" else 1.0  # U_k of a +theta wave: e^{-iwt}
            assert growth == pytest.approx(s.real, rel=1e-6)
            assert freq == pytest.approx(sign * s.imag / (2 * np.pi), rel=1e-6)
        if fraction == 0.3:
            assert g.exponents[0][0] == pytest.approx(top.growth_rate, rel=0.01)
            assert -g.exponents[0][1] == pytest.approx(top.frequency_hz, rel=0.01)


REGULARISED = ['friction.regularization="constant-time"', "friction.relaxation_time=1e-4"]


def test_regularised_cea_tends_to_coulomb_and_to_the_exact_continuum():
    """A regularised friction bound (t* ṡ = p̃ − s per contact node) through the (u, s)
    quadratic eigenproblem (SLEPc PEP), figure3_n36 (N = 36), up to 2 kHz.

    * t* = 1e-9 s is the Coulomb CEA: every unstable mode again; λ moves by less than
      ωt* × ω ≈ 1e-5 ω (first order in ωt*): tolerance 1e-5 ω on the growth, 1e-5 relative
      on the frequency.
    * t* = 1e-4 s with the Kelvin-Voigt damping of figure1_n132_damped (τ = 1.99 µs), against
      the exact continuum with the same linearised law (``exact.sliding_flutter``,
      f_eff = f/(1 + λt*)): the fastest k = 4 branch against the rotation drops from 951.5
      to 308.5 /s (exact). FE N = 36: 290.6 /s (5.8 % low; with
      Coulomb friction the N = 36 error of this branch is 31 %); N = 72 / 132: 306.4 / 309.9
      (docs/flutter.md). Tolerance 8 % at N = 36."""
    _fe()
    from stickslip.exact.annulus import Elastic
    from stickslip.exact.sliding_flutter import Dissipation, sliding_branches
    from stickslip.studies.flutter_fe import complex_eigenvalue_analysis

    pb = _problem("figure3_n36")
    coulomb = complex_eigenvalue_analysis(pb, None, 2000.0).unstable()
    near = complex_eigenvalue_analysis(pb, None, 2000.0, t_star=1e-9).unstable()
    assert len(near) >= len(coulomb) > 20
    for m in coulomb:
        other = min(near, key=lambda x: abs(x.frequency_hz - m.frequency_hz)
                    + abs(x.growth_rate - m.growth_rate))
        omega = 2 * math.pi * m.frequency_hz
        assert abs(other.growth_rate - m.growth_rate) < 1e-5 * omega
        assert other.frequency_hz == pytest.approx(m.frequency_hz, rel=1e-5)
        assert other.k == m.k
    res = complex_eigenvalue_analysis(
        _problem("figure1_n132_damped", "mesh.n_inner=36", *REGULARISED), None, 2000.0)
    assert res.t_star == 1e-4 and res.tau == TAU_FIG and res.stats.max_residual < 1e-8
    fe = max((m for m in res.modes if m.wavenumber == 4 and m.direction == "opposite"
              and m.frequency_hz > 1400.0), key=lambda m: m.growth_rate)
    br = sliding_branches(4, 0.7, Elastic(E=E, rho=RHO, nu=NU, R=R, xi=XI), fmax_hz=2000.0,
                          diss=Dissipation(tau=TAU_FIG, t_star=1e-4)).branches
    exact = max((b for b in br if b.direction == "opposite"), key=lambda b: b.growth_rate)
    assert exact.growth_rate == pytest.approx(308.5, abs=0.1)
    assert fe.growth_rate == pytest.approx(exact.growth_rate, rel=0.08)


def test_regularised_transient_grows_as_the_regularised_cea_predicts():
    """figure3_n36 with the constant-time bound t* = 1e-4 s, β₂ = ½, mode 4 seeded at 1e-6 d,
    window 1-8 ms, every node slipping. The transient relaxes s with the reaction of the
    step before (``solver.contact.EffectivePressure``): first order in dt. Its dominant
    exponent (k = 4 against the rotation) grows at 434.4 /s at 0.3 dt_crit and 404.1 /s at
    0.1 dt_crit; the first-order extrapolation g(dt) − (g(3dt) − g(dt))/2 = 389.0 is the CEA's
    389.2 /s: measured 0.06 % apart, tolerance 1 % (the O(dt²) remainder)."""
    MPI, _, load_scene = _fe()
    from stickslip.studies.flutter_fe import complex_eigenvalue_analysis, measure_transient_growth

    scene = load_scene("figure3_n36", REGULARISED)
    res = complex_eigenvalue_analysis(_problem("figure3_n36", *REGULARISED), None, 3000.0)
    top = max((m for m in res.modes if m.wavenumber == 4), key=lambda m: m.growth_rate)
    assert top.direction == "opposite" and top.growth_rate == pytest.approx(389.2, abs=0.1)
    rates = []
    for fraction in (0.3, 0.1):
        sc = scene.with_overrides(f"time.dt_fraction={fraction}", "time.beta2=0.5")
        g = measure_transient_growth(sc, 4, MPI.COMM_SELF, window=(1e-3, 8e-3))
        assert g.all_slip and g.amplitude_range_m[1] < 1e-5
        growth, freq, _ = min(g.exponents, key=lambda e: abs(e[1] - top.frequency_hz))
        assert freq == pytest.approx(top.frequency_hz, rel=0.02)
        rates.append(growth)
    assert rates[0] > rates[1] > top.growth_rate  # the lag of the explicit relaxation
    extrapolated = rates[1] - (rates[0] - rates[1]) / 2.0  # dt ratio 3, first order
    assert extrapolated == pytest.approx(top.growth_rate, rel=0.01)


def test_cea_refuses_what_it_cannot_represent(capsys):
    """A scene term the CEA cannot represent is refused in one line, not dropped: the
    regularised bound with the consistent mass."""
    _fe()
    from stickslip.cli.main import main

    args = ["flutter-fe", "smoke", "--mass", "consistent"]
    for item in REGULARISED:
        args += ["--set", item]
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "regularised friction" in err and "--mass" in err


def test_cli_table_lists_resolved_modes_first_and_writes_mode_shapes(capsys, tmp_path):
    """The table has the damping ratio, signed k and direction; mesh-scale modes come after the
    resolved ones with the reason. --modes writes modes.csv (the listed modes), contact.csv and
    one VTX folder per mode; the exported ψ_θ on the contact circle has the table's signed
    wavenumber as its dominant Fourier component (exact: the same eigenvector)."""
    _fe()
    from stickslip.cli.main import main

    out_dir = tmp_path / "modes"
    assert main(["flutter-fe", "figure3_n36", "--fmax-hz", "3000", "--top", "4",
                 "--modes", str(out_dir)]) == 0
    text = capsys.readouterr().out
    assert "zeta" in text and "no damping" in text and "time.beta2 = 0.6" in text
    body = text.split("per k")[0]
    assert body.index("resolved by the mesh") < body.index("mesh-scale modes: wavelength < 8")
    rows = (out_dir / "modes.csv").read_text().splitlines()
    assert len(rows) == 1 + 4 + 3  # header, 4 resolved, 3 mesh-scale
    first = rows[1].split(",")
    assert first[8] == "false" and rows[-1].split(",")[8] == "true"
    assert float(first[3]) < 0 and (out_dir / first[9]).is_dir()
    table = np.genfromtxt(out_dir / "contact.csv", delimiter=",", skip_header=1)
    one = table[table[:, 0] == 1]
    assert one.shape[0] == 36 and np.max(one[:, 4]) == pytest.approx(1.0, rel=1e-12)
    psi = one[:, 2] + 1j * one[:, 3]
    kk = np.arange(-18, 19)
    power = np.abs(np.exp(-1j * np.outer(kk, np.radians(one[:, 1]))) @ psi)
    assert kk[np.argmax(power)] == int(first[4])
    assert main(["flutter-fe", "figure3_n36", "--modes", str(out_dir)]) == 2
    assert "not empty" in capsys.readouterr().err
