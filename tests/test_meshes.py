"""Tests of meshes.annulus: node counts on the contact circle, area convergence, tags, MPI."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("dolfinx")
pytestmark = pytest.mark.dolfinx

import dolfinx  # noqa: E402
import ufl  # noqa: E402
from mpi4py import MPI  # noqa: E402

from stickslip.meshes import INNER_TAG, OUTER_TAG, annulus_mesh, auto_n_radial  # noqa: E402

R, XI = 0.5, 1.25


def _inner_node_count(tube) -> int:
    """Global number of Lagrange(degree) nodes on the INNER_TAG facets (owned, summed)."""
    msh = tube.mesh
    V = dolfinx.fem.functionspace(msh, ("Lagrange", tube.degree))
    fdim = msh.topology.dim - 1
    msh.topology.create_connectivity(fdim, msh.topology.dim)
    dofs = dolfinx.fem.locate_dofs_topological(V, fdim, tube.facet_tags.find(INNER_TAG))
    owned = int(np.count_nonzero(dofs < V.dofmap.index_map.size_local))
    return msh.comm.allreduce(owned, op=MPI.SUM)


def _assemble(msh, expr) -> float:
    return msh.comm.allreduce(dolfinx.fem.assemble_scalar(dolfinx.fem.form(expr)), op=MPI.SUM)


def _global_cells(msh) -> int:
    return msh.topology.index_map(msh.topology.dim).size_global


@pytest.mark.parametrize("cell", ["triangle", "quadrilateral"])
@pytest.mark.parametrize("degree,n_inner", [(1, 24), (1, 37), (2, 24), (2, 42)])
def test_inner_node_count(cell: str, degree: int, n_inner: int) -> None:
    tube = annulus_mesh(MPI.COMM_WORLD, R=R, xi=XI, n_inner=n_inner, cell=cell, degree=degree)
    assert _inner_node_count(tube) == n_inner
    n_edges = n_inner // degree
    assert tube.n_edges == n_edges
    assert tube.n_radial == auto_n_radial(XI, n_edges)
    assert _global_cells(tube.mesh) == n_edges * tube.n_radial * (2 if cell == "triangle" else 1)


@pytest.mark.parametrize("degree", [1, 2])
def test_inner_nodes_on_circle_and_uniform(degree: int) -> None:
    """Inner nodes lie on r = R (midside ones too for P2) at angles 2πj/n_inner."""
    n_inner = 32
    tube = annulus_mesh(MPI.COMM_WORLD, R=R, xi=XI, n_inner=n_inner, degree=degree)
    msh = tube.mesh
    V = dolfinx.fem.functionspace(msh, ("Lagrange", degree))
    msh.topology.create_connectivity(1, 2)
    dofs = dolfinx.fem.locate_dofs_topological(V, 1, tube.facet_tags.find(INNER_TAG))
    xy = V.tabulate_dof_coordinates()[dofs, :2]
    xy = np.concatenate(msh.comm.allgather(xy))
    r = np.hypot(xy[:, 0], xy[:, 1])
    assert np.allclose(r, R, rtol=1e-12, atol=0)
    theta = np.sort(np.mod(np.arctan2(xy[:, 1], xy[:, 0]) + 1e-9, 2 * np.pi)) - 1e-9
    theta = theta[np.r_[True, np.diff(theta) > 1e-9]]  # nodes shared by ranks appear twice
    assert np.allclose(theta, 2 * np.pi * np.arange(n_inner) / n_inner, rtol=0, atol=1e-14)


@pytest.mark.parametrize("cell", ["triangle", "quadrilateral"])
def test_tags_and_lengths(cell: str) -> None:
    tube = annulus_mesh(MPI.COMM_WORLD, R=R, xi=XI, n_inner=48, cell=cell, degree=2)
    msh = tube.mesh
    ds = ufl.Measure("ds", domain=msh, subdomain_data=tube.facet_tags)
    one = dolfinx.fem.Constant(msh, 1.0)
    n_in = msh.comm.allreduce(tube.facet_tags.find(INNER_TAG).size, op=MPI.SUM)
    n_out = msh.comm.allreduce(tube.facet_tags.find(OUTER_TAG).size, op=MPI.SUM)
    assert n_in == n_out == 24  # only the two circles are tagged, 24 edges each
    # Geometry order 2: arc length error of a quadratic arc is O(h^4): 24 edges give ~1e-6.
    assert _assemble(msh, one * ds(INNER_TAG)) == pytest.approx(2 * np.pi * R, rel=1e-5)
    assert _assemble(msh, one * ds(OUTER_TAG)) == pytest.approx(2 * np.pi * XI * R, rel=1e-5)


def test_area_convergence_p1() -> None:
    """|Ω_h| → π(ξ²−1)R² at rate 2 for P1 geometry.

    The P1 mesh is the region between two inscribed regular n-gons: exact area
    ``n/2·sin(2π/n)·(ξ²−1)R²``, whose error is ``(2π²/3)(ξ²−1)R²/n² + O(n⁻⁴)``: rate 2.
    """
    exact = np.pi * (XI**2 - 1) * R**2
    ns = [16, 32, 64]
    errs = []
    for n in ns:
        tube = annulus_mesh(MPI.COMM_WORLD, R=R, xi=XI, n_inner=n, n_radial=2)
        one = dolfinx.fem.Constant(tube.mesh, 1.0)
        area = _assemble(tube.mesh, one * ufl.dx(domain=tube.mesh))
        assert area == pytest.approx(n / 2 * math.sin(2 * math.pi / n) * (XI**2 - 1) * R**2)
        errs.append(exact - area)
    rates = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(np.abs(rates - 2.0) < 0.05), rates


def test_area_p2_geometry() -> None:
    """With geometry order 2 (midside nodes on the circles) the area error is O(h⁴).

    A quadratic interpolant of a circular arc of angle h has a radial error ~ h⁴ (the
    interpolation error of a smooth curve by a parabola is O(h³), but it is odd about the
    midpoint, so the enclosed area error is O(h⁴)).
    """
    exact = np.pi * (XI**2 - 1) * R**2
    errs = []
    for n in (32, 64):
        tube = annulus_mesh(MPI.COMM_WORLD, R=R, xi=XI, n_inner=n, n_radial=2, degree=2)
        one = dolfinx.fem.Constant(tube.mesh, 1.0)
        errs.append(abs(_assemble(tube.mesh, one * ufl.dx(domain=tube.mesh)) - exact) / exact)
    print("P2-geometry area errors", errs)
    assert errs[0] < 1e-4 and np.log2(errs[0] / errs[1]) > 3.8


@pytest.mark.parametrize(
    "kwargs,match",
    [
        ({"n_inner": 6}, "n_inner"),
        ({"n_inner": 33, "degree": 2}, "even"),
        ({"n_inner": 32, "xi": 1.0}, "xi"),
        ({"n_inner": 32, "cell": "hexagon"}, "cell"),
        ({"n_inner": 32, "degree": 3}, "degree"),
    ],
)
def test_invalid_arguments(kwargs: dict, match: str) -> None:
    args = {"R": R, "xi": XI} | kwargs
    with pytest.raises(ValueError, match=match):
        annulus_mesh(MPI.COMM_WORLD, **args)


def test_called_twice_and_gmsh_left_clean() -> None:
    gmsh = pytest.importorskip("gmsh")
    for _ in range(2):
        annulus_mesh(MPI.COMM_WORLD, R=R, xi=XI, n_inner=16)
        assert not gmsh.isInitialized()


def test_gmsh_initialised_by_caller_is_left_as_found() -> None:
    gmsh = pytest.importorskip("gmsh")
    if MPI.COMM_WORLD.rank == 0:
        gmsh.initialize(readConfigFiles=False, interruptible=False)
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("caller_model")
    try:
        annulus_mesh(MPI.COMM_WORLD, R=R, xi=XI, n_inner=16)
        if MPI.COMM_WORLD.rank == 0:
            assert gmsh.isInitialized()
            assert gmsh.model.getCurrent() == "caller_model"
            assert "stickslip_annulus" not in gmsh.model.list()
    finally:
        if MPI.COMM_WORLD.rank == 0:
            gmsh.finalize()


@pytest.mark.parallel
@pytest.mark.parametrize("cell", ["triangle", "quadrilateral"])
@pytest.mark.parametrize("degree", [1, 2])
def test_parallel_counts(cell: str, degree: int) -> None:
    """Global counts match the closed-form counts and a serial (COMM_SELF) copy, any rank count."""
    n_inner, n_radial = 40, 3
    n_edges = n_inner // degree
    # Lagrange nodes: an (n_inner) x (degree·n_radial + 1) grid for P1, P2 and Q2 alike.
    n_nodes = n_inner * (degree * n_radial + 1)
    n_cells = n_edges * n_radial * (2 if cell == "triangle" else 1)
    values = []
    for comm in (MPI.COMM_WORLD, MPI.COMM_SELF):
        tube = annulus_mesh(
            comm, R=R, xi=XI, n_inner=n_inner, n_radial=n_radial, cell=cell, degree=degree
        )
        msh = tube.mesh
        V = dolfinx.fem.functionspace(msh, ("Lagrange", degree))
        one = dolfinx.fem.Constant(msh, 1.0)
        values.append(
            (
                _inner_node_count(tube),
                _global_cells(msh),
                V.dofmap.index_map.size_global,
                msh.geometry.index_map().size_global,
                _assemble(msh, one * ufl.dx(domain=msh)),
            )
        )
    world, serial = values
    assert world[:4] == (n_inner, n_cells, n_nodes, n_nodes)
    assert world[:4] == serial[:4]
    assert world[4] == pytest.approx(serial[4], rel=1e-13)
