"""A user's finite tube from a gmsh file (``mesh.file`` with ``mesh.dim = 3``: ``.geo`` or
``.msh``).

The file names its boundary surfaces by physical group: the contact surface (default
``"contact"``: r = R, which the rotating cylinder touches), the clamped surface (default
``"clamped"``: u = 0) and, optionally, the ends (default ``"ends"``: what
``boundary.ends`` holds: free, roller or clamped). The rest of the boundary is free. A
``.geo`` is meshed here in 3D; a ``.msh`` is read as it is.

The contact law, the records and the wave analysis of a 3D run read the contact surface
ring by ring (``solver.problem``): the surface must be a cross-section's contact circle
extruded, its nodes on rings z = z_k of the same angles. The axial layers may differ in
thickness (refined towards the ends, say), and the rest of the mesh is the user's own.

Checks, each a one-line :class:`MeshFileError` naming the value and the fix:

* the mesh has volume cells, all 8-node hexahedra;
* the contact and clamped surface groups exist (dimension 2; the ends group is optional);
* every node of the contact group lies on r = R (to 1e-6 R; they are then put exactly on
  it, and on their ring's z);
* the contact nodes lie on two or more rings of ``mesh.n_inner`` = N nodes each, every ring
  at the first ring's angles (to 1e-6 rad), all around (no gap wider than two mean
  spacings);
* the clamped group holds a face.

:func:`inspect_tube_file` runs the checks and counts nodes and cells (gmsh only: the scene's
validation and the size estimate use it); :func:`user_tube_mesh` distributes the mesh with
the groups as ``INNER_TAG``, ``OUTER_TAG`` and ``END0_TAG``, as the built-in tube's.
"""

from __future__ import annotations

import functools
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from stickslip.meshes.annulus import INNER_TAG, OUTER_TAG
from stickslip.meshes.tube3d import END0_TAG, Tube3DMesh
from stickslip.meshes.user_mesh import (
    MeshFileError,
    distributed_checked,
    group_nodes_on_radius,
    group_tag,
    inspected,
    physical_groups,
    retagged,
    snap_to_circle,
)

__all__ = ["TubeFileFacts", "inspect_tube_file", "user_tube_mesh"]

#: gmsh element type -> (cell, its vertices, its edges as vertex pairs): the 8-node
#: hexahedron, what a cross-section of quadrilaterals extruded along z gives (gmsh: Extrude
#: with Layers and Recombine)
_VOLUME_CELLS = {
    5: ("hexahedron", 8, ((0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4),
                          (0, 4), (1, 5), (2, 6), (3, 7))),
}
#: the angles of a ring against the first ring's, and a level's spread in z (relative)
ON_RING = 1e-6


@dataclass(frozen=True)
class TubeFileFacts:
    """What the checks found: the file, its counts, the contact surface's rings (their z,
    the angles of their nodes) and the groups' physical tags (``ends_tag`` 0: none)."""

    path: str
    n_contact: int
    levels: tuple[float, ...]
    angles: tuple[float, ...]
    n_nodes: int
    n_cells: int
    cell: str
    nodes_per_cell: int
    contact_tag: int
    clamped_tag: int
    ends_tag: int
    h_min: float  # the shortest cell edge [m]

    @property
    def n_axial(self) -> int:
        """Element layers along the contact surface: its rings less one."""
        return len(self.levels) - 1

    @property
    def length(self) -> float:
        """The contact surface's extent along z [m]."""
        return self.levels[-1] - self.levels[0]


def _load(gmsh, path: Path) -> None:
    """Open ``path`` into a new gmsh model; mesh a .geo in 3D."""
    gmsh.model.add("stickslip_user_tube")
    gmsh.merge(str(path))
    if path.suffix == ".geo":
        gmsh.model.geo.synchronize()
        gmsh.model.mesh.generate(3)


def _volume_cells(gmsh, label: str) -> tuple[int, str, int, tuple]:
    types = [int(t) for t in gmsh.model.mesh.getElementTypes(3)]
    if not types:
        raise MeshFileError(f"{label}: no volume cells: mesh the tube in 3D (a .msh holds "
                            "only the cells of its physical groups: add a Physical Volume)")
    if len(types) != 1 or types[0] not in _VOLUME_CELLS:
        names = [gmsh.model.mesh.getElementProperties(t)[0] for t in types]
        raise MeshFileError(f"{label}: cells {names}: need 8-node hexahedra alone (a "
                            "cross-section of quadrilaterals extruded: gmsh Extrude with "
                            "Layers and Recombine)")
    return (types[0], *_VOLUME_CELLS[types[0]])


def _rings(pts: np.ndarray, label: str, group: str, n_contact: int
           ) -> tuple[np.ndarray, np.ndarray]:
    """The z of the contact surface's rings and the first ring's angles (sorted), checked:
    two rings or more, ``n_contact`` nodes each, every ring at the first ring's angles."""
    z = np.sort(pts[:, 2])
    extent = float(z[-1] - z[0])
    breaks = np.flatnonzero(np.diff(z) > ON_RING * max(extent, 1.0)) + 1
    rings = np.split(np.arange(z.size), breaks)
    if len(rings) < 2:
        raise MeshFileError(f"{label}: the contact group {group!r} lies on one ring (z = "
                            f"{z[0]:g}): a 3D tube's contact surface spans two rings or more")
    counts = sorted({len(r) for r in rings})
    if counts != [n_contact]:
        raise MeshFileError(f"{label}: the contact group {group!r} has rings of {counts} "
                            f"nodes, the scene says mesh.n_inner = {n_contact}: each ring must "
                            f"hold mesh.n_inner nodes (set mesh.n_inner = {counts[0]})")
    levels = np.array([z[r].mean() for r in rings])
    level = np.searchsorted((levels[1:] + levels[:-1]) / 2.0, pts[:, 2])
    theta = np.mod(np.arctan2(pts[:, 1], pts[:, 0]), 2.0 * np.pi)
    angles = [np.sort(theta[level == k]) for k in range(levels.size)]
    off = max(float(np.max(np.abs(np.angle(np.exp(1j * (a - angles[0])))))) for a in angles)
    if off > ON_RING:
        raise MeshFileError(f"{label}: the rings of the contact group {group!r} have their "
                            f"nodes at other angles (up to {off:.3g} rad apart): mesh the "
                            "tube as a cross-section extruded along z (gmsh: Extrude, Layers)")
    gap = float(np.max(np.diff(np.append(angles[0], angles[0][0] + 2.0 * np.pi))))
    if gap > 2.0 * (2.0 * np.pi / n_contact):
        raise MeshFileError(f"{label}: the contact group {group!r} leaves a gap of "
                            f"{np.degrees(gap):.1f} degrees around the tube without nodes: it "
                            "must be the whole cylinder r = R (the cylinder turns under all of "
                            "it)")
    return levels, angles[0]


def _shortest_edge(gmsh, cell_type: int, n_vertices: int, edges: tuple) -> float:
    tags, coords, _ = gmsh.model.mesh.getNodes()
    where = np.zeros(int(np.max(tags)) + 1, dtype=np.int64)
    where[np.asarray(tags, dtype=np.int64)] = np.arange(len(tags))
    xyz = np.asarray(coords).reshape(-1, 3)
    _, cell_nodes = gmsh.model.mesh.getElementsByType(cell_type)
    v = where[np.asarray(cell_nodes, dtype=np.int64).reshape(-1, n_vertices)]
    pairs = np.asarray(edges)
    return float(np.min(np.linalg.norm(xyz[v[:, pairs[:, 0]]] - xyz[v[:, pairs[:, 1]]],
                                       axis=-1)))


def _check_model(gmsh, label: str, R: float, n_contact: int, contact_group: str,
                 clamped_group: str, ends_group: str) -> TubeFileFacts:
    """The checks of the module docstring on the current gmsh model."""
    cell_type, cell, per_cell, edges = _volume_cells(gmsh, label)
    groups = physical_groups(gmsh, 2)
    contact_tag = group_tag(groups, contact_group, "mesh.contact_group", label, "Surface")
    clamped_tag = group_tag(groups, clamped_group, "mesh.clamped_group", label, "Surface")
    pts = group_nodes_on_radius(gmsh, 2, contact_tag, R, f"{label}: ", contact_group,
                                "contact surface must be the cylinder r = geometry.R about "
                                "the z axis")
    levels, angles = _rings(pts, label, contact_group, n_contact)
    _, clamped_pts = gmsh.model.mesh.getNodesForPhysicalGroup(2, clamped_tag)
    if len(clamped_pts) < 9:  # three nodes (x, y, z each): one clamped face at least
        raise MeshFileError(f"{label}: the clamped group {clamped_group!r} has no face: "
                            "clamp at least one face of the outside")
    cells, cell_nodes = gmsh.model.mesh.getElementsByType(cell_type)
    return TubeFileFacts(
        path=label, n_contact=int(n_contact), levels=tuple(float(z) for z in levels),
        angles=tuple(float(a) for a in angles),
        n_nodes=int(np.unique(np.asarray(cell_nodes)).size), n_cells=len(cells), cell=cell,
        nodes_per_cell=per_cell, contact_tag=int(contact_tag), clamped_tag=int(clamped_tag),
        ends_tag=int(groups.get(ends_group, 0)),
        h_min=_shortest_edge(gmsh, cell_type, per_cell, edges))


@functools.lru_cache(maxsize=32)
def _inspect_cached(path: str, mtime: float, R: float, n_contact: int, contact_group: str,
                    clamped_group: str, ends_group: str) -> TubeFileFacts:
    return inspected(path, lambda gmsh: _load(gmsh, Path(path)),
                     lambda gmsh: _check_model(gmsh, f"mesh.file = {path!r}", R, n_contact,
                                               contact_group, clamped_group, ends_group))


def inspect_tube_file(path: Path, *, R: float, n_contact: int, contact_group: str = "contact",
                      clamped_group: str = "clamped", ends_group: str = "ends"
                      ) -> TubeFileFacts:
    """Run the checks of the module docstring on ``path`` (one process, gmsh only); the
    result is cached per file version and parameters."""
    path = Path(path)
    return _inspect_cached(str(path), os.path.getmtime(path), float(R), int(n_contact),
                           contact_group, clamped_group, ends_group)


def user_tube_mesh(comm, path: Path, *, R: float, xi: float, n_contact: int,  # noqa: ANN001 - an MPI communicator
                   contact_group: str = "contact", clamped_group: str = "clamped",
                   ends_group: str = "ends") -> Tube3DMesh:
    """The checked tube of ``path``, distributed over ``comm``: a ``meshes.tube3d.Tube3DMesh``
    whose facet tags are ``INNER_TAG`` on the contact group, ``OUTER_TAG`` on the clamped
    group and ``END0_TAG`` on the ends group, with the rings' ``levels`` and ``angles``
    (``n_radial`` = 0). gmsh runs on rank 0 only; a failed check raises on every rank."""
    msh, cell_tags, facet_tags, facts = distributed_checked(
        comm, lambda gmsh: _load(gmsh, Path(path)),
        lambda gmsh: _check_model(gmsh, f"mesh.file = {str(path)!r}", R, n_contact,
                                  contact_group, clamped_group, ends_group),
        gdim=3, renumber=True)
    msh.name = "tube"
    facet_tags = retagged(msh, facet_tags, {facts.contact_tag: INNER_TAG,
                                            facts.clamped_tag: OUTER_TAG,
                                            facts.ends_tag: END0_TAG})
    levels = np.array(facts.levels)
    _snap_to_rings(msh, R, levels)
    return Tube3DMesh(mesh=msh, cell_tags=cell_tags, facet_tags=facet_tags, R=float(R),
                      xi=float(xi), length=facts.length, n_inner=int(n_contact), n_radial=0,
                      n_axial=facts.n_axial, levels=levels, angles=np.array(facts.angles))


def _snap_to_rings(msh, R: float, levels: np.ndarray) -> None:  # noqa: ANN001 - a dolfinx Mesh
    """Put the geometry nodes within ``ON_CIRCLE`` R of r = R exactly on it (radially) and
    on their ring's z."""
    near = snap_to_circle(msh, R)
    x = msh.geometry.x
    ring = np.searchsorted((levels[1:] + levels[:-1]) / 2.0, x[:, 2])
    on_ring = near & (np.abs(x[:, 2] - levels[ring]) <= ON_RING * max(np.ptp(levels), 1.0))
    x[on_ring, 2] = levels[ring[on_ring]]
