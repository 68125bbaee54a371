"""Error against run time: explicit vs implicit Newmark, meshes N = 36...528.

One command regenerates the tables and the figure of archive/accuracy_undamped.md (and the
stability table of docs/stability.md)::

    ./dev python3 benchmarks/work_precision.py            # everything (~15 min, one core)
    ./dev python3 benchmarks/work_precision.py --smoke    # 2 points, < 60 s (CI)
    ./dev python3 benchmarks/work_precision.py --only accuracy|semianalytic|stability|lean

Each point is one in-process run of the Figure-3 physics (Omega = 50 rad/s, delta = 4e-4,
f = 0.7, nu = 0.3, xi = 1.25, mode-4 seed of 0.1 d) to ``T_END``; the wave is analysed over the
last ``WINDOW`` seconds (``postprocess.analysis.analyse``). Errors are taken against the reference
run (explicit, N = 528, dt = 0.45 dt_crit; its own convergence is estimated from its neighbours
N = 264 and dt = 0.9 dt_crit): relative for celerity, frequency and amplitude, absolute (max
over separation/stick/slip) for the zone fractions. Wall time = setup (mesh, assembly,
omega_max, steady state, K_eff factorisation and Schur complement) + time loop, one process.
Generated tables sit between ``<!-- BEGIN name -->`` / ``<!-- END name -->`` markers in the docs;
the prose around them is written by hand from these numbers.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

T_END = 0.06  # s: the wave settles after ~0.02-0.03 s at these parameters (docs/accuracy.md)
WINDOW = 0.03  # s analysed at the end
BASE = "scenes/figure3_n132.toml"
EXPLICIT = ("time.beta1=0", "time.beta2=0.6")
TRAPEZOIDAL = ("time.beta1=0.25", "time.beta2=0.5")
DISSIPATIVE = ("time.beta1=0.3025", "time.beta2=0.6")
SCHEMES = {"explicit b2=0.6": EXPLICIT, "implicit b1=1/4 b2=1/2": TRAPEZOIDAL,
           "implicit b1=0.3025 b2=0.6": DISSIPATIVE}
REFERENCE = ("explicit b2=0.6", 528, 0.45)
POINTS = [
    *[("explicit b2=0.6", n, 0.9) for n in (36, 66, 132, 264, 528)],
    *[("explicit b2=0.6", n, 0.45) for n in (132, 264)],
    *[("implicit b1=1/4 b2=1/2", n, fr) for n in (66, 132, 264) for fr in (1.0, 4.0)],
    *[("implicit b1=1/4 b2=1/2", 528, fr) for fr in (4.0, 16.0)],
    *[("implicit b1=0.3025 b2=0.6", n, 1.0) for n in (132, 264)],
]
QUANTITIES = ("celerity", "frequency", "fractions", "amplitude")
# Figure-1 parameters: the reduced model's admissible wave there (docs/semianalytic.md)
FIG1 = ("loading.omega=40", "geometry.delta=0.001")
FIG1_POINTS = [("explicit b2=0.6", n, 0.9) for n in (36, 132, 264)] + [
    ("implicit b1=1/4 b2=1/2", 132, 1.0)]


# ---------------------------------------------------------------------------------------------
# one run


def run_point(scheme: str, n: int, fraction: float, extra: tuple[str, ...] = (),
              t_end: float = T_END, window: float = WINDOW) -> dict:
    """One run; returns wave metrics over the last ``window`` s and timings."""
    from mpi4py import MPI

    from stickslip.postprocess.analysis import analyse
    from stickslip.solver.errors import Diverged
    from stickslip.solver.run import Simulation
    from stickslip.solver.scene import load_scene

    over = ["output.progress=false", f"time.end_time={t_end}", f"mesh.n_inner={n}",
            *SCHEMES[scheme], f"time.dt_fraction={fraction}", *extra]
    sc = load_scene(BASE, over)
    t0 = time.perf_counter()
    sim = Simulation(sc, MPI.COMM_SELF)
    # physics may exceed the run's guard
    guard = sim.columns.sampler.guard
    guard.initial[:], guard.bound[:] = 1.0, math.inf
    t1 = time.perf_counter()
    try:  # a non-finite energy ends the run "diverged"; a failed solve raises
        failed = sim.message if sim.proceed() == "diverged" else ""
    except Diverged as err:  # e.g. ContactSolveError: recorded, not hidden
        failed = str(err)
    if failed:
        return {"scheme": scheme, "N": n, "dt_fraction": fraction, "extra": list(extra),
                "dt_s": sim.dt, "steps": sim.integrator.step_count, "failed": failed,
                "wall_s": time.perf_counter() - t0, "finite": False}
    t2 = time.perf_counter()
    a = sim.recorder.arrays()
    sel = a["t"] >= a["t"][-1] - window
    g = sc.geometry
    w = analyse(a["t"][sel], a["theta"], a["u_r"][sel], a["u_theta"][sel], a["status"][sel],
                d=g.d, radius=g.R, window=window)
    out = {
        "scheme": scheme, "N": n, "dt_fraction": fraction, "extra": list(extra),
        "dt_s": sim.dt, "steps": sim.integrator.step_count, "dofs": sim.problem.n_global_dofs,
        "setup_s": t1 - t0, "loop_s": t2 - t1, "wall_s": t2 - t0,
        "contact_s": sim.integrator.facts()["contact_s"],
        "regime": w.regime, "mode": w.mode, "celerity": w.celerity_m_s,
        "frequency": w.frequency_hz, "fractions": w.fractions, "amplitude": w.amplitude_m,
        "finite": bool(np.all(np.isfinite(sim.integrator.u))),
    }
    if hasattr(sim.integrator, "iteration_stats"):
        out["implicit"] = sim.integrator.iteration_stats()
    return out


def errors(point: dict, ref: dict) -> dict[str, float]:
    """Relative errors (celerity, frequency, amplitude) and max absolute fraction error."""
    rel = {q: abs(point[q] - ref[q]) / max(abs(ref[q]), 1e-300)
           for q in ("celerity", "frequency", "amplitude")}
    rel["fractions"] = max(abs(point["fractions"][z] - ref["fractions"][z])
                           for z in ("separation", "stick", "slip"))
    return rel


def headline(err: dict[str, float]) -> float:
    """The accuracy a setting delivers: worst of celerity, frequency and zone fractions."""
    return max(err["celerity"], err["frequency"], err["fractions"])


# ---------------------------------------------------------------------------------------------
# cache of runs


class Cache:
    def __init__(self, path: Path, reuse: bool) -> None:
        self.path, self.reuse = path, reuse
        self.data = json.loads(path.read_text()) if reuse and path.exists() else {}

    def get(self, scheme: str, n: int, fraction: float, extra: tuple[str, ...] = (),
            **kw) -> dict:
        key = json.dumps([scheme, n, fraction, list(extra), kw])
        if key not in self.data:
            t0 = time.perf_counter()
            self.data[key] = run_point(scheme, n, fraction, extra, **kw)
            r = self.data[key]
            what = (f"FAILED {r['failed'][:80]}" if "failed" in r else
                    f"{r['regime']} k={r['mode']} c={r['celerity']:.0f}")
            print(f"  ran {scheme:26s} N={n:4d} dt={fraction:5.2f} dt_crit "
                  f"{time.perf_counter() - t0:6.1f} s  {what}", flush=True)
            self.path.write_text(json.dumps(self.data, indent=1))
        return self.data[key]


# ---------------------------------------------------------------------------------------------
# accuracy study


def accuracy(cache: Cache, figure: Path | None) -> str:
    ref = cache.get(*REFERENCE)
    rows = []
    failed = []
    for p in POINTS:
        pt = cache.get(*p)
        if "failed" in pt:
            failed.append(pt)
            continue
        rows.append((pt, errors(pt, ref)))
    # convergence of the reference: its neighbours in space and in time
    ref_h = cache.get("explicit b2=0.6", 264, 0.45)
    ref_t = cache.get("explicit b2=0.6", 528, 0.9)
    lines = [
        f"Reference: explicit beta2 = 0.6, N = 528, dt = 0.45 dt_crit = {ref['dt_s']:.3g} s, "
        f"{ref['steps']} steps, {ref['wall_s']:.0f} s: {ref['regime']}, mode {ref['mode']}, "
        f"{ref['celerity']:+.1f} m/s, {ref['frequency']:.1f} Hz, fractions "
        f"{_fr(ref)}, amplitude {ref['amplitude']:.3g} m.",
        "",
        "Its neighbours (an estimate of the reference's own error): "
        f"N = 264 at the same dt_fraction differs by {_errtxt(errors(ref_h, ref))}; "
        f"N = 528 at dt = 0.9 dt_crit differs by {_errtxt(errors(ref_t, ref))}.",
        "",
        "| scheme | N | dt/dt_crit | dt (s) | steps | wall (s) | contact (s) | AS it. | regime | k "
        "| celerity (m/s) | freq (Hz) | sep/stick/slip | err c | err f | err fr | err amp |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for pt, e in sorted(rows, key=lambda r: (r[0]["scheme"], r[0]["N"], r[0]["dt_fraction"])):
        its = pt.get("implicit", {})
        it_txt = (f"{its['active_set_iterations_mean']:.2f}/{its['active_set_iterations_max']}"
                  if its else "-")
        lines.append(
            f"| {pt['scheme']} | {pt['N']} | {pt['dt_fraction']:g} | {pt['dt_s']:.3g} | "
            f"{pt['steps']} | {pt['wall_s']:.1f} | {pt['contact_s']:.1f} | {it_txt} | "
            f"{pt['regime']} | {pt['mode']} | {pt['celerity']:+.0f} | {pt['frequency']:.0f} | "
            f"{_fr(pt)} | {_pct(e['celerity'])} | {_pct(e['frequency'])} | "
            f"{e['fractions']:.3f} | {_pct(e['amplitude'])} |")
    for pt in failed:
        lines.append(f"| {pt['scheme']} | {pt['N']} | {pt['dt_fraction']:g} | "
                     f"{pt['dt_s']:.3g} | {pt['steps']} | {pt['wall_s']:.1f} | | | FAILED: "
                     f"{pt['failed']} | | | | | | | | |")
    lines += ["", _orders(rows), "", _recommend(rows)]
    if figure is not None:
        _plot(rows, figure)
    return "\n".join(lines)


def _fr(p: dict) -> str:
    f = p["fractions"]
    return f"{f['separation']:.2f}/{f['stick']:.2f}/{f['slip']:.2f}"


def _pct(x: float) -> str:
    return f"{100 * x:.2g} %" if x < 10 else f"{x:.1f}x"


def _errtxt(e: dict) -> str:
    return (f"celerity {_pct(e['celerity'])}, frequency {_pct(e['frequency'])}, fractions "
            f"{e['fractions']:.3f}, amplitude {_pct(e['amplitude'])}")


def _orders(rows) -> str:
    """Observed orders between neighbouring points of the same wave (same mode)."""
    by = {(p["scheme"], p["N"], p["dt_fraction"]): (p, e) for p, e in rows}
    out = ["| observed order | pair | celerity | frequency | fractions |", "|---|---|---|---|---|"]

    def add(label: str, a, b, ratio: float) -> None:
        if a not in by or b not in by:
            return
        (pa, ea), (pb, eb) = by[a], by[b]
        if pa["mode"] != pb["mode"]:
            out.append(f"| {label} | {a[1]}/{a[2]:g} -> {b[1]}/{b[2]:g} | different modes "
                       f"({pa['mode']}, {pb['mode']}): not in the asymptotic range | | |")
            return
        cells = []
        for q in ("celerity", "frequency", "fractions"):
            if ea[q] > 0 and eb[q] > 0:
                cells.append(f"{math.log(ea[q] / eb[q]) / math.log(ratio):.2f}")
            else:
                cells.append("-")
        out.append(f"| {label} | {a[1]}/{a[2]:g} -> {b[1]}/{b[2]:g} | " + " | ".join(cells)
                   + " |")

    ex, im = "explicit b2=0.6", "implicit b1=1/4 b2=1/2"
    add("explicit, space (h/2, dt ~ h)", (ex, 132, 0.9), (ex, 264, 0.9), 2.0)
    add("explicit, space (h/2, dt ~ h)", (ex, 264, 0.9), (ex, 528, 0.9), 2.0)
    add("explicit, time (dt/2)", (ex, 264, 0.9), (ex, 264, 0.45), 2.0)
    add("implicit, time (dt/4)", (im, 264, 4.0), (im, 264, 1.0), 4.0)
    add("implicit, time (dt/4)", (im, 528, 16.0), (im, 528, 4.0), 4.0)
    return "\n".join(out)


def _recommend(rows) -> str:
    out = ["| target (worst of celerity, frequency, fractions) | cheapest setting measured | "
           "its error | wall (s) |", "|---|---|---|---|"]
    for target in (0.01, 0.05, 0.20):
        ok = [(p["wall_s"], p, e) for p, e in rows if headline(e) <= target]
        if ok:
            wall, p, e = min(ok, key=lambda r: r[0])
            out.append(f"| {100 * target:.0f} % | {p['scheme']}, N = {p['N']}, "
                       f"dt = {p['dt_fraction']:g} dt_crit | {_pct(headline(e))} | "
                       f"{wall:.1f} |")
        else:
            out.append(f"| {100 * target:.0f} % | none of the measured settings | | |")
    return "\n".join(out)


def _plot(rows, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(11, 8.5))
    styles = {"explicit b2=0.6": ("o", "C0"), "implicit b1=1/4 b2=1/2": ("s", "C3"),
              "implicit b1=0.3025 b2=0.6": ("^", "C2")}
    for ax, q in zip(axes.flat, QUANTITIES, strict=True):
        for scheme, (marker, color) in styles.items():
            pts = [(p["wall_s"], max(e[q], 1e-6), p) for p, e in rows if p["scheme"] == scheme]
            if not pts:
                continue
            ax.loglog([x for x, _, _ in pts], [y for _, y, _ in pts], marker, color=color,
                      label=scheme, ms=7, mfc="none" if "implicit" in scheme else color)
            for x, y, p in pts:
                ax.annotate(f"{p['N']}/{p['dt_fraction']:g}" + ("" if p["mode"] == 12 else
                                                                 f" k{p['mode']}"),
                            (x, y), fontsize=7, xytext=(3, 3), textcoords="offset points")
        for target in (0.01, 0.05, 0.2):
            ax.axhline(target, color="grey", lw=0.6, ls=":")
        ax.set_xlabel("wall time (s), one core")
        ax.set_ylabel("relative error" if q != "fractions" else "max |fraction error|")
        ax.set_title(q)
        ax.grid(True, which="both", alpha=0.3)
    axes[0, 0].legend(fontsize=8)
    fig.suptitle("Figure-3 physics, error against wall time (labels N/dt_fraction; "
                 "kX = a mode other than the reference's)", fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


# ---------------------------------------------------------------------------------------------
# against the semi-analytical wave


def semianalytic(cache: Cache) -> str:
    from stickslip.studies.verification import semianalytic_waves

    p = dict(nu=0.3, xi=1.25, f=0.7, delta=0.001, omega=40.0, R=1.0, wave_speed=1000.0)
    waves = [w for w in semianalytic_waves(p, 4) if w["admissible"]]
    lines = []
    if not waves:
        return "No admissible reduced-model wave at the Figure-1 parameters."
    w = waves[0]
    ref = {"celerity": w["celerity_m_s"], "frequency": w["frequency_hz"],
           "fractions": {"separation": 0.0, "stick": w["psi2"], "slip": 1.0 - w["psi2"]},
           "amplitude": w["amplitude_theta_m"]}
    lines += [
        f"Reduced model (Figure-1 parameters, k = 4): admissible {w['regime']} wave, "
        f"{w['celerity_m_s']:+.1f} m/s, {w['frequency_hz']:.1f} Hz, stick fraction "
        f"{w['psi2']:.4f}, tangential amplitude {w['amplitude_theta_m']:.3g} m.",
        "",
        "| scheme | N | dt/dt_crit | wall (s) | FE regime | k | celerity (m/s) | freq (Hz) | "
        "sep/stick/slip | err c | err f | err fr |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for scheme, n, fr in FIG1_POINTS:
        pt = cache.get(scheme, n, fr, FIG1)
        e = errors(pt, ref)
        lines.append(f"| {scheme} | {n} | {fr:g} | {pt['wall_s']:.1f} | {pt['regime']} | "
                     f"{pt['mode']} | {pt['celerity']:+.0f} | {pt['frequency']:.0f} | "
                     f"{_fr(pt)} | {_pct(e['celerity'])} | {_pct(e['frequency'])} | "
                     f"{e['fractions']:.3f} |")
    return "\n".join(lines)


# ---------------------------------------------------------------------------------------------
# stability survey (docs/stability.md)

STABILITY_CASES = {
    "nu = 0.45": ("material.nu=0.45",),
    "nu = 0.49": ("material.nu=0.49",),
    "Omega = 1000 rad/s, delta = 1e-3, f = 0.9 (Fig. 5)": (
        "loading.omega=1000", "geometry.delta=0.001", "loading.f=0.9"),
    "f = 0": ("loading.f=0",),
    "f = 2": ("loading.f=2",),
    "delta = 1e-7": ("geometry.delta=1e-7",),
    "xi = 1.05 (thin)": ("geometry.xi=1.05",),
    "xi = 3 (thick)": ("geometry.xi=3",),
    "beta2 = 0.5 (explicit: no damping)": ("time.beta2=0.5",),
}


def stability(cache: Cache) -> str:
    from stickslip.solver.scene import load_scene
    from stickslip.solver.schemes import shortest_wave_period

    lines = ["| case | scheme | N | T (s) | dt (s) | steps | wall (s) | AS it. | outcome | regime "
             "| k | celerity (m/s) | sep/stick/slip |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    runs = [(c, s, 36, 1.0 if "implicit" in s else 0.9, 0.1) for c in STABILITY_CASES
            for s in ("explicit b2=0.6", "implicit b1=1/4 b2=1/2")]
    runs += [("N = 528", s, 528, fr, 0.01) for s, fr in (("explicit b2=0.6", 0.9),
                                                          ("implicit b1=1/4 b2=1/2", 10.0))]
    runs += [("N = 1056", s, 1056, fr, 0.004) for s, fr in (("explicit b2=0.6", 0.9),
                                                             ("implicit b1=1/4 b2=1/2", 10.0))]
    for case, scheme, n, fr, t_end in runs:
        extra = STABILITY_CASES.get(case, ())
        if case.startswith("beta2") and "implicit" in scheme:
            continue  # the trapezoidal rule already has beta2 = 1/2
        if n >= 528:
            extra = ("mesh.n_radial=2",)
        pt = cache.get(scheme, n, fr, extra, t_end=t_end, window=t_end / 3)
        if case.startswith("beta2"):
            scheme = "explicit b2=0.5"
        its = pt.get("implicit", {})
        it_txt = (f"{its['active_set_iterations_mean']:.2f}/{its['active_set_iterations_max']}"
                  if its else "-")
        lines.append(
            f"| {case} | {scheme} | {n} | {t_end:g} | {pt['dt_s']:.3g} | {pt['steps']} | "
            f"{pt['wall_s']:.1f} | {it_txt} | {'finite' if pt['finite'] else 'NaN'} | "
            f"{pt['regime']} | {pt['mode']} | {pt['celerity']:+.0f} | {_fr(pt)} |")
    # the explicit step and the CLI advice per case
    adv = ["", "| case | T_h / dt_crit (explicit steps per shortest mesh wave) | CLI warning |",
           "|---|---|---|"]
    from mpi4py import MPI

    from stickslip.solver.problem import build_problem, omega_max
    from stickslip.solver.schemes import stability_advice

    for case, extra in STABILITY_CASES.items():
        sc = load_scene(BASE, ["mesh.n_inner=36", *extra])
        w = omega_max(build_problem(sc, MPI.COMM_SELF))
        dtc = math.sqrt(2.0 / sc.time.beta2) / w
        text = stability_advice(sc, 0.9 * dtc, dtc)
        adv.append(f"| {case} | {shortest_wave_period(sc) / dtc:.1f} | "
                   f"{'yes' if text else 'no'} |")
    return "\n".join(lines + adv)


def large_steps(cache: Cache) -> str:
    """Where the implicit scheme loses the wave: N = 36, 0.2 s, dt_fraction 0.5 ... 16."""
    from stickslip.solver.implicit import damping_per_period

    lines = ["| scheme | dt/dt_crit | dt (s) | steps/period | amplitude kept per period "
             "(linear) | wall (s) | regime | k | celerity (m/s) | freq (Hz) | sep/stick/slip |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for scheme, (b1, b2) in (("implicit b1=0.3025 b2=0.6", (0.3025, 0.6)),
                             ("implicit b1=1/4 b2=1/2", (0.25, 0.5))):
        for fr in (0.5, 1.0, 2.0, 4.0, 8.0, 16.0):
            pt = cache.get(scheme, 36, fr, (), t_end=0.2, window=0.066)
            period = 1.0 / 1500.0  # the mode-4 wave at dt -> 0 (~1500-1600 Hz)
            keep = damping_per_period(2 * math.pi * pt["dt_s"] / period, b1, b2)
            lines.append(
                f"| {scheme} | {fr:g} | {pt['dt_s']:.3g} | {period / pt['dt_s']:.1f} | "
                f"{keep:.3f} | {pt['wall_s']:.1f} | {pt['regime']} | {pt['mode']} | "
                f"{pt['celerity']:+.0f} | {pt['frequency']:.0f} | {_fr(pt)} |")
    return "\n".join(lines)


# ---------------------------------------------------------------------------------------------
# leaving out what a scene does not need (item 4)


def _in_subprocess(code: str) -> str:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                         cwd=ROOT, timeout=600)
    if res.returncode:
        raise RuntimeError(res.stderr[-2000:])
    return res.stdout.strip().splitlines()[-1]


def lean() -> str:
    rows = ["| what | measured | how |", "|---|---|---|"]
    # 1. friction work skipped at f = 0 (explicit projection, N = 528 contact nodes)
    rows.append(_in_subprocess(
        "import time, numpy as np\n"
        "from mpi4py import MPI\n"
        "from stickslip.solver.contact import ContactLaw, ContactProjection\n"
        "from stickslip.solver.problem import build_problem\n"
        "from stickslip.solver.scene import load_scene\n"
        "res = {}\n"
        "for f in (0.0, 0.7):\n"
        "    sc = load_scene('scenes/smoke.toml', ['mesh.n_inner=528', f'loading.f={f}'])\n"
        "    pb = build_problem(sc, MPI.COMM_SELF)\n"
        "    pr = ContactProjection(pb, ContactLaw.from_scene(sc, 1e-6))\n"
        "    u = np.random.default_rng(0).normal(size=pb.n_owned) * 1e-3\n"
        "    out = np.zeros_like(u)\n"
        "    best = 1e9\n"
        "    for _ in range(7):\n"
        "        t0 = time.perf_counter()\n"
        "        for _ in range(2000): pr(u, u, out)\n"
        "        best = min(best, (time.perf_counter() - t0) / 2000)\n"
        "    res[f] = best\n"
        "print(f'| f = 0 skips the friction work (explicit contact step, 528 nodes) | "
        "{res[0.0]*1e6:.1f} us (f = 0) vs {res[0.7]*1e6:.1f} us (f = 0.7) a step | "
        "ContactProjection call, best of 7 x 2000 |')\n"))
    rows.append(_in_subprocess(
        "import time\n"
        "from mpi4py import MPI\n"
        "from stickslip.solver.run import Simulation\n"
        "from stickslip.solver.scene import load_scene\n"
        "res = {}\n"
        "for f in (0.0, 0.7):\n"
        "    sc = load_scene('scenes/smoke.toml', ['mesh.n_inner=264', f'loading.f={f}',\n"
        "        'time.beta1=0.25', 'time.beta2=0.5', 'time.end_time=1e-4',\n"
        "        'output.progress=false'])\n"
        "    sim = Simulation(sc, MPI.COMM_SELF)\n"
        "    res[f] = (sim.integrator.factor_seconds, sim.columns.projection.solver.S.shape[0])\n"
        "print(f'| f = 0 halves the implicit Schur complement (264 nodes) | '\n"
        "      f'{res[0.0][1]}x{res[0.0][1]} in {res[0.0][0]:.2f} s vs '\n"
        "      f'{res[0.7][1]}x{res[0.7][1]} in {res[0.7][0]:.2f} s | K_eff factorisation + '\n"
        "      f'E^T K_eff^-1 E |')\n"))
    # 2. no output -> no I/O
    rows.append(_in_subprocess(
        "import io, tempfile\n"
        "from pathlib import Path\n"
        "from mpi4py import MPI\n"
        "from stickslip.studies.rundir import run_scene\n"
        "from stickslip.solver.scene import load_scene\n"
        "res = {}\n"
        "for fields in ('false', 'true'):\n"
        "    sc = load_scene('scenes/smoke.toml', [f'output.fields={fields}',\n"
        "        'output.progress=false', 'output.field_interval=1e-3'])\n"
        "    d = Path(tempfile.mkdtemp())\n"
        "    s = run_scene(sc, d / 'run', comm=MPI.COMM_SELF, stream=io.StringIO())\n"
        "    files = sorted(p.name for p in (d / 'run').iterdir())\n"
        "    res[fields] = (s['profile_s'].get('output', 0.0), len(files))\n"
        "print(f'| no field output, no field I/O | output phase {res[\"false\"][0]:.3f} s, '\n"
        "      f'{res[\"false\"][1]} files (fields = false) vs {res[\"true\"][0]:.3f} s, '\n"
        "      f'{res[\"true\"][1]} files (fields = true) | smoke scene, run_scene profile |')\n"))
    # 3. plotting libraries only when plotting
    rows.append(_in_subprocess(
        "import io, sys, tempfile\n"
        "from pathlib import Path\n"
        "from mpi4py import MPI\n"
        "from stickslip.studies.rundir import run_scene\n"
        "from stickslip.solver.scene import load_scene\n"
        "sc = load_scene('scenes/smoke.toml', ['output.progress=false', 'time.end_time=0.002'])\n"
        "run_scene(sc, Path(tempfile.mkdtemp()) / 'r', comm=MPI.COMM_SELF, "
        "stream=io.StringIO())\n"
        "mods = [m for m in ('pyvista', 'matplotlib', 'vtk') if m in sys.modules]\n"
        "print(f'| a run without --plot imports no plotting library | loaded: '\n"
        "      f'{mods or \"none\"} | sys.modules after run_scene |')\n"))
    # 4. the reduced model without dolfinx
    rows.append(_in_subprocess(
        "import sys, time\n"
        "t0 = time.perf_counter()\n"
        "from stickslip.semianalytic.coefficients import coefficients, gamma_from_physical\n"
        "from stickslip.semianalytic.waves import find_waves\n"
        "co = coefficients(0.3, 1.25, gamma_from_physical(1000.0, 1.0, 40.0))\n"
        "w = find_waves(co, 0.7, 4, 0.001)\n"
        "t = time.perf_counter() - t0\n"
        "heavy = [m for m in ('dolfinx', 'petsc4py', 'ufl', 'gmsh', 'mpi4py') "
        "if m in sys.modules]\n"
        "print(f'| the reduced model needs no dolfinx | {len(w)} waves in {t:.2f} s; '\n"
        "      f'FE stack loaded: {heavy or \"none\"} | find_waves at the Figure-1 point |')\n"))
    # 5. an unused diagnostic costs nothing: probes
    rows.append(_in_subprocess(
        "import time, math\n"
        "from mpi4py import MPI\n"
        "from stickslip.solver.run import Simulation\n"
        "from stickslip.solver.scene import load_scene\n"
        "res = {}\n"
        "for probes in ('[]', '[0.0, 90.0, 180.0, 270.0]'):\n"
        "    best = 1e9\n"
        "    for _ in range(3):\n"
        "        sc = load_scene('scenes/smoke.toml', [f'output.probes_deg={probes}',\n"
        "            'output.progress=false', 'time.end_time=0.1', 'mesh.n_inner=132',\n"
        "            'mesh.n_radial=0'])\n"
        "        sim = Simulation(sc, MPI.COMM_SELF)\n"
        "        t0 = time.perf_counter(); sim.proceed()\n"
        "        best = min(best, (time.perf_counter() - t0) / sim.integrator.step_count)\n"
        "    res[probes] = best\n"
        "a, b = res['[]'], res['[0.0, 90.0, 180.0, 270.0]']\n"
        "print(f'| an unused diagnostic costs nothing (probes) | {a*1e6:.1f} us/step without, '\n"
        "      f'{b*1e6:.1f} us/step with 4 probes | N = 132 time loop, best of 3 |')\n"))
    return "\n".join(rows)


# ---------------------------------------------------------------------------------------------
# docs


def replace_block(path: Path, name: str, text: str) -> None:
    """Put ``text`` between the BEGIN/END markers ``name`` of ``path`` (appended if absent)."""
    begin, end = f"<!-- BEGIN {name} -->", f"<!-- END {name} -->"
    doc = path.read_text() if path.exists() else ""
    block = f"{begin}\n{text}\n{end}"
    if begin in doc and end in doc:
        doc = doc[: doc.index(begin)] + block + doc[doc.index(end) + len(end):]
    else:
        doc = doc + ("\n" if doc else "") + block + "\n"
    path.write_text(doc)


def smoke(cache_path: Path | None = None) -> dict:
    """Two points (explicit and implicit, N = 36, 0.012 s) against an explicit run at half the
    step; returns {label: errors} (used by the CI test)."""
    cache = Cache(cache_path or Path(tempfile.mkdtemp()) / "smoke.json", reuse=False)
    kw = dict(t_end=0.012, window=0.006)
    ref = cache.get("explicit b2=0.6", 36, 0.45, (), **kw)
    out = {}
    for scheme, fr in (("explicit b2=0.6", 0.9), ("implicit b1=1/4 b2=1/2", 1.0)):
        pt = cache.get(scheme, 36, fr, (), **kw)
        out[scheme] = {"errors": errors(pt, ref), "wall_s": pt["wall_s"], "mode": pt["mode"],
                       "ref_mode": ref["mode"], "finite": pt["finite"]}
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--smoke", action="store_true", help="2 points, < 60 s (CI)")
    ap.add_argument("--only", choices=("accuracy", "semianalytic", "stability", "lean"))
    ap.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir())
                    / "stickslip_work_precision.json", help="JSON of finished runs")
    ap.add_argument("--reuse", action="store_true", help="reuse runs found in --cache")
    args = ap.parse_args(argv)
    if args.smoke:
        res = smoke()
        for label, r in res.items():
            e = r["errors"]
            print(f"{label:26s} wall {r['wall_s']:.1f} s mode {r['mode']} (ref {r['ref_mode']}) "
                  f"err c {e['celerity']:.3g} f {e['frequency']:.3g} fr {e['fractions']:.3g}")
        return 0
    cache = Cache(args.cache, args.reuse)
    docs = ROOT / "docs"
    parts = [args.only] if args.only else ["accuracy", "semianalytic", "stability", "lean"]
    undamped = ROOT / "archive" / "accuracy_undamped.md"  # the undamped study's record
    if "accuracy" in parts:
        replace_block(undamped, "work-precision",
                      accuracy(cache, docs / "figures" / "accuracy_work_precision.png"))
    if "semianalytic" in parts:
        replace_block(undamped, "semianalytic", semianalytic(cache))
    if "lean" in parts:
        replace_block(undamped, "lean", lean())
    if "stability" in parts:
        replace_block(docs / "stability.md", "stability-survey", stability(cache))
        replace_block(docs / "stability.md", "large-steps", large_steps(cache))
    print(f"runs cached in {args.cache}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
