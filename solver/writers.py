"""Field output for ParaView: displacement, velocity, stress and contact tractions.

Created only when a scene sets ``output.fields = true``. Per written time level n:

* on the nodes of the tube's Lagrange space: ``displacement`` u_n and ``velocity`` v_n [m,
  m/s]; on the contact circle ``contact_pressure`` p = r_r / ∫φ_i ds and
  ``contact_shear`` q = r_θ / ∫φ_i ds [Pa], where r_r, r_θ are the nodal forces [N/m] that
  the cylinder exerts on the tube in the contact step (``solver.contact.projection``;
  ``forms.polar``: traction ``t = p e_r + q e_θ``, so p > 0 presses, q > 0 pulls the tube
  along the rotation), and ``contact_status`` (0 / 1 / 2 = separation / stick / slip).
  Away from the contact circle p = q = 0 and the status is −1;
* per cell: ``sigma_rr``, ``sigma_tt``, ``sigma_rt``, ``von_mises`` [Pa] in the cylinder's
  polar frame, the cell averages of ``forms.stress`` (plane strain: von Mises includes
  σ_zz = ν (σ_rr + σ_θθ)). One assembly over the cells per written level, none per step.

Formats (``output.field_format``):

* ``"vtx"`` (default): dolfinx's ``VTXWriter`` (ADIOS2 BP4), ``fields.bp`` (the nodal fields;
  the mesh written once) and ``stress.bp`` (the cell fields). ParaView opens each folder with
  its *ADIOS2VTXReader*;
* ``"xdmf"``: one ``fields.xdmf`` + ``fields.h5`` with all of them (ParaView's *Xdmf3 Reader*).

Both are written collectively under MPI (one file set, written in parallel).
"""

from __future__ import annotations

from pathlib import Path

import dolfinx
import dolfinx.fem
import dolfinx.io
import numpy as np
import ufl

from stickslip.forms.stress import (
    STRESS_COMPONENTS,
    STRESS_COMPONENTS_3D,
    cell_area,
    cell_average_stress,
)

__all__ = ["FIELD_FILES", "FieldFrames", "FieldValues", "NODAL_FIELDS"]

#: The nodal fields, in the order they are written.
NODAL_FIELDS = ("displacement", "velocity", "contact_pressure", "contact_shear",
                "contact_status")
#: The entries a run directory gets per format.
FIELD_FILES = {"vtx": ("fields.bp", "stress.bp"), "xdmf": ("fields.xdmf", "fields.h5")}


class FieldValues:
    """The fields of one time level (module docstring) as dolfinx Functions, no files.

    ``update(u, v, contact)``: u, v the owned dofs of u_n, v_n; ``contact`` the contact
    step's ``surface_out`` (r_r, r_t, status at the owned contact nodes, in the order of
    ``problem.nodes``, or of a 3D tube's ``problem.surface``). In 3D the cell stress is
    ``forms.stress.cylindrical_stress``'s six components and von Mises.
    """

    def __init__(self, problem) -> None:
        msh = problem.V.mesh
        self.problem = problem
        self.n_owned = problem.n_owned
        degree = problem.V.ufl_element().degree
        scalar = dolfinx.fem.functionspace(msh, ("Lagrange", degree))
        self.u = dolfinx.fem.Function(problem.V, name="displacement")
        self.v = dolfinx.fem.Function(problem.V, name="velocity")
        self.pressure = dolfinx.fem.Function(scalar, name="contact_pressure")
        self.shear = dolfinx.fem.Function(scalar, name="contact_shear")
        self.status = dolfinx.fem.Function(scalar, name="contact_status")
        self.status.x.array[:] = -1.0
        contact = problem.nodes if problem.surface is None else problem.surface
        self.nodes = contact.nodes
        self.inv_ds = 1.0 / contact.ds_weight  # nodal force [N/m, N in 3D] -> traction [Pa]
        # cell stress: s_K = (∫_K s·q dx) / |K| on (DG0)^k, components split into scalars
        names = STRESS_COMPONENTS if msh.geometry.dim == 2 else STRESS_COMPONENTS_3D
        cells4 = dolfinx.fem.functionspace(msh, ("DG", 0, (len(names),)))
        cells = dolfinx.fem.functionspace(msh, ("DG", 0))
        self._stress_rhs = dolfinx.fem.form(
            cell_average_stress(self.u, problem.material, ufl.TestFunction(cells4)))
        area = dolfinx.fem.assemble_vector(dolfinx.fem.form(cell_area(ufl.TestFunction(cells))))
        self.n_cells = cells.dofmap.index_map.size_local
        self._inv_area = 1.0 / area.array[: self.n_cells]
        self._stress_vec = dolfinx.fem.Function(cells4).x  # the assembly target, reused
        self.stress = [dolfinx.fem.Function(cells, name=n) for n in names]

    @property
    def nodal(self) -> list:
        """The nodal Functions, in the order of ``NODAL_FIELDS``."""
        return [self.u, self.v, self.pressure, self.shear, self.status]

    def update(self, u: np.ndarray, v: np.ndarray, contact) -> None:
        """Fill the fields from u_n, v_n (owned dofs) and the contact step's ``out``."""
        n = self.n_owned
        for fn, values in ((self.u, u), (self.v, v)):
            fn.x.array[:n] = values
            fn.x.scatter_forward()
        self.pressure.x.array[self.nodes] = contact.r_r * self.inv_ds
        self.shear.x.array[self.nodes] = contact.r_t * self.inv_ds
        self.status.x.array[self.nodes] = contact.status
        for fn in (self.pressure, self.shear, self.status):
            fn.x.scatter_forward()
        rhs = self._stress_vec
        rhs.array[:] = 0.0
        dolfinx.fem.assemble_vector(rhs.array, self._stress_rhs)
        k = len(self.stress)
        cellwise = rhs.array[: k * self.n_cells].reshape(-1, k)
        for j, fn in enumerate(self.stress):
            fn.x.array[: self.n_cells] = cellwise[:, j] * self._inv_area
            fn.x.scatter_forward()


class FieldFrames(FieldValues):
    """``FieldValues`` written to the files of ``output.field_format`` (module docstring)."""

    def __init__(self, problem, directory: Path, file_format: str = "vtx") -> None:
        super().__init__(problem)
        self.directory = Path(directory)
        self.format = file_format
        comm = problem.V.mesh.comm
        if file_format == "vtx":
            policy = dolfinx.io.VTXMeshPolicy.reuse
            self._files = [
                dolfinx.io.VTXWriter(comm, str(self.directory / "fields.bp"), self.nodal,
                                     engine="BP4", mesh_policy=policy),
                dolfinx.io.VTXWriter(comm, str(self.directory / "stress.bp"), self.stress,
                                     engine="BP4"),
            ]
        elif file_format == "xdmf":
            xdmf = dolfinx.io.XDMFFile(comm, str(self.directory / "fields.xdmf"), "w")
            xdmf.write_mesh(problem.V.mesh)
            self._files = [xdmf]
        else:
            raise ValueError(f"output.field_format={file_format!r}: use 'vtx' or 'xdmf'")

    def write(self, time: float, u: np.ndarray, v: np.ndarray, contact) -> None:
        """Update the fields (``update``) and write them at ``time`` (collective)."""
        self.update(u, v, contact)
        if self.format == "vtx":
            for f in self._files:
                f.write(time)
        else:
            for fn in (*self.nodal, *self.stress):
                self._files[0].write_function(fn, time)

    def close(self) -> None:
        for f in self._files:
            f.close()
        self._files = []
