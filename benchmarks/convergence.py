"""Convergence study of the FE limit cycle: regenerates archive/convergence_report.md (the
full tables; docs/convergence.md summarises them).

    ./dev python3 benchmarks/convergence.py [--quick] [--results FILE] [--report-only]
                                            [--max-n N] [--only SUBSTRING] [--budget S]

Runs (each in its own process, one core, results appended to a JSON-lines file, so the study is
resumable: finished cases are skipped) in priority order:

1. Figure 3 (Omega = 50, delta = 4e-4, f = 0.7), mode-4 seed, undamped and damped, N = 66 ...
   1056 at dt = 0.9 dt_crit (the damped limit when damped), beta2 = 1/2;
   1b. the same undamped with the 1-2-1 filtered friction bound (``[friction] filter``,
   docs/friction_filter.md), mode-4 seed and random seeds, N = 66 ... 528, mode-4 at 1056
   (``--only f121``);
2. the same at N = 264 with dt halved twice;
3. random seeds 1, 2, 3 over N;
4. Figure 1 (Omega = 40, delta = 1e-3, f = 0.7), the same list;
5. beta2 = 0.6 and 0.9 on the fine meshes (Figure 3 at N = 264, 528; Figure 1 damped at
   N = 264, 528, 1056).

Then writes the report (tables, observed orders, Richardson extrapolation, plot). ``--quick``
keeps N <= 264, one random seed and Figure 3 only (a few minutes).

Measured per run, over the last ``WINDOW`` seconds of ``END_TIME``:
* frequency f: FFT peak (parabolic refinement) of the every-step probe history at theta = 0
  (u_r - d when the tube separates, else u_theta): a property of the time signal, independent
  of which wavenumber carries it;
* zone fractions (node-samples), psi1, psi2, k, celerity (postprocess.analysis.analyse);
* amplitude: RMS of u_r - d over all contact nodes and the samples of the last whole number of
  periods 1/f (a mean, so it can converge; a maximum over a window need not);
* stationarity: the same quantities over the two halves of the window; their difference is the
  time-averaging uncertainty carried into the error bars.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

from stickslip.studies.convergence import (  # noqa: E402
    END_TIME,
    ETA_DAMPED,
    F_REF_HZ,
    NS,
    WINDOW,
    case_key,
    richardson,
    run_case,
)

REPO = Path(__file__).resolve().parents[1]
DEFAULT_RESULTS = REPO / "archive" / "convergence_runs.jsonl"


# ---------------------------------------------------------------------------------------------
# The run list


def run_list(quick: bool, max_n: int) -> list[dict]:
    """Cases in priority order (see module docstring)."""
    ns = [n for n in NS if n <= (264 if quick else max_n)]
    seeds = ["random1"] if quick else ["random1", "random2", "random3"]
    physics = ["fig3"] if quick else ["fig3", "fig1"]
    out: list[dict] = []

    def add(phys, damped, n, seed, beta2=0.5, frac=0.9, filt="nodal"):
        c = dict(phys=phys, damped=damped, n=n, seed=seed, beta2=beta2, frac=frac, filter=filt)
        c["key"] = case_key(phys, damped, n, seed, beta2, frac, filt)
        if c["key"] not in {o["key"] for o in out}:
            out.append(c)

    small = [n for n in ns if n <= 264]
    both = (True, False)  # damped first: the physically motivated series
    for n in ns:  # 1. Figure 3, mode-4 seed over N
        for damped in both:
            add("fig3", damped, n, "mode4") if n <= 528 else None
    for seed in ["mode4", *seeds]:  # 1b. the 1-2-1 filtered bound, undamped
        for n in [n for n in ns if n <= 528]:
            add("fig3", False, n, seed, filt="1-2-1")
    if 1056 in ns:
        add("fig3", False, 1056, "mode4", filt="1-2-1")
    for frac in (0.45, 0.225):  # 2. dt halved twice at N = 264
        for damped in both:
            add("fig3", damped, 264, "mode4", frac=frac) if 264 in ns else None
    for damped in both:  # 3. random seeds, N <= 264
        for seed in seeds:
            for n in small:
                add("fig3", damped, n, seed)
    if not quick:
        for damped in both:  # 4. Figure 1, mode-4 seed; 5. beta2 on a fine mesh
            for n in small:
                add("fig1", damped, n, "mode4")
        for n_b in (small[-1], 528):  # 264 first; 528 when the list reaches it
            for beta2 in (0.6, 0.9):
                for damped in both:
                    if n_b in ns:
                        add("fig3", damped, n_b, "mode4", beta2=beta2)
        for n_b in (264, 528, 1056):  # 5b. beta2 on the Figure-1 k = 4 member (damped)
            for beta2 in (0.6, 0.9):
                if n_b in ns:
                    add("fig1", True, n_b, "mode4", beta2=beta2)
        for damped in both:  # 6. Figure 1 seeds
            for seed in seeds:
                for n in small:
                    add("fig1", damped, n, seed)
    for phys in physics:  # 7. what is left on the fine meshes
        for n in ns:
            if n <= 264:
                continue
            for seed in ["mode4", *seeds]:
                for damped in both:
                    add(phys, damped, n, seed)
    return out


# ---------------------------------------------------------------------------------------------
# Report


QUANTS = [("frequency_hz", "f (Hz)", 1.0), ("sep", "sep", 1.0), ("stick", "stick", 1.0),
          ("slip", "slip", 1.0), ("psi1", "psi1", 1.0), ("psi2", "psi2", 1.0),
          ("amp_rms_m", "RMS(u_r - d) (um)", 1e6)]


def load_results(path: Path) -> dict[str, dict]:
    out = {}
    if path.exists():
        for line in path.read_text().splitlines():
            if line.strip():
                r = json.loads(line)
                out[r["key"]] = r
    return out


def fmt(x, scale=1.0, digits=4):
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-"
    return f"{x * scale:.{digits}g}"


def series_table(res, phys, damped, seed, ns, filt="nodal"):
    rows = []
    head = ("| N | dofs | dt (us) | dt/dt_crit | k | c (m/s) | f (Hz) | sep / stick / slip | "
            "psi1 | psi2 | RMS(u_r-d) (um) | LC | drift f / sep | wall (s) |")
    rows += [head, "|" + "---|" * 14]
    for n in ns:
        r = res.get(case_key(phys, damped, n, seed, filt=filt))
        if r is None:
            rows.append(f"| {n} | not run | | | | | | | | | | | | |")
            continue
        rows.append(
            f"| {n} | {r['dofs']} | {r['dt_s'] * 1e6:.3g} | {r['frac']} | {r['k']} | "
            f"{r['celerity_m_s']:+.0f} | {r['frequency_hz']:.1f} | {r['sep']:.3f} / "
            f"{r['stick']:.3f} / {r['slip']:.3f} | {r['psi1']:.3f} | {r['psi2']:.3f} | "
            f"{r['amp_rms_m'] * 1e6:.3f} | {'y' if r['limit_cycle'] else 'n'} | "
            f"{abs(r['h1']['frequency_hz'] - r['h2']['frequency_hz']):.1f} / "
            f"{abs(r['h1']['sep'] - r['h2']['sep']):.3f} | {r['wall_s']:.0f} |")
    return rows


def convergence_rows(res, phys, damped, seed, ns, filt="nodal"):
    have = [n for n in ns if case_key(phys, damped, n, seed, filt=filt) in res]
    rs = [res[case_key(phys, damped, n, seed, filt=filt)] for n in have]
    rows = []
    if len({(r["k"], r["celerity_m_s"] > 0) for r in rs[-3:]}) > 1:
        ks = ", ".join(f"{r['k']}{'+' if r['celerity_m_s'] > 0 else '-'}" for r in rs)
        return [f"| all | the selected member changes with N (k = {ks}): no order, no "
                "extrapolation | - | - | - |"]
    for q, label, scale in QUANTS:
        qs = [r[q] for r in rs]
        noise = abs(rs[-1]["h1"][q] - rs[-1]["h2"][q]) if rs else 0.0
        rich = richardson(have, qs, noise)
        diffs = " / ".join(fmt(abs(a - b), scale, 3) for a, b in zip(qs, qs[1:], strict=False))
        if rich is None:
            rows.append(f"| {label} | {diffs} | - | - | - |")
            continue
        if rich["order"] is not None and rich["order"] < 0.5:  # too slow to extrapolate
            rows.append(f"| {label} | {diffs} | {rich['order']:.2f} (too slow to "
                        f"extrapolate) | - | - |")
            continue
        order = "none (not monotone)" if rich["order"] is None else f"{rich['order']:.2f}"
        rows.append(f"| {label} | {diffs} | {order} | {fmt(rich['value'], scale)} | "
                    f"+- {fmt(rich['err'], scale, 2)} |")
    return rows


def accuracy_rows(res, ns) -> list[str]:
    """Error against wall time for the damped Figure-3 mode-4 runs (k = 12 branch), against
    the finest run; the cheapest run within 1 %, 5 %, 20 % (frequency, RMS amplitude) and
    0.01, 0.05, 0.2 (fractions, absolute)."""
    rows = [r for k, r in res.items() if k.startswith("fig3-eta2-") and "-mode4-b0.5-" in k]
    if len(rows) < 2:
        return []
    ref = max(rows, key=lambda r: (r["n"], -r["frac"]))
    out = ["", f"## Error against run time (fig3, eta = 2 %, mode-4 seed; reference: N = "
           f"{ref['n']}, dt = {ref['frac']} dt_crit)", "",
           "| N | dt/dt_crit | k | wall (s) | err f | err sep | err stick | err slip | "
           "err RMS |", "|---|---|---|---|---|---|---|---|---|"]
    errs = []
    for r in sorted(rows, key=lambda r: r["wall_s"]):
        if r is ref:
            continue
        e = dict(f=abs(r["frequency_hz"] / ref["frequency_hz"] - 1),
                 fr=max(abs(r[z] - ref[z]) for z in ("sep", "stick", "slip")),
                 a=abs(r["amp_rms_m"] / ref["amp_rms_m"] - 1))
        errs.append((r, e))
        out.append(f"| {r['n']} | {r['frac']} | {r['k']} | {r['wall_s']:.0f} | "
                   f"{e['f']:.2%} | {abs(r['sep'] - ref['sep']):.3f} | "
                   f"{abs(r['stick'] - ref['stick']):.3f} | {abs(r['slip'] - ref['slip']):.3f} | "
                   f"{e['a']:.1%} |")
    out += ["", "| target | cheapest for f | cheapest for fractions (abs.) | cheapest for RMS |",
            "|---|---|---|---|"]
    for tol in (0.01, 0.05, 0.2):
        cells = []
        for q in ("f", "fr", "a"):
            ok = [r for r, e in errs if e[q] <= tol]
            cells.append(f"N = {ok[0]['n']}, {ok[0]['frac']} dt_crit ({ok[0]['wall_s']:.0f} s)"
                         if ok else "not reached below the reference")
        out.append(f"| {tol:g} | " + " | ".join(cells) + " |")
    return out


def plot(res, path: Path, ns):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
    for phys, marker in (("fig3", "o"), ("fig1", "s")):
        for damped, ls in ((False, "-"), (True, "--")):
            for seed, color in (("mode4", "C0"), ("random1", "C1"), ("random2", "C2"),
                                ("random3", "C3")):
                pts = [(n, res[k]) for n in ns
                       if (k := case_key(phys, damped, n, seed)) in res]
                if len(pts) < 2:
                    continue
                x = [p[0] for p in pts]
                lab = f"{phys} {'eta=2%' if damped else 'undamped'} {seed}"
                axes[0].plot(x, [p[1]["frequency_hz"] for p in pts], ls, marker=marker,
                             color=color, label=lab, ms=4)
                axes[1].plot(x, [p[1]["sep"] for p in pts], ls, marker=marker, color=color,
                             ms=4)
                axes[1].plot(x, [p[1]["stick"] for p in pts], ls, marker=marker, color=color,
                             ms=4, alpha=0.5)
                axes[2].plot(x, [p[1]["amp_rms_m"] * 1e6 for p in pts], ls, marker=marker,
                             color=color, ms=4)
    for ax, title in zip(axes, ("frequency (Hz)", "separation (solid) and stick fractions",
                                "RMS(u_r - d) (um)"), strict=True):
        ax.set_xscale("log", base=2)
        ax.set_xlabel("N (contact nodes)")
        ax.set_title(title, fontsize=10)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=6, ncol=1)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _rel(path: Path) -> Path:
    return path.relative_to(REPO) if path.is_relative_to(REPO) else path


def _series():
    """(physics, damped, seed, friction filter) of the per-seed sections, in report order."""
    return [(p, d, s, f) for p in ("fig3", "fig1") for d in (False, True)
            for f in ("nodal", "1-2-1") for s in ("mode4", "random1", "random2", "random3")]


def report(res: dict, out: Path, quick: bool, results_path: Path) -> None:
    ns = [n for n in NS if not quick or n <= 264]
    lines = ["# Convergence of the FE limit cycle", "",
             "Generated by `./dev python3 benchmarks/convergence.py"
             + (" --quick" if quick else "") + f"` from `{_rel(results_path)}`"
             " (one JSON line per run; the command resumes and skips finished runs).", "",
             f"Setting: explicit Newmark, beta2 = 1/2 (no algorithmic damping), dt = 0.9 dt_crit "
             f"(the damped limit when damped), P1 triangles, automatic radial layers, "
             f"end time {END_TIME} s, quantities over the last {WINDOW} s. "
             f"Damped series: Kelvin-Voigt loss factor eta = {ETA_DAMPED:g} at {F_REF_HZ:g} Hz "
             f"(tau = {ETA_DAMPED / (2 * math.pi * F_REF_HZ) * 1e6:.3g} us), the order of a "
             "lightly damped polymer at the wave frequency. Wall times: one core of a shared "
             "2-core machine (noisy).", ""]
    for phys, damped, seed, filt in _series():
        if not any(case_key(phys, damped, n, seed, filt=filt) in res for n in ns):
            continue
        lines += [f"## {phys}, {'eta = 2 %' if damped else 'undamped'}, seed {seed}"
                  + ("" if filt == "nodal" else f", friction filter {filt}"), ""]
        lines += series_table(res, phys, damped, seed, ns, filt)
        lines += ["", "| quantity | successive differences | observed order | "
                      "Richardson value | error bar |", "|---|---|---|---|---|"]
        lines += convergence_rows(res, phys, damped, seed, ns, filt)
        lines += [""]
    # dt refinement
    lines += ["## Time-step refinement at N = 264 (mode-4 seed)", "",
              "| physics | damping | dt/dt_crit | k | f (Hz) | sep / stick / slip | psi1 | psi2 |"
              " RMS (um) | wall (s) |", "|---|---|---|---|---|---|---|---|---|---|"]
    for phys in ("fig3", "fig1"):
        for damped in (False, True):
            for frac in (0.9, 0.45, 0.225):
                r = res.get(case_key(phys, damped, 264, "mode4", frac=frac))
                if r:
                    lines.append(
                        f"| {phys} | {'eta 2%' if damped else 'none'} | {frac} | {r['k']} | "
                        f"{r['frequency_hz']:.1f} | {r['sep']:.3f} / {r['stick']:.3f} / "
                        f"{r['slip']:.3f} | {r['psi1']:.3f} | {r['psi2']:.3f} | "
                        f"{r['amp_rms_m'] * 1e6:.3f} | {r['wall_s']:.0f} |")
    # family
    lines += ["", "## The family: which k from which start", "",
              "| physics | damping | friction | seed | k over N (" + ", ".join(map(str, ns))
              + ") | f over N (Hz) |", "|---|---|---|---|---|---|"]
    for phys, damped, seed, filt in _series():
        rs = [res.get(case_key(phys, damped, n, seed, filt=filt)) for n in ns]
        if not any(rs):
            continue
        ks = ", ".join(f"{r['k']}{'+' if r['celerity_m_s'] > 0 else '-'}" if r else "."
                       for r in rs)
        fs = ", ".join(f"{r['frequency_hz']:.0f}" if r else "." for r in rs)
        lines.append(f"| {phys} | {'eta 2%' if damped else 'none'} | {filt} | {seed} | {ks} | "
                     f"{fs} |")
    # members reached on several meshes
    lines += ["", "## Members of the family reached on several meshes (beta2 = 1/2, dt = 0.9 "
              "dt_crit): does each converge?", "",
              "| physics | damping | friction | k | N: f (Hz), sep / stick / slip, RMS (um) "
              "[seeds] |", "|---|---|---|---|---|"]
    for phys, damped, filt in ((p, d, f) for p in ("fig3", "fig1") for d in (False, True)
                               for f in ("nodal", "1-2-1")):
        if True:
            members: dict = {}
            for r in res.values():
                if (r["phys"], r["damped"], r["beta2"], r["frac"], r.get("filter", "nodal")) \
                        != (phys, damped, 0.5, 0.9, filt):
                    continue
                members.setdefault((r["k"], r["celerity_m_s"] > 0), {}).setdefault(
                    r["n"], []).append(r)
            for (k, fwd), by_n in sorted(members.items()):
                if len(by_n) < 2:
                    continue
                cells = []
                for n in sorted(by_n):
                    rs = by_n[n]
                    r = rs[0]
                    cells.append(f"N = {n}: {r['frequency_hz']:.1f}, {r['sep']:.3f} / "
                                 f"{r['stick']:.3f} / {r['slip']:.3f}, "
                                 f"{r['amp_rms_m'] * 1e6:.0f} [{', '.join(x['seed'] for x in rs)}]")
                lines.append(f"| {phys} | {'eta 2%' if damped else 'none'} | {filt} | {k}"
                             f"{'+' if fwd else '-'} | " + "; ".join(cells) + " |")
    # beta2
    lines += ["", "## beta2 on the meshes it was run on (mode-4 seed)", "",
              "f_c = |c| k / (2 pi R), the frequency of the tracked phase; the relative "
              "differences are against beta2 = 1/2 on the same mesh (same member only).", "",
              "| physics | damping | N | beta2 | dt (us) | k | c (m/s) | f (Hz) | f_c (Hz) | "
              "sep / stick / slip | psi1 | psi2 | RMS (um) | rel. diff f_c / psi1 / psi2 / RMS "
              "| wall (s) |", "|" + "---|" * 15]
    for phys in ("fig3", "fig1"):
        for damped in (False, True):
            n_b = [n for n in ns if case_key(phys, damped, n, "mode4", beta2=0.6) in res
                   or case_key(phys, damped, n, "mode4", beta2=0.9) in res]
            for n, beta2 in ((n, b) for n in n_b for b in (0.5, 0.6, 0.9)):
                r = res.get(case_key(phys, damped, n, "mode4", beta2=beta2))
                r0 = res.get(case_key(phys, damped, n, "mode4"))
                if not r:
                    continue
                rel = "-"
                if beta2 != 0.5 and r0 and (r0["k"], r0["celerity_m_s"] > 0) == (
                        r["k"], r["celerity_m_s"] > 0):
                    rel = " / ".join(f"{r[q] / r0[q] - 1:+.2%}" for q in (
                        "wave_frequency_hz", "psi1", "psi2", "amp_rms_m"))
                lines.append(
                    f"| {phys} | {'eta 2%' if damped else 'none'} | {n} | {beta2} | "
                    f"{r['dt_s'] * 1e6:.3g} | {r['k']} | {r['celerity_m_s']:+.0f} | "
                    f"{r['frequency_hz']:.1f} | {r['wave_frequency_hz']:.2f} | {r['sep']:.3f} / "
                    f"{r['stick']:.3f} / {r['slip']:.3f} | {r['psi1']:.3f} | "
                    f"{r['psi2']:.3f} | {r['amp_rms_m'] * 1e6:.3f} | {rel} | "
                    f"{r['wall_s']:.0f} |")
    lines += ["", "## Power balance over the window (J/m/s; runs that recorded it)", "",
              "| run | mean E (J/m) | cylinder | friction | damping | normal contact (impacts) |",
              "|---|---|---|---|---|---|"]
    for key, r in sorted(res.items()):
        pw = r.get("power")
        if pw:
            lines.append(f"| {key} | {pw['mean_energy']:.4g} | {pw['cylinder']:.4g} | "
                         f"{pw['friction']:.4g} | {pw['damping']:.4g} | {pw['normal']:.4g} |")
    lines += accuracy_rows(res, ns)
    fig = REPO / "docs" / "figures" / ("convergence_quick.png" if quick else "convergence.png")
    plot(res, fig, ns)
    lines += ["", f"![convergence]({os.path.relpath(fig, out.parent)})", ""]
    marker = "<!-- discussion -->"
    old = out.read_text() if out.exists() else ""
    tail = old[old.index(marker):] if marker in old else f"{marker}\n"
    out.write_text("\n".join(lines) + "\n" + tail)


# ---------------------------------------------------------------------------------------------


def speed(n: int = 1056, steps: int = 3000) -> None:
    """CPU time of the N-node Figure-3 runs (undamped, eta = 2 %) on one core: setup plus
    ``steps`` steps measured with time.process_time, projected to the whole run."""
    from mpi4py import MPI

    from stickslip.solver.run import Simulation
    from stickslip.studies.convergence import scene_for

    for damped in (False, True):
        sc = scene_for(dict(phys="fig3", damped=damped, n=n, seed="mode4", beta2=0.5,
                            frac=0.9, key="speed"))
        c0 = time.process_time()
        sim = Simulation(sc, MPI.COMM_SELF)
        c1 = time.process_time()
        sim.proceed(max_steps=steps)
        per = (time.process_time() - c1) / steps
        total = sim.planned_steps()
        print(json.dumps(dict(n=n, damped=damped, kernel=sim.integrator.__class__.__name__,
                              setup_cpu_s=c1 - c0, cpu_per_step_ms=per * 1e3,
                              planned_steps=total,
                              projected_cpu_min=(c1 - c0 + per * total) / 60)), flush=True)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--results", type=Path, default=None)
    ap.add_argument("--out", type=Path, default=REPO / "archive" / "convergence_report.md")
    ap.add_argument("--report-only", action="store_true")
    ap.add_argument("--max-n", type=int, default=NS[-1])
    ap.add_argument("--only", default="", help="run only cases whose key contains this")
    ap.add_argument("--budget", type=float, default=math.inf,
                    help="stop starting new runs after this many seconds")
    ap.add_argument("--skip", action="append", default=[],
                    help="case key not to start (e.g. one still running elsewhere)")
    ap.add_argument("--speed", action="store_true",
                    help="CPU time of the N = 1056 rows on one core (projected from 3000 steps)")
    ap.add_argument("--case", default=None, help=argparse.SUPPRESS)  # child process
    args = ap.parse_args()
    results = args.results or (REPO / "archive" / ("convergence_runs_quick.jsonl" if args.quick
                                                 else "convergence_runs.jsonl"))
    if args.speed:
        speed()
        return 0
    if args.case:
        case = json.loads(args.case)
        r = run_case(case)
        with results.open("a") as fh:
            fh.write(json.dumps(r) + "\n")
        return 0
    t_start = time.perf_counter()
    if not args.report_only:
        for case in run_list(args.quick, args.max_n):
            if args.only and args.only not in case["key"]:
                continue
            if case["key"] in load_results(results) or case["key"] in args.skip:
                continue
            if time.perf_counter() - t_start > args.budget:
                print("budget spent; stopping", flush=True)
                break
            t0 = time.perf_counter()
            print(f"run {case['key']} ...", flush=True)
            proc = subprocess.run([sys.executable, __file__, "--results", str(results),
                                   "--case", json.dumps(case)], cwd=REPO,
                                  env={**os.environ, "OMP_NUM_THREADS": "1"})
            print(f"  exit {proc.returncode}, {time.perf_counter() - t0:.0f} s", flush=True)
            report(load_results(results), args.out, args.quick, results)
    report(load_results(results), args.out, args.quick, results)
    return 0


if __name__ == "__main__":
    sys.exit(main())
