"""Measurements of the reduced transient model (studies/reduced_transient.py) for
docs/reduced_transient.md.

Usage: ``python3 benchmarks/reduced_transient.py [--quick] [-o out.json]`` (one core, ~1 min).

1. Start on the admissible semi-analytical stick-slip waves (Figure-1 parameters, k = 4; the
   paper's k = 8 example), run ``PERIODS`` wave periods at fixed CFL, refine N (Δt ∝ Δθ),
   print errors (celerity, zone fractions, co-moving profile, junction timing) and observed
   orders, for β2 = 0.5 and 0.6, and with the naive (inconsistent) Newmark start.
2. Start from steady sliding + a mode-k bump or a random seed and report the selected wave.
"""

from __future__ import annotations

import argparse
import json
import time
from typing import Any

import numpy as np

from stickslip.semianalytic import coefficients, gamma_from_physical, stick_slip_waves
from stickslip.studies.reduced_transient import (
    ReducedModel,
    junction_phases,
    observed_order,
    record_summary,
    start_from_wave,
    steady_start,
    wave_errors,
    wave_fields,
)

CASES = {
    "figure1": {"nu": 0.3, "xi": 1.25, "f": 0.7, "k": 4, "delta": 0.001, "omega": 40.0},
    "k8_example": {"nu": 0.3, "xi": 1.25, "f": 1.0, "k": 8, "delta": 0.005, "omega": 100.0},
}
PERIODS = 5


def admissible_wave(case: dict[str, Any], k: int | None = None) -> Any:
    co = coefficients(case["nu"], case["xi"], gamma_from_physical(1000.0, 1.0, case["omega"]))
    ws = stick_slip_waves(co, case["f"], k or case["k"], case["delta"])
    return co, next(w for w in ws if w.admissible)


def convergence(name: str, ns: list[int], beta2: float, consistent: bool = True) -> list[dict]:
    case = CASES[name]
    co, w = admissible_wave(case)
    tau = w.period / abs(w.c)
    rows = []
    for n in ns:
        m = ReducedModel(co, case["f"], case["delta"], n, beta2=beta2, cfl=0.9)
        if consistent:
            start_from_wave(m, w)
        else:  # Newmark.set_state alone: predictor v0 (no -beta2 dt a0)
            ev = wave_fields(w, m.theta)
            m.set_state(ev["U"], ev["V"], -w.c * ev["dU"], -w.c * ev["dV"])
        t0 = time.perf_counter()
        rec = m.run(PERIODS * tau, 400)
        wall = time.perf_counter() - t0
        e = wave_errors(rec, w)
        ph = junction_phases(rec, w)
        on, rel = ph["onset"], ph["release"]
        spurious = int(np.count_nonzero(np.abs(on - w.psi1) > 0.03))
        rows.append({
            "n": n, "dt": m.dt, "steps": rec.steps, "wall_s": wall, **e,
            "onset_median_abs": float(np.median(np.abs(on - w.psi1))),
            "release_mean": float(np.mean(rel - w.psi2)),
            "release_std": float(np.std(rel - w.psi2)),
            "spurious_sticks": spurious,
        })
    return rows


def orders(rows: list[dict], key: str) -> list[float]:
    h = np.array([1.0 / r["n"] for r in rows])
    return [float(x) for x in observed_order(h, np.array([r[key] for r in rows]))]


def selection(n: int, beta2: float, t_end: float, *, k: int | None, seed: int | None) -> dict:
    case = CASES["figure1"]
    co = coefficients(case["nu"], case["xi"], gamma_from_physical(1000.0, 1.0, case["omega"]))
    m = ReducedModel(co, case["f"], case["delta"], n, beta2=beta2, cfl=0.9)
    steady_start(m, 1e-3, k=k, seed=seed)
    t0 = time.perf_counter()
    rec = m.run(t_end, 2000)
    s = record_summary(rec, m, 1.0)
    s.update({"n": n, "beta2": beta2, "bump_k": k, "seed": seed,
              "wall_s": time.perf_counter() - t0})
    return s


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("-o", "--output", default=None)
    args = ap.parse_args()
    ns = [256, 512, 1024] if args.quick else [256, 512, 1024, 2048, 4096]
    out: dict[str, Any] = {"convergence": {}, "selection": []}
    for name, beta2, cons in [("figure1", 0.5, True), ("figure1", 0.6, True),
                              ("figure1", 0.5, False), ("k8_example", 0.5, True)]:
        key = f"{name} beta2={beta2}" + ("" if cons else " naive-start")
        rows = convergence(name, ns, beta2, cons)
        out["convergence"][key] = rows
        print(f"\n## {key}")
        print("N | steps | celerity | fractions | profile | shape | onset |rel mean| rel std "
              "| spurious | frac stick")
        for r in rows:
            print(f"{r['n']} | {r['steps']} | {r['celerity']:.2e} | {r['fractions']:.2e} | "
                  f"{r['profile']:.2e} | {r['shape']:.2e} | {r['onset_median_abs']:.2e} | "
                  f"{r['release_mean']:+.2e} | {r['release_std']:.2e} | "
                  f"{r['spurious_sticks']} | {r['frac_stick']:.4f}")
        for k in ("celerity", "fractions", "profile", "shape", "onset_median_abs"):
            print(f"  order {k}: {np.round(orders(rows, k), 2).tolist()}")
    for n in ([256] if args.quick else [256, 512]):
        for beta2 in (0.5, 0.6):
            for k, seed in ((4, None), (None, 1), (None, 2)):
                s = selection(n, beta2, 20.0, k=k, seed=seed)
                out["selection"].append(s)
                print(json.dumps(s, default=float))
    if args.output:
        with open(args.output, "w") as fh:
            json.dump(out, fh, indent=1, default=float)


if __name__ == "__main__":
    main()
