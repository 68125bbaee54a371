"""The finite-length tube in 3D (meshes/tube3d.py) and the elasticity forms in 3D.

* The mesh: hexahedra, exactly N × (N_z + 1) nodes on the contact surface r = R at the
  angles 2πj/N and the levels Lk/N_z, the tags of the contact surface, the clamped surface
  and both ends; bad parameters refused in one line.
* The plane-strain limit, on the discrete operators: with roller ends (u_z = 0 at z = 0 and
  z = L) and the outer surface clamped, every eigenvalue ω² of the 2D tube (K u = ω² M u, the
  lumped mass) is an eigenvalue of the 3D tube extruded from the same cross-section. The
  trilinear space holds the z-constant in-plane fields, and on them the 3D stiffness and the
  HRZ-lumped mass are the 2D ones times the lumped P1 weights along z (dz/2 at the ends, dz
  inside), so the match is exact but for round-off: 1e-10 relative allowed (dense
  eigensolvers on matrices of condition ~1e3), 5e-15 measured.
* The forms' own checks in 3D (a manufactured solution's convergence, the strain energy,
  the lumped mass, the cylindrical stress) are tests/test_forms_3d.py.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("dolfinx")

import dolfinx  # noqa: E402
import dolfinx.fem.petsc  # noqa: E402
import ufl  # noqa: E402
from mpi4py import MPI  # noqa: E402

from stickslip.forms.elasticity import Material, lumped_mass, stiffness  # noqa: E402
from stickslip.meshes.annulus import INNER_TAG, OUTER_TAG, annulus_mesh  # noqa: E402
from stickslip.meshes.tube3d import END0_TAG, END1_TAG, tube_mesh_3d  # noqa: E402

STEEL = Material(E=2.1e11, nu=0.3, rho=7800.0)


def test_the_mesh_has_n_times_nz_plus_one_contact_nodes_and_its_tags():
    t = tube_mesh_3d(MPI.COMM_SELF, R=0.1, xi=1.25, length=0.05, n_inner=16, n_axial=3,
                     n_radial=2)
    msh = t.mesh
    assert msh.topology.cell_type == dolfinx.mesh.CellType.hexahedron
    assert msh.topology.index_map(3).size_local == 16 * 2 * 3
    x = msh.geometry.x
    r = np.hypot(x[:, 0], x[:, 1])
    inner = x[np.abs(r - 0.1) < 1e-14]
    assert inner.shape[0] == 16 * 4
    angles = np.sort(np.round(np.mod(np.arctan2(inner[:, 1], inner[:, 0]), 2 * math.pi)
                              / (2 * math.pi / 16)).astype(int) % 16)
    assert np.array_equal(np.bincount(angles), np.full(16, 4))
    levels = inner[:, 2] / (0.05 / 3)
    assert np.array_equal(levels, np.rint(levels))
    counts = {tag: int(np.sum(t.facet_tags.values == tag))
              for tag in (INNER_TAG, OUTER_TAG, END0_TAG, END1_TAG)}
    assert counts == {INNER_TAG: 48, OUTER_TAG: 48, END0_TAG: 32, END1_TAG: 32}


@pytest.mark.parametrize("bad, words", [
    ({"length": 0.0}, "length=0.0"), ({"length": math.inf}, "length=inf"),
    ({"n_axial": 0}, "n_axial=0"), ({"n_inner": 6}, "n_inner=6"), ({"xi": 1.0}, "xi=1.0"),
    ({"n_radial": -1}, "n_radial=-1")])
def test_bad_parameters_are_one_line_errors(bad, words):
    args = dict(R=0.1, xi=1.25, length=0.05, n_inner=16, n_axial=2) | bad
    with pytest.raises(ValueError, match=words) as err:
        tube_mesh_3d(MPI.COMM_SELF, **args)
    assert "\n" not in str(err.value)


def _free_spectrum(msh, clamped: list[tuple[np.ndarray, int | None]]) -> np.ndarray:
    """The eigenvalues ω² of K u = ω² M u (lumped M) on the dofs not in ``clamped`` (each:
    facets of the mesh's boundary, and the component fixed there, None for all)."""
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (msh.geometry.dim,)))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    K = dolfinx.fem.petsc.assemble_matrix(dolfinx.fem.form(stiffness(u, v, STEEL)))
    K.assemble()
    n = V.dofmap.index_map.size_local * V.dofmap.index_map_bs
    dense = K.convert("dense").getDenseArray()[:n, :n]
    mass = lumped_mass(V, STEEL.rho).array[:n]
    fixed = np.zeros(n, dtype=bool)
    tdim = msh.topology.dim
    for facets, comp in clamped:
        if comp is None:  # the nodes (blocks) of the facets: every component
            nodes = dolfinx.fem.locate_dofs_topological(V, tdim - 1, facets)
            for c in range(msh.geometry.dim):
                fixed[nodes * msh.geometry.dim + c] = True
        else:  # a component: the sub-space's dofs, numbered in V's (unrolled) dofs
            fixed[dolfinx.fem.locate_dofs_topological(V.sub(comp), tdim - 1, facets)] = True
    free = ~fixed
    scale = 1.0 / np.sqrt(mass[free])
    A = dense[np.ix_(free, free)] * scale[:, None] * scale[None, :]
    return np.linalg.eigvalsh(0.5 * (A + A.T))


def test_roller_ends_hold_every_plane_strain_eigenvalue():
    """The 2D quadrilateral tube (N = 16, 2 layers, outer circle clamped) and the 3D tube
    extruded from it (3 axial layers, outer surface clamped, u_z = 0 on both ends): each 2D
    eigenvalue is in the 3D spectrum to 1e-10 relative; the 3D spectrum has more (the modes
    that vary along z)."""
    two = annulus_mesh(MPI.COMM_SELF, R=0.1, xi=1.25, n_inner=16, n_radial=2,
                       cell="quadrilateral")
    lam2 = _free_spectrum(two.mesh, [(two.facet_tags.find(OUTER_TAG), None)])
    three = tube_mesh_3d(MPI.COMM_SELF, R=0.1, xi=1.25, length=0.03, n_inner=16, n_axial=3,
                         n_radial=2)
    ft = three.facet_tags
    ends = np.concatenate([ft.find(END0_TAG), ft.find(END1_TAG)])
    lam3 = _free_spectrum(three.mesh, [(ft.find(OUTER_TAG), None), (ends, 2)])
    assert lam3.size > 3 * lam2.size
    gap = np.array([np.min(np.abs(lam3 - lam)) / lam for lam in lam2])
    assert gap.max() < 1e-10, gap.max()


def _cea_spectrum(problem) -> np.ndarray:
    """Every μ of the sliding CEA pencil (K̂ + f K_f) φ = μ B φ (``build_operators``: the
    contact radial dofs eliminated, the θ-rows take −f × the r-rows), densely."""
    import scipy.linalg as la
    import scipy.sparse as sp

    from stickslip.studies.flutter_fe.cea import build_operators

    def dense(mat) -> np.ndarray:  # noqa: ANN001 - a sequential PETSc matrix
        ai, aj, av = mat.getValuesCSR()
        return sp.csr_matrix((av, aj, ai), shape=mat.getSize()).toarray()

    ops = build_operators(problem)
    f = problem.scene.loading.f
    return la.eigvals(dense(ops.Kt) + f * dense(ops.Kf), dense(ops.B))


def test_the_3d_cea_with_roller_ends_holds_the_2d_cea():
    """The plane-strain limit of the CEA: the Figure-1 scene at N = 16, 2 layers, in
    quadrilaterals (the cross-section the hexahedra extrude), and the 3D tube of it
    (``solver.problem.tube_problem_3d``, L = 20 mm, 3 axial layers). With roller ends every
    2D μ of the sliding pencil, 42 of its 48 in flutter pairs (f = 0.7), is a 3D μ to 1e-10
    relative (measured 1.4e-13): on the z-constant in-plane fields the 3D K, lumped mass and
    friction rows are the 2D ones times the lumped weights along z. With free ends the
    plane-strain fields are no subspace, and the 2D μ are not 3D ones (measured up to 8 %;
    asserted > 1e-3). A bad ``ends`` or a P2 scene is refused in one line."""
    from stickslip.solver.problem import build_problem, tube_problem_3d
    from stickslip.solver.scene import load_scene

    scene = load_scene("scenes/figure1.toml", ["mesh.n_inner=16", "mesh.n_radial=2",
                                               "mesh.cell=quadrilateral"])
    mu2 = _cea_spectrum(build_problem(scene, MPI.COMM_SELF))
    assert np.count_nonzero(np.abs(mu2.imag) > 1e-9 * np.abs(mu2)) == 42
    for ends, within in (("roller", True), ("free", False)):
        three = tube_problem_3d(scene, length=0.02, n_axial=3, ends=ends, comm=MPI.COMM_SELF)
        mu3 = _cea_spectrum(three)
        gap = np.array([np.min(np.abs(mu3 - mu)) / abs(mu) for mu in mu2])
        assert (gap.max() < 1e-10) if within else (gap.max() > 1e-3), (ends, gap.max())
    with pytest.raises(ValueError, match="ends = 'hinged': use one of free, roller, clamped"):
        tube_problem_3d(scene, length=0.02, n_axial=3, ends="hinged", comm=MPI.COMM_SELF)
    p2 = load_scene("scenes/figure1.toml", ["mesh.n_inner=16", "mesh.degree=2"])
    with pytest.raises(ValueError, match="degree 1"):
        tube_problem_3d(p2, length=0.02, n_axial=3, comm=MPI.COMM_SELF)


def test_clamping_the_ends_raises_every_eigenvalue_of_the_cea():
    """Clamped ends hold their rings, which are then no contact nodes: the CEA pencil of the
    clamped tube lives on a subspace of the free tube's dofs (the held end dofs removed).
    Frictionless (f = 0: K^ symmetric, B the lumped mass), Courant-Fischer says each ordered
    eigenvalue of the clamped tube is at least the free tube's of the same rank: asserted
    to 1e-12 relative (round-off of the dense solve), and clamping must move the spectrum
    (measured: the lowest by more than 1 %). With friction (f = 0.7) the clamped CEA
    finds flutter pairs, as the CLI prints them."""
    from stickslip.cli.main import main
    from stickslip.solver.problem import tube_problem_3d
    from stickslip.solver.scene import load_scene

    scene = load_scene("scenes/figure1.toml", ["mesh.n_inner=16", "mesh.n_radial=2",
                                               "mesh.cell=quadrilateral", "loading.f=0"])
    mu = {ends: np.sort(_cea_spectrum(tube_problem_3d(
        scene, length=0.02, n_axial=3, ends=ends, comm=MPI.COMM_SELF)).real)
        for ends in ("free", "clamped")}
    held = mu["free"].size - mu["clamped"].size
    assert held == 2 * 16 * 3 * 3 - 2 * 16 * 3 - 2 * 16  # end faces' nodes x 3, less outer, r
    assert (mu["clamped"] >= mu["free"][: mu["clamped"].size] * (1 - 1e-12)).all()
    assert mu["clamped"][0] > 1.01 * mu["free"][0]
    assert main(["flutter-fe", "figure1", "--set", "mesh.n_inner=32", "--set",
                 "mesh.cell=quadrilateral", "--fmax-hz", "3000", "--length", "0.05",
                 "--n-axial", "4", "--ends", "clamped", "--top", "1"]) == 0


@pytest.mark.parallel
def test_the_distributed_mesh_has_the_same_tags():
    """On any number of ranks the owned facets of each tag add up to the serial counts."""
    comm = MPI.COMM_WORLD
    t = tube_mesh_3d(comm, R=0.1, xi=1.25, length=0.05, n_inner=16, n_axial=3, n_radial=2)
    msh = t.mesh
    owned = msh.topology.index_map(2).size_local
    counts = {tag: comm.allreduce(int(np.sum(t.facet_tags.find(tag) < owned)))
              for tag in (INNER_TAG, OUTER_TAG, END0_TAG, END1_TAG)}
    assert counts == {INNER_TAG: 48, OUTER_TAG: 48, END0_TAG: 32, END1_TAG: 32}
    assert comm.allreduce(msh.topology.index_map(3).size_local) == 96


def test_the_3d_cea_labels_each_mode_by_wavenumber_and_axial_order():
    """``complex_eigenvalue_analysis`` on the 3D tube with roller ends (N = 32, Figure 1,
    L = 50 mm, 4 axial layers) finds the 2D scene's unstable modes below 3 kHz with their
    wavenumber k, frequency and growth rate (to 1e-8 relative: the same pencil restricted
    to a subspace), each of axial order m = 0; ``axial_order`` counts the sign changes of a
    ring profile after its common phase is removed."""
    from stickslip.solver.problem import build_problem, tube_problem_3d
    from stickslip.solver.scene import load_scene
    from stickslip.studies.flutter_fe.cea import axial_order, complex_eigenvalue_analysis

    assert axial_order(np.array([1.0, 0.9, 1.1])) == 0
    assert axial_order(np.exp(0.7j) * np.array([1.0, 0.4, -0.3, -1.0])) == 1
    assert axial_order(np.array([1.0, -1.0, 1.0, 0.001, -1.0])) == 3  # 0.001: below the floor
    assert axial_order(np.array([2.0])) == 0
    scene = load_scene("scenes/figure1.toml", ["mesh.n_inner=32", "mesh.cell=quadrilateral"])
    two = complex_eigenvalue_analysis(build_problem(scene, MPI.COMM_SELF), fmax_hz=3000.0)
    three = complex_eigenvalue_analysis(
        tube_problem_3d(scene, length=0.05, n_axial=4, ends="roller", comm=MPI.COMM_SELF),
        fmax_hz=3000.0)
    plane = [m for m in three.unstable() if m.axial_order == 0]
    assert len(two.unstable()) >= 8
    for mode in two.unstable():
        twin = min(plane, key=lambda m: abs(m.frequency_hz - mode.frequency_hz)
                   + abs(m.growth_rate - mode.growth_rate))
        assert twin.k == mode.k
        assert twin.frequency_hz == pytest.approx(mode.frequency_hz, rel=1e-8)
        assert twin.growth_rate == pytest.approx(mode.growth_rate, rel=1e-8)


def test_the_band_solver_finds_every_unstable_mode_of_a_dense_3d_spectrum():
    """The shift-and-invert slices (``band_eigenvalues``) against the dense pencil, where a
    3D tube crowds the band: Figure 3 damped, N = 64, L = R/4 in one axial layer, roller
    ends (640 free dofs). The dense pencil has 165 unstable modes below 3 kHz; the slices
    find all 165 (one was lost while a slice's strip height came only from the eigenvalues
    in its own disc, which the tallest ones lay outside), each growth rate to 1e-8."""
    import scipy.linalg as la
    import scipy.sparse as sp

    from stickslip.solver.problem import tube_problem_3d
    from stickslip.solver.scene import load_scene
    from stickslip.studies.flutter_fe.cea import (
        build_operators,
        complex_eigenvalue_analysis,
        damped_exponents,
    )

    scene = load_scene("scenes/figure3_n132_damped.toml", ["mesh.n_inner=64",
                                                           "mesh.cell=quadrilateral"])
    problem = tube_problem_3d(scene, length=0.25, n_axial=1, ends="roller", comm=MPI.COMM_SELF)
    ops = build_operators(problem)

    def dense(mat) -> np.ndarray:  # noqa: ANN001 - a sequential PETSc matrix
        ai, aj, av = mat.getValuesCSR()
        return sp.csr_matrix((av, aj, ai), shape=mat.getSize()).toarray()

    mu = la.eigvals(dense(ops.Kt) + scene.loading.f * dense(ops.Kf), dense(ops.B))
    lam = damped_exponents(mu, scene.damping.tau)
    hz = np.abs(lam.imag) / (2 * math.pi)
    growing = (mu.imag > 0) & (hz <= 3000.0) & (lam.real > 1e-7 * np.maximum(2 * math.pi * hz,
                                                                             1.0))
    exact = np.sort(lam.real[growing])[::-1]
    found = np.array([m.growth_rate for m in
                      complex_eigenvalue_analysis(problem, fmax_hz=3000.0, ops=ops).unstable()])
    assert exact.size == 165 and found.size == exact.size
    assert np.allclose(found, exact, rtol=1e-8)


def test_flutter_fe_length_runs_the_3d_tube(capsys):
    """``stickslip flutter-fe --length L --ends roller`` (Figure 1, N = 32, L = 50 mm,
    4 layers): the JSON names the tube, and its fastest unstable mode is the plane-strain
    scene's (quadrilaterals), m = 0, to 1e-8; the table has the m column. Options that
    describe no 3D tube, or that it cannot take, are one line each (exit 2)."""
    import json

    from stickslip.cli.main import main

    base = ["flutter-fe", "figure1", "--set", "mesh.n_inner=32", "--set",
            "mesh.cell=quadrilateral", "--fmax-hz", "3000"]
    assert main([*base, "--json"]) == 0
    two = json.loads(capsys.readouterr().out)
    assert main([*base, "--length", "0.05", "--n-axial", "4", "--ends", "roller",
                 "--json"]) == 0
    three = json.loads(capsys.readouterr().out)
    assert three["tube_3d"] == {"length_m": 0.05, "n_axial": 4, "ends": "roller"}
    top2, top3 = two["unstable"][0], three["unstable"][0]
    assert (top3["k"], top3["axial_order"]) == (top2["k"], 0)
    assert top3["growth_rate"] == pytest.approx(top2["growth_rate"], rel=1e-8)
    assert main([*base, "--length", "0.05", "--top", "1"]) == 0
    # R = 1 m: the default N_z = round(L N / (2π R)) = 0 is raised to 1 layer
    assert "3D tube: length 0.05 m, 1 axial layer, free ends" in capsys.readouterr().out
    for extra, words in ((["--ends", "roller"], "give its --length too"),
                         (["--length", "0"], "--length 0.0 is out of range"),
                         (["--length", "0.05", "--n-axial", "0"], "--n-axial 0"),
                         (["--length", "0.05", "--friction", "1-2-1"], "--friction 1-2-1"),
                         (["--length", "0.05", "--set", "mesh.degree=2"], "degree 1")):
        assert main([*base, *extra]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and words in err, err
