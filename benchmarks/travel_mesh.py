"""Mesh convergence of the travelled wave against the transient (third rung).

``./dev nice python3 benchmarks/travel_mesh.py RUN_DIR [RUN_DIR ...] [--lumped] [--step S]``

Each RUN_DIR is a finished ``stickslip run scenes/figure1_n132_damped.toml --set
mesh.n_inner=N --set time.dt_fraction=F`` (mode-k seed 0.1 d, β₂ = 1/2, τ = 1.989 µs);
N is read from the run. For each: the travel problem on the same mesh with the scene's τ
(``--lumped``: the wave-frame inertia by the vertex rule, the transient's mass lumping),
fixed-ω solves from the run's last sample at ω0(1 ± j·S), j ≤ 0.05/S (nearest admissible speed
first), then the band of the wave found. One JSON line per run on stdout.

``--nested RUN_DIR --levels 264 528`` (nested iteration): the wave is solved from the run's
last sample on the run's own mesh only; each finer mesh starts from the previous mesh's
converged band members, prolonged to the finer contact circle (``driver.prolong``), solved at
fixed ω (the member's own speed first, then ω0(1 ± j·S) up to ±``--scan``), and its band is
traced (``newton.wave_band``, steps of 0.2 %, edges bisected ``--bisections`` times). From
the third level on, ω0 is predicted from the last two levels' fast edges assuming first to
second order (shift 3/8 of the last one). One JSON line per level: the band, its two edge
members (amplitude, sub-node ψ, inequality margins, the one tangent at the edge and the one
violated beyond), the attempts (speed, residual history, violated inequality) and CPU/wall.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", type=Path)
    ap.add_argument("--lumped", action="store_true")
    ap.add_argument("--step", type=float, default=0.001)
    ap.add_argument("--scan", type=float, default=0.05)
    ap.add_argument("--k", type=int, default=0, help="wavenumber (default: the run's mode)")
    ap.add_argument("--nested", action="store_true", help="nested starts (module doc)")
    ap.add_argument("--levels", type=int, nargs="*", default=[264, 528])
    ap.add_argument("--prolong", choices=("linear", "fourier"), default="linear")
    ap.add_argument("--starts", type=int, default=3,
                    help="coarse members tried per level (fast edge first)")
    ap.add_argument("--bisections", type=int, default=5)
    ap.add_argument("--sweep", type=float, nargs=2, metavar=("C_FROM", "C_TO"),
                    help="at the finest level: fixed-ω solves from the prolonged fast-edge "
                         "member over C_FROM..C_TO m/s in steps of --step (a map of where it "
                         "converges), instead of the nearest-wave search; without --nested: "
                         "the same map from each run's last sample")
    ap.add_argument("--c-start", type=float, nargs="*", default=[],
                    help="per finer level, the speed (m/s) of the first fixed-ω solve from the "
                         "prolonged member (0: the member's own speed)")
    ap.add_argument("--tau-scales", type=float, nargs="*", default=[],
                    help="at the finest level, after its band: continue its middle member in the "
                         "damping τ·s for each s in turn (same ω, else nearest within ±1 %%) "
                         "and trace each band; stops at the first failure")
    ap.add_argument("--rate", choices=("bdf1", "bdf2"), default="bdf2",
                    help="material-derivative scheme of the contact law (newton.RATES)")
    ap.add_argument("--inertia", choices=("rotation", "shift"), default="rotation",
                    help="wave-frame operator: K - w^2 G (rotation) or the transient's own "
                         "travelling operator (shift; frame.py)")
    ap.add_argument("--free", action="store_true",
                    help="first a free-omega solve (phase condition) from each run's last "
                         "sample (nested: from the first prolonged member at each finer "
                         "level), recorded under 'free'")
    ap.add_argument("--pick", type=float, default=None, metavar="C_M_S",
                    help="nested: start each finer level from the coarse member nearest this "
                         "speed (default: the fast edge)")
    ap.add_argument("--all-starts", action="store_true",
                    help="try every start and trace each band found (default: stop at the first)")
    a = ap.parse_args()
    if a.nested:
        for run in a.runs:
            nested(run, a)
        return

    from stickslip.postprocess.analysis import analyse_run
    from stickslip.solver.scene import load_scene
    from stickslip.studies.travel import driver as D
    from stickslip.studies.travel.newton import NotConverged, nearest_wave, solve_wave

    for run in a.runs:
        scene = load_scene(str(run / "scene.toml"), [])
        t0 = time.process_time()
        st = D.setup(scene, float(scene.damping.tau), lumped=a.lumped, rate=a.rate,
                     inertia=a.inertia)
        W0, om0, _ = D.start_from_run(run, st)
        wave = analyse_run(run)
        k = a.k or wave.mode
        R = scene.geometry.R
        rec = {"run": str(run), "k": k, "n": st.ops.n, "dofs": int(st.ops.problem.n_global_dofs),
               "lumped": a.lumped, "rate": a.rate,
               "inertia": a.inertia, "dt_fraction": scene.time.dt_fraction,
               "transient_c_m_s": wave.celerity_m_s,
               "transient_amplitude_m": wave.amplitude_m, "transient_psi1": wave.psi1,
               "transient_psi2": wave.psi2, "step": a.step, "scan": a.scan}
        if a.free:  # (W, ω) with the phase condition from the run's last sample
            t_f = time.process_time()
            try:
                fs = solve_wave(st.prob, W0, om0, k, max_iter=40, stall=15)
                rec["free"] = {"status": "converged", "c_m_s": fs.omega * R,
                               "amplitude_m": D.member_amplitude(st, fs),
                               "history": fs.residual_history}
            except NotConverged as err:
                rec["free"] = {"status": "none", "last_c_m_s": err.info.get("omega", 0.0) * R,
                               "residual": err.info.get("residual"),
                               "violated": err.info.get("violated"),
                               "history": err.info.get("hist")}
            rec["free"]["cpu_s"] = time.process_time() - t_f
            _log(f"N={st.ops.n} free omega: {rec['free']}"[:300])
        if a.sweep:  # a map from the run's own last sample instead of the nearest wave
            sweep(st, None, st.ops.n, k, a, rec, W0=W0, from_c=om0 * R)
            continue
        try:
            sol = nearest_wave(st.prob, W0, om0, k, rel_step=a.step,
                               max_steps=int(round(a.scan / a.step)), max_iter=30)
            m, _ = D.measure(st, sol, k)
            b = D.band(st, sol, k)
            lo, hi = b["celerity_m_s"]
            c = wave.celerity_m_s
            rec.update(status="converged", celerity_m_s=sol.omega * R, band=b,
                       regime=m["regime"], amplitude_m=m["amplitude_m"],
                       psi1_subnode=m["psi1_subnode"], psi2_subnode=m["psi2_subnode"],
                       transient_outside_band_m_s=max(lo - c, c - hi, 0.0))
        except NotConverged as err:
            rec.update(status="none", last_residual=err.info.get("residual"),
                       violated=err.info.get("violated"))
        rec["cpu_s"] = time.process_time() - t0
        print(json.dumps(rec), flush=True)


def _log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def _edge(st, m, k: int) -> dict:
    """One band edge member measured like ``stickslip run``; the tangent inequality is the
    smallest of the four nodal margins (gap, pressure, cone, slip direction)."""
    from stickslip.studies.travel import driver as D

    s, _ = D.measure(st, m, k)
    mg = s["inequalities"]["margins"]
    keys = ("gap_separation", "pressure_contact", "cone_stick", "slip_direction")
    tangent = min(keys, key=lambda key: mg[key])
    return {"c_m_s": m.omega * st.scene.geometry.R, "amplitude_m": s["amplitude_m"],
            "regime": s["regime"], "psi1": s["psi1"], "psi2": s["psi2"],
            "psi1_subnode": s["psi1_subnode"], "psi2_subnode": s["psi2_subnode"],
            "fractions": s["fractions"], "margins": mg, "tangent": tangent}


def nested(run: Path, a: argparse.Namespace) -> None:
    """Nested iteration over the meshes (module doc); one JSON line per level on stdout."""
    from stickslip.postprocess.analysis import analyse_run
    from stickslip.solver.scene import load_scene
    from stickslip.studies.travel import driver as D
    from stickslip.studies.travel.newton import NotConverged, nearest_wave, solve_wave, wave_band

    base = load_scene(str(run / "scene.toml"), [])
    wave = analyse_run(run)
    k = a.k or wave.mode
    R = base.geometry.R
    tau = float(base.damping.tau)
    members = None
    fast_hist: list[float] = []  # fast-edge ω per level
    members_n = 0  # the mesh the members come from
    for level, n in enumerate([base.mesh.n_inner, *a.levels]):
        c0, w0 = time.process_time(), time.time()
        scene = base if level == 0 else load_scene(str(run / "scene.toml"),
                                                   [f"mesh.n_inner={n}"])
        st = D.setup(scene, tau, lumped=a.lumped, rate=a.rate,
                     inertia=a.inertia)
        rec: dict = {"run": str(run), "k": k, "n": n, "dofs": int(st.ops.problem.n_global_dofs),
                     "tau_s": tau, "beta2": scene.time.beta2, "lumped": a.lumped,
                     "rate": a.rate, "inertia": a.inertia,
                     "start": "run" if level == 0 else f"prolonged from N = {members_n}",
                     "prolong": a.prolong, "attempts": []}
        sol = None
        if level == 0:
            W0, om0, _ = D.start_from_run(run, st)
            rec["transient"] = {"c_m_s": wave.celerity_m_s, "amplitude_m": wave.amplitude_m,
                                "psi1": wave.psi1, "psi2": wave.psi2,
                                "dt_fraction": scene.time.dt_fraction}
            try:
                if a.free:  # free ω first (phase condition), else the nearest fixed speed
                    try:
                        sol = solve_wave(st.prob, W0, om0, k, max_iter=40, stall=15)
                        rec["free"] = {"status": "converged", "c_m_s": sol.omega * R,
                                       "history": sol.residual_history}
                    except NotConverged:
                        sol = None
                if sol is None:
                    sol = nearest_wave(st.prob, W0, om0, k, rel_step=a.step,
                                       max_steps=int(round(a.scan / a.step)), max_iter=30)
            except NotConverged as err:
                rec["attempts"].append({"c0_m_s": om0 * R, "residual": err.info.get("residual"),
                                        "violated": err.info.get("violated")})
        else:
            # fast edge first (largest |ω|), then the others by distance from it; --pick: the
            # member nearest that speed first
            order = sorted(members, key=lambda m: -abs(m.omega) if a.pick is None
                           else abs(m.omega * R - a.pick))
            picks = [order[0]] if len(order) == 1 else [
                order[int(round(i * (len(order) - 1) / max(a.starts - 1, 1)))]
                for i in range(min(a.starts, len(order)))]
            shift = 0.0
            if len(fast_hist) >= 2:
                shift = 0.375 * (fast_hist[-1] - fast_hist[-2])
            if a.sweep and level == len(a.levels):  # the sweep maps the finest level
                sweep(st, members, n, k, a, rec)
                return
            found = []  # (fast-edge |ω|, sol) per start that converged
            if a.free:  # (W, ω) with the phase condition from the first prolonged member
                t_f = time.process_time()
                W0 = D.prolong(np.concatenate([picks[0].W_r, picks[0].W_t]), n, a.prolong)
                try:
                    fs = solve_wave(st.prob, W0, picks[0].omega + shift, k, max_iter=40,
                                    stall=15)
                    rec["free"] = {"status": "converged", "c_m_s": fs.omega * R,
                                   "amplitude_m": D.member_amplitude(st, fs),
                                   "history": fs.residual_history}
                    found.append((abs(fs.omega), fs))
                except NotConverged as err:
                    rec["free"] = {"status": "none",
                                   "last_c_m_s": err.info.get("omega", 0.0) * R,
                                   "residual": err.info.get("residual"),
                                   "violated": err.info.get("violated"),
                                   "history": err.info.get("hist")}
                rec["free"]["cpu_s"] = time.process_time() - t_f
                _log(f"N={n} free omega: {rec['free']}"[:300])
            for m in picks if not found else []:
                W0 = D.prolong(np.concatenate([m.W_r, m.W_t]), n, a.prolong)
                om0 = m.omega + shift
                if level <= len(a.c_start) and a.c_start[level - 1]:
                    om0 = a.c_start[level - 1] / R
                att = {"from_c_m_s": m.omega * R, "c0_m_s": om0 * R}
                t_att = time.process_time()
                got = None
                try:  # the member's own speed (plus the predicted shift) first
                    got = solve_wave(st.prob, W0, om0, k, free_omega=False, max_iter=30)
                    att["how"] = "same speed"
                except NotConverged as err:
                    att["same_speed"] = {"residual": err.info.get("residual"),
                                         "violated": err.info.get("violated"),
                                         "history": err.info.get("hist")}
                    _log(f"N={n} from c={m.omega * R:.1f}: same speed fails "
                         f"(residual {err.info.get('residual'):.3g}, {err.info.get('violated')})")
                    try:
                        got = nearest_wave(st.prob, W0, om0, k, rel_step=a.step,
                                           max_steps=int(round(a.scan / a.step)), max_iter=30)
                        att["how"] = "scan"
                    except NotConverged as err2:
                        att["scan"] = {"residual": err2.info.get("residual"),
                                       "violated": err2.info.get("violated")}
                if got is not None:
                    att["c_m_s"] = got.omega * R
                    if a.all_starts:  # each start's band, to see which bands exist
                        lo_, hi_, mem_ = wave_band(st.prob, got, k, rel_step=0.002,
                                                   max_steps=60, bisections=3, max_iter=30)
                        att["band_m_s"] = [lo_ * R, hi_ * R]
                        att["amplitude_m"] = [D.member_amplitude(st, x) for x in mem_]
                        found.append((max(abs(lo_), abs(hi_)), got))
                    else:
                        found.append((abs(got.omega), got))
                att["cpu_s"] = time.process_time() - t_att
                rec["attempts"].append(att)
                _log(f"N={n}: attempt {att}"[:400])
                if found and not a.all_starts:
                    break
            # proceed with the band reaching the fastest speed (the transient sits at the
            # fast edge at N = 132, and the transients get faster with N)
            sol = max(found, key=lambda x: x[0])[1] if found else None
        if sol is None:
            rec.update(status="none", cpu_s=time.process_time() - c0, wall_s=time.time() - w0)
            print(json.dumps(rec), flush=True)
            return
        why: list = []
        lo, hi, members = wave_band(st.prob, sol, k, rel_step=0.002, max_steps=60,
                                    bisections=a.bisections, max_iter=30, edge_reasons=why)
        members_n = n
        fast = max(members, key=lambda m: abs(m.omega))
        slow = min(members, key=lambda m: abs(m.omega))
        fast_hist.append(fast.omega)
        # edge_reasons are for the lower then the upper ω edge
        beyond = {"fast": why[0] if fast.omega < 0 else why[1],
                  "slow": why[1] if fast.omega < 0 else why[0]}
        rec.update(status="converged", found_c_m_s=sol.omega * R,
                   band_m_s=[lo * R, hi * R], members=len(members),
                   fast=_edge(st, fast, k) | {"violated_beyond": beyond["fast"]},
                   slow=_edge(st, slow, k) | {"violated_beyond": beyond["slow"]},
                   member_table=[[m.omega * R, D.member_amplitude(st, m)] for m in members],
                   cpu_s=time.process_time() - c0, wall_s=time.time() - w0)
        print(json.dumps(rec), flush=True)
        if a.tau_scales and level == len(a.levels):
            damping_path(scene, sorted(members, key=lambda x: x.omega)[len(members) // 2],
                         n, k, tau, a)
        _log(f"N={n}: band [{lo * R:.2f}, {hi * R:.2f}] m/s, fast edge amplitude "
             f"{rec['fast']['amplitude_m']:.4e}, cpu {rec['cpu_s']:.0f} s")


def damping_path(scene, start, n: int, k: int, tau: float, a: argparse.Namespace) -> None:
    """Continuation in the Kelvin–Voigt τ from a converged wave (same ω, else the nearest
    within ±1 %): does more damping widen the band (blunt the interior resonances)? One JSON
    line per τ; the path stops at the first τ without a wave."""
    from stickslip.studies.travel import driver as D
    from stickslip.studies.travel.newton import NotConverged, nearest_wave, wave_band

    R = scene.geometry.R
    cur = start
    for s in a.tau_scales:
        c0 = time.process_time()
        st = D.setup(scene, tau * s, lumped=a.lumped, rate=a.rate,
                     inertia=a.inertia)
        rec: dict = {"n": n, "k": k, "tau_s": tau * s, "tau_scale": s, "c0_m_s": cur.omega * R}
        try:
            # same ω first, then the nearest speed within ±1 % (0.1 % steps)
            cur = nearest_wave(st.prob, np.concatenate([cur.W_r, cur.W_t]), cur.omega, k,
                               rel_step=0.001, max_steps=10, max_iter=30)
            lo, hi, mem = wave_band(st.prob, cur, k, rel_step=0.002, max_steps=60,
                                    bisections=a.bisections, max_iter=30)
            amp = [D.member_amplitude(st, x) for x in mem]
            rec.update(status="converged", band_m_s=[lo * R, hi * R],
                       amplitude_m=[min(amp), max(amp)], members=len(mem))
            # next τ from the band's middle member (an edge member is marginal by definition)
            cur = sorted(mem, key=lambda x: x.omega)[len(mem) // 2]
        except NotConverged as err:
            rec.update(status="none", residual=err.info.get("residual"),
                       violated=err.info.get("violated"))
        rec["cpu_s"] = time.process_time() - c0
        print(json.dumps(rec), flush=True)
        _log(f"N={n} tau x{s}: {rec}")
        if rec["status"] != "converged":
            break  # the path ends here: the row names the violated inequality


def sweep(st, members, n: int, k: int, a: argparse.Namespace, rec: dict,
          W0: np.ndarray | None = None, from_c: float | None = None) -> None:
    """Fixed-ω solves over a range of speeds, each from the same start (the coarse band's
    prolonged fast-edge member, or ``W0``, e.g. a run's last sample): where does an admissible
    wave exist near it? JSON line."""
    from stickslip.studies.travel import driver as D
    from stickslip.studies.travel.newton import NotConverged, solve_wave

    R = st.scene.geometry.R
    c0, w0 = time.process_time(), time.time()
    if W0 is None:
        m = max(members, key=lambda x: abs(x.omega))
        W0 = D.prolong(np.concatenate([m.W_r, m.W_t]), n, a.prolong)
        from_c = m.omega * R
    c_from, c_to = a.sweep
    count = int(round(abs(np.log(c_to / c_from)) / a.step)) + 1
    rows = []
    for c in c_from * (c_to / c_from) ** np.linspace(0.0, 1.0, count):
        try:
            sol = solve_wave(st.prob, W0, c / R, k, free_omega=False, max_iter=30)
            zs, _ = D.measure(st, sol, k)
            row = {"c_m_s": c, "status": "converged", "amplitude_m": zs["amplitude_m"],
                   "psi1_subnode": zs["psi1_subnode"], "psi2_subnode": zs["psi2_subnode"],
                   "iterations": sol.iterations}
        except NotConverged as err:
            row = {"c_m_s": c, "status": "none", "residual": err.info.get("residual"),
                   "violated": err.info.get("violated"), "iterations": err.info.get("iterations")}
        rows.append(row)
        _log(f"N={n} sweep {row}")
    rec.update(status="sweep", from_c_m_s=from_c, sweep=rows,
               cpu_s=time.process_time() - c0, wall_s=time.time() - w0)
    print(json.dumps(rec), flush=True)


if __name__ == "__main__":
    main()
