"""P1 against P2 (HRZ-lumped) elements on the damped CEA: one resolved branch against the exact
damped continuum, per mesh and per dof (docs/convergence.md, "P2 elements").

``./dev nice python3 benchmarks/p2_ladder.py [--out FILE.jsonl]`` (the CEA ladder) and
``./dev nice python3 benchmarks/p2_ladder.py --travel 132:RUN132 --travel 264:RUN264
--travel 528:RUN528 [--out FILE.jsonl]`` (the celerity ladder of one rigid member).

Each check point is one branch of the linearised sliding problem (lowest branch of wavenumber
k travelling against the rotation), chosen before any P2 result was seen:

* ``figure1_n132_damped``, k = 8, fmax 1600 Hz (the P1 table of docs/flutter.md);
* ``figure3_n132_damped``, k = 12, fmax 2200 Hz (the damped Figure-3 member's k).

The linearised sliding problem depends on f, the damping and the geometry only, which the
two scenes share: the second point differs by its branch (k = 12, four times the growth).
The meshes: N contact nodes and N/22 radial layers for P1, N/44 for P2 (the same nodes, so
the same dofs at one N); P2 also with the consistent mass (``--mass consistent``), which
tells the lumping's share of the P2 error.

The exact branch is ``stickslip flutter-exact SCENE --n k --fmax-hz F --json`` (the growing
root against the rotation); each FE level is ``stickslip flutter-fe SCENE --fmax-hz F --set
mesh.degree=D --set mesh.n_inner=N --set mesh.n_radial=L --csv FILE`` (the lowest mode of
that k and direction). Prints one JSON line per level (degree, N, free dofs, frequency and
growth, their errors against the exact branch) and the observed orders of consecutive
levels, p = log2(e(N) / e(2N)).

``--travel N:RUN_DIR``: the damped Figure-1 k = 4 wave (RUN_DIR: ``stickslip run
scenes/figure1_n132_damped.toml --set mesh.n_inner=N --set mesh.n_radial=N/22``, which ends
on it) solved by the direct travelling-wave solver (``studies.travel.driver``: the
transient's own discrete wave, central in time, first-order contact law, free ω) on the same
meshes, P1 with S = 4 points per node and P2 with S = 8 per edge, so both have the step
h = Δφ/(4|ω|) of the node spacing Δφ = 2π/N. P1 starts from the run's probe history, P2 from
the P1 wave of the same N. One JSON line per level: celerity, amplitude, sub-node ψ₁,
residual, CPU; the observed order of the celerity from three consecutive levels,
p = log2(|c₁ − c₂| / |c₂ − c₃|).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path

#: (scene, k, fmax in Hz): the check points.
POINTS = (("figure1_n132_damped", 8, 1600.0), ("figure3_n132_damped", 12, 2200.0))
#: contact nodes per level; P2 puts N/2 curved edges on the circle.
LEVELS = (132, 264, 528, 1056)
#: contact nodes per radial element layer of P1 (about square cells, as the automatic rule);
#: P2 takes half as many layers, so P1 and P2 at one N have the same nodes and dofs.
NODES_PER_LAYER = 22
CLI = [sys.executable, "-m", "stickslip.cli.main"]


def exact_branch(scene: str, k: int, fmax: float) -> dict:
    """The exact damped continuum's growing branch of order k against the rotation."""
    out = subprocess.run(CLI + ["flutter-exact", scene, "--n", str(k), "--fmax-hz", str(fmax),
                                "--json"], check=True, capture_output=True, text=True).stdout
    branches = json.loads(out)["results"][0]["orders"][0]["branches"]
    opposite = [b for b in branches if b["direction"] == "opposite" and b["growth_rate"] > 0]
    best = min(opposite, key=lambda b: b["frequency_hz"])
    return {"frequency_hz": best["frequency_hz"], "growth_rate": best["growth_rate"]}


def fe_branch(scene: str, k: int, fmax: float, degree: int, n: int,
              mass: str = "lumped") -> dict:
    """The FE CEA's lowest mode of wavenumber k against the rotation (purity >= 0.5), on N
    contact nodes and N / (22 degree) radial layers."""
    layers = n // (NODES_PER_LAYER * degree)
    with tempfile.TemporaryDirectory() as tmp:
        table = Path(tmp) / "modes.csv"
        out = subprocess.run(CLI + ["flutter-fe", scene, "--fmax-hz", str(fmax), "--set",
                                    f"mesh.degree={degree}", "--set", f"mesh.n_inner={n}",
                                    "--set", f"mesh.n_radial={layers}", "--mass", mass,
                                    "--csv", str(table), "--json"],
                             check=True, capture_output=True, text=True).stdout
        rows = list(csv.DictReader(table.open()))
    dofs = json.loads(out)["free_dofs"]
    match = [r for r in rows if int(r["k"]) == k and r["direction"] == "opposite"
             and float(r["purity"]) >= 0.5]
    row = min(match, key=lambda r: float(r["frequency_hz"]))
    return {"n_radial": layers, "mass": mass, "free_dofs": dofs,
            "frequency_hz": float(row["frequency_hz"]),
            "growth_rate": float(row["re_lambda_per_s"])}


def travel_ladder(runs: dict[int, Path]) -> list[dict]:
    """The celerity ladder of ``--travel`` (module doc): per N, P1 from the run's probe
    history, then P2 from the P1 wave of the same N (``driver.prolong``). A wave prolonged
    from N/2 to N does not converge here (the celerity moves by 2 % at N = 264 and the
    separation zones with it), hence one run per N."""
    import numpy as np

    from stickslip.solver.scene import load_scene
    from stickslip.studies.travel import driver as D

    base = load_scene("scenes/figure1_n132_damped.toml", [])
    lines = []
    for n, run in sorted(runs.items()):
        wave = None
        for degree, samples in ((1, 4), (2, 8)):
            t0 = time.process_time()
            sc = base.with_overrides(f"mesh.n_inner={n}", f"mesh.degree={degree}",
                                     f"mesh.n_radial={n // (NODES_PER_LAYER * degree)}")
            st = D.setup(sc, float(sc.damping.tau), rate="bdf1", inertia="shift",
                         samples=samples, time_scheme="central")
            if wave is None:
                W0, om0, _ = D.start_from_run(run, st)
            else:
                W0, om0 = D.prolong(wave[0], st.prob.n), wave[1]
            sol = D.solve_free(st, 4, W0, om0)
            summary, _ = D.measure(st, sol, 4)
            wave = (np.r_[sol.W_r, sol.W_t], sol.omega)
            cel = [ln["celerity_m_s"] for ln in lines if ln["degree"] == degree]
            cel.append(sol.omega * sc.geometry.R)
            line = {"degree": degree, "n": n, "samples": samples, "dofs": st.ops.K.shape[0],
                    "h_s": st.ops.step(sol.omega), "celerity_m_s": cel[-1],
                    "amplitude_mm": summary["amplitude_m"] * 1e3,
                    "psi1": summary["psi1_subnode"], "residual": sol.residual,
                    "cpu_s": round(time.process_time() - t0, 1)}
            if len(cel) >= 3:
                line["order_celerity"] = order(cel[-3] - cel[-2], cel[-2] - cel[-1])
            lines.append(line)
            print(json.dumps(line), flush=True)
    return lines


def _run_level(text: str) -> tuple[int, Path]:
    n, _, run = text.partition(":")
    if not n.isdigit() or not (Path(run) / "samples.npz").is_file():
        raise argparse.ArgumentTypeError(f"--travel {text!r}: expected N:RUN_DIR, a finished "
                                         "`stickslip run` of N contact nodes")
    return int(n), Path(run)


def order(e1: float, e2: float) -> float:
    """Observed order between a level and the next (N doubled)."""
    return math.log2(abs(e1) / abs(e2)) if e1 and e2 else math.nan


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, help="also write the JSON lines here")
    ap.add_argument("--levels", default=",".join(map(str, LEVELS)),
                    help="contact nodes N, comma-separated, each doubling the last")
    ap.add_argument("--travel", type=_run_level, action="append", metavar="N:RUN_DIR",
                    help="the celerity ladder of the k = 4 wave instead, one run per N "
                    "(module doc; repeat)")
    args = ap.parse_args(argv)
    levels = [int(x) for x in args.levels.split(",")]
    if args.travel:
        lines = travel_ladder(dict(args.travel))
        if args.out:
            args.out.write_text("".join(json.dumps(x) + "\n" for x in lines))
        return 0
    lines = []
    for scene, k, fmax in POINTS:
        ref = exact_branch(scene, k, fmax)
        lines.append({"scene": scene, "k": k, "fmax_hz": fmax, "exact": ref})
        print(json.dumps(lines[-1]), flush=True)
        for degree, mass in ((1, "lumped"), (2, "lumped"), (2, "consistent")):
            errs = []
            for n in levels:
                fe = fe_branch(scene, k, fmax, degree, n, mass)
                ef = fe["frequency_hz"] - ref["frequency_hz"]
                eg = fe["growth_rate"] - ref["growth_rate"]
                line = {"scene": scene, "k": k, "degree": degree, "n": n, **fe,
                        "error_frequency_hz": ef, "error_growth_per_s": eg}
                if errs:
                    line["order_frequency"] = order(errs[-1][0], ef)
                    line["order_growth"] = order(errs[-1][1], eg)
                errs.append((ef, eg))
                lines.append(line)
                print(json.dumps(line), flush=True)
    if args.out:
        args.out.write_text("".join(json.dumps(x) + "\n" for x in lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
