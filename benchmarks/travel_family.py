"""Family of FE travelling waves, k = 1 .. 12: what exists, what attracts.

``./dev nice python3 benchmarks/travel_family.py OUT [--scene NAME ...] [--dt-fraction F]``
then ``./dev python3 benchmarks/travel_family.py OUT --table`` prints the markdown table of
archive/travel/travelling_waves_history.md ("Family of FE waves"), with each transient's frame
spread
(``travel_mismatch.rigidity``: is the limit cycle a rigidly turning wave at all?).

Stage 1 (attractors): for each seed k = 1 .. 12 the transient
``stickslip run scenes/NAME.toml --set initial.mode=k --set time.dt_fraction=F`` (mode-k seed of
0.1 d, the scene's β₂, Kelvin–Voigt τ and N); kept if OUT/NAME_seedK/summary.json exists.

Stage 2 (existence): for each wavenumber k, fixed-ω travel solves (``newton.nearest_wave``:
ω0(1 ± j·0.25 %), j ≤ 20, i.e. ±5 % of the start speed; the scene's τ) from

* ``run seed s``: the last sample of every transient that reached mode k (the attractors);
* ``reduced``: the reduced model's wave at k (``driver.start_from_reduced``; where eq. [2] has
  none, its built-in mode-k flutter guess), at its speed;
* ``shape bwd`` / ``shape fwd``: a backward (forward) attractor of another wavenumber m,
  period-averaged and stretched to period 2π/k (W'(θ) = W̄((θ mod 2π/k)·k/m)), at the speed
  of equal frequency c' = c·m/k: mode-k starts that are not transient end states, in both
  directions.

Every converged wave is measured (``driver.measure``, sub-node ψ) and its band of admissible
speeds traced (``driver.band``). One JSON line per attempt in OUT/family.jsonl.

``--samples S --time-scheme central``: the same starts on the transient's own discrete wave
(``studies.travel.frame``, "Samples" and "Central scheme"; inertia "shift", bdf1 law). Its
waves are isolated in ω (archive/travel/travelling_waves_history.md 2e), so each start gets the
free-ω Newton
only (on one wavelength when k divides N·S, ``driver.folded``), no fixed-ω scan and no band;
the starts from a run are its probe history. Lines in OUT/family_central_sS.jsonl, each
wave in OUT/waves/SCENE_kK_I.npz (``benchmarks/travel_wave_seeds.py`` starts transients next
to them); ``--table`` with the same options prints that table.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

SCENES = ("figure1_n132_damped", "figure3_n132_damped")
REL_STEP, STEPS = 0.0025, 20  # ±5 % of the start speed in steps of 0.25 % (bands ~0.5-1 % wide)
DIRS = {"opposite": "against Ω", "rotation": "with Ω"}
RIGID = 0.10  # frame spread (travel_mismatch.rigidity) below which a limit cycle is a rigidly
# turning wave: measured 0.2 - 6 % for waves and 28 - 46 % for modulated cycles at N = 66 - 264


def transients(out: Path, scene: str, dt_fraction: float, kmax: int) -> dict[int, dict]:
    """Stage 1: the seeded transients (module doc); {seed: summary}."""
    runs = {}
    for k in range(1, kmax + 1):
        r = out / f"{scene}_seed{k}"
        if not (r / "summary.json").exists():
            cmd = ["stickslip", "run", f"scenes/{scene}.toml", "--set", f"initial.mode={k}",
                   "--set", f"time.dt_fraction={dt_fraction}", "-o", str(r), "--force"]
            with open(f"{r}.log", "w") as log:
                subprocess.run(cmd, stdout=log, stderr=subprocess.STDOUT, check=False)
        s = json.loads((r / "summary.json").read_text())
        s["dir"] = str(r)
        runs[k] = s
        print(f"{scene} seed {k}: {s.get('regime')} k={s.get('mode')} "
              f"c={s.get('celerity_m_s', float('nan')):.1f} lc={s.get('limit_cycle')}",
              flush=True)
    return runs


def stretched(W: np.ndarray, n: int, m: int, k: int) -> np.ndarray:
    """A mode-m nodal wave (W_r, W_θ), averaged over its m periods, stretched to period 2π/k."""
    theta = np.arange(n) * (2.0 * math.pi / n)
    a = (theta % (2.0 * math.pi / k)) * k / m  # target phase -> angle in the source's 1st period
    out = []
    for comp in (W[:n], W[n:]):
        vals = [np.interp(a + 2.0 * math.pi * j / m, theta, comp, period=2.0 * math.pi)
                for j in range(m)]
        out.append(np.mean(vals, axis=0))
    return np.concatenate(out)


def attempt(st, k: int, W0: np.ndarray, om0: float, label: str, known: list,
            save: Path | None = None) -> dict:
    """Fixed-ω nearest-speed solve from (W0, om0); band of a new wave (module doc). Central
    scheme: the free-ω Newton only, no band (isolated waves), the wave saved to ``save``."""
    from stickslip.studies.travel import driver as D
    from stickslip.studies.travel.newton import NotConverged, nearest_wave

    R = st.scene.geometry.R
    c0 = om0 * R
    central = st.ops.time_scheme == "central"
    rec = {"k": k, "start": label, "start_celerity_m_s": c0,
           "scanned_m_s": [c0, c0] if central else
           sorted([c0 * (1 - REL_STEP * STEPS), c0 * (1 + REL_STEP * STEPS)])}
    t0 = time.process_time()
    try:
        if central:
            sol = D.solve_free(st, k, W0, om0, max_iter=40)
        else:
            sol = nearest_wave(st.prob, W0, om0, k, rel_step=REL_STEP, max_steps=STEPS,
                               max_iter=30)
    except NotConverged as err:
        rec.update(status="none", last_residual=err.info.get("residual"),
                   violated=err.info.get("violated"), cpu_s=time.process_time() - t0)
        return rec
    summ, _ = D.measure(st, sol, k)
    c = sol.omega * R
    rec.update(status="converged", celerity_m_s=c, regime=summ["regime"], mode=summ["mode"],
               direction=summ["direction"], amplitude_m=summ["amplitude_m"],
               psi1=summ["psi1"], psi2=summ["psi2"], psi1_subnode=summ["psi1_subnode"],
               psi2_subnode=summ["psi2_subnode"], fractions=summ["fractions"])
    rec.update(iterations=sol.iterations, residual=sol.residual)
    if central and save is not None:  # the wave itself, for travel_wave_seeds.py
        save.mkdir(exist_ok=True)
        path = save / f"{st.scene.name}_k{k}_{len(list(save.glob('*.npz')))}.npz"
        np.savez(path, scene=st.scene.name, k=k, samples=st.ops.samples, omega=sol.omega,
                 W=np.r_[sol.W_r, sol.W_t], start=label)
        rec["wave_file"] = str(path)
    same = [b for b in known if b["celerity_m_s"][0] - 1e-9 <= c <= b["celerity_m_s"][1] + 1e-9]
    if central:
        rec["band"] = {"celerity_m_s": [c, c], "psi1": [summ["psi1_subnode"]] * 2,
                       "psi2": [summ["psi2_subnode"]] * 2,
                       "amplitude_m": [summ["amplitude_m"]] * 2, "members": 1}
    elif same:
        rec["band"] = same[0]
        rec["band_from"] = "known"
    else:
        rec["band"] = D.band(st, sol, k)
        known.append(rec["band"])
    rec["cpu_s"] = time.process_time() - t0
    return rec


def family_file(out: Path, samples: int, time_scheme: str) -> Path:
    """OUT/family.jsonl (one point per node, exact in time) or OUT/family_central_sS.jsonl."""
    return out / ("family.jsonl" if time_scheme == "exact" and samples == 1
                  else f"family_{time_scheme}_s{samples}.jsonl")


def existence(out: Path, scene_name: str, runs: dict[int, dict], kmax: int,
              samples: int = 1, time_scheme: str = "exact") -> None:
    """Stage 2 (module doc): append one JSON line per attempt to ``family_file``."""
    from stickslip.solver.scene import load_scene
    from stickslip.studies.travel import driver as D

    scene = load_scene(f"scenes/{scene_name}.toml", [])
    if time_scheme == "exact" and samples == 1:
        st = D.setup(scene, float(scene.damping.tau))
    else:
        st = D.setup(scene, float(scene.damping.tau), rate="bdf1", inertia="shift",
                     samples=samples, time_scheme=time_scheme)
    n = st.ops.n
    R = scene.geometry.R
    ends = {}
    for s, r in runs.items():
        if r.get("mode") and r.get("celerity_m_s"):
            try:
                W, om, _ = D.start_from_run(Path(r["dir"]), st)
            except ValueError:
                continue
            ends[s] = (int(r["mode"]), W, om, bool(r.get("limit_cycle")))
    lc = [(s, e) for s, e in ends.items() if e[3]]
    bwd = next((e for s, e in sorted(lc, key=lambda x: x[0] != 4) if e[2] < 0), None)
    fwd = next((e for s, e in sorted(lc, key=lambda x: x[0] != 6) if e[2] > 0), None)
    with open(family_file(out, samples, time_scheme), "a") as fh:
        for k in range(1, kmax + 1):
            known: list = []
            starts = [(f"run seed {s}", W, om) for s, (m, W, om, _) in ends.items() if m == k]
            try:
                W, om, info = D.start_from_reduced(st, k)
                starts.append((info["start"], W, om))
            except Exception as err:  # noqa: BLE001 - a start that cannot be built is reported
                print(f"k={k}: no reduced start ({err})", flush=True)
            for name, src in (("shape bwd", bwd), ("shape fwd", fwd)):
                if src is not None and src[0] != k:
                    m, W, om, _ = src
                    starts.append((f"{name} (mode {m})", stretched(W, n, m, k), om * m / k))
            for label, W0, om0 in starts:
                rec = attempt(st, k, W0, om0, label, known, save=out / "waves")
                rec["scene"] = scene_name
                fh.write(json.dumps(rec) + "\n")
                fh.flush()
                c = rec.get("celerity_m_s")
                print(f"{scene_name} k={k} {label}: {rec['status']} "
                      f"{'' if c is None else f'{c:.1f} m/s'} start {om0 * R:.1f} "
                      f"({rec['cpu_s']:.1f} s CPU)", flush=True)


def _fmt_band(b: dict) -> str:
    lo, hi = b["celerity_m_s"]
    return (f"[{lo:.0f}, {hi:.0f}] m/s, ψ₁ {b['psi1'][0]:.2f}–{b['psi1'][1]:.2f}, "
            f"ψ₂ {b['psi2'][0]:.2f}–{b['psi2'][1]:.2f}, amplitude "
            f"{1e3 * b['amplitude_m'][0]:.2f}–{1e3 * b['amplitude_m'][1]:.2f} mm")


def seeded_runs(out: Path, scene: str, kmax: int) -> dict[int, dict]:
    """{seed: the transient's summary with its frame spread} for the seeds 1 … kmax in OUT."""
    from travel_mismatch import rigidity  # benchmarks/ (this script's folder)

    runs = {}
    for seed in range(1, kmax + 1):
        p = out / f"{scene}_seed{seed}" / "summary.json"
        if p.exists():
            runs[seed] = json.loads(p.read_text())
            rig = rigidity(p.parent)
            runs[seed]["spread"] = max(rig["frame_spread_u_r"], rig["frame_spread_u_theta"])
    return runs


def table(out: Path, kmax: int) -> str:
    """Markdown table: per scene and k, the transient from seed k and the waves found at k."""
    recs, seen = [], set()
    for line in (out / "family.jsonl").read_text().splitlines():
        r = json.loads(line)
        key = (r["scene"], r["k"], r["start"], r["status"], r.get("celerity_m_s"))
        if key not in seen:  # a rerun appends the same attempt again
            seen.add(key)
            recs.append(r)
    short = {"figure1_n132_damped": "Figure 1", "figure3_n132_damped": "Figure 3"}
    reg = {"stick-slip-separation": "SSS", "stick-slip": "SS", "slip-separation": "slip-sep",
           "steady-sliding": "sliding"}
    rows = ["| case | k | transient from a mode-k seed reaches: regime, k, c (m/s), amplitude "
            "(mm), ψ₁/ψ₂ | waves that exist at this k (travel, fixed ω): regime, direction, "
            "band of c, ψ₁/ψ₂ (sub-node) and amplitude over the band; found from | reached by "
            "the transient (seed) | scanned without finding a wave (m/s) |",
            "|---|---|---|---|---|---|"]
    for scene in SCENES:
        sub = [r for r in recs if r["scene"] == scene]
        if not sub:
            continue
        runs = seeded_runs(out, scene, kmax)
        for k in range(1, kmax + 1):
            a = runs.get(k, {})
            tr = (f"{reg.get(a.get('regime'), a.get('regime'))}, k = {a.get('mode')}, "
                  f"{a.get('celerity_m_s', float('nan')):.1f}, "
                  f"{1e3 * a.get('amplitude_m', float('nan')):.2f}, "
                  f"{a.get('psi1', float('nan')):.3f}/{a.get('psi2', float('nan')):.3f}"
                  + ("" if a.get("limit_cycle") else " (no limit cycle)")
                  + (f"; rigid wave (spread {100 * a['spread']:.1f} %)" if a["spread"] < RIGID
                     else f"; **not a rigid wave** (spread {100 * a['spread']:.0f} %)")
                  ) if a else "–"
            ks = [r for r in sub if r["k"] == k]
            bands: list[tuple[dict, list[str], dict]] = []
            for r in ks:
                if r["status"] != "converged":
                    continue
                hit = next((b for b in bands if b[0]["celerity_m_s"] == r["band"]["celerity_m_s"]),
                           None)
                if hit:
                    hit[1].append(r["start"])
                else:
                    bands.append((r["band"], [r["start"]], r))
            waves = "; ".join(
                f"{reg.get(r['regime'], r['regime'])}, "
                f"{DIRS.get(r['direction'], r['direction'])}, "
                f"{_fmt_band(b)} "
                f"(from {', '.join(fr)})" for b, fr, r in bands) or "none found"
            reached = []
            for s, a2 in runs.items():
                if a2.get("mode") != k or not a2.get("celerity_m_s"):
                    continue
                c = a2["celerity_m_s"]
                inb = [b for b, _, _ in bands
                       if b["celerity_m_s"][0] - 0.005 * abs(c) <= c
                       <= b["celerity_m_s"][1] + 0.005 * abs(c)]
                reached.append(f"seed {s}: {c:.0f}" + (" (in/within 0.5 % of a band)" if inb
                                                        else " (no band found there)"))
            fails = {f"[{lo:.0f}, {hi:.0f}]": lo for lo, hi in
                     (r["scanned_m_s"] for r in ks if r["status"] != "converged")}
            scanned = ", ".join(sorted(fails, key=fails.get)) or "–"
            rows.append(f"| {short[scene]} | {k} | {tr} | {waves} | "
                        f"{'; '.join(reached) or 'no'} | {scanned} |")
    return "\n".join(rows)


def central_table(out: Path, kmax: int, samples: int) -> str:
    """Markdown table of the central-scheme run (module doc): per scene and k, the transient
    from seed k, the waves the free-ω Newton found at k (roots within 0.5 % of each other
    merged into one cluster, with the number of distinct roots), and which seeds' transients
    end on mode k with their speed minus the nearest wave's."""

    recs = [json.loads(line) for line in
            family_file(out, samples, "central").read_text().splitlines()]
    short = {"figure1_n132_damped": "Figure 1", "figure3_n132_damped": "Figure 3"}
    reg = {"stick-slip-separation": "SSS", "stick-slip": "SS", "slip-separation": "slip-sep"}
    rows = ["| case | k | transient from a mode-k seed: regime, k, c (m/s), amplitude (mm); "
            f"frame spread | waves found at k (central scheme, S = {samples}): c (m/s), "
            "amplitude (mm), ψ₁/ψ₂; from | transients that end on mode k: seed, c − wave's c "
            "(m/s) | starts without a wave (start c, m/s) |", "|---|---|---|---|---|---|"]
    for scene in SCENES:
        sub = [r for r in recs if r.get("scene") == scene]
        if not sub:
            continue
        runs = seeded_runs(out, scene, kmax)
        for k in range(1, kmax + 1):
            a = runs.get(k)
            tr = "–" if a is None else (
                f"{reg.get(a['regime'], a['regime'])}, k = {a['mode']}, "
                f"{a['celerity_m_s']:.1f}, {1e3 * a['amplitude_m']:.2f}; "
                f"{100 * a['spread']:.1f} %" + ("" if a["spread"] < RIGID else " (not rigid)"))
            found = sorted((r for r in sub if r["k"] == k and r["status"] == "converged"),
                           key=lambda r: r["celerity_m_s"])
            clusters: list[list[dict]] = []
            for r in found:
                if clusters and abs(r["celerity_m_s"] - clusters[-1][0]["celerity_m_s"]) < (
                        0.005 * abs(r["celerity_m_s"])):
                    clusters[-1].append(r)
                else:
                    clusters.append([r])
            waves = []
            for cl in clusters:
                c = [r["celerity_m_s"] for r in cl]
                amp = [1e3 * r["amplitude_m"] for r in cl]
                roots = len({round(x, 2) for x in c})
                speed = f"{c[0]:.1f}" if roots == 1 else f"{min(c):.1f} … {max(c):.1f}"
                size = f"{amp[0]:.2f}" if roots == 1 else f"{min(amp):.2f} – {max(amp):.2f}"
                waves.append(f"{speed}, {size}, {cl[0]['psi1_subnode']:.3f}/"
                             f"{cl[0]['psi2_subnode']:.3f}"
                             + (f" ({roots} roots)" if roots > 1 else "")
                             + f"; from {', '.join(r['start'] for r in cl)}")
            ends = []
            for seed, a2 in runs.items():
                if a2.get("mode") == k and found:
                    near = min(found, key=lambda r: abs(r["celerity_m_s"] - a2["celerity_m_s"]))
                    ends.append(f"{seed}: {a2['celerity_m_s'] - near['celerity_m_s']:+.2f}")
                elif a2.get("mode") == k:
                    ends.append(f"{seed}: no wave")
            none = [f"{r['start']} ({r['start_celerity_m_s']:.0f})" for r in sub
                    if r["k"] == k and r["status"] != "converged"]
            rows.append(f"| {short[scene]} | {k} | {tr} | {'<br>'.join(waves) or 'none found'} "
                        f"| {'; '.join(ends) or '–'} | {'; '.join(none) or '–'} |")
    return "\n".join(rows)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--scene", nargs="*", default=list(SCENES))
    ap.add_argument("--dt-fraction", type=float, default=0.1125)
    ap.add_argument("--kmax", type=int, default=12)
    ap.add_argument("--samples", type=int, default=1)
    ap.add_argument("--time-scheme", choices=("exact", "central"), default="exact")
    ap.add_argument("--table", action="store_true", help="print the table from OUT and stop")
    a = ap.parse_args()
    if a.samples < 1:
        ap.error(f"--samples {a.samples}: give a whole number >= 1 of points per node")
    if a.table:
        print(central_table(a.out, a.kmax, a.samples) if a.time_scheme == "central"
              else table(a.out, a.kmax))
        return
    a.out.mkdir(parents=True, exist_ok=True)
    for scene in a.scene:
        runs = transients(a.out, scene, a.dt_fraction, a.kmax)
        existence(a.out, scene, runs, a.kmax, a.samples, a.time_scheme)


if __name__ == "__main__":
    sys.exit(main())
