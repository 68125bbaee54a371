"""The per-step contact/friction complementarity problem on a Schur complement (implicit scheme).

A primal-dual active set (semi-smooth Newton, Hueber-Stadler-Wohlmuth) for the nodal unilateral
contact + Coulomb law, with a friction-bound fixed point as fallback; plain numpy on rank 0.
The derivation and the time scheme that calls it: ``solver.implicit``.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from stickslip.solver.contact import SLIP
from stickslip.solver.errors import Diverged

MAX_ACTIVE_SET_ITERATIONS = 50
MAX_FIXED_POINT_ITERATIONS = 100  # friction-bound fixed point (fallback of the active set)


class ContactSolveError(Diverged):
    """The active-set contact solve did not converge (or its linear system is singular)."""


SEPARATED, STUCK, SLIP_FORWARD, SLIP_BACKWARD = 0, 1, 2, 3  # active-set modes of a node


class ActiveSetSolver:
    """Primal-dual active set for the nodal contact + Coulomb problem on a Schur complement.

    ``S`` is the compliance of the contact unknowns: interleaved (p_0, q_0, p_1, q_1, ...) when
    ``f > 0``, only (p_0, p_1, ...) when ``f == 0``. Each node has a mode (separated, stuck,
    slipping with q = +f p or q = -f p). For given modes the unknowns are p of the contact
    nodes and q of the stuck ones (separated: p = q = 0; slipping: q = +-f p), with the
    equations u_r = d at contact nodes and u_theta = u_theta_n + R Omega dt at stuck nodes:
    a dense system of that (reduced) size, factorised by LU. The modes persist between calls
    (warm start) and the LU of the last system is reused while the modes do not change (the
    first system of a step is usually the last one of the previous step).
    """

    def __init__(self, S: np.ndarray, d: float, f: float,
                 max_iterations: int = MAX_ACTIVE_SET_ITERATIONS) -> None:
        S = 0.5 * (S + S.T)
        self.S, self.d, self.f = S, d, f
        self.friction = f > 0.0
        self.max_iterations = max_iterations
        per = 2 if self.friction else 1
        nc = S.shape[0] // per
        self.nc = nc
        self.ir = np.arange(nc) * per  # radial rows/columns of S
        self.it = self.ir + 1 if self.friction else self.ir  # tangential (friction only)
        s_r = S[:, self.ir]
        if self.friction:
            s_t = S[:, self.it]
            # columns of the unknown p for a stuck / forward-slipping / backward-slipping node,
            # then of the unknown q of a stuck node
            self.columns = np.hstack([s_r, s_r + f * s_t, s_r - f * s_t, s_t])
        else:
            self.columns = s_r
        diag = np.diag(S)
        self.c_n = 1.0 / diag[self.ir]
        self.c_t = 1.0 / diag[self.it]
        self.mode = np.zeros(nc, dtype=np.int8)
        self.p, self.q = np.zeros(nc), np.zeros(nc)
        self.u_r, self.u_t = np.zeros(nc), np.zeros(nc)
        self.r = np.zeros(S.shape[0])
        self.fallbacks = 0  # steps that needed the friction fixed point
        self._cache_key: bytes | None = None
        self._cache_lu = None

    def set_contact(self, contact: np.ndarray) -> None:
        """Warm start: nodes in contact slip forward (the cylinder is faster), others free."""
        self.mode[:] = np.where(contact, SLIP_FORWARD, SEPARATED)

    def _lu(self, mode: np.ndarray, c_idx: np.ndarray, s_idx: np.ndarray, tresca: bool):
        key = mode.tobytes() + (b"T" if tresca else b"C")
        if key != self._cache_key:
            nc = self.nc
            if self.friction:
                if tresca:  # slip forces are known: every contact column is S[:, ir]
                    col_p = c_idx
                else:  # stuck 0, forward slip nc, backward slip 2 nc
                    col_p = c_idx + nc * (mode[c_idx].astype(np.intp) - 1)
                cols = np.concatenate([col_p, 3 * nc + s_idx])
                rows = np.concatenate([self.ir[c_idx], self.it[s_idx]])
            else:
                cols, rows = c_idx, self.ir[c_idx]
            A = self.columns[np.ix_(rows, cols)]
            lu = None
            if A.size:
                lu = scipy.linalg.lu_factor(A, check_finite=False)
                pivots = np.abs(np.diag(lu[0]))
                if not np.all(np.isfinite(pivots)) or pivots.min() <= 1e-13 * pivots.max():
                    raise ContactSolveError(
                        f"implicit contact: the active-set system is singular with {c_idx.size}"
                        f" contact nodes, {s_idx.size} stuck (f = {self.f}: the slip "
                        "linearisation q = +-f p may be singular); reduce time.dt_fraction"
                    )
            self._cache_key, self._cache_lu = key, lu
        return self._cache_lu

    def _iterate(self, w_r, w_t, target_t, bound: np.ndarray | None) -> tuple[int, str]:
        """Active-set iterations for Coulomb (``bound`` None: q = +-f p on slip) or Tresca
        (q = +-bound). Returns (iterations, "" if converged else the reason)."""
        S, ir, it, f, d = self.S, self.ir, self.it, self.f, self.d
        p, q, r, mode = self.p, self.q, self.r, self.mode
        tresca = bound is not None
        seen: set[bytes] = set()
        for iteration in range(1, self.max_iterations + 1):
            c_idx = np.flatnonzero(mode)
            s_idx = np.flatnonzero(mode == STUCK)
            lu = self._lu(mode, c_idx, s_idx, tresca)
            p.fill(0.0)
            q.fill(0.0)
            fwd, bwd = mode == SLIP_FORWARD, mode == SLIP_BACKWARD
            if self.friction and tresca:
                q[fwd], q[bwd] = bound[fwd], -bound[bwd]
            if lu is not None:
                if self.friction:
                    rhs = np.concatenate([d - w_r[c_idx], target_t[s_idx] - w_t[s_idx]])
                    if tresca:
                        sl = np.flatnonzero(fwd | bwd)
                        rows = np.concatenate([ir[c_idx], it[s_idx]])
                        rhs -= S[np.ix_(rows, it[sl])] @ q[sl]
                else:
                    rhs = d - w_r[c_idx]
                x = scipy.linalg.lu_solve(lu, rhs, check_finite=False)
                p[c_idx] = x[:c_idx.size]
                if self.friction:
                    q[s_idx] = x[c_idx.size:]
                    if not tresca:
                        q[fwd], q[bwd] = f * p[fwd], -f * p[bwd]
            r[ir] = p
            if self.friction:
                r[it] = q
            sr = S @ r
            np.add(w_r, sr[ir], out=self.u_r)
            lam_n = p - self.c_n * (self.u_r - d)
            new = (lam_n > 0.0).astype(np.int8)  # SEPARATED 0 or STUCK 1
            if self.friction:
                np.add(w_t, sr[it], out=self.u_t)
                lam_t = q - self.c_t * (self.u_t - target_t)
                cone = bound if tresca else f * lam_n
                slipping = (new == STUCK) & (np.abs(lam_t) > cone)
                new[slipping] = np.where(lam_t[slipping] >= 0.0, SLIP_FORWARD, SLIP_BACKWARD)
            else:
                self.u_t[:] = w_t
                new *= SLIP_FORWARD  # frictionless contact nodes slip
            if np.array_equal(new, mode):
                return iteration, ""
            key = new.tobytes()
            if key in seen:
                return iteration, (f"the active set cycles after {iteration} iterations "
                                   f"({int(np.count_nonzero(new))} contact, "
                                   f"{int(np.sum(new == STUCK))} stuck nodes)")
            seen.add(mode.tobytes())
            mode[:] = new
        return self.max_iterations, f"no convergence in {self.max_iterations} iterations"

    def solve(self, w_r: np.ndarray, w_t: np.ndarray, target_t: np.ndarray) -> int:
        """Contact forces for displacement w + S r; returns the number of iterations.

        ``target_t`` is the stick position u_theta_n + R Omega dt. Results in ``p``, ``q``,
        ``u_r``, ``u_t`` and ``mode``. The semi-smooth Newton on Coulomb's law (slip
        q = +-f p linearised in p) can cycle when the nodes are strongly coupled (large dt,
        large f); then the fallback is a fixed point on the friction bound: Tresca problems
        with bound g = f p from the previous iterate (each a convex problem, solved by the same
        active set) until g = f p. Raises ``ContactSolveError`` if that fails too.
        """
        total, why = self._iterate(w_r, w_t, target_t, None)
        if not why:
            return total
        self.fallbacks += 1
        g = np.zeros(self.nc)
        for _ in range(MAX_FIXED_POINT_ITERATIONS):
            np.multiply(np.maximum(self.p, 0.0), self.f, out=g)
            its, why2 = self._iterate(w_r, w_t, target_t, g.copy())
            total += its
            if why2:
                break
            if np.max(np.abs(self.f * self.p - g)) <= 1e-11 * max(np.max(g), 1e-300):
                return total
        else:
            why2 = f"friction fixed point not converged in {MAX_FIXED_POINT_ITERATIONS} steps"
        raise ContactSolveError(
            f"implicit contact: Coulomb active set failed ({why}) and the friction fixed "
            f"point failed ({why2}); reduce time.dt_fraction"
        )

    def status(self) -> np.ndarray:
        """SEPARATION / STICK / SLIP per node (f = 0: every contact node slips)."""
        return np.minimum(self.mode, SLIP).astype(np.int8)


