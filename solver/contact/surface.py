"""The explicit contact step on the finite tube's contact surface r = R (3D, ``mesh.dim`` = 3).

The nodal law of ``solver.contact.nodal.project_contact_disc`` at every owned node of the
surface: the normal e_r, the tangent plane (e_theta, e_z), the Coulomb cone a disc. As
``ContactProjection`` in plane strain, it is the ``solver.newmark.ContactStep`` of the explicit
scheme: from u_n, the velocity predictor v~_n and a*_n = -M^{-1} K u_n it forms the trial
position u_n + dt v~_n + kappa a*_n at the contact nodes, computes the nodal forces r_n and
adds M^{-1} r_n to the acceleration there. With u_z = 0 and no z dependence it is the plane
strain step on every ring of nodes, to round-off (tests/test_tube3d_transient.py).

What a run records is the ring of contact nodes at mid-length (``TubeProblem.nodes``): the
surface (``TubeProblem.surface``) holds that ring's nodes first, so the ring's forces and
statuses (``out``) are views of the surface's (``surface_out``), and every record of a
plane-strain run (samples, probes, the wave analysis) reads the ring as it reads the
contact circle.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stickslip.solver.contact.law import ContactLaw, SpatialFilter
from stickslip.solver.contact.nodal import (
    ContactArrays,
    EffectivePressure,
    NeighbourFilter,
    project_contact_disc,
)

__all__ = ["RingOutputs", "SurfaceContactProjection"]


@dataclass
class RingOutputs:
    """The ring's part of the surface's outputs (views): r_r, r_theta [N] and the status."""

    r_r: np.ndarray
    r_t: np.ndarray
    status: np.ndarray


class SurfaceContactProjection:
    """The forward-increment contact step of the explicit scheme on the contact surface of a 3D
    ``solver.problem.TubeProblem`` (``problem.surface``; module docstring).

    Per step: three ``take`` of (x, y, z) at the surface's dofs, the polar frame in real
    arithmetic (u_r = c x + s y, u_theta = -s x + c y), ``project_contact_disc``, and the
    forces back, r_x = c r_r - s r_theta, r_y = s r_r + c r_theta, r_z, divided by the nodal
    mass and put into a. Every array is allocated once. Each node is owned by one rank, so
    the step needs no communication.
    """

    def __init__(self, problem, law: ContactLaw) -> None:
        bs = problem.V.dofmap.index_map_bs
        ring, surface = problem.nodes, problem.surface
        self.nodes = ring  # what the records read: the ring at mid-length
        self.node_index = np.asarray(ring.nodes, dtype=np.intp)
        self.phase_conj = np.exp(-1j * ring.theta)
        order = np.asarray(surface.nodes, dtype=np.intp)  # the ring's first
        self.cos_t, self.sin_t = surface.cos_t, surface.sin_t
        self.dofs = (bs * order[:, None] + np.arange(3)).astype(np.intp)  # (m, 3): x, y, z
        self.law, self.kappa, self.dt = law, law.kappa, law.dt
        self.d, self.f, self.slide = law.d, law.f, law.slide
        self.mass = problem.mass[self.dofs[:, 0]].copy()
        # M^{-1} at the (x, y, z) dofs: 0 where an end holds a component (roller: u_z)
        self.inv_mass = problem.inv_mass[self.dofs]
        m = order.size
        self.now = np.zeros((m, 3))  # u_n at the nodes, (x, y, z)
        self.trial = np.zeros((m, 3))  # trial u_{n+1}
        self.work3 = np.zeros((m, 3))
        self.force = np.zeros((m, 3))  # r_n in (x, y, z): the work observer reads it
        self.polar = np.zeros((5, m))  # u_r~, u_theta~, u_theta,n, and scratch
        self.r_z = np.zeros(m)
        self.surface_out = ContactArrays(m)
        # a regularised bound's per-node state (Prakash-Clifton, constant time), else None
        self.effective = (EffectivePressure(m, law.regularisation, law.dt)
                          if law.regularisation.code else None)
        # the 1-2-1 filtered bound along each ring (``NeighbourFilter``), else None
        tube = problem.tube  # the ring-major index runs over every level (n_axial + 1)
        self.filter = (NeighbourFilter(surface.global_node_index,
                                       (tube.n_axial + 1) * tube.n_inner, problem.comm,
                                       ring=tube.n_inner)
                       if law.filter is SpatialFilter.ONE_TWO_ONE else None)
        n = self.node_index.size
        so = self.surface_out
        self.out = RingOutputs(so.r_r[:n], so.r_t[:n], so.status[:n])

    def rotate(self, xyz: np.ndarray, radial: np.ndarray, tangential: np.ndarray) -> None:
        """(u_r, u_theta) = (c x + s y, -s x + c y) at the surface's nodes, no allocation."""
        scratch = self.polar[4]
        np.multiply(xyz[:, 0], self.cos_t, out=radial)
        np.multiply(xyz[:, 1], self.sin_t, out=scratch)
        radial += scratch
        np.multiply(xyz[:, 1], self.cos_t, out=tangential)
        np.multiply(xyz[:, 0], self.sin_t, out=scratch)
        tangential -= scratch

    def __call__(self, u_now: np.ndarray, v_pred: np.ndarray, accel: np.ndarray) -> None:
        """The explicit scheme's contact step (see ``solver.newmark.ContactStep``)."""
        dofs, now, trial, work = self.dofs, self.now, self.trial, self.work3
        u_now.take(dofs, out=now, mode="clip")
        v_pred.take(dofs, out=trial, mode="clip")  # trial u_{n+1} = u_n + dt v~_n + kappa a*_n
        trial *= self.dt
        accel.take(dofs, out=work, mode="clip")
        work *= self.kappa
        trial += work
        trial += now
        r_trial, t_trial, t_now = self.polar[0], self.polar[1], self.polar[2]
        self.rotate(trial, r_trial, t_trial)
        self.rotate(now, self.polar[3], t_now)
        so = self.surface_out
        project_contact_disc(r_trial, t_trial, trial[:, 2], t_now, now[:, 2], self.mass,
                             self.kappa, self.d, self.slide, self.f, so, self.r_z,
                             self.effective, self.filter)
        force, scratch = self.force, self.polar[4]
        np.multiply(so.r_r, self.cos_t, out=force[:, 0])  # back to (x, y, z)
        np.multiply(so.r_t, self.sin_t, out=scratch)
        force[:, 0] -= scratch
        np.multiply(so.r_r, self.sin_t, out=force[:, 1])
        np.multiply(so.r_t, self.cos_t, out=scratch)
        force[:, 1] += scratch
        force[:, 2] = self.r_z
        np.multiply(force, self.inv_mass, out=work)  # a_n = a*_n + r / m
        accel.take(dofs, out=trial, mode="clip")
        trial += work
        np.put(accel, dofs, trial)

    def state(self) -> dict[str, np.ndarray]:
        """The checkpoint: the surface's statuses of the last level and, for a regularised
        bound, sigma_eff, the last u_theta and u_z and the rate (the step reads those)."""
        out = {"status": self.surface_out.status.copy()}
        eff = self.effective
        if eff is not None:
            out.update(sigma=eff.sigma.copy(), u_t_last=eff.u_t_last.copy(),
                       u_z_last=eff.u_z_last.copy(), rate=eff.rate.copy(),
                       started=np.int8(eff.started))
        return out

    def restore(self, state: dict[str, np.ndarray]) -> None:
        """Continue from ``state()`` (in place)."""
        self.surface_out.status[:] = state["status"]
        eff = self.effective
        if eff is not None:
            for name in ("sigma", "u_t_last", "u_z_last", "rate"):
                getattr(eff, name)[:] = state[name]
            eff.started = bool(state["started"])
