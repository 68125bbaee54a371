"""Is the wave-frame operator itself mesh-converged? Harmonic symbols of S(ω).

The contact nodes are Z_N symmetric, so the condensed wave-frame stiffness S(ω) (polar
components, ``studies.travel.frame``) is block circulant and the discrete harmonic
e_m = e^{imθ_j}/√N is an eigenvector of each block. Its 2 × 2 symbol, per unit length of the
contact circle (R = 1 m in the Figure-1 scenes, so the node spacing is 2π/N m),

    s_m(ω) = [e_mᴴ S_ab(ω) e_m]_{a,b ∈ {r, θ}} / (2π/N)          [Pa per m],

is the dynamic stiffness the contact sees for the m-th harmonic of a wave turning at ω (the
tube's response at frequency mω with circumferential order m). A mode-k wave uses the
harmonics m = k, 2k, 3k, ...; the frame problem can only converge in N once s_m(ω) has
converged for the harmonics that carry the wave.

``./dev nice python3 benchmarks/travel_symbol.py symbol --n 132 264 528 --omega -2580``
    one JSON line per (N, ω): s_m for m = 4, 8, ..., 128 (scene figure1_n132_damped, its
    Kelvin–Voigt τ); then a table of max|s_m(N) − s_m(2N)| / max|s_m(2N)| on stderr.

``./dev nice python3 benchmarks/travel_symbol.py residual RUN [--samples M]``
    the transient run's last M samples, shifted back into the wave frame at the measured ω₀
    (spectral shift by ω₀(t_end − t_j), exact for a rigidly turning wave) and averaged, put
    into the frame equilibrium: r_m = |F_m(S(ω₀)W̄ − λ̄)| / |F_m λ̄| per harmonic, with the
    share |F_m λ̄|² / Σ of the contact force in each. r_m ≈ 0: the transient's state is a
    stationary solution of the frame equations at that harmonic.

``./dev nice python3 benchmarks/travel_symbol.py transient --n 132 264 --omega -2580``
    the same symbol for the *transient's* semi-discrete equations M ü + τK u̇ + K u = r
    (lumped M, ``solver.ensemble.ArrayColumns``, continuous in time): a wave W(θ − ωt) that
    is invariant under the mesh's discrete shift has, per discrete harmonic m, the frequency
    −mω, so its dynamic stiffness is the contact Schur complement of
    A_m = (1 − imωτ)K − (mω)² M, t_m(ω) = e_mᴴ S(A_m) e_m / (2π/N) (``frame`` with
    ``inertia="shift"``, Bloch reduction). The wave-frame operator replaces (mω)² M by ω² G
    (the Galerkin form of the continuous rotation). One JSON line per (N, ω);
    max|s_m − t_m| / max|t_m| on stderr. ``symcmp``-style tables of t_m across N: run with
    ``--no-rotation`` and compare the lines.

``./dev nice python3 benchmarks/travel_symbol.py law RUN --rate bdf1``
    the run's last sample (W, and its own contact forces λ) put into the wave-frame contact
    law of that scheme at ω₀: max_i |C_i| / (c·d) and the nodes whose status differs (the law
    alone, without the bulk equilibrium).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np


def symbols(S: np.ndarray, n: int, ms: list[int]) -> dict[int, np.ndarray]:
    """{m: 2 × 2 complex symbol per unit length} of the polar block-circulant S (module doc)."""
    theta = np.arange(n) * (2.0 * math.pi / n)
    out = {}
    for m in ms:
        e = np.exp(1j * m * theta) / math.sqrt(n)
        blk = np.array([[e.conj() @ S[a * n:(a + 1) * n, b * n:(b + 1) * n] @ e
                         for b in range(2)] for a in range(2)])
        out[m] = blk / (2.0 * math.pi / n)
    return out


def cmd_symbol(a: argparse.Namespace) -> None:
    from stickslip.solver.scene import load_scene
    from stickslip.studies.travel import driver as D

    table: dict = {}
    for n in a.n:
        sc = load_scene(a.scene, [f"mesh.n_inner={n}"])
        st = D.setup(sc, float(sc.damping.tau))
        ms = [m for m in range(a.k, a.m_max + 1, a.k) if m <= n // 2]
        for om in a.omega:
            t0 = time.process_time()
            S, _ = st.prob.stiffness(om, False)
            sym = symbols(S, n, ms)
            table[(n, om)] = sym
            print(json.dumps({"n": n, "omega": om, "tau_s": float(sc.damping.tau),
                              "cpu_s": time.process_time() - t0,
                              "symbol_re_im": {m: [v.real.tolist(), v.imag.tolist()]
                                               for m, v in sym.items()}}), flush=True)
    for om in a.omega:
        pairs = [(x, y) for x, y in zip(a.n, a.n[1:], strict=False)]
        print(f"omega {om}: max|s_m(N) - s_m(N')| / max|s_m(N')|  "
              + "  ".join(f"{x}->{y}" for x, y in pairs), file=sys.stderr)
        for m in sorted(table[(a.n[0], om)]):
            row = [np.abs(table[(x, om)][m] - table[(y, om)][m]).max()
                   / np.abs(table[(y, om)][m]).max()
                   for x, y in pairs if m in table[(y, om)]]
            print(f"  m = {m:3d}  " + "  ".join(f"{v:9.3f}" for v in row), file=sys.stderr)


def cmd_transient(a: argparse.Namespace) -> None:
    from stickslip.solver.scene import load_scene
    from stickslip.studies.travel import driver as D

    for n in a.n:
        sc = load_scene(a.scene, [f"mesh.n_inner={n}"])
        tau = float(sc.damping.tau)
        st = D.setup(sc, tau, inertia="shift")
        rot = D.setup(sc, tau) if not a.no_rotation else None
        ms = [m for m in range(a.k, a.m_max + 1, a.k) if m <= n // 2]
        for om in a.omega:
            t0 = time.process_time()
            t_all = st.ops.shift_symbols_bloch(om) / (2.0 * math.pi / n)
            rec = {"n": n, "omega": om, "tau_s": tau,
                   "transient_symbol_re_im": {m: [t_all[m].real.tolist(), t_all[m].imag.tolist()]
                                              for m in ms}}
            if rot is not None:
                S, _ = rot.prob.stiffness(om, False)
                s_f = symbols(S, n, ms)
                rec["frame_vs_transient"] = {m: float(np.abs(s_f[m] - t_all[m]).max()
                                                      / np.abs(t_all[m]).max()) for m in ms}
                print(f"N = {n}, omega = {om}: max|s_m - t_m|/max|t_m|  "
                      + "  ".join(f"{m}:{v:.3f}" for m, v in rec["frame_vs_transient"].items()),
                      file=sys.stderr)
            rec["cpu_s"] = time.process_time() - t0
            print(json.dumps(rec), flush=True)


def cmd_residual(a: argparse.Namespace) -> None:
    from stickslip.postprocess.analysis import load_run
    from stickslip.solver.scene import load_scene
    from stickslip.studies.travel import driver as D

    sc = load_scene(str(a.run / "scene.toml"), [])
    st = D.setup(sc, a.tau_scale * float(sc.damping.tau), lumped=a.lumped,
                 inertia=a.inertia)
    _, om0, _ = D.start_from_run(a.run, st)
    s = load_run(a.run).samples
    o = np.argsort(s["theta"])
    n = o.size
    m = np.fft.rfftfreq(n, 1.0 / n)
    t = s["t"]
    Wf = np.zeros((2, m.size), complex)
    Lf = np.zeros((2, m.size), complex)
    for j in range(-a.samples, 0):
        ph = np.exp(-1j * m * om0 * (t[-1] - t[j]))[None, :] / a.samples
        Wf += np.fft.rfft(np.vstack([s["u_r"][j][o], s["u_theta"][j][o]]), axis=1) * ph
        Lf += np.fft.rfft(np.vstack([s["r_r"][j][o], s["r_theta"][j][o]]), axis=1) * ph
    W = np.fft.irfft(Wf, n, axis=1).reshape(-1)
    total = float(np.sum(np.abs(Lf) ** 2))
    for om in [om0 * (1.0 + x) for x in a.rel_omega]:
        S, _ = st.prob.stiffness(om, False)
        Rf = np.fft.rfft((S @ W).reshape(2, n), axis=1) - Lf
        ks = list(range(0, min(n // 2, a.m_max) + 1, a.k))
        rec = {"run": str(a.run), "n": n, "omega": om, "omega0": om0, "samples": a.samples,
               "span_s": float(t[-1] - t[-a.samples]), "lumped": a.lumped,
               "tau_scale": a.tau_scale, "inertia": a.inertia,
               "m": ks,
               "force_share": [float(np.sum(np.abs(Lf[:, k]) ** 2) / total) for k in ks],
               "residual": [float(np.linalg.norm(Rf[:, k]) / np.linalg.norm(Lf[:, k]))
                            for k in ks]}
        print(json.dumps(rec), flush=True)
        print(f"N = {n}, omega = {om:.2f}: m / share / r_m: "
              + "  ".join(f"{k}:{sh:.1e}/{r:.3f}" for k, sh, r in
                          zip(ks, rec["force_share"], rec["residual"], strict=True)),
              file=sys.stderr)


def cmd_law(a: argparse.Namespace) -> None:
    from stickslip.postprocess.analysis import load_run
    from stickslip.solver.scene import load_scene
    from stickslip.studies.travel import driver as D
    from stickslip.studies.travel.newton import _Law, nodal_stiffness

    sc = load_scene(str(a.run / "scene.toml"), [])
    st = D.setup(sc, float(sc.damping.tau), rate=a.rate)
    W, om0, _ = D.start_from_run(a.run, st)
    s = load_run(a.run).samples
    o = np.argsort(s["theta"])
    n = o.size
    lam = np.concatenate([s["r_r"][-1][o], s["r_theta"][-1][o]])
    c = nodal_stiffness(st.prob)
    law = _Law(st.prob, c)
    C, _ = law(W, lam, om0)
    scale = c * sc.geometry.d
    rec = {"run": str(a.run), "n": n, "rate": a.rate, "omega0": om0,
           "law_residual_normal": float(np.abs(C[:n]).max() / scale),
           "law_residual_tangential": float(np.abs(C[n:]).max() / scale),
           "status_differs": int(np.count_nonzero(law.out.status != s["status"][-1][o]))}
    print(json.dumps(rec), flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("symbol")
    p.add_argument("--scene", default="scenes/figure1_n132_damped.toml")
    p.add_argument("--n", type=int, nargs="+", default=[132, 264, 528])
    p.add_argument("--omega", type=float, nargs="+", default=[-2580.0])
    p.add_argument("--k", type=int, default=4)
    p.add_argument("--m-max", type=int, default=64)
    p.set_defaults(func=cmd_symbol)
    t = sub.add_parser("transient")
    t.add_argument("--scene", default="scenes/figure1_n132_damped.toml")
    t.add_argument("--n", type=int, nargs="+", default=[132, 264])
    t.add_argument("--omega", type=float, nargs="+", default=[-2580.0])
    t.add_argument("--k", type=int, default=4)
    t.add_argument("--m-max", type=int, default=64)
    t.add_argument("--no-rotation", action="store_true",
                   help="the transient's symbols only (no LU of the rotation operator)")
    t.set_defaults(func=cmd_transient)
    q = sub.add_parser("residual")
    q.add_argument("run", type=Path)
    q.add_argument("--samples", type=int, default=20)
    q.add_argument("--rel-omega", type=float, nargs="+", default=[0.0])
    q.add_argument("--lumped", action="store_true")
    q.add_argument("--inertia", choices=("rotation", "shift"), default="rotation")
    q.add_argument("--tau-scale", type=float, default=1.0,
                   help="frame damping = this × the scene's τ (a sign / size check)")
    q.add_argument("--k", type=int, default=4)
    q.add_argument("--m-max", type=int, default=64)
    q.set_defaults(func=cmd_residual)
    w = sub.add_parser("law")
    w.add_argument("run", type=Path)
    w.add_argument("--rate", choices=("bdf1", "bdf2"), default="bdf2")
    w.set_defaults(func=cmd_law)
    a = ap.parse_args()
    a.func(a)


if __name__ == "__main__":
    main()
