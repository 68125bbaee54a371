"""The finite-length tube in 3D: the structured annulus ``R <= r <= ξR`` extruded along z over
``0 <= z <= L`` into hexahedra, built with gmsh and distributed by dolfinx.

The cross-section is the 2D tube's quadrilateral mesh (``meshes.annulus.annulus_surfaces``):
``n_inner`` equal angular divisions times ``n_radial`` radial layers, invariant under a
rotation by 2π/``n_inner``. Extruded in ``n_axial`` equal layers, every hexahedron is the
quadrilateral above it times one axial step, so the trilinear (Q1) space holds every field of
the 2D bilinear space that is constant in z: with u_z = 0 on both ends ("roller" ends), such a
field obeys the 3D equations exactly as the plane-strain one obeys the 2D equations, per unit
length (tests/test_tube3d.py checks it on the discrete eigenvalues). The contact surface
r = R carries exactly ``n_inner`` × (``n_axial`` + 1) nodes.

Facet tags (found by position after the mesh is built, exact at the snapped nodes):
``INNER_TAG`` r = R (the contact surface), ``OUTER_TAG`` r = ξR (clamped), ``END0_TAG``
z = 0 and ``END1_TAG`` z = L (the ends: free, clamped or roller, as a scene chooses).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import dolfinx
import gmsh
import numpy as np
from mpi4py import MPI

from stickslip.meshes.annulus import (
    INNER_TAG,
    OUTER_TAG,
    TUBE_TAG,
    annulus_surfaces,
    auto_n_radial,
    distributed_gmsh_mesh,
    snap_circles,
)

__all__ = ["END0_TAG", "END1_TAG", "Tube3DMesh", "tube_mesh_3d"]

END0_TAG = 3  #: facet tag of the end z = 0
END1_TAG = 4  #: facet tag of the end z = L


@dataclass
class Tube3DMesh:
    """A distributed 3D tube mesh with its tags and the parameters it was built from."""

    mesh: dolfinx.mesh.Mesh
    cell_tags: dolfinx.mesh.MeshTags
    facet_tags: dolfinx.mesh.MeshTags
    R: float
    xi: float
    length: float
    n_inner: int
    n_radial: int
    n_axial: int
    #: the z of the contact surface's rings (n_axial + 1) and the angles of a ring's nodes
    #: (n_inner), in order: L k / n_axial and 2 pi j / n_inner on the built-in tube
    levels: np.ndarray
    angles: np.ndarray


def _check(R: float, xi: float, length: float, n_inner: int, n_radial: int,
           n_axial: int) -> None:
    if not (math.isfinite(R) and R > 0.0):
        raise ValueError(f"R={R!r}: the inner radius must be a finite number > 0")
    if not (math.isfinite(xi) and xi > 1.0):
        raise ValueError(f"xi={xi!r}: the radius ratio ξ = R*/R must be > 1")
    if not (math.isfinite(length) and length > 0.0):
        raise ValueError(f"length={length!r}: the tube's length must be a finite number > 0")
    if int(n_inner) != n_inner or n_inner < 8:
        raise ValueError(f"n_inner={n_inner!r}: need an integer >= 8 nodes around the tube")
    if int(n_radial) != n_radial or n_radial < 0:
        raise ValueError(f"n_radial={n_radial!r}: need an integer >= 0 (0 = automatic)")
    if int(n_axial) != n_axial or n_axial < 1:
        raise ValueError(f"n_axial={n_axial!r}: need an integer >= 1 element layers along z")


def _build_model(R: float, xi: float, length: float, n_inner: int, n_radial: int,
                 n_axial: int) -> None:
    """The extruded structured annulus in the current gmsh model, meshed (rank 0 only)."""
    surfaces, _, _ = annulus_surfaces(R, xi, n_inner, n_radial, recombine=True)
    out = gmsh.model.geo.extrude([(2, s) for s in surfaces], 0.0, 0.0, length,
                                 numElements=[n_axial], recombine=True)
    gmsh.model.geo.synchronize()
    volumes = [tag for dim, tag in out if dim == 3]
    gmsh.model.addPhysicalGroup(3, volumes, TUBE_TAG, name="tube")
    gmsh.model.mesh.generate(3)


def _snap(msh: dolfinx.mesh.Mesh, R: float, xi: float, length: float, n_inner: int,
          n_axial: int) -> None:
    """Put the nodes of both cylinders exactly at radius R/ξR and angles 2πj/``n_inner``
    (``snap_circles``), and every node exactly on its axial level L k/``n_axial`` (gmsh's
    arc and extrusion arithmetic leaves them ~1e-8 relative off)."""
    snap_circles(msh, R, xi, n_inner)
    x = msh.geometry.x
    dz = length / n_axial
    x[:, 2] = dz * np.rint(x[:, 2] / dz)


def _facet_tags(msh: dolfinx.mesh.Mesh, R: float, xi: float,
                length: float) -> dolfinx.mesh.MeshTags:
    """The boundary facets tagged by position (module docstring)."""
    tdim = msh.topology.dim
    msh.topology.create_connectivity(tdim - 1, tdim)
    tol = 1e-9
    where = (
        (INNER_TAG, lambda x: np.abs(np.hypot(x[0], x[1]) - R) < tol * R),
        (OUTER_TAG, lambda x: np.abs(np.hypot(x[0], x[1]) - xi * R) < tol * R),
        (END0_TAG, lambda x: np.abs(x[2]) < tol * length),
        (END1_TAG, lambda x: np.abs(x[2] - length) < tol * length),
    )
    facets, values = [], []
    for tag, marker in where:
        found = dolfinx.mesh.locate_entities_boundary(msh, tdim - 1, marker)
        facets.append(found)
        values.append(np.full(found.size, tag, dtype=np.int32))
    facets_all = np.concatenate(facets)
    order = np.argsort(facets_all, kind="stable")
    return dolfinx.mesh.meshtags(msh, tdim - 1, facets_all[order],
                                 np.concatenate(values)[order])


def tube_mesh_3d(comm: MPI.Comm, *, R: float, xi: float, length: float, n_inner: int,
                 n_axial: int, n_radial: int = 0) -> Tube3DMesh:
    """The tube ``R <= r <= ξR``, ``0 <= z <= length``, in hexahedra: ``n_inner`` nodes
    around, ``n_radial`` layers through the wall (0: ``auto_n_radial``, square cells at
    r = R), ``n_axial`` layers along z (module docstring)."""
    _check(R, xi, length, n_inner, n_radial, n_axial)
    n_radial = n_radial or auto_n_radial(xi, n_inner)
    R, xi, length = float(R), float(xi), float(length)
    msh, cell_tags, _ = distributed_gmsh_mesh(
        comm, "stickslip_tube3d",
        lambda: _build_model(R, xi, length, n_inner, n_radial, n_axial), gdim=3)
    msh.name = "tube"
    _snap(msh, R, xi, length, n_inner, n_axial)
    return Tube3DMesh(mesh=msh, cell_tags=cell_tags, facet_tags=_facet_tags(msh, R, xi, length),
                      R=R, xi=xi, length=length, n_inner=int(n_inner), n_radial=int(n_radial),
                      n_axial=int(n_axial), levels=length / n_axial * np.arange(n_axial + 1),
                      angles=2.0 * math.pi / n_inner * np.arange(n_inner))
