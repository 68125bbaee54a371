"""Structured annulus (tube cross-section, paper section 2) built with gmsh, distributed by dolfinx.

The tube occupies ``R <= r <= ξR``. The inner circle ``r = R`` (physical tag ``INNER_TAG``) is
the contact surface with the rotating rigid cylinder; the outer circle ``r = ξR``
(``OUTER_TAG``) is clamped.

Mesh layout: ``n_edges`` equal angular divisions times ``n_radial`` equal radial layers, made of
four transfinite annular sectors that share their radial lines (no duplicated seam nodes). Every
cell of a sector is the rotated copy of its neighbour (one diagonal direction for triangles), so
the mesh is invariant under a rotation by ``2π/n_edges``: all contact nodes are equivalent.

Node count on the contact circle: the user asks for ``n_inner`` finite-element NODES of the
Lagrange space of degree ``degree`` (= geometry degree):

* ``degree=1``: ``n_edges = n_inner`` straight edges, the vertices are the nodes;
* ``degree=2``: ``n_inner`` must be even, ``n_edges = n_inner/2`` curved edges; the mesh is
  built with geometry order 2, so the midside nodes lie ON the circle (isoparametric mesh)
  and all ``n_inner`` nodes are at angles ``2πj/n_inner``.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import dolfinx
import gmsh
import numpy as np
from mpi4py import MPI

from stickslip.meshes.compat import model_to_mesh

__all__ = ["INNER_TAG", "OUTER_TAG", "TUBE_TAG", "TubeMesh", "annulus_mesh", "auto_n_radial"]

INNER_TAG = 1  #: physical tag of the contact circle r = R
OUTER_TAG = 2  #: physical tag of the clamped circle r = ξR
TUBE_TAG = 1  #: physical tag of the cells

_CELLS = ("triangle", "quadrilateral")
_N_SECTORS = 4  # each sector arc spans < π (gmsh circle arcs must)


@dataclass
class TubeMesh:
    """A distributed annulus mesh with its tags and the parameters it was built from."""

    mesh: dolfinx.mesh.Mesh
    cell_tags: dolfinx.mesh.MeshTags
    facet_tags: dolfinx.mesh.MeshTags
    R: float
    xi: float
    n_inner: int
    n_radial: int
    cell: str
    degree: int

    @property
    def n_edges(self) -> int:
        """Number of cell edges on the contact circle."""
        return self.n_inner // self.degree


def auto_n_radial(xi: float, n_edges: int) -> int:
    """Layers giving ≈ square cells at r = R: ``round((ξ−1)·n_edges/(2π))``, at least 2."""
    return max(2, round((xi - 1.0) * n_edges / (2.0 * math.pi)))


def _check(R: float, xi: float, n_inner: int, n_radial: int, cell: str, degree: int) -> None:
    if not R > 0.0:
        raise ValueError(f"R={R!r}: the inner radius must be > 0")
    if not xi > 1.0:
        raise ValueError(f"xi={xi!r}: the radius ratio ξ = R*/R must be > 1")
    if cell not in _CELLS:
        raise ValueError(f"cell={cell!r}: unknown cell type, use one of {_CELLS}")
    if degree not in (1, 2):
        raise ValueError(f"degree={degree!r}: only Lagrange degree 1 or 2 is supported")
    if int(n_inner) != n_inner or n_inner < 8:
        raise ValueError(f"n_inner={n_inner!r}: need an integer >= 8 nodes on the inner circle")
    if degree == 2 and n_inner % 2:
        raise ValueError(
            f"n_inner={n_inner}: degree 2 needs an even number of inner nodes "
            "(n_inner/2 curved edges, each with a midside node)"
        )
    if int(n_radial) != n_radial or n_radial < 0:
        raise ValueError(f"n_radial={n_radial!r}: need an integer >= 0 (0 = automatic)")


def annulus_surfaces(R: float, xi: float, n_edges: int, n_radial: int,
                     recombine: bool) -> tuple[list[int], list[int], list[int]]:
    """The structured annulus's four transfinite sectors in the current gmsh model's geo
    kernel, its mesh constraints set there too (so that they survive a later extrusion;
    ``recombine``: quadrilaterals): (surfaces, inner arcs, outer arcs). Neither synchronised
    nor meshed: ``_build_model`` meshes it as the 2D tube, ``meshes.tube3d`` extrudes it."""
    geo = gmsh.model.geo
    # Edges per sector, as equal as possible; sector boundaries at multiples of 2π/n_edges.
    counts = [n_edges // _N_SECTORS + (k < n_edges % _N_SECTORS) for k in range(_N_SECTORS)]
    starts = [sum(counts[:k]) for k in range(_N_SECTORS)]
    centre = geo.addPoint(0.0, 0.0, 0.0)
    p_in, p_out = [], []
    for s in starts:
        t = 2.0 * math.pi * s / n_edges
        c, sn = math.cos(t), math.sin(t)
        p_in.append(geo.addPoint(R * c, R * sn, 0.0))
        p_out.append(geo.addPoint(xi * R * c, xi * R * sn, 0.0))
    radial = [geo.addLine(p_in[k], p_out[k]) for k in range(_N_SECTORS)]
    inner, outer, surfaces = [], [], []
    for k in range(_N_SECTORS):
        k1 = (k + 1) % _N_SECTORS
        a = geo.addCircleArc(p_in[k], centre, p_in[k1])
        b = geo.addCircleArc(p_out[k], centre, p_out[k1])
        loop = geo.addCurveLoop([a, radial[k1], -b, -radial[k]])
        surfaces.append(geo.addPlaneSurface([loop]))
        inner.append(a)
        outer.append(b)
    mesh = geo.mesh
    for k in range(_N_SECTORS):
        k1 = (k + 1) % _N_SECTORS
        mesh.setTransfiniteCurve(inner[k], counts[k] + 1)
        mesh.setTransfiniteCurve(outer[k], counts[k] + 1)
        mesh.setTransfiniteCurve(radial[k], n_radial + 1)
        mesh.setTransfiniteSurface(surfaces[k], "Left", [p_in[k], p_in[k1], p_out[k1], p_out[k]])
        if recombine:
            mesh.setRecombine(2, surfaces[k])
    return surfaces, inner, outer


def _build_model(R: float, xi: float, n_edges: int, n_radial: int, cell: str, degree: int) -> None:
    """Create the structured annulus in the current gmsh model and mesh it (rank 0 only)."""
    surfaces, inner, outer = annulus_surfaces(R, xi, n_edges, n_radial,
                                              cell == "quadrilateral")
    gmsh.model.geo.synchronize()
    gmsh.model.addPhysicalGroup(2, surfaces, TUBE_TAG, name="tube")
    gmsh.model.addPhysicalGroup(1, inner, INNER_TAG, name="inner")
    gmsh.model.addPhysicalGroup(1, outer, OUTER_TAG, name="outer")
    mesh = gmsh.model.mesh
    mesh.generate(2)
    if degree == 2:
        gmsh.option.setNumber("Mesh.SecondOrderIncomplete", 0)  # Q9 for quadrilaterals
        mesh.setOrder(2)  # midside nodes placed on the geometry (the circles)


def distributed_gmsh_mesh(comm: MPI.Comm, name: str, build, gdim: int):  # noqa: ANN001, ANN201
    """``build()`` a gmsh model on rank 0 only and distribute it over ``comm`` as (mesh,
    cell_tags, facet_tags). gmsh is left as found (initialised and finalised here unless
    the caller had already initialised it). PT-Scotch partitions with one thread, so that
    the same mesh on the same ranks gets the same partition every time (a continued run
    needs it: ``studies.rundir.continuation``; the variable is read at each partitioning)."""
    os.environ.setdefault("SCOTCH_PTHREAD_NUMBER", "1")
    root = 0
    if comm.rank != root:
        return model_to_mesh(gmsh.model, comm, root, gdim=gdim)
    owns_gmsh = not gmsh.isInitialized()
    if owns_gmsh:
        gmsh.initialize(readConfigFiles=False, interruptible=False)
    terminal = gmsh.option.getNumber("General.Terminal")
    gmsh.option.setNumber("General.Terminal", 0)
    previous = gmsh.model.getCurrent() if not owns_gmsh else None
    gmsh.model.add(name)
    try:
        build()
        return model_to_mesh(gmsh.model, comm, root, gdim=gdim)
    finally:
        gmsh.model.setCurrent(name)
        gmsh.model.remove()
        if owns_gmsh:
            gmsh.finalize()
        else:
            gmsh.option.setNumber("General.Terminal", terminal)
            if previous:
                gmsh.model.setCurrent(previous)


def snap_circles(msh: dolfinx.mesh.Mesh, R: float, xi: float, n_nodes: int) -> None:
    """Put the geometry nodes of both circles exactly at radius R/ξR and angles 2πj/n_nodes.

    gmsh places transfinite arc points (and P2 midside points) by numerical arc-length
    parametrisation, ~1e-8 relative off the uniform angles; snapping them (on every rank,
    ghosts included, deterministically) makes the contact nodes exactly rotationally uniform.
    In 3D (``meshes.tube3d``) the cylinders' nodes alike, whatever their z.
    """
    x = msh.geometry.x
    r = np.hypot(x[:, 0], x[:, 1])
    step = 2.0 * np.pi / n_nodes
    for radius in (R, xi * R):
        on = np.abs(r - radius) < 1e-9 * radius
        angle = step * np.rint(np.arctan2(x[on, 1], x[on, 0]) / step)
        x[on, 0] = radius * np.cos(angle)
        x[on, 1] = radius * np.sin(angle)


def annulus_mesh(
    comm: MPI.Comm,
    *,
    R: float,
    xi: float,
    n_inner: int,
    n_radial: int = 0,
    cell: str = "triangle",
    degree: int = 1,
) -> TubeMesh:
    """Structured annulus ``R <= r <= ξR`` with exactly ``n_inner`` Lagrange nodes on r = R.

    ``n_radial`` = element layers through the thickness (0: :func:`auto_n_radial`). The mesh is
    generated by gmsh on rank 0 only and distributed over ``comm``; gmsh is left as found
    (initialised and finalised here unless the caller had already initialised it).
    """
    _check(R, xi, n_inner, n_radial, cell, degree)
    n_edges = n_inner // degree
    n_radial = n_radial or auto_n_radial(xi, n_edges)
    result = distributed_gmsh_mesh(
        comm, "stickslip_annulus",
        lambda: _build_model(float(R), float(xi), n_edges, n_radial, cell, degree), gdim=2)
    msh, cell_tags, facet_tags = result
    msh.name = "tube"
    snap_circles(msh, float(R), float(xi), n_edges * degree)
    return TubeMesh(
        mesh=msh,
        cell_tags=cell_tags,
        facet_tags=facet_tags,
        R=float(R),
        xi=float(xi),
        n_inner=int(n_inner),
        n_radial=int(n_radial),
        cell=cell,
        degree=int(degree),
    )
