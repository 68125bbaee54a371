"""The finite tube's contact surface at every sample: u_r, u_theta, u_z and the status on the
(z, theta) grid of its nodes, for the axial structure of a wave (``surface.npz``).

The samples of a 3D run (``samples.npz``) are its mid-length ring's, so that every analysis
of a plane-strain run reads them unchanged. This observer keeps the whole surface besides, at
the same levels: each rank its own nodes, in float32 (a wave's displacement to 6 digits;
13 bytes a node and sample with the status), gathered to rank 0 once, at the end, and put on
the grid by each node's ring-major global index (level x N + angle). Nothing is allocated
per sample.
"""

from __future__ import annotations

import numpy as np

from stickslip.solver.observers import Cadence

__all__ = ["SURFACE_BYTES_PER_NODE_SAMPLE", "SurfaceSamples"]

#: What one node's sample costs in memory: u_r, u_theta, u_z in float32 and the status.
SURFACE_BYTES_PER_NODE_SAMPLE = 13


class SurfaceSamples:
    """Observer: the contact surface of ``problem`` (``TubeProblem.surface``) at the levels
    ``due`` says, up to ``max_samples`` of them, from ``projection``
    (``solver.contact.surface.SurfaceContactProjection``: its frames and statuses)."""

    def __init__(self, problem, projection, due, every: int, max_samples: int) -> None:
        self.problem, self.projection, self.due = problem, projection, due
        self.cadence = Cadence(every)
        m = projection.dofs.shape[0]
        self.t = np.zeros(max_samples)
        self.u = np.zeros((max_samples, 3, m), dtype=np.float32)  # u_r, u_theta, u_z
        self.status = np.zeros((max_samples, m), dtype=np.int8)
        self.now = np.zeros((m, 3))
        self.polar = np.zeros((2, m))
        self.n = 0
        self.before: dict[str, np.ndarray] | None = None  # a continued run's earlier records

    def observe(self, stepper) -> str:
        """Record level n (``stepper.u_prev`` after the step that made u_{n+1})."""
        if self.n == self.t.size:  # the planned samples are taken: the run stops anyway
            return ""
        p, i = self.projection, self.n
        stepper.u_prev.take(p.dofs, out=self.now, mode="clip")
        p.rotate(self.now, self.polar[0], self.polar[1])
        self.u[i, :2] = self.polar
        self.u[i, 2] = self.now[:, 2]
        self.status[i] = p.surface_out.status
        self.t[i] = stepper.time - stepper.dt
        self.n += 1
        return ""

    def arrays(self) -> dict[str, np.ndarray] | None:
        """Gathered to rank 0 (None elsewhere; collective): ``t`` (n,), ``z`` (L+1,),
        ``theta`` (N,), ``u_r``, ``u_theta``, ``u_z`` (n, L+1, N) and ``status``
        (n, L+1, N) on the grid of levels z and angles theta; a continued run's ``before``
        in front."""
        problem, n = self.problem, self.n
        tube = problem.tube
        # the surface's global index is ring-major: level x N + angle (solver.problem)
        level, angle = np.divmod(problem.surface.global_node_index, tube.n_inner)
        pieces = problem.comm.gather((level, angle, self.u[:n], self.status[:n]), root=0)
        if pieces is None:
            return None
        shape = (n, tube.n_axial + 1, tube.n_inner)
        out = {name: np.zeros(shape, dtype=np.float32) for name in ("u_r", "u_theta", "u_z")}
        out["status"] = np.full(shape, -1, dtype=np.int8)
        for lev, ang, u, status in pieces:
            for j, name in enumerate(("u_r", "u_theta", "u_z")):
                out[name][:, lev, ang] = u[:, j]
            out["status"][:, lev, ang] = status
        out.update(t=self.t[:n].copy(), z=tube.levels.copy(), theta=tube.angles.copy())
        if self.before is not None:  # a continuation: the records up to its checkpoint first
            for key in ("t", "u_r", "u_theta", "u_z", "status"):
                out[key] = np.concatenate([self.before[key], out[key]])
        return out
