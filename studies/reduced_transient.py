"""Reduced transient model: the paper's eq. [2] on a periodic θ grid, integrated with the FE
solver's own explicit Newmark step (``solver.scene_explicit.operator_stepper``) and nodal
contact law (:func:`solver.contact.project_contact`). Pure numpy/scipy (no dolfinx, no PETSc).

Non-dimensional (paper section 2): lengths / R, time Ωt, so the cylinder surface speed is 1.
Unknowns U_j(t), V_j(t) at θ_j = jΔθ, Δθ = 2π/N, stored as one vector u = (U_0..U_{N−1},
V_0..V_{N−1}). Eq. [2]

    Ü − bU'' − DV' + gU = P,     V̈ − aV'' + DU' + hV = Q

is multiplied by the cell length Δθ (the weak form in θ with P1 elements and lumped mass is
identical), giving M ü + K u = r with M = Δθ I, nodal forces r = Δθ (P, Q) and

    K = Δθ [[−b L + g I, −D G], [D G, −a L + h I]],
    L = periodic 2nd-order central second difference, G = periodic central first difference.

G is antisymmetric, so the D blocks make K *symmetric* (−D G and D G = (−D G)^T), not
non-symmetric: the gyroscopic-looking coupling of [2] is a symmetric stiffness coupling.
Its spectrum is known exactly: for the Fourier mode exp(imθ_j), κ = mΔθ, the 2×2 symbol
[[b s₂ + g, −iD s₁], [iD s₁, a s₂ + h]] with s₂ = 4 sin²(κ/2)/Δθ², s₁ = sin κ/Δθ is Hermitian,
and its two eigenvalues over m = 0..N−1 are *all* the eigenvalues ω² of M⁻¹K
(:func:`eigenfrequencies`; the test checks them against scipy's ``eigsh``). ω_max gives
dt_crit = √(2/β₂)/ω_max (:func:`solver.newmark.critical_time_step`).

Contact adapter (:class:`GridContact`, the grid analogue of ``solver.contact.ContactProjection``):
radial displacement = U, tangential = V, mismatch d = δ, cylinder travel per step slide = 1·dt,
nodal mass = Δθ. ``project_contact`` then enforces [2]'s U ≥ δ, P ≥ 0, P(U − δ) = 0 and
Coulomb's law with the stick condition V̇ = 1, exactly as the FE solver does on its inner circle.

Start from a travelling wave ([3], :func:`wave_fields` evaluates a
:class:`semianalytic.waves.TravellingWave` exactly at any φ): U, V from the profile at t = 0 and
U̇ = −cU', V̇ = −cV'. ``SceneExplicit.set_state`` starts its velocity predictor at v₀, which shifts
the first step's velocity by β₂Δt·a₀ (a first-order global error whenever a₀ ≠ 0);
:meth:`ReducedModel.set_state` therefore passes the consistent predictor v₀ − β₂Δt·a₀ with
a₀ = M⁻¹(r₀ − K u₀) and r₀ the wave's reactions.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from stickslip.postprocess.analysis import angular_speed, classify, dominant_mode, mode_coefficients
from stickslip.semianalytic.coefficients import Coefficients
from stickslip.semianalytic.waves import TravellingWave, separation_matrix, slip_matrix
from stickslip.solver.contact import (
    SEPARATION,
    SLIP,
    STICK,
    ContactArrays,
    forward_increment_factor,
    project_contact,
)
from stickslip.solver.ensemble import BatchedProblem
from stickslip.solver.newmark import critical_time_step
from stickslip.solver.scene_explicit import operator_stepper

if TYPE_CHECKING:
    import scipy.sparse as sp

__all__ = [
    "GridContact",
    "ReducedModel",
    "ReducedRecord",
    "eigenfrequencies",
    "junction_phases",
    "observed_order",
    "record_summary",
    "start_from_wave",
    "steady_start",
    "stiffness_matrix",
    "wave_errors",
    "wave_fields",
]

Array = NDArray[np.float64]


# ----------------------------------------------------------------------------- operators
def stiffness_matrix(co: Coefficients, n: int) -> sp.csr_matrix:
    """K = Δθ [[−bL + gI, −DG], [DG, −aL + hI]] of eq. [2] on N periodic nodes (module doc)."""
    import scipy.sparse as sp  # scipy on first use: the CLI starts without it

    if n < 4:
        raise ValueError(f"n={n!r} out of range: need n >= 4 grid nodes")
    h = 2.0 * math.pi / n
    one = np.ones(n)
    # periodic shifts: S+ u_j = u_{j+1}, S- u_j = u_{j-1}
    sp_ = sp.diags([one[:-1], one[:1]], [1, -(n - 1)], shape=(n, n))
    sm_ = sp_.T
    eye = sp.identity(n)
    L = (sp_ + sm_ - 2.0 * eye) / (h * h)
    G = (sp_ - sm_) / (2.0 * h)
    K = sp.bmat(
        [[-co.b * L + co.g * eye, -co.D * G], [co.D * G, -co.a * L + co.h * eye]], format="csr"
    )
    return (h * K).tocsr()


def eigenfrequencies(co: Coefficients, n: int) -> Array:
    """All 2N eigenvalues ω² of M⁻¹K, exactly, from the 2×2 Hermitian Fourier symbol (sorted)."""
    h = 2.0 * math.pi / n
    kap = np.arange(n) * h
    s2 = 4.0 * np.sin(0.5 * kap) ** 2 / (h * h)
    s1 = np.sin(kap) / h
    al, be = co.b * s2 + co.g, co.a * s2 + co.h
    mid, rad = 0.5 * (al + be), np.sqrt(0.25 * (al - be) ** 2 + (co.D * s1) ** 2)
    return np.sort(np.concatenate([mid - rad, mid + rad]))


# ----------------------------------------------------------------------------- contact
class GridContact:
    """Forward-increment contact step of the explicit scheme for the θ grid (radial = U,
    tangential = V).

    Calls the FE solver's nodal law ``project_contact`` with d = δ, slide = 1·dt (cylinder
    surface speed 1 in units of RΩ) and nodal mass Δθ; preallocated, allocation-free.
    """

    def __init__(self, n: int, kappa: float, dt: float, delta: float, f: float) -> None:
        self.n, self.kappa, self.dt, self.delta, self.f = n, kappa, dt, delta, f
        self.slide = 1.0 * dt
        self.mass = np.full(n, 2.0 * math.pi / n)
        self.out = ContactArrays(n)
        self.trial = np.zeros(2 * n)
        self.scratch = np.zeros(2 * n)
        self.inv_mass = 1.0 / self.mass

    def __call__(self, u_now: Array, v_pred: Array, accel: Array) -> None:
        """The explicit contact step (``solver.newmark.ContactStep``): every node is a
        contact node, so the trial position is formed on the whole grid."""
        n, out, trial = self.n, self.out, self.trial
        np.multiply(v_pred, self.dt, out=trial)
        trial += u_now
        np.multiply(accel, self.kappa, out=self.scratch)
        trial += self.scratch
        project_contact(
            trial[:n], trial[n:], u_now[n:], self.mass, self.kappa, self.delta,
            self.slide, self.f, out,
        )
        np.multiply(out.r_r, self.inv_mass, out=self.scratch[:n])
        np.multiply(out.r_t, self.inv_mass, out=self.scratch[n:])
        accel += self.scratch


# ----------------------------------------------------------------------------- model
@dataclass
class ReducedRecord:
    """History of a reduced run (non-dimensional time Ωt).

    ``t``/``U``/``V``/``status`` are snapshots every few steps (``status`` is that of the
    contact force of the step that produced the snapshot, i.e. one dt earlier); ``counts[i]``
    are the numbers of separation/stick/slip nodes of *every* step, so time-averaged zone
    fractions use all steps. ``events`` lists every status change after the first step:
    ``step`` (index n of the force r_n, time n·dt), ``node`` and ``new`` status.
    """

    theta: Array
    t: Array
    U: Array
    V: Array
    status: NDArray[np.int8]
    counts: NDArray[np.int64]
    dt: float
    steps: int
    events: dict[str, NDArray[Any]] = field(default_factory=dict)

    def fractions(self, start: int = 0) -> dict[str, float]:
        """Zone fractions averaged over steps ``start:`` (all nodes, every step)."""
        c = self.counts[start:].sum(axis=0).astype(float)
        tot = max(1.0, c.sum())
        return {"separation": c[SEPARATION] / tot, "stick": c[STICK] / tot, "slip": c[SLIP] / tot}


class ReducedModel:
    """Eq. [2] on N periodic nodes, explicit Newmark (β₁ = 0) at dt = ``cfl`` · dt_crit.

    ``cfl`` is the fraction of the exact stability limit √(2/β₂)/ω_max (``eigenfrequencies``).
    """

    def __init__(
        self,
        co: Coefficients,
        f: float,
        delta: float,
        n: int,
        *,
        beta2: float = 0.5,
        cfl: float = 0.9,
    ) -> None:
        self.co, self.f, self.delta, self.n = co, f, delta, n
        self.dtheta = 2.0 * math.pi / n
        self.theta = np.arange(n) * self.dtheta
        self.K = stiffness_matrix(co, n)
        self.omega_max = float(math.sqrt(eigenfrequencies(co, n)[-1]))
        self.dt_crit = critical_time_step(self.omega_max, 0.0, beta2)
        self.dt = cfl * self.dt_crit
        self.mass = np.full(2 * n, self.dtheta)
        K = self.K

        def mult(u: Array, out: Array) -> None:
            out[:] = K @ u

        kappa = forward_increment_factor(beta2, self.dt)
        self.contact = GridContact(n, kappa, self.dt, delta, f)
        bp = BatchedProblem.without_matrix(self.mass, 1.0 / self.mass, self.dt, beta2)
        self.integ = operator_stepper(bp, mult, self.contact)

    @property
    def steady(self) -> tuple[float, float, float, float]:
        """Steady sliding U_e = δ, V_e = δfg/h, P_e = gδ, Q_e = fP_e (section 3)."""
        co, d, f = self.co, self.delta, self.f
        return d, d * f * co.g / co.h, co.g * d, f * co.g * d

    def set_state(
        self, U: Array, V: Array, Ud: Array, Vd: Array, P: Array | None = None,
        Q: Array | None = None,
    ) -> None:
        """Initial fields; with reactions P, Q the velocity predictor is made consistent
        (v₀ − β₂Δt·a₀, a₀ = M⁻¹(Δθ(P, Q) − K u₀)), see the module docstring."""
        u = np.concatenate([U, V])
        v = np.concatenate([Ud, Vd])
        nm = self.integ
        a0 = None
        if P is not None and Q is not None:
            a0 = np.concatenate([P, Q]) - (self.K @ u) / self.mass
        nm.set_state(u, v, a0)
        nm.time, nm.step_count = 0.0, 0

    def run(self, t_end: float, n_samples: int = 200) -> ReducedRecord:
        """Advance to ``t_end`` (non-dimensional), recording ~``n_samples`` snapshots."""
        nm, n = self.integ, self.n
        steps = max(1, int(math.ceil(t_end / self.dt - 1e-9)))
        every = max(1, steps // n_samples)
        ns = steps // every + 1
        t = np.empty(ns)
        Us, Vs = np.empty((ns, n)), np.empty((ns, n))
        st = np.zeros((ns, n), dtype=np.int8)
        counts = np.empty((steps, 3), dtype=np.int64)
        t[0], Us[0], Vs[0] = nm.time, nm.u[:n], nm.u[n:]
        status = self.contact.out.status
        prev = np.full(n, -1, dtype=np.int8)
        ev_step: list[Array] = []
        ev_node: list[Array] = []
        ev_new: list[Array] = []
        i0 = nm.step_count
        j = 1
        for i in range(steps):
            nm.step()
            counts[i] = np.bincount(status, minlength=3)
            changed = np.flatnonzero(status != prev)
            if i > 0 and changed.size:
                ev_step.append(np.full(changed.size, i0 + i))
                ev_node.append(changed)
                ev_new.append(status[changed].copy())
            prev[:] = status
            if (i + 1) % every == 0:
                t[j], Us[j], Vs[j], st[j] = nm.time, nm.u[:n], nm.u[n:], status
                j += 1
        def cat(a: list[Array], dtype: type) -> NDArray[Any]:
            return np.concatenate(a) if a else np.zeros(0, dtype)

        events = {
            "step": cat(ev_step, np.int64),
            "node": cat(ev_node, np.int64),
            "new": cat(ev_new, np.int8),
        }
        return ReducedRecord(
            self.theta, t[:j], Us[:j], Vs[:j], st[:j], counts, self.dt, steps, events
        )


# ----------------------------------------------------------------------------- waves
def wave_fields(w: TravellingWave, phi: Array) -> dict[str, Array]:
    """Exact U, V, U', V' (φ-derivatives), P, Q, zone of a travelling wave at any φ (eq. [3]).

    Same closed forms as ``semianalytic.waves`` (matrix exponentials per zone) but evaluated
    at arbitrary points, so a grid θ_j − ct needs no interpolation.
    """
    from scipy.linalg import expm  # scipy on first use: the CLI starts without it

    co, f, delta = w.coeffs, w.f, w.delta
    T = w.period
    sig = -1.0 if w.c > 0 else 1.0  # s = σφ (time-ordered coordinate)
    cabs, c2, Ds = abs(w.c), w.c * w.c, sig * co.D
    s = np.mod(sig * np.asarray(phi, dtype=float), T)
    n = s.size
    U, Us, V, Vs = np.full(n, delta), np.zeros(n), np.empty(n), np.empty(n)
    P, Q = np.zeros(n), np.zeros(n)
    zone = np.empty(n, dtype=np.int8)
    s1, s2 = w.psi1 * T, w.psi2 * T
    sep, slp = s < s1, s >= s2
    stk = ~sep & ~slp
    if sep.any():
        E = expm(separation_matrix(co, c2, Ds)[None] * s[sep][:, None, None])
        U[sep], Us[sep], V[sep], Vs[sep] = (E @ w.y0).T
        zone[sep] = SEPARATION
    V[stk] = w.V1 + (s[stk] - s1) / cabs
    Vs[stk] = 1.0 / cabs
    P[stk] = co.g * delta - Ds / cabs
    Q[stk] = co.h * V[stk]
    zone[stk] = STICK
    if slp.any():
        zp = np.array([f * co.g * delta / co.h, 0.0])
        E = expm(slip_matrix(co, c2, Ds, f)[None] * (s[slp] - s2)[:, None, None])
        V[slp], Vs[slp] = (E @ (w.z2 - zp) + zp).T
        P[slp] = co.g * delta - Ds * Vs[slp]
        Q[slp] = f * P[slp]
        zone[slp] = SLIP
    return {"U": U, "V": V, "dU": sig * Us, "dV": sig * Vs, "P": P, "Q": Q, "zone": zone}


def start_from_wave(model: ReducedModel, w: TravellingWave) -> None:
    """Initial state = wave at t = 0 with U̇ = −cU', V̇ = −cV' and its reactions."""
    ev = wave_fields(w, model.theta)
    model.set_state(ev["U"], ev["V"], -w.c * ev["dU"], -w.c * ev["dV"], ev["P"], ev["Q"])


def wave_errors(rec: ReducedRecord, w: TravellingWave) -> dict[str, float]:
    """Errors of a run started on wave ``w`` against the exact travelling wave.

    * ``celerity``: |c_num − c|/|c|, c_num from the phase of mode k (``postprocess.analysis``) of
      V − V_e (U − δ when the wave separates) over the whole record;
    * ``fractions``: max over zones of |time-averaged fraction − exact| (all steps, all nodes);
    * ``profile``: max_j |V_j − V(θ_j − ct)| (and same for U) at the last snapshot, over the
      wave's tangential amplitude (co-moving frame, exact c: includes the phase error);
    * ``shape``: the same after removing the best shift (profile error without the phase).
    """
    co = w.coeffs
    ve = w.delta * w.f * co.g / co.h
    sig_field = rec.U - w.delta if w.psi1 > 0 else rec.V - ve
    c_num = angular_speed(rec.t, sig_field, rec.theta, w.k)
    fr = rec.fractions()
    exact = {"separation": w.psi1, "stick": w.psi2 - w.psi1, "slip": 1.0 - w.psi2}
    t_end = rec.t[-1]
    ev = wave_fields(w, rec.theta - w.c * t_end)
    scale = w.v_amplitude
    prof = max(np.max(np.abs(rec.V[-1] - ev["V"])), np.max(np.abs(rec.U[-1] - ev["U"]))) / scale
    evn = wave_fields(w, rec.theta - c_num * t_end)
    shape = max(np.max(np.abs(rec.V[-1] - evn["V"])), np.max(np.abs(rec.U[-1] - evn["U"])))
    return {
        "c_num": c_num,
        "celerity": abs(c_num - w.c) / abs(w.c),
        "fractions": max(abs(fr[z] - exact[z]) for z in exact),
        "profile": float(prof),
        "shape": float(shape / scale),
        **{f"frac_{z}": fr[z] for z in fr},
    }


def junction_phases(rec: ReducedRecord, w: TravellingWave) -> dict[str, Array]:
    """Wave phase (fraction of the period, time-ordered s/T) at each status change of a run.

    ``onset``: changes to STICK (expected at ψ1: slip → stick, or landing when ψ1 > 0);
    ``release``: STICK → SLIP changes (expected at ψ2). Phases are wrapped to
    [expected − ½, expected + ½) so the differences are signed timing errors in periods.
    """
    ev = rec.events
    T = w.period
    sig = -1.0 if w.c > 0 else 1.0
    t = ev["step"] * rec.dt
    ph = np.mod(sig * (rec.theta[ev["node"]] - w.c * t), T) / T

    def wrap(x: Array, ref: float) -> Array:
        return np.mod(x - ref + 0.5, 1.0) - 0.5 + ref

    onset = wrap(ph[ev["new"] == STICK], w.psi1)
    release = wrap(ph[ev["new"] == SLIP], w.psi2)
    return {"onset": onset, "release": release}


def observed_order(h: Array, err: Array) -> Array:
    """Observed orders log(e_i/e_{i+1})/log(h_i/h_{i+1}) between successive refinements."""
    h, err = np.asarray(h, float), np.asarray(err, float)
    return np.log(err[:-1] / err[1:]) / np.log(h[:-1] / h[1:])


# ----------------------------------------------------------------------------- selection
def steady_start(
    model: ReducedModel, eps: float, *, k: int | None = None, seed: int | None = None
) -> None:
    """Steady sliding (U = δ, V = V_e, P = gδ, Q = fP) plus a tangential perturbation.

    ``k``: V += eps·V_e·cos(kθ); ``seed``: V += eps·V_e·(unit normal noise per node).
    """
    Ue, Ve, Pe, Qe = model.steady
    n = model.n
    V = np.full(n, Ve)
    if k is not None:
        V += eps * Ve * np.cos(k * model.theta)
    if seed is not None:
        V += eps * Ve * np.random.default_rng(seed).standard_normal(n)
    zero = np.zeros(n)
    model.set_state(np.full(n, Ue), V, zero, zero, np.full(n, Pe), np.full(n, Qe))


def record_summary(rec: ReducedRecord, model: ReducedModel, window: float) -> dict[str, Any]:
    """Regime, mode, celerity and zone fractions over the last ``window`` (non-dim time).

    Mode from ``postprocess.analysis.dominant_mode`` of U − δ when separation is present, else of
    V − mean(V); celerity c (units RΩ, > 0 with the rotation) from the phase of that mode.
    """
    sel = rec.t >= rec.t[-1] - window
    start = int(max(0, rec.steps - round(window / rec.dt)))
    fr = rec.fractions(start)
    regime = classify(fr)
    if fr["separation"] > 0.005:
        sig = rec.U[sel] - model.delta
    else:
        sig = rec.V[sel] - rec.V[sel].mean()
    k = dominant_mode(sig, rec.theta)
    c = angular_speed(rec.t[sel], sig, rec.theta, k)
    amp = np.abs(mode_coefficients(sig, rec.theta, k)[:, k])
    return {
        "regime": regime,
        "k": k,
        "c": c,
        "fractions": fr,
        "mode_amplitude": float(amp.mean()),
        "max_U_minus_delta": float(np.max(rec.U[sel]) - model.delta),
        "v_amplitude": float(0.5 * np.mean(np.ptp(rec.V[sel], axis=0))),
    }
