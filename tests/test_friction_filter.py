"""The 1-2-1 filtered friction bound (docs/friction_filter.md).

Law (``solver.contact.project_contact_filtered``): normal projection unchanged, then the
tangential projection with bound f p~_i, p~_i = in_contact_i (p_{i-1} + 2 p_i + p_{i+1}) / 4
along the angle-ordered contact circle (periodic).
"""

import numpy as np
import pytest
from conftest import step_checking_contact

from stickslip.solver.contact import (
    SEPARATION,
    SLIP,
    STICK,
    ContactArrays,
    NeighbourFilter,
    project_contact,
    project_contact_filtered,
)
from stickslip.solver.fused import numba_available
from stickslip.solver.scene import SceneError, load_scene
from stickslip.solver.schemes import resolve_kernel


def test_filter_is_the_periodic_1_2_1_stencil_in_angle_order():
    """Nodes stored in a shuffled local order: p~ equals (roll(-1) + 2 p + roll(+1)) / 4 in
    angle order, wraps around the circle, is zero off contact, and keeps a uniform p exactly
    (steady sliding unchanged)."""
    rng = np.random.default_rng(1)
    n = 37
    gidx = rng.permutation(n)  # global (angle) rank of each locally stored node
    p_sorted = rng.uniform(0, 1, n)
    expect = (np.roll(p_sorted, 1) + 2 * p_sorted + np.roll(p_sorted, -1)) / 4
    filt = NeighbourFilter(gidx, n)
    contact = rng.uniform(size=n) < 0.7
    got = filt.apply(p_sorted[gidx], contact)
    np.testing.assert_allclose(got, np.where(contact, expect[gidx], 0.0), rtol=1e-15)
    uniform = filt.apply(np.full(n, 0.3), np.ones(n, bool))
    assert np.array_equal(uniform, np.full(n, 0.3))  # (0.3 + 0.6 + 0.3) / 4: exact in binary


def test_filtered_projection_keeps_normal_step_and_uses_filtered_bound():
    """Random trial states with all three statuses: r_r identical to Coulomb's (the normal
    step is untouched), slip forces on f p~, stick forces inside f p~, none off contact."""
    rng = np.random.default_rng(5)
    n, kappa, d, slide, f = 400, 1e-9, 1e-3, 1e-4, 0.7
    mass = rng.uniform(1, 2, n)
    a, b = ContactArrays(n), ContactArrays(n)
    filt = NeighbourFilter(np.arange(n), n)
    ur = d + rng.normal(scale=1e-4, size=n)
    ut_prev = rng.normal(scale=1e-4, size=n)
    ut = ut_prev + slide + rng.normal(scale=1e-4, size=n)
    project_contact(ur, ut, ut_prev, mass, kappa, d, slide, f, a)
    project_contact_filtered(ur, ut, ut_prev, mass, kappa, d, slide, f, filt, b)
    assert np.array_equal(a.r_r, b.r_r)
    assert set(np.unique(b.status)) == {SEPARATION, STICK, SLIP}
    p = b.r_r
    pf = (np.roll(p, 1) + 2 * p + np.roll(p, -1)) / 4 * (p > 0)
    slip, stick = b.status == SLIP, b.status == STICK
    np.testing.assert_allclose(np.abs(b.r_t[slip]), f * pf[slip], rtol=1e-14)
    assert np.all(np.abs(b.r_t[stick]) <= f * pf[stick])
    assert np.all(b.r_t[b.status == SEPARATION] == 0.0)
    assert not np.array_equal(a.status, b.status)  # the bound really changed


def test_prakash_clifton_relaxes_towards_the_filtered_pressure():
    """Composition: sigma_eff relaxes towards p~ (not p). With L -> 0 (exp(-rate dt) = 0)
    the regularised filtered law is the filtered Coulomb law bit for bit."""
    from stickslip.solver.contact import EffectivePressure, PrakashClifton

    rng = np.random.default_rng(7)
    n, kappa, d, slide, f = 300, 1e-9, 1e-3, 1e-4, 0.7
    mass = rng.uniform(1, 2, n)
    a, b = ContactArrays(n), ContactArrays(n)
    fa, fb = NeighbourFilter(np.arange(n), n), NeighbourFilter(np.arange(n), n)
    eff = EffectivePressure(n, PrakashClifton(slip_length=1e-300, reference_velocity=1.0),
                            1e-6)
    for _ in range(4):
        ur = d + rng.normal(scale=1e-4, size=n)
        ut_prev = rng.normal(scale=1e-4, size=n)
        ut = ut_prev + slide + rng.normal(scale=1e-4, size=n)
        project_contact_filtered(ur, ut, ut_prev, mass, kappa, d, slide, f, fa, a)
        project_contact_filtered(ur, ut, ut_prev, mass, kappa, d, slide, f, fb, b, eff)
        assert np.array_equal(a.r_t, b.r_t) and np.array_equal(a.status, b.status)
        assert np.array_equal(eff.sigma, fb.p)


def test_filter_option_is_validated():
    sc = load_scene("scenes/smoke.toml")
    assert sc.friction.filter == "nodal" and not sc.friction.filtered
    with pytest.raises(SceneError, match=r"friction.filter = '121' is not allowed.*1-2-1"):
        load_scene("scenes/smoke.toml", ['friction.filter="121"'])
    with pytest.raises(SceneError, match=r"friction.filter = '1-2-1' needs the explicit"):
        load_scene("scenes/smoke.toml", ['friction.filter="1-2-1"', "time.beta1=0.25",
                                         "time.dt_fraction=2"])


def test_kernel_falls_back_to_numpy_for_physics_the_fused_kernel_lacks():
    """THE fallback rule uses this branch's real keys: a filtered scene never runs on the
    fused kernel; damped and regularised scenes do (the kernels have that physics)."""
    fused = "numba" if numba_available() else "numpy"
    plain = load_scene("scenes/smoke.toml")
    assert resolve_kernel(plain) == fused
    for ov in (["damping.retardation_time=2e-6"],
               ["damping.loss_factor=0.02", "damping.reference_frequency_hz=1600"],
               ['friction.regularization="constant-time"', "friction.relaxation_time=1e-4"],
               ['friction.regularization="prakash-clifton"', "friction.slip_length=1e-5",
                "friction.reference_velocity=1"]):
        assert resolve_kernel(load_scene("scenes/smoke.toml", ov)) == fused, ov
    for ov in (['friction.filter="1-2-1"'],
               ['friction.filter="1-2-1"', "damping.retardation_time=2e-6"]):
        assert resolve_kernel(load_scene("scenes/smoke.toml", ov)) == "numpy", ov


pytest.importorskip("dolfinx")

from mpi4py import MPI  # noqa: E402

from stickslip.solver.contact import ContactProjection, FilteredContactProjection  # noqa: E402
from stickslip.solver.run import Simulation  # noqa: E402

SMALL = ["output.progress=false", "mesh.n_inner=72", "mesh.n_radial=0", 'time.kernel="numpy"']


def test_nodal_default_is_the_unchanged_coulomb_projection():
    """filter = "nodal" (explicit or default) runs the pre-existing ContactProjection class:
    same code path, hence bit-identical to before; a written "nodal" changes nothing."""
    a = Simulation(load_scene("scenes/smoke.toml", [*SMALL, "time.end_time=0.02"]),
                   MPI.COMM_SELF)
    b = Simulation(load_scene("scenes/smoke.toml", [*SMALL, "time.end_time=0.02",
                                                    'friction.filter="nodal"']), MPI.COMM_SELF)
    assert type(a.columns.projection) is ContactProjection
    assert type(b.columns.projection) is ContactProjection
    for _ in range(300):
        a.integrator.step()
        b.integrator.step()
    assert np.array_equal(a.integrator.u, b.integrator.u)


def test_non_penetration_and_exact_stick_with_the_filter():
    """FE run (N = 72, smoke physics) with the filter: after every step u_r >= d (1e-12 d),
    contact nodes sit on the cylinder, stick nodes advance R Omega dt (round-off: 1e-9 of
    it, the subtraction of two ~1e-4 m displacements), slip forces lie on f p~; all three
    statuses occur."""
    sc = load_scene("scenes/smoke.toml", [*SMALL, "time.end_time=0.25",
                                          'friction.filter="1-2-1"'])
    sim = Simulation(sc, MPI.COMM_SELF)
    proj = sim.columns.projection
    assert isinstance(proj, FilteredContactProjection)
    f = sc.loading.f

    def slip_on_the_filtered_bound(status):
        slip = status == SLIP
        np.testing.assert_allclose(np.abs(proj.out.r_t[slip]), f * proj.filter.p[slip],
                                   rtol=1e-12)

    seen, n_stick = step_checking_contact(sim, 2500, slip_on_the_filtered_bound)
    assert seen == {SEPARATION, STICK, SLIP}
    assert n_stick > 10


@pytest.mark.parallel
def test_filter_is_rank_count_independent():
    """Serial and COMM_WORLD runs with the filter: identical statuses, u to round-off (1e-10
    of max u_r at 0.15 s, the MatMult summation-order growth measured in test_solver_fe)."""
    sc = load_scene("scenes/smoke.toml", ["output.progress=false", "time.end_time=0.15",
                                          "output.sample_interval=0.001",
                                          'friction.filter="1-2-1"'])
    results = {}
    for name, comm in (("serial", MPI.COMM_SELF), ("world", MPI.COMM_WORLD)):
        sim = Simulation(sc, comm)
        sim.proceed()
        if comm.rank == 0:
            results[name] = sim.recorder.arrays()
    if MPI.COMM_WORLD.rank == 0:
        a, b = results["serial"], results["world"]
        np.testing.assert_array_equal(a["status"], b["status"])
        assert {SEPARATION, SLIP} <= set(np.unique(a["status"]).tolist())  # nonlinear regime
        scale = np.max(np.abs(a["u_r"]))
        assert np.max(np.abs(a["u_r"] - b["u_r"])) < 1e-10 * scale
        assert np.max(np.abs(a["u_theta"] - b["u_theta"])) < 1e-10 * scale


def test_seeded_transient_with_the_filter_grows_as_the_filtered_cea_predicts():
    """figure3_n132 with the filter, beta2 = 1/2, mode k = 4 seeded at 1e-6 d, linear phase
    1-8 ms (every node slipping). The explicit solver in sliding is Newmark on
    M u'' + (K + K_f~) u = 0 with the filtered friction operator, which is what
    ``flutter-fe --friction 1-2-1`` builds: the matrix-pencil exponents of U_4(t) must be
    its two k = 4 eigenvalues mapped by ``newmark_exponents`` (tolerance 1e-3: the fit, as in
    test_flutter_fe's nodal version). At k = 4 the filter scales the friction by
    (2 + 2 cos(2 pi k / N)) / 4 = 0.991, so the nodal CEA's leading k = 4 rate is 0.7 % higher
    (1192 vs 1184 /s): the transient must sit > 3e-3 away from it, so the test tells the two
    laws apart. Over all k the filtered CEA has no mesh-scale branch
    above the physical one: its fastest mode is k <= 8 (docs/friction_filter.md)."""
    from stickslip.solver.problem import build_problem
    from stickslip.studies.flutter_fe import (
        complex_eigenvalue_analysis,
        measure_transient_growth,
        newmark_exponents,
    )
    from stickslip.studies.flutter_fe.cea import build_operators, distinct_modes

    scene = load_scene("figure3_n132", ["output.progress=false", 'friction.filter="1-2-1"'])
    problem = build_problem(scene, MPI.COMM_SELF)
    res = complex_eigenvalue_analysis(problem, None, 6000.0,
                                      ops=build_operators(problem, friction="1-2-1"))
    nodal = complex_eigenvalue_analysis(problem, None, 3000.0,
                                        ops=build_operators(problem, friction="nodal"))
    k4 = sorted(distinct_modes(m for m in res.modes if m.wavenumber == 4),
                key=lambda m: -m.growth_rate)
    k4n = sorted(distinct_modes(m for m in nodal.modes if m.wavenumber == 4),
                 key=lambda m: -m.growth_rate)
    assert abs(k4[0].growth_rate / k4n[0].growth_rate - 1) > 0.005
    assert res.unstable()[0].wavenumber <= 8
    g = measure_transient_growth(scene, 4, MPI.COMM_SELF, window=(1e-3, 8e-3))
    assert g.all_slip and g.amplitude_range_m[1] < 1e-5
    for m, (growth, freq, _) in zip(k4[:2], g.exponents[:2], strict=True):
        s = newmark_exponents(np.array([m.omega2_real + 1j * m.omega2_imag]), g.dt_s, 0.5)[0]
        sign = -1.0 if m.direction == "rotation" else 1.0  # U_k of a +theta wave: e^{-iwt}
        assert growth == pytest.approx(s.real, rel=1e-3)
        assert freq == pytest.approx(sign * s.imag / (2 * np.pi), rel=1e-3)
    sn = newmark_exponents(np.array([k4n[0].omega2_real + 1j * k4n[0].omega2_imag]), g.dt_s,
                           0.5)[0]
    assert abs(g.exponents[0][0] / sn.real - 1) > 3e-3
