"""The FE tube in the wave's frame: K − ω²G condensed on the contact nodes.

``forms.travelling`` gives the wave-frame operator A(ω) = K − ω²G (K: the transient's
stiffness, ``solver.problem.build_problem``; G: travelling inertia). The outer circle is
clamped (its dofs removed). Everything but the contact is linear, so with c = contact dofs
and i = the other free dofs,

    S(ω) = A_cc − A_ci A_ii⁻¹ A_ic          (the FE dynamic stiffness at the contact nodes),
    dS/dω = −2ω (G_cc − G_ci X − Xᵀ G_ic + Xᵀ G_ii X),   X = A_ii⁻¹ A_ic,

(differentiate A_ii⁻¹: d(A⁻¹) = −A⁻¹ dA A⁻¹; A, G symmetric). With Kelvin–Voigt damping,
A = K − ω²G − ωC is not symmetric, and with A' = dA/dω = −2ωG − C and Y = A_ci A_ii⁻¹,

    dS/dω = A'_cc − A'_ci X − Y A'_ic + Y A'_ii X = A'_cc − A'_ci X + A_ci Z,
    Z = A_ii⁻¹ (A'_ii X − A'_ic)              (one LU of A_ii, two solves, A_ci kept sparse).

The interior is recovered as
w_i = −X w_c. S is rotated node by node to polar components (W_r block, W_θ block, nodes in
θ order): x = cosθ W_r − sinθ W_θ, y = sinθ W_r + cosθ W_θ, S_polar = Tᵀ S T, so that
S_polar W = (p, q), the nodal forces [N/m] the cylinder exerts (as in ``solver.contact``).

Serial (one process): the condensed problem is dense and small (2N × 2N).

**The transient's own travelling operator** (``inertia="shift"``). G is the Galerkin form of
the *continuous* rotation on the P1 space. The transient (lumped mass M, Kelvin–Voigt
σ = C:(ε + τε̇), ``solver.newmark``) can only carry waves invariant under the mesh's discrete
shift (θ → θ + Δφ, t → t + Δφ/|ω|). For such a wave W(θ − ωt) each discrete harmonic m of the
contact values (e_m = e^{imθ_j}, |m| ≤ N/2) has the frequency −mω, so its semi-discrete
(continuous in time) equations are A_m w = r with

    A_m(ω) = (1 − imωτ) K − (mω)² M,

and the mesh is Z_N symmetric, so the contact Schur complement of A_m maps the polar harmonic
m onto itself through a 2 × 2 symbol t_m(ω). The operator is block circulant in polar
components: S_ab[j, l] = (1/N) Σ_m t_m,ab e^{im(θ_j − θ_l)}, t_−m = conj(t_m) (K, M real), the
Nyquist term real. It costs one sparse complex LU of A_m,ii (two right-hand sides) per
harmonic m = 0 … N/2 and ω; dS/dω by a central difference. The two operators agree as the
harmonics are resolved (``benchmarks/travel_symbol.py``; measured with the former, P1-
inconsistent damping form: at N = 132, ω = −2497 rad/s they differed by 15 % at m = 4 and by
O(1) at m = 12, 16; not re-measured with D = τK M⁻¹B).

**Samples: the node's history between node passages** (``samples`` = s > 1, "shift" only).
A wave of the semi-discrete transient is u_j(t) = R^j u_0(t − jτ), τ = Δφ/|ω|: every contact
node runs through the same history, one node passage later than its upstream neighbour. With
one point per node (s = 1) the frame holds that history only at the node passages, so a node
changes status (stick, slip, separation) only there. With s points per node the contact
circle carries the profile at θ_j = jΔφ/s, i.e. node 0's history at the times jτ/s. A profile
harmonic e^{imθ} is seen by the mesh nodes as the discrete harmonic m mod N at the frequency
−mω, so its symbol is the Schur complement of the same A_m = (1 − imωτ_KV)K − (mω)²M for
|m| ≤ Ns/2: ``_sector_operator`` already carries the Bloch phase e^{imα} (α a multiple of Δφ,
hence m mod N) and the frequency mω. The contact law is applied at every point with the
material rate over τ/s (``newton.rate_stencil``). As s → ∞ this is the transient's own
travelling wave at N, continuous in time (the transient's limit as Δt → 0); s is the time
resolution, N the space resolution (archive/travel/travelling_waves_history.md 2e).

**Central scheme** (``time_scheme="central"``): the transient's own time discretisation with
step h = τ/s, the explicit β-method of ``solver.newmark`` at the scene's β₂:
u_{n+1} = u_n + h v_n + h²a_n/2, v_n = ṽ_n + β₂h a_n, ṽ_{n+1} = v_n + (1 − β₂)h a_n and
M a_n + τ_KV K ṽ_n + K u_n = r_n (Kelvin–Voigt on the predictor ṽ), where r_n is the force
that puts the node where the contact law wants it at step n + 1 (the forward increment).
Per harmonic (e^{−iνt}, ν = mω, z = e^{−iνh} one step) these give ṽ = (z − 1)u/(hD),
a = (z − 1)²u/(h²D) with D = 1 + (β₂ + 1/2)(z − 1), so the interior operator is

    A_m = (1 + τ_KV(z − 1)/(hD)) K + ((z − 1)²/(h²D)) M,

at β₂ = 1/2 (D = z) the central difference (1 + τ_KV(1 − e^{iνh})/h) K − (2/h)² sin²(νh/2) M;
pairing the force with the position one step later multiplies the contact symbol by
e^{iνh} (νh = ±2πm/(Ns): the shift by one point). A wave of this problem is a periodic orbit
of the transient's discrete equations at dt = h: a run started on it (``shift_state``) stays
on it to round-off (``tests/test_travel_fe.py``). The "exact" scheme differs at the landing:
the node's velocity jumps there, and the exact-in-time inertia of the sampled history rings
(the force at the points before the landing changes sign), so its fixed-status problem
found no admissible wave at s = 4 (N = 132, the speeds and active sets scanned) where the
central one has one, isolated to 0.05 m/s at s = 6 (docs 2e).

**Tracks: P2 circles** (``tracks`` = the element degree, "shift" only). A P2 contact circle
of N nodes has E = N/2 edges, each with a vertex and a mid-edge node of different lumped
(HRZ) masses, so the mesh turns onto itself by one edge, Δφ_e = 2π/E, not by one node. A
wave of its transient is two node histories, the vertex's W_0 and the mid-edge node's W_1,
each repeating one edge passage τ_e = Δφ_e/|ω| later on the next edge. The frame holds both:
point 2i + a is track a's i-th, the node of type a at g_a + iΔφ_e/S (g_a = o_a mod Δφ_e/S,
o_a the node's angle in its sector: where such nodes stand at the steps t = jh, h = τ_e/S),
and the material rate links a point to the same track's point one step upstream
(``newton.rate_stencil``). The Bloch reduction (``_bloch``) runs over Z_E with both contact
nodes of the sector; a track's DFT coefficient b̂_m is the sector node's value times
e^{−im(o_a − g_a)} (``track_phases``), so the symbol t_m is 4 × 4 (track, r/θ) and S is
the 2 × 2 block circulant of the tracks, interleaved. The sector phase e^{imα} (α = jΔφ_e)
holds harmonic m mod E. ``frame.theta`` labels the points uniformly (pΔφ_e/(2S)), which is
the exact angle where S is odd and half a point off for the mid-edge track where S is even;
the operator and ``shift_state`` use the exact g_a (``tests/test_p2_rungs.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import partial

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.sparse.linalg import splu

from stickslip.forms.travelling import travelling_inertia, travelling_transport
from stickslip.solver.problem import TubeProblem
from stickslip.solver.scene import Scene
from stickslip.studies.travel.newton import CircleProblem, fold_operator

__all__ = ["INERTIAS", "TIME_SCHEMES", "FrameOperators", "frame_operators", "circle_problem"]

Array = NDArray[np.float64]
MODAL_MAX = 6000  # interiors up to this size may use the modal form of the Schur complement
MODAL_AFTER = 40  # ... once this many ω have been evaluated (a one-off dense eigenproblem
# of the interior costs ~25 sparse-LU condensations at N = 132, so few-ω solves skip it)


def _csr(mat) -> sp.csr_matrix:
    indptr, indices, data = mat.getValuesCSR()
    return sp.csr_matrix((data, indices, indptr), shape=mat.getSize())


#: wave-frame operators (module doc): the continuous rotation, or the transient's shift
INERTIAS = ("rotation", "shift")
#: time discretisation of the shift operator (module doc): exact in time, or the transient's
#: explicit central-difference step h = Δφ/(samples·|ω|)
TIME_SCHEMES = ("exact", "central")

@dataclass
class FrameOperators:
    """K and G restricted to the free dofs, split into contact (c) and interior (i) parts."""

    problem: TubeProblem
    K: sp.csr_matrix
    G: sp.csr_matrix
    contact: NDArray[np.intp]  # dof indices, x block then y block, nodes in θ order
    interior: NDArray[np.intp]
    theta: Array
    ds_weight: Array  # ∫φ_i ds per contact node (nodal force / ds = pressure)
    T: Array  # polar -> (x, y) at the contact dofs
    C: sp.csr_matrix | None = None  # Kelvin–Voigt wave-frame damping (None: undamped)
    inertia: str = "rotation"  # "rotation": K − ω²G − ωC; "shift": the transient's (module doc)
    tau: float = 0.0  # Kelvin–Voigt retardation time (s), for "shift"
    samples: int = 1  # contact points per mesh node ("shift" only; module doc, "Samples")
    time_scheme: str = "exact"  # "exact" in time, or "central": the transient's step h = τ/s
    beta2: float = 0.5  # the explicit scheme's β₂ ("central" only; the scene's time.beta2)
    tracks: int = 1  # contact nodes per contact edge: the element degree (module doc, "Tracks")
    _cache: tuple | None = None  # ((ω, period), (S, dS, X)): the last evaluation
    _static: dict = field(default_factory=dict)  # period -> S(0): every solve's nodal scale
    _blocks: dict | None = None
    _evaluations: int = 0

    @property
    def n(self) -> int:
        """Points on the contact circle: N mesh nodes × ``samples``."""
        return self.theta.size

    @property
    def mesh_n(self) -> int:
        """N, the contact nodes of the mesh (its Z_N symmetry)."""
        return self.theta.size // self.samples

    def _split(self) -> dict:
        """Blocks of K and G (once); the modal form once it pays (``factor``)."""
        if self._blocks is None:
            c, i = self.contact, self.interior
            b = {}
            mats = [("K", self.K), ("G", self.G)] + ([("C", self.C)] if self.C is not None
                                                     else [])
            for name, M in mats:
                Mi = M[i]
                b[name + "ii"] = Mi[:, i].tocsc()
                b[name + "ic"] = Mi[:, c].toarray()
                b[name + "ci"] = M[c][:, i].tocsr()  # sparse: the contact nodes' neighbours
                b[name + "cc"] = M[c][:, c].toarray()
            self._blocks = b
        b = self._blocks
        self._evaluations += 1
        if ("mu" not in b and self.C is None and self.interior.size <= MODAL_MAX
                and self._evaluations > MODAL_AFTER):
            # G_ii Φ = K_ii Φ diag(μ), ΦᵀK_iiΦ = I  =>  A_ii⁻¹ = Φ diag(1/(1 − ω²μ)) Φᵀ
            from scipy.linalg import eigh

            mu, phi = eigh(b["Gii"].toarray(), b["Kii"].toarray())
            b["mu"], b["phi"] = mu, phi
            b["B0"], b["B1"] = phi.T @ b["Kic"], phi.T @ b["Gic"]
        return b

    def factor(self, omega: float, derivative: bool = True, period: int = 1
               ) -> tuple[Array, Array | None, Array | None]:
        """(S_polar, dS_polar/dω or None, X) at ω (module doc); the last result is cached.
        ``period`` > 1: S and dS/dω on ``period``-periodic fields (``newton``, "Folding"),
        from the harmonics m ∈ period·ℤ only for the shift operator; X is then None.

        After ``MODAL_AFTER`` evaluations, small interiors switch to the modal form (one dense
        generalised eigenproblem):
        with B = Φᵀ A_ic = B0 − ω²B1 and D = diag(1/(1 − ω²μ)), S = A_cc − BᵀDB and
        w_i = −ΦDB w_c, so each ω costs dense products only. Before that, and for large
        interiors, A_ii is factored (sparse LU) at each ω.
        """
        if self.n % (period * self.tracks):
            raise ValueError(f"period {period}: must divide the {self.n // self.tracks} "
                             "contact points of each track")
        key = (omega, period)
        if self._cache is not None and self._cache[0] == key and (
                self._cache[1][1] is not None or not derivative):
            return self._cache[1]
        if omega == 0.0 and not derivative and period in self._static:
            return self._static[period]
        if self.inertia == "shift":
            S = self._schur_shift(omega, period)
            dS = None
            if derivative:
                h = 1e-6 * abs(omega)
                dS = (self._schur_shift(omega + h, period)
                      - self._schur_shift(omega - h, period)) / (2.0 * h)
            out = (S, dS, None)
        else:
            out = self._factor_frame(omega, derivative)
            if period > 1:
                out = (fold_operator(out[0], period),
                       None if out[1] is None else fold_operator(out[1], period),
                       None)
        self._cache = (key, out)
        if omega == 0.0:  # the nodal-stiffness scale, read by every solve
            self._static[period] = (out[0], None, out[2])
        return out

    def _factor_frame(self, omega: float, derivative: bool
                      ) -> tuple[Array, Array | None, Array | None]:
        """``factor`` of the continuous-rotation operator K − ω²G − ωC (whole circle)."""
        b = self._split()
        w2 = omega * omega
        Acc = b["Kcc"] - w2 * b["Gcc"]
        T = self.T
        dS = None
        if "mu" in b:
            den = 1.0 - w2 * b["mu"]
            B = b["B0"] - w2 * b["B1"]
            DB = B / den[:, None]
            S = Acc - B.T @ DB
            if derivative:
                # d(BᵀDB)/dω = 2 dBᵀ D B + Bᵀ dD B (D diagonal)
                dB = -2.0 * omega * b["B1"]
                dD = (2.0 * omega * b["mu"] / den**2)[:, None]
                M = dB.T @ DB
                dS = -2.0 * omega * b["Gcc"] - M - M.T - B.T @ (dD * B)
            X = None  # w_i = −Φ D B w_c, formed only for the output field
        elif self.C is None:
            Aic = b["Kic"] - w2 * b["Gic"]
            X = splu((b["Kii"] - w2 * b["Gii"]).tocsc()).solve(Aic)
            S = Acc - Aic.T @ X
            if derivative:
                GX = b["Gic"].T @ X
                dS = -2.0 * omega * (b["Gcc"] - GX - GX.T + X.T @ (b["Gii"] @ X))
        else:  # damped: A = K − ω²G − ωC is not symmetric (module doc)
            S, dS = self._schur_damped(omega, derivative)
            X = None
        return T.T @ S @ T, None if dS is None else T.T @ dS @ T, X

    def _schur_damped(self, omega: float, derivative: bool) -> tuple[Array, Array | None]:
        """S(ω) and dS/dω of the damped A = K − ω²G − ωC with one LU of A_ii (module doc)."""
        b = self._split()
        w2 = omega * omega

        def blk(key: str):
            return b["K" + key] - w2 * b["G" + key] - omega * b["C" + key]

        def dblk(key: str):  # A' = dA/dω = −2ωG − C
            return -2.0 * omega * b["G" + key] - b["C" + key]

        lu = splu((b["Kii"] - w2 * b["Gii"] - omega * b["Cii"]).tocsc())
        X = lu.solve(blk("ic"))
        # A_ci couples the contact dofs to their neighbours only: keep it sparse (the dense
        # product costs 27 s per ω at N = 528, the sparse one < 0.1 s)
        Aci = blk("ci")
        S = blk("cc") - Aci @ X
        if not derivative:
            return S, None
        Z = lu.solve(dblk("ii") @ X - dblk("ic"))
        return S, dblk("cc") - dblk("ci") @ X + Aci @ Z

    def _bloch(self) -> dict:
        """Node orbits under the mesh's rotation group Z_E (E = N/``tracks`` contact edges,
        Δφ_e = 2π/E, once): each free node p is the image of a representative q (same r,
        θ_q ∈ [0, Δφ_e)) turned by α_p = θ_p − θ_q. R maps the representatives' polar dofs
        (2 per node) to every free node's (x, y) dofs: R[(x, y)_p, (r, θ)_q] = rotation by
        θ_p. A harmonic-m field is diag(e^{imα}) R c. The contact representatives are the
        ``tracks`` nodes of one edge (P1: its vertex; P2: its vertex and mid-edge node), at
        the angles ``offsets`` in the sector. Serial (dof 2p, 2p + 1 = x, y of node p)."""
        if self._blocks is not None and "bloch" in self._blocks:
            return self._blocks["bloch"]
        n = self.mesh_n // self.tracks
        dphi = 2.0 * math.pi / n
        xy = self.problem.V.tabulate_dof_coordinates()[: self.problem.n_owned // 2, :2]
        rad = np.hypot(xy[:, 0], xy[:, 1])
        th = np.mod(np.arctan2(xy[:, 1], xy[:, 0]), 2.0 * math.pi)
        sector = np.floor(th / dphi + 1e-9)  # a node on a sector's edge belongs to it
        frac = np.maximum(th - sector * dphi, 0.0)
        sector = np.mod(sector, n)
        free_nodes = np.setdiff1d(np.arange(rad.size), np.asarray(self.problem.clamped) // 2)
        keys = np.round(np.c_[rad[free_nodes] / rad.max(), frac[free_nodes] / dphi] * 1e6)
        _, rep = np.unique(keys, axis=0, return_inverse=True)
        rep = rep.reshape(-1)
        n_rep = int(rep.max()) + 1
        tp = th[free_nodes]
        alpha = sector[free_nodes] * dphi  # sector angle jΔφ_e of each free node
        cs, sn = np.cos(tp), np.sin(tp)
        rows = np.r_[2 * free_nodes, 2 * free_nodes, 2 * free_nodes + 1, 2 * free_nodes + 1]
        cols = np.r_[2 * rep, 2 * rep + 1, 2 * rep, 2 * rep + 1]
        vals = np.r_[cs, -sn, sn, cs]
        R = sp.csr_matrix((vals, (rows, cols)), shape=(self.problem.n_owned, 2 * n_rep))
        ph_dof = np.zeros(self.problem.n_owned)
        ph_dof[2 * free_nodes], ph_dof[2 * free_nodes + 1] = alpha, alpha
        on_circle = np.flatnonzero((np.abs(rad[free_nodes] - rad.min()) < 1e-9 * rad.max())
                                   & (sector[free_nodes] == 0))
        on_circle = on_circle[np.argsort(frac[free_nodes][on_circle])]
        if on_circle.size != self.tracks or len(free_nodes) != n * n_rep:
            raise ValueError(f"the mesh is not Z_{n} symmetric with {self.tracks} contact "
                             "node(s) per edge: no Bloch reduction")
        c_reps = rep[on_circle]
        offsets = frac[free_nodes][on_circle]
        # A couples a node to its neighbours only, so α_col − α_row takes a few values s (mod
        # 2π): RᵀA_m R = Σ_s e^{ims} RᵀA_s R, each RᵀA_s R (2 n_rep square) formed once
        mats = {}
        free_dof = np.zeros(self.problem.n_owned, dtype=bool)
        free_dof[2 * free_nodes], free_dof[2 * free_nodes + 1] = True, True
        for name, M in (("K", self.K), ("M", sp.diags(self.problem.mass).tocsr())):
            C = M.tocoo()
            # R has no rows at the clamped dofs: their entries (the zeros the boundary
            # condition leaves in the pattern among them) would only add empty shifts s,
            # one per clamped neighbour's sector (N of them; 8 s per S(ω) at N = 1056)
            keep = free_dof[C.row] & free_dof[C.col] & (C.data != 0.0)
            C = sp.coo_matrix((C.data[keep], (C.row[keep], C.col[keep])), shape=C.shape)
            dal = np.mod(ph_dof[C.col] - ph_dof[C.row], 2.0 * math.pi)
            key = np.round(dal / dphi).astype(np.intp) % n
            parts = []
            for k in np.unique(key):
                sel = key == k
                As = sp.csr_matrix((C.data[sel], (C.row[sel], C.col[sel])), shape=M.shape)
                parts.append((k * dphi, (R.T @ (As @ R)).toarray() / n))
            mats[name] = parts
        cdofs = np.ravel(np.c_[2 * c_reps, 2 * c_reps + 1])  # (track, r/θ) order
        idofs = np.setdiff1d(np.arange(2 * n_rep), cdofs)
        out = {"mats": mats, "c": cdofs, "i": idofs, "R": R, "alpha": ph_dof,
               "offsets": offsets}
        if self._blocks is None:
            self._blocks = {}
        self._blocks["bloch"] = out
        return out

    def track_phases(self, m: int) -> NDArray[np.complex128]:
        """e^{im(o_a − g_a)} per (track, r/θ) contact unknown of harmonic m: track a's node
        sits at o_a in its sector (``_bloch``), its points at g_a + iΔφ_e/S with g_a = o_a
        mod Δφ_e/S, where such nodes stand at the steps t = jh (module doc, "Tracks"); 1 on
        a P1 circle."""
        bl = self._bloch()
        pitch = 2.0 * math.pi * self.tracks / self.n  # Δφ_e/S
        grid = np.mod(bl["offsets"] + 1e-9 * pitch, pitch) - 1e-9 * pitch
        return np.repeat(np.exp(1j * m * (bl["offsets"] - grid)), 2)

    def shift_symbols_bloch(self, omega: float, period: int = 1) -> NDArray[np.complex128]:
        """t_m, m = 0 … P/2 (P points), by the Bloch (one-sector) reduction of A_m
        (``_bloch``): the harmonic-m subspace is invariant, so A_m restricted to it is
        Rᴴ diag(e^{−imα}) A_m diag(e^{imα}) R / N on 2 dofs per node orbit; its Schur
        complement on the contact orbit's (r, θ) is t_m. Cost per m: a few dense sums and one
        solve of 2 n_rep unknowns (n_rep = nodes per sector), no LU of the whole interior.
        ``period`` = k: only m = 0, k, 2k, … (row j is t_{jk}; the k-periodic fields)."""
        bl = self._bloch()
        ci, ii = bl["c"], bl["i"]
        n = self.n // (period * self.tracks)  # points per track
        w = 2 * self.tracks
        sym = np.zeros((n // 2 + 1, w, w), dtype=complex)
        for j in range(n // 2 + 1):
            m = j * period
            A = self._sector_operator(bl, m, omega)
            ph = self.track_phases(m)
            sym[j] = self.time_symbols(m, omega)[2] * (ph.conj()[:, None] * (
                A[np.ix_(ci, ci)] - A[np.ix_(ci, ii)] @ np.linalg.solve(
                    A[np.ix_(ii, ii)], A[np.ix_(ii, ci)])) * ph[None, :])
        return sym

    def step(self, omega: float) -> float:
        """h = Δφ_e/(samples·|ω|): the time between two points of one track, Δφ_e the
        mesh's symmetry angle (one contact edge; module doc, "Tracks")."""
        return 2.0 * math.pi * self.tracks / (self.n * abs(omega))

    def time_symbols(self, m: int, omega: float) -> tuple[complex, float, complex]:
        """(damping factor, inertia factor, contact factor) of harmonic m at ω, so that
        A_m = damping·K − inertia·M and the contact symbol is contact·(Schur complement).

        exact:   1 − iντ,              ν²,               1         (ν = mω);
        central: 1 + τ(z − 1)/(hD),    −(z − 1)²/(h²D),  e^{iνh}   (z = e^{−iνh},
        D = 1 + (β₂ + 1/2)(z − 1); module doc)."""
        nu = m * omega
        if self.time_scheme == "exact" or omega == 0.0:  # ω = 0: the static S (no step)
            return 1.0 - 1j * nu * self.tau, nu * nu, 1.0
        h = self.step(omega)
        vel, acc = self.step_factors(m, omega)
        return 1.0 + self.tau * vel, -acc, np.exp(1j * nu * h)

    def step_factors(self, m: int, omega: float) -> tuple[complex, complex]:
        """(ṽ/u, a/u) of harmonic m in the explicit scheme at step h (module doc):
        (z − 1)/(hD) and (z − 1)²/(h²D), z = e^{−imωh}, D = 1 + (β₂ + 1/2)(z − 1)."""
        h = self.step(omega)
        zm1 = np.exp(-1j * m * omega * h) - 1.0
        den = 1.0 + (self.beta2 + 0.5) * zm1
        return zm1 / (h * den), zm1 * zm1 / (h * h * den)

    def _sector_operator(self, bl: dict, m: int, omega: float) -> NDArray[np.complex128]:
        """A_m = (1 − imωτ)K − (mω)²M (or the central scheme's, ``time_symbols``) restricted
        to harmonic m on one sector (``_bloch``)."""
        red = {name: sum(np.exp(1j * m * a) * P for a, P in parts)
               for name, parts in bl["mats"].items()}
        fk, fm, _ = self.time_symbols(m, omega)
        return fk * red["K"] - fm * red["M"]

    def shift_symbols(self, omega: float) -> tuple[NDArray[np.complex128], float]:
        """(t_m for m = 0 … N/2, shape (N/2 + 1, 2, 2), forces per unit polar harmonic; the
        largest relative part of S(A_m) e_m outside harmonic m: the Z_N-symmetry check).
        The reference route: one sparse LU of the whole A_m,ii per m (``shift_symbols_bloch``
        is the fast one)."""
        if self.samples != 1 or self.time_scheme != "exact" or self.tracks != 1:
            raise ValueError("shift_symbols: the whole-mesh reference route has one point "
                             "per node of a P1 circle, exact in time; use "
                             "shift_symbols_bloch")
        if self._blocks is None or "Mii" not in self._blocks:
            c, i = self.contact, self.interior
            b = self._blocks if self._blocks is not None else {}
            Mm = sp.diags(self.problem.mass).tocsr()
            for name, Mat in (("Ks", self.K.tocsr()), ("M", Mm)):
                Mi = Mat[i]
                b[name + "ii"] = Mi[:, i].tocsc()
                b[name + "ic"] = Mi[:, c].tocsr()
                b[name + "ci"] = Mat[c][:, i].tocsr()
                b[name + "cc"] = Mat[c][:, c].toarray()
            self._blocks = b
        b = self._blocks
        n, theta, T = self.n, self.theta, self.T
        sym = np.zeros((n // 2 + 1, 2, 2), dtype=complex)
        leak = 0.0
        for m in range(n // 2 + 1):
            fk, fm = 1.0 - 1j * m * omega * self.tau, (m * omega) ** 2
            e = np.exp(1j * m * theta)
            E = np.zeros((2 * n, 2), dtype=complex)  # polar harmonic m, r then θ
            E[:n, 0], E[n:, 1] = e, e
            V = T @ E  # (x, y) contact dofs
            Aii = (fk * b["Ksii"] - fm * b["Mii"]).tocsc()
            X = splu(Aii).solve(fk * (b["Ksic"] @ V) - fm * (b["Mic"] @ V))
            SV = T.T @ (fk * (b["Kscc"] @ V) - fm * (b["Mcc"] @ V)
                        - fk * (b["Ksci"] @ X) + fm * (b["Mci"] @ X))
            t = E.conj().T @ SV / n
            sym[m] = t
            leak = max(leak, float(np.abs(SV - E @ t).max() / np.abs(SV).max()))
        return sym, leak

    def _schur_shift(self, omega: float, period: int = 1) -> Array:
        """The block-circulant S of the transient's travelling operator (module doc). Folded
        (``period`` = k, P/k points): S_k[j, l] = (1/(P/k)) Σ_m' t_{km'} e^{im'2π(j − l)k/P},
        the circulant of the symbols t_{km'} (``newton``, "Folding")."""
        tr = self.tracks
        n = self.n // (period * tr)  # points per track
        sym = self.shift_symbols_bloch(omega, period)
        full = np.zeros((n, 2 * tr, 2 * tr), dtype=complex)
        full[: n // 2 + 1] = sym
        full[n // 2 + 1:] = np.conj(sym[1:(n + 1) // 2][::-1])  # t_{N−m} = conj(t_m)
        if n % 2 == 0:
            full[n // 2] = full[n // 2].real
        col = np.fft.ifft(full, axis=0).real  # S_ab[j, 0] = (1/N) Σ_m t_m,ab e^{imθ_j}
        j = np.arange(n)
        idx = (j[:, None] - j[None, :]) % n
        P = n * tr  # points of the (folded) circle: point tr·i + a is track a's i-th
        S = np.empty((2 * P, 2 * P))
        for ta in range(tr):
            for tb in range(tr):
                for a in range(2):
                    for bb in range(2):
                        S[a * P + ta:(a + 1) * P:tr, bb * P + tb:(bb + 1) * P:tr] = col[
                            idx, 2 * ta + a, 2 * tb + bb]
        return S

    def stiffness(self, omega: float, derivative: bool = True, period: int = 1
                  ) -> tuple[Array, Array | None]:
        """(S, dS/dω or None) at ω, on ``period``-periodic fields (``factor``)."""
        S, dS, _ = self.factor(omega, derivative, period)
        return S, dS

    def shift_state(self, W: Array, omega: float, t: float = 0.0
                    ) -> tuple[Array, Array, Array]:
        """(u, v, a) at time t of the whole mesh for the contact values W of a wave of the
        transient's travelling operator (``inertia="shift"``, module doc); owned dofs, clamped
        ones 0. With P = N·samples points and ĉ_m the polar DFT of W (ĉ_m = (1/P) Σ_j W_j
        e^{−imθ_j}), the wave is

            u(t) = Σ_m diag(e^{imα}) R c_m e^{−imωt},   c_m = (ĉ_m, −A_m,ii⁻¹ A_m,ic ĉ_m),

        over |m| ≤ P/2 (``_bloch``: c_m on one sector's node orbits, α the sector angle, so
        e^{imα} is the discrete harmonic m mod N). ``time_scheme="exact"``: v = Σ −imω (…),
        a = Σ −(mω)² (…); the interior rows of M a + K (u + τ v) vanish, the contact rows are
        the nodal forces S(ω) W at the points the nodes occupy at t, and at t = jτ/samples
        (τ = Δφ/|ω|) node i holds W at point i·samples − j·sign(ω). ``"central"``: the
        explicit scheme's state at step t (``solver.newmark``, module doc): per harmonic
        a = (z − 1)²u/(h²D), v = ṽ + β₂h a with ṽ = (z − 1)u/(hD) (``step_factors``; at
        β₂ = 1/2, ṽ = (u(t) − u(t − h))/h and a the central difference), so that
        ``Simulation(initial_state=(u, v, a))`` with dt = h starts on the discrete wave
        (``tests/test_travel_fe.py``)."""
        if self.inertia != "shift":
            raise ValueError("shift_state: the wave must be one of inertia='shift'")
        bl = self._bloch()
        ci, ii = bl["c"], bl["i"]
        tr = self.tracks
        n = self.n // tr  # points per track
        # (track, r/θ) x m: each track's polar DFT on its own points
        chat = np.fft.fft(np.asarray(W, dtype=float).reshape(2, n, tr).transpose(2, 0, 1),
                          axis=2).reshape(2 * tr, n) / n
        R, alpha = bl["R"], bl["alpha"]
        central = self.time_scheme == "central"
        h = self.step(omega) if central else 0.0
        u, v, a = (np.zeros(self.problem.n_owned) for _ in range(3))
        for m in range(n // 2 + 1):
            A = self._sector_operator(bl, m, omega)
            c = np.zeros(A.shape[0], dtype=complex)
            c[ci] = chat[:, m] * self.track_phases(m)
            c[ii] = -np.linalg.solve(A[np.ix_(ii, ii)], A[np.ix_(ii, ci)] @ c[ci])
            term = np.exp(1j * m * alpha) * (R @ c) * np.exp(-1j * m * omega * t)
            weight = 1.0 if m == 0 or 2 * m == n else 2.0  # ĉ_{−m} = conj(ĉ_m): W is real
            if central:  # v_n = ṽ_n + β₂h a_n from the scheme's per-step factors
                vel, acc = self.step_factors(m, omega)
                dv, da = vel + self.beta2 * h * acc, acc
            else:  # the exact derivatives
                dv, da = -1j * m * omega, -((m * omega) ** 2)
            u += weight * term.real
            v += weight * (dv * term).real
            a += weight * (da * term).real
        return u, v, a

    def full_field(self, W: Array, omega: float) -> Array:
        """Owned dof array of w (clamped dofs 0) from the polar contact values W at ω."""
        _, _, X = self.factor(omega)
        b = self._split()
        wc = self.T @ W
        out = np.zeros(self.problem.n_owned)
        out[self.contact] = wc
        if X is None:
            if "phi" not in b:
                raise ValueError("full_field: the interior is kept only by the undamped "
                                 "rotation operator (LU or modal route), not with damping "
                                 "or inertia='shift'")
            w2 = omega * omega
            out[self.interior] = -b["phi"] @ (((b["B0"] - w2 * b["B1"]) @ wc)
                                             / (1.0 - w2 * b["mu"]))
        else:
            out[self.interior] = -X @ wc
        return out


def require_rotational_symmetry(scene) -> None:
    """ValueError (one line) unless the scene's mesh is invariant under the rotation by one
    contact-edge angle 2π/(N/degree): the wave's frame turns the mesh onto itself. The tube
    is; a user's ``mesh.file`` is checked (``meshes.user_mesh``)."""
    m = scene.mesh
    if m.tube or m.file_facts(scene.geometry.R).rotation_invariant:
        return
    raise ValueError(f"travel needs a rotationally symmetric cross-section (the wave's frame "
                     f"turns the mesh onto itself by 2π/{m.n_inner // m.degree}); mesh.file = "
                     f"{m.file!r} is not: use the tube (no mesh.file) or a symmetric mesh")


def frame_operators(problem: TubeProblem, damping: float = 0.0,
                    lumped: bool = False, inertia: str = "rotation",
                    samples: int = 1, time_scheme: str = "exact") -> FrameOperators:
    """Assemble G (and the damping, retardation time ``damping`` s), split the free dofs,
    order the contact nodes by θ (serial only). ``lumped``: G by the vertex rule
    (``forms.travelling.travelling_inertia``), the analogue of the transient's lumped mass.
    ``samples``: contact points per mesh node, ``time_scheme``: "exact" or "central" (both
    ``inertia="shift"`` only, module doc)."""
    import dolfinx
    import dolfinx.fem.petsc
    import ufl

    if problem.comm.size > 1:
        raise ValueError("stickslip travel runs on one process: drop mpirun")
    require_rotational_symmetry(problem.scene)
    if inertia not in INERTIAS:
        raise ValueError(f"inertia {inertia!r}: use 'rotation' (K − ω²G) or 'shift' (the "
                         "transient's travelling operator)")
    if not (isinstance(samples, int) and samples >= 1):
        raise ValueError(f"samples = {samples!r}: give a whole number ≥ 1 of contact points "
                         "per mesh node")
    if time_scheme not in TIME_SCHEMES:
        raise ValueError(f"time scheme {time_scheme!r}: use one of {', '.join(TIME_SCHEMES)}")
    if time_scheme != "exact" and inertia != "shift":
        raise ValueError(f"time scheme {time_scheme!r} needs inertia='shift'")
    if samples > 1 and inertia != "shift":
        raise ValueError(f"samples = {samples}: sub-node samples need inertia='shift' (the "
                         "continuous rotation has no node passage to sample)")
    V = problem.V
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    Gm = dolfinx.fem.petsc.assemble_matrix(
        dolfinx.fem.form(travelling_inertia(u, v, problem.material.rho, lumped)))
    Gm.assemble()
    G = _csr(Gm)
    Gm.destroy()
    K = _csr(problem.K)
    nd = problem.nodes
    order = np.argsort(nd.theta)
    theta = nd.theta[order]
    n = theta.size
    dphi = 2.0 * math.pi / n
    if abs(theta[0]) > 1e-9 * dphi or np.ptp(np.diff(theta)) > 1e-9 * dphi:
        raise ValueError("contact nodes are not uniform from θ = 0: need the structured tube mesh")
    contact = np.concatenate([nd.dofs_x[order], nd.dofs_y[order]]).astype(np.intp)
    free = np.ones(problem.n_owned, dtype=bool)
    free[problem.clamped] = False
    free[contact] = False
    interior = np.flatnonzero(free)
    cs, sn = np.cos(theta), np.sin(theta)
    T = np.block([[np.diag(cs), -np.diag(sn)], [np.diag(sn), np.diag(cs)]])
    C = None
    if damping > 0.0 and inertia == "rotation":  # "shift" damps with τK per harmonic
        # Kelvin–Voigt in the frame: D = τ K M⁻¹ B, M⁻¹B w the lumped projection of
        # (∂_θ − J)w onto P1 (forms.travelling.travelling_transport); the clamped dofs
        # have no velocity, so their rows of the projection are zero.
        Bm = dolfinx.fem.petsc.assemble_matrix(
            dolfinx.fem.form(travelling_transport(u, v, problem.material.rho)))
        Bm.assemble()
        moving = np.ones(problem.n_owned)
        moving[problem.clamped] = 0.0
        C = (damping * (K @ (sp.diags(moving / problem.mass) @ _csr(Bm)))).tocsr()
        Bm.destroy()
    points = theta if samples == 1 else np.arange(n * samples) * (dphi / samples)
    tracks = int(problem.scene.mesh.degree) if inertia == "shift" else 1
    ds = nd.ds_weight[order]
    weights = (np.repeat(ds, samples) if tracks == 1
               else np.tile(ds[:tracks], n * samples // tracks))  # point tr·i + a: track a
    return FrameOperators(problem, K, G, contact, interior, points, weights, T, C,
                          inertia=inertia, tau=float(damping), samples=samples,
                          time_scheme=time_scheme, beta2=float(problem.scene.time.beta2),
                          tracks=tracks)


def circle_problem(ops: FrameOperators, scene: Scene | None = None,
                   rate: str = "bdf2", period: int = 1) -> CircleProblem:
    """The condensed FE problem for ``studies.travel.newton.solve_wave`` (SI units).

    ``scene`` (default: the one the operators were built for) may change the loading and the
    mismatch only: K and G do not depend on them. ``rate``: the material-derivative scheme
    (``newton.RATES``). ``period`` = k: folded to one of k copies (``newton``, "Folding").
    """
    sc = ops.problem.scene if scene is None else scene
    if period < 1 or ops.n % (period * ops.tracks):
        raise ValueError(f"period {period}: must divide the {ops.n // ops.tracks} contact "
                         "points of each track")
    return CircleProblem(n=ops.n // period, d=sc.geometry.d,
                         surface_speed=sc.geometry.R * sc.loading.omega, f=sc.loading.f,
                         stiffness=partial(ops.stiffness, period=period), rate=rate,
                         period=period, tracks=ops.tracks)
