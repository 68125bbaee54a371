"""The time-T map of the census's explicit scheme, the rotation by s, and the RPO residual.

A **relative periodic orbit** (RPO) is a state x = (u, ṽ) (displacement and velocity
predictor of the explicit β-scheme, ``solver.ensemble.BatchedExplicit``: the only arrays its
next step reads) with a period T and a shift s such that

    G(x, T, s) = R₋ₛ F_T(x) − x = 0,     i.e.  u(θ, t + T) = u(θ − s, t),

where F_T is the scheme's map over the time T and R_s the rotation of a field by s.

**The time-T map.** F_T is p steps of the batched explicit stepper (the census's own kernel:
numba on the CPU, the bits of ``stickslip run``) at the step h = T/p, the number of steps
p = round(T₀/Δt) fixed from the start's period T₀ and the run's step Δt. So T is a smooth
unknown (h, the forward-increment factor κ = (β₂ + ½)h² and the cylinder's travel per step
RΩh follow it) and |h/Δt − 1| ≤ 1/(2p): the orbit is exactly periodic for the scheme at step
h, not at Δt (0.3 % apart at p = 160; the scheme's error is O(Δt²) in the bulk).
B columns advance in lockstep (one kernel call per step): the base map and its perturbed
copies for the Jacobian-vector products (``studies.rpo.newton``).

**The rotation by a continuous s** (``RingRotation``). The structured tube (degree 1) has
the same N angles θ_j = θ₀ + 2πj/N on every ring of nodes, and its stiffness and lumped mass
are invariant under rotation by multiples of Δφ = 2π/N only. On each ring the polar
components (u_r, u_θ)(θ_j), which a rotation leaves unchanged, are shifted by s through
their discrete Fourier series: û_m → û_m e^{−ims} for m = 0 … N/2, the Nyquist term by
cos(Ns/2) (its real-signal interpolant), then turned back to (x, y). For s a multiple of Δφ
this is the exact node permutation (to round-off), the mesh's own symmetry. For other s it
interpolates; it is not a symmetry of the FE system, so a solution is an RPO "up to
the interpolation": a field with wavenumbers |k| ≤ K is shifted exactly, one with content
near the Nyquist k = N/2 loses up to that content (docs/theory/rpo.md measures the
difference between F_T(R_s x) and R_s F_T(x), the commutation defect, on the orbits found).
The alternative (s a multiple of Δφ, T = p h with h free) keeps exactness but needs both
frequencies of the two-wave state locked to the mesh: it exists for the rigid wave (s = Δφ)
and is what ``studies.travel`` solves there (the "central" frame, h = τ/S).

The residual is measured in the **scaled state** ξ = (u/U, ṽ/V)/√(2n) (U, V the start's RMS
displacement and velocity), so ‖ξ‖ ≈ 1 and ‖G‖ is a relative RMS residual.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from stickslip.solver.contact import ContactLaw
from stickslip.solver.contact.law import forward_increment_factor
from stickslip.solver.ensemble import BatchedProblem
from stickslip.solver.ensemble_run import BatchColumns, BatchOptions
from stickslip.solver.run import Profile
from stickslip.solver.scene import require_plane_strain
from stickslip.solver.schemes.select import for_scene
from stickslip.studies.rundir.checkpoint import read_checkpoint
from stickslip.studies.rundir.continuation import plan_continuation

__all__ = ["Start", "RingRotation", "TimeMap", "start_from_run", "start_from_state"]


@dataclass
class Start:
    """A state of the explicit scheme with what its map needs: the scene, the dolfinx
    problem, the batch's shared arrays (``BatchedProblem``), the contact law at the run's
    step ``dt``, Kelvin–Voigt τ, and (u, ṽ) at time ``time``."""

    scene: object
    problem: object
    batched: object
    law: object
    dt: float
    tau: float
    u: np.ndarray
    v: np.ndarray
    time: float = 0.0
    run_dir: Path | None = None


def _build(scene, dt: float | None = None):
    """(TubeProblem, BatchedProblem, ContactLaw, dt) of ``scene`` on one rank; ``dt``: the
    scheme's own step unless given."""
    if for_scene(scene).name != "explicit":
        raise ValueError("rpo: the scene's scheme is implicit (time.beta1 > 0); the RPO "
                         "solver maps the explicit scheme only")
    if scene.mesh.degree != 1 or not scene.mesh.tube:
        raise ValueError("rpo: the rotation by s needs the structured tube of degree 1 "
                         "(mesh.degree = 1, no mesh.file)")
    cols = BatchColumns([scene], Profile(), BatchOptions(build=False, resumed=True))
    step = float(cols.dt) if dt is None else float(dt)
    if dt is not None:
        bp = BatchedProblem.from_problem(cols.problem, step, float(scene.time.beta2))
    else:
        bp = cols.layout.problem
    law = ContactLaw.from_scene(scene, step)
    if law.kernel_bound()[0]:
        raise ValueError("rpo: a regularised friction bound has a state of its own; the "
                         "map here carries (u, v~) only")
    return cols.problem, bp, law, step


def start_from_run(run_dir: str | Path) -> Start:
    """The state where a run's checkpoint stands (a census start, a batch member or a
    one-rank ``stickslip run``), with its scene and step."""
    run_dir = Path(run_dir)
    # the checkpoint's time from its validated reader; the plan then checks every file
    # (summary.json included) against it: a damaged run is one line (ReadError), not a trace
    t_ck = read_checkpoint(run_dir).time
    plan = plan_continuation(run_dir, t_ck + 1.0, 1)
    scene = plan.scene
    require_plane_strain(scene)  # SceneError, one line: the orbit's shift is the circle's
    state = plan.checkpoint.states[0]
    problem, bp, law, dt = _build(scene)
    return Start(scene, problem, bp, law, dt, float(scene.damping.tau),
                 np.array(state["stepper/u"], dtype=float),
                 np.array(state["stepper/v_pred"], dtype=float),
                 float(state["stepper/time"]), run_dir)


def start_from_state(scene, u: np.ndarray, v: np.ndarray, dt: float | None = None) -> Start:
    """A given (u, ṽ) of ``scene`` (tests: a manufactured or a travelling-wave state)."""
    problem, bp, law, step = _build(scene, dt)
    return Start(scene, problem, bp, law, step, float(scene.damping.tau),
                 np.asarray(u, dtype=float).copy(), np.asarray(v, dtype=float).copy())


class RingRotation:
    """R_s on the tube's rings of nodes by a Fourier shift of the polar components (module
    docstring). Fields are (n,) or (n, B) arrays of (x, y) dofs, node p at 2p, 2p + 1."""

    def __init__(self, problem) -> None:
        n = int(problem.n_owned)
        xy = problem.V.tabulate_dof_coordinates()[: n // 2, :2]
        rad = np.hypot(xy[:, 0], xy[:, 1])
        th = np.mod(np.arctan2(xy[:, 1], xy[:, 0]), 2.0 * math.pi)
        keys = np.round(rad / rad.max() * 1e8).astype(np.int64)
        radii = np.unique(keys)
        count = th.size // radii.size
        if count * radii.size != th.size:
            raise ValueError("rpo: the mesh's rings do not all hold the same node count")
        idx = np.empty((radii.size, count), dtype=np.int64)
        for i, key in enumerate(radii):
            nodes = np.flatnonzero(keys == key)
            if nodes.size != count:
                raise ValueError("rpo: the mesh's rings do not all hold the same node count")
            idx[i] = nodes[np.argsort(th[nodes])]
        d_theta = np.diff(th[idx], axis=1)
        if np.ptp(d_theta) > 1e-8 or abs(float(d_theta.mean()) - 2 * math.pi / count) > 1e-8:
            raise ValueError("rpo: the nodes of a ring are not uniform in θ")
        self.idx, self.n, self.count = idx, n, count
        self.cos, self.sin = np.cos(th[idx]), np.sin(th[idx])
        self.m = np.arange(count // 2 + 1)

    def _polar_hat(self, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        ux, uy = w[2 * self.idx], w[2 * self.idx + 1]
        c = self.cos if w.ndim == 1 else self.cos[..., None]
        s = self.sin if w.ndim == 1 else self.sin[..., None]
        return (np.fft.rfft(c * ux + s * uy, axis=1),
                np.fft.rfft(-s * ux + c * uy, axis=1))

    def _from_hat(self, rh: np.ndarray, th: np.ndarray, like: np.ndarray) -> np.ndarray:
        ur = np.fft.irfft(rh, n=self.count, axis=1)
        ut = np.fft.irfft(th, n=self.count, axis=1)
        c = self.cos if like.ndim == 1 else self.cos[..., None]
        s = self.sin if like.ndim == 1 else self.sin[..., None]
        out = np.zeros_like(like)
        out[2 * self.idx] = c * ur - s * ut
        out[2 * self.idx + 1] = s * ur + c * ut
        return out

    def _factor(self, values: np.ndarray, ndim: int) -> np.ndarray:
        return values[None, :] if ndim == 1 else values[None, :, None]

    def rotate(self, w: np.ndarray, s: float) -> np.ndarray:
        """(R_s w)(θ) = Q(s) w(θ − s): polar harmonic m times e^{−ims}."""
        rh, th = self._polar_hat(w)
        f = self._factor(np.exp(-1j * self.m * s), w.ndim)
        return self._from_hat(rh * f, th * f, w)

    def derivative(self, w: np.ndarray) -> np.ndarray:
        """∂_θ w in polar components (spectral): d/ds R₋ₛ w at s = 0; the Nyquist term's
        derivative is 0 (its interpolant cos(Nθ/2) is even about every node)."""
        rh, th = self._polar_hat(w)
        f = self._factor(1j * self.m, w.ndim)
        return self._from_hat(rh * f, th * f, w)


class TimeMap:
    """p steps of the census's batched explicit scheme at step h on B columns (module
    docstring); the steppers are built once per B and reused."""

    #: the mismatch d of a contact-free map (``contact=False``): a cylinder this far inside
    #: the tube never touches it, so the map is the linear tube's (tests: manufactured orbits)
    NO_CONTACT_D = -1.0e3

    def __init__(self, start: Start, contact: bool = True) -> None:
        self.start, self.contact = start, contact
        self.scheme = for_scene(start.scene)
        self.n = int(start.batched.n)
        self._steppers: dict[int, object] = {}
        #: per call of ``advance``: status changes of each column against column 0, summed
        #: over the nodes and steps (the Jacobian-vector products' kinks, ``newton``)
        self.flips = np.zeros(0, dtype=np.int64)

    def stepper(self, columns: int):
        if columns not in self._steppers:
            s = self.start
            st = self.scheme.build_batch(s.batched, [s.law] * columns, "cpu", s.tau)
            st.full_state_at = lambda level: False  # no diagnostics: the state's bits only
            if not self.contact:
                st.d[:] = self.NO_CONTACT_D
            self._steppers[columns] = st
        return self._steppers[columns]

    def advance(self, u: np.ndarray, v: np.ndarray, steps: int, h: float,
                observe=None) -> tuple[np.ndarray, np.ndarray]:
        """(u, ṽ) after ``steps`` steps of h from (u, ṽ), each (n, B); ``observe(k, st)``
        is called after each step k = 1 … steps (samples of one period)."""
        B = u.shape[1]
        st = self.stepper(B)
        st.dt = float(h)
        st.kappa = forward_increment_factor(st.beta2, h)
        st.slide[:] = self.start.law.surface_speed * h
        st.time, st.step_count = 0.0, 0
        st.set_state(u, v)
        flips = np.zeros(B, dtype=np.int64)
        for k in range(steps):
            st.step(observe is not None)
            if B > 1:
                flips += np.count_nonzero(st.status != st.status[:, :1], axis=0)
            if observe is not None:
                observe(k + 1, st)
        self.flips = flips
        return np.array(st.u), np.array(st.v_pred)


@dataclass
class Guess:
    """A point of the RPO problem: the scaled state ξ, the period T (s), the shift s (rad)."""

    xi: np.ndarray
    period: float
    shift: float


class OrbitProblem:
    """G(ξ, T, s) = R₋ₛ F_T(x) − ξ in the scaled state (module docstring) and its
    linearisation for the Newton–Krylov solver, with the two phase conditions.

    ``hold_shift``: s stays at its guess, a whole number of node passages for a rigid wave
    (R_s is then the node permutation), and X = (ξ, T/T₀) with the time condition alone.

    Unknowns X = (ξ, T/T₀, s) (2n + 2); equations: G (2n) and the phase conditions on the
    update, ⟨e_t, δξ⟩ = 0 and ⟨e_θ, δξ⟩ = 0, with e_t the direction of time (one step of the
    map from ξ) and e_θ = ∂_θ ξ (the rotation), each normalised: the update moves neither
    along the orbit nor along its rotation, the two directions in which a solution is not
    isolated (Viswanath 2007, channelflow's ``findorbit``).

    Jacobian-vector products: J δX = R₋ₛ DF_T δx + R₋ₛ ∂_T F_T δT + ∂_θ(R₋ₛ F_T) δs − δξ.
    DF_T δx by a central difference in lockstep: columns x ± ε δx of one batch (ε = ``eps``
    relative to ‖ξ‖ = 1). The map is continuous and piecewise linear in x (the contact
    projection is max(·, 0) and a clip to the Coulomb cone, the rest linear), so where
    neither column changes a node's status the difference is the exact derivative of the
    piece the base trajectory lies on; where one does (a node within ε of a switch), it is
    the mean of the two one-sided derivatives. ``TimeMap.flips`` counts those status
    changes per product (``jvp_flips``). ∂_T F_T: a central difference in h (two runs of
    one column) once per linearisation."""

    def __init__(self, start: Start, guess_period: float, guess_shift: float,
                 steps: int | None = None, eps: float = 1e-7, contact: bool = True,
                 hold_shift: bool = False) -> None:
        self.start, self.map = start, TimeMap(start, contact)
        #: the shift held at its guess, T alone free with the time phase condition: with a
        #: whole number of node passages R_s is the node permutation, an exact symmetry of
        #: the mesh, so the orbit and its multipliers are the scheme's own (a rigid wave)
        self.hold_shift = hold_shift
        self.rotation = RingRotation(start.problem)
        self.steps = steps or max(1, int(round(guess_period / start.dt)))
        self.period0 = float(guess_period)
        self.eps = eps
        n = self.map.n
        U = float(np.sqrt(np.mean(start.u**2)))
        V = float(np.sqrt(np.mean(start.v**2)))
        self.scale = np.r_[np.full(n, U), np.full(n, V)] * math.sqrt(2 * n)
        self.n = n
        self.jvp_flips: list[int] = []
        self.guess = Guess(self.scaled(start.u, start.v), float(guess_period),
                           float(guess_shift))

    # ------------------------------------------------------------------ state and maps
    def scaled(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        return np.r_[u, v] / self.scale

    def physical(self, xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(u, ṽ), each (n,) or (n, B), of the scaled ξ ((2n,) or (2n, B))."""
        x = xi * (self.scale if xi.ndim == 1 else self.scale[:, None])
        return x[: self.n], x[self.n:]

    def rotate(self, xi: np.ndarray, s: float) -> np.ndarray:
        """R_s on both halves (u and ṽ are fields; the scaling is per half, so it commutes)."""
        return np.concatenate([self.rotation.rotate(xi[: self.n], s),
                               self.rotation.rotate(xi[self.n:], s)])

    def d_theta(self, xi: np.ndarray) -> np.ndarray:
        return np.concatenate([self.rotation.derivative(xi[: self.n]),
                               self.rotation.derivative(xi[self.n:])])

    @property
    def free(self) -> np.ndarray:
        """Which entries of ξ are free (not clamped): the clamped dofs carry no mass, so the
        scheme keeps their u and ṽ (``floquet``)."""
        free = np.asarray(self.start.batched.inv_mass) > 0.0
        return np.r_[free, free]

    def step_of(self, period: float) -> float:
        return period / self.steps

    def flow(self, xi: np.ndarray, period: float, steps: int | None = None) -> np.ndarray:
        """F_T of the columns of ξ ((2n,) or (2n, B)), p steps of h = T/p (or ``steps``
        steps of that h)."""
        cols = xi if xi.ndim == 2 else xi[:, None]
        u, v = self.physical(cols)
        u, v = self.map.advance(u, v, self.steps if steps is None else steps,
                                self.step_of(period))
        out = np.r_[u, v] / self.scale[:, None]
        return out if xi.ndim == 2 else out[:, 0]

    def residual(self, g: Guess) -> np.ndarray:
        """G = R₋ₛ F_T(ξ) − ξ."""
        return self.rotate(self.flow(g.xi, g.period), -g.shift) - g.xi

    # ------------------------------------------------------------------ the Newton system
    def pack(self, g: Guess) -> np.ndarray:
        if self.hold_shift:
            return np.r_[g.xi, g.period / self.period0]
        return np.r_[g.xi, g.period / self.period0, g.shift]

    def unpack(self, X: np.ndarray) -> Guess:
        if self.hold_shift:
            return Guess(X[:-1].copy(), float(X[-1]) * self.period0, self.guess.shift)
        return Guess(X[:-2].copy(), float(X[-2]) * self.period0, float(X[-1]))

    def extended_residual(self, X: np.ndarray) -> np.ndarray:
        conditions = 1 if self.hold_shift else 2
        return np.r_[self.residual(self.unpack(X)), np.zeros(conditions)]

    def linearise(self, X: np.ndarray):
        """J(X) as a function δX ↦ J δX (class docstring)."""
        g = self.unpack(X)
        h = self.step_of(g.period)
        dh = 1e-7 * h
        plus = self.flow(g.xi, g.period + self.steps * dh)
        minus = self.flow(g.xi, g.period - self.steps * dh)
        d_period = self.rotate(plus - minus, -g.shift) / (2.0 * dh * self.steps) * self.period0
        e_t = self.flow(g.xi, g.period, steps=1) - g.xi
        e_t /= np.linalg.norm(e_t)
        held = self.hold_shift
        extra = 1 if held else 2  # (T, s) or T alone
        if not held:  # s free: its column (a map of the base) and its phase condition
            d_shift = self.d_theta(self.rotate(self.flow(g.xi, g.period), -g.shift))
            e_th = self.d_theta(g.xi)
            e_th /= np.linalg.norm(e_th)

        def jvp(dX: np.ndarray) -> np.ndarray:
            dxi = dX[:-extra]
            size = float(np.linalg.norm(dxi))
            out = -dxi.copy()
            if size > 0.0:
                eps = self.eps / size
                cols = self.flow(np.c_[g.xi + eps * dxi, g.xi - eps * dxi], g.period)
                self.jvp_flips.append(int(self.map.flips[1]))
                out += self.rotate((cols[:, 0] - cols[:, 1]) / (2.0 * eps), -g.shift)
            out += d_period * dX[-extra]
            if held:
                return np.r_[out, e_t @ dxi]
            out += d_shift * dX[-1]
            return np.r_[out, e_t @ dxi, e_th @ dxi]

        return jvp

    def monodromy(self, g: Guess):
        """δξ ↦ R₋ₛ DF_T δξ (the linearised map rotated back, ``floquet``), by a forward
        difference from the base map F_T(ξ), computed once: one column a product. The map
        is piecewise linear (class docstring), so on the base trajectory's piece the
        difference is its exact derivative; across a status change it is the derivative of
        the piece on the side of δξ."""
        base = self.flow(g.xi, g.period)

        def apply(dxi: np.ndarray) -> np.ndarray:
            size = float(np.linalg.norm(dxi))
            if size == 0.0:
                return np.zeros_like(dxi)
            eps = self.eps / size
            ahead = self.flow(g.xi + eps * dxi, g.period)
            return self.rotate((ahead - base) / eps, -g.shift)

        return apply
