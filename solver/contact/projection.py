"""The explicit contact step on the tube's inner circle: the nodal law of
``solver.contact.nodal`` applied at the contact nodes of a ``solver.problem.TubeProblem``.

``make_projection(problem, law)`` picks the projection for the scene's friction variant
(``solver.contact.law.ContactLaw``): nodal Coulomb, Prakash-Clifton regularised, or the 1-2-1
filtered bound. Each is the ``solver.newmark.ContactStep`` of the explicit scheme: from u_n,
the velocity predictor v~_n and a*_n = -M^{-1} K u_n it forms the trial position
u_n + dt v~_n + kappa a*_n at the contact nodes only, computes the nodal forces r_n and adds
M^{-1} r_n to the acceleration there.
"""

from __future__ import annotations

import numpy as np

from stickslip.solver.contact.law import ContactLaw, SpatialFilter
from stickslip.solver.contact.nodal import (
    ContactArrays,
    EffectivePressure,
    NeighbourFilter,
    project_contact,
    project_contact_filtered,
    project_contact_regularized,
)
from stickslip.solver.contact.surface import SurfaceContactProjection

__all__ = ["NodalFrames", "ContactProjection", "RegularizedContactProjection",
           "FilteredContactProjection", "make_projection"]


class NodalFrames:
    """(x, y) <-> (r, theta) at the contact nodes, with complex numbers.

    An owned blocked array (x0, y0, x1, y1, ...) viewed as complex128 holds z_i = x_i + i y_i
    per node, and z_i e^{-i theta_i} = u_r + i u_theta. ``nodes`` are the owned contact nodes
    (``forms.polar.ContactNodes``): ``node_index`` their local node numbers, ``phase`` =
    e^{i theta_i} (polar -> (x, y)) and ``phase_conj`` = e^{-i theta_i} ((x, y) -> polar).
    """

    def __init__(self, nodes) -> None:
        self.nodes = nodes
        self.node_index = np.asarray(nodes.nodes, dtype=np.intp)
        self.phase = np.exp(1j * nodes.theta)
        self.phase_conj = np.conj(self.phase)
        self._views: dict[int, np.ndarray] = {}

    def complex_view(self, array: np.ndarray) -> np.ndarray:
        """Cached complex128 view (one z per node) of an owned blocked array."""
        key = id(array)  # the integrator's arrays live as long as the run (cheap key)
        view = self._views.get(key)
        if view is None:
            view = self._views[key] = array.view(np.complex128)
        return view

    def polar_at_nodes(self, array: np.ndarray, out: np.ndarray) -> np.ndarray:
        """u_r + i u_theta at the contact nodes, into the complex array ``out``."""
        self.complex_view(array).take(self.node_index, out=out)  # method: no wrapper cost
        out *= self.phase_conj
        return out

    @property
    def surface_out(self) -> ContactArrays:
        """The outputs at every contact node (``problem.surface`` of a 3D tube's
        projection): here the circle's, ``out``."""
        return self.out


class ContactProjection(NodalFrames):
    """The forward-increment contact step of the explicit scheme for the tube's inner circle.

    Rotating to and from the nodes' polar frames is done with complex numbers: an owned
    blocked array (x0, y0, x1, y1, ...) viewed as complex128 holds z_i = x_i + i y_i per node,
    and z_i e^{-i theta_i} = u_r + i u_theta. So each conversion is one ``take`` and one
    multiply over the contact nodes. Calls ``solver.contact.project_contact`` (the nodal law)
    and writes the nodal forces back at the contact dofs. Each node is owned by exactly one
    rank, so nothing is double counted in parallel. All arrays are preallocated.
    """

    #: A regularised friction bound's per-node state (the subclasses that have one).
    effective: EffectivePressure | None = None

    def __init__(self, problem, law: ContactLaw) -> None:
        nd = problem.nodes
        super().__init__(nd)
        self.law = law
        self.kappa = law.kappa
        self.dt = law.dt
        self.d = law.d
        self.f = law.f
        self.slide = law.slide  # cylinder surface travel per step
        self.mass = problem.mass[nd.dofs_x].copy()
        self.inv_mass = 1.0 / self.mass
        n = nd.dofs_x.size
        self.z_now = np.zeros(n, dtype=complex)  # u_n at the nodes, polar
        self.z_trial = np.zeros(n, dtype=complex)  # trial u_{n+1}, (x, y) then polar
        self.z_work = np.zeros(n, dtype=complex)
        self.r_polar = np.zeros(n, dtype=complex)  # r_r + i r_theta
        self.r_xy = np.zeros(n, dtype=complex)  # r_x + i r_y
        self.out = ContactArrays(n, r_r=self.r_polar.real, r_t=self.r_polar.imag)

    def _project(self, u_r_trial: np.ndarray, u_t_trial: np.ndarray,
                 u_t_now: np.ndarray) -> None:
        """The nodal law (Coulomb): ``solver.contact.project_contact``."""
        project_contact(u_r_trial, u_t_trial, u_t_now, self.mass, self.kappa, self.d,
                        self.slide, self.f, self.out)

    def __call__(self, u_now: np.ndarray, v_pred: np.ndarray, accel: np.ndarray) -> None:
        """The explicit scheme's contact step (see ``solver.newmark.ContactStep``)."""
        idx, trial, work = self.node_index, self.z_trial, self.z_work
        now = self.polar_at_nodes(u_now, self.z_now)
        # trial u_{n+1} = u_n + dt v~_n + kappa a*_n at the nodes only, (x, y) then polar
        a_c = self.complex_view(accel)
        self.complex_view(v_pred).take(idx, out=trial)
        trial *= self.dt
        a_c.take(idx, out=work)
        work *= self.kappa
        trial += work
        trial *= self.phase_conj
        trial += now
        self._project(trial.real, trial.imag, now.imag)
        # back to (x, y): r_x + i r_y = (r_r + i r_t) e^{i theta}; a_n = a*_n + r / m
        np.multiply(self.r_polar, self.phase, out=self.r_xy)
        a_c.take(idx, out=work)
        np.multiply(self.r_xy, self.inv_mass, out=trial)
        work += trial
        np.put(a_c, idx, work)


    def state(self) -> dict[str, np.ndarray]:
        """The checkpoint: the statuses of the last level and, for a regularised bound,
        sigma_eff and the last u_theta (the step reads those)."""
        out = {"status": self.out.status.copy()}
        if self.effective is not None:
            eff = self.effective
            out.update(sigma=eff.sigma.copy(), u_t_last=eff.u_t_last.copy(),
                       rate=eff.rate.copy(), started=np.int8(eff.started))
        return out

    def restore(self, state: dict[str, np.ndarray]) -> None:
        """Continue from ``state()`` (in place: a compiled step holds views of the arrays)."""
        self.out.status[:] = state["status"]
        if self.effective is not None:
            eff = self.effective
            eff.sigma[:] = state["sigma"]
            eff.u_t_last[:] = state["u_t_last"]
            eff.rate[:] = state["rate"]
            eff.started = bool(state["started"])


class RegularizedContactProjection(ContactProjection):
    """``ContactProjection`` with the Prakash-Clifton friction bound (scene ``[friction]``):
    ``solver.contact.project_contact_regularized`` and the per-node state
    ``solver.contact.EffectivePressure`` (allocated once)."""

    def __init__(self, problem, law: ContactLaw) -> None:
        super().__init__(problem, law)
        self.effective = _effective_pressure(self.mass.size, law)

    def _project(self, u_r_trial: np.ndarray, u_t_trial: np.ndarray,
                 u_t_now: np.ndarray) -> None:
        project_contact_regularized(u_r_trial, u_t_trial, u_t_now, self.mass, self.kappa,
                                    self.d, self.slide, self.f, self.effective, self.out)


class FilteredContactProjection(ContactProjection):
    """``ContactProjection`` with the 1-2-1 filtered friction bound (``[friction] filter =
    "1-2-1"``): ``solver.contact.project_contact_filtered`` with a ``NeighbourFilter`` over
    the angle-ordered contact nodes (Allgather of the N nodal p's under MPI), composed with
    the Prakash-Clifton state when the scene also regularises."""

    def __init__(self, problem, law: ContactLaw) -> None:
        super().__init__(problem, law)
        nd = problem.nodes
        self.filter = NeighbourFilter(nd.global_node_index, nd.n_global, problem.comm)
        self.effective = (_effective_pressure(self.mass.size, law)
                          if law.regularisation.code else None)

    def _project(self, u_r_trial: np.ndarray, u_t_trial: np.ndarray,
                 u_t_now: np.ndarray) -> None:
        project_contact_filtered(u_r_trial, u_t_trial, u_t_now, self.mass, self.kappa, self.d,
                                 self.slide, self.f, self.filter, self.out, self.effective)


def _effective_pressure(n: int, law: ContactLaw) -> EffectivePressure:
    """The per-node Prakash-Clifton state of ``law``'s regularisation (allocated once)."""
    return EffectivePressure(n, law.regularisation, law.dt)


def make_projection(problem, law: ContactLaw) -> ContactProjection | SurfaceContactProjection:
    """The explicit contact step of ``law``'s bound: on a 3D tube's contact surface
    (``problem.surface``) the disc cone's ``SurfaceContactProjection``; in plane strain by
    the bound's spatial filter (``PROJECTIONS``), then, nodal, Coulomb or regularised."""
    if problem.surface is not None:
        return SurfaceContactProjection(problem, law)
    projection = PROJECTIONS[law.filter]
    if projection is ContactProjection and law.regularisation.code:
        projection = RegularizedContactProjection
    return projection(problem, law)


#: The explicit contact step of each spatial filter of the bound (``SpatialFilter``); a
#: filtered step composes the regularisation itself.
PROJECTIONS: dict[SpatialFilter, type[ContactProjection]] = {
    SpatialFilter.NODAL: ContactProjection,
    SpatialFilter.ONE_TWO_ONE: FilteredContactProjection,
}
