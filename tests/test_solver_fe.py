"""FE explicit solver: discrete fixed point, exact contact constraints, stability limit, runs.

Scene: scenes/smoke.toml (Figure-3 physics, N = 36, 2 layers) so every test takes seconds.
"""

import json

import numpy as np
import pytest

pytest.importorskip("dolfinx")

from conftest import (  # noqa: E402
    assert_steady_sliding_stays,
    explicit_stepper,
    peaks_just_below_and_above,
    step_checking_contact,
)
from mpi4py import MPI  # noqa: E402

from stickslip.solver.contact import SEPARATION, SLIP, STICK  # noqa: E402
from stickslip.solver.problem import build_problem, omega_max  # noqa: E402
from stickslip.solver.run import Simulation, StepTooLarge  # noqa: E402
from stickslip.solver.scene import load_scene  # noqa: E402
from stickslip.studies.rundir import run_scene  # noqa: E402

SELF = MPI.COMM_SELF


def smoke(*overrides):
    return load_scene("scenes/smoke.toml", ["output.progress=false", *overrides])


def test_steady_sliding_is_a_fixed_point_of_the_scheme():
    """No perturbation: nothing moves beyond round-off, every node slips (steady sliding).

    Steady sliding is flutter-unstable (paper section 2), so round-off is amplified
    exponentially: on this mesh the deviation stays at 1e-15 for ~50 steps, then grows
    ~700 /s (1e-9 after 300 steps) until the wave saturates. The fixed point is checked over
    the first 40 steps, where only round-off can act; the growth is checked to be real
    instability (monotone, by orders of magnitude), not a wrong fixed point (which would
    show up at step 1).
    """
    sim = Simulation(smoke("initial.perturbation=\"none\""), SELF)
    u0 = assert_steady_sliding_stays(sim, 40)
    scale = np.max(np.abs(u0))
    for _ in range(360):
        sim.integrator.step()
    assert np.max(np.abs(sim.integrator.u - u0)) > 1e-11 * scale  # flutter amplifies round-off


def test_non_penetration_and_exact_stick_after_every_step():
    sim = Simulation(smoke("time.end_time=0.25", "mesh.n_inner=72", "mesh.n_radial=0"), SELF)
    seen, n_stick_checks = step_checking_contact(sim, 2500)
    assert seen == {SEPARATION, STICK, SLIP}, "the test must exercise all three statuses"
    assert n_stick_checks > 10


def test_explicit_limit_on_the_fe_matrices():
    """dt_crit = sqrt(2/beta2)/w_max with SLEPc's w_max: 3 % below bounded, 3 % above blows up."""
    problem = build_problem(smoke(), SELF)
    w_max = omega_max(problem)
    rng = np.random.default_rng(3)
    u0 = rng.normal(size=problem.n_owned) * 1e-3
    u0[problem.clamped] = 0.0
    for beta2 in (0.5, 0.8):
        dt_crit = np.sqrt(2 / beta2) / w_max
        def explicit(factor, b2=beta2, dtc=dt_crit):
            return explicit_stepper(problem.stiffness_mult(), problem.inv_mass, factor * dtc,
                                    b2)

        results = peaks_just_below_and_above(explicit, u0)
        assert results[0] < 10 * np.max(np.abs(u0))
        assert not np.isfinite(results[1]) or results[1] > 1e6 * np.max(np.abs(u0))


def test_time_step_above_the_limit_is_refused_with_the_limit_in_the_message():
    sim = Simulation(smoke(), SELF)
    with pytest.raises(StepTooLarge, match=r"stability limit dt_crit = .* Use time.dt <="):
        Simulation(smoke(f"time.dt={1.05 * sim.dt_crit}"), SELF)


def test_discrete_steady_pressure_converges_to_the_closed_form():
    """p_e = E delta (xi^2 + 1/(1-2nu)) / ((xi^2-1)(1+nu)) (paper section 2), P1: O(h^2)."""
    errors = []
    for n in (24, 48, 96):
        sc = smoke(f"mesh.n_inner={n}", "mesh.n_radial=0")
        sim_p = build_problem(sc, SELF)
        from stickslip.solver.steady import solve_steady_sliding

        st = solve_steady_sliding(sim_p)
        g, m = sc.geometry, sc.material
        p_e = m.E * g.delta * (g.xi**2 + 1 / (1 - 2 * m.nu)) / ((g.xi**2 - 1) * (1 + m.nu))
        errors.append(abs(np.mean(st.pressure) - p_e) / p_e)
    rates = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    # second order (P1 with a polygonal boundary: O(h^2)); 1.7 leaves room for pre-asymptotics
    assert np.all(rates > 1.7), (errors, rates)
    assert errors[-1] < 2e-3


def test_run_directory_summary_and_refusal_to_overwrite(tmp_path):
    run_dir = tmp_path / "run"
    s = run_scene(smoke(), run_dir, comm=SELF, stream=open("/dev/null", "w"))
    assert s["status"] == "completed"
    on_disk = json.loads((run_dir / "summary.json").read_text())
    for key in ("status", "regime", "mode", "celerity_m_s", "frequency_hz", "fractions",
                "amplitude_m", "limit_cycle", "steps", "dt_s", "dofs", "ranks", "wall_time_s"):
        assert key in on_disk
    assert on_disk["fractions"]["separation"] + on_disk["fractions"]["stick"] \
        + on_disk["fractions"]["slip"] == pytest.approx(1.0)
    assert (run_dir / "samples.npz").exists() and (run_dir / "scene.toml").exists()
    with pytest.raises(FileExistsError, match="--force"):
        run_scene(smoke(), run_dir, comm=SELF)


def test_divergence_is_reported_not_hidden(tmp_path, monkeypatch):
    """A blow-up stops the run, keeps the diagnostics and writes status 'diverged'."""
    import stickslip.solver.schemes.select  # noqa: F401 (loaded: used as an attribute)
    from stickslip import solver

    real = solver.schemes.select.critical_time_step
    monkeypatch.setattr(
        solver.schemes.select, "critical_time_step",
        lambda w, b1, b2, tau=0.0: 1.6 * real(w, b1, b2, tau)
    )
    s = run_scene(smoke(), tmp_path / "div", comm=SELF, stream=open("/dev/null", "w"))
    assert s["status"] == "diverged"
    assert "energy" in s["message"] or "non-finite" in s["message"]
    assert json.loads((tmp_path / "div" / "summary.json").read_text())["status"] == "diverged"
    assert np.load(tmp_path / "div" / "samples.npz")["t"].size > 0


def test_interrupt_leaves_a_valid_partial_run_directory(tmp_path, monkeypatch):
    def interrupted(self, *args, **kwargs):
        for _ in range(50):
            self.integrator.step()
        raise KeyboardInterrupt

    monkeypatch.setattr(Simulation, "proceed", interrupted)
    s = run_scene(smoke(), tmp_path / "int", comm=SELF, stream=open("/dev/null", "w"))
    assert s["status"] == "interrupted"
    assert json.loads((tmp_path / "int" / "summary.json").read_text())["status"] == "interrupted"


@pytest.mark.parallel
def test_serial_and_parallel_runs_agree():
    """Same statuses and u on 1 and COMM_WORLD ranks over ~1940 steps (t = 0.15 s).

    The partitions sum the MatMult in different orders, so u differs by round-off; the
    stick-slip-separation limit cycle amplifies it (measured on 2 ranks, relative to max u_r:
    2e-17 at t = 0, 4e-13 at 0.03 s, 2e-12 at 0.09 s, 1.4e-11 at 0.15 s, 7e-10 at 0.3 s).
    Hence 1e-10 at 0.15 s: round-off growth, not a partition-dependent result. The contact
    statuses must agree exactly.
    """
    sc = smoke("time.end_time=0.15", "output.sample_interval=0.001")
    results = {}
    for name, comm in (("serial", SELF), ("world", MPI.COMM_WORLD)):
        sim = Simulation(sc, comm)
        sim.proceed()
        if comm.rank == 0:
            results[name] = sim.recorder.arrays()
        assert sim.integrator.step_count > 1900
    if MPI.COMM_WORLD.rank == 0:
        a, b = results["serial"], results["world"]
        np.testing.assert_array_equal(a["theta"], b["theta"])
        np.testing.assert_array_equal(a["status"], b["status"])
        scale = np.max(np.abs(a["u_r"]))
        assert np.max(np.abs(a["u_r"] - b["u_r"])) < 1e-10 * scale
        assert np.max(np.abs(a["u_theta"] - b["u_theta"])) < 1e-10 * scale
