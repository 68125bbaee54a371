"""The unstable modes of a finite tube on its contact surface (``cea.contact_grid``,
``plots.plot_contact_modes``, ``stickslip flutter-fe --mode-plot``).

The structured tube (Figure 1, N = 32, quadrilaterals extruded in hexahedra) is invariant
under a rotation by 2π/N: mesh, material, clamped surface and friction rows. A simple
eigenvalue's eigenvector is therefore a Bloch wave, ψ_θ(θ_j, z) = a(z) e^{ikθ_j} at the
contact nodes, and after ``contact_grid``'s normalisation each ring holds
``|a(z)| cos(kθ + φ(z))``. The symmetry is gmsh's to 2.3e-9 rad (the node angles of the
interior ring; the contact ring's are exact), which mixes in the nearest modes (relative
gap ~7e-4) by ~1e-6 at most: measured 5.5e-8 off the cosine (the same with the
eigensolver's tolerance at 1e-10 or 1e-14), 1e-6 allowed. With roller ends the plane-strain
fields (no z dependence) are an invariant subspace that holds every 2D mode
(tests/test_tube3d.py) exactly, the ring-angle error included, so an m = 0 mode is constant
along z to round-off: measured 4e-14, 1e-8 allowed (the solver's residual, 1e-10, over
that gap).
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("dolfinx")

from mpi4py import MPI  # noqa: E402

from stickslip.cli.main import main  # noqa: E402
from stickslip.solver.problem import tube_problem_3d  # noqa: E402
from stickslip.solver.scene import load_scene  # noqa: E402
from stickslip.studies.flutter_fe.cea import (  # noqa: E402
    CEAMode,
    ContactGrid,
    build_operators,
    complex_eigenvalue_analysis,
    contact_grid,
)

SETS = ["mesh.n_inner=32", "mesh.cell=quadrilateral"]
BASE = ["flutter-fe", "figure1", *(x for s in SETS for x in ("--set", s)), "--fmax-hz", "3000"]


def _fastest(length: float, ends: str, count: int) -> list[tuple[CEAMode, ContactGrid]]:
    """The ``count`` fastest-growing unstable modes of the Figure 1 tube (N = 32, 4 axial
    layers, below 3 kHz) and their ψ_θ on the contact grid; only their vectors are kept."""
    scene = load_scene("scenes/figure1.toml", SETS)
    problem = tube_problem_3d(scene, length=length, n_axial=4, ends=ends, comm=MPI.COMM_SELF)
    ops = build_operators(problem)
    res = complex_eigenvalue_analysis(problem, fmax_hz=3000.0, ops=ops, shapes=count)
    where = {id(m): i for i, m in enumerate(res.modes)}
    fastest = res.unstable()[:count]
    assert sorted(res.shapes) == sorted(where[id(m)] for m in fastest)  # those K, no more
    return [(m, contact_grid(ops, res.shapes[where[id(m)]])) for m in fastest]


def _cosine_residual(grid: ContactGrid, k: int) -> float:
    """Largest residual of the least-squares fit ``a cos kθ + b sin kθ`` to each ring of
    ``Re ψ_θ``, over max |ψ_θ| (= 1)."""
    basis = np.stack([np.cos(k * grid.theta), np.sin(k * grid.theta)], axis=1)
    rings = grid.values.real.T
    coef = np.linalg.lstsq(basis, rings, rcond=None)[0]
    return float(np.abs(basis @ coef - rings).max())


def test_an_m0_mode_with_roller_ends_is_a_cosine_in_theta_and_uniform_along_z():
    """Roller ends, L = 50 mm: the 4 fastest modes are m = 0; on the (θ, z) grid (5 rings of
    32) each is constant along z to 1e-8 and a cosine of its k in θ to 1e-6 (module
    docstring),
    normalised to max |ψ_θ| = 1, real at the peak."""
    drawn = _fastest(0.05, "roller", 4)
    assert len(drawn) == 4
    for mode, grid in drawn:
        assert mode.axial_order == 0
        v = grid.values
        assert v.shape == (5, 32)
        assert np.allclose(grid.z_rel, np.linspace(0, 1, 5))
        assert np.allclose(np.degrees(grid.theta), np.arange(32) * 360 / 32)
        assert np.abs(v).max() == pytest.approx(1.0, rel=1e-14)
        peak = v.flat[np.argmax(np.abs(v))]
        assert peak.imag == 0.0 and peak.real > 0
        assert np.std(v, axis=0).max() / np.abs(v).max() < 1e-8
        assert _cosine_residual(grid, mode.k) < 1e-6


def test_an_m1_mode_with_free_ends_changes_sign_once_along_z():
    """Free ends, L = 0.5 m: the second fastest mode (k = +10, 1299.5 Hz, 834 1/s) has
    m = 1; wherever its ring amplitude is not small, Re ψ_θ changes sign exactly once from
    z = 0 to z = L (one nodal ring, at z = L/2 by the tube's mirror symmetry), and each ring
    is still a cosine of k in θ (the rotation symmetry holds with any ends)."""
    drawn = _fastest(0.5, "free", 3)
    ones = [(m, g) for m, g in drawn if m.axial_order == 1]
    assert ones, [(m.k, m.axial_order) for m, _ in drawn]
    mode, grid = ones[0]
    v = grid.values.real
    strong = np.abs(v).max(axis=0) > 0.5  # columns away from the cosine's zeros
    assert strong.sum() >= 8
    for column in v[:, strong].T:
        kept = column[np.abs(column) > 1e-6]  # the mid ring is 0 to round-off
        assert np.count_nonzero(np.diff(np.sign(kept))) == 1
    # z = L/2 is the nodal ring: the extrusion's mirror z -> L - z is exact (measured 3e-14)
    assert abs(v[2]).max() < 1e-8
    assert _cosine_residual(grid, mode.k) < 1e-6


def test_flutter_fe_mode_plot_writes_the_figure_and_refuses_a_plane_strain_scene(
        tmp_path, capsys):
    """``--mode-plot PNG --mode-count 2`` on the roller tube writes the PNG and names it in a
    ``figure:`` line; a 2D scene and a bad count are one line each (exit 2)."""
    png = tmp_path / "modes.png"
    tube = ["--length", "0.05", "--n-axial", "4", "--ends", "roller"]
    assert main([*BASE, *tube, "--top", "2", "--mode-plot", str(png), "--mode-count", "2"]) == 0
    out = capsys.readouterr().out
    assert f"figure: {png}" in out
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    for extra, words in (([], "--mode-plot draws a 3D tube's contact surface"),
                         ([*tube, "--mode-count", "0"], "--mode-count 0 is out of range")):
        assert main([*BASE, *extra, "--mode-plot", str(tmp_path / "x.png")]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and words in err, err
    assert not (tmp_path / "x.png").exists()


def test_flutter_fe_modes_writes_a_3d_tubes_shapes_ring_by_ring(tmp_path, capsys):
    """``--modes DIR`` on the roller tube (N = 32, 4 layers): one VTX folder per listed mode,
    modes.csv with the axial order m (0: every listed mode is a plane-strain one with roller
    ends), and contact.csv with ψ_θ on every ring (5 rings x 32 angles per mode), normalised
    to max |ψ_θ| = 1 with ψ_θ real there; an m = 0 mode's rings are equal (to 1e-8 of the
    peak, as ``contact_grid`` above). With ``--mode-plot --mode-count 1`` beside it, every
    listed mode is still written (the plot keeps its one vector, the shapes all of theirs)."""
    out_dir = tmp_path / "modes"
    tube = ["--length", "0.05", "--n-axial", "4", "--ends", "roller"]
    assert main([*BASE, *tube, "--top", "2", "--modes", str(out_dir)]) == 0
    capsys.readouterr()
    rows = [r.split(",") for r in (out_dir / "modes.csv").read_text().splitlines()]
    assert rows[0][-1] == "axial_order" and len(rows) >= 3  # the header, 2 or more modes
    both = tmp_path / "both"
    assert main([*BASE, *tube, "--top", "2", "--modes", str(both), "--mode-plot",
                 str(tmp_path / "m.png"), "--mode-count", "1"]) == 0
    capsys.readouterr()
    assert (both / "modes.csv").read_text() == (out_dir / "modes.csv").read_text()
    assert all(r[-1] == "0" and (out_dir / r[9]).is_dir() for r in rows[1:])
    table = np.genfromtxt(out_dir / "contact.csv", delimiter=",", names=True)
    one = table[table["index"] == 1]
    assert one.size == 5 * 32 and sorted(set(one["z_rel"])) == [0.0, 0.25, 0.5, 0.75, 1.0]
    assert np.max(one["abs_psi_theta"]) == pytest.approx(1.0, rel=1e-12)
    psi = (one["re_psi_theta"] + 1j * one["im_psi_theta"]).reshape(5, 32)
    assert np.abs(psi - psi[0]).max() < 1e-8
