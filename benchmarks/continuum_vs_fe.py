"""Tables of docs/continuum.md: exact continuum flutter against the FE CEA.

    ./dev python3 benchmarks/continuum_vs_fe.py PART [PART ...] [--out DIR] [--quick]

PART is one of

* ``halfspace``   threshold f_c(ν) and the growing root c/c_s per f (closed form);
* ``annulus``     exact growth against n (1..200) for f in {0.3, 0.7, 1.0, 1.5, 2.0},
                  ν = 0.3, ξ = 1.25, and the effect of the thickness ξ;
* ``fe``          flutter-fe (P1, lumped, f = 0.7) at N = 66, 132, 264, 528 against the exact
                  first three branches of n = 1..8 (errors, observed order, wall time);
* ``meshscale``   the fastest FE growth per k over the whole discrete spectrum for P1/P2,
                  triangles/quadrilaterals, lumped/consistent mass, against the exact
                  fastest growth of the same n;
* ``fespectrum``  P1 lumped FE, whole spectrum, f = 0.3, 0.5, 0.7, N = 36, 72, 132, undamped
                  and with Kelvin-Voigt damping, against the exact fastest growth;
* ``smoothing``   flutter-fe ``--friction 1-2-1`` (friction on filtered nodal reactions);
* ``dissipation`` exact growth against n with Kelvin-Voigt damping and linearised
                  Prakash-Clifton friction, below and above f_c.

Each part prints Markdown and writes ``DIR/PART.json`` (default DIR: /tmp/continuum_vs_fe).
Single core: BLAS threads pinned to 1. Material: the paper's (E = 1 GPa, sqrt(E/ρ) = 1000 m/s,
ν = 0.3, R = 1 m, ξ = 1.25).
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from stickslip.exact import halfspace  # noqa: E402
from stickslip.exact.annulus import Elastic  # noqa: E402
from stickslip.exact.sliding_flutter import Dissipation, sliding_branches  # noqa: E402

MAT = Elastic(E=1.0e9, rho=1000.0, nu=0.3, R=1.0, xi=1.25)
FS = (0.3, 0.7, 1.0, 1.5, 2.0)
NS = (1, 2, 4, 8, 16, 32, 64, 100, 150, 200)


def exact_growing(n: int, f: float, mat: Elastic = MAT, fmax_hz: float = 3000.0,
                  speed_factor: float = 0.0, diss: Dissipation | None = None) -> list[dict]:
    """Exact branches of order n, one per frequency pair: the member with the larger growth
    (what the FE CEA lists), sorted by frequency."""
    sp = sliding_branches(n, f, mat, fmax_hz=fmax_hz, speed_factor=speed_factor,
                          diss=diss or Dissipation())
    out: list[dict] = []
    for b in sp.branches:
        if out and abs(b.frequency_hz - out[-1]["frequency_hz"]) <= 1e-9 * b.frequency_hz:
            if b.growth_rate > out[-1]["growth_rate"]:
                out[-1] = b.to_dict()
            continue
        out.append(b.to_dict())
    return out


# ----------------------------------------------------------------------------------- parts


def part_halfspace(quick: bool) -> dict:
    rows = []
    print("| ν | f_c (bisection) | growing roots c/c_s at f = 1.5 | count (argument principle) |")
    print("|---|---|---|---|")
    for nu in (0.1, 0.2, 0.25, 0.3, 0.35, 0.4, 0.45):
        fc = halfspace.threshold(nu)
        r = halfspace.growing_roots(1.5, nu)
        cnt = halfspace.argument_principle_count(1.5, nu)
        rows.append({"nu": nu, "f_c": fc, "roots_f1.5": [[z.real, z.imag] for z in r],
                     "count_f1.5": cnt})
        print(f"| {nu} | {fc:.7f} | {', '.join(f'{z.real:+.4f}{z.imag:+.4f}i' for z in r)} "
              f"| {cnt} |")
    cs = MAT.cs
    print("\nν = 0.3: growing root per f (c in units of c_s; growth = k c_s Im c)")
    print("| f | c/c_s | c (m/s) | growth/n (1/s, R = 1 m) | roots by argument principle |")
    print("|---|---|---|---|---|")
    per_f = []
    for f in (0.3, 0.7, 0.9, 0.99, 1.0, 1.01, 1.03, 1.1, 1.5, 2.0, 3.0):
        r = halfspace.growing_roots(f, 0.3)
        cnt = halfspace.argument_principle_count(f, 0.3)
        z = r[0] if r.size else None
        per_f.append({"f": f, "c": None if z is None else [z.real, z.imag], "count": cnt})
        cell = "none" if z is None else f"{z.real:+.5f}{z.imag:+.5f}i"
        speed = "–" if z is None else f"{z.real * cs:+.1f}"
        g = "0" if z is None else f"{z.imag * cs / MAT.R:.2f}"
        print(f"| {f} | {cell} | {speed} | {g} | {cnt} |")
    return {"by_nu": rows, "nu0.3": per_f}


def part_annulus(quick: bool) -> dict:
    ns = NS[:6] if quick else NS
    res: dict = {"f": {}, "xi": {}}
    hs = {f: halfspace.growing_roots(f, MAT.nu) for f in FS}
    print("Exact annulus (ν = 0.3, ξ = 1.25): fastest growth over all branches with phase "
          "speed ≤ 1.5 c_p (1/s), its frequency (Hz) and direction; half-space growth k c_s "
          "Im c for comparison")
    print("| n | " + " | ".join(f"f = {f}" for f in FS) + " |")
    print("|---|" + "---|" * len(FS))
    for n in ns:
        cells = []
        for f in FS:
            t0 = time.perf_counter()
            br = exact_growing(n, f, fmax_hz=3000.0, speed_factor=1.5)
            best = max(br, key=lambda b: b["growth_rate"])
            res["f"].setdefault(str(f), []).append(
                {"n": n, "best": best, "branches": len(br), "wall_s": time.perf_counter() - t0})
            hsg = (hs[f][0].imag * MAT.cs * n / MAT.R) if hs[f].size else 0.0
            cells.append(f"{best['growth_rate']:.0f} @ {best['frequency_hz']:.0f} "
                         f"{best['direction'][:3]} (hs {hsg:.0f})")
        print(f"| {n} | " + " | ".join(cells) + " |")
    print("\nThickness: fastest growth at n = 100 and 200 against ξ")
    print("| ξ | f = 0.7, n = 100 | f = 0.7, n = 200 | f = 1.5, n = 100 | f = 1.5, n = 200 |")
    print("|---|---|---|---|---|")
    for xi in ((1.1, 1.25, 1.5) if quick else (1.1, 1.25, 1.5, 2.0)):
        mat = Elastic(E=MAT.E, rho=MAT.rho, nu=MAT.nu, R=MAT.R, xi=xi)
        cells = []
        for f in (0.7, 1.5):
            for n in (100, 200):
                best = max(exact_growing(n, f, mat, fmax_hz=3000.0, speed_factor=1.5),
                           key=lambda b: b["growth_rate"])
                res["xi"].setdefault(str(xi), []).append({"f": f, "n": n, "best": best})
                cells.append(f"{best['growth_rate']:.0f} @ {best['frequency_hz']:.0f}")
        print(f"| {xi} | " + " | ".join(cells) + " |")
    return res


def _fe_problem(N: int, overrides: list[str]):
    from mpi4py import MPI

    from stickslip.solver.problem import build_problem
    from stickslip.solver.scene import load_scene

    return build_problem(load_scene("figure3_n36", [f"mesh.n_inner={N}", *overrides]),
                         MPI.COMM_SELF)


def part_fe(quick: bool, out: Path) -> dict:
    from stickslip.studies.flutter_fe.cea import complex_eigenvalue_analysis, distinct_modes

    Ns = (66, 132) if quick else (66, 132, 264, 528)
    f, ks = 0.7, range(1, 9)
    exact = {k: exact_growing(k, f, fmax_hz=3200.0)[:3] for k in ks}
    cache = out / "fe_runs.json"
    runs = json.loads(cache.read_text()) if cache.exists() else {}
    for N in Ns:
        if str(N) in runs:
            continue
        t0 = time.perf_counter()
        problem = _fe_problem(N, [])
        res = complex_eigenvalue_analysis(problem, f, 3200.0)
        wall = time.perf_counter() - t0
        runs[str(N)] = {
            "free_dofs": res.n_free, "wall_s": wall,
            "branches": {str(k): [[m.frequency_hz, m.growth_rate, m.direction]
                                  for m in distinct_modes(x for x in res.modes
                                                          if x.wavenumber == k)[:3]]
                         for k in ks},
        }
        cache.write_text(json.dumps(runs, indent=1))
        print(f"N = {N}: {res.n_free} free dofs, {wall:.1f} s", flush=True)
    print("\nExact (f = 0.7): first three branches per n: frequency (Hz), growth (1/s), "
          "direction")
    for k in ks:
        print(f"n = {k}: " + "; ".join(f"{b['frequency_hz']:.2f} Hz, {b['growth_rate']:+.2f}, "
                                       f"{b['direction']}" for b in exact[k]))
    table = []
    print("\n| N | free dofs | wall (s) | max rel. freq. error | max growth error / ω | "
          "max rel. growth error (branches 2, 3) | direction mismatches |")
    print("|---|---|---|---|---|---|---|")
    for N in Ns:
        r = runs[str(N)]
        ef, eg, egr, mis = 0.0, 0.0, 0.0, 0
        per = []
        for k in ks:
            for j, (fr, g, d) in enumerate(r["branches"][str(k)]):
                ex = exact[k][j]
                w = 2 * math.pi * ex["frequency_hz"]
                e1 = abs(fr - ex["frequency_hz"]) / ex["frequency_hz"]
                e2 = abs(g - ex["growth_rate"]) / w
                e3 = abs(g - ex["growth_rate"]) / abs(ex["growth_rate"]) if j else 0.0
                ef, eg, egr = max(ef, e1), max(eg, e2), max(egr, e3)
                mis += d != ex["direction"]
                per.append({"k": k, "branch": j, "freq_err": e1, "growth_err_over_omega": e2,
                            "growth_rel_err": e3, "fe": [fr, g, d]})
        table.append({"N": N, "max_freq_err": ef, "max_growth_err_over_omega": eg,
                      "max_growth_rel_err_23": egr, "mismatch": mis, "per": per})
        print(f"| {N} | {r['free_dofs']} | {r['wall_s']:.1f} | {100 * ef:.3f} % | "
              f"{100 * eg:.3f} % | {100 * egr:.2f} % | {mis} |")
    for a, b in zip(table[:-1], table[1:], strict=False):
        order = math.log(a["max_freq_err"] / b["max_freq_err"]) / math.log(b["N"] / a["N"])
        og = math.log(a["max_growth_err_over_omega"] / b["max_growth_err_over_omega"]) \
            / math.log(b["N"] / a["N"])
        print(f"observed order {a['N']} -> {b['N']}: frequency {order:.2f}, growth {og:.2f}")
    print("\nPer branch at the finest N (freq err %, growth: FE vs exact):")
    last = table[-1]
    for p in last["per"]:
        ex = exact[p["k"]][p["branch"]]
        print(f"n = {p['k']} branch {p['branch'] + 1}: {ex['frequency_hz']:.1f} Hz "
              f"{ex['growth_rate']:+.1f} /s {ex['direction']} | FE {p['fe'][0]:.1f} Hz "
              f"{p['fe'][1]:+.1f} /s {p['fe'][2]} | df {100 * p['freq_err']:.3f} %")
    return {"exact": exact, "runs": runs, "table": table}


VARIANTS = {
    "P1 tri lumped": ([], "lumped"),
    "P1 tri consistent": ([], "consistent"),
    "Q1 quad lumped": (['mesh.cell="quadrilateral"'], "lumped"),
    "P2 tri lumped": (["mesh.degree=2"], "lumped"),
    "P2 tri consistent": (["mesh.degree=2"], "consistent"),
    "Q2 quad lumped": (['mesh.cell="quadrilateral"', "mesh.degree=2"], "lumped"),
}


def part_meshscale(quick: bool, out: Path, f: float = 0.7) -> dict:
    from stickslip.studies.flutter_fe.cea import build_operators, complex_eigenvalue_analysis

    Ns = (36, 72) if quick else (36, 72, 132)
    cache = out / f"meshscale_f{f}.json"
    runs = json.loads(cache.read_text()) if cache.exists() else {}
    for name, (ov, mass) in VARIANTS.items():
        for N in Ns:
            key = f"{name} N={N}"
            if key in runs:
                continue
            t0 = time.perf_counter()
            problem = _fe_problem(N, ov)
            ops = build_operators(problem, mass)
            fmax = 1.3 * math.sqrt(_max_omega2(ops)) / (2 * math.pi)  # whole spectrum
            res = complex_eigenvalue_analysis(problem, f, fmax, ops=ops)
            ops.destroy()
            best = res.by_wavenumber()
            top = res.unstable()[0] if res.unstable() else None
            runs[key] = {
                "free_dofs": res.n_free, "fmax_hz": fmax, "wall_s": time.perf_counter() - t0,
                "max": None if top is None else [top.growth_rate, top.frequency_hz,
                                                 top.wavenumber, top.direction],
                "per_k": {str(k): [m.growth_rate, m.frequency_hz, m.direction]
                          for k, m in best.items()},
            }
            cache.write_text(json.dumps(runs, indent=1))
            print(f"{key}: {res.n_free} dofs, band {fmax:.0f} Hz, max growth "
                  f"{runs[key]['max']}, {runs[key]['wall_s']:.1f} s", flush=True)
    print(f"\nf = {f}: fastest growth over the whole discrete spectrum (1/s) @ k")
    print("| variant | " + " | ".join(f"N = {N}" for N in Ns) + " |")
    print("|---|" + "---|" * len(Ns))
    for name in VARIANTS:
        cells = []
        for N in Ns:
            m = runs.get(f"{name} N={N}", {}).get("max")
            cells.append("–" if m is None else f"{m[0]:.0f} @ k = {m[2]} ({m[1]:.0f} Hz)")
        print(f"| {name} | " + " | ".join(cells) + " |")
    return runs


def _max_omega2(ops) -> float:
    """Largest eigenvalue of the f = 0 pencil (power iteration on B⁻¹A, 200 steps)."""
    from slepc4py import SLEPc

    eps = SLEPc.EPS().create(ops.Kt.getComm())
    eps.setOperators(ops.Kt, ops.B)
    eps.setProblemType(SLEPc.EPS.ProblemType.GHEP if ops.mass_kind == "lumped"
                       else SLEPc.EPS.ProblemType.GNHEP)
    eps.setWhichEigenpairs(SLEPc.EPS.Which.LARGEST_MAGNITUDE)
    eps.setDimensions(1)
    eps.setTolerances(1e-8, 2000)
    eps.solve()
    val = eps.getEigenvalue(0).real
    eps.destroy()
    return float(val)


def _kv_map(mu: complex, tau: float) -> complex:
    """Kelvin-Voigt (stiffness-proportional, also in the contact reaction) of an undamped
    eigenvalue μ = ω² (e^{−iωt}): ``ω² + iτμω − μ = 0``, the root with Re ω > 0."""
    disc = complex(-(tau * mu) ** 2 + 4 * mu) ** 0.5
    roots = ((-1j * tau * mu + disc) / 2, (-1j * tau * mu - disc) / 2)
    return max(roots, key=lambda w: w.real)


TAUS = (0.0, 1e-6, 2e-6)


def part_fespectrum(quick: bool, out: Path) -> dict:
    """P1 lumped CEA over the whole discrete spectrum for f = 0.3, 0.5, 0.7 and N = 36, 72,
    132: fastest growth undamped and with Kelvin-Voigt τ (mapped eigenvalue by eigenvalue:
    K → K(1 − iωτ) also in the nodal reactions), against the exact fastest growth over n."""
    from stickslip.studies.flutter_fe.cea import build_operators, complex_eigenvalue_analysis

    Ns = (36, 72) if quick else (36, 72, 132)
    fs = (0.3, 0.5, 0.7)
    cache = out / "fespectrum.json"
    runs = json.loads(cache.read_text()) if cache.exists() else {}
    for N in Ns:
        problem = None
        for f in fs:
            key = f"f={f} N={N}"
            if key in runs:
                continue
            t0 = time.perf_counter()
            problem = problem or _fe_problem(N, [])
            ops = build_operators(problem, "lumped")
            fmax = 1.3 * math.sqrt(_max_omega2(ops)) / (2 * math.pi)
            res = complex_eigenvalue_analysis(problem, f, fmax, ops=ops)
            ops.destroy()
            runs[key] = {"wall_s": time.perf_counter() - t0, "fmax_hz": fmax,
                         "modes": [[m.omega2_real, m.omega2_imag, m.wavenumber]
                                   for m in res.modes]}
            cache.write_text(json.dumps(runs))
            print(f"{key}: {len(res.modes)} modes, {runs[key]['wall_s']:.1f} s", flush=True)
    table: dict = {}
    for f in fs:
        ex = {}
        for tau in TAUS:
            diss = Dissipation(tau=tau)
            best = 0.0
            for n in (1, 2, 4, 7, 10, 15, 20, 30, 40, 50, 66):
                br = exact_growing(n, f, fmax_hz=20000.0, diss=diss)
                best = max(best, max((b["growth_rate"] for b in br), default=0.0))
            ex[tau] = best
        for N in Ns:
            modes = runs[f"f={f} N={N}"]["modes"]
            row = {}
            for tau in TAUS:
                g, kk = -math.inf, 0
                for re, im, k in modes:
                    for mu in (complex(re, im), complex(re, -im)):
                        w = _kv_map(mu, tau) if tau else complex(mu) ** 0.5
                        gr = abs(w.imag) if not tau else w.imag
                        if gr > g:
                            g, kk = gr, k
                row[str(tau)] = [g, kk]
            table[f"f={f} N={N}"] = row
        table[f"f={f} exact"] = {str(t): ex[t] for t in TAUS}
    print("\nFastest growth over the whole spectrum (1/s) @ k: P1 lumped FE vs exact sup over n "
          "(n = 1..66, ≤ 20 kHz); Kelvin-Voigt τ applied to both")
    print("| f | τ (s) | " + " | ".join(f"FE N = {N}" for N in Ns) + " | exact sup |")
    print("|---|---|" + "---|" * (len(Ns) + 1))
    for f in fs:
        for tau in TAUS:
            cells = [f"{table[f'f={f} N={N}'][str(tau)][0]:.0f} @ k = "
                     f"{table[f'f={f} N={N}'][str(tau)][1]}" for N in Ns]
            print(f"| {f} | {tau:g} | " + " | ".join(cells)
                  + f" | {table[f'f={f} exact'][str(tau)]:.0f} |")
    return table


def part_smoothing(quick: bool, out: Path) -> dict:
    """P1 lumped with the 1-2-1 smoothed friction: fastest growth over the whole spectrum and
    the first three branches of n = 2, 4, 7 against the exact, f = 0.7."""
    from stickslip.studies.flutter_fe.cea import (
        build_operators,
        complex_eigenvalue_analysis,
        distinct_modes,
    )

    Ns = (36, 72) if quick else (36, 72, 132, 264)
    cache = out / "smoothing.json"
    runs = json.loads(cache.read_text()) if cache.exists() else {}
    for N in Ns:
        for name in ("nodal", "1-2-1"):
            key = f"{name} N={N}"
            if key in runs or (name == "nodal" and N == 264):
                continue
            t0 = time.perf_counter()
            problem = _fe_problem(N, [])
            ops = build_operators(problem, "lumped", name)
            fmax = 1.3 * math.sqrt(_max_omega2(ops)) / (2 * math.pi)
            if N == 264:
                fmax = 12000.0  # the whole spectrum costs too long; the k ≈ 0.3 N band
            res = complex_eigenvalue_analysis(problem, 0.7, fmax, ops=ops)
            ops.destroy()
            top = res.unstable()[0]
            runs[key] = {
                "wall_s": time.perf_counter() - t0, "fmax_hz": fmax,
                "max": [top.growth_rate, top.frequency_hz, top.wavenumber],
                "branches": {str(k): [[m.frequency_hz, m.growth_rate, m.direction] for m in
                                      distinct_modes(x for x in res.modes if x.wavenumber == k)[:3]]
                             for k in (2, 4, 7)},
            }
            cache.write_text(json.dumps(runs))
            print(f"{key}: max {runs[key]['max']}, {runs[key]['wall_s']:.1f} s", flush=True)
    exact = {k: exact_growing(k, 0.7, fmax_hz=3200.0)[:3] for k in (2, 4, 7)}
    print("\n| friction law | N | fastest growth (1/s) @ k (Hz) | max freq. error n = 2, 4, 7 "
          "| max growth error / ω |")
    print("|---|---|---|---|---|")
    for key, r in runs.items():
        ef = max(abs(b[0] - e["frequency_hz"]) / e["frequency_hz"] for k in (2, 4, 7)
                 for b, e in zip(r["branches"][str(k)], exact[k], strict=True))
        eg = max(abs(b[1] - e["growth_rate"]) / (2 * math.pi * e["frequency_hz"])
                 for k in (2, 4, 7) for b, e in zip(r["branches"][str(k)], exact[k], strict=True))
        name, N = key.split(" N=")
        band = f" (band ≤ {r['fmax_hz']:.0f} Hz)" if N == "264" else ""
        print(f"| {name} | {N} | {r['max'][0]:.0f} @ k = {r['max'][2]} ({r['max'][1]:.0f} Hz)"
              f"{band} | {100 * ef:.2f} % | {100 * eg:.3f} % |")
    return runs


def part_dissipation(quick: bool) -> dict:
    ns = (1, 4, 8, 16, 32, 64) if quick else (1, 4, 8, 16, 32, 64, 100, 200)
    cases = {
        "elastic": Dissipation(),
        "KV eta=0.02 @ 1.6 kHz": Dissipation(tau=Dissipation.from_loss_factor(0.02, 1600.0)),
        "KV tau=2e-6 s": Dissipation(tau=2e-6),
        "PC L=1e-5 m, V*=0 (t*=2e-7 s)": Dissipation(
            t_star=Dissipation.prakash_clifton_time(1e-5, 50.0, 0.0)),
        "PC L=1e-4 m (t*=2e-6 s)": Dissipation(
            t_star=Dissipation.prakash_clifton_time(1e-4, 50.0, 0.0)),
        "constant time t*=1e-5 s": Dissipation(t_star=1e-5),
    }
    res: dict = {}
    for f in (0.7, 1.5):
        print(f"\nf = {f}: fastest growth (1/s) @ frequency (Hz), branches with phase speed "
              "≤ 1.5 c_p")
        print("| case | " + " | ".join(f"n = {n}" for n in ns) + " |")
        print("|---|" + "---|" * len(ns))
        for name, diss in cases.items():
            cells = []
            for n in ns:
                br = exact_growing(n, f, fmax_hz=3000.0, speed_factor=1.5, diss=diss)
                best = max(br, key=lambda b: b["growth_rate"])
                res.setdefault(str(f), {}).setdefault(name, []).append({"n": n, "best": best})
                cells.append(f"{best['growth_rate']:.0f} @ {best['frequency_hz']:.0f}")
            print(f"| {name} | " + " | ".join(cells) + " |", flush=True)
    return res


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("parts", nargs="+",
                   choices=("halfspace", "annulus", "fe", "meshscale", "fespectrum",
                            "smoothing", "dissipation"))
    p.add_argument("--out", default="/tmp/continuum_vs_fe")
    p.add_argument("--quick", action="store_true", help="fewer n / N (a smoke run)")
    p.add_argument("--f", type=float, default=0.7, help="friction of the meshscale part")
    args = p.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for part in args.parts:
        t0 = time.perf_counter()
        print(f"\n## {part}\n", flush=True)
        if part == "halfspace":
            data = part_halfspace(args.quick)
        elif part == "annulus":
            data = part_annulus(args.quick)
        elif part == "fe":
            data = part_fe(args.quick, out)
        elif part == "meshscale":
            data = part_meshscale(args.quick, out, args.f)
        elif part == "fespectrum":
            data = part_fespectrum(args.quick, out)
        elif part == "smoothing":
            data = part_smoothing(args.quick, out)
        else:
            data = part_dissipation(args.quick)
        name = part if part != "meshscale" else f"meshscale_f{args.f}_table"
        (out / f"{name}.json").write_text(json.dumps(data, indent=1, default=str))
        print(f"\n({part}: {time.perf_counter() - t0:.1f} s wall)", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
