"""The finite tube's transient (``mesh.dim`` = 3): the disc-cone law on the contact surface,
the plane-strain limit with roller ends, the energy balance with free ends, and MPI."""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from stickslip.solver.contact import SLIP, STICK, ContactArrays, project_contact
from stickslip.solver.contact.nodal import project_contact_disc

#: The smoke scene's cross-section in quadrilaterals with a step below both limits, and
#: the same tube 0.35 m long in 2 layers (its mid-length ring, z = 0.175 m, is recorded).
PLANE = ("mesh.cell=quadrilateral", "time.dt=9e-5", "output.sample_interval=9e-5")
TUBE = (*PLANE, "mesh.dim=3", "geometry.length=0.35", "mesh.n_axial=2")


def _law_inputs(rng: np.random.Generator, n: int) -> dict:
    """Trial positions about the mismatch d = 1e-3 (a third separate), stick forces inside
    and outside the cone: every status occurs."""
    u_t_prev = rng.normal(0.0, 1e-3, n)
    return dict(u_r_trial=1e-3 + rng.normal(0.0, 3e-4, n),
                u_t_trial=u_t_prev + 2e-4 + rng.normal(0.0, 2e-4, n), u_t_prev=u_t_prev,
                mass=rng.uniform(0.5, 2.0, n))


def test_the_disc_law_is_the_plane_law_bit_for_bit_without_axial_motion():
    """Where u_z~ = u_z,n the disc cone's step is ``project_contact``'s, bit for bit
    (|q_stick| = |q_theta,stick|, q_theta / |q| = +-1 exactly), and r_z = 0."""
    rng = np.random.default_rng(3)
    n = 4000
    inputs = _law_inputs(rng, n)
    u_z = rng.normal(0.0, 1e-3, n)
    plane, disc, r_z = ContactArrays(n), ContactArrays(n), np.zeros(n)
    project_contact(**inputs, kappa=1e-9, d=1e-3, slide=2e-4, f=0.6, out=plane)
    project_contact_disc(inputs["u_r_trial"], inputs["u_t_trial"], u_z, inputs["u_t_prev"],
                         u_z.copy(), inputs["mass"], 1e-9, 1e-3, 2e-4, 0.6, disc, r_z)
    assert {0, STICK, SLIP} <= set(np.unique(plane.status))
    for name in ("r_r", "r_t", "status"):
        np.testing.assert_array_equal(getattr(disc, name), getattr(plane, name))
    assert not r_z.any()


def test_the_regularised_disc_is_the_regularised_plane_law_without_axial_motion():
    """Prakash-Clifton on the disc: over five steps of changing inputs with u_z still, the
    bound f sigma_eff relaxes at the plane law's rate and the forces, statuses and state are
    ``project_contact_regularized``'s, bit for bit (|(x, 0)| = |x| exactly)."""
    from stickslip.solver.contact import EffectivePressure, project_contact_regularized
    from stickslip.solver.contact.law import regularisation_of

    rng = np.random.default_rng(11)
    n, dt = 2000, 1e-5
    reg = regularisation_of("prakash-clifton", slip_length=1e-5, reference_velocity=1.0,
                            relaxation_time=0.0)
    plane, disc = EffectivePressure(n, reg, dt), EffectivePressure(n, reg, dt)
    out_plane, out_disc, r_z = ContactArrays(n), ContactArrays(n), np.zeros(n)
    u_z = rng.normal(0.0, 1e-3, n)
    for _ in range(5):
        inputs = _law_inputs(rng, n)
        project_contact_regularized(**inputs, kappa=1e-9, d=1e-3, slide=2e-4, f=0.6,
                                    effective=plane, out=out_plane)
        project_contact_disc(inputs["u_r_trial"], inputs["u_t_trial"], u_z,
                             inputs["u_t_prev"], u_z.copy(), inputs["mass"], 1e-9, 1e-3,
                             2e-4, 0.6, out_disc, r_z, disc)
        for name in ("r_r", "r_t", "status", "cone"):
            np.testing.assert_array_equal(getattr(out_disc, name), getattr(out_plane, name))
        np.testing.assert_array_equal(disc.sigma, plane.sigma)
        assert not r_z.any()


def test_the_disc_law_slips_along_the_trial_traction_on_the_cone():
    """With axial motion: a sticking node takes its stick force (|q| <= f p); a slipping one
    the return mapping, |q| = f p (1e-15 relative: a division and a product) along the
    stick force (cross product 0 to the same round-off); separated nodes carry nothing;
    f = 0 slips every node in contact with no tangential force."""
    rng = np.random.default_rng(5)
    n, kappa, d, slide, f = 4000, 1e-9, 1e-3, 2e-4, 0.6
    inputs = _law_inputs(rng, n)
    u_z_prev = rng.normal(0.0, 1e-3, n)
    u_z_trial = u_z_prev + rng.normal(0.0, 1e-4, n)
    out, r_z = ContactArrays(n), np.zeros(n)
    args = (inputs["u_r_trial"], inputs["u_t_trial"], u_z_trial, inputs["u_t_prev"],
            u_z_prev, inputs["mass"], kappa, d, slide)
    project_contact_disc(*args, f, out, r_z)
    stiff = inputs["mass"] / kappa
    q_t = stiff * (inputs["u_t_prev"] + slide - inputs["u_t_trial"])
    q_z = stiff * (u_z_prev - u_z_trial)
    cone = f * out.r_r
    stick, slip, apart = out.status == STICK, out.status == SLIP, out.status == 0
    assert stick.sum() > 100 and slip.sum() > 100 and apart.sum() > 100
    np.testing.assert_allclose(out.r_t[stick], q_t[stick], rtol=1e-14)
    np.testing.assert_allclose(r_z[stick], q_z[stick], rtol=1e-14)
    assert np.all(np.hypot(out.r_t, r_z)[stick] <= cone[stick])
    np.testing.assert_allclose(np.hypot(out.r_t, r_z)[slip], cone[slip], rtol=1e-15)
    cross = out.r_t * q_z - r_z * q_t
    assert np.all(np.abs(cross[slip]) <= 1e-15 * (np.hypot(q_t, q_z) * cone)[slip])
    assert np.all(np.sign(out.r_t[slip]) == np.sign(q_t[slip]))
    assert not (out.r_r[apart].any() or out.r_t[apart].any() or r_z[apart].any())
    project_contact_disc(*args, 0.0, out, r_z)
    assert not (out.r_t.any() or r_z.any())
    np.testing.assert_array_equal(out.status, np.where(out.r_r > 0, SLIP, 0))


def test_a_tube_with_roller_ends_runs_the_plane_strain_wave(tmp_path):
    """Roller ends (u_z = 0) keep the plane-strain fields: the 3D tube's mid-length ring is
    the 2D scene in quadrilaterals, step by step (smoke physics, 223 steps of 9e-5 s).
    u and v agree to 1e-9 of their largest value (measured 9e-13: the two assemblies sum in
    other orders and the flutter-unstable transient amplifies the round-off; a modelling
    difference, e.g. an axial coupling, shows at 1e-3 and above), the statuses exactly, the
    nodal forces by the ring's share of the length (dz = 0.175 m: N against N/m), and the
    wave analysis gives the same k and celerity. u_z stays 0 to round-off of u, and every
    ring of ``surface.npz`` is the plane-strain circle (float32: 1e-6); ``--plot`` draws
    the surface unrolled and half the tube."""
    from stickslip import run

    flat = run("smoke", tmp_path / "plane", overrides=list(PLANE), force=True, quiet=True)
    tube = run("smoke", tmp_path / "tube", overrides=[*TUBE, "boundary.ends=roller"],
               force=True, quiet=True, plot=True)
    a = np.load(tmp_path / "plane" / "samples.npz")
    b = np.load(tmp_path / "tube" / "samples.npz")
    for key in ("u_r", "u_theta", "v_r", "v_theta"):
        assert np.max(np.abs(a[key] - b[key])) < 1e-9 * np.max(np.abs(a[key])), key
    np.testing.assert_array_equal(a["status"], b["status"])
    np.testing.assert_allclose(b["r_r"], 0.175 * a["r_r"], rtol=1e-9, atol=1e-9 * a["r_r"].max())
    assert (tube["mode"], tube["regime"]) == (flat["mode"], flat["regime"])
    assert tube["celerity_m_s"] == pytest.approx(flat["celerity_m_s"], rel=1e-9)
    axial = tube["tube_3d"].pop("axial")
    assert tube["tube_3d"] == {"length_m": 0.35, "n_axial": 2, "ends": "roller",
                               "surface_nodes": 108, "ring_z_m": 0.175}
    assert axial["k"] == tube["mode"] and axial["z_m"] == [0.0, 0.175, 0.35]
    assert axial["profile"] == [1.0, 1.0, 1.0] and abs(axial["end_phase_deg"]) < 1e-6
    assert set(tube["energy"]) == {k.replace("_J_per_m", "_J") for k in flat["energy"]}
    u = np.load(tmp_path / "tube" / "final_field.npz")["u"]
    assert u.shape[1] == 3 and np.max(np.abs(u[:, 2])) < 1e-12 * np.max(np.abs(u))
    surface = np.load(tmp_path / "tube" / "surface.npz")
    assert surface["u_r"].shape == (b["t"].size, 3, 36)  # samples, levels z, angles
    np.testing.assert_array_equal(surface["t"], b["t"])
    np.testing.assert_allclose(surface["z"], [0.0, 0.175, 0.35])
    np.testing.assert_allclose(surface["theta"], b["theta"], atol=1e-12)
    for level in range(3):  # every ring is the plane-strain one (float32: 1e-6 relative)
        assert np.max(np.abs(surface["u_r"][:, level] - b["u_r"])) < 1e-6 * np.max(b["u_r"])
        np.testing.assert_array_equal(surface["status"][:, level], b["status"])
    assert np.max(np.abs(surface["u_z"])) < 1e-12 * np.max(np.abs(b["u_r"]))
    from stickslip.studies.verification import compare_run, conclusion

    said = conclusion(compare_run(tmp_path / "tube"))  # against the plane-strain model
    assert "ring z = 0.175 m of a finite tube, L = 0.35 m, roller ends" in said
    assert "finite tube" not in conclusion(compare_run(tmp_path / "plane"))
    made = {p.name for p in (tmp_path / "tube").glob("*.png")}
    assert {"surface.png", "isomap.png"} <= made and "stress.png" not in made


#: The Prakash-Clifton bound (a slip length of 10 um, V* = 1 m/s).
PRAKASH_CLIFTON = ("friction.regularization=prakash-clifton", "friction.slip_length=1e-5",
                   "friction.reference_velocity=1")


@pytest.mark.parametrize("law", [PRAKASH_CLIFTON, ("friction.filter=1-2-1",)],
                         ids=["prakash-clifton", "1-2-1"])
def test_a_roller_tube_runs_the_plane_strain_wave_of_each_bound(tmp_path, law):
    """The regularised bound on the disc, and the 1-2-1 filter along each ring: with roller
    ends the ring is the plane-strain run of the same bound (both numpy) to 1e-9 of u
    (measured 4.3e-13 with Prakash-Clifton), statuses equal (as for Coulomb: the two
    assemblies round otherwise and the flutter amplifies it)."""
    from stickslip import run

    numpy = ("time.kernel=numpy", *law)
    run("smoke", tmp_path / "plane", overrides=[*PLANE, *numpy], force=True, quiet=True)
    run("smoke", tmp_path / "tube", overrides=[*TUBE, *numpy, "boundary.ends=roller"],
        force=True, quiet=True)
    a = np.load(tmp_path / "plane" / "samples.npz")
    b = np.load(tmp_path / "tube" / "samples.npz")
    for key in ("u_r", "u_theta"):
        assert np.max(np.abs(a[key] - b[key])) < 1e-9 * np.max(np.abs(a[key])), key
    np.testing.assert_array_equal(a["status"], b["status"])


def test_a_tube_with_free_ends_balances_its_energy(tmp_path):
    """Free ends: the tube moves along z (Poisson and the disc cone's axial friction), and
    with beta_2 = 1/2 (no numerical dissipation) the residual of E(t) - E(0) = W_contact
    is the scheme's O(dt^2) error: over the first 3 ms (every node slipping, smoke
    physics) it falls 3.98 times when dt halves from 4e-5 s (-38.0 J, then -9.55 J; the
    energies of the finite tube are in J), so the ratio is asserted in [3.5, 4.5]: second
    order, which a missing work term (axial friction, the ends) would break."""
    from stickslip import run

    residual = []
    for dt in (4e-5, 2e-5):
        tube = run("smoke", tmp_path / f"tube{dt}",
                   overrides=[*TUBE, "boundary.ends=free", "time.beta2=0.5",
                              "time.end_time=0.003", f"time.dt={dt}",
                              f"output.sample_interval={dt}"], force=True, quiet=True)
        assert tube["status"] == "completed" and tube["fractions"]["slip"] == 1.0
        residual.append(tube["energy"]["balance_residual_J"])
    assert 3.5 < residual[0] / residual[1] < 4.5, residual
    u = np.load(tmp_path / f"tube{dt}" / "final_field.npz")["u"]
    assert np.max(np.abs(u[:, 2])) > 1e-2 * np.max(np.abs(u))  # it moves along z


def test_a_sweep_runs_3d_tubes_one_by_one(tmp_path):
    """A sweep over the length of a 3D tube: each variant a run of its own (the 3D tube is
    no batch column), its row the mid-length ring's wave with the tube's facts."""
    from stickslip.studies.sweep import load_sweep, run_sweep

    body = ('base = "smoke"\nset = ["time.end_time=0.005", "mesh.cell=quadrilateral", '
            '"mesh.dim=3", "mesh.n_axial=2", "geometry.length=0.3"]\n'
            '[grid]\n"geometry.length" = [0.2, 0.4]\n')
    path = tmp_path / "s.toml"
    path.write_text(body)
    out = tmp_path / "out"
    assert run_sweep(load_sweep(path), out, comm=MPI.COMM_SELF, stream=io.StringIO()) == 0
    lengths = sorted(json.loads(p.read_text())["tube_3d"]["length_m"]
                     for p in out.glob("runs/*/summary.json"))
    assert lengths == [0.2, 0.4]


@pytest.mark.parametrize("law", [(), PRAKASH_CLIFTON], ids=["coulomb", "prakash-clifton"])
def test_a_3d_run_continues_bitwise(tmp_path, law):
    """Free ends, smoke physics: a run to 0.006 s continued to 0.012 s is the run straight
    to 0.012 s, bit for bit: samples.npz, surface.npz (the records before the checkpoint
    in front of the new ones) and the summary but its timers; with the regularised bound
    its state (sigma_eff, the last u_theta and u_z) too."""
    from stickslip import run
    from stickslip.studies.rundir import continue_run

    sets = [*TUBE, "boundary.ends=free", *law]
    full = run("smoke", tmp_path / "full", overrides=[*sets, "time.end_time=0.012"],
               force=True, quiet=True)
    run("smoke", tmp_path / "part", overrides=[*sets, "time.end_time=0.006"], force=True,
        quiet=True)
    cont = continue_run(tmp_path / "part", 0.012, stream=io.StringIO())
    for name in ("samples.npz", "surface.npz"):
        a, b = np.load(tmp_path / "full" / name), np.load(tmp_path / "part" / name)
        assert set(a.files) == set(b.files), name
        for key in a.files:
            np.testing.assert_array_equal(a[key], b[key], err_msg=f"{name}: {key}")
    for key in ("steps", "mode", "celerity_m_s", "frequency_hz", "energy", "tube_3d"):
        assert cont[key] == full[key], key


def test_a_census_counts_the_starts_of_a_3d_tube(tmp_path):
    """``stickslip attractors`` on a 3D tube (smoke physics, L = 0.35 m, free ends): every
    start runs, its class read from its mid-length ring; 3 starts to 0.02 s, no settle leg
    (``max_time`` = ``end_time``): each is accounted for, none lost."""
    from stickslip import attractors

    answer = attractors("smoke", tmp_path / "census", starts=3, meshes=[36],
                        end_time=0.02, max_time=0.02, certify=False, kick=False,
                        overrides=[*TUBE, "boundary.ends=free"], quiet=True)
    assert answer["finished"] and len(answer["starts"]) == 3
    for row in answer["starts"]:
        summary = json.loads((Path(row["run_dir"]) / "summary.json").read_text())
        assert summary["tube_3d"]["ends"] == "free" and summary["status"] == "completed"


def test_the_wave_frame_certificates_say_they_are_plane_strain(tmp_path):
    """The census's certificates that work in the wave's frame of the contact circle, the
    direct solver and the RPO screen, tell a 3D start in one line that they are plane
    strain only (not a numpy shape error)."""
    from stickslip import run
    from stickslip.studies.attractors.certify import certify
    from stickslip.studies.rpo.certificate import rpo_screen

    run("smoke", tmp_path / "tube", overrides=[*TUBE, "boundary.ends=free"], force=True,
        quiet=True)
    direct = certify(tmp_path / "tube")
    assert "plane strain only" in direct["at_dt"]["message"]
    screen = rpo_screen(tmp_path / "tube", [{"k": 4, "frequency_hz": 1400.0},
                                            {"k": 5, "frequency_hz": 1500.0}])
    assert "plane strain only" in screen["message"]


@pytest.mark.parametrize("length, dofs, wall_s, rss_mb", [
    (0.25, 14256, 25.8, 452), (0.5, 28512, 50.1, 624), (2.0, 102168, 214.4, 2129)])
def test_the_estimate_knows_a_3d_tube(length, dofs, wall_s, rss_mb):
    """Before meshing, ``studies.resources.estimate`` counts a 3D tube's dofs exactly, and
    its time per step and memory within 35 % of what Figure 3 damped with free ends took
    over 8060 steps (summary.json of docs/tube3d.md's runs: wall_time_s, peak_rss_mb; the
    model's fit, ``tube_costs``); the shipped scene's own step count, 8918 (its
    dt = 3.364e-5 s), within 35 % too. A guard that let a 3D run cost ten times what it
    said would be no guard."""
    from stickslip.solver.scene import load_scene
    from stickslip.studies.resources import estimate

    est = estimate(load_scene("tube3d_figure3_damped", [f"geometry.length={length}"]))
    assert est.dofs == dofs
    assert est.seconds / est.steps == pytest.approx(wall_s / 8060, rel=0.35)
    assert est.memory_bytes / 1e6 == pytest.approx(rss_mb, rel=0.35)
    if length == 0.5:
        assert est.steps == pytest.approx(8918, rel=0.35)


def test_the_estimate_knows_the_iterative_steady_state():
    """Above ``STEADY_DIRECT_DOFS`` the estimate's memory and setup are those N_θ = 264,
    N_z = 64 took (617 760 dofs: peak 3128 MB, set up in 99 s; docs/tube3d.md), within
    35 % as the direct rows above."""
    from stickslip.solver.scene import load_scene
    from stickslip.studies.resources import RUN_SECONDS, estimate

    scene = load_scene("figure3_n132_damped", [
        "mesh.dim=3", "mesh.n_inner=264", "geometry.length=1.5232", "mesh.n_axial=64",
        "mesh.cell=quadrilateral", "boundary.ends=free", "time.max_steps=1"])
    est = estimate(scene)
    assert est.dofs == 617760
    assert est.memory_bytes / 1e6 == pytest.approx(3128, rel=0.35)
    assert est.seconds - RUN_SECONDS == pytest.approx(99 + 0.097, rel=0.35)


def test_a_rank_that_owns_no_node_of_the_ring_records_nothing():
    """A long tube over 3 ranks leaves ranks without a node of the mid-length ring (L = 6 m,
    48 layers: 0, 0 and 36 of its 36): their gathered rows are (rows, 0), not a reshape
    error (the 3-rank run then gives the serial samples to 7e-16, statuses equal)."""
    from types import SimpleNamespace

    from stickslip.solver.ensemble_observers import _GatheredRows

    empty = SimpleNamespace(n_local=0, is_root=False, n_nodes=36)
    rows = _GatheredRows(empty, (6,), 10, np.float64, None)
    assert rows.flat.shape == (6, 0) and rows.row().shape == (1, 6, 0)


@pytest.mark.parametrize("sets", [[*TUBE, "boundary.ends=free"], ["time.kernel=numpy"],
                                  ["time.kernel=numba"]], ids=["3d", "2d-numpy", "2d-numba"])
def test_a_one_scene_run_is_kicked_into_a_new_run(tmp_path, sets):
    """The census's kick test on a start that is no batch member (a 3D tube; a plane-strain
    run alone): ``continue_run(..., kick=0.01)`` perturbs u and v~ by 1 % of their RMS
    (the facts in the summary's ``kick``: δu/u = 0.01 to 1e-12), writes a new run whose
    records start at the kick, and leaves the run itself as it was."""
    from stickslip import run
    from stickslip.studies.rundir import continue_run

    first = run("smoke", tmp_path / "run", overrides=[*sets, "time.end_time=0.006"],
                force=True, quiet=True)
    before = (tmp_path / "run" / "samples.npz").read_bytes()
    kicked = continue_run(tmp_path / "run", 0.01, tmp_path / "kicked", kick=0.01,
                          kick_seed=3, stream=io.StringIO())
    facts = kicked["kick"]
    assert kicked["status"] == "completed" and facts["seed"] == 3
    assert facts["du_rms_m"] / facts["u_rms_m"] == pytest.approx(0.01, rel=1e-12)
    assert facts["dv_rms_m_s"] / facts["v_rms_m_s"] == pytest.approx(0.01, rel=1e-12)
    t = np.load(tmp_path / "kicked" / "samples.npz")["t"]
    assert t[0] >= first["sim_time_s"] - 1e-12 and t[-1] == pytest.approx(0.01, abs=2e-4)
    assert (tmp_path / "run" / "samples.npz").read_bytes() == before
    with pytest.raises(ValueError, match="another directory"):
        continue_run(tmp_path / "run", 0.01, kick=0.01, stream=io.StringIO())


@pytest.mark.parallel
def test_the_iterative_steady_state_is_the_direct_one():
    """A large 3D tube's steady sliding is solved by GMRES with smoothed aggregation over
    the rigid-body modes (``STEADY_DIRECT_DOFS``); on the smoke tube with free ends (972
    dofs) it gives the LU's u to 1e-13 of its largest value (the refinement takes both to
    round-off), on one rank and on two (each rank's owned rows of the modes)."""
    from stickslip.forms.steady import static_sliding
    from stickslip.solver.problem import build_problem
    from stickslip.solver.scene import load_scene

    problem = build_problem(load_scene("smoke", [*TUBE, "boundary.ends=free"]),
                            MPI.COMM_WORLD)
    g, f = problem.scene.geometry, problem.scene.loading.f
    u = [static_sliding(problem.V, problem.tube, problem.material, g.d, f,
                        held=problem.end_held, iterative=iterative).u.x.array
         for iterative in (False, True)]
    assert np.max(np.abs(u[1] - u[0])) < 1e-13 * np.max(np.abs(u[0]))


def test_the_rigid_body_modes_are_the_kernel_and_halve_the_iterative_solve(monkeypatch):
    """``forms.steady.rigid_body_modes`` are the kernel of the unclamped stiffness (K r to
    1e-12 of max|K| max|r|: round-off of sums of ~80 entries a row), and as the near null
    space of smoothed aggregation they take the steady solve of Figure 3's tube (L/R =
    0.25, 14 256 dofs) from 59 GMRES iterations to 19: asserted at most 30, and fewer than
    half of those without them."""
    import dolfinx.fem.petsc
    import ufl
    from petsc4py import PETSc

    from stickslip.forms import steady
    from stickslip.forms.elasticity import stiffness
    from stickslip.solver.problem import build_problem
    from stickslip.solver.scene import load_scene

    problem = build_problem(load_scene("tube3d_figure3_damped", ["geometry.length=0.25"]),
                            MPI.COMM_SELF)
    V = problem.V
    K = dolfinx.fem.petsc.assemble_matrix(dolfinx.fem.form(stiffness(
        ufl.TrialFunction(V), ufl.TestFunction(V), problem.material)))
    K.assemble()
    inf = PETSc.NormType.INFINITY
    k_max = K.norm(inf)
    for mode in steady.rigid_body_modes(V):
        r, out = K.createVecRight(), K.createVecLeft()
        r.setArray(mode)
        K.mult(r, out)
        assert out.norm(inf) < 1e-12 * k_max * np.max(np.abs(mode))
    g, f = problem.scene.geometry, problem.scene.loading.f

    def iterations() -> int:
        return steady.static_sliding(V, problem.tube, problem.material, g.d, f,
                                     held=problem.end_held, iterative=True).iterations

    with_modes = iterations()
    monkeypatch.setattr(steady, "set_near_nullspace", lambda A, V, T: None)
    without = iterations()
    assert with_modes <= 30 and 2 * with_modes < without


def test_the_3d_tube_refuses_what_it_does_not_run(tmp_path, capsys):
    """One line each, before anything is meshed or made: the implicit scheme and the numba
    kernel on a 3D tube (``stickslip run`` exits 2 and makes no run directory; a sweep
    and a census with such a scene are refused whole), and clamped ends with fewer than
    two layers (no ring of contact nodes between the held end rings)."""
    from stickslip.cli.main import main
    from stickslip.solver.run import Simulation
    from stickslip.solver.scene import SceneError, load_scene

    for extra, words in ((["time.beta1=0.25", "time.beta2=0.5"], "plane strain only"),
                         (["time.kernel=numba"], "steps with numpy")):
        scene = load_scene("smoke", [*TUBE, *extra])
        with pytest.raises(ValueError, match=words):
            Simulation(scene, MPI.COMM_SELF)
        sets = [a for item in [*TUBE, *extra] for a in ("--set", item)]
        assert main(["run", "smoke", *sets, "-o", str(tmp_path / "run")]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and words in err, err
        sweep = tmp_path / "s.toml"
        sweep.write_text(f'base = "smoke"\nset = {json.dumps([*TUBE, *extra])}\n'
                         '[grid]\n"geometry.length" = [0.2, 0.4]\n')
        assert main(["sweep", str(sweep), "-o", str(tmp_path / "sweep")]) == 2
        assert words in capsys.readouterr().err
        assert main(["attractors", "smoke", *sets, "--starts", "2",
                     "-o", str(tmp_path / "census")]) == 2
        assert words in capsys.readouterr().err
        assert not any(tmp_path.glob("run*")) and not (tmp_path / "census").exists()
        assert not (tmp_path / "sweep").exists()
    with pytest.raises(SceneError, match="mesh.n_axial = 1 .* n_axial >= 2 with clamped"):
        load_scene("smoke", [*TUBE, "mesh.n_axial=1", "boundary.ends=clamped"])


def test_clamped_ends_hold_their_rings_and_balance_the_energy(tmp_path):
    """Clamped ends (u = 0 on z = 0, L) hold the contact surface's end rings: those nodes
    are the support's, no contact nodes (``forms.polar.without_held``). Smoke physics, 4
    layers, beta_2 = 1/2, every node slipping over 3 ms: the end rings' records say "no
    node" (status -1, u = 0) and the other rings move; the energy residual is the
    scheme's O(dt^2) error, 3.75 times smaller when dt halves from 2e-5 s (measured
    -15.4 J, then -4.09 J: asserted in [3.5, 4.5], second order); the axial profile of the
    wave vanishes at the held rings, and its end phase is the first contact ring's."""
    from stickslip import run

    residual = []
    for dt in (2e-5, 1e-5):
        tube = run("smoke", tmp_path / f"tube{dt}",
                   overrides=[*TUBE, "mesh.n_axial=4", "boundary.ends=clamped",
                              "time.beta2=0.5", "time.end_time=0.003", f"time.dt={dt}",
                              f"output.sample_interval={dt}"], force=True, quiet=True)
        assert tube["status"] == "completed" and tube["fractions"]["slip"] == 1.0
        residual.append(tube["energy"]["balance_residual_J"])
    assert 3.5 < residual[0] / residual[1] < 4.5, residual
    facts = tube["tube_3d"]
    assert facts["ends"] == "clamped" and facts["surface_nodes"] == 3 * 36
    assert facts["axial"]["profile"][0] == facts["axial"]["profile"][-1] == 0.0
    assert facts["axial"]["modes"] == []  # steady sliding by 3 ms: no wave to take apart
    surface = np.load(tmp_path / "tube1e-05" / "surface.npz")
    held, inner = surface["status"][:, [0, -1]], surface["status"][:, 1:-1]
    assert (held == -1).all() and (inner >= 0).all()
    assert not surface["u_r"][:, [0, -1]].any() and surface["u_r"][:, 1:-1].all()


@pytest.mark.parallel
def test_the_3d_tube_runs_the_same_on_every_rank_count(tmp_path):
    """Free ends, 0.01 s: one rank against COMM_WORLD, statuses equal and u to 1e-10 of
    max u_r (the partitions sum K u in other orders: round-off, as in plane strain); the
    whole surface gathered from the ranks the same (float32: 1e-6). A run directory is
    written and drawn on every rank count (rank 0 alone writes; nothing collective there)."""
    from stickslip import run
    from stickslip.solver.run import Simulation
    from stickslip.solver.scene import load_scene

    scene = load_scene("smoke", [*TUBE, "boundary.ends=free", "time.end_time=0.01"])
    root = Path(MPI.COMM_WORLD.bcast(str(tmp_path), root=0))
    summary = run(scene, root / "tube", force=True, quiet=True, plot=True)  # the writer too
    if MPI.COMM_WORLD.rank == 0:
        assert summary["tube_3d"]["surface_nodes"] == 108
        assert (root / "tube" / "surface.png").exists()
    results = {}
    for name, comm in (("serial", MPI.COMM_SELF), ("world", MPI.COMM_WORLD)):
        sim = Simulation(scene, comm)
        sim.proceed()
        surface = sim.columns.surface_arrays()  # collective: gathered to rank 0
        if comm.rank == 0:
            results[name] = (sim.recorder.arrays(), surface)
    if MPI.COMM_WORLD.rank == 0:
        (a, surface_a), (b, surface_b) = results["serial"], results["world"]
        np.testing.assert_array_equal(a["status"], b["status"])
        np.testing.assert_array_equal(surface_a["status"], surface_b["status"])
        assert (surface_a["status"] >= 0).all()  # every node of the grid came from a rank
        scale = np.max(np.abs(surface_a["u_r"]))
        assert np.max(np.abs(surface_a["u_r"] - surface_b["u_r"])) <= 1e-6 * scale
        scale = np.max(np.abs(a["u_r"]))
        for key in ("u_r", "u_theta"):
            assert np.max(np.abs(a[key] - b[key])) < 1e-10 * scale, key
        assert np.max(np.abs(a["energies"] - b["energies"])) < 1e-9 * np.max(a["energies"])


def test_axial_modes_take_a_wave_apart_by_k_and_m():
    """``axial_modes`` on a made surface (N = 36, 7 levels, refined towards the ends): a
    k = 4 wave uniform along z (amplitude 2) and a k = 7 wave of one nodal ring,
    cos(pi zeta) (amplitude 1), travelling in opposite directions. The shares are the
    waves' powers over the total, 2²/2 against 1²/2 x the trapezoid rule's mean of
    cos², recovered to the 4 digits kept (the axial shapes are in the basis: the
    projection is exact);
    nothing else is found above the floor."""
    from stickslip.postprocess.surface_map import axial_modes

    z = np.array([0.0, 0.02, 0.05, 0.15, 0.25, 0.28, 0.3])
    zeta = z / z[-1]
    theta = 2 * np.pi * np.arange(36) / 36
    t = np.linspace(0.0, 0.01, 200)
    T, Z, TH = np.meshgrid(t, zeta, theta, indexing="ij")
    u_r = (1e-3 + 2.0 * np.cos(4 * TH - 900.0 * T)
           + np.cos(np.pi * Z) * np.cos(7 * TH + 1300.0 * T))
    modes = axial_modes({"u_r": u_r, "z": z})
    w = np.zeros_like(zeta)
    w[1:] += 0.5 * np.diff(zeta)
    w[:-1] += 0.5 * np.diff(zeta)
    cos2 = float(np.sum(w * np.cos(np.pi * zeta) ** 2))
    total = 2.0**2 / 2 + cos2 / 2
    assert [(e["k"], e["m"]) for e in modes] == [(4, 0), (7, 1)]
    assert modes[0]["share"] == pytest.approx(2.0 / total, abs=1e-4)  # rounded to 4 digits
    assert modes[1]["share"] == pytest.approx(cos2 / 2 / total, abs=1e-4)
