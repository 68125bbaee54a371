"""Implicit Newmark (solver.implicit): active-set contact solve, energy, fixed point, MPI.

The active-set and spring-chain tests need only numpy/scipy/petsc4py; the FE tests use the
smoke scene (N = 36, 2 layers), so each takes a few seconds.
"""

import numpy as np
import pytest

pytest.importorskip("petsc4py")

from mpi4py import MPI  # noqa: E402
from petsc4py import PETSc  # noqa: E402

from stickslip.solver.active_set import (  # noqa: E402
    SEPARATED,
    STUCK,
    ActiveSetSolver,
    ContactSolveError,
)
from stickslip.solver.implicit import ImplicitNewmark, amplification_eigenvalues  # noqa: E402

SELF = MPI.COMM_SELF


def random_contact_problem(nc: int, f: float, seed: int):
    """SPD compliance S (interleaved p, q), free displacements w, stick targets."""
    rng = np.random.default_rng(seed)
    n = 2 * nc
    B = rng.normal(size=(n, n))
    S = (B @ B.T / n + np.eye(n)) * 1e-9  # m per N/m, like the FE Schur complements
    d = 1e-3
    w_r = d + rng.normal(scale=5e-4, size=nc)  # about half the nodes would penetrate
    w_t = rng.normal(scale=5e-4, size=nc)
    target = w_t + rng.normal(scale=5e-4, size=nc)
    return S, d, w_r, w_t, target


@pytest.mark.parametrize("f", [0.0, 0.3, 1.0])
def test_active_set_satisfies_signorini_and_coulomb(f):
    """The converged forces satisfy every nodal condition of the law (paper eq. [2])."""
    nc = 24
    S, d, w_r, w_t, target = random_contact_problem(nc, f, seed=int(10 * f))
    if f == 0.0:
        S = S[::2, ::2].copy()  # radial unknowns only
    solver = ActiveSetSolver(S, d, f)
    iterations = solver.solve(w_r, w_t, target)
    p, q, u_r, u_t = solver.p, solver.q, solver.u_r, solver.u_t
    # Tolerances: the linear solves are exact to ~1e-16 relative; displacements ~1e-3 m,
    # forces ~1e6 N/m, so 1e-12 of each scale is round-off, not a modelling error.
    tol_u, tol_p = 1e-12 * d, 1e-12 * max(1.0, np.abs(p).max())
    contact = solver.mode != SEPARATED
    assert contact.any() and (~contact).any(), "the test must have both contact and gaps"
    assert np.all(p >= -tol_p)
    assert np.all(u_r >= d - tol_u)
    assert np.allclose(u_r[contact], d, atol=tol_u, rtol=0)
    assert np.all(p[~contact] == 0.0) and np.all(q[~contact] == 0.0)
    if f == 0.0:
        assert np.all(q == 0.0)
    else:
        stuck = solver.mode == STUCK
        slipping = contact & ~stuck
        assert np.all(np.abs(q[stuck]) <= f * p[stuck] + tol_p)
        assert np.allclose(u_t[stuck], target[stuck], atol=tol_u, rtol=0)
        assert np.allclose(np.abs(q[slipping]), f * p[slipping], rtol=1e-12)
        # friction opposes the slip relative to the cylinder: q (u_t - target) <= 0
        assert np.all(q[slipping] * (u_t[slipping] - target[slipping]) <= tol_p * tol_u)
    assert 1 <= iterations < 20
    # warm start: the same data again converge in one iteration (sets already right)
    assert solver.solve(w_r, w_t, target) == 1


def test_active_set_failure_is_an_exception_with_a_message():
    S, d, w_r, w_t, target = random_contact_problem(24, 0.3, seed=1)
    solver = ActiveSetSolver(S, d, 0.3, max_iterations=1)
    with pytest.raises(ContactSolveError, match="no convergence in 1 iterations"):
        solver.solve(w_r, w_t, target)


def test_friction_fixed_point_fallback_finds_the_same_coulomb_solution(monkeypatch):
    """If the Coulomb active set fails (it can cycle at large dt, measured at N = 528,
    dt = 16 dt_crit), the fallback (Tresca problems with bound f p, fixed point) must land on
    the same solution: the Coulomb problem's solution here is unique (f small enough)."""
    S, d, w_r, w_t, target = random_contact_problem(24, 0.3, seed=2)
    direct = ActiveSetSolver(S, d, 0.3)
    direct.solve(w_r, w_t, target)
    fallback = ActiveSetSolver(S, d, 0.3)
    real = fallback._iterate
    calls = []

    def first_fails(*args):
        calls.append(args[-1] is None)
        if len(calls) > 1:
            return real(*args)
        fallback.max_iterations = 1  # stop the Coulomb iteration early, far from converged
        its, _ = real(*args)
        fallback.max_iterations = 50
        return its, "forced failure"

    monkeypatch.setattr(fallback, "_iterate", first_fails)
    fallback.solve(w_r, w_t, target)
    assert calls[0] and not any(calls[1:]) and len(calls) > 2  # Coulomb, then Tresca steps
    assert fallback.fallbacks == 1
    np.testing.assert_array_equal(fallback.mode, direct.mode)
    scale = np.abs(direct.p).max()
    # fixed point stopped at |f p - g| <= 1e-11 max g: forces agree to ~1e-10
    assert np.max(np.abs(fallback.p - direct.p)) < 1e-9 * scale
    assert np.max(np.abs(fallback.q - direct.q)) < 1e-9 * scale


def chain_matrix(n: int) -> PETSc.Mat:
    """Fixed-free spring chain, unit springs (PETSc AIJ): w_max < 2 for unit masses."""
    A = PETSc.Mat().createAIJ((n, n), nnz=3, comm=SELF)
    for i in range(n):
        A.setValue(i, i, 2.0 if i < n - 1 else 1.0)
        if i + 1 < n:
            A.setValue(i, i + 1, -1.0)
            A.setValue(i + 1, i, -1.0)
    A.assemble()
    return A


def test_trapezoidal_rule_conserves_energy_exactly_without_contact():
    """beta1 = 1/4, beta2 = 1/2 at dt = 20 / w_max (10x the explicit limit): the discrete
    energy 1/2 v.Mv + 1/2 u.Ku is an exact invariant, so it may only drift by round-off
    (1e-12 relative over 2000 steps); the dissipative beta2 = 0.6 variant must lose energy."""
    n = 40
    K = chain_matrix(n)
    mass = np.ones(n)
    clamped = np.array([0])
    rng = np.random.default_rng(0)
    u0 = rng.normal(size=n)
    u0[0] = 0.0
    energies = {}
    for beta1, beta2 in ((0.25, 0.5), ((0.6 + 0.5) ** 2 / 4, 0.6)):
        integ = ImplicitNewmark(K, mass, clamped, 10.0, beta1, beta2, None, SELF)
        integ.set_state(u0, np.zeros(n))
        e = []
        for _ in range(2000):
            integ.step()
            e.append(0.5 * integ.v @ (mass * integ.v) + 0.5 * integ.u_prev @ integ.ku)
        energies[beta2] = np.array(e)
    e = energies[0.5]
    assert np.max(np.abs(e - e[0])) < 1e-12 * e[0]
    assert energies[0.6][-1] < 0.9 * energies[0.6][0]


def test_amplification_matrix_is_unitary_for_the_trapezoidal_rule():
    for wdt in (0.1, 2.0, 50.0):
        assert np.allclose(np.abs(amplification_eigenvalues(wdt, 0.25, 0.5)), 1.0, atol=1e-12)
        assert max(abs(amplification_eigenvalues(wdt, 0.3025, 0.6))) < 1.0


# ---------------------------------------------------------------------------------------------
# FE tests


def implicit_smoke(*overrides):
    pytest.importorskip("dolfinx")
    from stickslip.solver.scene import load_scene

    return load_scene("scenes/smoke.toml", ["output.progress=false", "time.beta1=0.25",
                                            "time.beta2=0.5", *overrides])


def test_scene_picks_the_implicit_scheme_and_allows_large_steps():
    pytest.importorskip("dolfinx")
    from stickslip.solver.run import Simulation

    sim = Simulation(implicit_smoke("time.dt_fraction=5"), SELF)
    assert isinstance(sim.integrator, ImplicitNewmark)
    assert sim.dt == pytest.approx(5 * sim.dt_crit, rel=1e-12)


def test_steady_sliding_is_a_fixed_point_of_the_implicit_scheme():
    """No perturbation, dt = 5 x the explicit limit: nothing moves beyond round-off, every
    node slips with q = f p (same checks as the explicit test in test_solver_fe.py; 40 steps,
    before the flutter instability can amplify round-off)."""
    pytest.importorskip("dolfinx")
    from conftest import assert_steady_sliding_stays

    from stickslip.solver.run import Simulation

    sim = Simulation(implicit_smoke('initial.perturbation="none"', "time.dt_fraction=5"), SELF)
    assert_steady_sliding_stays(sim, 40)
    assert max(sim.integrator.iterations) == 1  # the warm-started set is already right


@pytest.mark.parametrize("f", [0.0, 0.7])
def test_non_penetration_stick_and_exact_energy_identity(f):
    """Every step: u_r >= d exactly, contact nodes at u_r = d, stick nodes move R Omega dt,
    and E_{n+1} - E_n = r_{n+1} . (u_{n+1} - u_n) (the scheme's energy identity for
    beta1 = 1/4, beta2 = 1/2, module docstring). So with f = 0 the energy never grows (impacts
    dissipate, lift-off is free) and between impacts it is conserved exactly."""
    pytest.importorskip("dolfinx")
    from stickslip.solver.contact import SEPARATION, STICK
    from stickslip.solver.run import Simulation

    sim = Simulation(implicit_smoke(f"loading.f={f}", "time.end_time=0.1"), SELF)
    integ, proj, m = sim.integrator, sim.columns.projection, sim.problem.mass
    d = sim.scene.geometry.d
    idx = proj.node_index
    z = np.empty(idx.size, dtype=complex)
    seen, n_stick = set(), 0
    energies, work = [], [0.0]
    u_old = u_prev_prev = None
    for _ in range(700):
        integ.step()
        # exposed level n: u_prev = u_n, v = v_n, ku = K u_n, out / r_xy = r_n
        energies.append(0.5 * integ.v @ (m * integ.v) + 0.5 * integ.u_prev @ integ.ku)
        if u_old is not None:
            du = proj.complex_view(integ.u_prev)[idx] - proj.complex_view(u_old)[idx]
            work.append(work[-1] + np.vdot(proj.r_xy, du).real)
        u_old = integ.u_prev.copy()
        u_r = proj.polar_at_nodes(integ.u_prev, z).real.copy()
        status = proj.out.status
        seen.update(np.unique(status).tolist())
        # non-penetration: round-off of two triangular solves, ~1e-14 d measured
        assert u_r.min() >= d * (1 - 1e-12)
        assert np.allclose(u_r[status != SEPARATION], d, rtol=1e-12, atol=0)
        stick = status == STICK
        if stick.any() and u_prev_prev is not None:
            _, t_prev = sim.problem.polar(u_prev_prev)
            _, t_now = sim.problem.polar(integ.u_prev)
            assert np.allclose(t_now[stick] - t_prev[stick], proj.slide, rtol=1e-9, atol=0)
            n_stick += 1
        u_prev_prev = integ.u_prev.copy()
    e, w = np.array(energies), np.array(work)
    # identity to round-off: 1e-12 of the energy (measured 2e-15 per step)
    assert np.max(np.abs(e - e[0] - w)) < 1e-11 * e.max()
    assert SEPARATION in seen
    if f == 0.0:
        assert np.all(np.diff(e) <= 1e-12 * e[0])  # never grows
    else:
        assert seen == {0, 1, 2} and n_stick > 10
    mean_it = np.mean(integ.iterations)
    assert 1.0 <= mean_it < 4.0, mean_it  # measured 1.0 (f = 0) and 2.2 (f = 0.7)


def test_short_run_same_mode_as_explicit():
    """Smoke scene to t = 0.1 s (N = 36): the explicit scheme (beta2 = 0.6) and the implicit
    trapezoidal rule at the same dt both end in a mode-4 wave with separation travelling
    against the rotation at about -2.4 km/s. They differ in the regime: explicit measured
    slip-separation (-2470 m/s), implicit stick-slip-separation (-2358 m/s, 14 % stick, as the
    explicit N = 132 run), see docs/stability.md."""
    pytest.importorskip("dolfinx")
    from stickslip.solver.run import Simulation
    from stickslip.solver.scene import load_scene
    from stickslip.studies.rundir import summarise

    out = {}
    for name, sc in (
        ("explicit", load_scene("scenes/smoke.toml", ["output.progress=false",
                                                      "time.end_time=0.1"])),
        ("implicit", implicit_smoke("time.end_time=0.1", "time.dt_fraction=1")),
    ):
        sim = Simulation(sc, SELF)
        sim.proceed()
        out[name] = summarise(sim)
    ex, im = out["explicit"], out["implicit"]
    assert ex["mode"] == im["mode"] == 4
    assert ex["fractions"]["separation"] > 0.4 and im["fractions"]["separation"] > 0.4
    # same wave speed within 10 % (measured 4.5 %: the two time discretisations differ)
    assert im["celerity_m_s"] == pytest.approx(ex["celerity_m_s"], rel=0.1)
    assert ex["celerity_m_s"] < 0


@pytest.mark.parallel
def test_implicit_serial_and_parallel_runs_agree():
    """Same statuses and u on 1 and COMM_WORLD ranks over 150 steps (Schur complement
    gathered to rank 0; MUMPS in parallel vs PETSc LU in serial: round-off differences,
    amplified by the flutter instability, hence 1e-9 relative)."""
    pytest.importorskip("dolfinx")
    from stickslip.solver.run import Simulation

    sc = implicit_smoke("time.end_time=0.015", "output.sample_interval=0.001")
    results = {}
    for name, comm in (("serial", SELF), ("world", MPI.COMM_WORLD)):
        sim = Simulation(sc, comm)
        sim.proceed()
        if comm.rank == 0:
            results[name] = sim.recorder.arrays()
        assert sim.integrator.step_count >= 150
    if MPI.COMM_WORLD.rank == 0:
        a, b = results["serial"], results["world"]
        np.testing.assert_array_equal(a["status"], b["status"])
        scale = np.max(np.abs(a["u_r"]))
        assert np.max(np.abs(a["u_r"] - b["u_r"])) < 1e-9 * scale
        assert np.max(np.abs(a["u_theta"] - b["u_theta"])) < 1e-9 * scale


def _work_precision_module():
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "benchmarks" / "work_precision.py"
    spec = importlib.util.spec_from_file_location("work_precision", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_work_precision_smoke_mode(tmp_path):
    """The CI version of benchmarks/work_precision.py: 2 points + their reference (~3 s)."""
    pytest.importorskip("dolfinx")
    wp = _work_precision_module()
    res = wp.smoke(tmp_path / "cache.json")
    assert set(res) == {"explicit b2=0.6", "implicit b1=1/4 b2=1/2"}
    for r in res.values():
        assert r["finite"] and r["wall_s"] > 0
        assert all(np.isfinite(v) and v >= 0 for v in r["errors"].values())
    # the generated-doc blocks are replaced in place, prose kept
    doc = tmp_path / "doc.md"
    doc.write_text("intro\n<!-- BEGIN t -->\nold\n<!-- END t -->\noutro\n")
    wp.replace_block(doc, "t", "new")
    assert doc.read_text() == "intro\n<!-- BEGIN t -->\nnew\n<!-- END t -->\noutro\n"


def test_exact_work_at_the_observers_level_closes_the_sampled_energy():
    """work_totals(exposed=True) is the work up to the level the recorder samples, so
    E_sample - E_0 - W matches to round-off at every sample (the proposed observers' input)."""
    pytest.importorskip("dolfinx")
    from stickslip.solver.run import Simulation

    sim = Simulation(implicit_smoke("time.end_time=0.01"), SELF)
    integ, proj, m = sim.integrator, sim.columns.projection, sim.problem.mass
    e0 = None
    worst = 0.0
    for _ in range(100):
        integ.step()
        e = 0.5 * integ.v @ (m * integ.v) + 0.5 * integ.u_prev @ integ.ku
        e0 = e if e0 is None else e0
        work, _ = proj.work_totals(exposed=True)
        worst = max(worst, abs(e - e0 - work) / e)
    assert worst < 1e-12  # measured ~1e-15
