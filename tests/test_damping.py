"""Kelvin-Voigt damping: stability limit, energy balance, implicit decay, bad input.

The explicit damped scheme (``solver.ensemble.internal_force``) puts the damping
force tau K v~_n on the velocity predictor; its limit (``critical_time_step`` docstring) is
beta2 (w dt)^2 + tau w^2 dt <= 2.
"""

import math

import numpy as np
import pytest
from conftest import explicit_stepper, peaks_just_below_and_above

from stickslip.solver.newmark import critical_time_step
from stickslip.solver.scene import SceneError, load_scene


def chain(n: int = 12, k: float = 4.0e6, m: float = 1.0):
    """Fixed-fixed spring chain: K (tridiagonal), lumped M = m I, and its w_max."""
    K = k * (2 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1))
    w_max = math.sqrt(np.linalg.eigvalsh(K / m).max())

    def mult(u, out):
        np.dot(K, u, out=out)

    return K, np.full(n, 1.0 / m), w_max, mult


def test_damped_limit_formula_matches_the_amplification_matrix():
    """Spectral radius of A = [[1 - kW^2, 1 - kC], [-W^2, 1 - C]] is 1 at the formula's dt."""
    for beta2 in (0.5, 0.6, 0.9):
        for zeta_dt in (0.0, 0.1, 1.0, 10.0):  # tau w for the test mode
            w, tau = 1.0, zeta_dt
            dt = critical_time_step(w, 0.0, beta2, tau)
            radii = []
            for f in (0.999, 1.001):
                W, C, kk = w * dt * f, tau * w * w * dt * f, beta2 + 0.5
                A = np.array([[1 - kk * W * W, 1 - kk * C], [-W * W, 1 - C]])
                radii.append(max(abs(np.linalg.eigvals(A))))
            # just below: |lambda| <= 1 (to round-off); just above: > 1 (a real root < -1)
            assert radii[0] <= 1 + 1e-12 and radii[1] > 1 + 1e-5, (beta2, zeta_dt, radii)
    # central differences: (2/w)(sqrt(1 + zeta^2) - zeta), zeta = tau w / 2
    w, tau = 3.0e4, 2.0e-5
    zeta = tau * w / 2
    assert critical_time_step(w, 0.0, 0.5, tau) == pytest.approx(
        2 / w * (math.sqrt(1 + zeta**2) - zeta), rel=1e-13)
    assert critical_time_step(w, 0.0, 0.6, 0.0) == pytest.approx(math.sqrt(2 / 0.6) / w)


@pytest.mark.parametrize("beta2", [0.5, 0.8])
def test_damped_explicit_stable_just_below_and_unstable_just_above_the_limit(beta2):
    """Spring chain, zeta_max = tau w_max / 2 = 0.6: 2 % below stays bounded over 4000 steps,
    2 % above blows up (the highest mode's root passes -1: growth ~(1.0x)^n)."""
    K, inv_m, w_max, mult = chain()
    tau = 1.2 / w_max
    dt_crit = critical_time_step(w_max, 0.0, beta2, tau)
    assert dt_crit < 0.7 * critical_time_step(w_max, 0.0, beta2)  # damping does cut it
    rng = np.random.default_rng(1)
    u0 = rng.normal(size=inv_m.size)
    peaks = peaks_just_below_and_above(
        lambda factor: explicit_stepper(mult, inv_m, factor * dt_crit, beta2, tau=tau),
        u0, factors=(0.98, 1.02))
    assert peaks[0] < 2 * np.max(np.abs(u0))
    assert not np.isfinite(peaks[1]) or peaks[1] > 1e6 * np.max(np.abs(u0))


def test_damping_work_is_the_work_of_the_applied_damping_force():
    """``DampingWork`` (telescoped, no extra MatMult per step) equals the direct sum
    tau K v~_n . (u_{n+1} - u_{n-1}) / 2 to round-off, and the balance
    E_n - E_0 + W_d closes to O(dt^2) (ratio ~4 per halving of dt)."""
    from stickslip.solver.observers import DampingWork

    K, inv_m, w_max, mult = chain()
    tau = 0.3 / w_max
    u0 = np.random.default_rng(0).normal(size=inv_m.size)  # all modes
    residuals = []
    for frac in (0.2, 0.1):
        dt = frac * critical_time_step(w_max, 0.0, 0.5, tau)
        integ = explicit_stepper(mult, inv_m, dt, 0.5, tau=tau)
        integ.set_state(u0, np.zeros_like(u0))
        work = DampingWork(integ, u0)
        direct, u_older = 0.0, u0.copy()
        n_steps = int(round(2e-2 / dt))
        for _ in range(n_steps):
            vp = integ.v_pred.copy()  # v~_n before the step
            integ.step()
            direct += 0.5 * tau * (K @ vp) @ (integ.u - u_older)
            u_older = integ.u_prev.copy()
            work.after_step(integ)
        integ.refresh_ku()
        w_d = work.local_total(integ)
        assert w_d == pytest.approx(direct, rel=1e-9)  # round-off of ~1e3 step sums
        e0 = 0.5 * u0 @ K @ u0
        e_n = 0.5 * integ.v @ (integ.v / inv_m) + 0.5 * integ.u_prev @ integ.ku
        assert 0.1 * e0 < w_d < e0  # a decaying free vibration: real, partial dissipation
        residuals.append(abs(e_n - e0 + w_d) / e0)
    assert residuals[0] / residuals[1] == pytest.approx(4.0, rel=0.25)  # O(dt^2)


dolfinx = pytest.importorskip("dolfinx")

from mpi4py import MPI  # noqa: E402

from stickslip.solver.problem import build_problem, omega_max  # noqa: E402
from stickslip.solver.run import Simulation  # noqa: E402
from stickslip.solver.schemes import damping_advice  # noqa: E402

SELF = MPI.COMM_SELF


def smoke(*overrides):
    return load_scene("scenes/smoke.toml", ["output.progress=false", *overrides])


def test_damped_limit_on_the_fe_matrices():
    """FE matrices (smoke mesh), tau = 2 us: 3 % below the damped limit bounded, 3 % above
    blows up; the limit is 10-30 % below the undamped one at this zeta_max."""
    problem = build_problem(smoke(), SELF)
    w_max = omega_max(problem)
    tau = 2.0e-5
    rng = np.random.default_rng(3)
    u0 = rng.normal(size=problem.n_owned) * 1e-3
    u0[problem.clamped] = 0.0
    dt_crit = critical_time_step(w_max, 0.0, 0.5, tau)
    assert dt_crit < 0.9 * critical_time_step(w_max, 0.0, 0.5)
    peaks = peaks_just_below_and_above(
        lambda factor: explicit_stepper(problem.stiffness_mult(), problem.inv_mass,
                                        factor * dt_crit, 0.5, tau=tau), u0)
    assert peaks[0] < 10 * np.max(np.abs(u0))
    assert not np.isfinite(peaks[1]) or peaks[1] > 1e6 * np.max(np.abs(u0))


def test_energy_balance_with_damping_closes_at_second_order():
    """Smoke scene with contact, beta2 = 1/2, tau = 2 us: E_n - E_0 - W_contact + W_damping
    shrinks ~4x per halving of dt (second order, as without damping: 0.030 -> 0.0083 of
    max E measured), and the damping removes a real share of the energy fed in."""
    res = []
    for frac in (0.45, 0.225):
        sim = Simulation(smoke("time.beta2=0.5", "time.end_time=0.03",
                               f"time.dt_fraction={frac}", "damping.retardation_time=2e-6"),
                         SELF)
        sim.proceed()
        e = sim.recorder.arrays()["energies"]
        E = e[:, 0] + e[:, 1]
        r = E - E[0] - (e[:, 2] - e[0, 2]) + (e[:, 5] - e[0, 5])
        assert e[-1, 5] > 0.1 * E.max()  # dissipation is not negligible
        assert np.all(np.diff(e[:, 5]) > -1e-9 * E.max())  # it only grows
        res.append(np.abs(r).max() / E.max())
    assert res[1] < 0.02  # 0.8 % measured
    assert 2.8 < res[0] / res[1] < 5.5  # ratio 3.6 measured; 4 is the O(dt^2) value


def test_energy_balance_with_damping_closes_in_the_fused_and_batched_kernels():
    """The damped scene of the test above at dt_fraction = 0.225, run by the numpy
    kernel, the fused kernel and a batch of two (with a second Omega): the fused and
    batched runs record W_d and the other energies of the numpy run to round-off (1e-9 of
    max E: ~400 steps of sums in other orders), so their balance
    E_n - E_0 - W_contact + W_d closes as the numpy one does (0.8 % of max E measured).
    The batch's checkpoints are taken from one host copy of its state."""
    sc = smoke("time.beta2=0.5", "time.end_time=0.03", "time.dt_fraction=0.225",
               "damping.retardation_time=2e-6")
    energies = {}
    for kernel in ("numpy", "numba"):
        sim = Simulation(sc.with_overrides(f'time.kernel="{kernel}"'), SELF)
        assert sim.integrator.facts()["kernel"] == kernel
        sim.proceed()
        energies[kernel] = sim.recorder.arrays()["energies"]
    batch = Simulation.batch([sc, sc.with_overrides("loading.omega=30.0")])
    assert batch.stepper.damped and batch.stepper.B == 2
    copies, host_state = [], batch.stepper.host_state
    batch.stepper.host_state = lambda: (copies.append(1), host_state())[1]
    batch.proceed()
    # every column's checkpoint comes from one host copy of the batch's state (a GPU's
    # arrays cross to the host once, not once per column)
    assert len(copies) == 1
    assert np.array_equal(batch.runs[1].state["stepper/u"], host_state()["u"][:, 1])
    energies["batch"] = batch.runs[0].recorder.arrays()["energies"]
    ref = energies["numpy"]
    scale = (ref[:, 0] + ref[:, 1]).max()
    for kernel, e in energies.items():
        assert e.shape == ref.shape, kernel
        np.testing.assert_allclose(e, ref, rtol=0, atol=1e-9 * scale, err_msg=kernel)
        r = e[:, 0] + e[:, 1] - e[0, 0] - e[0, 1] - (e[:, 2] - e[0, 2]) + (e[:, 5] - e[0, 5])
        assert e[-1, 5] > 0.1 * scale
        assert np.abs(r).max() < 0.02 * scale, kernel


def test_undamped_step_is_the_plain_step():
    """No [damping]: the plain step (one MatMult a step, no damping work, no w arrays)."""
    sc = smoke("time.beta2=0.5")
    problem = build_problem(sc, SELF)
    calls = []
    base = problem.stiffness_mult()
    integ = explicit_stepper(lambda u, out: (calls.append(1), base(u, out)), problem.inv_mass,
                             1e-6)
    assert not integ.damped and integ.batch.w_levels[0].size == 0
    integ.set_state(np.zeros(problem.n_owned), np.zeros(problem.n_owned))
    calls.clear()
    for _ in range(5):
        integ.step()
    assert len(calls) == 5
    sim = Simulation(sc, SELF)
    assert "damping" not in sim.columns.records.parts  # no damping-work observer
    damped = explicit_stepper(base, problem.inv_mass, 1e-6, tau=1e-6)
    assert damped.damped and damped.tau == 1e-6


def test_implicit_damped_free_vibration_decays_at_the_kelvin_voigt_rate():
    """Trapezoidal rule (beta1 = 1/4, beta2 = 1/2), small w dt: a single low mode decays as
    exp(-zeta w t), zeta = tau w / 2 (Kelvin-Voigt). 1 % of the decay exponent: the
    trapezoidal rule's O((w dt)^2) error at w dt = 0.05 is ~2e-4."""
    from petsc4py import PETSc

    from stickslip.solver.implicit import ImplicitNewmark

    K, inv_m, w_max, mult = chain(n=8)
    lam, vec = np.linalg.eigh(K)
    w1 = math.sqrt(lam[0])
    tau = 0.1 / w1  # zeta = 0.05
    A = PETSc.Mat().createAIJ(K.shape, comm=SELF)
    A.setUp()
    for i in range(K.shape[0]):
        cols = np.nonzero(K[i])[0].astype(PETSc.IntType)
        A.setValues(i, cols, K[i, cols])
    A.assemble()
    dt = 0.05 / w1
    integ = ImplicitNewmark(A, 1.0 / inv_m, np.array([], dtype=np.int64), dt, 0.25, 0.5,
                            None, SELF, tau=tau)
    integ.set_state(vec[:, 0], np.zeros(K.shape[0]))
    n = int(round(20 * 2 * math.pi / w1 / dt))
    energy = []
    for _ in range(n):
        integ.step()
        energy.append(0.5 * integ.v @ (integ.v / inv_m) + 0.5 * integ.u_prev @ (K @ integ.u_prev))
    t = dt * np.arange(n)
    # energy ~ exp(-2 zeta w t) (mean over the oscillation): fit the log of period means
    per = int(round(2 * math.pi / w1 / dt))
    m = len(energy) // per
    means = np.array(energy[: m * per]).reshape(m, per).mean(axis=1)
    rate = -np.polyfit(t[: m * per].reshape(m, per).mean(axis=1), np.log(means), 1)[0]
    assert rate == pytest.approx(2 * 0.05 * w1, rel=0.01)


def test_bad_damping_input_is_refused_with_key_and_range():
    for ov, match in (("damping.loss_factor=-0.1", r"damping.loss_factor = -0.1 .*0 <="),
                      ("damping.retardation_time=nan", r"damping.retardation_time = nan"),
                      ("damping.retardation_time=-1e-6", r"retardation_time >= 0"),
                      ("damping.loss_factor=0.02", r"reference_frequency_hz > 0")):
        with pytest.raises(SceneError, match=match):
            smoke(ov)
    with pytest.raises(SceneError, match="not both"):
        smoke("damping.loss_factor=0.02", "damping.reference_frequency_hz=1600",
              "damping.retardation_time=1e-6")
    sc = smoke("damping.loss_factor=0.02", "damping.reference_frequency_hz=1600")
    assert sc.damping.tau == pytest.approx(0.02 / (2 * math.pi * 1600))


def test_collapsing_damped_step_recommends_the_implicit_scheme():
    """tau so large that dt_crit(damped) < 1e-3 dt_crit(undamped): a message names the
    implicit scheme; a mild damping gets none."""
    w = 1.0e5
    assert damping_advice(smoke("damping.retardation_time=1e-6"), w) is None
    text = damping_advice(smoke("damping.retardation_time=1e-1"), w)
    assert text and "implicit" in text and "time.beta1=0.25" in text


def test_implicit_energy_identity_with_damping_and_contact_is_exact():
    """Trapezoidal rule with contact and tau = 2 us (smoke scene): E_n - E_0 = W_contact -
    W_damping to round-off (the damping force has the Newmark weights of the elastic force);
    measured 6e-16 of max E, bound 1e-12 (round-off of ~600 step sums)."""
    sim = Simulation(smoke("time.beta1=0.25", "time.beta2=0.5", "time.dt_fraction=2",
                           "time.end_time=0.03", "damping.retardation_time=2e-6"), SELF)
    sim.proceed()
    e = sim.recorder.arrays()["energies"]
    E = e[:, 0] + e[:, 1]
    assert e[-1, 5] > 0.1 * E.max()
    r = E - E[0] - (e[:, 2] - e[0, 2]) + (e[:, 5] - e[0, 5])
    assert np.abs(r).max() < 1e-12 * E.max()
