"""A user's cross-section from a gmsh file (``mesh.file``: ``.geo`` or ``.msh``).

The file names two curves by physical group: the contact boundary (default name
``"contact"``: the circle r = R that the rotating cylinder touches) and the clamped boundary
(default ``"clamped"``: any part of the outside, u = 0). A ``.geo`` is meshed here (2D, at the
scene's Lagrange degree, ``Mesh.RecombineAll`` for quadrilaterals); a ``.msh`` is read as it
is. The rest of the outline is free (traction-free).

Checks, each a one-line :class:`MeshFileError` naming the value and the fix:

* the file exists and is ``.geo`` or ``.msh``;
* the mesh is 2D (no volume cells, every node at z = 0) and its cells are triangles or
  quadrilaterals of one kind and of the scene's degree (``mesh.cell``, ``mesh.degree``);
* both physical groups exist (dimension 1);
* every node of the contact group lies on r = R (to 1e-6 R; they are then put exactly on it)
  and they go all around it (no gap wider than two mean spacings);
* the clamped group holds an edge at least;
* the contact group has exactly ``mesh.n_inner`` = N nodes.

:func:`inspect_mesh_file` runs the checks and counts nodes and cells (gmsh only, no dolfinx:
the scene's validation and the size estimate use it); :func:`user_mesh` distributes the mesh
with the two groups as ``INNER_TAG`` (contact) and ``OUTER_TAG`` (clamped), as the tube's.
"""

from __future__ import annotations

import functools
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from stickslip.meshes.annulus import INNER_TAG, OUTER_TAG, TUBE_TAG, TubeMesh
from stickslip.meshes.compat import model_to_mesh

__all__ = ["MeshFileError", "MeshFileFacts", "distributed_checked", "group_nodes_on_radius",
           "group_tag", "inspect_mesh_file", "inspected", "physical_groups", "retagged",
           "snap_to_circle", "user_mesh"]

SUFFIXES = (".geo", ".msh")
ON_CIRCLE = 1e-6  # relative distance to r = R accepted for a contact node
# gmsh element type -> (cell, degree, nodes per cell)
_CELL_TYPES = {2: ("triangle", 1, 3), 9: ("triangle", 2, 6), 3: ("quadrilateral", 1, 4),
               10: ("quadrilateral", 2, 9)}


class MeshFileError(ValueError):
    """A mesh file that cannot serve as the cross-section (one line: the value and the fix)."""


@dataclass(frozen=True)
class MeshFileFacts:
    """What the checks found: the file, its counts and the groups' physical tags."""

    path: str
    n_contact: int
    n_nodes: int
    n_cells: int
    cell: str
    degree: int
    nodes_per_cell: int
    contact_tag: int
    clamped_tag: int
    h_min: float  # the shortest cell edge [m]
    rotation_invariant: bool  # the mesh's nodes map onto themselves under 2π/(N/degree)


def gmsh_session():  # noqa: ANN201 - the gmsh module and whether this call initialised it
    """gmsh, initialised (quiet) if it was not: (the module, True when the caller must
    finalise it)."""
    import gmsh

    owns = not gmsh.isInitialized()
    if owns:
        gmsh.initialize(readConfigFiles=False, interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)
    return gmsh, owns


def _load(gmsh, path: Path, cell: str, degree: int) -> None:
    """Open ``path`` into a new gmsh model; mesh a .geo (2D, ``degree``, recombined quads)."""
    gmsh.model.add("stickslip_user_mesh")
    if path.suffix == ".geo":
        gmsh.option.setNumber("Mesh.RecombineAll", 1 if cell == "quadrilateral" else 0)
        gmsh.merge(str(path))
        gmsh.model.geo.synchronize()
        gmsh.model.mesh.generate(2)
        if degree == 2:
            gmsh.option.setNumber("Mesh.SecondOrderIncomplete", 0)
            gmsh.model.mesh.setOrder(2)
    else:
        gmsh.merge(str(path))


def physical_groups(gmsh, dim: int) -> dict[str, int]:  # noqa: ANN001 - the gmsh module
    """{name: tag} of the current model's physical groups of dimension ``dim``."""
    return {gmsh.model.getPhysicalName(dim, t): t for _, t in gmsh.model.getPhysicalGroups(dim)}


def group_tag(groups: dict[str, int], name: str, key: str, label: str,
              kind: str = "Curve") -> int:
    """The tag of the group ``name`` of ``groups`` (``physical_groups``), else a one-line
    ``MeshFileError`` naming the groups there are and the fix (``kind``: its gmsh word)."""
    if name not in groups:
        have = ", ".join(repr(n) for n in sorted(groups)) or "none"
        word = kind.lower()
        raise MeshFileError(
            f"{label}: no {word} physical group named {name!r} ({key}); the file's {word} "
            f"groups: {have}: add Physical {kind}(\"{name}\") = {{...}}; or set {key}")
    return groups[name]


def _check_model(gmsh, label: str, R: float, n_contact: int, cell: str, degree: int,
                 contact_group: str, clamped_group: str) -> MeshFileFacts:
    """The checks of the module docstring on the current gmsh model."""
    if len(gmsh.model.mesh.getElementTypes(3)):
        raise MeshFileError(f"{label}: the mesh has volume cells: give a 2D cross-section "
                            "(cells in the x-y plane)")
    node_tags, xyz, _ = gmsh.model.mesh.getNodes()
    xyz = np.asarray(xyz).reshape(-1, 3)
    scale = float(np.max(np.abs(xyz[:, :2]))) if xyz.size else 1.0
    if xyz.size and float(np.max(np.abs(xyz[:, 2]))) > 1e-9 * scale:
        raise MeshFileError(f"{label}: nodes off the plane z = 0 (|z| up to "
                            f"{float(np.max(np.abs(xyz[:, 2]))):.3g}): the cross-section must "
                            "lie in the x-y plane")
    types = [int(t) for t in gmsh.model.mesh.getElementTypes(2)]
    if not len(types):
        raise MeshFileError(f"{label}: no surface cells: mesh the cross-section in 2D (a "
                            ".geo needs a Plane Surface; a .msh holds only the cells of its "
                            "physical groups: add a Physical Surface)")
    known = [_CELL_TYPES.get(t) for t in types]
    if None in known or len(types) != 1:
        names = [gmsh.model.mesh.getElementProperties(t)[0] for t in types]
        raise MeshFileError(f"{label}: cells {names}: need triangles or quadrilaterals of one "
                            "kind (3/6-node triangles or 4/9-node quadrangles)")
    file_cell, file_degree, per_cell = known[0]
    if (file_cell, file_degree) != (cell, degree):
        raise MeshFileError(f"{label}: the file has degree-{file_degree} {file_cell} cells, the "
                            f"scene says mesh.cell = {cell!r}, mesh.degree = {degree}: set "
                            f"mesh.cell = {file_cell!r}, mesh.degree = {file_degree}")
    groups = physical_groups(gmsh, 1)
    contact_tag = group_tag(groups, contact_group, "mesh.contact_group", label)
    clamped_tag = group_tag(groups, clamped_group, "mesh.clamped_group", label)
    pts = group_nodes_on_radius(gmsh, 1, contact_tag, R, f"{label}: ", contact_group,
                                "contact boundary must be the circle r = geometry.R centred "
                                "at the origin")
    r = np.hypot(pts[:, 0], pts[:, 1])
    angles = np.sort(np.arctan2(pts[:, 1], pts[:, 0]))
    gap = float(np.max(np.diff(np.append(angles, angles[0] + 2 * np.pi)))) if r.size else 0.0
    if r.size and gap > 2.0 * (2 * np.pi / r.size):
        raise MeshFileError(
            f"{label}: the contact group {contact_group!r} leaves a gap of "
            f"{np.degrees(gap):.1f} degrees of the circle r = R without nodes: it must be the "
            "whole circle (the cylinder turns under all of it)")
    _, clamped_pts = gmsh.model.mesh.getNodesForPhysicalGroup(1, clamped_tag)
    if len(clamped_pts) < 6:  # two nodes (x, y, z each): one clamped edge at least
        raise MeshFileError(f"{label}: the clamped group {clamped_group!r} has no edge: "
                            "clamp at least one edge of the outside (else the section "
                            "turns freely with the cylinder)")
    if r.size != n_contact:
        raise MeshFileError(f"{label}: the contact group {contact_group!r} has {r.size} nodes, "
                            f"the scene says mesh.n_inner = {n_contact}: set mesh.n_inner = "
                            f"{r.size}")
    cells, cell_nodes = gmsh.model.mesh.getElementsByType(types[0])
    used = np.unique(np.asarray(cell_nodes, dtype=np.int64))
    xy = xyz[np.isin(np.asarray(node_tags, dtype=np.int64), used)]  # nodes of the cells
    return MeshFileFacts(path=label, n_contact=int(r.size), n_nodes=int(used.size),
                         n_cells=len(cells), cell=file_cell, degree=file_degree,
                         nodes_per_cell=per_cell, contact_tag=int(contact_tag),
                         clamped_tag=int(clamped_tag),
                         h_min=_shortest_edge(gmsh, cell_nodes, per_cell, file_cell),
                         rotation_invariant=is_rotation_invariant(
                             xy, int(r.size) // file_degree, ON_CIRCLE * R))


def _shortest_edge(gmsh, cell_nodes, per_cell: int, cell: str) -> float:
    """The shortest cell edge (between vertices) [m], for the stability estimate."""
    tags, coords, _ = gmsh.model.mesh.getNodes()
    where = np.zeros(int(np.max(tags)) + 1, dtype=np.int64)
    where[np.asarray(tags, dtype=np.int64)] = np.arange(len(tags))
    xy = np.asarray(coords).reshape(-1, 3)[:, :2]
    n_vertices = 3 if cell == "triangle" else 4
    v = where[np.asarray(cell_nodes, dtype=np.int64).reshape(-1, per_cell)[:, :n_vertices]]
    edges = xy[v] - xy[np.roll(v, -1, axis=1)]
    return float(np.min(np.hypot(edges[..., 0], edges[..., 1])))


def resolve(file: str, search: tuple[Path, ...] = ()) -> Path:
    """The mesh file: ``file`` itself (absolute, or relative to the working directory), else
    relative to each folder of ``search`` (the shipped scenes' folder)."""
    p = Path(file)
    if p.suffix.lower() not in SUFFIXES:
        raise MeshFileError(f"mesh.file = {file!r}: not a gmsh file: give a .geo or .msh file")
    candidates = [p] if p.is_absolute() else [p, *(Path(d) / p for d in search)]
    for c in candidates:
        if c.is_file():
            return c.resolve()
    where = ", ".join(str(c) for c in candidates)
    raise MeshFileError(f"mesh.file = {file!r}: no such file (looked at {where}): give the "
                        "path of a gmsh .geo or .msh file")


def group_nodes_on_radius(gmsh, dim: int, tag: int, R: float, where: str, group: str,  # noqa: ANN001 - the gmsh module
                          what: str) -> np.ndarray:
    """The (n, 3) nodes of the physical group ``tag`` of dimension ``dim``, checked to lie
    on r = R (to ``ON_CIRCLE`` R): else ``MeshFileError`` saying how many do not and
    ``what`` the group must be."""
    _, pts = gmsh.model.mesh.getNodesForPhysicalGroup(dim, tag)
    pts = np.asarray(pts).reshape(-1, 3)
    r = np.hypot(pts[:, 0], pts[:, 1])
    off = np.abs(r - R) > ON_CIRCLE * R
    if off.any():
        worst = float(r[np.argmax(np.abs(r - R))])
        raise MeshFileError(
            f"{where}{int(off.sum())} of {r.size} nodes of the contact group {group!r} are "
            f"not on r = R = {R:g} m (one at r = {worst:.9g}): the {what}")
    return pts


def inspected(path: str, load, check):  # noqa: ANN001, ANN201 - gmsh callables, the facts
    """``check(gmsh)`` of the file ``path`` after ``load(gmsh)``, in a gmsh session of its
    own: what gmsh cannot read is a one-line ``MeshFileError`` too."""
    gmsh, owns = gmsh_session()
    try:
        load(gmsh)
        return check(gmsh)
    except Exception as err:
        if isinstance(err, MeshFileError):
            raise
        raise MeshFileError(f"mesh.file = {path!r}: gmsh cannot read it ({err}): check the "
                            "file with `gmsh FILE`") from err
    finally:
        gmsh.model.remove()
        if owns:
            gmsh.finalize()


@functools.lru_cache(maxsize=32)
def _inspect_cached(path: str, mtime: float, R: float, n_contact: int, cell: str, degree: int,
                    contact_group: str, clamped_group: str) -> MeshFileFacts:
    return inspected(path, lambda gmsh: _load(gmsh, Path(path), cell, degree),
                     lambda gmsh: _check_model(gmsh, f"mesh.file = {path!r}", R, n_contact,
                                               cell, degree, contact_group, clamped_group))


def inspect_mesh_file(path: Path, *, R: float, n_contact: int, cell: str, degree: int,
                      contact_group: str = "contact",
                      clamped_group: str = "clamped") -> MeshFileFacts:
    """Run the checks of the module docstring on ``path`` (one process, gmsh only); the
    result is cached per file version and parameters."""
    path = Path(path)
    return _inspect_cached(str(path), os.path.getmtime(path), float(R), int(n_contact), cell,
                           int(degree), contact_group, clamped_group)


def user_mesh(comm, path: Path, *, R: float, xi: float, n_contact: int, cell: str,
              degree: int, contact_group: str = "contact", clamped_group: str = "clamped"):
    """The checked mesh of ``path``, distributed over ``comm``: a ``meshes.annulus.TubeMesh``
    whose facet tags are ``INNER_TAG`` on the contact group and ``OUTER_TAG`` on the clamped
    group (``n_radial`` = 0). gmsh runs on rank 0 only; a failed check raises on every rank."""
    msh, cell_tags, facet_tags, facts = distributed_checked(
        comm, lambda gmsh: _load(gmsh, Path(path), cell, degree),
        lambda gmsh: _check_model(gmsh, f"mesh.file = {str(path)!r}", R, n_contact, cell,
                                  degree, contact_group, clamped_group), gdim=2)
    msh.name = "cross_section"
    facet_tags = retagged(msh, facet_tags, {facts.contact_tag: INNER_TAG,
                                            facts.clamped_tag: OUTER_TAG})
    snap_to_circle(msh, R)
    return TubeMesh(mesh=msh, cell_tags=cell_tags, facet_tags=facet_tags, R=float(R),
                    xi=float(xi), n_inner=int(n_contact), n_radial=0, cell=cell,
                    degree=int(degree))


def distributed_checked(comm, load, check, gdim: int, renumber: bool = False):  # noqa: ANN001, ANN201
    """(mesh, cell tags, facet tags, facts) of a user's file: on rank 0 gmsh ``load``s it
    and ``check`` returns its facts or raises ``MeshFileError`` (raised on every rank);
    cells of dimension ``gdim`` outside any physical group are grouped (dolfinx reads a
    group's cells), with ``renumber`` the nodes numbered 1 .. n (a .msh saved from its
    groups has gaps, which dolfinx does not read); then distributed over ``comm``."""
    import gmsh

    root, facts, error, owns = 0, None, None, False
    if comm.rank == root:
        _, owns = gmsh_session()
        try:
            load(gmsh)
            facts = check(gmsh)
            if not gmsh.model.getPhysicalGroups(gdim):
                gmsh.model.addPhysicalGroup(gdim, [t for _, t in gmsh.model.getEntities(gdim)],
                                            TUBE_TAG)
            if renumber:
                gmsh.model.mesh.renumberNodes()
        except MeshFileError as err:
            error = str(err)
    error, facts = comm.bcast((error, facts), root=root)
    try:
        if error is not None:
            raise MeshFileError(error)
        msh, cell_tags, facet_tags = model_to_mesh(gmsh.model, comm, root, gdim=gdim)
    finally:
        if comm.rank == root:
            gmsh.model.remove()
            if owns:
                gmsh.finalize()
    return msh, cell_tags, facet_tags, facts


def retagged(msh, facet_tags, ours: dict[int, int]):  # noqa: ANN001, ANN201 - dolfinx objects
    """The facets of the file's physical tags that ``ours`` maps (a tag 0: none), tagged with
    the project's tags (``INNER_TAG``, ...); the other facets dropped."""
    import dolfinx

    keep = np.isin(facet_tags.values, [t for t in ours if t])
    tags = np.array([ours[v] for v in facet_tags.values[keep]], dtype=np.int32)
    return dolfinx.mesh.meshtags(msh, msh.topology.dim - 1, facet_tags.indices[keep], tags)


def snap_to_circle(msh, R: float) -> np.ndarray:  # noqa: ANN001 - a dolfinx Mesh
    """Put the geometry nodes within ``ON_CIRCLE`` R of r = R exactly on it (radially);
    returns which nodes those are."""
    x = msh.geometry.x
    r = np.hypot(x[:, 0], x[:, 1])
    near = np.abs(r - R) <= ON_CIRCLE * R
    x[near, 0] *= R / r[near]
    x[near, 1] *= R / r[near]
    return near


def is_rotation_invariant(points: np.ndarray, n: int, tol: float) -> bool:
    """True when the point set maps onto itself under the rotation by 2π/n (to ``tol``)."""
    from scipy.spatial import cKDTree

    c, s = math.cos(2 * math.pi / n), math.sin(2 * math.pi / n)
    rotated = np.column_stack([c * points[:, 0] - s * points[:, 1],
                               s * points[:, 0] + c * points[:, 1]])
    dist, _ = cKDTree(points[:, :2]).query(rotated)
    return bool(np.max(dist, initial=0.0) <= tol)
