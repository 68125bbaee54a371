"""Shared pytest configuration.

Parallel tests are marked ``@pytest.mark.parallel``; ``tests/run.sh`` runs them once serially
and once under ``mpirun -n 2``. Under mpirun only rank 0 writes the JUnit report, so the
summary counts each parallel test once.

The suite runs with SIGINT as a terminal delivers it (Python's KeyboardInterrupt), however it
was launched: a script's background job (``cmd &`` without job control) inherits SIGINT
ignored, and the CLI keeps an ignored SIGINT ignored (as ``nohup`` asks), so the tests that
interrupt a command on purpose would otherwise see it run on. Their children inherit the
default disposition too.
"""

import os
import signal

import numpy as np
import pytest

MPI_RANK = int(os.environ.get("OMPI_COMM_WORLD_RANK", os.environ.get("PMI_RANK", "0")))


@pytest.hookimpl(tryfirst=True)
def pytest_configure(config: pytest.Config) -> None:
    if MPI_RANK > 0:
        config.option.xmlpath = None
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


def assert_steady_sliding_stays(sim, steps: int = 40) -> np.ndarray:
    """Step an unperturbed ``Simulation`` ``steps`` times: every node slips, nothing moves
    beyond round-off (1e-13 of u, 1e-12 of the slide velocity) and q = f p at every node
    (f = 0.7 of the smoke scene). The shared check of the explicit and implicit schemes'
    fixed point; returns u_0."""
    from stickslip.solver.contact import SLIP

    u0 = sim.integrator.u.copy()
    scale = np.max(np.abs(u0))
    for _ in range(steps):
        sim.integrator.step()
        assert np.all(sim.columns.projection.out.status == SLIP)
    assert np.max(np.abs(sim.integrator.u - u0)) < 1e-13 * scale
    assert np.max(np.abs(sim.integrator.v)) < 1e-12 * sim.columns.projection.slide / sim.dt
    # tangential force = f x normal force (Coulomb, sliding forward)
    out = sim.columns.projection.out
    assert np.allclose(out.r_t, 0.7 * out.r_r, rtol=1e-10)
    return u0


def step_checking_contact(sim, steps: int, each=None) -> tuple[set, int]:
    """Step ``sim`` ``steps`` times; after every step assert the contact constraints of the
    forward-increment projection: no penetration and contact nodes exactly on the cylinder
    (to 1e-12 d, round-off), stick nodes moved exactly with the cylinder surface (R Omega dt,
    1e-9: the tangential increment is a difference of O(1) polar components). ``each(status)``
    adds a law-specific check. Returns (statuses seen, number of steps with a stick node)."""
    from stickslip.solver.contact import SEPARATION, STICK

    integ, proj = sim.integrator, sim.columns.projection
    d = sim.scene.geometry.d
    seen: set = set()
    n_stick = 0
    for _ in range(steps):
        integ.step()
        u_r, u_t = sim.problem.polar(integ.u)
        _, u_t_prev = sim.problem.polar(integ.u_prev)
        status = proj.out.status
        seen.update(np.unique(status).tolist())
        assert u_r.min() >= d * (1 - 1e-12)
        contact = status != SEPARATION
        assert np.allclose(u_r[contact], d, rtol=1e-12, atol=0)
        stick = status == STICK
        if stick.any():
            assert np.allclose(u_t[stick] - u_t_prev[stick], proj.slide, rtol=1e-9, atol=0)
            n_stick += 1
        if each is not None:
            each(status)
    return seen, n_stick


def peaks_just_below_and_above(make_integrator, u0: np.ndarray, factors=(0.97, 1.03),
                               steps: int = 4000) -> list[float]:
    """max |u| after ``steps`` steps from (u0, 0) with dt = factor x dt_crit, one per factor:
    the stability-limit check (``make_integrator(factor)`` builds the integrator). A stable
    run stays O(max |u0|); an unstable one overflows or grows by > 1e6 in 4000 steps."""
    peaks = []
    for factor in factors:
        integ = make_integrator(factor)
        integ.set_state(u0, np.zeros_like(u0))
        with np.errstate(all="ignore"):
            for _ in range(steps):
                integ.step()
        peaks.append(float(np.max(np.abs(integ.u))))
    return peaks


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    """A finished smoke run to 0.005 s (``test_ownership.run``), made once per module and
    copied by each test that changes it."""
    pytest.importorskip("dolfinx")
    from test_ownership import run

    d = tmp_path_factory.mktemp("done") / "r"
    assert run(d)["status"] == "completed"
    return d


def explicit_stepper(mult, inv_mass: np.ndarray, dt: float, beta2: float = 0.5, contact=None,
                     tau: float = 0.0):
    """The numpy explicit step of M a + K (u + tau v~) = r given by ``mult(u, out)`` (out =
    K u), the inverse lumped mass (0: a held dof) and ``contact`` (``ContactStep``): a
    batch of one with these operators (``solver.scene_explicit.operator_stepper``)."""
    from stickslip.solver.ensemble import BatchedProblem
    from stickslip.solver.scene_explicit import operator_stepper

    inv_mass = np.asarray(inv_mass, dtype=float)
    mass = np.divide(1.0, inv_mass, out=np.zeros_like(inv_mass), where=inv_mass > 0)
    return operator_stepper(BatchedProblem.without_matrix(mass, inv_mass, dt, beta2), mult,
                            contact, tau)
