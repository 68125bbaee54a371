"""The nodal unilateral-contact / Coulomb-friction projection (paper section 2 and eq. [2]).

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

from stickslip.solver.contact.law import (
    SEPARATION,
    SLIP,
    STICK,
    Regularisation,
)


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

    Args:
        u_r_trial, u_t_trial: Radial and tangential displacement of each contact node at
            t_{n+1} *without* contact force (the Newmark predictor).
        u_t_prev: Tangential displacement at t_n (stick = move with the cylinder from here).
        mass: Lumped nodal mass (same for both components), kg/m (plane strain: per unit depth).
        kappa: Newmark factor: a nodal force r changes u_{n+1} by kappa / m * r.
        d: Mismatch (radius excess of the cylinder), m.
        slide: Distance the cylinder surface travels in one step, R Omega dt.
        f: Friction coefficient. With f == 0 the tangential work is skipped entirely.
        out: ``r_r``, ``r_t`` (normal and tangential nodal force on the tube, N/m), ``status``
            (SEPARATION, STICK, SLIP per node) and scratch arrays.
    """
    project_normal(u_r_trial, mass, kappa, d, out)
    if f == 0.0:  # frictionless: contact nodes slip freely, no tangential force
        out.r_t.fill(0.0)
        np.multiply(out.in_contact, SLIP, out=out.status)
        return
    np.multiply(out.r_r, f, out=out.cone)  # Coulomb bound f p
    project_tangential(u_t_trial, u_t_prev, slide, out)


def project_normal(u_r_trial: np.ndarray, mass: np.ndarray, kappa: float, d: float,
                   out: ContactArrays) -> None:
    """Normal multiplier r_r = m (d - u_r_trial)^+ / kappa (u_r,{n+1} >= d exactly), and
    ``out.stiff`` = m / kappa, ``out.in_contact``."""
    r_r = out.r_r
    np.multiply(mass, 1.0 / kappa, out=out.stiff)  # force per unit of displacement correction
    np.subtract(d, u_r_trial, out=r_r)
    np.maximum(r_r, 0.0, out=r_r)
    r_r *= out.stiff
    np.greater(r_r, 0.0, out=out.in_contact)


def project_tangential(u_t_trial: np.ndarray, u_t_prev: np.ndarray, slide: float,
                       out: ContactArrays) -> None:
    """Tangential multiplier inside the friction bound ``out.cone`` (>= 0 per node; it must be
    zero where separated: r_r = 0 there for Coulomb, and ``EffectivePressure`` zeroes it).

    The stick force makes the node move with the cylinder over the step; where it exceeds the
    bound the node slips with r_theta = cone sign(r_theta_stick). Statuses 0/1/2.
    """
    r_t, work = out.r_t, out.work
    np.add(u_t_prev, slide, out=r_t)
    r_t -= u_t_trial
    r_t *= out.stiff
    np.abs(r_t, out=work)
    np.greater(work, out.cone, out=out.slipping)
    # status = in_contact * (STICK + slipping): 0 separation, 1 stick, 2 slip.
    np.add(out.slipping, STICK, out=out.status)
    out.status *= out.in_contact
    np.copysign(out.cone, r_t, out=work)
    np.copyto(r_t, work, where=out.slipping)


def project_contact_disc(
    u_r_trial: np.ndarray, u_t_trial: np.ndarray, u_z_trial: np.ndarray,
    u_t_prev: np.ndarray, u_z_prev: np.ndarray, mass: np.ndarray, kappa: float, d: float,
    slide: float, f: float, out: ContactArrays, r_z: np.ndarray,
    effective: EffectivePressure | None = None, filt: NeighbourFilter | None = None,
) -> None:
    """``project_contact`` on a contact surface: the tangent plane is (e_theta, e_z) and the
    Coulomb cone a disc, |q| <= f p (the finite tube, ``solver.contact.surface``).

    The stick force moves the node with the cylinder's surface over the step,

        q_stick = m / kappa (u_theta,n + R Omega dt - u_theta~, u_z,n - u_z~),

    stick where |q_stick| <= f p, else slip with the return mapping onto the disc,
    q = f p q_stick / |q_stick| (the slip takes the direction of the trial traction). The
    axial force is written into ``r_z``. Where u_z~ = u_z,n the step is ``project_contact``'s,
    bit for bit: |q_stick| = |q_theta,stick| and q_theta,stick / |q_stick| = +-1 exactly.
    With ``effective`` (a regularised bound, ``EffectivePressure``) the disc's radius is
    f sigma_eff, sigma_eff relaxing at the tangent plane's slip rate, and without axial motion
    the step is ``project_contact_regularized``'s. With ``filt`` (``NeighbourFilter`` along
    each ring) the bound takes the filtered pressure p~, as ``project_contact_filtered``.
    """
    project_normal(u_r_trial, mass, kappa, d, out)
    r_t, work, norm = out.r_t, out.work, out.cone_norm
    if f == 0.0:  # frictionless: contact nodes slip freely, no tangential force
        r_t.fill(0.0)
        r_z.fill(0.0)
        np.multiply(out.in_contact, SLIP, out=out.status)
        return
    p = out.r_r if filt is None else filt.apply(out.r_r, out.in_contact)
    if effective is None:
        np.multiply(p, f, out=out.cone)  # Coulomb bound f p (or f p~)
    else:
        effective.update(p, u_t_prev, slide, f, out, u_z_prev)  # f sigma_eff
    np.add(u_t_prev, slide, out=r_t)  # the stick force, in project_tangential's operations
    r_t -= u_t_trial
    r_t *= out.stiff
    np.subtract(u_z_prev, u_z_trial, out=r_z)
    r_z *= out.stiff
    np.hypot(r_t, r_z, out=norm)
    np.greater(norm, out.cone, out=out.slipping)
    np.add(out.slipping, STICK, out=out.status)
    out.status *= out.in_contact
    for component in (r_t, r_z):  # q = f p q_stick / |q_stick| where slipping (norm > 0)
        np.divide(component, norm, out=work, where=out.slipping)
        work *= out.cone
        np.copyto(component, work, where=out.slipping)


# ---------------------------------------------------------------------------------------------
# Regularised friction bound (Prakash-Clifton)


def relax_effective_pressure(sigma: np.ndarray, p: np.ndarray, rate: np.ndarray, dt: float,
                             work: np.ndarray) -> None:
    """Exact step of d sigma/dt = -rate (sigma - p) with p and rate frozen over dt, in place:

        sigma <- p + (sigma - p) exp(-rate dt).

    Unconditionally stable and exact for any dt at frozen (p, rate); ``work`` is scratch.
    """
    np.multiply(rate, -dt, out=work)
    np.exp(work, out=work)
    sigma -= p
    sigma *= work
    sigma += p


class EffectivePressure:
    """Per-node state of the Prakash-Clifton law (Prakash & Clifton 1993; Ranjith & Rice 2001):
    the friction bound is f sigma_eff with

        d sigma_eff / dt = -(|V| + V*) / L (sigma_eff - p)        ("prakash-clifton")
        d sigma_eff / dt = -(sigma_eff - p) / t*                   ("constant-time")

    in nodal-force units (N/m, as the multipliers), V the slip rate of the node relative to
    the cylinder. Each step (``update``) integrates it exactly with the rate frozen at the
    previous step's slip rate |u_theta,n - u_theta,{n-1} - R Omega dt| / dt and p = r_r,n, the
    normal multiplier of this step; then the tangential projection uses cone = f sigma_eff.
    The normal projection is untouched (exact non-penetration) and stick is still exact.

    Out of contact sigma_eff follows the same law with p = 0: the ODE is defined for every
    p >= 0, so this is its continuous extension; sigma_eff is a memory of the pressure that
    fades over a slip distance L (or a time t*) after lift-off, and at re-contact the bound
    builds up gradually from what is left, which is the very delay that regularises the
    Coulomb law. (Resetting it to 0 or to p would be an infinitely fast relaxation, the
    instantaneous response that Prakash-Clifton removes.) A separated node has no friction
    force whatever sigma_eff is: friction needs contact. At the first step sigma_eff = p, so
    steady sliding is a fixed point. All arrays are allocated once.
    """

    def __init__(self, n: int, reg: Regularisation, dt: float) -> None:
        if reg.code == 0:
            raise ValueError(f"{type(reg).__name__}: not a regularised law")
        self.regularisation, self.dt = reg, dt
        # rate = |V dt| rate_slip + rate_base (``Regularisation``); a slip-independent rate
        # (rate_slip = 0) is set once, a slip-dependent one at each update
        self.rate_slip, self.rate_base = reg.rates(dt)
        self.sigma = np.zeros(n)
        self.rate = np.zeros(n) if self.rate_slip else np.full(n, self.rate_base)
        self.u_t_last = np.zeros(n)  # u_theta,{n-1}
        self.u_z_last = np.zeros(n)  # u_z,{n-1} on a contact surface (``update``'s u_z_now)
        self.work = np.zeros(n)
        self.started = False

    def update(self, p: np.ndarray, u_t_now: np.ndarray, slide: float, f: float,
               out: ContactArrays, u_z_now: np.ndarray | None = None) -> None:
        """Advance sigma_eff to t_n and set ``out.cone`` = f sigma_eff where in contact, else 0.
        On a contact surface (``u_z_now``) the slip rate is the tangent plane's,
        |V| dt = |(u_theta,n - u_theta,{n-1} - slide, u_z,n - u_z,{n-1})|, which is the
        circle's |u_theta,n - u_theta,{n-1} - slide| bit for bit where u_z does not move."""
        if not self.started:
            self.sigma[:] = p
            self.u_t_last[:] = u_t_now  # at rest: slip rate R Omega, as in steady sliding
            if u_z_now is not None:
                self.u_z_last[:] = u_z_now
            self.started = True
        if self.rate_slip:
            # Prakash-Clifton: rate = (|V| + V*) / L, V = (u_theta,n - u_theta,{n-1} - slide) / dt
            np.subtract(u_t_now, self.u_t_last, out=self.rate)
            self.rate -= slide
            if u_z_now is None:
                np.abs(self.rate, out=self.rate)
            else:
                np.subtract(u_z_now, self.u_z_last, out=self.work)
                np.hypot(self.rate, self.work, out=self.rate)
            self.rate *= self.rate_slip
            self.rate += self.rate_base
        relax_effective_pressure(self.sigma, p, self.rate, self.dt, self.work)
        self.u_t_last[:] = u_t_now
        if u_z_now is not None:
            self.u_z_last[:] = u_z_now
        np.multiply(self.sigma, f, out=out.cone)
        out.cone *= out.in_contact  # no friction without contact


def project_contact_regularized(
    u_r_trial: np.ndarray, u_t_trial: np.ndarray, u_t_prev: np.ndarray, mass: np.ndarray,
    kappa: float, d: float, slide: float, f: float, effective: EffectivePressure,
    out: ContactArrays,
) -> None:
    """``project_contact`` with the Prakash-Clifton bound f sigma_eff instead of f p."""
    project_normal(u_r_trial, mass, kappa, d, out)
    effective.update(out.r_r, u_t_prev, slide, f, out)
    project_tangential(u_t_trial, u_t_prev, slide, out)


# ---------------------------------------------------------------------------------------------
# Filtered friction bound (1-2-1 along the contact circle)


class NeighbourFilter:
    """The 1-2-1 filter of nodal normal reactions along the contact circle:

        p~_i = in_contact_i (p_{i-1} + 2 p_i + p_{i+1}) / 4,

    neighbours in angle, periodic (node i-1 of the first node is the last). The friction
    bound of node i becomes f p~_i instead of f p_i (docs/friction_filter.md): the node-by-node
    Coulomb bound is what carries the FE's spurious mesh-scale flutter branch
    (docs/continuum.md); the filter is exact on a uniform pressure, so steady sliding is
    unchanged, and p~_i = 0 off contact (friction needs contact).

    ``global_index``: partition-independent rank of each owned node in the angle-sorted list
    of all ``n_global`` contact nodes (``forms.polar.ContactNodes.global_node_index``). Under
    MPI the N nodal p's are Allgather-ed each step (N is small: ~1 kB), so each rank filters
    the same global array: results do not depend on the rank count. Arrays are allocated once.
    On a 3D tube's contact surface the filter runs along each ring of ``ring`` nodes: the
    global index is ring x ``ring`` + the angle's rank, and the neighbours are the ring's
    (``ring`` = ``n_global``: the circle); ``n_global`` then bounds the index (every level's
    ring, a clamped end's held ring too, which has no contact node).
    """

    def __init__(self, global_index: np.ndarray, n_global: int, comm=None,
                 ring: int | None = None) -> None:
        gidx = np.asarray(global_index, dtype=np.intp)
        self.comm = comm if comm is not None and comm.size > 1 else None
        self.full = np.zeros(n_global)  # p at every contact node, in angle order
        self.mine = gidx
        ring = n_global if ring is None else ring
        start = gidx - gidx % ring  # the first node of each node's ring
        self.left = start + (gidx - start - 1) % ring
        self.right = start + (gidx - start + 1) % ring
        self.p = np.zeros(gidx.size)  # p~ at the owned nodes (the output)
        self.work = np.zeros(gidx.size)
        if self.comm is not None:
            counts = np.asarray(self.comm.allgather(gidx.size))
            self.counts = counts
            self.displs = np.concatenate([[0], np.cumsum(counts)[:-1]])
            self.order = np.concatenate(self.comm.allgather(gidx))  # gathered slot -> node
            self.gathered = np.zeros(int(counts.sum()))  # the nodes, in the ranks' order
            self.send = np.zeros(gidx.size)  # contiguous copy (p may be a strided view)

    def apply(self, p: np.ndarray, in_contact: np.ndarray) -> np.ndarray:
        """p~ of the owned nodes into ``self.p`` (returned), from their nodal reactions ``p``."""
        if self.comm is None:
            self.full[self.mine] = p
        else:
            from mpi4py import MPI

            self.send[:] = p
            self.comm.Allgatherv(self.send, [self.gathered, self.counts, self.displs, MPI.DOUBLE])
            self.full[self.order] = self.gathered
        out, work = self.p, self.work
        self.full.take(self.left, out=out)
        self.full.take(self.right, out=work)
        out += work
        self.full.take(self.mine, out=work)
        work *= 2.0
        out += work
        out *= 0.25
        out *= in_contact
        return out


def project_contact_filtered(
    u_r_trial: np.ndarray, u_t_trial: np.ndarray, u_t_prev: np.ndarray, mass: np.ndarray,
    kappa: float, d: float, slide: float, f: float, filt: NeighbourFilter,
    out: ContactArrays, effective: EffectivePressure | None = None,
) -> None:
    """``project_contact`` with the filtered bound f p~_i (``NeighbourFilter``).

    1. the normal projection of every node, unchanged (exact non-penetration): p_i = r_r,i;
    2. p~ = the 1-2-1 filter of p along the circle (zero where separated);
    3. the tangential stick/slip projection with bound f p~_i (stick stays exact); with a
       ``effective`` (Prakash-Clifton) state, sigma_eff relaxes towards p~ and the bound is
       f sigma_eff.
    """
    project_normal(u_r_trial, mass, kappa, d, out)
    if f == 0.0:
        out.r_t.fill(0.0)
        np.multiply(out.in_contact, SLIP, out=out.status)
        return
    p_filtered = filt.apply(out.r_r, out.in_contact)
    if effective is None:
        np.multiply(p_filtered, f, out=out.cone)
    else:
        effective.update(p_filtered, u_t_prev, slide, f, out)
    project_tangential(u_t_trial, u_t_prev, slide, out)


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
        self.cone_norm = np.zeros(n)  # |q_stick| on a contact surface (the disc cone)
        self.in_contact = np.zeros(n, dtype=bool)
        self.slipping = np.zeros(n, dtype=bool)


def zone_fractions(status: np.ndarray) -> dict[str, float]:
    """Fractions of node-samples in separation / stick / slip."""
    total = max(1, status.size)
    return {
        "separation": float(np.count_nonzero(status == SEPARATION)) / total,
        "stick": float(np.count_nonzero(status == STICK)) / total,
        "slip": float(np.count_nonzero(status == SLIP)) / total,
    }
