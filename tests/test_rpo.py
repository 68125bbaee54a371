"""Relative periodic orbits (``studies.rpo``): R₋ₛ F_T(x) = x on the explicit scheme.

* the ring rotation: a whole-node shift is the mesh's node permutation (round-off), R_s on a
  pure harmonic is exact for any s, and ∂_θ is its derivative;
* a manufactured two-wave state of the contact-free tube (two Bloch modes of the explicit
  scheme, N = 32, no damping, β₂ = ½) is an RPO with the exact T and s of its discrete
  frequencies: its residual is round-off, and Newton from a guess off by 10⁻³ returns T and s;
* a rigid wave (the travel solver's central-scheme wave, N = 132, S = 3 points per node) is an
  RPO with T = q·S·h and s = qΔφ: residual at the travel solver's round-off, Newton from a
  guess off by 10⁻³ returns it, and a transient started on the orbit stays on it.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("dolfinx")


def _harmonic(rot, w: np.ndarray) -> int:
    """The dominant polar harmonic m of a field on the rings."""
    rh, th = rot._polar_hat(w)
    return int(np.argmax(np.sum(np.abs(rh) ** 2 + np.abs(th) ** 2, axis=0)))


@pytest.fixture(scope="module")
def linear32():
    """The N = 32 Figure-1 tube without damping at β₂ = ½; its contact-free problem."""
    from stickslip.solver.scene import load_scene
    from stickslip.studies.rpo.orbit import start_from_state

    scene = load_scene("scenes/figure1.toml", ["mesh.n_inner=32", "time.beta2=0.5"])
    start = start_from_state(scene, np.zeros(1), np.zeros(1))
    return scene, start


def test_ring_rotation_is_the_node_permutation_and_exact_on_harmonics(linear32):
    """R_{qΔφ} permutes the nodes (to 1e-9 of the field: the node angles that gmsh writes
    are uniform to ~1e-10 rad, measured 1.3e-10 relative); on a pure polar harmonic m the
    Fourier shift is exact for any s, so R_a R_b = R_{a+b} (1e-9, the node angles again;
    measured 3e-13) and the spectral ∂_θ
    matches the difference quotient of R₋ₛ (1e-6: its O(ε²) error at ε = 1e-4)."""
    from stickslip.studies.rpo.orbit import RingRotation

    _, start = linear32
    rot = RingRotation(start.problem)
    rng = np.random.default_rng(3)
    w = np.zeros(rot.n)
    w[: rot.n] = rng.standard_normal(rot.n)
    w[np.asarray(start.problem.clamped)] = 0.0
    N = rot.count
    shifted = rot.rotate(w, 2 * 2 * math.pi / N)
    # node j of a ring moves to node j + 2, its (x, y) turned by 2Δφ
    i, j = rot.idx[1, 0], rot.idx[1, 2]
    c, s = math.cos(4 * math.pi / N), math.sin(4 * math.pi / N)
    expect = np.array([c * w[2 * i] - s * w[2 * i + 1], s * w[2 * i] + c * w[2 * i + 1]])
    assert np.abs(shifted[2 * j: 2 * j + 2] - expect).max() < 1e-9 * np.abs(w).max()
    # a pure harmonic: u_r = cos(3θ) on every ring
    th = np.arctan2(*start.problem.V.tabulate_dof_coordinates()[: rot.n // 2, 1::-1].T)
    h3 = np.zeros(rot.n)
    h3[0::2], h3[1::2] = np.cos(3 * th) * np.cos(th), np.cos(3 * th) * np.sin(th)
    a, b = 0.123, 0.456
    assert np.abs(rot.rotate(rot.rotate(h3, a), b) - rot.rotate(h3, a + b)).max() < 1e-9
    eps = 1e-4
    quotient = (rot.rotate(h3, -eps) - rot.rotate(h3, eps)) / (2 * eps)
    assert np.abs(quotient - rot.derivative(h3)).max() < 1e-6


def _bloch_modes(start, rot, harmonics):
    """The lowest eigenpair (λ, travelling complex mode Ψ ∝ e^{imθ}) of K φ = λ M φ for each
    harmonic m of ``harmonics`` (dense, free dofs)."""
    import scipy.linalg as la
    import scipy.sparse as sp

    bp = start.batched
    K = sp.csr_matrix((bp.data, bp.indices.astype(np.int64), bp.indptr.astype(np.int64)),
                      shape=(bp.n, bp.n)).toarray()
    free = np.flatnonzero(bp.inv_mass > 0)
    lam, vec = la.eigh(K[np.ix_(free, free)], np.diag(bp.mass[free]))
    out = []
    for m in harmonics:
        for col in range(lam.size):
            phi = np.zeros(bp.n)
            phi[free] = vec[:, col]
            if _harmonic(rot, phi) == m:
                psi = phi + 1j * rot.rotate(phi, math.pi / (2 * m))
                out.append((float(lam[col]), psi))
                break
    return out


def test_manufactured_two_wave_state_of_the_linear_tube_is_reproduced(linear32):
    """Two Bloch modes of the contact-free, undamped scheme (β₂ = ½: the central difference,
    cos ω̃h = 1 − h²λ/2, |z| = 1): m = 2 with the rotation and m = 3 against it. In the frame
    of the first (c₁ = ω̃₁/2) the second turns at 3c₁ + ω̃₂, so T = 2π/(3c₁ + ω̃₂), s = c₁T,
    with h chosen so that T = p h exactly. The residual there is < 1e-8 (measured 2.2e-9: the
    node angles that gmsh writes are uniform to ~1e-10 rad, so the modes are pure harmonics,
    and the mesh Z_N symmetric, to that order). Newton from T(1 + 1e-3), s + 1e-3 reaches
    2e-9 in 3 iterations (3.4e-3, 1.4e-4, 1.0e-7, 1.3e-9) and returns T and s to 1e-9
    relative (measured 9e-11, 6e-11): the map is linear, one piece, the products exact; the
    amplitudes are a family the phase conditions leave free, T and s do not depend on them.
    Below ~1e-9 GMRES needs more than 80 vectors (every multiplier of the undamped map lies
    on the unit circle)."""
    from scipy.optimize import brentq

    from stickslip.studies.rpo.certificate import (
        orbit_verdict,
        solve_orbit,
        two_period_residual,
    )
    from stickslip.studies.rpo.orbit import OrbitProblem, RingRotation, start_from_state

    scene, start = linear32
    rot = RingRotation(start.problem)
    (l1, psi1), (l2, psi2) = _bloch_modes(start, rot, (2, 3))

    def omega(lam: float, h: float) -> float:
        return math.acos(1.0 - 0.5 * h * h * lam) / h

    def period(h: float) -> float:
        return 2 * math.pi / (3 * omega(l1, h) / 2 + omega(l2, h))

    p = max(8, math.ceil(period(start.dt) / start.dt))  # h ≤ the scene's stable Δt
    h = brentq(lambda x: period(x) - p * x, 0.1 * start.dt, start.dt, xtol=1e-22)
    T, s = p * h, omega(l1, h) / 2 * p * h
    z1, z2 = np.exp(-1j * omega(l1, h) * h), np.exp(1j * omega(l2, h) * h)
    amp = 1e-4 / np.abs(psi1).max()
    u = (amp * (psi1 + 0.7 * psi2)).real
    v = (amp * (psi1 * (1 - 1 / z1) + 0.7 * psi2 * (1 - 1 / z2)) / h).real
    exact = OrbitProblem(start_from_state(scene, u, v, dt=h), T, s, steps=p, contact=False)
    assert np.linalg.norm(exact.residual(exact.guess)) < 1e-8
    off = OrbitProblem(exact.start, T * (1 + 1e-3), s + 1e-3, steps=p, contact=False)
    result, orbit = solve_orbit(off, tol=2e-9, max_iter=6)
    assert result.converged
    assert abs(orbit.period / T - 1) < 1e-9 and abs(orbit.shift / s - 1) < 1e-9
    # an orbit, not only a root: one more period keeps it (|multipliers| = 1 here)
    r2 = two_period_residual(off, orbit)
    assert orbit_verdict(result, r2, 2e-9, 0.0)[0] and r2 < 10 * max(result.residual, 2e-9)


@pytest.fixture(scope="module")
def rigid132():
    """The central-scheme k = 4 wave of ``tests/test_travel_fe.py``'s fixture (damped
    Figure 1, N = 132, S = 3, h = Δφ/(3|ω|)) as the scheme's state (u, ṽ = v − β₂ h a)."""
    from stickslip.solver.scene import load_scene
    from stickslip.studies.rpo.orbit import start_from_state
    from stickslip.studies.travel import driver as D
    from stickslip.studies.travel.family import zone_pattern
    from stickslip.studies.travel.newton import wave_of_active_set

    sc = load_scene("scenes/figure1_n132_damped.toml")
    st = D.setup(sc, float(sc.damping.tau), rate="bdf1", inertia="shift", samples=3,
                 time_scheme="central")
    om = -2498.778131 / sc.geometry.R
    status = np.tile(zone_pattern(st.prob.n // 4, 25, 5, 1), 4)
    wave = wave_of_active_set(st.prob, status, np.ones(st.prob.n), om, period=4)
    h = st.ops.step(wave.omega)
    u, v, a = st.ops.shift_state(np.r_[wave.W_r, wave.W_t], wave.omega)
    start = start_from_state(st.scene, u, v - sc.time.beta2 * h * a, dt=h)
    return start, wave, h


def test_rigid_wave_is_an_rpo_and_newton_returns_it(rigid132):
    """q = 4 node passages: T = 12 h, s = −4Δφ (the wave turns against the rotation). The
    travel solver's wave is a root to its own round-off (< 1e-8; measured 1.5e-9, the dense
    one-sector solves of ``shift_state``). From T(1 + 1e-3), s(1 + 1e-3) Newton converges to
    < 1e-9 and returns the wave: T and s to 1e-6 relative, u to 1e-6 d (measured 8e-8 and
    6e-8 d: a rigid wave is an RPO for any step h, a family along which Newton may move by
    its residual's order)."""
    from stickslip.studies.rpo.certificate import solve_orbit
    from stickslip.studies.rpo.orbit import OrbitProblem

    start, wave, h = rigid132
    T, s = 12 * h, -4 * 2 * math.pi / 132
    on = OrbitProblem(start, T, s, steps=12)
    assert np.linalg.norm(on.residual(on.guess)) < 1e-8
    off = OrbitProblem(start, T * (1 + 1e-3), s * (1 + 1e-3), steps=12)
    result, orbit = solve_orbit(off, tol=1e-9, max_iter=12, max_krylov=60)
    assert result.converged, result.message
    assert abs(orbit.period / T - 1) < 1e-6 and abs(orbit.shift / s - 1) < 1e-6
    u, _ = off.physical(orbit.xi)
    assert np.abs(u - start.u).max() < 1e-6 * start.scene.geometry.d


def test_transient_started_on_the_rigid_orbit_stays_on_it(rigid132):
    """40 periods (480 steps) of the census's batched kernel from the orbit agree with the
    orbit turned by 40 s: 1e-7 of the state (relative RMS; measured ~1e-9: the residual
    1.5e-9 carried along, not amplified over 40 periods)."""
    from stickslip.studies.rpo.orbit import OrbitProblem

    start, wave, h = rigid132
    T, s = 12 * h, -4 * 2 * math.pi / 132
    P = OrbitProblem(start, T, s, steps=12)
    after = P.flow(P.guess.xi, T, steps=480)  # 480 steps of the orbit's h = T/12
    assert np.linalg.norm(after - P.rotate(P.guess.xi, 40 * s)) < 1e-7


@pytest.fixture(scope="module")
def census_start(tmp_path_factory):
    """A census start on the smoke mesh (2 starts at N = 36 to 0.05 s) to hand the command."""
    import io

    from test_attractors import SMOKE

    from stickslip.studies.attractors.census import Census, run_census
    from stickslip.studies.attractors.starts import StartDistribution

    out = tmp_path_factory.mktemp("rpo_cli") / "census"
    spec = Census(SMOKE, (36,), StartDistribution(starts=1), ("time.end_time=0.05",),
                  max_time=0.05)
    assert run_census(spec, out, certify=False, stream=io.StringIO()) == 0
    return next(p.parent for p in (out / "starts" / "runs").glob("*/checkpoint.npz"))


@pytest.mark.parametrize("option, words", [
    (["--period", "-1"], "--period -1.0: give a positive"),
    (["--period", "nan"], "--period nan"),
    (["--shift", "inf"], "--shift inf: give a finite angle"),
    (["--tol", "0"], "--tol 0.0: give a positive"),
    (["--max-iter", "-2"], "--max-iter -2: give 0 or more"),
    (["--multipliers", "-1"], "--multipliers -1")])
def test_rpo_bad_option_is_one_line(census_start, capsys, option, words):
    from stickslip.cli.main import main

    rc = main(["rpo", str(census_start), "--period", "1e-3", "--shift", "10", *option])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and words in err, err


def test_rpo_output_never_overwrites_a_run_and_replaces_only_with_force(census_start,
                                                                        tmp_path, capsys):
    """-o is claimed as kind rpo: a run directory (here the start itself, whose samples.npz
    the orbit's would overwrite) is refused and left byte for byte; a new directory takes
    rpo.json and samples.npz; the same -o again is refused without --force."""
    from stickslip.cli.main import main

    before = {p.name: p.read_bytes() for p in census_start.iterdir() if p.is_file()}
    args = ["rpo", str(census_start), "--period", "1e-3", "--shift", "10", "--max-iter", "0",
            "--multipliers", "0"]
    assert main([*args, "-o", str(census_start)]) == 2
    assert "not a rpo one" in capsys.readouterr().err
    assert {p.name: p.read_bytes() for p in census_start.iterdir() if p.is_file()} == before
    orbit = tmp_path / "orbit"
    assert main([*args, "-o", str(orbit)]) == 1  # zero iterations: not converged, said
    assert {"rpo.json", "samples.npz"} <= {p.name for p in orbit.iterdir()}
    capsys.readouterr()
    assert main([*args, "-o", str(orbit)]) == 2
    assert "--force" in capsys.readouterr().err
    assert main([*args, "-o", str(orbit), "--force"]) == 1


def test_the_guess_takes_a_given_period_and_shift_without_a_second_generator():
    """With --period and --shift both given, a start on a rigid wave (one generator, as
    its census member lists it) is an RPO guess like any other; with only one of them a
    second generator is needed and its absence is said. The issue's two-wave example,
    (6, −927.26 Hz) and (10, −990.96 Hz), has the frame frequency 554.47 Hz."""
    from stickslip.studies.rpo.certificate import orbit_guess

    one = [{"k": 11, "frequency_hz": -1638.4}]
    assert orbit_guess(one, 1e-4, -0.1) == (1e-4, -0.1)
    with pytest.raises(ValueError, match="1 generator"):
        orbit_guess(one, 1e-4, None)
    two = [{"k": 6, "frequency_hz": -927.26}, {"k": 10, "frequency_hz": -990.96}]
    period, shift = orbit_guess(two)
    assert period == pytest.approx(1 / 554.47, rel=1e-5)
    assert shift == pytest.approx(2 * math.pi * -927.26 * period / 6, rel=1e-12)
    assert orbit_guess(two, 2e-3) == (2e-3, shift)


def test_a_held_whole_node_shift_keeps_s_and_finds_the_wave(rigid132):
    """``hold_shift``: s stays at exactly −4Δφ (the node permutation, the mesh's symmetry)
    and Newton moves T alone, from T(1 + 1e-3), back to the wave: residual < 1e-9, T to 1e-6
    relative, u to 1e-6 d, as with s free."""
    from stickslip.studies.rpo.certificate import solve_orbit
    from stickslip.studies.rpo.orbit import OrbitProblem

    start, wave, h = rigid132
    T, s = 12 * h, -4 * 2 * math.pi / 132
    held = OrbitProblem(start, T * (1 + 1e-3), s, steps=12, hold_shift=True)
    assert held.pack(held.guess).size == held.guess.xi.size + 1
    result, orbit = solve_orbit(held, tol=1e-9, max_iter=12, max_krylov=60)
    assert result.converged, result.message
    assert orbit.shift == s
    assert abs(orbit.period / T - 1) < 1e-6
    u, _ = held.physical(orbit.xi)
    assert np.abs(u - start.u).max() < 1e-6 * start.scene.geometry.d


@pytest.mark.parametrize("option, words", [
    (["--nodes", "0"], "--nodes 0: give a nonzero number"),
    (["--nodes", "4", "--shift", "10"], "--nodes 4 and --shift 10.0: give one of them"),
    (["--krylov", "5"], "--krylov 5: give at least --multipliers (12)")])
def test_rpo_held_shift_options_are_one_line(census_start, capsys, option, words):
    from stickslip.cli.main import main

    base = ["rpo", str(census_start), "--period", "1e-3"]
    if "--shift" not in option and "--nodes" not in option:
        base += ["--shift", "10"]
    rc = main([*base, *option])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and words in err, err


def test_floquet_verdict_sets_aside_only_a_neutral_mode_and_needs_converged_growth():
    """The verdict's rules (``studies.rpo.floquet``), on multipliers over T = 1 ms. With a
    held shift at most one eigenvector is neutral, and only if it lies in span{e_t, e_θ}
    (share ≥ 0.5) and grows slower than 1 1/s: the public point's real 1.0241 (23 1/s,
    share 0.97) is a growing mode. A converged growing mode makes the orbit unstable; an
    unconverged one (Ritz residual > 1e-6) leaves the verdict open; modes slower than
    1 1/s are stable."""
    from stickslip.studies.rpo.floquet import Floquet, neutral_marks

    T = 1e-3
    mu = np.array([1.0241, 1.0235 * np.exp(0.5j), 1.0235 * np.exp(-0.5j), 1.0001])
    growth = np.log(np.abs(mu)) / T
    share = np.array([0.97, 0.0, 0.0, 0.2])
    held = neutral_marks(share, growth, held=True)
    assert not held.any()
    assert neutral_marks(np.array([0.1, 0.99, 0.0]), np.array([23.0, 0.05, -1.0]),
                         held=True).tolist() == [False, True, False]
    assert neutral_marks(share, growth, held=False).tolist() == [True, False, False, True]
    converged = np.full(4, 1e-14)
    assert Floquet(mu, held, share, converged, T).stable is False
    assert Floquet(mu, held, share, converged, T).fastest_growth == pytest.approx(23.8, 0.01)
    loose = np.array([1e-4, 1e-4, 1e-4, 1e-14])
    assert Floquet(mu, held, share, loose, T).stable is None
    slow = np.array([1.0009, 0.9995, 0.99])  # 0.9, −0.5, −10 1/s
    assert Floquet(slow, np.zeros(3, bool), np.zeros(3), np.full(3, 1e-3), T).stable is True


def test_floquet_multipliers_of_the_damped_linear_tube_are_the_dense_ones():
    """Arnoldi through the kernel against the dense monodromy. The contact-free damped tube
    (Figure 1 damped, N = 32, Kelvin–Voigt) is linear, so its map R₋ₛ F_T is a matrix; built
    column by column over the free dofs (one map per unit vector) and diagonalised densely,
    it gives every multiplier. At a held shift of 2 whole nodes (R_s the node permutation,
    which commutes with the scheme) over p = 100 steps, the leading Ritz values from 80
    vectors that have converged (residual ≤ 1e-6; measured 1e-11 – 4e-10, leading
    |μ| = 0.847519) are dense eigenvalues to 1e-8 (the products are forward differences of a
    linear map: round-off ~ 1e-16/ε = 1e-9 of each column), the leading 4 converge, and the
    verdict is "stable": a damped tube without friction does not grow. (A start vector with
    clamped components, which keep their u and ṽ, put spurious Ritz values at
    |μ| = 1.00000x with residuals ~1e-11 among them.)"""
    from stickslip.solver.scene import load_scene
    from stickslip.studies.rpo.floquet import floquet_multipliers
    from stickslip.studies.rpo.orbit import OrbitProblem, start_from_state

    scene = load_scene("scenes/figure1_n132_damped.toml", ["mesh.n_inner=32"])
    probe = start_from_state(scene, np.zeros(1), np.zeros(1))
    rng = np.random.default_rng(5)
    n = int(probe.batched.n)
    free = np.asarray(probe.batched.inv_mass) > 0
    u, v = rng.standard_normal(n) * free, rng.standard_normal(n) * free
    start = start_from_state(scene, 1e-6 * u, 1e-3 * v, dt=probe.dt)
    p = 100
    held = OrbitProblem(start, p * start.dt, 2 * 2 * math.pi / 32, steps=p, contact=False,
                        hold_shift=True)
    flo = floquet_multipliers(held, held.guess, count=8, krylov=80)
    apply = held.monodromy(held.guess)
    keep = np.flatnonzero(np.r_[free, free])  # the clamped dofs stay 0: multiplier 0
    dense = np.zeros((keep.size, keep.size))
    for col, i in enumerate(keep):
        e = np.zeros(2 * n)
        e[i] = 1.0
        dense[:, col] = apply(e)[keep]
    exact = np.linalg.eigvals(dense)
    done = flo.ritz_residual <= 1e-6
    assert done[:4].all()
    for mu in flo.multipliers[done]:
        assert np.abs(exact - mu).min() < 1e-8
    assert np.abs(exact).max() < 1.0
    assert flo.stable is True and not flo.neutral.any()


@pytest.fixture(scope="module")
def smoke_rigid_run(tmp_path_factory):
    """A start on a rigid wave: the smoke census of ``test_attractor_kick`` (N = 36,
    Ω = 20 rad/s, δ = 0.005, 3 starts to the 0.1 s cap), whose seed 2 ends on k = 6
    against the rotation."""
    import io

    from test_attractors import SMOKE

    from stickslip.studies.attractors.census import Census, run_census
    from stickslip.studies.attractors.starts import StartDistribution

    out = tmp_path_factory.mktemp("rigid") / "census"
    spec = Census(SMOKE, (36,), StartDistribution(starts=3),
                  ("loading.omega=20", "geometry.delta=0.005", "time.end_time=0.05"),
                  max_time=0.1)
    assert run_census(spec, out, certify=False, stream=io.StringIO()) == 0
    return next((out / "starts" / "runs").glob("*seed-2"))


def test_a_rigid_waves_multipliers_predict_the_growth_of_the_map_from_it(smoke_rigid_run):
    """The multipliers of a rigid wave as an orbit at a held whole-node shift (40 node
    passages, p = round(40τ/Δt) steps of h = T/p) against the nonlinear map itself: G
    iterated from the orbit plus 10⁻⁶ grows, over its linear range, at the leading
    multipliers' rate. On the smoke k = 6 wave: a complex pair at |μ| = 1.1948 over
    T = 3.6 ms, 49.08 1/s; the map's |δξ| grows at 49.15 1/s over periods 33 – 69 (0.14 %;
    asserted 2 %: the pair beats in |δξ| across the fit, and the next multiplier, −6 1/s,
    has died out by period 33). The orbit converges to < 1e-10 and the verdict is
    "unstable" with converged Ritz pairs. (These are the multipliers of the orbit locked to
    p steps per 40 passages, not of the run at Δt: ``studies.attractors.certify``.)"""
    from stickslip.studies.rpo.certificate import solve_orbit
    from stickslip.studies.rpo.floquet import floquet_multipliers, growth_from_the_orbit
    from stickslip.studies.rpo.orbit import OrbitProblem, start_from_run
    from stickslip.studies.travel import wave_from_run

    wave = wave_from_run(smoke_rigid_run)
    assert (wave["k"], wave["direction"]) == (6, "opposite")
    start = start_from_run(smoke_rigid_run)
    N = start.scene.mesh.n_inner
    period = 40 * wave["k"] / (N * wave["frequency_hz"])
    problem = OrbitProblem(start, period, -40 * 2 * math.pi / N, hold_shift=True)
    result, orbit = solve_orbit(problem)
    assert result.converged and result.residual < 1e-10
    flo = floquet_multipliers(problem, orbit, krylov=150)
    assert flo.stable is False and flo.converged
    growth = flo.fastest_growth
    assert growth > 10.0
    _, rate, (first, last) = growth_from_the_orbit(problem, orbit, 80)
    assert rate is not None and last - first >= 10
    assert rate == pytest.approx(growth, rel=0.02)


def test_a_root_that_the_map_does_not_repeat_is_no_orbit():
    """The verdict's rule (``orbit_verdict``) on the numbers of the two-wave state of P at
    N = 132 (seed 4, docs/theory/rpo.md): Newton's root had residual 6.3e-11 over one
    period and 0.079 over two, the size of the commutation defect (0.078); it is no orbit,
    and says so. An orbit whose error grows over the second period by a multiplier (here 5)
    stays one."""
    from types import SimpleNamespace

    from stickslip.studies.rpo.certificate import orbit_verdict

    root = SimpleNamespace(converged=True, residual=6.3e-11, message="converged")
    ok, why = orbit_verdict(root, 0.079, 1e-10, 0.078)
    assert not ok and "no orbit" in why and "0.079" in why
    assert orbit_verdict(root, 6 * 6.3e-11, 1e-10, 0.078) == (True, "converged")
    stalled = SimpleNamespace(converged=False, residual=3.7e-3, message="stagnated")
    assert orbit_verdict(stalled, 1e-3, 1e-10, 0.1) == (False, "stagnated")


def test_the_rpo_screen_of_a_census_start_and_its_line(census_start):
    """``rpo_screen`` (the census's screen of a two-generator member: no Newton) on a census
    start with two generators given: T = 1/|f₂ − (k₂/k₁) f₁| and s = 2π f₁T/k₁ exactly, p =
    round(T/Δt) steps, the three norms finite and non-negative (the smoke state moves, so the
    residual over T is not 0); its census line names them. A screen that cannot run (one
    generator) says why and never raises."""
    from stickslip.studies.attractors.certify import rpo_line
    from stickslip.studies.rpo.certificate import rpo_screen

    generators = [{"k": 4, "frequency_hz": 800.0}, {"k": 5, "frequency_hz": 1500.0}]
    screen = rpo_screen(census_start, generators)
    T = 1.0 / abs(1500.0 - 5 / 4 * 800.0)
    assert screen["period_s"] == pytest.approx(T, rel=1e-15)
    assert screen["shift_rad"] == pytest.approx(2 * math.pi * 800.0 * T / 4, rel=1e-15)
    assert screen["steps"] >= 1
    for key in ("residual", "residual_two_periods", "commutation_defect"):
        assert math.isfinite(screen[key]) and screen[key] >= 0.0, key
    assert screen["residual"] > 0.0
    line = rpo_line(screen)
    assert line.startswith("RPO screen: half-node commutation defect ") and line.endswith(
        "over 2T")
    bad = rpo_screen(census_start, generators[:1])
    assert "ValueError" in bad["message"] and rpo_line(bad).startswith("RPO screen: ValueError")


@pytest.mark.parametrize("option, words", [
    (["--along", "omega=60"], "give KEY=A:B:M"),
    (["--along", "loading.omega=60:70:1"], "(2 <= M <= 200 values from A to B)"),
    (["--along", "loading.omega=1:2:100000"], "(2 <= M <= 200 values from A to B)"),
    (["--along", "loading.omega=1,2", "--leg", "1e308"], "up to 100 (a census's cap"),
    (["--along", "loading.omegax=1,2", "--wave", "4", "--sideband", "3"],
     "unknown key 'loading.omegax'"),
    (["--along", "loading.omega=1,2", "--leg", "0"], "--leg 0.0: give a positive"),
    (["--along", "loading.omega=1,2", "--seed", "-1"], "--seed -1.0: give a positive"),
    (["--along", "loading.omega=1,2", "--wave", "4", "--sideband", "4"],
     "give --wave K and --sideband K2"),
    (["--seed", "1e-2"], "go with --along")])
def test_rpo_along_bad_option_is_one_line(census_start, capsys, option, words):
    from stickslip.cli.main import main

    rc = main(["rpo", str(census_start), *option])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and words in err, err


def test_rpo_along_follows_the_start_and_reports_each_value(census_start, capsys):
    """``--along``: two values of Ω, each 10 ms from the end of the one before, k = 3 read
    against k = 4 (the smoke start carries every mode): one row per value with σ, the
    frequencies and the frame frequency f₃ − (3/4) f₄, finite; the start is not changed."""
    import json

    from stickslip.cli.main import main

    before = (census_start / "checkpoint.npz").read_bytes()
    rc = main(["rpo", str(census_start), "--along", "loading.omega=40,41", "--wave", "4",
               "--sideband", "3", "--leg", "0.01", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert rc == 0 and out["key"] == "loading.omega" and (out["k_wave"], out["k_side"]) == (4, 3)
    assert [r["value"] for r in out["rows"]] == [40.0, 41.0]
    for r in out["rows"]:
        assert all(math.isfinite(r[k]) for k in ("sigma", "frequency_hz", "wave_hz", "frame_hz"))
        assert r["frame_hz"] == pytest.approx(r["frequency_hz"] - 0.75 * r["wave_hz"])
    assert (census_start / "checkpoint.npz").read_bytes() == before


def test_rpo_along_in_python_is_the_command(census_start, capsys):
    """``stickslip.rpo_along`` returns the rows ``stickslip rpo --along --json`` prints: the
    same function on the same start, so the same bits."""
    import json

    import stickslip
    from stickslip.cli.main import main

    args = dict(key="loading.omega", values=[40.0], leg=0.01, wave=4, sideband=3)
    out = stickslip.rpo_along(census_start, **args, quiet=True)
    assert capsys.readouterr().out == ""
    assert main(["rpo", str(census_start), "--along", "loading.omega=40", "--wave", "4",
                 "--sideband", "3", "--leg", "0.01", "--json"]) == 0
    assert json.loads(capsys.readouterr().out) == json.loads(json.dumps(out))
    with pytest.raises(stickslip.SceneError, match="loading.omegax"):
        stickslip.rpo_along(census_start, "loading.omegax", [1.0], wave=4, sideband=3)
    for bad, words in (({"leg": float("inf")}, "leg = inf"), ({"leg": 1e308}, "up to 100"),
                       ({"values": [40.0] * 201}, "201 values"),
                       ({"values": [40.0, -1.0]}, "loading.omega = -1.0"),
                       ({"seed": float("nan")}, "seed = nan")):
        with pytest.raises(ValueError, match=words):
            stickslip.rpo_along(census_start, **{**args, **bad}, quiet=True)
