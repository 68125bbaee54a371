"""Semismooth Newton for a travelling wave on the contact circle, interior eliminated.

Setting (derivation in ``studies.travel.frame`` and docs/travelling_waves.md). A wave turning
at angular speed ω is stationary in its own frame: u(x, t) = Q(ωt) w(Q(ωt)ᵀx).
Everything but the contact is linear, so the interior unknowns are eliminated and the problem
lives on the N contact nodes (θ_i = 2πi/N, uniform) with the polar nodal values
W = (W_r, W_θ) and the nodal contact forces λ = (p, q) exerted by the cylinder:

    S(ω) W = λ,                                                     (equilibrium)

S(ω) = Schur complement of the dynamic stiffness K − ω²G at the contact nodes (FE) or the
reduced operator of eq. [2] (reduced model). Both are supplied as a callable returning
(S, dS/dω).

Contact law in the wave frame. The material derivative of a polar component is −ω ∂_φ, so
the slip velocity of the cylinder relative to the tube is s = RΩ + ω ∂_φ W_θ. It is
discretised *upwind in time*: the material point now at node i was at the upstream node
up(i) = i + sign(ω) a time τ_h = Δφ/|ω| earlier (Δφ = 2π/N), so (first order)

    s_i τ_h = RΩ τ_h + W_θ,up(i) − W_θ,i.

This is exactly the transient's nodal law with "time step" τ_h (``solver.contact``: stick =
the node advances RΩ·dt from where it was one step earlier). Two upwind schemes (``RATES``,
``CircleProblem.rate``), each a "previous position" and a "step":

    bdf1:  prev = W_θ,up,                    step = τ_h        (first order),
    bdf2:  prev = (4W_θ,up − W_θ,upup)/3,    step = 2τ_h/3     (second order, the default).

bdf1 is what the transient sees on a rigidly travelling P1 wave: W(φ_i + ω dt) interpolated
between i and up(i) gives (W_i − W_up)/τ_h for any dt < τ_h. ``rate_stencil`` is the one
place that defines (prev, step); the law, the Jacobian, ``material_rate``, the margins and the
zone measure all read it. So the law is applied by the same
function, ``solver.contact.project_contact``, in the Alart–Curnier fixed-point form

    λ = proj(λ − c (W − W_target)),   c > 0 a nodal stiffness,

i.e. the trial position is W − λ/c, the "previous" tangential position is prev and the
cylinder travel is RΩ·step. A root of C(W, ω) = λ − proj(...) satisfies, node by node,
W_r ≥ d, p ≥ 0, p(W_r − d) = 0, |q| ≤ f p, q = f p sign(s) where s ≠ 0 (stick: s = 0).

Unknowns (W, ω), 2N + 1; equations C (2N) and one phase condition
Im(e^{−iα₀} Σ_j W_θ,j e^{−ikθ_j}) = 0 that fixes the wave's position. Steady sliding solves
C = 0 for every ω (and has no k-th Fourier mode), so it is rejected after convergence if the
mode-k amplitude collapsed; a start near a wave stays near it in practice.

The discrete problem is only Z_N symmetric, so the continuous rotation family of the
continuum becomes a family parametrised by the sub-node position of the wave: for a fixed
active set (which nodes separate / stick / slip) C = 0 is linear in W for every ω, so each
active set is admissible on an interval of ω. The phase condition selects one member; ω
varies over the family by an amount that falls with N (measured in docs/travelling_waves.md).

Folding. A wave of wavenumber k repeats every 2π/k. When k divides n the problem is solved on
one wavelength: n/k points, the upstream index taken mod n/k, the step that of the whole
circle (Δφ = 2π/n), and S replaced by its action on k-periodic fields,
S_k[j, l] = Σ_c S[j, l + c n/k]. For the circulant FE operators only the harmonics m ∈ kℤ
enter (``studies.travel.frame``), so folding divides the symbol work by k and the dense
Newton by k³. ``CircleProblem.period`` = k marks a folded problem; ``fold_state`` carries a
start to it, ``unfold`` the wave back. The law, the margins and the zones are node by node, so
they are those of the whole circle.

Generalised Jacobian (rows by the status ``project_contact`` returns):
separation: C = λ; stick: C_n = c(W_r − d), C_t = c(W_θ − W_θ,up − RΩτ_h);
slip: C_n = c(W_r − d), C_t = q − fσ(p − c(W_r − d)), σ = sign of the trial stick force.
(bdf2: W_θ,up + RΩτ_h becomes (4W_θ,up − W_θ,upup)/3 + 2RΩτ_h/3.)
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from stickslip.solver.contact import SEPARATION, SLIP, STICK, ContactArrays, project_contact

__all__ = [
    "CircleProblem", "NotConverged", "RATES", "TravelSolution", "inequality_margins",
    "fold_operator", "fold_state", "material_rate", "nodal_stiffness", "rate_stencil",
    "solve_wave", "unfold", "wave_amplitude", "wave_of_active_set", "zone_lengths",
]

Array = NDArray[np.float64]
StiffnessFn = Callable[..., tuple[Array, Array | None]]

# material-derivative schemes (module doc): weight of W_up, weight of W_upup, step / τ_h
RATES: dict[str, tuple[float, float, float]] = {
    "bdf1": (1.0, 0.0, 1.0),
    "bdf2": (4.0 / 3.0, -1.0 / 3.0, 2.0 / 3.0),
}


def check_rate(rate: str) -> str:
    """``rate`` if it names a scheme of ``RATES``, else a one-line ``ValueError``."""
    if rate not in RATES:
        raise ValueError(f"rate {rate!r}: the material-derivative scheme must be one of "
                         f"{', '.join(RATES)}")
    return rate


class NotConverged(RuntimeError):
    """The Newton iteration failed; ``info`` names the last residual and what was violated."""

    def __init__(self, message: str, info: dict) -> None:
        super().__init__(message)
        self.info = info


@dataclass
class CircleProblem:
    """Travelling-wave problem reduced to N uniform contact nodes (any units, consistent).

    ``stiffness(omega, derivative) -> (S, dS/domega or None)``: 2N × 2N, polar ordering (W_r
    block, W_θ block), nodal forces = S W. ``surface_speed`` = RΩ, ``d`` = mismatch, ``f`` =
    friction.
    """

    n: int
    d: float
    surface_speed: float
    f: float
    stiffness: StiffnessFn
    rate: str = "bdf2"  # material-derivative scheme (``RATES``, module doc)
    period: int = 1  # the n points are one of ``period`` identical copies ("Folding")
    #: interleaved node histories: 1 on a P1 circle; the element degree on a P2 one, whose
    #: vertex and mid-edge nodes carry two histories (``studies.travel.frame``, "Tracks")
    tracks: int = 1

    def __post_init__(self) -> None:
        check_rate(self.rate)
        if not (isinstance(self.period, int) and self.period >= 1):
            raise ValueError(f"period = {self.period!r}: a whole number >= 1 of copies")
        if not (isinstance(self.tracks, int) and self.tracks >= 1) or self.n % self.tracks:
            raise ValueError(f"tracks = {self.tracks!r}: a whole number >= 1 dividing the "
                             f"{self.n} points")

    @property
    def theta(self) -> Array:
        return np.arange(self.n) * self.spacing

    @property
    def spacing(self) -> float:
        """Δφ, the angle between two points: 2π/(n · period)."""
        return 2.0 * math.pi / (self.n * self.period)

    def step(self, omega: float) -> float:
        """The ``step`` of ``rate_stencil`` on this circle (``rate_step`` of its Δφ)."""
        return rate_step(self.n * self.period // self.tracks, omega, self.rate)


@dataclass
class TravelSolution:
    """A converged wave: nodal polar displacements, forces, status and ω (problem units)."""

    omega: float
    W_r: Array
    W_t: Array
    p: Array
    q: Array
    status: NDArray[np.int8]
    iterations: int
    residual: float
    residual_history: list[float] = field(default_factory=list)
    margins: dict[str, float] = field(default_factory=dict)
    violated: str | None = None
    how: str = ""

    @property
    def fractions(self) -> dict[str, float]:
        n = self.status.size
        return {
            "separation": float(np.count_nonzero(self.status == SEPARATION)) / n,
            "stick": float(np.count_nonzero(self.status == STICK)) / n,
            "slip": float(np.count_nonzero(self.status == SLIP)) / n,
        }


def _upstream(n: int, omega: float, tracks: int = 1) -> NDArray[np.intp]:
    """Point the material at point i came from: i + sign(ω) on its own track (material moves
    by −ω in φ; ``tracks`` interleaved histories: the next point of the same track)."""
    return (np.arange(n) + (tracks if omega > 0 else -tracks)) % n


def rate_stencil(W_t: Array, omega: float, rate: str = "bdf2", period: int = 1,
                 tracks: int = 1) -> tuple[Array, float]:
    """(prev, step) of the upwind material derivative (module doc): the "previous position"
    of the material now at each node and the time since, so −ω∂_φW_θ ≈ (W_θ − prev)/step.
    ``period``: W_t is one of that many copies of the circle ("Folding"; upstream mod n).
    ``tracks``: interleaved node histories (``CircleProblem.tracks``): the previous position
    is the same track's, ``tracks`` points upstream, one step = ``tracks`` spacings."""
    a1, a2, _ = RATES[rate]
    n = W_t.size
    up = _upstream(n, omega, tracks)
    prev = a1 * W_t[up] if a2 == 0.0 else a1 * W_t[up] + a2 * W_t[up[up]]
    return prev, rate_step(n * period // tracks, omega, rate)


def rate_step(n: int, omega: float, rate: str = "bdf2") -> float:
    """The ``step`` of ``rate_stencil``: s · Δφ/|ω|, Δφ = 2π/n (n points on the whole
    circle), s from ``RATES``."""
    return RATES[rate][2] * (2.0 * math.pi / n) / abs(omega)


def material_rate(W_t: Array, omega: float, rate: str = "bdf2", period: int = 1,
                  tracks: int = 1) -> Array:
    """Material time derivative −ω ∂_φ W_θ at the nodes, upwind in time (``rate_stencil``)."""
    prev, step = rate_stencil(W_t, omega, rate, period, tracks)
    return (W_t - prev) / step


def fourier_k(values: Array, theta: Array, k: int) -> complex:
    """Σ_j values_j e^{−ikθ_j} (same convention as postprocess.analysis.mode_coefficients)."""
    return complex(np.sum(values * np.exp(-1j * k * theta)))


class _Law:
    """Alart–Curnier residual through ``project_contact`` (preallocated, allocation-light)."""

    def __init__(self, prob: CircleProblem, c: float) -> None:
        n = prob.n
        self.prob, self.c, self.n = prob, c, n
        self.out = ContactArrays(n)
        self.mass = np.full(n, c)  # project_contact's stiff = mass / kappa = c (kappa = 1)

    def __call__(self, W: Array, lam: Array, omega: float) -> tuple[Array, Array]:
        """(C, λ_projected); ``self.out.status`` holds the nodal statuses."""
        n, c, pr = self.n, self.c, self.prob
        prev, step = rate_stencil(W[n:], omega, pr.rate, pr.period, pr.tracks)
        project_contact(
            W[:n] - lam[:n] / c, W[n:] - lam[n:] / c, prev, self.mass, 1.0, pr.d,
            pr.surface_speed * step, pr.f, self.out,
        )
        proj = np.concatenate([self.out.r_r, self.out.r_t])
        return lam - proj, proj


def inequality_margins(prob: CircleProblem, sol: TravelSolution, scale_force: float) -> dict:
    """Margins of every inequality of the nodal law (>= 0 when satisfied), relative.

    gap (separated nodes) / d, p (contact) / force scale, f p − |q| (stick), slip velocity in
    the sense of q (slip) / RΩ.
    """
    st = sol.status
    sep, stick, slip = st == SEPARATION, st == STICK, st == SLIP
    contact = ~sep
    s = prob.surface_speed - material_rate(sol.W_t, sol.omega, prob.rate, prob.period, prob.tracks)
    big = np.inf
    return {
        "gap_separation": float(np.min((sol.W_r[sep] - prob.d) / max(prob.d, 1e-300),
                                       initial=big)),
        "pressure_contact": float(np.min(sol.p[contact] / scale_force, initial=big)),
        "cone_stick": float(np.min((prob.f * sol.p[stick] - np.abs(sol.q[stick])) / scale_force,
                                   initial=big)),
        "slip_direction": float(np.min(np.sign(sol.q[slip]) * s[slip] / prob.surface_speed,
                                       initial=big)),
        "penetration": float(np.min((sol.W_r - prob.d) / max(prob.d, 1e-300))),
    }


INEQUALITY_NAMES = {
    "gap_separation": "[7] U > delta in separation",
    "pressure_contact": "[5]/[6] P >= 0 in contact",
    "cone_stick": "[6] |Q| <= fP in stick",
    "slip_direction": "[5] slip velocity in the sense of Q",
    "penetration": "U >= delta (no penetration)",
}


def nodal_stiffness(prob: CircleProblem) -> float:
    """c, the scale of the nodal law: the mean normal diagonal of the static S(0) (positive
    whatever the wave speed). c·d is the nodal force that pushes a node by the mismatch."""
    S0, _ = prob.stiffness(0.0, False)
    return float(np.mean(np.diag(S0)[: prob.n]))


def solve_wave(
    prob: CircleProblem,
    W0: Array,
    omega0: float,
    k: int,
    *,
    tol: float = 1e-10,
    max_iter: int = 60,
    margin_tol: float = 1e-8,
    min_mode_fraction: float = 1e-3,
    growth: float = 1.0,
    free_omega: bool = True,
    stall: int = 12,
) -> TravelSolution:
    """Semismooth Newton (with backtracking) for (W, ω) from the guess (W0, omega0).

    Stops early (``NotConverged``) when the residual has not fallen by 1 % over ``stall``
    iterations: near a speed where no admissible active set exists the semismooth iteration
    cycles between active sets at a constant residual (measured at N = 132, docs/
    travelling_waves.md), and further iterations only cost factorisations.

    The phase of the k-th Fourier mode of W_θ is held at that of the guess. Converged when
    ‖C‖_∞ ≤ tol · c·d (c·d: the nodal force that pushes a node by the mismatch). Raises
    ``NotConverged`` (last residual, violated inequality) on failure, on a collapse to steady
    sliding, or when a converged wave violates an inequality by more than ``margin_tol``.
    """
    n = prob.n
    if k % prob.period:
        raise ValueError(f"k = {k}: a problem folded to 1/{prob.period} of the circle holds "
                         f"only waves whose k is a multiple of {prob.period}")
    c = nodal_stiffness(prob)
    a0 = fourier_k(W0[n:], prob.theta, k)
    if abs(a0) == 0.0:
        raise NotConverged("the start has no mode-k content in u_theta", {"k": k})
    alpha = np.exp(-1j * (np.angle(a0) + k * prob.theta))  # phase row: Im(alpha · W_θ) = 0
    res = _WaveResidual(prob, _Law(prob, c), alpha.imag / abs(a0), c * max(prob.d, 1e-300),
                        free_omega)
    W, om = np.array(W0, dtype=float), float(omega0)
    hist: list[float] = []
    F, S, proj = res(W, om)
    it = 0
    best = float(F @ F)
    while it < max_iter:
        it += 1
        norm = float(np.max(np.abs(F)))
        hist.append(norm / res.fscale)
        if norm <= tol * res.fscale:
            break
        if stall and it > stall and min(hist[-stall:]) > 0.99 * min(hist[:-stall]):
            break  # stagnation (docstring)
        dx, F = res.newton_direction(W, om, F, S)
        merit = float(F @ F)
        best = min(best, merit) if it > 1 else merit
        W, om, F, S, proj = res.backtrack(W, om, dx, merit, growth * best)
    norm = float(np.max(np.abs(F)))
    sol = TravelSolution(
        omega=om, W_r=W[:n].copy(), W_t=W[n:].copy(), p=proj[:n].copy(), q=proj[n:].copy(),
        status=res.law.out.status.copy(), iterations=it, residual=norm / res.fscale,
        residual_history=hist,
    )
    _check_wave(prob, sol, norm, k, a0, res.fscale, tol, margin_tol, min_mode_fraction)
    return sol


class _WaveResidual:
    """F(W, ω) = (C, phase): the nodal law's Alart–Curnier residual C = λ − proj(λ − cW)
    with λ = S(ω)W, and the phase condition Im(α · W_θ) = 0 (scaled to a force) that fixes
    the wave's position on the circle (0 when ω is held fixed)."""

    def __init__(self, prob: CircleProblem, law: _Law, phase_row: Array, fscale: float,
                 free_omega: bool) -> None:
        self.prob, self.law, self.phase_row = prob, law, phase_row
        self.fscale, self.free_omega = fscale, free_omega

    def __call__(self, W: Array, om: float) -> tuple[Array, Array, Array]:
        """(F, S(ω), λ projected)."""
        n, prob = self.prob.n, self.prob
        S, _ = prob.stiffness(om, False)
        lam = S @ W
        C, proj = self.law(W, lam, om)
        F = np.empty(2 * n + 1)
        F[: 2 * n] = C
        F[2 * n] = (self.fscale * float(self.phase_row @ W[n:]) / max(prob.d, 1e-300)
                    if self.free_omega else 0.0)
        return F, S, proj

    def newton_direction(self, W: Array, om: float, F: Array, S: Array) -> tuple[Array, Array]:
        """(dx, F): the semismooth Newton step J dx = −F at the statuses of the last
        evaluation; with ω fixed, the phase row and the ω column are dropped (dx_ω = 0)."""
        prob = self.prob
        if self.free_omega:
            _, dS = prob.stiffness(om, True)
        else:
            dS = np.zeros_like(S)
        J = _jacobian(prob, self.law, W, om, S, dS, self.phase_row, self.fscale)
        if not self.free_omega:  # ω fixed: drop the phase row and the ω column
            J, F = J[:-1, :-1], F[:-1]
        try:
            dx = np.linalg.solve(J, -F)
        except np.linalg.LinAlgError:
            dx = np.linalg.lstsq(J, -F, rcond=None)[0]
        if not self.free_omega:
            dx, F = np.append(dx, 0.0), np.append(F, 0.0)
        return dx, F

    def backtrack(self, W: Array, om: float, dx: Array, merit: float,
                  accept: float) -> tuple[Array, float, Array, Array, Array]:
        """The point (W, ω, F, S, λ projected) along dx, halving the step up to 12 times.

        Non-monotone: a full step that changes the active set may raise the residual for a
        while (primal-dual active-set behaviour); a step is taken when its merit ‖F‖² falls
        by the Armijo fraction or stays below ``accept`` (``growth`` times the best merit so
        far). A step never crosses ω = 0 (the upwind direction flips); if every halving
        would, the point stays where it is.
        """
        step = 1.0
        trial = None
        for _ in range(12):
            om_t = om + step * dx[-1] if self.free_omega else om
            if om_t * om <= 0:  # never cross ω = 0 (the upwind direction flips)
                step *= 0.5
                continue
            W_t = W + step * dx[:-1]
            trial = (W_t, om_t, *self(W_t, om_t))
            m_t = float(trial[2] @ trial[2])
            if np.isfinite(m_t) and (m_t < (1.0 - 1e-4 * step) * merit or m_t < accept):
                break
            step *= 0.5
        return trial if trial is not None else (W, om, *self(W, om))


def _check_wave(prob: CircleProblem, sol: TravelSolution, norm: float, k: int, a0: complex,
                fscale: float, tol: float, margin_tol: float, min_mode_fraction: float) -> None:
    """Fill ``sol``'s inequality margins and raise ``NotConverged`` unless it is a converged
    (‖F‖_∞ = ``norm`` ≤ tol · c·d), admissible wave of dominant mode k (``solve_wave``)."""
    it, om, hist = sol.iterations, sol.omega, sol.residual_history
    sol.margins = inequality_margins(prob, sol, fscale)
    bad = [key for key, m in sol.margins.items() if m < -margin_tol]
    sol.violated = INEQUALITY_NAMES[bad[0]] if bad else None
    info = {"residual": sol.residual, "iterations": it, "omega": om, "hist": hist,
            "violated": sol.violated, "margins": sol.margins}
    if not norm <= tol * fscale or not np.isfinite(norm):
        raise NotConverged(
            f"no convergence after {it} iterations: last residual {sol.residual:.3e} "
            f"(tol {tol:.1e}); violated inequality: {sol.violated or 'none'}", info)
    amp = abs(fourier_k(sol.W_t, prob.theta, k))
    if amp < min_mode_fraction * abs(a0) or sol.fractions["slip"] == 1.0:
        raise NotConverged(
            "converged to steady sliding (no stick or separation, mode-k amplitude "
            f"{amp / abs(a0):.1e} of the start)", info)
    if sol.violated:
        raise NotConverged(f"converged wave violates {sol.violated}", info)
    sep = np.any(sol.status == SEPARATION)
    signal = (sol.W_r - prob.d) if sep else (sol.W_t - sol.W_t.mean())
    spec = np.abs(np.fft.rfft(signal))
    spec[0] = 0.0
    mode = int(np.argmax(spec)) * prob.period  # a folded circle holds one wavelength per k/period
    if mode != k:
        raise NotConverged(f"converged to a wave whose dominant mode is {mode}, not k = {k} "
                           "(a node-scale pattern, not the requested wave)", info | {"mode": mode})


def wave_of_active_set(prob: CircleProblem, status: NDArray[np.int8], sense: Array,
                       omega: float, *, period: int = 1, S: Array | None = None,
                       c: float | None = None) -> TravelSolution:
    """The wave of a *fixed* active set at speed ω: one linear solve, no Newton.

    With the statuses (``solver.contact`` codes) and the slip senses ``sense`` = sgn q held,
    the nodal law is linear in W ("The discrete waves come in bands",
    docs/travelling_waves.md):

        separated:  λ = S(ω) W = 0            contact:  W_r = d
        stick:      W_θ − prev(W_θ) = RΩ·step    (``rate_stencil``)
        slip:       λ_θ = f sgn λ_r

    The result satisfies the equalities exactly. Whether it is a wave is the sign of
    ``inequality_margins``, which the caller checks. The band of the active set is the ω where
    every margin is >= 0 (benchmarks/travel_active_set.py). The matrix is the W-block of
    the semismooth Newton's generalised Jacobian at these statuses (``_law_rows``).

    ``period`` = k > 1: the statuses and senses repeat every N/k nodes and W is sought with
    the same period (a k-periodic wave): S is folded to one wavelength (its rows there, the
    columns of the k copies of each unknown summed) and the 2N/k equations of that wavelength
    are solved; W and λ are tiled back. ``S`` = S(ω) and
    ``c`` = ``nodal_stiffness(prob)`` may be passed to reuse them across active sets.
    """
    n = prob.n
    if n % period or period < 1:
        raise ValueError(f"period {period}: must divide the {n} contact nodes")
    n0 = n // period
    status = np.asarray(status, dtype=np.int8)
    sgn = np.sign(np.asarray(sense, dtype=float))
    if period > 1 and (np.any(status != np.roll(status, n0)) or np.any(sgn != np.roll(sgn, n0))):
        raise ValueError(f"period {period}: the statuses and slip senses do not repeat every "
                         f"{n0} nodes")
    c = nodal_stiffness(prob) if c is None else c
    if S is None:
        S, _ = prob.stiffness(omega, False)
    if period > 1:  # S on n0-periodic fields, so the law's rows (upstream node taken mod
        # n0) are those of a circle of n0 nodes; the stick step stays that of the N-node mesh
        S = fold_operator(S, period)
        status, sgn = status[:n0], sgn[:n0]
    A = _law_rows(replace(prob, n=n0, period=prob.period * period), status, sgn, c, S, omega)
    b = np.zeros(2 * n0)  # the constant parts of C (Alart-Curnier form, module doc)
    contact = np.flatnonzero(status != SEPARATION)
    stick = np.flatnonzero(status == STICK)
    slip = np.flatnonzero(status == SLIP)
    b[contact] = c * prob.d  # C_r = c (W_r − d)
    b[n0 + stick] = c * prob.surface_speed * prob.step(omega)
    b[n0 + slip] = prob.f * sgn[slip] * c * prob.d  # λ_θ − f sgn (λ_r − c (W_r − d))
    w = np.linalg.solve(A, b)
    lam = S @ w  # one wavelength's forces
    W, lam = (np.tile(x.reshape(2, n0), (1, period)).reshape(-1) for x in (w, lam))
    return TravelSolution(omega=omega, W_r=W[:n], W_t=W[n:], p=lam[:n], q=lam[n:],
                          status=np.tile(status, period), iterations=1,
                          residual=0.0, how="fixed active set")


def fold_operator(S: Array, period: int) -> Array:
    """S on ``period``-periodic polar fields (W_r block, W_θ block): the rows of one copy, the
    columns of the copies of each unknown summed, S_k[j, l] = Σ_c S[j, l + c n/k]
    ("Folding")."""
    n = S.shape[0] // 2
    n0 = n // period
    rows = np.r_[np.arange(n0), n + np.arange(n0)]
    return S[rows].reshape(2 * n0, 2, period, n0).sum(axis=2).reshape(2 * n0, 2 * n0)


def fold_state(W: Array, period: int) -> Array:
    """(W_r, W_θ) on n points carried to one of ``period`` copies (n/period points each): the
    mean of the copies, the L² projection onto ``period``-periodic fields ("Folding")."""
    W = np.asarray(W, dtype=float)
    n = W.size // 2
    if W.size != 2 * n or n % period:
        raise ValueError(f"fold_state: {W.size} values are not 2 × a multiple of {period}")
    return W.reshape(2, period, n // period).mean(axis=1).reshape(-1)


def unfold(sol: TravelSolution, period: int) -> TravelSolution:
    """A folded problem's wave tiled ``period`` times round the whole circle ("Folding")."""
    if period == 1:
        return sol
    return replace(sol, **{name: np.tile(getattr(sol, name), period)
                           for name in ("W_r", "W_t", "p", "q", "status")})


def wave_amplitude(prob: CircleProblem, sol: TravelSolution) -> float:
    """A wave's amplitude as ``postprocess.analysis.analyse`` measures a transient's: the
    peak lift-off max(W_r − d) if any node separates, else half the peak-to-peak W_θ.
    (``driver.member_amplitude``, the band tables' measure, takes the larger of the two.)"""
    if np.any(sol.status == SEPARATION):
        return float(max(0.0, sol.W_r.max() - prob.d))
    return float(0.5 * np.ptp(sol.W_t))


def _law_rows(prob: CircleProblem, status: NDArray[np.int8], sgn: Array, c: float,
              S: Array, om: float) -> Array:
    """∂C/∂W at fixed statuses and slip senses ``sgn`` (2N × 2N; module doc): separated
    nodes C = λ = S W; contact C_r = c (W_r − d); stick C_θ = c (W_θ − prev − RΩ·step);
    slip C_θ = λ_θ − f sgn (λ_r − c (W_r − d)). At a fixed active set C is affine in W
    with this matrix (``wave_of_active_set``)."""
    n, f = prob.n, prob.f
    A = S.copy()  # separation rows (C = λ) by default
    idx = np.arange(n)
    ci = idx[status != SEPARATION]
    A[ci, :] = 0.0
    A[ci, ci] = c
    stick = idx[status == STICK]
    up = _upstream(n, om, prob.tracks)
    a1, a2, _ = RATES[prob.rate]
    A[n + stick, :] = 0.0
    A[n + stick, n + stick] = c
    A[n + stick, n + up[stick]] -= c * a1
    A[n + stick, n + up[up[stick]]] -= c * a2
    slip = idx[status == SLIP]
    A[n + slip] = S[n + slip] - (f * sgn[slip])[:, None] * S[slip]
    A[n + slip, slip] += f * sgn[slip] * c
    return A


def _jacobian(
    prob: CircleProblem, law: _Law, W: Array, om: float, S: Array, dS: Array,
    phase_row: Array, fscale: float,
) -> Array:
    """Generalised Jacobian of (C, phase) w.r.t. (W, ω) at the current statuses (module doc)."""
    n, c, f = prob.n, law.c, prob.f
    st = law.out.status
    sgn = np.sign(law.out.r_t)
    dlam_w = dS @ W
    J = np.zeros((2 * n + 1, 2 * n + 1))
    J[: 2 * n, : 2 * n] = _law_rows(prob, st, sgn, c, S, om)
    J[: 2 * n, 2 * n] = dlam_w  # separation rows: dλ/dω
    idx = np.arange(n)
    J[idx[st != SEPARATION], 2 * n] = 0.0  # C_r = c (W_r − d): no ω
    stick = idx[st == STICK]
    # d/dω of −c RΩ step, step ∝ 1/|ω|
    J[n + stick, 2 * n] = c * prob.surface_speed * prob.step(om) / om
    slip = idx[st == SLIP]
    J[n + slip, 2 * n] = dlam_w[n + slip] - f * sgn[slip] * dlam_w[slip]
    J[2 * n, n: 2 * n] = fscale * phase_row / max(prob.d, 1e-300)
    return J


# ----------------------------------------------------------------------------- zone measure
def zone_lengths(prob: CircleProblem, sol: TravelSolution) -> dict[str, float]:
    """Zone fractions with the boundaries located *between* nodes (ψ to o(Δφ), not Δφ).

    Nodal statuses give ψ only to one node, and near a boundary where an inequality is
    tangent (the slip velocity or the cone margin going to 0) the discrete law may keep a
    node or two on the wrong side with a tiny margin. Each boundary A → B (time order) is put
    where the quantity that must vanish as zone A ends goes to 0, by linear extrapolation
    from the two nodes where it is smallest at the end of the run of A:

    * slip → stick: the slip velocity s; slip → separation, stick → separation: p;
    * stick → slip: the cone margin f p − |q|; separation → contact: the gap W_r − d.

    Returns the fractions of the circle (sum 1) and the sub-node boundary count.
    """
    n = prob.n
    order = np.arange(n) if sol.omega < 0 else np.arange(n)[::-1]  # time order of nodes
    st = sol.status[order]
    if np.all(st == st[0]):
        return {name: float(np.all(st == code)) for code, name in
                enumerate(("separation", "stick", "slip"))} | {"boundaries": 0}
    s = (prob.surface_speed
         - material_rate(sol.W_t, sol.omega, prob.rate, prob.period, prob.tracks))[order]
    p, q, gap = sol.p[order], sol.q[order], (sol.W_r - prob.d)[order]
    cone = prob.f * p - np.abs(q)
    start = int(np.flatnonzero(st != np.roll(st, 1))[0])  # a run boundary
    st, s, p, cone, gap = (np.roll(a, -start) for a in (st, s, p, cone, gap))
    edges = np.flatnonzero(st != np.roll(st, -1))  # last node of each run
    lengths = np.zeros(3)
    bounds = []
    for e in edges:
        a, b = st[e], st[(e + 1) % n]
        if a == SLIP:
            ind = np.abs(s) if b == STICK else p
        elif a == STICK:
            ind = cone if b == SLIP else p
        else:
            ind = gap
        bounds.append(e + _extrapolate_zero(ind, e, n))
    for i in range(1, len(bounds)):  # a one-node run may get crossing estimates: keep order
        bounds[i] = max(bounds[i], bounds[i - 1])
    bounds[-1] = min(bounds[-1], bounds[0] + n)
    for i, e in enumerate(edges):
        lo = bounds[i - 1] - (n if i == 0 else 0)
        lengths[st[e]] += bounds[i] - lo
    frac = lengths / n
    return {"separation": float(frac[0]), "stick": float(frac[1]), "slip": float(frac[2]),
            "boundaries": len(edges)}


def _extrapolate_zero(ind: Array, e: int, n: int) -> float:
    """Offset in [−1, 1] from node e where ``ind`` (≥ 0 on the run ending at e) reaches 0.

    Uses the pair of consecutive nodes among the last three of the run with the smallest
    value (a last node held in the zone with a tiny, non-monotone margin is skipped).
    """
    cand = [e, (e - 1) % n, (e - 2) % n]
    j = min(cand[:2], key=lambda i: ind[i])
    jm = (j - 1) % n
    drop = ind[jm] - ind[j]
    off = (j - e) % n - (n if (j - e) % n > n // 2 else 0)
    if drop <= 0.0:
        return off + 0.5
    return float(np.clip(off + ind[j] / drop, -1.0, 1.0))


# ----------------------------------------------------------------------------- ω-band
def nearest_wave(
    prob: CircleProblem, W0: Array, omega0: float, k: int, *, rel_step: float = 0.01,
    max_steps: int = 20, **kw,
) -> TravelSolution:
    """Fixed-ω solve at ω0, then at ω0(1 ± j·rel_step), j = 1 .. max_steps, alternately:
    the admissible wave of speed nearest to the start (``NotConverged`` if none)."""
    last: NotConverged | None = None
    for j in range(0, max_steps + 1):
        for sgn in ((1.0,) if j == 0 else (-1.0, 1.0)):
            om = omega0 * (1.0 + sgn * j * rel_step)
            try:
                return solve_wave(prob, W0, om, k, free_omega=False, **kw)
            except NotConverged as err:
                last = err
    assert last is not None
    raise NotConverged(f"no admissible mode-{k} wave within ±{100 * max_steps * rel_step:.0f} % "
                       f"of the start speed; last: {last}", last.info)


def wave_band(
    prob: CircleProblem, sol: TravelSolution, k: int, *, rel_step: float = 0.002,
    max_steps: int = 40, bisections: int = 4, edge_reasons: list | None = None, **kw,
) -> tuple[float, float, list[TravelSolution]]:
    """The interval of ω around ``sol.omega`` on which fixed-ω solves (warm started) converge.

    The discrete Coulomb problem has, for each active set, a solution for every ω, admissible
    on an interval: waves come in bands of speed (module doc). Steps of ``rel_step``|ω| each
    way until a solve fails, then ``bisections`` halvings of the last step locate each edge.
    ``edge_reasons`` (a list) receives, for the lower then the upper ω edge, the inequality the
    last failed solve beyond it violated (None: no convergence without a violation, or
    ``max_steps`` reached).
    """
    members = [sol]
    edges = []
    reasons: list = []
    for sgn in (-1.0, 1.0):
        cur = sol
        h = sgn * rel_step * abs(sol.omega)
        steps = 0
        why = None
        while steps < max_steps:
            W = np.concatenate([cur.W_r, cur.W_t])
            try:
                cur = solve_wave(prob, W, cur.omega + h, k, free_omega=False, **kw)
                members.append(cur)
                steps += 1
                continue
            except NotConverged as err:
                why = err.info.get("violated")
                if bisections == 0 or abs(h) < rel_step * abs(sol.omega) / 2**bisections:
                    break
                h *= 0.5
        edges.append(cur.omega)
        reasons.append(why if steps < max_steps else None)
    if edge_reasons is not None:  # edges[0] is the lower ω
        edge_reasons.extend(reasons)
    members.sort(key=lambda s: s.omega)
    return min(edges), max(edges), members
