"""Polar (r, θ) projections on the contact circle (paper section 2: ``u``, ``v``, ``p``, ``q``).

Conventions: ``e_r = x/|x|``, ``e_θ = (−y, x)/|x|`` (counter-clockwise = rotation sense of the
cylinder for Ω > 0). On the inner face the tube's outward normal is ``−e_r``; the traction
exerted by the cylinder on the tube is ``t = σ·(−e_r) = p e_r + q e_θ`` (``σ_rr = −p``,
``σ_rθ = −q``).
"""

from __future__ import annotations

from dataclasses import dataclass

import dolfinx
import numpy as np
import ufl
from numpy.typing import NDArray

__all__ = [
    "ContactNodes",
    "boundary_measure",
    "contact_nodes",
    "radial_component",
    "radial_unit",
    "ring_first",
    "tangential_component",
    "tangential_unit",
    "without_held",
]


def radial_unit(x: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """``e_r = x/|x|`` (UFL, ``x = ufl.SpatialCoordinate(mesh)``)."""
    return x / ufl.sqrt(ufl.dot(x, x))


def tangential_unit(x: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """``e_θ = (−x₂, x₁)/|x|``: counter-clockwise, the sense of rotation for Ω > 0."""
    return ufl.as_vector((-x[1], x[0])) / ufl.sqrt(ufl.dot(x, x))


def radial_component(u: ufl.core.expr.Expr, x: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """``u_r = u·e_r`` (the paper's ``u``)."""
    return ufl.dot(u, radial_unit(x))


def tangential_component(u: ufl.core.expr.Expr, x: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """``u_θ = u·e_θ`` (the paper's ``v``)."""
    return ufl.dot(u, tangential_unit(x))


def boundary_measure(
    mesh: dolfinx.mesh.Mesh, facet_tags: dolfinx.mesh.MeshTags, tag: int
) -> ufl.Measure:
    """``ds`` restricted to the facets tagged ``tag`` (e.g. ``INNER_TAG``)."""
    return ufl.Measure("ds", domain=mesh, subdomain_data=facet_tags, subdomain_id=tag)


@dataclass(frozen=True)
class ContactNodes:
    """Owned nodes of the blocked space on the contact circle (for the nodal contact law).

    Arrays are aligned, one entry per owned contact node:

    * ``nodes``: local node (block) indices; ``dofs_x = bs·node``, ``dofs_y = bs·node + 1`` are
      local indices into the blocked vector's local array;
    * ``theta`` in [0, 2π), ``cos_t``, ``sin_t``: nodal polar angle;
    * ``ds_weight = ∫_Γ φ_i ds`` [m]: nodal force [N/m] / ds_weight = pressure [Pa];
    * ``global_node_index``: partition-independent rank of the node in the θ-sorted list of
      all contact nodes (0 .. n_global−1).
    """

    nodes: NDArray[np.int32]
    dofs_x: NDArray[np.int32]
    dofs_y: NDArray[np.int32]
    theta: NDArray[np.float64]
    cos_t: NDArray[np.float64]
    sin_t: NDArray[np.float64]
    ds_weight: NDArray[np.float64]
    global_node_index: NDArray[np.int64]
    n_owned: int
    n_global: int


def ring_first(surface: ContactNodes, ring: ContactNodes) -> ContactNodes:
    """The nodes of ``surface`` with those of ``ring`` (a subset) first, in the ring's
    order, then the others in their own: so arrays over the surface hold the ring's values
    as their first ``ring.n_owned`` entries."""
    rest = np.flatnonzero(~np.isin(surface.nodes, ring.nodes))
    first = np.searchsorted(surface.nodes, ring.nodes)  # ``contact_nodes`` sorts the nodes
    order = np.concatenate([first, rest]).astype(np.intp)
    return _taken(surface, order, surface.n_global)


def _taken(nodes: ContactNodes, index: NDArray, n_global: int) -> ContactNodes:
    """The nodes ``index`` (indices or a mask) of ``nodes``, every array alike."""
    taken = {name: getattr(nodes, name)[index] for name in
             ("nodes", "dofs_x", "dofs_y", "theta", "cos_t", "sin_t", "ds_weight",
              "global_node_index")}
    return ContactNodes(**taken, n_owned=int(taken["nodes"].size), n_global=int(n_global))


def without_held(nodes: ContactNodes, held: NDArray[np.int32], comm) -> ContactNodes:  # noqa: ANN001 - an MPI communicator
    """``nodes`` less those whose x dof is in ``held`` (owned local dofs that a support holds
    at 0: a 3D tube's clamped end rings). A node the support holds cannot be pushed: it is
    no contact node but part of the support. The others keep their order and global index;
    ``nodes`` itself where no rank drops one (collective)."""
    keep = ~np.isin(nodes.dofs_x, np.asarray(held))
    if not comm.allreduce(int(np.count_nonzero(~keep))):
        return nodes
    return _taken(nodes, keep, comm.allreduce(int(keep.sum())))


def contact_nodes(
    V: dolfinx.fem.FunctionSpace, facet_tags: dolfinx.mesh.MeshTags, tag: int,
    z_level: float | None = None,
) -> ContactNodes:
    """Owned nodes of the vector Lagrange space ``V`` on the facets ``tag`` (computed once);
    with ``z_level`` those of the ring z = ``z_level`` of a 3D contact surface only (its
    nodes lie on their axial levels: ``meshes.tube3d``)."""
    msh = V.mesh
    comm = msh.comm
    fdim = msh.topology.dim - 1
    msh.topology.create_connectivity(fdim, msh.topology.dim)
    bs = V.dofmap.index_map_bs
    n_local = V.dofmap.index_map.size_local
    blocks = dolfinx.fem.locate_dofs_topological(V, fdim, facet_tags.find(tag))
    nodes = np.sort(blocks[blocks < n_local]).astype(np.int32)
    if z_level is not None:
        z = V.tabulate_dof_coordinates()[nodes, 2]
        nodes = nodes[np.abs(z - z_level) <= 1e-9 * max(1.0, abs(z_level))]
    xy = V.tabulate_dof_coordinates()[nodes, :2]
    theta = np.arctan2(xy[:, 1], xy[:, 0])
    theta[theta < -1e-12] += 2.0 * np.pi
    theta = np.maximum(theta, 0.0)  # a node at θ = 0 may sit at ±1e-17: map it to 0, not 2π
    # ∫_Γ φ_i ds, assembled on the x component and summed over ranks (ghost accumulation).
    v = ufl.TestFunction(V)
    w = dolfinx.fem.assemble_vector(dolfinx.fem.form(v[0] * boundary_measure(msh, facet_tags, tag)))
    w.scatter_reverse(dolfinx.la.InsertMode.add)
    ds_weight = w.array[bs * nodes].copy()
    # Partition-independent ordering: rank of each node in the global θ-sorted list.
    all_theta = np.sort(np.concatenate(comm.allgather(theta)))
    gidx = np.searchsorted(all_theta, theta).astype(np.int64)
    return ContactNodes(
        nodes=nodes,
        dofs_x=(bs * nodes).astype(np.int32),
        dofs_y=(bs * nodes + 1).astype(np.int32),
        theta=theta,
        cos_t=np.cos(theta),
        sin_t=np.sin(theta),
        ds_weight=ds_weight,
        global_node_index=gidx,
        n_owned=int(nodes.size),
        n_global=int(all_theta.size),
    )
