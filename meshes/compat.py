"""dolfinx version differences, kept in ONE place.

* gmsh io module: ``dolfinx.io.gmshio`` (0.9) vs ``dolfinx.io.gmsh`` (0.10+).
* ``model_to_mesh`` returns a ``(mesh, cell_tags, facet_tags)`` tuple in 0.9 and a
  ``MeshData`` object (attributes ``mesh``, ``cell_tags``, ``facet_tags``) in 0.10+.
* ``create_petsc_vector``: ``dolfinx.la.create_petsc_vector`` (0.9) vs
  ``dolfinx.la.petsc.create_vector`` (0.10+).
* ``LinearProblem`` needs ``petsc_options_prefix`` (0.10+) and ``solve()`` returns a tuple
  of solutions in some 0.10 variants: :func:`solve_linear` hides both.
"""

from __future__ import annotations

from typing import Any

import dolfinx
from mpi4py import MPI

try:  # dolfinx >= 0.10
    from dolfinx.io import gmsh as _gmshio  # type: ignore[attr-defined]
except ImportError:  # dolfinx 0.9
    from dolfinx.io import gmshio as _gmshio  # type: ignore[no-redef]

__all__ = ["DOLFINX_VERSION", "create_petsc_vector", "model_to_mesh", "solve_linear"]

DOLFINX_VERSION: tuple[int, ...] = tuple(
    int(p) for p in dolfinx.__version__.split(".")[:2] if p.isdigit()
)


def model_to_mesh(
    model: Any, comm: MPI.Comm, rank: int, gdim: int
) -> tuple[dolfinx.mesh.Mesh, dolfinx.mesh.MeshTags, dolfinx.mesh.MeshTags]:
    """Distribute a gmsh model (built on ``rank``) as ``(mesh, cell_tags, facet_tags)``."""
    out = _gmshio.model_to_mesh(model, comm, rank, gdim=gdim)
    if isinstance(out, tuple):  # 0.9
        return out[0], out[1], out[2]
    return out.mesh, out.cell_tags, out.facet_tags  # 0.10+: MeshData


def create_petsc_vector(index_map: dolfinx.common.IndexMap, bs: int) -> Any:
    """A ghosted ``PETSc.Vec`` laid out like ``index_map`` with block size ``bs``."""
    try:  # dolfinx >= 0.10
        from dolfinx.la.petsc import create_vector  # type: ignore[import-not-found]

        return create_vector(index_map, bs)
    except ImportError:  # dolfinx 0.9
        return dolfinx.la.create_petsc_vector(index_map, bs)


def solve_linear(
    a: Any, L: Any, bcs: list[Any], petsc_options: dict[str, Any], prefix: str = "stickslip_"
) -> dolfinx.fem.Function:
    """Solve the linear variational problem ``a = L`` with ``bcs`` (``LinearProblem``)."""
    import dolfinx.fem.petsc

    kwargs: dict[str, Any] = {"bcs": bcs, "petsc_options": petsc_options}
    if DOLFINX_VERSION >= (0, 10):
        kwargs["petsc_options_prefix"] = prefix
    out = dolfinx.fem.petsc.LinearProblem(a, L, **kwargs).solve()
    return out[0] if isinstance(out, tuple | list) else out
