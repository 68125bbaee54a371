"""Optional field output for ParaView: XDMF time series of the displacement and contact status.

Created only when a scene sets ``output.fields = true`` (no writer otherwise). XDMF (HDF5)
is always available in dolfinx; open ``fields.xdmf`` in ParaView (Xdmf3 reader).
"""

from __future__ import annotations

from pathlib import Path

import dolfinx
import dolfinx.io
import numpy as np


class FieldWriter:
    """Writes u (vector, P1/P2 → its own space) and the nodal contact status every call.

    ``status`` is a scalar field of the same degree: -1 away from the contact circle, and
    0 / 1 / 2 = separation / stick / slip at the contact nodes.
    """

    def __init__(self, problem, path: Path) -> None:
        self.problem = problem
        msh = problem.V.mesh
        self.u = dolfinx.fem.Function(problem.V, name="displacement")
        degree = problem.V.ufl_element().degree
        S = dolfinx.fem.functionspace(msh, ("Lagrange", degree))
        self.status = dolfinx.fem.Function(S, name="contact_status")
        self.path = Path(path)
        self.file = dolfinx.io.XDMFFile(msh.comm, str(self.path), "w")
        self.file.write_mesh(msh)
        self._status_nodes = problem.nodes.nodes

    def write(self, time: float, u_owned: np.ndarray, status: np.ndarray) -> None:
        n = u_owned.size
        self.u.x.array[:n] = u_owned
        self.u.x.scatter_forward()
        arr = self.status.x.array
        arr[:] = -1.0
        arr[self._status_nodes] = status
        self.status.x.scatter_forward()
        self.file.write_function(self.u, time)
        self.file.write_function(self.status, time)

    def close(self) -> None:
        self.file.close()
