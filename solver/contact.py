"""Nodal unilateral-contact / Coulomb-friction projection (paper section 2 and eq. [2]).

These are plain numpy functions over arrays of contact nodes, independent of the time loop,
so they can be tested on their own and reused by the FE solver and the reduced model.

The law, at a contact node with outward radial unit e_r (pointing from the cylinder axis into
the tube) and tangential unit e_theta (the rotation sense, Omega > 0):

* unilateral contact against the rigid cylinder of radius R + d:
  gap g = u_r - d >= 0,  p >= 0,  p g = 0;
* Coulomb friction, the cylinder surface moving at R Omega along e_theta:
  |q| <= f p;  stick (q < f p) when the tube point moves with the cylinder
  (u_theta_dot = R Omega), slip otherwise with q = f p sign(R Omega - u_theta_dot).

The forward-increment Lagrange-multiplier treatment of Carpenter, Taylor & Katona [CAR 91]:
a nodal force r = (r_r, r_theta) applied at step n moves the node at step n+1 by
``kappa / m * r`` (``kappa`` comes from the Newmark scheme, see ``solver.newmark``), so the
multiplier that enforces a constraint at n+1 is found node by node, in closed form, from the
*trial* position (the position at n+1 without contact force):

* normal:  r_r = m (d - u_r_trial) / kappa if u_r_trial < d, else 0 (separation);
* tangent: the stick force makes the node move with the cylinder over the step,
  r_theta_stick = m (u_theta_prev + R Omega dt - u_theta_trial) / kappa;
  stick if |r_theta_stick| <= f r_r, else slip with r_theta = f r_r sign(r_theta_stick).
"""

from __future__ import annotations

import numpy as np

SEPARATION, STICK, SLIP = 0, 1, 2
STATUS_NAMES = ("separation", "stick", "slip")


def gap(u_r: np.ndarray, d: float) -> np.ndarray:
    """Normal gap g = u_r - d between the tube and the cylinder (>= 0 when admissible)."""
    return u_r - d


def project_contact(
    u_r_trial: np.ndarray,
    u_t_trial: np.ndarray,
    u_t_prev: np.ndarray,
    mass: np.ndarray,
    kappa: float,
    d: float,
    slide: float,
    f: float,
    out: ContactArrays,
) -> None:
    """Contact/friction multipliers for one step, written into ``out`` (no allocation).

    Parameters
    ----------
    u_r_trial, u_t_trial
        Radial and tangential displacement of each contact node at t_{n+1} *without* contact
        force (the Newmark predictor).
    u_t_prev
        Tangential displacement at t_n (stick = move with the cylinder from here).
    mass
        Lumped nodal mass (same for both components), kg/m (plane strain: per unit depth).
    kappa
        Newmark factor: a nodal force r changes u_{n+1} by kappa / m * r.
    d
        Mismatch (radius excess of the cylinder), m.
    slide
        Distance the cylinder surface travels in one step, R Omega dt.
    f
        Friction coefficient. With f == 0 the tangential work is skipped entirely.
    out
        ``r_r``, ``r_t`` (normal and tangential nodal force on the tube, N/m), ``status``
        (SEPARATION, STICK, SLIP per node) and scratch arrays.
    """
    r_r, r_t, work = out.r_r, out.r_t, out.work
    np.multiply(mass, 1.0 / kappa, out=out.stiff)  # force per unit of displacement correction
    # Normal: project onto u_r >= d.
    np.subtract(d, u_r_trial, out=r_r)
    np.maximum(r_r, 0.0, out=r_r)
    r_r *= out.stiff
    np.greater(r_r, 0.0, out=out.in_contact)
    if f == 0.0:  # frictionless: contact nodes slip freely, no tangential force
        r_t.fill(0.0)
        np.multiply(out.in_contact, SLIP, out=out.status)
        return
    # Tangential trial (stick) force: the node moves with the cylinder over the step.
    np.add(u_t_prev, slide, out=r_t)
    r_t -= u_t_trial
    r_t *= out.stiff
    # Coulomb cone: slip where |r_t| > f r_r.
    np.abs(r_t, out=work)
    np.multiply(r_r, f, out=out.cone)
    np.greater(work, out.cone, out=out.slipping)
    # status = in_contact * (STICK + slipping): 0 separation, 1 stick, 2 slip.
    np.add(out.slipping, STICK, out=out.status)
    out.status *= out.in_contact
    # Slip: return to the cone, q = f p sign(relative sliding).
    np.copysign(out.cone, r_t, out=work)
    np.copyto(r_t, work, where=out.slipping)


class ContactArrays:
    """Preallocated per-node arrays of the projection (outputs and scratch)."""

    def __init__(self, n: int, r_r: np.ndarray | None = None,
                 r_t: np.ndarray | None = None) -> None:
        # r_r, r_t may be views supplied by the caller (e.g. the real and imaginary parts of
        # one complex array, so that rotating the force back to (x, y) is one multiply).
        self.r_r = np.zeros(n) if r_r is None else r_r
        self.r_t = np.zeros(n) if r_t is None else r_t
        self.status = np.zeros(n, dtype=np.int8)
        self.stiff = np.zeros(n)
        self.work = np.zeros(n)
        self.cone = np.zeros(n)
        self.in_contact = np.zeros(n, dtype=bool)
        self.slipping = np.zeros(n, dtype=bool)


class NodalFrames:
    """(x, y) <-> (r, theta) at the contact nodes, with complex numbers.

    An owned blocked array (x0, y0, x1, y1, ...) viewed as complex128 holds z_i = x_i + i y_i
    per node, and z_i e^{-i theta_i} = u_r + i u_theta. Subclasses set ``node_index`` (local
    node numbers of the contact nodes), ``phase_conj`` (e^{-i theta_i}) and ``_views`` ({}).
    """

    node_index: np.ndarray
    phase_conj: np.ndarray
    _views: dict

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

    def _polar(self, array: np.ndarray, radial: np.ndarray, tangential: np.ndarray) -> None:
        """Radial and tangential components at the contact nodes (diagnostics, not hot)."""
        z = self.polar_at_nodes(array, np.empty(self.node_index.size, dtype=complex))
        radial[:] = z.real
        tangential[:] = z.imag


def zone_fractions(status: np.ndarray) -> dict[str, float]:
    """Fractions of node-samples in separation / stick / slip."""
    total = max(1, status.size)
    return {
        "separation": float(np.count_nonzero(status == SEPARATION)) / total,
        "stick": float(np.count_nonzero(status == STICK)) / total,
        "slip": float(np.count_nonzero(status == SLIP)) / total,
    }
