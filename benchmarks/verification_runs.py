"""Regenerate the FE <-> semi-analytical verification: runs, table, figures.

Run (repository root): ``./dev python3 benchmarks/verification_runs.py`` — all stages; or
``--stage runs|table|figures``, ``--quick`` (skip N = 528), ``--force`` (re-run finished runs).

* runs: Figure-1 (Omega = 40 rad/s, delta = 0.001, f = 0.7), Figure-3 (50, 0.0004, 0.7) and
  Figure-2 (1, 0.0004, 0.3) cases, seeded in mode 4 and from a random seed, at N = 132, 264,
  528 contact nodes and beta2 = 0.6, 0.9, 0.3 s each; the scenes of Figures 4, 5 and 6
  (``scenes/figure{4,5,6}_*.toml``); into ``runs/verification/`` (git-ignored). Runs also
  record the nodal contact forces (for the P, Q panels of the Figure-1 style plot).
* table: ``stickslip compare`` of every run, the FE modal analysis of the tube, and the
  generated section of ``archive/verification_tables.md`` (between the GENERATED markers) plus
  ``runs/verification/table.json``.
* figures: ``docs/figures/fe_*.png`` (pyvista iso-value maps of u_r on two meshes, phase
  diagrams with the semi-analytical curves, Figure-1 style U, V, P, Q of the FE wave).

Finished runs are reused unless ``--force``; total ~15 min on one core (N = 528: ~40 s a run).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

OUT = ROOT / "runs" / "verification"
DOC = ROOT / "archive" / "verification_tables.md"
FIGS = ROOT / "docs" / "figures"

#: case name -> (scene file, paper figure)
CASES = {
    "figure1": ("scenes/figure1.toml", "Figure 1 (Ω = 40 rad/s, δ = 0.001, f = 0.7)"),
    "figure3": ("scenes/figure3_n132.toml", "Figure 3 (Ω = 50 rad/s, δ = 0.0004, f = 0.7)"),
    "figure2": ("scenes/figure2_n132.toml", "Figure 2 (Ω = 1 rad/s, δ = 0.0004, f = 0.3)"),
}
SEEDS = {
    "mode4": ["initial.perturbation=mode", "initial.mode=4"],
    "random": ["initial.perturbation=random", "initial.seed=1", "initial.n_modes=16"],
}
MESHES = (132, 264, 528)
BETAS = (0.6, 0.9)
FIGURE_SCENES = sorted(p.stem for p in (ROOT / "scenes").glob("figure[456]_*.toml"))


def run_name(case: str, seed: str, n: int, beta2: float) -> str:
    return f"{case}_{seed}_n{n}_b{int(round(beta2 * 10))}"


def matrix(quick: bool) -> list[tuple[str, str, list[str]]]:
    """(run name, scene file, overrides) of the verification matrix."""
    out = []
    for case, (scene, _) in CASES.items():
        for seed, sov in SEEDS.items():
            for n in MESHES:
                if quick and n > 264:
                    continue
                for b in BETAS:
                    ov = [*sov, f"mesh.n_inner={n}", f"time.beta2={b}", "time.end_time=0.3",
                          "output.progress=false"]
                    out.append((run_name(case, seed, n, b), scene, ov))
    for name in FIGURE_SCENES:
        out.append((name, f"scenes/{name}.toml", ["output.progress=false"]))
    return out


def stage_runs(quick: bool, force: bool, only: str | None) -> None:
    from mpi4py import MPI

    from stickslip.solver.scene import load_scene
    from stickslip.studies.rundir import run_scene

    OUT.mkdir(parents=True, exist_ok=True)
    todo = [r for r in matrix(quick) if only is None or r[0].startswith(only)]
    t_all = time.perf_counter()
    for i, (name, scene_file, ov) in enumerate(todo):
        run_dir = OUT / name
        summ = run_dir / "summary.json"
        if not force and summ.exists() and json.loads(summ.read_text()).get("status") in (
                "completed",):
            continue
        scene = load_scene(ROOT / scene_file, ov)
        t0 = time.perf_counter()
        with contextlib.redirect_stdout(io.StringIO()):
            s = run_scene(scene, run_dir, force=True, comm=MPI.COMM_SELF, stream=io.StringIO())
        print(f"[{i + 1}/{len(todo)}] {name}: {s.get('status')} {s.get('regime')} "
              f"k={s.get('mode')} c={s.get('celerity_m_s', 0):+.0f} m/s "
              f"({time.perf_counter() - t0:.1f} s)", flush=True)
    print(f"runs: {time.perf_counter() - t_all:.0f} s", flush=True)


# ---------------------------------------------------------------------------------------------
# Table


def stage_table(quick: bool) -> dict:
    from stickslip.solver.scene import load_scene
    from stickslip.studies.verification import (
        compare_run,
        fe_modes,
        free_flight_celerity,
        modal_table,
        radial_branch,
    )

    results: dict = {"runs": {}, "modal": {}}
    # free radial branch of the tube (geometry only: the same for every case), N = 264
    branch = radial_branch(load_scene(ROOT / "scenes/figure3_n132.toml", ["mesh.n_inner=264"]),
                           kmax=20)
    results["radial_branch_hz"] = {str(k): v for k, v in branch.items()}
    lin = fe_modes(load_scene(ROOT / "scenes/figure3_n132.toml", ["mesh.n_inner=264"]),
                   kmax=24, n_eig=240, conditions=("sliding", "flutter"))
    results["fe_linear_modes_n264"] = lin
    for name, _, _ in matrix(quick):
        if (OUT / name / "samples.npz").exists():
            res = compare_run(OUT / name, [4])
            fe = res["fe"]
            if fe["psi1"] > 0.05:
                fe["free_flight_m_s"] = free_flight_celerity(branch, fe["k"], fe["psi1"],
                                                             res["parameters"]["R"])
                fe["free_flight_reduced_m_s"] = free_flight_celerity(
                    None, fe["k"], fe["psi1"], res["parameters"]["R"],
                    reduced=res["parameters"])
            fe.update(nearest_linear_modes(lin, fe["k"], fe["frequency_hz"], res["parameters"]))
            results["runs"][name] = res
    for case, (scene_file, _) in CASES.items():
        for n in (132, 264):
            sc = load_scene(ROOT / scene_file, [f"mesh.n_inner={n}"])
            results["modal"][f"{case}_n{n}"] = modal_table(sc, [4, 8, 12])
    (OUT / "table.json").write_text(json.dumps(results, indent=2, default=_jd))
    write_doc_tables(results)
    return results


def nearest_linear_modes(lin: dict, k: int, freq: float, params: dict) -> dict:
    """The FE sliding mode (branch number, Hz) and the unstable FE flutter mode of wavenumber k
    whose frequency is closest to the wave's (flutter: f = 0.7 of the N = 264 modal run scaled
    to the case's f is NOT done: friction f enters the flutter matrix, so flutter is reported
    only for cases with the same f as the modal scene, f = 0.7)."""
    sl = sorted({round(m["frequency_hz"], 1) for m in lin["sliding"] if m["k"] == k})
    out: dict = {}
    if sl:
        j = int(np.argmin([abs(f - freq) for f in sl]))
        out["sliding_branch"] = j + 1
        out["sliding_hz"] = sl[j]
    fl = [m for m in lin["flutter"] if m["k"] == k and m["growth_rate_per_s"] > 1e-6]
    if fl and abs(params["f"] - 0.7) < 1e-12:
        m = min(fl, key=lambda m: abs(m["frequency_hz"] - freq))
        out["flutter_hz"] = m["frequency_hz"]
        out["flutter_growth_per_s"] = m["growth_rate_per_s"]
        out["flutter_phase_speed_m_s"] = m["phase_speed_m_s"]
    return out


def _jd(o):
    if isinstance(o, np.generic):
        return o.item()
    raise TypeError(type(o).__name__)


def _fmt(v, f: str) -> str:
    return "–" if v is None else f.format(v)


def write_doc_tables(results: dict) -> None:
    """Regenerate the tables between the GENERATED markers of archive/verification_tables.md."""
    lines: list[str] = []
    for case, (_, title) in CASES.items():
        lines += [f"#### {title}", "",
                  "| run | N | β2 | seed | regime | k | celerity (m/s) | f (Hz) | ψ1 | ψ2 "
                  "| zone order | max u_r−d (mm) | u_θ ½p-p (mm) | limit cycle "
                  "| free-flight \\|c\\| FE / reduced (m/s) | nearest FE sliding mode of k "
                  "(branch: Hz) |",
                  "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
        sa_rows: dict[str, dict] = {}
        for name, res in results["runs"].items():
            if not name.startswith(case + "_"):
                continue
            fe = res["fe"]
            lines.append(
                f"| {name} | {fe['n_inner']} | {fe['beta2']} | {fe['seed']} | {fe['regime']} "
                f"| {fe['k']} | {fe['celerity_m_s']:+.0f} | {fe['frequency_hz']:.0f} "
                f"| {fe['psi1']:.3f} | {fe['psi2']:.3f} | {fe['zone_order']} "
                f"| {1e3 * fe['amplitude_r_m']:.3f} | {1e3 * fe['amplitude_theta_m']:.3f} "
                f"| {fe['limit_cycle']} "
                f"| {_fmt(fe.get('free_flight_m_s'), '{:.0f}')} / "
                f"{_fmt(fe.get('free_flight_reduced_m_s'), '{:.0f}')} "
                f"| {fe.get('sliding_branch', '–')}: {_fmt(fe.get('sliding_hz'), '{:.0f}')} |")
            for w in res["semianalytic"]:
                key = f"{w['source']} k={w['k']} c={w['celerity_m_s']:+.0f}"
                sa_rows.setdefault(key, w)
        lines += ["", "Reduced model (semi-analytical) waves at the same parameters, for the FE "
                  "wavenumbers found above and k = 4:", "",
                  "| wave | k | celerity (m/s) | f (Hz) | ψ1 | ψ2 | max U−δ (mm) | V ½p-p (mm) "
                  "| admissible | first violated inequality |",
                  "|---|---|---|---|---|---|---|---|---|---|"]
        for w in sorted(sa_rows.values(), key=lambda w: (w["k"], not w["admissible"],
                                                          w["regime"], w["celerity_m_s"])):
            lines.append(
                f"| {w['source']} | {w['k']} | {w['celerity_m_s']:+.0f} "
                f"| {w['frequency_hz']:.0f} | {w['psi1']:.3f} | {w['psi2']:.3f} "
                f"| {1e3 * w['amplitude_r_m']:.3f} | {1e3 * w['amplitude_theta_m']:.3f} "
                f"| {'**yes**' if w['admissible'] else 'no'} | {w['violated'] or '–'} |")
        lines.append("")
    lines += ["#### Natural frequencies and flutter of mode k: FE tube against the reduced "
              "model", "",
              "| case | k | FE free tang. / rad. (Hz) | reduced free tang. / rad. (Hz) "
              "| FE sliding (Hz) | reduced sliding (Hz) | FE fastest flutter of k: Hz, "
              "1/s, m/s | reduced flutter: Hz, 1/s, m/s |",
              "|---|---|---|---|---|---|---|---|"]
    for key, tab in results["modal"].items():
        for k, r in tab.items():
            lines.append(
                f"| {key} | {k} | {_fmt(r.get('fe_free_tangential_hz'), '{:.0f}')} / "
                f"{_fmt(r.get('fe_free_radial_hz'), '{:.0f}')} "
                f"| {r['reduced_free_tangential_hz']:.0f} / {r['reduced_free_radial_hz']:.0f} "
                f"| {_fmt(r.get('fe_sliding_hz'), '{:.0f}')} | {r['reduced_sliding_hz']:.0f} "
                f"| {_fmt(r.get('fe_flutter_hz'), '{:.0f}')}, "
                f"{_fmt(r.get('fe_flutter_growth_per_s'), '{:.0f}')}, "
                f"{_fmt(r.get('fe_flutter_phase_speed_m_s'), '{:+.0f}')} "
                f"| {r['reduced_flutter_hz']:.0f}, {r['reduced_flutter_growth_per_s']:.0f}, "
                f"{r['reduced_flutter_phase_speed_m_s']:+.0f} |")
    begin, end = "<!-- BEGIN GENERATED TABLES -->", "<!-- END GENERATED TABLES -->"
    text = DOC.read_text() if DOC.exists() else f"{begin}\n{end}\n"
    a, b = text.index(begin) + len(begin), text.index(end)
    DOC.write_text(text[:a] + "\n" + "\n".join(lines) + "\n" + text[b:])


# ---------------------------------------------------------------------------------------------
# Figures


def stage_figures() -> None:
    from stickslip.solver import plotting

    made = plotting.verification_figures(OUT, FIGS)
    for p in made:
        print(f"figure: {p.relative_to(ROOT)}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--stage", choices=("runs", "table", "figures", "all"), default="all")
    ap.add_argument("--quick", action="store_true", help="skip the N = 528 runs")
    ap.add_argument("--force", action="store_true", help="re-run finished runs")
    ap.add_argument("--only", help="only runs whose name starts with this")
    args = ap.parse_args()
    if args.stage in ("runs", "all"):
        stage_runs(args.quick, args.force, args.only)
    if args.stage in ("table", "all"):
        stage_table(args.quick)
    if args.stage in ("figures", "all"):
        stage_figures()
    return 0


if __name__ == "__main__":
    sys.exit(main())
